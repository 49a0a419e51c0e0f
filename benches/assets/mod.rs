//! Where the benchmarks find the test meshes.

use std::path::{Path, PathBuf};

/// `$LUZ_ASSETS`, by default `../shared/assets` beside the crate.
pub fn assets() -> PathBuf {
    std::env::var_os("LUZ_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets"))
}
