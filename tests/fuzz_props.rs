//! Property tests of the loaders (scene TOML, PLY, OBJ, PPM): arbitrary bytes
//! and mutations of valid files never panic, and either load or fail with an
//! error that starts with the file's name; files written from random data
//! read back equal. Case counts are bounded so the file runs in seconds;
//! `fuzz/` holds the open-ended cargo-fuzz targets over the same entry points.

use luz::geometry::Mesh;
use luz::image::io::{parse_ppm, srgb_to_linear};
use luz::math::{PackedVec3, Vec3};
use luz::scene::load_bytes;
use luz::scene::mesh_io::parse_mesh;
use proptest::prelude::*;
use std::path::Path;

/// One edit of a byte string: replace, insert or delete at a position.
#[derive(Clone, Debug)]
enum Edit {
    Replace(usize, u8),
    Insert(usize, u8),
    Delete(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Replace(i, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Insert(i, b)),
        any::<usize>().prop_map(Edit::Delete),
    ]
}

/// `data` after up to 8 edits, cut at a random length half of the time.
fn mutated(data: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    (
        prop::collection::vec(edit(), 1..8),
        prop::option::of(any::<usize>()),
    )
        .prop_map(move |(edits, cut)| {
            let mut d = data.clone();
            for e in edits {
                let n = d.len().max(1);
                match e {
                    Edit::Replace(i, b) if !d.is_empty() => d[i % n] = b,
                    Edit::Insert(i, b) => d.insert(i % (d.len() + 1), b),
                    Edit::Delete(i) if !d.is_empty() => {
                        d.remove(i % n);
                    }
                    _ => {}
                }
            }
            if let Some(cut) = cut {
                d.truncate(cut % (d.len() + 1));
            }
            d
        })
}

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn check_scene(data: &[u8]) -> Result<(), TestCaseError> {
    // Relative mesh and texture names resolve in a folder that does not exist.
    let path = Path::new("/nonexistent/luz-props/scene.toml");
    if let Err(e) = load_bytes(data, path) {
        let msg = e.to_string();
        prop_assert!(msg.starts_with(&path.display().to_string()), "{msg}");
        prop_assert_eq!(msg.lines().count(), 1, "{}", msg);
    }
    Ok(())
}

/// sin of the angle at the first vertex of triangle `t`, in f64.
fn sin_p0(m: &Mesh, t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
    let (e1, e2) = (b - a, c - a);
    e1.cross(e2).length() / (e1.length() * e2.length())
}

fn check_mesh(data: &[u8], name: &str) -> Result<(), TestCaseError> {
    match parse_mesh(data, Path::new(name)) {
        Ok(m) => {
            let n = m.positions.len();
            prop_assert!(m.indices.iter().flatten().all(|&i| (i as usize) < n));
            prop_assert!(m.positions.iter().all(|p| p.is_finite()));
            prop_assert!(!m.indices.is_empty());
            // Degenerate triangles are dropped on loading.
            prop_assert!(m.indices.iter().all(|&t| sin_p0(&m, t) > 1e-6));
        }
        Err(e) => {
            let msg = e.to_string();
            prop_assert!(msg.starts_with(name), "{msg}");
            prop_assert_eq!(msg.lines().count(), 1, "{}", msg);
        }
    }
    Ok(())
}

fn check_ppm(data: &[u8]) -> Result<(), TestCaseError> {
    match parse_ppm(data, Path::new("t.ppm")) {
        Ok(img) => {
            prop_assert_eq!(img.pixels.len(), img.width as usize * img.height as usize);
            prop_assert!(img.pixels.iter().all(|p| p.is_finite()));
        }
        Err(e) => {
            let msg = e.to_string();
            prop_assert!(msg.starts_with("t.ppm"), "{msg}");
        }
    }
    Ok(())
}

const SCENE: &str = r#"[camera]
eye = [0, 1, 3.7]
target = [0, 1, 0]
fov = 40
resolution = [4, 4]
[render]
spp = 1
max_depth = 3
[materials.white]
kd = [0.8, 0.8, 0.8]
[materials.glass]
type = "dielectric"
ior = 1.5
[materials.light]
emission = [17, 12, 4]
[textures.check]
checker = [0.2, [0.9, 0.9, 0.9]]
squares = 4
[[shapes]]
type = "quad"
corners = [[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]]
material = "white"
[[shapes]]
type = "sphere"
center = [0, 0.5, 0]
radius = 0.5
material = "glass"
[[shapes]]
type = "cuboid"
min = [-0.2, 1.9, -0.2]
max = [0.2, 2, 0.2]
material = "light"
nee = true
[[lights]]
type = "point"
position = [0, 1.5, 0]
intensity = 3
[environment]
radiance = 0.1
"#;

const PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                   property float z\nproperty float u\nproperty float v\nelement face 2\n\
                   property list uchar int vertex_indices\nend_header\n\
                   0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n3 0 1 2\n4 0 1 2 3\n";

const OBJ: &str = "o q\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
                   vt 0 1\nf 1/1 2/2 3/3 4/4\nf -1 -2 -3\n";

/// A binary PLY of `mesh` (float positions, int indices).
fn binary_ply(mesh: &Mesh, big_endian: bool) -> Vec<u8> {
    let format = if big_endian { "big" } else { "little" };
    let mut out = format!(
        "ply\nformat binary_{format}_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.indices.len()
    )
    .into_bytes();
    let word = |b: [u8; 4]| {
        if big_endian {
            [b[3], b[2], b[1], b[0]]
        } else {
            b
        }
    };
    for p in &mesh.positions {
        for c in p.to_array() {
            out.extend(word(c.to_le_bytes()));
        }
    }
    for t in &mesh.indices {
        out.push(3);
        for &i in t {
            out.extend(word(i.to_le_bytes()));
        }
    }
    out
}

/// An ascii PLY of `mesh`; `{:?}` prints the shortest decimal that reads
/// back as the same f32.
fn ascii_ply(mesh: &Mesh) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.indices.len()
    );
    for p in &mesh.positions {
        out += &format!("{:?} {:?} {:?}\n", p.x, p.y, p.z);
    }
    for [a, b, c] in &mesh.indices {
        out += &format!("3 {a} {b} {c}\n");
    }
    out.into_bytes()
}

fn obj(mesh: &Mesh) -> Vec<u8> {
    let mut out = String::new();
    for p in &mesh.positions {
        out += &format!("v {:?} {:?} {:?}\n", p.x, p.y, p.z);
    }
    for [a, b, c] in &mesh.indices {
        out += &format!("f {} {} {}\n", a + 1, b + 1, c + 1);
    }
    out.into_bytes()
}

fn finite_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        -1e6f32..1e6,
        any::<f32>().prop_filter("finite", |x| x.is_finite()),
    ]
}

/// Random triangle soups: 3..40 vertices, 1..40 triangles over them, all
/// well clear of the loaders' degeneracy threshold, and of an f32 cross
/// product that underflows to zero (the loaders drop both).
fn meshes() -> impl Strategy<Value = Mesh> {
    prop::collection::vec((finite_f32(), finite_f32(), finite_f32()), 3..40)
        .prop_flat_map(|ps| {
            let n = ps.len() as u32;
            prop::collection::vec((0..n, 0..n, 0..n), 1..40).prop_map(move |tris| {
                let mut m = Mesh {
                    positions: ps
                        .iter()
                        .map(|&(x, y, z)| PackedVec3::new(x, y, z))
                        .collect(),
                    indices: tris.into_iter().map(|(a, b, c)| [a, b, c]).collect(),
                    uvs: None,
                    normals: None,
                };
                let keep: Vec<_> = m
                    .indices
                    .iter()
                    .copied()
                    .filter(|&t| {
                        let corners = t.map(|i| Vec3::from(m.positions[i as usize]));
                        sin_p0(&m, t) > 1e-3 && !luz::geometry::has_zero_area(corners)
                    })
                    .collect();
                m.indices = keep;
                m
            })
        })
        .prop_filter("at least one triangle", |m| !m.indices.is_empty())
}

/// The triangles of `m` as corner positions (OBJ loading renumbers
/// vertices by first use, so indices alone need not match).
fn corners(m: &Mesh) -> Vec<[[u32; 3]; 3]> {
    m.indices
        .iter()
        .map(|t| t.map(|i| m.positions[i as usize].to_array().map(f32::to_bits)))
        .collect()
}

proptest! {
    #![proptest_config(config(2000))]

    #[test]
    fn scene_from_arbitrary_bytes(data in prop::collection::vec(any::<u8>(), 0..512)) {
        check_scene(&data)?;
    }

    #[test]
    fn scene_from_arbitrary_text(text in "[\\[\\]a-z_=. 0-9\"\n,-]{0,300}") {
        check_scene(text.as_bytes())?;
    }

    #[test]
    fn scene_mutated(data in mutated(SCENE.as_bytes().to_vec())) {
        check_scene(&data)?;
    }

    #[test]
    fn ply_from_arbitrary_bytes(data in prop::collection::vec(any::<u8>(), 0..512)) {
        let mut d = b"ply\nformat binary_little_endian 1.0\n".to_vec();
        d.extend(&data);
        check_mesh(&d, "a.ply")?;
        check_mesh(&data, "b.ply")?;
    }

    #[test]
    fn ply_mutated(data in mutated(PLY.as_bytes().to_vec())) {
        check_mesh(&data, "m.ply")?;
    }

    #[test]
    fn binary_ply_mutated(
        data in (meshes(), any::<bool>()).prop_flat_map(|(m, be)| mutated(binary_ply(&m, be)))
    ) {
        check_mesh(&data, "m.ply")?;
    }

    #[test]
    fn obj_from_arbitrary_bytes(data in prop::collection::vec(any::<u8>(), 0..512)) {
        check_mesh(&data, "a.obj")?;
    }

    #[test]
    fn obj_mutated(data in mutated(OBJ.as_bytes().to_vec())) {
        check_mesh(&data, "m.obj")?;
    }

    #[test]
    fn ppm_from_arbitrary_bytes(
        magic in prop::sample::select(vec!["P2", "P3", "P5", "P6"]),
        data in prop::collection::vec(any::<u8>(), 0..256),
    ) {
        let mut d = magic.as_bytes().to_vec();
        d.extend(&data);
        check_ppm(&d)?;
        check_ppm(&data)?;
    }

    #[test]
    fn ppm_mutated(
        data in prop_oneof![
            Just(b"P3\n#MAX=48.5\n2 2\n1000\n0 0 0 1000 500 250\n10 20 30 1 2 3\n".to_vec()),
            Just(b"P6\n2 1\n255\n\x00\xff\x80\xff\x00\x0a".to_vec()),
            Just(b"P5 1 1 65535\n\xff\xff".to_vec()),
        ].prop_flat_map(mutated)
    ) {
        check_ppm(&data)?;
    }
}

proptest! {
    #![proptest_config(config(300))]

    #[test]
    fn ply_round_trips(mesh in meshes(), be in any::<bool>()) {
        for data in [ascii_ply(&mesh), binary_ply(&mesh, be)] {
            let back = parse_mesh(&data, Path::new("r.ply")).map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(&back.positions, &mesh.positions);
            prop_assert_eq!(&back.indices, &mesh.indices);
        }
    }

    #[test]
    fn obj_round_trips(mesh in meshes()) {
        let back = parse_mesh(&obj(&mesh), Path::new("r.obj")).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(corners(&back), corners(&mesh));
    }

    #[test]
    fn p6_round_trips(
        (w, h, bytes) in (1u32..8, 1u32..8).prop_flat_map(|(w, h)| {
            (Just(w), Just(h), prop::collection::vec(any::<u8>(), (w * h * 3) as usize))
        })
    ) {
        let mut data = format!("P6\n{w} {h}\n255\n").into_bytes();
        data.extend(&bytes);
        let img = parse_ppm(&data, Path::new("r.ppm")).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!((img.width, img.height), (w, h));
        for (p, rgb) in img.pixels.iter().zip(bytes.chunks_exact(3)) {
            for c in 0..3 {
                let want = srgb_to_linear(rgb[c] as f32 / 255.0);
                prop_assert!((p[c] - want).abs() <= 1e-6, "{} vs {}", p[c], want);
            }
        }
    }
}
