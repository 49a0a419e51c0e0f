//! `scripts/fetch-assets.sh --check`: the test assets in `$LUZ_ASSETS`
//! match the checksums the download script holds, and a corrupted file is
//! caught and named. Both skip, and say so, when the assets are missing.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn assets() -> PathBuf {
    std::env::var_os("LUZ_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets"))
}

fn check(assets: &Path, files: &[&str]) -> Output {
    Command::new(Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/fetch-assets.sh"))
        .arg("--check")
        .args(files)
        .env("LUZ_ASSETS", assets)
        .output()
        .expect("scripts/fetch-assets.sh runs")
}

fn text(output: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

#[test]
fn assets_match_the_fetch_script_checksums() {
    let dir = assets();
    if !dir.is_dir() {
        eprintln!("skipped: no test assets at {}", dir.display());
        return;
    }
    let output = check(&dir, &[]);
    let text = text(&output);
    assert!(output.status.success(), "--check failed:\n{text}");
    assert!(text.contains("present, verified: stanford/bunny/bun_zipper.ply"));
}

#[test]
fn a_flipped_byte_fails_the_check_naming_the_file() {
    let name = "cornell-box/CornellBox-Original.mtl";
    let source = assets().join(name);
    if !source.is_file() {
        eprintln!("skipped: no test asset {}", source.display());
        return;
    }
    let dir = std::env::temp_dir().join(format!("luz-assets-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let copy = dir.join(name);
    std::fs::create_dir_all(copy.parent().unwrap()).unwrap();
    let mut bytes = std::fs::read(&source).unwrap();

    // The intact copy passes, so the failure below is the flipped byte's.
    std::fs::write(&copy, &bytes).unwrap();
    let intact = check(&dir, &[name]);
    assert!(intact.status.success(), "{}", text(&intact));

    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x20;
    std::fs::write(&copy, &bytes).unwrap();
    let flipped = check(&dir, &[name]);
    let message = text(&flipped);
    assert_eq!(flipped.status.code(), Some(1), "{message}");
    assert!(
        message.contains(&format!("checksum mismatch: {name}")),
        "{message}"
    );

    // A file that is not there at all fails too, and is named.
    std::fs::remove_file(&copy).unwrap();
    let missing = check(&dir, &[name]);
    let message = text(&missing);
    assert_eq!(missing.status.code(), Some(1), "{message}");
    assert!(message.contains(&format!("missing: {name}")), "{message}");
    std::fs::remove_dir_all(&dir).unwrap();
}
