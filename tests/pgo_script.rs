//! `scripts/build-pgo.sh` is not run here (two release builds and a
//! training run take minutes, and it needs rustup's llvm-tools): these
//! check what it relies on, which could otherwise go stale unnoticed until
//! someone runs it.

mod common;

use common::{luz, temp_dir};
use std::path::Path;
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn script() -> String {
    std::fs::read_to_string(root().join("scripts/build-pgo.sh")).expect("scripts/build-pgo.sh")
}

/// Each training scene is a scene file of `scenes/` that loads, so that a
/// renamed or broken scene is caught by `cargo test`, not by a user's PGO
/// build failing half-way; the bunny joins when the script finds the mesh
/// its scene names.
#[test]
fn training_scenes_are_scenes_of_this_repository() {
    let script = script();
    let line = script
        .lines()
        .find_map(|l| l.strip_prefix("scenes=("))
        .and_then(|l| l.strip_suffix(')'))
        .expect("a `scenes=(...)` line");
    let scenes: Vec<&str> = line.split_whitespace().collect();
    assert!(scenes.len() >= 5, "{scenes:?}");
    for scene in scenes {
        if let Err(e) = luz::scene::load(&root().join("scenes").join(format!("{scene}.toml"))) {
            panic!("{e}");
        }
    }
    let mesh = "\"$LUZ_ASSETS/stanford/bunny/bun_zipper.ply\"";
    assert!(script.contains(&format!("[ -f {mesh} ]")), "{mesh}");
    assert!(script.contains("scenes+=(bunny)"));
    let bunny =
        std::fs::read_to_string(root().join("scenes/bunny.toml")).expect("scenes/bunny.toml");
    assert!(bunny.contains(mesh), "{mesh}");
}

/// What the script reads from `luz info` and the options it renders with
/// are what luz has.
#[test]
fn the_script_reads_and_runs_luz_as_it_is() {
    let script = script();
    assert!(script.contains("grep -q '^backends:.*embree'"));
    let info = String::from_utf8_lossy(&luz(&["info"]).stdout).into_owned();
    let backends = info.lines().find(|l| l.starts_with("backends:"));
    assert!(backends.is_some_and(|l| l.contains("rust")), "{info}");

    let options = [
        "--resolution 96x96",
        "--spp 16 --quiet --checkpoint-every off -o",
    ];
    for o in options {
        assert!(
            script.contains(o),
            "the script's options changed from `{o}`: update this test"
        );
    }
    let dir = temp_dir("render");
    let image = dir.join("cornell-area.exr");
    let scene = root().join("scenes/cornell-area.toml");
    let out = luz(&[
        "render",
        scene.to_str().expect("a UTF-8 path"),
        "--backend",
        "rust",
        "--resolution",
        "8x8",
        "--spp",
        "1",
        "--quiet",
        "--checkpoint-every",
        "off",
        "-o",
        image.to_str().expect("a UTF-8 path"),
    ]);
    assert!(out.status.success() && image.is_file(), "{out:?}");
}

#[test]
fn the_script_parses() {
    let status = Command::new("bash")
        .arg("-n")
        .arg(root().join("scripts/build-pgo.sh"))
        .status()
        .expect("bash runs");
    assert!(status.success());
}
