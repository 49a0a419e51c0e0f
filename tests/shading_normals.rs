//! Shading normals from vertex normals: what the PLY and OBJ readers make
//! of them, how a transform moves them, the located errors of bad ones, and
//! what they do to images (nothing for normals equal to the face normal, a
//! measurable change for tilted ones, a coarse sphere closer to the true
//! one when smooth).

mod common;

use luz::accel::{Accel, BackendKind, BuildOptions};
use luz::geometry::{Geometry, Mesh};
use luz::math::Vec3;
use luz::render::{render_with, Film, RenderOptions};
use luz::scene::{load, Scene};
use std::path::Path;
use std::sync::Arc;

fn mesh_of(scene: &Scene, shape: usize) -> &Mesh {
    match &scene.shapes[shape].geometry {
        Geometry::Mesh(m) => m,
        other => panic!("shape {shape} is a {}", other.name()),
    }
}

fn load_scene(dir: &Path, name: &str, text: &str) -> Result<Scene, String> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    load(&path).map_err(|e| e.to_string())
}

/// A scene of one mesh shape (`file`, with extra `keys`) under a point
/// light, seen from above.
fn mesh_scene(file: &str, keys: &str, resolution: u32, spp: u32) -> String {
    format!(
        r#"
[camera]
eye = [0, 0, 6]
target = [0, 0, 0]
up = [0, 1, 0]
fov = 25
resolution = [{resolution}, {resolution}]

[render]
spp = {spp}
max_depth = 2
russian_roulette = false
sampler = "independent"
seed = 7

[materials.grey]
kd = 0.7

[[shapes]]
type = "mesh"
file = "{file}"
material = "grey"
{keys}

[[lights]]
type = "point"
position = [1, 2, 5]
intensity = [30, 30, 30]
"#
    )
}

fn render(scene: Scene) -> Film {
    let scene = Arc::new(scene);
    let accel = Accel::build(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    render_with(&scene, &accel, &RenderOptions::from_scene(&scene), &()).0
}

/// Mean over pixels and channels, and its standard error from the film's
/// own per-pixel variance (samples independent).
fn mean_and_se(film: &Film) -> (f64, f64) {
    let n = film.samples as f64;
    let (mut mean, mut var) = (0.0, 0.0);
    for (s, q) in film.sum.iter().zip(&film.sum_sq) {
        for c in 0..3 {
            let m = s[c] / n;
            mean += m;
            var += (q[c] / n - m * m).max(0.0) / (n - 1.0);
        }
    }
    let k = 3.0 * film.sum.len() as f64;
    (mean / k, var.sqrt() / k)
}

fn ply(vertices: &[([f32; 3], [f32; 3])], faces: &[[u32; 3]]) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        faces.len()
    );
    for (p, n) in vertices {
        s += &format!("{} {} {} {} {} {}\n", p[0], p[1], p[2], n[0], n[1], n[2]);
    }
    for f in faces {
        s += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    s
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn ply_normals_are_read_and_moved_by_the_inverse_transpose() {
    let dir = common::temp_dir("ply-normals");
    let text = ply(
        &[
            ([0.0, 0.0, 0.0], [1.0, 1.0, 0.0]),
            ([1.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ],
        &[[0, 1, 2]],
    );
    std::fs::write(dir.join("tri.ply"), &text).unwrap();
    let plain = load_scene(&dir, "a.toml", &mesh_scene("tri.ply", "", 4, 1)).unwrap();
    let n = mesh_of(&plain, 0).normals.clone().expect("normals read");
    assert!(close(n[0], Vec3::new(1.0, 1.0, 0.0).normalize()), "{n:?}");
    assert!(close(n[1], Vec3::Z) && close(n[2], Vec3::Z), "{n:?}");

    // Scaling x by 2 halves the x of a normal (inverse transpose), then
    // the normal is made unit again; positions are scaled as given.
    let scaled = load_scene(
        &dir,
        "b.toml",
        &mesh_scene("tri.ply", "scale = [2, 1, 1]", 4, 1),
    )
    .unwrap();
    let m = mesh_of(&scaled, 0);
    let n = m.normals.as_ref().unwrap();
    assert!(close(n[0], Vec3::new(0.5, 1.0, 0.0).normalize()), "{n:?}");
    assert!(close(n[1], Vec3::Z), "{n:?}");
    assert_eq!(m.positions[1], Vec3::new(2.0, 0.0, 0.0));

    // `normals = "flat"` drops them; a file without normals has none.
    let flat = load_scene(
        &dir,
        "c.toml",
        &mesh_scene("tri.ply", "normals = \"flat\"", 4, 1),
    )
    .unwrap();
    assert!(mesh_of(&flat, 0).normals.is_none());
}

#[test]
fn obj_normals_split_vertices_and_follow_negative_indices() {
    let dir = common::temp_dir("obj-normals");
    // Two triangles share the edge 1-3 but give its vertices different
    // normals: four positions become six vertices. The second face uses
    // negative indices (relative to the last `v` and `vn`).
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
               vn 0 0 1\nvn 0 1 1\n\
               vt 0 0\n\
               f 1//1 2//1 3//1\n\
               f -4/-1/-1 -2/1/2 -1//2\n";
    std::fs::write(dir.join("two.obj"), obj).unwrap();
    let scene = load_scene(&dir, "a.toml", &mesh_scene("two.obj", "", 4, 1)).unwrap();
    let m = mesh_of(&scene, 0);
    let n = m.normals.as_ref().expect("normals read");
    assert_eq!(m.positions.len(), 6, "{:?}", m.positions);
    let tilted = Vec3::new(0.0, 1.0, 1.0).normalize();
    for (t, want) in m.indices.iter().zip([Vec3::Z, tilted]) {
        for &i in t {
            assert!(close(n[i as usize], want), "{:?} {n:?}", m.indices);
        }
    }
    // The corner at position 1 (0, 0, 0) appears with either normal.
    let at_origin: Vec<Vec3> = (0..6)
        .filter(|&i| m.positions[i] == Vec3::ZERO)
        .map(|i| n[i])
        .collect();
    assert_eq!(at_origin.len(), 2, "{at_origin:?}");

    // A face without normals among faces with: shaded flat, said once.
    std::fs::write(
        dir.join("mixed.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 2\n",
    )
    .unwrap();
    let scene = load_scene(&dir, "b.toml", &mesh_scene("mixed.obj", "", 4, 1)).unwrap();
    assert!(mesh_of(&scene, 0).normals.is_none());
}

#[test]
fn bad_normals_are_located_errors() {
    let dir = common::temp_dir("bad-normals");
    let ply_text = ply(
        &[
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            ([1.0, 0.0, 0.0], [0.0, f32::NAN, 1.0]),
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ],
        &[[0, 1, 2]],
    );
    std::fs::write(dir.join("bad.ply"), ply_text).unwrap();
    let err = load_scene(&dir, "a.toml", &mesh_scene("bad.ply", "", 4, 1)).unwrap_err();
    // The vertex is the second record, on line 14 after 12 header lines.
    assert!(
        err.contains("bad.ply:14:") && err.contains("vertex 1") && err.contains("nx ny nz"),
        "{err}"
    );

    std::fs::write(
        dir.join("bad.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 inf 1\nf 1//1 2//1 3//1\n",
    )
    .unwrap();
    let err = load_scene(&dir, "b.toml", &mesh_scene("bad.obj", "", 4, 1)).unwrap_err();
    assert!(
        err.contains("bad.obj:4:") && err.contains("vertex normal"),
        "{err}"
    );

    let err = load_scene(
        &dir,
        "c.toml",
        &mesh_scene("bad.obj", "normals = \"bumpy\"", 4, 1),
    )
    .unwrap_err();
    assert!(err.contains("normals") && err.contains("bumpy"), "{err}");
}

/// A quad of two triangles in the z = 0 plane, facing +z, every vertex
/// with the normal `n`.
fn quad_ply(n: [f32; 3]) -> String {
    let c = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ];
    let v: Vec<_> = c.iter().map(|&p| (p, n)).collect();
    ply(&v, &[[0, 1, 2], [0, 2, 3]])
}

#[test]
fn face_normals_render_as_no_normals_and_tilted_ones_do_not() {
    let dir = common::temp_dir("quad");
    std::fs::write(dir.join("face.ply"), quad_ply([0.0, 0.0, 1.0])).unwrap();
    let tilt = 30f32.to_radians();
    std::fs::write(
        dir.join("tilted.ply"),
        quad_ply([tilt.sin(), 0.0, tilt.cos()]),
    )
    .unwrap();
    let scene = |file: &str, keys: &str, name: &str| {
        render(load_scene(&dir, name, &mesh_scene(file, keys, 16, 16)).unwrap())
    };
    let flat = scene("face.ply", "normals = \"flat\"", "a.toml");
    let face = scene("face.ply", "", "b.toml");
    let tilted = scene("tilted.ply", "", "c.toml");
    // Same seed, same random numbers: normals equal to the face normal
    // change the image only by rounding (interpolated weights need not sum
    // to exactly 1 in f32).
    let (m_flat, se_flat) = mean_and_se(&flat);
    let max_diff = flat
        .sum
        .iter()
        .zip(&face.sum)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
        .fold(0.0f64, f64::max)
        / flat.samples as f64;
    assert!(max_diff < 1e-4 * m_flat, "{max_diff} vs mean {m_flat}");
    // Tilted normals reflect the light differently: the means differ by
    // far more than their noise (the bound, 6 standard errors, is passed
    // by chance about once in 10^9).
    let (m_tilted, se_tilted) = mean_and_se(&tilted);
    let z = (m_tilted - m_flat).abs() / (se_flat.powi(2) + se_tilted.powi(2)).sqrt();
    assert!(
        z > 6.0,
        "flat {m_flat} ± {se_flat}, tilted {m_tilted} ± {se_tilted}"
    );
}

/// An icosphere of unit radius, `subdivisions` times subdivided, with its
/// exact (radial) normals.
fn icosphere(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for [a, b, c] in f {
            let mut m = |i: u32, j: u32| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    p.push((p[i as usize] + p[j as usize]).normalize());
                    p.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (p, f)
}

/// Mean absolute difference per pixel value between two films.
fn mean_abs_diff(a: &Film, b: &Film) -> f64 {
    let (na, nb) = (a.samples as f64, b.samples as f64);
    let total: f64 = a
        .sum
        .iter()
        .zip(&b.sum)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] / na - y[c] / nb).abs()))
        .sum();
    total / (3 * a.sum.len()) as f64
}

#[test]
fn a_smooth_coarse_sphere_is_closer_to_the_true_sphere() {
    let dir = common::temp_dir("icosphere");
    let (p, f) = icosphere(2);
    let v: Vec<_> = p.iter().map(|q| (q.to_array(), q.to_array())).collect();
    std::fs::write(dir.join("ico.ply"), ply(&v, &f)).unwrap();
    // The same faces without normals, for the computed ones.
    let mut obj: String = p
        .iter()
        .map(|q| format!("v {} {} {}\n", q.x, q.y, q.z))
        .collect();
    for t in &f {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(dir.join("ico.obj"), obj).unwrap();
    let res = 48;
    let mesh = |file: &str, keys: &str, name: &str| {
        render(load_scene(&dir, name, &mesh_scene(file, keys, res, 8)).unwrap())
    };
    let smooth = mesh("ico.ply", "", "a.toml");
    let flat = mesh("ico.ply", "normals = \"flat\"", "b.toml");
    // Mitsuba's computed normals for the same faces, from a file without.
    let computed = mesh("ico.obj", "normals = \"smooth\"", "c.toml");
    let sphere_scene = mesh_scene("ico.ply", "", res, 8).replace(
        "type = \"mesh\"\nfile = \"ico.ply\"",
        "type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1",
    );
    let sphere = render(load_scene(&dir, "d.toml", &sphere_scene).unwrap());
    let (e_smooth, e_flat) = (
        mean_abs_diff(&smooth, &sphere),
        mean_abs_diff(&flat, &sphere),
    );
    let e_computed = mean_abs_diff(&computed, &sphere);
    eprintln!(
        "mean |error| against the sphere: smooth {e_smooth}, computed {e_computed}, flat {e_flat}"
    );
    // The silhouettes differ alike in all three (the polygon is inscribed);
    // the facets' shading is what the vertex normals take away.
    assert!(e_smooth < 0.7 * e_flat, "{e_smooth} vs flat {e_flat}");
    assert!(e_computed < 0.7 * e_flat, "{e_computed} vs flat {e_flat}");
}

#[test]
fn computed_normals_of_an_icosphere_are_nearly_radial() {
    let (positions, indices) = icosphere(2);
    let mut mesh = Mesh {
        positions,
        indices,
        uvs: None,
        normals: None,
    };
    mesh.compute_vertex_normals();
    let normals = mesh.normals.as_ref().unwrap();
    let worst = mesh
        .positions
        .iter()
        .zip(normals)
        .map(|(p, n)| p.normalize().dot(*n).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0f32, f32::max);
    // The icosphere is symmetric about each vertex up to the slight
    // unevenness of subdivided triangles: a degree or two at most.
    assert!(worst < 2.0, "worst {worst}°");
}

#[test]
fn the_shading_normal_stays_on_the_side_of_the_winding() {
    use luz::geometry::PrimHit;
    // Facing +z by its winding; the file's normals point to -z, tilted.
    let mesh = Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        indices: vec![[0, 1, 2]],
        uvs: None,
        normals: Some(vec![Vec3::new(0.6, 0.0, -0.8); 3]),
    };
    let sp = mesh.surface(
        0,
        &PrimHit {
            t: 1.0,
            u: 0.2,
            v: 0.3,
        },
    );
    assert_eq!(sp.n, Vec3::Z);
    assert!(close(sp.ns, Vec3::new(-0.6, 0.0, 0.8)), "{:?}", sp.ns);
}

#[test]
fn mitsuba_meshes_use_file_normals_else_computed_ones_unless_face_normals() {
    let dir = common::temp_dir("mitsuba");
    let (p, f) = icosphere(1);
    let mut obj: String = p
        .iter()
        .map(|q| format!("v {} {} {}\n", q.x, q.y, q.z))
        .collect();
    for t in &f {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(dir.join("ico.obj"), obj).unwrap();
    std::fs::write(
        dir.join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 1 1\nf 1//1 2//1 3//1\n",
    )
    .unwrap();
    let shape = |file: &str, extra: &str| {
        format!(r#"<shape type="obj"><string name="filename" value="{file}"/>{extra}</shape>"#)
    };
    let xml = format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
  <rfilter type="box"/></film></sensor>
<emitter type="point"><point name="position" value="0,0,3"/></emitter>
{}
{}
{}
</scene>"#,
        shape("ico.obj", ""),
        shape("ico.obj", r#"<boolean name="face_normals" value="true"/>"#),
        shape("tri.obj", ""),
    );
    let scene = load_scene(&dir, "s.xml", &xml).unwrap();
    let computed = mesh_of(&scene, 0);
    let normals = computed.normals.as_ref().expect("computed normals");
    for (q, n) in computed.positions.iter().zip(normals) {
        assert!(q.normalize().dot(*n) > 0.999, "{q} {n}");
    }
    assert!(mesh_of(&scene, 1).normals.is_none(), "face_normals");
    let file = mesh_of(&scene, 2).normals.as_ref().expect("file normals");
    assert!(
        file.iter()
            .all(|n| close(*n, Vec3::new(0.0, 1.0, 1.0).normalize())),
        "{file:?}"
    );
}

#[test]
fn a_bad_normal_in_a_binary_ply_names_its_byte_and_fields() {
    let dir = common::temp_dir("binary");
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
                  property float x\nproperty float y\nproperty float z\n\
                  property float nx\nproperty float ny\nproperty float nz\n\
                  element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let mut data = header.as_bytes().to_vec();
    let vertices = [
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0, f32::INFINITY, 0.0, 1.0],
    ];
    for v in vertices {
        for x in v {
            data.extend_from_slice(&f32::to_le_bytes(x));
        }
    }
    data.push(3);
    for i in [0i32, 1, 2] {
        data.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("bad.ply"), data).unwrap();
    let err = load_scene(&dir, "a.toml", &mesh_scene("bad.ply", "", 4, 1)).unwrap_err();
    // The third record starts 2 × 24 bytes into the body.
    let at = format!("bad.ply: byte {}: vertex 2", header.len() + 48);
    assert!(err.contains(&at) && err.contains("nx ny nz"), "{err}");
}

/// A floor whose vertex normals lean 40° towards +x, lit from above by a
/// quad light and from the side by one just below the floor's plane: the
/// side light reaches the floor only along directions below the surface
/// that the shading normal calls above it (light that would leak through).
fn leaning_floor_scene(material: &str, nee: bool) -> String {
    format!(
        r#"
[camera]
eye = [0, 0, 2.5]
target = [0, 0, 0]
up = [0, 1, 0]
fov = 40
resolution = [16, 16]

[render]
spp = 4096
max_depth = 3
russian_roulette = false
sampler = "independent"
seed = 11

[materials.floor]
{material}

[materials.light]
emission = 1

[[shapes]]
type = "mesh"
file = "leaning.ply"
material = "floor"

[[shapes]] # above, facing down
type = "quad"
corners = [[-1.5, -1.5, 3], [-1.5, 1.5, 3], [1.5, 1.5, 3], [1.5, -1.5, 3]]
material = "light"
nee = {nee}

[[shapes]] # beside and just below the floor, facing it (-x)
type = "quad"
corners = [[1.5, -1, -1], [1.5, -1, -0.05], [1.5, 1, -0.05], [1.5, 1, -1]]
material = "light"
nee = {nee}
"#
    )
}

#[test]
fn light_sampling_and_bsdf_sampling_agree_on_leaning_normals() {
    let dir = common::temp_dir("leaning");
    let lean = 40f32.to_radians();
    std::fs::write(
        dir.join("leaning.ply"),
        quad_ply([lean.sin(), 0.0, lean.cos()]),
    )
    .unwrap();
    let materials = [
        "kd = 0.7",
        "type = \"conductor\"\neta = [0.143, 0.375, 1.442]\nk = [3.983, 2.386, 1.603]\nroughness = 0.3",
    ];
    for (m, material) in materials.iter().enumerate() {
        let mean = |nee: bool| {
            let name = format!("{m}-{nee}.toml");
            let text = leaning_floor_scene(material, nee);
            mean_and_se(&render(load_scene(&dir, &name, &text).unwrap()))
        };
        // With `nee` both lights are also sampled, MIS-weighted; without,
        // only hit. The same expectation either way, if both strategies
        // drop the same directions: 5 standard errors, a false alarm about
        // once in 1.7 million.
        let ((a, sa), (b, sb)) = (mean(true), mean(false));
        let z = (a - b).abs() / (sa * sa + sb * sb).sqrt();
        eprintln!("{material}: nee {a} ± {sa}, hits only {b} ± {sb}");
        assert!(a > 100.0 * sa, "{material}: a black image");
        assert!(z < 5.0, "{material}: nee {a} ± {sa}, hits only {b} ± {sb}");
    }
}
