//! Helpers shared by the integration tests. Each test file is a crate of
//! its own that uses only some of them, hence `allow(dead_code)`.
#![allow(dead_code)]

pub mod meshes;

use std::path::PathBuf;
use std::process::{Command, Output};

/// A command running the `luz` binary, without the batch system's task
/// variables a test must not pick up from the machine it runs on.
pub fn luz_command() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_luz"));
    for var in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_COUNT",
        "JOB_COMPLETION_INDEX",
    ] {
        cmd.env_remove(var);
    }
    cmd
}

/// Runs the `luz` binary with `args` and waits for it.
pub fn luz(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_luz"))
        .args(args)
        .output()
        .expect("the luz binary runs")
}

/// A fresh, empty directory for test `name` of this test crate.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "luz-{}-{}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Whether Embree is compiled in. Without it the Embree half of a test is
/// skipped, and says so, unless `LUZ_REQUIRE_EMBREE` is set: then a
/// missing Embree fails the test instead of silently testing less.
pub fn embree_compiled() -> bool {
    if luz::accel::compiled_backends().contains(&"embree") {
        return true;
    }
    assert!(
        std::env::var_os("LUZ_REQUIRE_EMBREE").is_none(),
        "LUZ_REQUIRE_EMBREE is set but Embree is not compiled in"
    );
    eprintln!("skipped: Embree is not compiled into this build");
    false
}
