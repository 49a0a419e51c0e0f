//! The `luz` binary end to end: bad input gets one located error, exit
//! status 2, no panic and no output file; good input renders.

mod common;

use common::{luz, temp_dir};

use std::path::Path;

const GOOD: &str = r#"[camera]
eye = [0, 0, 4]
target = [0, 0, 0]
resolution = [16, 12]
[render]
spp = 2
[materials.light]
emission = 1
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "light"
"#;

/// Writes `scene`, renders it, and checks the failure is located.
fn assert_rejected(dir: &Path, name: &str, scene: &str, line: usize, needle: &str) {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, scene).unwrap();
    let out_file = dir.join(format!("{name}.png"));
    let out = luz(&[
        "render",
        path.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
    assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    let location = format!("{}:{line}:", path.display());
    assert!(
        stderr.contains(&location),
        "{name}: expected {location} in {stderr}"
    );
    assert!(
        stderr.contains(needle),
        "{name}: expected {needle:?} in {stderr}"
    );
    assert_eq!(
        stderr.lines().count(),
        1,
        "{name}: one error line: {stderr}"
    );
    assert!(!out_file.exists(), "{name}: no output file may be written");
}

#[test]
fn scene_errors_are_located_exit_2_and_write_nothing() {
    let dir = temp_dir("errors");
    let cases: &[(&str, String, usize, &str)] = &[
        (
            "unknown-key",
            GOOD.replace("radius = 1", "radius = 1\nradios = 2"),
            13,
            "did you mean `radius`",
        ),
        (
            "wrong-type",
            GOOD.replace("spp = 2", "spp = \"many\""),
            6,
            "spp",
        ),
        (
            "nan",
            GOOD.replace("radius = 1", "radius = nan"),
            12,
            "radius",
        ),
        (
            "negative-radius",
            GOOD.replace("radius = 1", "radius = -1"),
            12,
            "radius",
        ),
        (
            "energy-gain",
            GOOD.replace("emission = 1", "kd = 0.7\nks = 0.5"),
            9,
            "kd + ks + kt",
        ),
        (
            "missing-file",
            GOOD.replace(
                "type = \"sphere\"",
                "type = \"mesh\"\nfile = \"absent.ply\"",
            )
            .replace("center = [0, 0, 0]\nradius = 1\n", ""),
            11,
            "absent.ply",
        ),
        (
            "undefined-material",
            GOOD.replace("material = \"light\"", "material = \"lite\""),
            13,
            "lite",
        ),
        ("bad-toml", GOOD.replace("[render]", "[render"), 5, ""),
    ];
    for (name, scene, line, needle) in cases {
        assert_rejected(&dir, name, scene, *line, needle);
    }
}

#[test]
fn missing_scene_and_non_utf8_scene_are_input_errors() {
    let dir = temp_dir("io");
    let out = luz(&["render", dir.join("nope.toml").to_str().unwrap(), "--quiet"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.toml"));

    let path = dir.join("binary.toml");
    std::fs::write(&path, b"[camera]\neye = [0, 0, 4]\xff\xfe\n").unwrap();
    let out = luz(&["render", path.to_str().unwrap(), "--quiet"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("UTF-8"));
}

#[test]
fn bad_arguments_exit_2() {
    let out = luz(&["render", "x.toml", "--resolution", "12by4"]);
    assert_eq!(out.status.code(), Some(2));
    let out = luz(&["render", "x.toml", "--backend", "optix"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn renders_every_format_and_compares() {
    let dir = temp_dir("render");
    let scene = dir.join("good.toml");
    std::fs::write(&scene, GOOD).unwrap();
    for ext in ["exr", "hdr", "ppm", "png"] {
        let out_file = dir.join(format!("good.{ext}"));
        let out = luz(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out_file.to_str().unwrap(),
            "--backend",
            "rust",
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{ext}: {stderr}");
        assert!(stderr.contains("Msamples/s"), "summary line: {stderr}");
        assert!(out_file.metadata().unwrap().len() > 0);
    }
    let exr = dir.join("good.exr");
    let out = luz(&[
        "compare",
        exr.to_str().unwrap(),
        exr.to_str().unwrap(),
        "--fail-above",
        "0",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("RMSE"));
    let png = dir.join("tonemapped.png");
    let out = luz(&[
        "tonemap",
        dir.join("good.ppm").to_str().unwrap(),
        png.to_str().unwrap(),
        "--tonemap",
        "reinhard",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(png.exists());
}

#[test]
fn info_lists_backends() {
    let out = luz(&["info"]);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("backends: rust"), "{stdout}");
}

#[test]
fn embree_backend_without_embree_says_what_to_install() {
    let info = String::from_utf8_lossy(&luz(&["info"]).stdout).into_owned();
    let dir = temp_dir("embree");
    let scene = dir.join("good.toml");
    std::fs::write(&scene, GOOD).unwrap();
    let out_file = dir.join("good.exr");
    let out = luz(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
        "--backend",
        "embree",
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if info.contains("backends: rust, embree") {
        assert!(out.status.success(), "{stderr}");
    } else {
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("apt-get install libembree-dev"), "{stderr}");
        assert!(!out_file.exists());
    }
}
