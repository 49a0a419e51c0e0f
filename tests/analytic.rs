//! Analytic checks of the integrator: situations whose exact answer is known,
//! rendered through the full pipeline (scene file → backend → integrator).
//! Stochastic checks state their bound in standard errors of the mean,
//! estimated from the film's own per-pixel variance.

use luz::accel::{BackendKind, BuildOptions};
use luz::render::{build_accel, render_with, Film, RenderOptions};
use luz::scene::{load_str, Scene};
use std::f32::consts::PI;
use std::path::Path;
use std::sync::Arc;

fn scene(text: &str) -> Arc<Scene> {
    Arc::new(load_str(text, Path::new("inline.toml")).expect("valid scene"))
}

fn render_scene(scene: &Arc<Scene>, backend: BackendKind) -> Film {
    let accel = build_accel(scene, backend, &BuildOptions::default()).expect("backend");
    render_with(scene, &accel, &RenderOptions::from_scene(scene), &()).0
}

fn backends() -> Vec<BackendKind> {
    luz::accel::compiled_backends()
        .iter()
        .map(|n| n.parse().unwrap())
        .collect()
}

/// Mean and standard error of the mean of one channel over all pixels
/// (every pixel sees the same expected value).
fn mean_and_se(film: &Film, channel: usize) -> (f64, f64) {
    let n = (film.samples * film.sum.len() as u64) as f64;
    let s: f64 = film.sum.iter().map(|p| p[channel]).sum();
    let q: f64 = film.sum_sq.iter().map(|p| p[channel]).sum();
    let mean = s / n;
    let var = (q / n - mean * mean).max(0.0) * n / (n - 1.0);
    (mean, (var / n).sqrt())
}

const SPHERE_IN_ENVIRONMENT: &str = r#"
[camera]
eye = [0, 0, 10]
target = [0, 0, 0]
fov = 2
resolution = [8, 8]

[render]
spp = 256
max_depth = 10
russian_roulette = RR

[materials.grey]
kd = 0.6

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "grey"

[environment]
radiance = [2, 1, 0.5]
"#;

#[test]
fn convex_diffuse_sphere_under_constant_sky_renders_albedo_times_sky() {
    // Every bounce ray from a convex shape escapes: L = kd * L_env. The sky
    // is both light-sampled and hit, MIS-weighted, so a single sample is not
    // exactly kd * L_env; their mean is, with or without Russian roulette.
    let expected = [1.2, 0.6, 0.3];
    for backend in backends() {
        for rr in ["false", "true"] {
            let film = render_scene(&scene(&SPHERE_IN_ENVIRONMENT.replace("RR", rr)), backend);
            for (c, expected) in expected.iter().enumerate() {
                let (mean, se) = mean_and_se(&film, c);
                // 5 standard errors: a false alarm once in ~1.7 million runs.
                assert!(
                    (mean - expected).abs() < 5.0 * se + 1e-6,
                    "{backend:?} russian roulette {rr}, channel {c}: {mean} ± {se}"
                );
            }
        }
    }
}

#[test]
fn a_masked_quad_lets_through_what_its_opacity_leaves() {
    // A quad fills the view in front of a constant sky of radiance 1. It is
    // met with probability α: black, it ends the path; grey (kd 0.5), it
    // reflects the sky seen from its front (kd · 1). Otherwise the path goes
    // straight through to the sky.
    for (kd, alpha, expected) in [(0.0f64, 0.25f64, 0.75f64), (0.5, 0.4, 0.4 * 0.5 + 0.6)] {
        let text = format!(
            r#"
[camera]
eye = [0, 0, 5]
target = [0, 0, 0]
fov = 10
resolution = [8, 8]
[render]
spp = 256
max_depth = 4
[materials.leaf]
kd = {kd}
opacity = {alpha}
[[shapes]]
type = "quad"
corners = [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]]
material = "leaf"
[environment]
radiance = 1
"#
        );
        for backend in backends() {
            let film = render_scene(&scene(&text), backend);
            let (mean, se) = mean_and_se(&film, 1);
            // 5 standard errors: a false alarm once in ~1.7 million runs.
            assert!(
                (mean - expected).abs() < 5.0 * se + 1e-6,
                "{backend:?} kd {kd} opacity {alpha}: {mean} ± {se}, expected {expected}"
            );
        }
    }
}

/// The radiance a camera with a tiny field of view sees at the point
/// `(x, 0, z)` of a diffuse plane y = 0 of albedo `kd`, lit by `light` (a
/// `[[lights]]` table's body) 2 above the origin, on each backend; checked
/// against `kd / π · intensity · falloff · cos / d²` to 1e-4, `falloff` being
/// the light's own factor in that direction.
fn check_light_over_diffuse_plane(x: f32, z: f32, light: &str, intensity: f32, falloff: f32) {
    let kd = 0.7f32;
    let text = format!(
        r#"
[camera]
eye = [{x}, 3, {zc}]
target = [{x}, 0, {z}]
fov = 0.001
resolution = [2, 2]
[render]
spp = 4
max_depth = 2
russian_roulette = false
[materials.m]
kd = {kd}
[[shapes]]
type = "plane"
point = [0, 0, 0]
normal = [0, 1, 0]
material = "m"
[[lights]]
position = [0, 2, 0]
intensity = {intensity}
{light}
"#,
        zc = z + 0.5
    );
    for backend in backends() {
        let film = render_scene(&scene(&text), backend);
        let (mean, _) = mean_and_se(&film, 1);
        let d2 = x * x + 4.0 + z * z;
        let cos = 2.0 / d2.sqrt();
        let expected = kd / PI * intensity * falloff * cos / d2;
        assert!(
            ((mean as f32) - expected).abs() <= 1e-4 * expected,
            "{backend:?} at ({x}, {z}), {light}: {mean} vs {expected}"
        );
    }
}

#[test]
fn point_light_over_diffuse_plane_follows_inverse_square_and_cosine() {
    for (x, z) in [(0.0f32, 0.0f32), (1.0, 0.5), (-2.5, 1.5)] {
        check_light_over_diffuse_plane(x, z, r#"type = "point""#, 5.0, 1.0);
    }
}

#[test]
fn spot_light_over_diffuse_plane_follows_its_cone() {
    // The spot aims straight down: full intensity within 20° of its axis,
    // linear in the angle to zero at 40°. The camera looks at the point of
    // the plane the spot sees at angle `degrees`.
    let spot = "type = \"spot\"\ntarget = [0, 0, 0]\ncutoff_angle = 40\nbeam_width = 20";
    for (degrees, falloff) in [(10.0f32, 1.0f32), (25.0, 0.75), (35.0, 0.25), (45.0, 0.0)] {
        let x = 2.0 * degrees.to_radians().tan();
        check_light_over_diffuse_plane(x, 0.0, spot, 5.0, falloff);
    }
}

#[test]
fn visible_quad_light_shows_its_radiance_exactly() {
    let text = r#"
[camera]
eye = [0, 0, 5]
target = [0, 0, 0]
fov = 5
resolution = [4, 4]
[render]
spp = 8
max_depth = 5
[materials.light]
emission = [20, 10, 5]
[[shapes]]
type = "quad"
corners = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
material = "light"
nee = true
"#;
    for backend in backends() {
        let img = render_scene(&scene(text), backend).image();
        for p in &img.pixels {
            assert_eq!(p.to_array(), [20.0, 10.0, 5.0], "{backend:?}");
        }
    }
    // Seen from behind, a one-sided emitter is black.
    let behind = text.replace("eye = [0, 0, 5]", "eye = [0, 0, -5]");
    for backend in backends() {
        let img = render_scene(&scene(&behind), backend).image();
        assert!(
            img.pixels.iter().all(|p| p.max_element() == 0.0),
            "{backend:?}"
        );
    }
}

const LIT_BOX: &str = r#"
[camera]
eye = [0, 1, 3.7]
target = [0, 1, 0]
resolution = [16, 16]
[render]
spp = 256
max_depth = 4
russian_roulette = false
[materials.white]
kd = 0.8
[materials.light]
emission = 10
[[shapes]]
type = "quad"
corners = [[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]]
material = "white"
[[shapes]]
type = "quad"
corners = [[-1, 0, -1], [1, 0, -1], [1, 2, -1], [-1, 2, -1]]
material = "white"
[[shapes]]
type = "sphere"
center = [0, 0.4, 0]
radius = 0.4
material = "white"
[[shapes]]
type = "LIGHT"
material = "light"
nee = NEE
"#;

#[test]
fn next_event_estimation_with_mis_counts_light_once() {
    // The same scene with the emitter sampled (NEE + MIS) and found only by
    // hitting it must converge to the same image mean.
    let lights = [
        "quad\"\ncorners = [[-0.5, 1.9, -0.5], [0.5, 1.9, -0.5], [0.5, 1.9, 0.5], [-0.5, 1.9, 0.5]]\n#\"",
        "sphere\"\ncenter = [0.5, 1.5, 0.3]\nradius = 0.2\n#\"",
    ];
    for light in lights {
        let with = LIT_BOX.replace("LIGHT", light).replace("NEE", "true");
        let without = LIT_BOX.replace("LIGHT", light).replace("NEE", "false");
        let a = render_scene(&scene(&with), BackendKind::Rust);
        let b = render_scene(&scene(&without), BackendKind::Rust);
        let (ma, sa) = mean_and_se(&a, 0);
        let (mb, sb) = mean_and_se(&b, 0);
        // Pixel means are not independent of one another, but each film's
        // per-sample spread bounds the error of its mean; 5 combined SE.
        let bound = 5.0 * (sa * sa + sb * sb).sqrt();
        assert!(
            (ma - mb).abs() < bound,
            "{light}: NEE {ma} ± {sa} vs hit-only {mb} ± {sb}"
        );
        assert!(ma > 0.01, "the light must light the scene: {ma}");
        // NEE must reduce the noise, or it is not doing its job.
        assert!(sa < sb, "NEE {sa} vs hit-only {sb}");
    }
}

#[test]
fn max_depth_counts_segments_like_mitsuba() {
    let text = LIT_BOX
        .replace("LIGHT", "quad\"\ncorners = [[-0.5, 1.9, -0.5], [0.5, 1.9, -0.5], [0.5, 1.9, 0.5], [-0.5, 1.9, 0.5]]\n#\"")
        .replace("NEE", "true");
    let means: Vec<f64> = [0u32, 1, 2, 3]
        .iter()
        .map(|&d| {
            let s = scene(&text.replace("max_depth = 4", &format!("max_depth = {d}")));
            mean_and_se(&render_scene(&s, BackendKind::Rust), 0).0
        })
        .collect();
    // 0: nothing; 1: only the light seen directly (from below, its front);
    // 2: plus direct light; 3: plus one indirect bounce. The random streams
    // are shared, so each sample can only gain from a deeper limit.
    assert_eq!(means[0], 0.0);
    assert!(means[1] > 0.0);
    assert!(means[2] > means[1] * 1.5, "{means:?}");
    assert!(means[3] > means[2] * 1.02, "{means:?}");
}

#[test]
fn same_image_for_one_and_two_threads() {
    let s = scene(
        &LIT_BOX
            .replace(
                "LIGHT",
                "sphere\"\ncenter = [0.5, 1.5, 0.3]\nradius = 0.2\n#\"",
            )
            .replace("NEE", "true")
            .replace("spp = 256", "spp = 16"),
    );
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render_scene(&s, BackendKind::Rust))
    };
    let one = run(1);
    let two = run(2);
    assert_eq!(one, two);
}
