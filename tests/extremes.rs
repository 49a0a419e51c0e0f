//! Numerical extremes, on every compiled backend (Embree with `embree_robust`
//! off and on): re-intersection of spheres from 1e-4 to 1e6, a scene far
//! from the origin, grazing rays, degenerate and sliver triangles, a closed
//! mesh probed from inside, renders at extreme settings and a 4096×4096
//! film, and non-finite samples kept out of written images. Every check
//! prints one row of a table:
//!
//! `extreme | backend | rays | self-hits | missed exits | escapes | non-finite`

mod common;

use common::embree_compiled;

use luz::accel::{Accel, Backend, BackendKind, BuildOptions};
use luz::geometry::Geometry;
use luz::geometry::{Mesh, Quad, Sphere};
use luz::image::io::{read, write, WriteOptions};
use luz::math::{reflect, spawn_ray, Ray, Rgb, Vec3};
use luz::render::{render_with, Film, PixelSum, RenderOptions};
use luz::sampling::{uniform_sphere, Rng};
use luz::scene::{load_str, Scene};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// Every backend configuration: native, and Embree with robust off and on.
fn configs() -> Vec<(&'static str, BackendKind, BuildOptions)> {
    let mut v = vec![("rust", BackendKind::Rust, BuildOptions::default())];
    if embree_compiled() {
        for (name, robust) in [("embree", false), ("embree-robust", true)] {
            v.push((
                name,
                BackendKind::Embree,
                BuildOptions {
                    embree_robust: robust,
                    ..BuildOptions::default()
                },
            ));
        }
    }
    v
}

thread_local! {
    /// This test's rows of the table (each test runs on its own thread).
    static ROWS: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
}

fn row(extreme: &str, backend: &str, rays: u64, self_hits: u64, missed: u64, esc: u64, nf: u64) {
    ROWS.with(|r| {
        r.borrow_mut().push(format!(
            "| {extreme:<34} | {backend:<13} | {rays:>9} | {self_hits:>9} | {missed:>12} | {esc:>7} | {nf:>10} |"
        ))
    });
}

/// Prints this test's table in one piece when dropped, also on a failed
/// assertion (tests run in parallel, so rows are not printed one by one).
struct Table;

impl Drop for Table {
    fn drop(&mut self) {
        print_table();
    }
}

fn print_table() {
    let rows = ROWS.with(|r| std::mem::take(&mut *r.borrow_mut()));
    let mut out = String::from(
        "| extreme                            | backend       |      rays | self-hits | missed exits | escapes | non-finite |\n",
    );
    for r in rows {
        out += &r;
        out.push('\n');
    }
    eprint!("{out}");
}

fn scene_of(shapes: Vec<Geometry>) -> Arc<Scene> {
    Arc::new(Scene::of_geometry(shapes))
}

/// Glass-like re-intersection of spheres of radius 1e-4, 1, 1e4 and 1e6,
/// centred at `r · (3, -1, 2)`: from 200 camera-side hit points per radius,
/// 1,000 uniformly random directions each (2e5 spawned rays, about 1e5
/// entering), spawned with `spawn_ray` from the scene's surface point.
/// Entering rays must hit the same sphere at `t > 0` no nearer than half
/// the exact chord `2r·cos θ` (closer is a self-hit, none is a missed exit);
/// for chords under 1e-4·r (cos θ < 5e-5) any hit at `t > 0` counts as the
/// exit. Leaving rays must hit nothing. Thresholds: 0 self-hits and 0 missed
/// exits on every backend and radius; at least 190 of 200 probes hit.
#[test]
fn sphere_reintersection_from_1e_minus4_to_1e6() {
    let _table = Table;
    let mut failures = Vec::new();
    for radius in [1e-4f32, 1.0, 1e4, 1e6] {
        let center = Vec3::new(3.0, -1.0, 2.0) * radius;
        let scene = scene_of(vec![Geometry::Sphere(Sphere { center, radius })]);
        for (name, kind, options) in configs() {
            let accel = Accel::build(&scene, kind, &options).unwrap();
            let mut rng = Rng::new(7, radius.to_bits() as u64);
            let (mut probes, mut rays, mut self_hits, mut missed, mut nf) = (0, 0u64, 0, 0, 0);
            for _ in 0..200 {
                let target = center + 0.9 * radius * uniform_sphere(rng.next_2d());
                let eye = center + 10.0 * radius * uniform_sphere(rng.next_2d());
                let ray = Ray::new(eye, (target - eye).normalize());
                let Some(hit) = accel.intersect(&ray) else {
                    continue;
                };
                probes += 1;
                let sp = scene.surface(&ray, &hit);
                if !(sp.p.is_finite() && sp.n.is_finite() && sp.p_err.is_finite()) {
                    nf += 1;
                    continue;
                }
                for _ in 0..1000 {
                    let w = uniform_sphere(rng.next_2d());
                    let r = spawn_ray(sp.p, sp.p_err, sp.n, w);
                    rays += 1;
                    let again = accel.intersect(&r);
                    let cos = -w.dot(sp.n);
                    if cos <= 0.0 {
                        if again.is_some() {
                            self_hits += 1;
                        }
                        continue;
                    }
                    let chord = 2.0 * radius * cos;
                    match again {
                        None => missed += 1,
                        Some(h) if !h.t.is_finite() => nf += 1,
                        Some(h) if h.t <= 0.0 => self_hits += 1,
                        Some(h) if chord < 1e-4 * radius => {
                            let _ = h;
                        }
                        Some(h) if h.t < 0.5 * chord => self_hits += 1,
                        Some(_) => {}
                    }
                }
            }
            row(
                &format!("sphere r={radius:e} reintersection"),
                name,
                rays,
                self_hits,
                missed,
                0,
                nf,
            );
            if probes < 190 || self_hits + missed + nf > 0 {
                failures.push(format!(
                    "r={radius:e} {name}: {probes} probes, {self_hits} self-hits, {missed} missed exits, {nf} non-finite"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

fn scene(text: &str) -> Arc<Scene> {
    Arc::new(load_str(text, Path::new("inline.toml")).expect("valid scene"))
}

/// Mean and standard error of the mean of the luminance-free channel sum
/// over all pixels and samples.
fn mean_and_se(film: &Film) -> (f64, f64) {
    let n = (film.samples * film.sum.len() as u64) as f64;
    let s: f64 = film.sum.iter().map(|p| p[0] + p[1] + p[2]).sum();
    // Upper bound on the variance of the channel sum: 3 × Σ per-channel.
    let q: f64 = film.sum_sq.iter().map(|p| p[0] + p[1] + p[2]).sum();
    let mean = s / n;
    let var = 3.0 * (q / n).max(0.0);
    (mean, (var / n).sqrt())
}

/// Renders `scene` on a backend config and checks the film: every pixel of
/// `image()` finite and `non_finite == 0`. Returns the film.
fn render_checked(
    scene: &Arc<Scene>,
    kind: BackendKind,
    options: &BuildOptions,
    what: &str,
    name: &str,
) -> Film {
    let accel = Accel::build(scene, kind, options).unwrap();
    let film = render_with(scene, &accel, &RenderOptions::from_scene(scene), &()).0;
    let img = film.image();
    let bad = (0..film.height)
        .flat_map(|y| (0..film.width).map(move |x| (x, y)))
        .filter(|&(x, y)| !img.get(x, y).is_finite())
        .count();
    row(what, name, 0, 0, 0, 0, film.non_finite + bad as u64);
    assert_eq!(film.non_finite, 0, "{what} on {name}: non-finite samples");
    assert_eq!(bad, 0, "{what} on {name}: non-finite pixels");
    film
}

fn floor_and_sphere(offset: Vec3, intensity: f32, extra: &str) -> String {
    let p = |x: f32, y: f32, z: f32| {
        let v = Vec3::new(x, y, z) + offset;
        format!("[{}, {}, {}]", v.x, v.y, v.z)
    };
    format!(
        r#"
[camera]
eye = {eye}
target = {target}
fov = 40
resolution = [12, 12]
{extra}
[materials.floor]
kd = 0.6
[materials.ball]
kd = 0.3
ks = 0.5
[[shapes]]
type = "quad"
corners = [{c0}, {c1}, {c2}, {c3}]
material = "floor"
[[shapes]]
type = "sphere"
center = {sc}
radius = 2
material = "ball"
[[lights]]
type = "point"
position = {lp}
intensity = {intensity}
"#,
        eye = p(0.0, 6.0, 14.0),
        target = p(0.0, 1.0, 0.0),
        c0 = p(-10.0, -1.0, 10.0),
        c1 = p(10.0, 1.0, 10.0),
        c2 = p(10.0, 1.0, -10.0),
        c3 = p(-10.0, -1.0, -10.0),
        sc = p(0.0, 2.5, 0.0),
        lp = p(3.0, 8.0, 4.0),
    )
}

/// A quad floor (20 units, tilted ~5.7° about z so one-ulp rounding of an
/// axis-aligned origin cannot hide a missing offset), a diffuse+mirror
/// sphere (radius 2) and a point
/// light, rendered at the origin and translated by (1e5, 1e5, -1e5)
/// (|offset| ≈ 1.7e5, where an f32 ulp is 0.0156): 12×12 pixels, 16 spp,
/// max_depth 6. The two image means must agree within 5 combined standard
/// errors plus 2% (geometry itself is only representable to ~1e-3 of the
/// scene size there); shadow acne from self-intersection would darken the
/// floor by far more (a zero offset drops the mean at 1e5 from ~0.33 to
/// ~0.19, checked by mutation). Both films finite with no non-finite samples.
#[test]
fn scene_translated_to_1e5_renders_the_same_mean() {
    let _table = Table;
    let settings = "[render]\nspp = 16\nmax_depth = 6\nseed = 3\n";
    let near = scene(&floor_and_sphere(Vec3::ZERO, 100.0, settings));
    let far = scene(&floor_and_sphere(
        Vec3::new(1e5, 1e5, -1e5),
        100.0,
        settings,
    ));
    for (name, kind, options) in configs() {
        let a = render_checked(&near, kind, &options, "floor+sphere at origin", name);
        let b = render_checked(&far, kind, &options, "floor+sphere at 1e5", name);
        let (ma, sa) = mean_and_se(&a);
        let (mb, sb) = mean_and_se(&b);
        let bound = 5.0 * (sa * sa + sb * sb).sqrt() + 0.02 * ma;
        eprintln!("  {name}: mean at origin {ma:.5} ± {sa:.5}, at 1e5 {mb:.5} ± {sb:.5}, bound {bound:.5}");
        assert!(ma > 0.1, "{name}: the scene must be lit ({ma})");
        assert!(
            (ma - mb).abs() < bound,
            "{name}: {ma} vs {mb} (bound {bound})"
        );
    }
}

fn orthonormal(n: Vec3) -> (Vec3, Vec3) {
    let f = luz::math::Frame::from_normal(n);
    (f.s, f.t)
}

/// Grazing rays on a quad and on a single triangle (both about 2 units, at
/// scales 1 and 1e4, random orientation): rays reach interior points (at
/// least 10% from every edge) at elevation angles 1e-1 .. 1e-6 rad from the
/// surface plane, 2,000 per angle. Then from each hit, three rays spawned
/// with `spawn_ray`: the mirror direction, the straight continuation and a
/// random direction. Thresholds: no NaN/Inf in t, u, v, p, n; 0 self-hits
/// (a flat shape can never be hit again by a ray leaving it); at least
/// 99.9% of the probes hit (a miss of an interior point is a lost hit).
#[test]
fn grazing_rays_down_to_1e_minus6_rad() {
    let _table = Table;
    let mut failures = Vec::new();
    for scale in [1.0f32, 1e4] {
        let mut rng = Rng::new(21, scale.to_bits() as u64);
        let n = uniform_sphere(rng.next_2d());
        let (s, t) = orthonormal(n);
        let origin = Vec3::new(0.7, -0.3, 0.2) * scale;
        let quad = Quad::new(origin, 2.0 * scale * s, 1.5 * scale * t).unwrap();
        let tri = Mesh {
            positions: vec![origin, origin + 2.0 * scale * s, origin + 2.0 * scale * t],
            indices: vec![[0, 1, 2]],
            uvs: None,
        };
        for (shape_name, g) in [
            ("quad", Geometry::Quad(quad)),
            ("triangle", Geometry::Mesh(tri)),
        ] {
            let scene = scene_of(vec![g]);
            for (name, kind, options) in configs() {
                let accel = Accel::build(&scene, kind, &options).unwrap();
                let (mut probes, mut hits, mut rays, mut self_hits, mut nf) =
                    (0u64, 0u64, 0u64, 0u64, 0u64);
                for k in 1..=6 {
                    let angle = 10f32.powi(-k);
                    for _ in 0..2000 {
                        // Interior point: barycentric-ish coordinates in [0.1, 0.4]
                        // (inside the triangle too, since a + b <= 0.8).
                        let (a, b) = (0.1 + 0.3 * rng.next_f32(), 0.1 + 0.3 * rng.next_f32());
                        let target = origin + 2.0 * scale * a * s + 1.5 * scale * b * t;
                        let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
                        let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
                        let along = phi.cos() * s + phi.sin() * t;
                        let d = (angle.cos() * along - side * angle.sin() * n).normalize();
                        let eye = target - 0.5 * scale * d;
                        let ray = Ray::new(eye, d);
                        probes += 1;
                        let Some(hit) = accel.intersect(&ray) else {
                            continue;
                        };
                        hits += 1;
                        if !(hit.t.is_finite() && hit.u.is_finite() && hit.v.is_finite()) {
                            nf += 1;
                            continue;
                        }
                        let sp = scene.surface(&ray, &hit);
                        if !(sp.p.is_finite() && sp.n.is_finite() && sp.p_err.is_finite()) {
                            nf += 1;
                            continue;
                        }
                        let mirror = reflect(-d, sp.n);
                        for w in [mirror, d, uniform_sphere(rng.next_2d())] {
                            let r = spawn_ray(sp.p, sp.p_err, sp.n, w.normalize());
                            rays += 1;
                            if !r.origin.is_finite() || !r.dir.is_finite() {
                                nf += 1;
                            } else if accel.intersect(&r).is_some() {
                                self_hits += 1;
                            }
                        }
                    }
                }
                let lost = probes - hits;
                row(
                    &format!("grazing {shape_name} scale {scale:e}"),
                    name,
                    rays,
                    self_hits,
                    lost,
                    0,
                    nf,
                );
                if nf > 0 || self_hits > 0 || lost * 1000 > probes {
                    failures.push(format!(
                        "{shape_name} scale {scale:e} {name}: {nf} non-finite, {self_hits} self-hits, {lost} of {probes} probes lost"
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Unit icosphere-like closed mesh: an octahedron subdivided `levels` times
/// with shared vertices (watertight by construction), projected onto the
/// sphere of `radius` around `center`.
fn octasphere(levels: u32, center: Vec3, radius: f32) -> Mesh {
    let mut positions = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let mut indices: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(indices.len() * 4);
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        for [a, b, c] in indices {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        indices = next;
    }
    Mesh {
        positions: positions.iter().map(|&p| center + radius * p).collect(),
        indices,
        uvs: None,
    }
}

/// A closed octasphere of 8,192 triangles (5 subdivisions), radius 1 at the
/// origin and radius 1e3 centred at (2e3, -1e3, 1e3), probed by 1e6 rays per
/// backend and placement from points uniform in the inner ball of half the
/// radius, in uniformly random directions (a tenth exactly axis-parallel).
/// An escape is a ray that hits nothing. Thresholds: 0 escapes on the
/// native backend and on Embree with `embree_robust`; Embree without it is
/// reported and must stay under 1e-4 of the rays.
#[test]
fn closed_mesh_probed_from_inside_never_leaks() {
    let _table = Table;
    let mut failures = Vec::new();
    for (center, radius) in [(Vec3::ZERO, 1.0f32), (Vec3::new(2e3, -1e3, 1e3), 1e3)] {
        let mesh = octasphere(5, center, radius);
        assert_eq!(mesh.indices.len(), 8192);
        let scene = scene_of(vec![Geometry::Mesh(mesh)]);
        for (name, kind, options) in configs() {
            let accel = Accel::build(&scene, kind, &options).unwrap();
            let mut rng = Rng::new(99, radius.to_bits() as u64);
            let n = 1_000_000u64;
            let mut escapes = 0u64;
            for _ in 0..n {
                let o =
                    center + 0.5 * radius * uniform_sphere(rng.next_2d()) * rng.next_f32().cbrt();
                let mut d = uniform_sphere(rng.next_2d());
                if rng.next_f32() < 0.1 {
                    let mut a = Vec3::ZERO;
                    a[(rng.next_u32() % 3) as usize] =
                        if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
                    d = a;
                }
                if accel.intersect(&Ray::new(o, d)).is_none() {
                    escapes += 1;
                }
            }
            row(
                &format!("closed mesh r={radius:e} from inside"),
                name,
                n,
                0,
                0,
                escapes,
                0,
            );
            let allowed = if name == "embree" { n / 10_000 } else { 0 };
            if escapes > allowed {
                failures.push(format!(
                    "r={radius:e} {name}: {escapes} of {n} rays escaped"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Render extremes on every backend, each film finite with `non_finite ==
/// 0`: (a) point-light intensities 1e-6, 1e-3, 1e3, 1e6, 1e9 against 1:
/// with the same
/// seed the paths are identical, so mean/intensity must match the
/// intensity-1 mean within 1e-4 relative (f32 rounding); (b) `max_depth = 0`
/// (documented: renders black) gives an all-zero image although
/// `max_depth = 1` of the same scene (environment visible) does not;
/// (c) `max_depth = 1000` inside a closed box of albedo 0.95 with a glass
/// ball, Russian roulette on and off: terminates, and the two means agree
/// within 6 combined standard errors; (d) 1 spp on a 1×1 image.
#[test]
fn render_extremes_stay_finite() {
    let _table = Table;
    // (a) intensity sweep.
    for (name, kind, options) in configs() {
        let settings = "[render]\nspp = 4\nmax_depth = 4\nseed = 9\n";
        let base = render_checked(
            &scene(&floor_and_sphere(Vec3::ZERO, 1.0, settings)),
            kind,
            &options,
            "point light I=1",
            name,
        );
        let (m1, _) = mean_and_se(&base);
        assert!(m1 > 0.0);
        for intensity in [1e-6f32, 1e-3, 1e3, 1e6, 1e9] {
            let film = render_checked(
                &scene(&floor_and_sphere(Vec3::ZERO, intensity, settings)),
                kind,
                &options,
                &format!("point light I={intensity:e}"),
                name,
            );
            let (m, _) = mean_and_se(&film);
            let ratio = m / intensity as f64 / m1;
            eprintln!("  {name}: I={intensity:e} mean/I over mean(I=1) = {ratio}");
            assert!(
                (ratio - 1.0).abs() < 1e-4,
                "{name} I={intensity:e}: ratio {ratio}"
            );
        }
    }

    // (b) max_depth 0 and 1.
    let sky = |depth: u32| {
        format!(
            r#"
[camera]
eye = [0, 0, 5]
target = [0, 0, 0]
fov = 40
resolution = [8, 8]
[render]
spp = 2
max_depth = {depth}
[materials.light]
emission = 3
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "light"
[environment]
radiance = [1, 2, 3]
"#
        )
    };
    for (name, kind, options) in configs() {
        let zero = render_checked(&scene(&sky(0)), kind, &options, "max_depth 0", name);
        assert!(
            zero.sum.iter().all(|p| *p == [0.0; 3]),
            "{name}: max_depth 0 must render black"
        );
        let one = render_checked(&scene(&sky(1)), kind, &options, "max_depth 1", name);
        assert!(
            mean_and_se(&one).0 > 1.0,
            "{name}: max_depth 1 sees the sky"
        );
    }

    // (c) max_depth 1000 in a closed box.
    let deep = |rr: bool| {
        format!(
            r#"
[camera]
eye = [0, 0, 3]
target = [0, 0, 0]
fov = 60
resolution = [8, 8]
[render]
spp = 8
max_depth = 1000
russian_roulette = {rr}
seed = 5
[materials.wall]
kd = 0.95
[materials.glass]
type = "glass"
[[shapes]]
type = "cuboid"
min = [-4, -4, -4]
max = [4, 4, 4]
material = "wall"
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "glass"
[[lights]]
type = "point"
position = [1, 2, 2]
intensity = 10
"#
        )
    };
    for (name, kind, options) in configs() {
        let on = render_checked(
            &scene(&deep(true)),
            kind,
            &options,
            "max_depth 1000 RR on",
            name,
        );
        let off = render_checked(
            &scene(&deep(false)),
            kind,
            &options,
            "max_depth 1000 RR off",
            name,
        );
        let (a, sa) = mean_and_se(&on);
        let (b, sb) = mean_and_se(&off);
        eprintln!("  {name}: depth 1000 RR on {a:.4} ± {sa:.4}, off {b:.4} ± {sb:.4}");
        assert!(a > 0.0 && b > 0.0);
        assert!(
            (a - b).abs() < 6.0 * (sa * sa + sb * sb).sqrt(),
            "{name}: {a} vs {b}"
        );
    }

    // (d) 1 spp, 1x1.
    let tiny = floor_and_sphere(Vec3::ZERO, 100.0, "[render]\nspp = 1\n")
        .replace("resolution = [12, 12]", "resolution = [1, 1]");
    for (name, kind, options) in configs() {
        let film = render_checked(&scene(&tiny), kind, &options, "1 spp, 1x1", name);
        assert_eq!((film.width, film.height, film.samples), (1, 1, 1));
    }
}

/// A unit square in a random plane, cut into 2,048 vertical strips each
/// split along its diagonal (4,096 slivers of aspect ratio 2,048, sharing
/// vertices), plus 4,094 degenerate triangles on the strips' edges: one
/// with a repeated vertex and one with three collinear vertices per edge.
/// The mesh goes through the PLY loader, which must drop exactly the
/// degenerate ones (kept, they gave zero or random normals and hundreds of
/// self-hits on every backend). Probes: 50,000 rays from either side at
/// elevations 0.05 to 1.5 rad, half aimed exactly at points of the inner
/// strip edges (shared by two slivers, where a test that is not watertight
/// can let a ray through), half anywhere inside (at least 1% from the
/// border). From each hit, the mirror and a random direction are spawned
/// with `spawn_ray`. Thresholds: on every backend t, u, v, p, n finite,
/// |n| = 1 and 0 lost interior probes; 0 self-hits on the native backend
/// and Embree robust, under 1e-4 of the rays on Embree without
/// `embree_robust`; 0 lost edge probes on the native backend (watertight)
/// and Embree robust. Edge probes lost by Embree without `embree_robust`
/// are reported.
#[test]
fn sliver_and_degenerate_triangles() {
    let _table = Table;
    let strips = 2048u32;
    let mut rng = Rng::new(17, 5);
    let n = uniform_sphere(rng.next_2d());
    let (s, t) = orthonormal(n);
    let origin = Vec3::new(0.3, -0.2, 0.5);
    let at = |x: f32, y: f32| origin + x * s + y * t;
    // Vertices: bottom row 0..=strips, top row from `top`, and a midpoint
    // on each inner edge for the collinear triangles.
    let mut positions = Vec::new();
    for row in [0.0, 1.0] {
        for k in 0..=strips {
            positions.push(at(k as f32 / strips as f32, row));
        }
    }
    let top = strips + 1;
    let mid = positions.len() as u32;
    for k in 1..strips {
        positions.push(at(k as f32 / strips as f32, 0.5));
    }
    let mut indices = Vec::new();
    for k in 0..strips {
        indices.push([k, k + 1, top + k + 1]);
        indices.push([k, top + k + 1, top + k]);
    }
    let slivers = indices.len();
    for k in 1..strips {
        indices.push([k, k, top + k]);
        indices.push([k, mid + k - 1, top + k]);
    }
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar uint vertex_indices\nend_header\n",
        positions.len(),
        indices.len()
    )
    .into_bytes();
    ply.extend(
        positions
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes),
    );
    for tri in &indices {
        ply.push(3);
        ply.extend(tri.iter().flat_map(|i| i.to_le_bytes()));
    }
    let mesh = luz::scene::mesh_io::parse_mesh(&ply, Path::new("slivers.ply")).unwrap();
    assert_eq!(
        mesh.indices,
        indices[..slivers],
        "the loader drops exactly the degenerate triangles"
    );
    let scene = scene_of(vec![Geometry::Mesh(mesh)]);
    let mut failures = Vec::new();
    for (name, kind, options) in configs() {
        let accel = Accel::build(&scene, kind, &options).unwrap();
        let mut rng = Rng::new(23, 1);
        let (mut probes, mut rays, mut self_hits, mut nf) = (0u64, 0u64, 0u64, 0u64);
        let (mut lost_edge, mut lost_inside) = (0u64, 0u64);
        for i in 0..50_000 {
            let on_edge = i % 2 == 0;
            let y = 0.01 + 0.98 * rng.next_f32();
            let x = if on_edge {
                (1 + rng.next_u32() % (strips - 1)) as f32 / strips as f32
            } else {
                0.01 + 0.98 * rng.next_f32()
            };
            let target = at(x, y);
            let elevation = 0.05 + 1.45 * rng.next_f32();
            let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
            let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
            let along = phi.cos() * s + phi.sin() * t;
            let d = (elevation.cos() * along - side * elevation.sin() * n).normalize();
            let ray = Ray::new(target - 2.0 * d, d);
            probes += 1;
            let Some(hit) = accel.intersect(&ray) else {
                if on_edge {
                    lost_edge += 1;
                } else {
                    lost_inside += 1;
                }
                continue;
            };
            let sp = scene.surface(&ray, &hit);
            let finite = hit.t.is_finite() && hit.u.is_finite() && hit.v.is_finite();
            let unit = (sp.n.length() - 1.0).abs() < 1e-3;
            if !(finite && sp.p.is_finite() && sp.p_err.is_finite() && unit) {
                nf += 1;
                continue;
            }
            let mirror = reflect(-d, sp.n);
            for w in [mirror, uniform_sphere(rng.next_2d())] {
                rays += 1;
                if accel
                    .intersect(&spawn_ray(sp.p, sp.p_err, sp.n, w))
                    .is_some()
                {
                    self_hits += 1;
                }
            }
        }
        let lost = lost_edge + lost_inside;
        row(
            "slivers (degenerate dropped)",
            name,
            rays,
            self_hits,
            lost,
            0,
            nf,
        );
        eprintln!(
            "  {name}: {lost_edge} of {} edge probes and {lost_inside} of {} interior probes lost",
            probes / 2,
            probes / 2
        );
        let edge_ok = name == "embree" || lost_edge == 0;
        let self_hits_allowed = if name == "embree" { rays / 10_000 } else { 0 };
        if nf > 0 || self_hits > self_hits_allowed || lost_inside > 0 || !edge_ok {
            failures.push(format!(
                "{name}: {nf} non-finite, {self_hits} self-hits, {lost_inside} interior and {lost_edge} edge probes lost"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// VmHWM (peak resident memory) of this process, in bytes.
fn peak_rss() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().strip_suffix("kB"))
        .and_then(|v| v.trim().parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// A 4096×4096 film at 1 spp (a sphere on a bright sky: one camera ray per
/// sample) on every backend. The film holds exactly two `[f64; 3]` per pixel
/// (sum and sum of squares, 48 bytes: 805 MB); the peak resident memory of
/// the whole test process, reported, must stay under the film plus its
/// 12-byte-per-pixel image plus 512 MiB (a second copy of the film would
/// exceed it). Every pixel finite, no non-finite sample.
#[test]
fn film_4096_squared_memory_is_bounded() {
    let _table = Table;
    let scene = scene(
        r#"
[camera]
eye = [0, 0, 5]
target = [0, 0, 0]
fov = 40
resolution = [4096, 4096]
[render]
spp = 1
max_depth = 2
[materials.ball]
kd = 0.5
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "ball"
[environment]
radiance = [1, 2, 3]
"#,
    );
    let pixels = 4096u64 * 4096;
    let film_bytes = 2 * pixels * std::mem::size_of::<[f64; 3]>() as u64;
    let image_bytes = pixels * std::mem::size_of::<Vec3>() as u64;
    for (name, kind, options) in configs() {
        let film = render_checked(&scene, kind, &options, "4096x4096 film, 1 spp", name);
        let held = (film.sum.capacity() + film.sum_sq.capacity()) as u64
            * std::mem::size_of::<[f64; 3]>() as u64;
        let peak = peak_rss();
        eprintln!(
            "  {name}: film {:.1} MB ({} bytes/pixel), peak RSS of the test process {:.1} MB",
            held as f64 / 1e6,
            held / pixels,
            peak as f64 / 1e6
        );
        assert_eq!(
            held, film_bytes,
            "{name}: the film holds 48 bytes per pixel"
        );
        assert!(
            peak < film_bytes + image_bytes + (512 << 20),
            "{name}: peak RSS {peak} bytes"
        );
    }
}

/// Non-finite samples (NaN, +∞, -∞) fed to the film's pixel accumulator
/// are counted and left out; the film's image and every image file written
/// from it (EXR, HDR, PPM, PNG) are finite and read back finite, with each
/// pixel the mean of its finite samples over all samples taken.
#[test]
fn non_finite_samples_are_counted_and_never_written() {
    let _table = Table;
    let (w, h, spp) = (4u32, 3u32, 4u64);
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    let mut film = Film::new(w, h);
    film.samples = spp;
    let mut injected = 0;
    for (i, (sum, sq)) in film.sum.iter_mut().zip(&mut film.sum_sq).enumerate() {
        let mut px = PixelSum::default();
        for s in 0..spp as usize {
            if (i + s) % 3 == 0 {
                let mut l = Rgb::splat(0.5);
                l[s % 3] = bad[(i + s) % 3];
                px.add(l);
                injected += 1;
            } else {
                px.add(Rgb::new(1.0, 2.0, 3.0));
            }
        }
        film.non_finite += px.non_finite;
        *sum = px.sum;
        *sq = px.sum_sq;
    }
    row(
        "injected NaN/Inf samples",
        "film",
        0,
        0,
        0,
        0,
        film.non_finite,
    );
    assert_eq!(film.non_finite, injected);
    let img = film.image();
    for (i, p) in img.pixels.iter().enumerate() {
        let good = (0..spp as usize).filter(|s| (i + s) % 3 != 0).count() as f32;
        let want = Rgb::new(1.0, 2.0, 3.0) * good / spp as f32;
        assert_eq!(*p, want, "pixel {i}");
    }
    let dir = std::env::temp_dir().join(format!("luz-extremes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for ext in ["exr", "hdr", "ppm", "png"] {
        let path = dir.join(format!("injected.{ext}"));
        write(&path, &img, &WriteOptions::default()).unwrap();
        let back = read(&path).unwrap();
        assert!(back.pixels.iter().all(|p| p.is_finite()), "{ext}");
        assert_eq!((back.width, back.height), (w, h));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
