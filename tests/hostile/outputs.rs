//! A user's files against `luz render`, `merge` and `tonemap` (issue 13,
//! classes 1, 5, 6 and 7): nothing that existed before a run is overwritten
//! or deleted by accident, every bad argument exits 2 naming its flag, and a
//! signal relayed twice is one signal.

use crate::common::{luz_command, temp_dir};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A small, quick scene with a texture file, in `dir`.
fn scene_in(dir: &Path) -> PathBuf {
    let texture = dir.join("tex.png");
    let pixels = image_bytes();
    std::fs::write(&texture, pixels).unwrap();
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        r#"
[camera]
eye = [0, 0, 3]
target = [0, 0, 0]
resolution = [8, 8]

[render]
spp = 4

[textures.tex]
file = "tex.png"

[materials.white]
kd = 0.8
texture = "tex"

[materials.light]
emission = 4

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "white"

[[shapes]]
type = "sphere"
center = [0, 3, 2]
radius = 0.5
material = "light"
"#,
    )
    .unwrap();
    scene
}

/// A 2×2 PNG.
fn image_bytes() -> Vec<u8> {
    let mut png = Vec::new();
    let img = image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]));
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    png
}

fn luz(args: &[&str]) -> Output {
    luz_command()
        .args(args)
        .output()
        .expect("the luz binary runs")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Asserts exit status 2 and a message containing every needle.
fn refused(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "no {needle:?} in: {stderr}");
    }
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_checkpoint_that_is_the_output_is_refused_and_the_output_kept() {
    let dir = temp_dir("ckpt-is-output");
    let scene = scene_in(&dir);
    let out = dir.join("out.exr");
    std::fs::write(&out, b"the user's image").unwrap();
    let dotted = dir.join(".").join("out.exr");
    let run = luz(&[
        "render",
        s(&scene),
        "-o",
        s(&out),
        "--checkpoint",
        s(&dotted),
        "--quiet",
    ]);
    refused(&run, &["out.exr", "would overwrite the output"]);
    assert_eq!(std::fs::read(&out).unwrap(), b"the user's image");
}

#[test]
fn a_file_at_the_checkpoint_path_is_never_deleted() {
    let dir = temp_dir("precious");
    let scene = scene_in(&dir);
    let precious = dir.join("precious.exr");
    std::fs::write(&precious, b"precious").unwrap();
    let new = dir.join("new.png");
    let run = luz(&[
        "render",
        s(&scene),
        "-o",
        s(&new),
        "--checkpoint",
        s(&precious),
        "--quiet",
    ]);
    refused(&run, &["precious.exr", "already exists"]);
    assert_eq!(std::fs::read(&precious).unwrap(), b"precious");
    assert!(!new.exists(), "rendered although refused");
    // The default checkpoint path too: a leftover is not taken over.
    let left = dir.join("new.checkpoint.exr");
    std::fs::write(&left, b"from another run").unwrap();
    let run = luz(&["render", s(&scene), "-o", s(&new), "--quiet"]);
    refused(&run, &["new.checkpoint.exr", "already exists"]);
    assert_eq!(std::fs::read(&left).unwrap(), b"from another run");
}

#[test]
fn an_output_that_is_an_input_is_refused_before_rendering() {
    let dir = temp_dir("output-is-input");
    let scene = scene_in(&dir);
    let texture = dir.join("tex.png");
    let original = std::fs::read(&texture).unwrap();
    // The texture, spelt another way, and through a hard link.
    let hard = dir.join("hard.png");
    std::fs::hard_link(&texture, &hard).unwrap();
    for out in [dir.join("sub/../tex.png"), hard] {
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let run = luz(&["render", s(&scene), "-o", s(&out), "--quiet"]);
        refused(&run, &["would overwrite a file the scene reads", "tex.png"]);
        assert_eq!(std::fs::read(&texture).unwrap(), original);
    }
    // The scene file itself, named as an output format.
    let scene_as_image = dir.join("scene.ppm");
    std::fs::copy(&scene, &scene_as_image).unwrap();
    let text = std::fs::read(&scene_as_image).unwrap();
    let run = luz(&[
        "render",
        s(&scene_as_image),
        "-o",
        s(&scene_as_image),
        "--quiet",
    ]);
    refused(&run, &["would overwrite the scene file"]);
    assert_eq!(std::fs::read(&scene_as_image).unwrap(), text);
}

#[test]
fn merge_and_tonemap_never_overwrite_their_inputs() {
    let dir = temp_dir("merge-input");
    let scene = scene_in(&dir);
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    for (part, range) in [(&a, "0..2"), (&b, "2..4")] {
        let run = luz(&[
            "render",
            s(&scene),
            "--samples",
            range,
            "-o",
            s(part),
            "--quiet",
        ]);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
    }
    let before = std::fs::read(&a).unwrap();
    let dotted = dir.join(".").join("a.exr");
    let run = luz(&["merge", s(&a), s(&b), "-o", s(&dotted), "--quiet"]);
    refused(&run, &["would overwrite a part to merge"]);
    assert_eq!(std::fs::read(&a).unwrap(), before);
    let run = luz(&["tonemap", s(&a), s(&dotted)]);
    refused(&run, &["would overwrite the input image"]);
    assert_eq!(std::fs::read(&a).unwrap(), before);
}

#[test]
fn outputs_that_cannot_be_written_are_refused_before_rendering() {
    let dir = temp_dir("unwritable");
    let scene = scene_in(&dir);
    let missing = dir.join("no-such-folder").join("out.png");
    let run = luz(&["render", s(&scene), "-o", s(&missing), "--quiet"]);
    refused(&run, &["no-such-folder", "does not exist"]);
    let folder = dir.join("folder.png");
    std::fs::create_dir(&folder).unwrap();
    let run = luz(&["render", s(&scene), "-o", s(&folder), "--quiet"]);
    refused(&run, &["folder.png", "is a folder"]);
    let run = luz(&[
        "render",
        s(&scene),
        "-o",
        s(&dir.join("ok.png")),
        "--checkpoint",
        s(&missing.with_extension("exr")),
        "--quiet",
    ]);
    refused(&run, &["the checkpoint", "does not exist"]);
    assert_eq!(files_in(&dir), ["folder.png", "s.toml", "tex.png"]);
}

/// A full disk while checkpointing, simulated by a file-size limit with
/// SIGXFSZ ignored (so writes fail with EFBIG, as they would with ENOSPC):
/// the checkpoint (72 bytes per pixel) does not fit, the PNG does. The
/// render warns and goes on, and its output is complete.
#[test]
fn a_checkpoint_that_cannot_be_written_warns_and_the_render_goes_on() {
    let dir = temp_dir("disk-full");
    let scene = scene_in(&dir);
    let out = dir.join("out.png");
    let run = Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 40 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_luz"))
        .args(["render", s(&scene), "--resolution", "64x64", "--spp", "64"])
        .args(["--checkpoint-every", "1ms", "-o", s(&out)])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: cannot write the checkpoint, rendering on"),
        "{stderr}"
    );
    assert!(stderr.contains("checkpoints failed"), "{stderr}");
    let image = luz::image::io::read(&out).unwrap();
    assert_eq!((image.width, image.height), (64, 64));
    // Nothing half-written is left: no checkpoint, no temporaries.
    assert_eq!(files_in(&dir), ["out.png", "s.toml", "tex.png"]);
}

#[test]
fn sample_ranges_beyond_the_spp_are_refused() {
    let dir = temp_dir("beyond-spp");
    let scene = scene_in(&dir);
    let out = dir.join("p.exr");
    let run = luz(&[
        "render",
        s(&scene),
        "--spp",
        "4",
        "--samples",
        "100..104",
        "-o",
        s(&out),
    ]);
    refused(&run, &["--samples 100..104", "4 samples per pixel"]);
    assert!(!out.exists());
}

#[test]
fn bad_arguments_exit_2_naming_their_flag() {
    let dir = temp_dir("bad-args");
    let scene = scene_in(&dir);
    let out = dir.join("out.png");
    let run = luz(&["render", s(&scene), "--threads", "100000", "-o", s(&out)]);
    refused(&run, &["--threads"]);
    let exr = dir.join("a.exr");
    let run = luz(&["render", s(&scene), "-o", s(&exr), "--quiet"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for gamma in ["0", "nan", "-1", "inf"] {
        let run = luz(&["tonemap", s(&exr), s(&out), &format!("--gamma={gamma}")]);
        refused(&run, &["--gamma"]);
    }
    let run = luz(&["tonemap", s(&exr), s(&out), "--exposure", "nan"]);
    refused(&run, &["--exposure"]);
    for flag in ["--fail-above", "--abs-tol", "--rel-tol"] {
        let run = luz(&["compare", s(&exr), s(&exr), flag, "nan"]);
        refused(&run, &[flag]);
    }
    assert!(!out.exists());
    let long = "9".repeat(100_000);
    let run = luz(&["render", s(&scene), "--resolution", &long, "-o", s(&out)]);
    refused(&run, &["--resolution"]);
    assert!(
        run.stderr.len() < 2_000,
        "{} bytes of error",
        run.stderr.len()
    );
}

/// GNU `timeout` sends its signal to luz and then to its whole process
/// group, so luz gets SIGTERM twice at once: that must count as one, and the
/// render must save what it has.
#[test]
fn sigterm_relayed_twice_by_timeout_still_saves_the_render() {
    if Command::new("timeout").arg("--version").output().is_err() {
        eprintln!("skipped: GNU timeout is not installed");
        return;
    }
    let dir = temp_dir("timeout");
    let scene = scene_in(&dir);
    for round in 0..3 {
        let out = dir.join(format!("out{round}.png"));
        let checkpoint = dir.join(format!("out{round}.checkpoint.exr"));
        let run = Command::new("timeout")
            .args(["--preserve-status", "-s", "TERM", "2"])
            .arg(env!("CARGO_BIN_EXE_luz"))
            .args([
                "render",
                s(&scene),
                "--spp",
                "1000000",
                "--resolution",
                "32x32",
            ])
            .args(["--checkpoint-every", "off", "--quiet", "-o", s(&out)])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(143), "round {round}: {stderr}");
        assert!(
            stderr.contains("interrupted by SIGTERM"),
            "round {round}: {stderr}"
        );
        assert!(stderr.contains("resume with:"), "round {round}: {stderr}");
        assert!(
            out.exists() && checkpoint.exists(),
            "round {round}: {stderr}"
        );
        let part = luz::distributed::part::read(&checkpoint).unwrap();
        assert!(part.film.samples > 0);
    }
}

/// A legal but huge request is rendered, and a log (not a terminal) gets a
/// progress line with the ETA within seconds, so nobody waits in the dark.
#[test]
fn a_huge_request_logs_its_eta() {
    if Command::new("timeout").arg("--version").output().is_err() {
        eprintln!("skipped: GNU timeout is not installed");
        return;
    }
    let dir = temp_dir("huge");
    let scene = scene_in(&dir);
    let out = dir.join("out.png");
    let run = Command::new("timeout")
        .args(["--preserve-status", "-s", "INT", "8"])
        .arg(env!("CARGO_BIN_EXE_luz"))
        .args([
            "render",
            s(&scene),
            "--spp",
            "4000000000",
            "--max-depth",
            "4000000000",
        ])
        .args(["--checkpoint-every", "off", "-o", s(&out)])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(130), "{stderr}");
    let line = stderr
        .lines()
        .find(|l| l.contains("% done after"))
        .unwrap_or_else(|| panic!("no progress line in: {stderr}"));
    assert!(line.contains("ETA"), "{line}");
}

/// A folder without write permission. Root writes there anyway, so the test
/// says it is skipped when the probe it makes itself succeeds.
#[test]
fn an_output_in_a_read_only_folder_is_refused_before_rendering() {
    use std::os::unix::fs::PermissionsExt;
    let dir = temp_dir("read-only");
    let scene = scene_in(&dir);
    let locked = dir.join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::write(locked.join("probe"), b"").is_ok() {
        eprintln!("skipped: this user writes into read-only folders (root)");
        return;
    }
    let out = locked.join("out.png");
    let run = luz(&["render", s(&scene), "-o", s(&out), "--quiet"]);
    refused(&run, &["locked", "does not take new files"]);
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// One resolution limit everywhere: what luz would refuse to merge, it
/// refuses to render, from the command line and from the scene file alike.
#[test]
fn a_resolution_merge_would_refuse_is_refused_before_rendering() {
    let dir = temp_dir("resolution-limit");
    let scene = scene_in(&dir);
    let out = dir.join("wide.exr");
    let run = luz(&[
        "render",
        s(&scene),
        "--resolution",
        "40000x2",
        "-o",
        s(&out),
    ]);
    refused(&run, &["--resolution", "40000x2", "1..=32768"]);
    let text = std::fs::read_to_string(&scene).unwrap();
    let wide = dir.join("wide.toml");
    std::fs::write(
        &wide,
        text.replace("resolution = [8, 8]", "resolution = [40000, 2]"),
    )
    .unwrap();
    let run = luz(&["render", s(&wide), "-o", s(&out)]);
    refused(&run, &["wide.toml:5", "resolution", "1..=32768"]);
    assert!(!out.exists());
}
