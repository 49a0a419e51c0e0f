//! Any bytes as a scene file: a scene or an error naming the file, never a
//! panic. Relative mesh and texture names resolve in a folder that does not
//! exist, so the loader never reads files the input names.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("/nonexistent/luz-fuzz/scene.toml");
    if let Err(e) = luz::scene::load_bytes(data, path) {
        assert!(e
            .to_string()
            .starts_with("/nonexistent/luz-fuzz/scene.toml"));
    }
});
