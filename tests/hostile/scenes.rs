//! Issue 13, scenes and meshes: derived values are validated (not only what
//! was typed), tables are tables, mesh files that contradict themselves are
//! errors with their place, unused mesh data earns one warning, and every
//! resource (inflated size, file kind, echoed text) is bounded.

use super::*;

use std::io::Write;

/// The minimal good scene of these tests: camera, one material `m`, no
/// shapes (each case adds its own).
const HEAD: &str = "[camera]\neye = [0, 0, 4]\ntarget = [0, 0, 0]\nresolution = [8, 8]\n\
                    [render]\nspp = 1\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 4]\n\
                    intensity = 1\n[materials.m]\nkd = 0.5\n";

/// One triangle as an ascii PLY.
fn tri_ply() -> String {
    format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
}

fn scene_case(name: &'static str, body: &str, needle: &'static str) -> Case {
    case(name, format!("{HEAD}{body}"), "scene.toml", needle)
}

/// A case with top-level keys before the tables of [`HEAD`].
fn top_case(name: &'static str, top: &str, needle: &'static str) -> Case {
    case(name, format!("{top}{HEAD}"), "scene.toml", needle)
}

fn mesh_scene_case(name: &'static str, shape_extra: &str, needle: &'static str) -> Case {
    let mut c = scene_case(
        name,
        &format!(
            "[[shapes]]\ntype = \"mesh\"\nfile = \"tri.ply\"\nmaterial = \"m\"\n{shape_extra}"
        ),
        needle,
    );
    c.files.push(("tri.ply", tri_ply().into_bytes()));
    c
}

#[test]
fn derived_values_are_validated() {
    let dir = temp_dir("derived");
    let sphere = "[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\n";
    let cases = [
        mesh_scene_case("mesh-scale-1e38", "scale = 1e38\n", "`scale`"),
        mesh_scene_case("mesh-scale-1e20", "scale = 1e20\n", "`scale`"),
        mesh_scene_case(
            "mesh-translate-far",
            "translate = [3e38, 0, 0]\n",
            "`translate`",
        ),
        case(
            "eye-3e38",
            HEAD.replace("eye = [0, 0, 4]", "eye = [0, 0, 3e38]"),
            "scene.toml",
            "`eye`",
        ),
        case(
            "eye-target-overflow",
            HEAD.replace("eye = [0, 0, 4]", "eye = [0, 0, -3e38]")
                .replace("target = [0, 0, 0]", "target = [0, 0, 3e38]"),
            "scene.toml",
            "`eye`",
        ),
        case(
            "up-nearly-parallel",
            HEAD.replace(
                "target = [0, 0, 0]",
                "target = [0, 0, 0]\nup = [0, 1e-7, 1]",
            ),
            "scene.toml",
            "`up`",
        ),
        scene_case(
            "uvs-nan",
            "[[shapes]]\ntype = \"triangle\"\nvertices = [[0,0,0],[1,0,0],[0,1,0]]\n\
             uvs = [[nan,0],[1,0],[0,1]]\n",
            "`uvs`",
        ),
        scene_case(
            "sphere-huge-radius",
            &format!("{sphere}center = [0, 0, 0]\nradius = 3e38\n"),
            "`radius`",
        ),
        scene_case(
            "sphere-far-center",
            &format!("{sphere}center = [3e38, 0, 0]\nradius = 3e38\n"),
            "`center`",
        ),
        scene_case(
            "quad-overflowing-edges",
            "[[shapes]]\ntype = \"quad\"\n\
             corners = [[-3e38,0,0],[3e38,0,0],[3e38,1,0],[-3e38,1,0]]\n",
            "`corners`",
        ),
        scene_case(
            "cuboid-huge",
            "[[shapes]]\ntype = \"cuboid\"\nmin = [-3e38,-3e38,-3e38]\nmax = [3e38,3e38,3e38]\n",
            "`min`",
        ),
        scene_case(
            "plane-far",
            "[[shapes]]\ntype = \"plane\"\npoint = [0, 1e30, 0]\nnormal = [0, 1, 0]\n",
            "`point`",
        ),
        scene_case(
            "light-far",
            "[[lights]]\ntype = \"point\"\nposition = [1e30, 0, 0]\nintensity = 1\n",
            "`position`",
        ),
        scene_case(
            "emitter-power-overflow",
            "[materials.e]\nemission = 3e38\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"e\"\n\
             nee = true\ncenter = [0, 0, 0]\nradius = 1e11\n",
            "`emission`",
        ),
        scene_case(
            "texture-offset-overflow",
            &format!(
                "{sphere}center = [0, 0, 0]\nradius = 1\n\
                 texture_scale = [3e38, 3e38]\ntexture_offset = [3e38, 3e38]\n"
            ),
            "`texture_offset`",
        ),
        scene_case(
            "plane-texture-scale-overflow",
            "[[shapes]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 1, 0]\n\
             texture_scale = [1e30, 1]\n",
            "`texture_scale`",
        ),
    ];
    run_all(&dir, &cases);
}

#[test]
fn tables_written_as_arrays_are_errors() {
    let dir = temp_dir("arrays");
    let no_render = HEAD.replace("[render]\nspp = 1\n", "");
    let cases = [
        top_case(
            "environment-array",
            "environment = [0.25, 99, \"junk\"]\n",
            "`environment`",
        ),
        case(
            "render-array",
            format!("render = [1, 64]\n{no_render}"),
            "scene.toml",
            "`render`",
        ),
        case(
            "camera-array",
            "camera = [[0, 0, 4], [0, 0, 0]]\n".into(),
            "scene.toml",
            "`camera`",
        ),
        top_case("shape-array", "shapes = [[\"sphere\"]]\n", "table"),
        top_case(
            "light-array",
            "lights = [[\"point\", [0, 1, 0], 1]]\n",
            "table",
        ),
        case(
            "material-array",
            HEAD.replace(
                "[materials.m]\nkd = 0.5\n",
                "[materials]\nm = [\"diffuse\", 0.5]\n",
            ),
            "scene.toml",
            "`m`",
        ),
        scene_case("texture-array", "[textures]\nt = [\"a.ppm\"]\n", "`t`"),
    ];
    run_all(&dir, &cases);
}

/// Validation happens at load: both backends refuse the same scenes with
/// the same message.
#[test]
fn both_backends_refuse_the_same_scenes() {
    let dir = temp_dir("both");
    let scenes = [
        format!("{HEAD}[[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 3e38\n"),
        format!("{HEAD}[[shapes]]\ntype = \"mesh\"\nfile = \"tri.ply\"\nscale = 1e20\n"),
    ];
    std::fs::write(dir.join("tri.ply"), tri_ply()).unwrap();
    for (i, text) in scenes.iter().enumerate() {
        let path = dir.join(format!("s{i}.toml"));
        std::fs::write(&path, text).unwrap();
        let mut messages = Vec::new();
        for backend in ["rust", "embree"] {
            let out = luz_limited(&[
                "render",
                path.to_str().unwrap(),
                "--backend",
                backend,
                "--quiet",
                "-o",
                dir.join("out.png").to_str().unwrap(),
            ]);
            let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
            assert_eq!(out.status.code(), Some(2), "{backend}: {stderr}");
            assert!(located(&stderr, &format!("s{i}.toml")), "{stderr}");
            messages.push(stderr);
        }
        assert_eq!(messages[0], messages[1]);
    }
    assert!(!dir.join("out.png").exists());
}

fn face(indices: &[i32]) -> Vec<u8> {
    let mut f = vec![indices.len() as u8];
    for i in indices {
        f.extend(i.to_le_bytes());
    }
    f
}

#[test]
fn meshes_that_contradict_themselves() {
    let dir = temp_dir("lying-meshes");
    let verts = triangle_vertices();
    let cases = [
        with_file(
            "ply-ascii-extra-faces",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n3 1 2 0\n"),
        )
        .needle("after the last element the header declares"),
        with_file(
            "ply-binary-trailing-bytes",
            "m.ply",
            binary_ply(
                "3",
                "1",
                "uchar",
                &[verts.clone(), face(&[0, 1, 2]), face(&[0, 2, 1])].concat(),
            ),
        )
        .needle("after the last element the header declares"),
        with_file(
            "obj-two-vertex-face",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\nf 3 2 1\n".to_vec(),
        )
        .needle("a face needs at least 3 vertices"),
        with_file(
            "obj-vt-index-zero",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/0 3/3\n".to_vec(),
        )
        .needle("texture coordinate index `0`"),
        with_file(
            "obj-normal-index",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n".to_vec(),
        )
        .needle("normal index `2`"),
    ];
    run_all(&dir, &cases);
}

/// Renders `scene` (with `files`) and returns stderr; the render must
/// succeed.
fn render_ok(dir: &Path, name: &str, scene: &str, files: &[(&str, &[u8])]) -> String {
    let sub = dir.join(name);
    std::fs::create_dir_all(&sub).unwrap();
    let path = sub.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    for (f, data) in files {
        std::fs::write(sub.join(f), data).unwrap();
    }
    let out = luz_limited(&[
        "render",
        path.to_str().unwrap(),
        "--quiet",
        "-o",
        sub.join("out.png").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{name}: {stderr}");
    stderr
}

#[test]
fn unused_mesh_data_earns_one_warning() {
    let dir = temp_dir("mesh-warnings");
    let shape = "[[shapes]]\ntype = \"mesh\"\nfile = \"m.ply\"\nmaterial = \"m\"\n";
    let scene = format!("{HEAD}{shape}");
    // Normals and an extra element luz does not read.
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
               property float z\nproperty float nx\nelement face 4\n\
               property list uchar int vertex_indices\nelement edge 1\nproperty int a\n\
               property int b\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n2 2 0 1\n\
               3 0 1 2\n3 0 1 3\n3 1 2 3\n3 0 0 1\n0 1\n";
    let stderr = render_ok(&dir, "ply", &scene, &[("m.ply", ply.as_bytes())]);
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    let w = warnings[0];
    assert!(w.contains("m.ply"), "{w}");
    for needle in ["`nx`", "`edge`", "1 of 4", "degenerate"] {
        assert!(w.contains(needle), "no {needle}: {w}");
    }
    // OBJ: normals on some faces only (dropped), groups and a degenerate
    // face.
    let obj = b"o thing\ng part\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 2 0\nvn 0 0 1\n\
                f 1//1 2//1 3//1\nf 1 1 2\ns 1\n";
    let scene = scene.replace("m.ply", "m.obj");
    let stderr = render_ok(&dir, "obj", &scene, &[("m.obj", obj)]);
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    for needle in ["m.obj", "vertex normals dropped", "`g`", "degenerate"] {
        assert!(warnings[0].contains(needle), "no {needle}: {}", warnings[0]);
    }
    // A clean mesh: not a word.
    let stderr = render_ok(
        &dir,
        "clean",
        &scene.replace("m.obj", "tri.ply"),
        &[("tri.ply", tri_ply().as_bytes())],
    );
    assert!(!stderr.contains("warning"), "{stderr}");
}

/// Meshes whose triangles are all degenerate are left out, the render goes
/// on, and one warning names them all.
#[test]
fn meshes_of_no_area_earn_one_warning() {
    let dir = temp_dir("no-area");
    let mesh =
        |file: &str| format!("[[shapes]]\ntype = \"mesh\"\nfile = \"{file}\"\nmaterial = \"m\"\n");
    let scene = format!(
        "{HEAD}{}{}{}",
        mesh("a.ply"),
        mesh("b.obj"),
        mesh("tri.ply")
    );
    let flat_ply = format!("{PLY_HEADER}0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n");
    let flat_obj = "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 3 2 1\n";
    let tri = tri_ply();
    let files: [(&str, &[u8]); 3] = [
        ("a.ply", flat_ply.as_bytes()),
        ("b.obj", flat_obj.as_bytes()),
        ("tri.ply", tri.as_bytes()),
    ];
    let stderr = render_ok(&dir, "no-area", &scene, &files);
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    for needle in ["left out 2 meshes", "a.ply", "b.obj", "degenerate"] {
        assert!(warnings[0].contains(needle), "no {needle}: {}", warnings[0]);
    }
}

/// A 2 MB `.ply.gz` whose header declares three vertices and one face,
/// followed by 2 GiB of zeros: inflation stops where the declared elements
/// end, long before memory runs out.
#[test]
fn a_gzip_bomb_stops_at_the_declared_size() {
    let dir = temp_dir("gz-bomb");
    let gz = |data: &[u8]| {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    };
    let body = [triangle_vertices(), face(&[0, 1, 2])].concat();
    let mut file = gz(&binary_ply("3", "1", "uchar", &body));
    // 32 gzip members of 64 MiB of zeros each: MultiGzDecoder reads them
    // all as one stream.
    let zeros = {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
        e.write_all(&vec![0u8; 64 << 20]).unwrap();
        e.finish().unwrap()
    };
    for _ in 0..32 {
        file.extend_from_slice(&zeros);
    }
    assert!(file.len() < 4 << 20, "{} bytes", file.len());
    let cases = [with_file("ply-gz-bomb", "m.ply.gz", file)
        .needle("after the last element the header declares")];
    run_all(&dir, &cases);
}

/// Runs `luz render PATH` under `timeout 10` (so a reader blocked on a FIFO
/// cannot hang the test) and returns its stderr; it must fail with status 2.
fn refused(path: &Path) -> String {
    let out = Command::new("timeout")
        .arg("10")
        .arg(env!("CARGO_BIN_EXE_luz"))
        .args(["render", path.to_str().unwrap(), "--quiet", "-o"])
        .arg(path.with_file_name("out.png"))
        .output()
        .expect("timeout runs luz");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{}: {stderr}", path.display());
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    stderr
}

#[test]
fn inputs_must_be_regular_files() {
    let dir = temp_dir("not-regular");
    let fifo = |p: &Path| {
        let c = std::ffi::CString::new(p.to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    };
    // The scene itself a FIFO, then a directory.
    let scene_fifo = dir.join("fifo.toml");
    fifo(&scene_fifo);
    let e = refused(&scene_fifo);
    assert!(
        e.contains("fifo.toml") && e.contains("is not a regular file"),
        "{e}"
    );
    let scene_dir = dir.join("dir.toml");
    std::fs::create_dir(&scene_dir).unwrap();
    let e = refused(&scene_dir);
    assert!(
        e.contains("dir.toml") && e.contains("is not a regular file"),
        "{e}"
    );
    // A mesh and a texture that are FIFOs, a mesh that is a directory, a
    // texture that is a device.
    fifo(&dir.join("fifo.ply"));
    fifo(&dir.join("fifo.ppm"));
    std::fs::create_dir(dir.join("dir.ply")).unwrap();
    let shape = |file: &str| {
        format!("{HEAD}[[shapes]]\ntype = \"mesh\"\nfile = \"{file}\"\nmaterial = \"m\"\n")
    };
    let texture = |file: &str| {
        format!(
            "{HEAD}texture = \"t\"\n[textures.t]\nfile = \"{file}\"\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\nmaterial = \"m\"\n"
        )
    };
    for (name, text, culprit) in [
        ("mesh-fifo.toml", shape("fifo.ply"), "fifo.ply"),
        ("mesh-dir.toml", shape("dir.ply"), "dir.ply"),
        ("texture-fifo.toml", texture("fifo.ppm"), "fifo.ppm"),
        ("texture-device.toml", texture("/dev/zero"), "/dev/zero"),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let e = refused(&path);
        assert!(located(&e, name), "{e}");
        assert!(
            e.contains(culprit) && e.contains("is not a regular file"),
            "{e}"
        );
    }
    assert!(!dir.join("out.png").exists());
}

#[test]
fn echoed_values_are_short() {
    let dir = temp_dir("echo");
    let long = "x".repeat(10 << 20);
    let sphere = "[[shapes]]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\n";
    let cases = [
        scene_case(
            "long-material-name",
            &format!("{sphere}material = \"{long}\"\n"),
            "material",
        ),
        scene_case(
            "long-texture-path",
            &format!("[textures.t]\nfile = \"{long}\"\n"),
            "file",
        ),
        scene_case(
            "long-texture-reference",
            &format!("[materials.n]\ntexture = \"{long}\"\n"),
            "texture",
        ),
        scene_case(
            "long-shape-type",
            &format!("[[shapes]]\ntype = \"{long}\"\n"),
            "type",
        ),
        scene_case(
            "long-unknown-key",
            &format!("{long} = 1\n"),
            "unknown field",
        ),
        scene_case(
            "long-wrong-type",
            &format!("{sphere}nee = \"{long}\"\n"),
            "nee",
        ),
        with_file(
            "long-ply-keyword",
            "m.ply",
            PLY_HEADER.replace("element face 1", &format!("element face 1\n{long}")),
        )
        .needle("unknown header keyword"),
        with_file(
            "long-ply-property",
            "m.ply",
            format!(
                "{}0 0 0 1\n1 0 0 1\n0 1 0",
                PLY_HEADER.replace(
                    "property float z",
                    &format!("property float z\nproperty float {long}")
                )
            ),
        )
        .needle("property"),
    ];
    for c in &cases {
        match check(&dir, c) {
            Ok(line) => assert!(
                line.len() < 1024,
                "{}: {} bytes: {}…",
                c.name,
                line.len(),
                &line[..2000]
            ),
            Err(e) => panic!("{}", &e[..e.len().min(2000)]),
        }
    }
}
