//! What vertex normals do to images: nothing for normals equal to the face
//! normal, a measurable change for tilted ones, a coarse sphere closer to
//! the true one when smooth, and light sampling and BSDF sampling that
//! agree where the two normals disagree.

mod common;

use common::meshes::{icosphere, load_scene, mesh_scene, obj, ply, quad_ply};
use luz::accel::{BackendKind, BuildOptions};
use luz::render::{build_accel, render_with, Film, RenderOptions};
use luz::scene::Scene;
use std::sync::Arc;

fn render(scene: Scene) -> Film {
    let scene = Arc::new(scene);
    let accel = build_accel(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
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

#[test]
fn a_smooth_coarse_sphere_is_closer_to_the_true_sphere() {
    let dir = common::temp_dir("icosphere");
    let (p, f) = icosphere(2);
    let v: Vec<_> = p.iter().map(|q| (q.to_array(), q.to_array())).collect();
    std::fs::write(dir.join("ico.ply"), ply(&v, &f)).unwrap();
    // The same faces without normals, for the computed ones.
    let obj = obj(&p, &f);
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
