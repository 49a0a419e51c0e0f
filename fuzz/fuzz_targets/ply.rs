//! Any bytes as a .ply file: a mesh whose indices are all in range, or an
//! error naming the file, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.ply");
    match luz::scene::mesh_io::parse_mesh(data, path) {
        Ok(mesh) => {
            let n = mesh.positions.len();
            assert!(mesh.indices.iter().flatten().all(|&i| (i as usize) < n));
            assert!(mesh.positions.iter().all(|p| p.is_finite()));
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.ply")),
    }
});
