//! Hostile input through the `luz` binary: every malformed scene, mesh and
//! texture gets one error line that names the file, the place in it (line
//! and column, or byte offset in binary data) and the field; exit status 2,
//! no panic, no output file. Declared element counts far beyond the data are
//! run under a 1 GiB address-space limit, so a reader that allocated for the
//! header's count before the data is there aborts instead of passing.

#[path = "../common/mod.rs"]
mod common;
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
         [[shapes]]\n{shape}\nmaterial = \"m\"\n"
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

#[test]
fn malformed_ply_files() {
    let dir = temp_dir("ply");
    let verts = triangle_vertices();
    let mut face = vec![3u8];
    for i in [0i32, 1, 7] {
        face.extend(i.to_le_bytes());
    }
    let out_of_range = [verts.clone(), face].concat();
    let cases = [
        with_file("ply-empty", "m.ply", b"".to_vec()).needle("end_header"),
        with_file(
            "ply-not-ply",
            "m.ply",
            b"solid cube\nfacet normal 0 0 1\n".to_vec(),
        )
        .needle("not a PLY file"),
        with_file(
            "ply-bad-keyword",
            "m.ply",
            PLY_HEADER.replace("element face 1", "elephant face 1"),
        )
        .needle("elephant"),
        with_file(
            "ply-bad-count",
            "m.ply",
            PLY_HEADER.replace("vertex 3", "vertex three"),
        )
        .needle("element `vertex`"),
        with_file(
            "ply-non-utf8-header",
            "m.ply",
            b"ply\nformat ascii 1.0\nelement vert\xffex 3\n".to_vec(),
        )
        .needle("not text"),
        with_file(
            "ply-ascii-truncated",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1"),
        )
        .needle("property `z`"),
        with_file(
            "ply-ascii-garbage",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 zero\n3 0 1 2\n"),
        )
        .needle("property `z`"),
        with_file(
            "ply-ascii-nan",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
        )
        .needle("vertex 1: coordinates must be finite"),
        with_file(
            "ply-ascii-index",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
        )
        .needle("vertex index 3 is out of range"),
        with_file(
            "ply-ascii-negative-index",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"),
        )
        .needle("vertex index -1 is out of range"),
        with_file(
            "ply-all-degenerate",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n"),
        )
        .needle("degenerate"),
        with_file(
            "ply-ascii-huge-counts",
            "m.ply",
            PLY_HEADER
                .replace("vertex 3", "vertex 4000000000")
                .replace("face 1", "face 4000000000")
                + "0 0 0\n",
        )
        .needle("file ends early"),
        with_file(
            "ply-binary-truncated",
            "m.ply",
            binary_ply("3", "1", "uchar", &verts[..20]),
        )
        .needle("vertex 1 of 3"),
        with_file(
            "ply-binary-index",
            "m.ply",
            binary_ply("3", "1", "uchar", &out_of_range),
        )
        .needle("vertex index 7 is out of range"),
        with_file(
            "ply-binary-huge-vertices",
            "m.ply",
            binary_ply("4000000000", "1", "uchar", b"0123456789"),
        )
        .needle("file ends early"),
        with_file(
            "ply-binary-huge-list",
            "m.ply",
            binary_ply(
                "3",
                "1",
                "uint",
                &[verts.clone(), 4_000_000_000u32.to_le_bytes().to_vec()].concat(),
            ),
        )
        .needle("face 0 of 1 is cut off"),
        with_file(
            "ply-binary-huge-faces",
            "m.ply",
            binary_ply("3", "4000000000", "uchar", &[verts, vec![3, 0]].concat()),
        )
        .needle("file ends early"),
    ];
    run_all(&dir, &cases);
}

#[test]
fn malformed_obj_files() {
    let dir = temp_dir("obj");
    let cases = [
        with_file("obj-empty", "m.obj", b"".to_vec()).needle("no faces"),
        with_file(
            "obj-garbage-number",
            "m.obj",
            b"v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
        )
        .needle("vertex coordinate 1"),
        with_file(
            "obj-inf",
            "m.obj",
            b"v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n".to_vec(),
        )
        .needle("must be finite"),
        with_file(
            "obj-index",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n".to_vec(),
        )
        .needle("vertex index `9` is out of range"),
        with_file(
            "obj-zero-index",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n".to_vec(),
        )
        .needle("vertex index `0` is out of range"),
        with_file(
            "obj-truncated-face",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2".to_vec(),
        )
        .needle("a face needs at least 3 vertices"),
        with_file(
            "obj-non-utf8",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\xff\n".to_vec(),
        )
        .needle("not UTF-8"),
    ];
    run_all(&dir, &cases);
}

#[test]
fn malformed_ppm_textures() {
    let dir = temp_dir("ppm");
    let cases = [
        with_file(
            "ppm-bad-magic",
            "texture.ppm",
            b"P9\n1 1\n255\n0 0 0\n".to_vec(),
        )
        .needle("magic number"),
        with_file(
            "ppm-maxval-0",
            "texture.ppm",
            b"P3\n1 1\n0\n0 0 0\n".to_vec(),
        )
        .needle("maxval"),
        with_file(
            "ppm-width-text",
            "texture.ppm",
            b"P3\nwide 1\n255\n".to_vec(),
        )
        .needle("width"),
        with_file(
            "ppm-p6-absurd-width",
            "texture.ppm",
            b"P6\n4000000000 1\n255\n\x01\x02\x03".to_vec(),
        )
        .needle("truncated"),
        with_file(
            "ppm-p6-absurd-size",
            "texture.ppm",
            b"P6\n4000000000 4000000000\n255\n\x01\x02\x03".to_vec(),
        )
        .needle("too large"),
        with_file(
            "ppm-p3-absurd-width",
            "texture.ppm",
            b"P3\n100000 100000\n255\n1 2 3\n".to_vec(),
        )
        .needle("unexpected end of file"),
        with_file(
            "ppm-p6-truncated",
            "texture.ppm",
            b"P6\n2 2\n255\n\x01\x02\x03\x04\x05".to_vec(),
        )
        .needle("pixel data"),
        with_file(
            "ppm-p6-over-maxval",
            "texture.ppm",
            b"P6\n1 1\n15\n\x01\x10\x03".to_vec(),
        )
        .needle("16 exceeds maxval 15"),
        with_file(
            "ppm-p3-negative",
            "texture.ppm",
            b"P3\n1 1\n255\n0 -1 0\n".to_vec(),
        )
        .needle("green"),
        with_file(
            "ppm-hdr-nan-max",
            "texture.ppm",
            b"P3\n#MAX=nan\n1 1\n255\n0 0 0\n".to_vec(),
        )
        .needle("MAX"),
    ];
    run_all(&dir, &cases);
}

/// `luz tonemap` reading a broken PPM: the same located error, nothing
/// written.
#[test]
fn tonemap_of_a_truncated_ppm_writes_nothing() {
    let dir = temp_dir("tonemap");
    let input = dir.join("in.ppm");
    std::fs::write(&input, b"P3\n2 1\n255\n1 2 3\n4").unwrap();
    let output = dir.join("out.png");
    let out = luz_limited(&["tonemap", input.to_str().unwrap(), output.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("in.ppm:5:2: pixel (1, 0) green"),
        "{stderr}"
    );
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
