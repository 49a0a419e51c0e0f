//! Any bytes as a PPM file: an image of the declared size with finite
//! values, or an error naming the file, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.ppm");
    match luz::image::io::parse_ppm(data, path) {
        Ok(img) => {
            assert_eq!(img.pixels.len(), img.width as usize * img.height as usize);
            assert!(img.pixels.iter().all(|p| p.is_finite()));
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.ppm")),
    }
});
