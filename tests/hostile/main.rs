//! Hostile input through the `luz` binary: every malformed scene, mesh and
//! texture gets one error line that names the file, the place in it (line
//! and column, or byte offset in binary data) and the field; exit status 2,
//! no panic, no output file. Declared element counts far beyond the data are
//! run under a 1 GiB address-space limit, so a reader that allocated for the
//! header's count before the data is there aborts instead of passing.

#[path = "../common/mod.rs"]
mod common;
mod files;
mod job;
mod outputs;
mod parts;
mod scenes;

use common::temp_dir;

use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Command, Output};

/// Runs `luz ARGS` with its address space limited to 1 GiB.
fn luz_limited(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1048576 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_luz"))
        .args(args)
        .output()
        .expect("the luz binary runs")
}

/// A scene with one shape: a mesh file when `mesh` is given (else a sphere),
/// textured with `texture.ppm` when `texture` is set.
/// A light, so that the test scenes earn no warning for rendering black.
const LIGHT: &str = "[[lights]]\ntype = \"point\"\nposition = [0, 0, 4]\nintensity = 1\n";

fn scene(mesh: Option<&str>, texture: bool) -> String {
    let shape = match mesh {
        Some(file) => format!("type = \"mesh\"\nfile = \"{file}\""),
        None => "type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1".into(),
    };
    let (tex_table, tex_ref) = if texture {
        (
            "[textures.t]\nfile = \"texture.ppm\"\n",
            "texture = \"t\"\n",
        )
    } else {
        ("", "")
    };
    format!(
        "[camera]\neye = [0, 0, 4]\ntarget = [0, 0, 0]\nresolution = [8, 8]\n\
         [render]\nspp = 1\n{tex_table}[materials.m]\nkd = 0.5\n{tex_ref}\
         [[shapes]]\n{shape}\nmaterial = \"m\"\n{LIGHT}"
    )
}

/// `s` after its leading digits, if it starts with one.
fn digits(s: &str) -> Option<&str> {
    let n = s.bytes().take_while(u8::is_ascii_digit).count();
    (n > 0).then(|| &s[n..])
}

/// Whether `stderr` holds `file` followed by a place: `:LINE:COL:` or
/// `: byte N:`.
fn located(stderr: &str, file: &str) -> bool {
    stderr.match_indices(file).any(|(i, _)| {
        let rest = &stderr[i + file.len()..];
        let line_col = rest
            .strip_prefix(':')
            .and_then(digits)
            .and_then(|r| r.strip_prefix(':'))
            .and_then(digits)
            .is_some_and(|r| r.starts_with(':'));
        let byte = rest
            .strip_prefix(": byte ")
            .and_then(digits)
            .is_some_and(|r| r.starts_with(':'));
        line_col || byte
    })
}

struct Case {
    name: &'static str,
    scene: String,
    /// Extra files next to the scene: (name, contents).
    files: Vec<(&'static str, Vec<u8>)>,
    /// The file the error must locate.
    culprit: &'static str,
    /// Text naming the field or problem.
    needle: &'static str,
}

fn case(name: &'static str, scene: String, culprit: &'static str, needle: &'static str) -> Case {
    Case {
        name,
        scene,
        files: Vec::new(),
        culprit,
        needle,
    }
}

fn with_file(name: &'static str, file: &'static str, data: impl Into<Vec<u8>>) -> Case {
    let (mesh, texture) = if file.ends_with(".ppm") {
        (None, true)
    } else {
        (Some(file), false)
    };
    Case {
        name,
        scene: scene(mesh, texture),
        files: vec![(file, data.into())],
        culprit: file,
        needle: "",
    }
}

impl Case {
    fn needle(mut self, needle: &'static str) -> Self {
        self.needle = needle;
        self
    }
}

/// Renders the case and checks the failure; returns the error line.
fn check(dir: &Path, c: &Case) -> Result<String, String> {
    let sub = dir.join(c.name);
    std::fs::create_dir_all(&sub).unwrap();
    let scene_path = sub.join("scene.toml");
    std::fs::write(&scene_path, &c.scene).unwrap();
    for (name, data) in &c.files {
        std::fs::write(sub.join(name), data).unwrap();
    }
    let out_file = sub.join("out.png");
    let out = luz_limited(&[
        "render",
        scene_path.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let mut problems = Vec::new();
    if out.status.code() != Some(2) {
        problems.push(format!("exit status {:?}", out.status));
    }
    if stderr.contains("panicked") {
        problems.push("panic".into());
    }
    if stderr.lines().count() != 1 {
        problems.push("not exactly one line".into());
    }
    if !located(&stderr, c.culprit) {
        problems.push(format!("no location in {}", c.culprit));
    }
    if !stderr.contains(c.needle) {
        problems.push(format!("no {:?}", c.needle));
    }
    if out_file.exists() {
        problems.push("an output file was written".into());
    }
    if problems.is_empty() {
        Ok(stderr.trim_end().to_string())
    } else {
        Err(format!("{}: {}: {stderr}", c.name, problems.join(", ")))
    }
}

fn run_all(dir: &Path, cases: &[Case]) {
    let mut failures = Vec::new();
    for c in cases {
        match check(dir, c) {
            Ok(line) => eprintln!("{:<28} {line}", c.name),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

const PLY_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
                          property float y\nproperty float z\nelement face 1\n\
                          property list uchar int vertex_indices\nend_header\n";

fn binary_ply(vertices: &str, faces: &str, list: &str, body: &[u8]) -> Vec<u8> {
    let mut data = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {vertices}\nproperty float x\n\
         property float y\nproperty float z\nelement face {faces}\n\
         property list {list} int vertex_indices\nend_header\n"
    )
    .into_bytes();
    data.extend_from_slice(body);
    data
}

/// Three vertices (0,0,0), (1,0,0), (0,1,0) as little-endian f32.
fn triangle_vertices() -> Vec<u8> {
    [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

#[test]
fn malformed_scenes() {
    let dir = temp_dir("scenes");
    let good = scene(None, false);
    let cases = [
        case(
            "unclosed-table",
            good.replace("[render]", "[render"),
            "scene.toml",
            "",
        ),
        case(
            "unknown-key",
            good.replace("radius = 1", "radus = 1"),
            "scene.toml",
            "did you mean `radius`",
        ),
        case(
            "unknown-section",
            good.replace("[render]", "[rendr]"),
            "scene.toml",
            "did you mean `render`",
        ),
        case(
            "wrong-type",
            good.replace("spp = 1", "spp = \"many\""),
            "scene.toml",
            "spp",
        ),
        case(
            "negative-spp",
            good.replace("spp = 1", "spp = -4"),
            "scene.toml",
            "spp",
        ),
        case(
            "nan-radius",
            good.replace("radius = 1", "radius = nan"),
            "scene.toml",
            "radius",
        ),
        case(
            "inf-center",
            good.replace("center = [0, 0, 0]", "center = [0, inf, 0]"),
            "scene.toml",
            "center",
        ),
        case(
            "negative-radius",
            good.replace("radius = 1", "radius = -1"),
            "scene.toml",
            "radius",
        ),
        case(
            "negative-albedo",
            good.replace("kd = 0.5", "kd = [0.5, -0.1, 0.5]"),
            "scene.toml",
            "kd",
        ),
        case(
            "nan-intensity",
            format!("{good}[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = nan\n"),
            "scene.toml",
            "intensity",
        ),
        case(
            "undefined-material",
            good.replace("material = \"m\"", "material = \"n\""),
            "scene.toml",
            "no material named `n`",
        ),
        case(
            "missing-mesh",
            scene(Some("absent.ply"), false),
            "scene.toml",
            "absent.ply",
        ),
        case(
            "missing-texture",
            scene(None, true),
            "scene.toml",
            "texture.ppm",
        ),
        case("empty-scene", String::new(), "scene.toml", "camera"),
        case(
            "zero-resolution",
            good.replace("resolution = [8, 8]", "resolution = [0, 8]"),
            "scene.toml",
            "resolution",
        ),
    ];
    run_all(&dir, &cases);
}

#[test]
fn non_utf8_scene_is_located() {
    let dir = temp_dir("utf8");
    let text = scene(None, false).replace("kd = 0.5", "kd = 0.5 # \u{0}");
    let mut bytes = text.into_bytes();
    let at = bytes.iter().position(|&b| b == 0).unwrap();
    bytes[at] = 0xff;
    let path = dir.join("scene.toml");
    std::fs::write(&path, &bytes).unwrap();
    let out = luz_limited(&["render", path.to_str().unwrap(), "--quiet"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("scene.toml:8:12: the file is not UTF-8"),
        "{stderr}"
    );
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

#[test]
fn missing_scene_names_the_file() {
    let dir = temp_dir("missing");
    let path = dir.join("nowhere.toml");
    let out = luz_limited(&["render", path.to_str().unwrap(), "--quiet"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("nowhere.toml"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

#[test]
fn a_film_too_large_for_memory_is_refused_with_its_size() {
    // 16384² pixels need 12.9 GB of sums; under the 1 GiB limit the
    // allocation fails, which must end in a message, not an abort.
    let dir = temp_dir("huge-film");
    let path = dir.join("scene.toml");
    let text = scene(None, false).replace("resolution = [8, 8]", "resolution = [16384, 16384]");
    std::fs::write(&path, text).unwrap();
    let output = dir.join("out.exr");
    let out = luz_limited(&[
        "render",
        path.to_str().unwrap(),
        "--quiet",
        "-o",
        output.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("scene.toml: resolution: a 16384x16384 film needs 12.9 GB"),
        "{stderr}"
    );
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(!output.exists());
}

/// A render killed while its image is being written leaves the previous
/// file under the final name untouched: the data goes to a hidden temporary
/// that is renamed only once complete. The render is a 2048×2048 EXR (50 MB
/// to write); the test kills luz as soon as the temporary appears, and tries
/// again if a render finished before it could (a heavily loaded machine).
#[test]
fn killed_while_writing_leaves_the_old_image() {
    let dir = temp_dir("killed");
    let scene_path = dir.join("big.toml");
    std::fs::write(
        &scene_path,
        scene(None, false).replace("resolution = [8, 8]", "resolution = [2048, 2048]"),
    )
    .unwrap();
    let out_file = dir.join("out.exr");
    let temporaries = || -> Vec<String> {
        std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".out.exr.luz-tmp-"))
            .collect()
    };
    for attempt in 1..=3 {
        std::fs::write(&out_file, b"the previous image").unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_luz"))
            .args(["render", scene_path.to_str().unwrap(), "--backend", "rust"])
            .args(["--quiet", "-o", out_file.to_str().unwrap()])
            .spawn()
            .expect("the luz binary runs");
        let caught = loop {
            if !temporaries().is_empty() {
                child.kill().unwrap();
                // It may have renamed the file or exited in between.
                let killed = child.wait().unwrap().signal() == Some(9);
                break killed && !temporaries().is_empty();
            }
            if let Some(status) = child.try_wait().unwrap() {
                assert!(status.success(), "attempt {attempt}: {status}");
                break false;
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
        };
        if caught {
            assert_eq!(std::fs::read(&out_file).unwrap(), b"the previous image");
            assert_eq!(
                temporaries().len(),
                1,
                "the hidden temporary is all that is left"
            );
            return;
        }
        eprintln!("attempt {attempt}: the render finished before it could be killed");
    }
    panic!("three renders finished before the test could kill one while writing");
}
