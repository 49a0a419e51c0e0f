//! Backend benchmarks on the Stanford bunny (69,451 triangles), Lucy
//! (99,970) and the dragon (202,520) from `$LUZ_ASSETS` (default
//! `../shared/assets`; a missing mesh is skipped with a message):
//!
//! - `build/MESH/BACKEND`: building the backend for the mesh in the bunny's
//!   Cornell box; the native binned SAH and Embree at low, medium and high
//!   quality. Throughput in triangles/s.
//! - `traversal/MESH/RAYS/THREADS/BACKEND`: three ray sets made once, the
//!   same for every backend: camera rays (one per pixel of a 256×256 image),
//!   cosine-distributed bounce rays from their first hits, and shadow rays
//!   from those hits towards the middle of the light; traced on one thread
//!   and on all of rayon's. Throughput in rays/s; on one thread, per second
//!   of that thread's CPU time (Unix), which time spent waiting for a core
//!   on a busy machine does not inflate.
//!
//! Lucy and the dragon take the bunny's place in `scenes/bunny.toml`, scaled
//! to its largest extent and standing where it stands, so the ray sets are
//! alike.

use crate::assets::assets;
use criterion::measurement::WallTime;
use criterion::{black_box, BenchmarkGroup, Criterion, SamplingMode, Throughput};
use luz::accel::{Accel, Backend, BackendKind, BuildOptions, Quality};
use luz::geometry::Geometry;
use luz::math::{spawn_ray, spawn_ray_to, Aabb, Frame, Mat4, PackedVec3, Ray, Vec2, Vec3};
use luz::render::build_accel;
use luz::sampling::{cosine_hemisphere, Rng};
use luz::scene::Scene;
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

const MESHES: [(&str, &str); 3] = [
    ("bunny", "stanford/bunny/bun_zipper.ply"),
    ("lucy", "stanford/lucy/lucy.ply"),
    ("dragon", "stanford/dragon/dragon_vrip_res2.ply.gz"),
];

/// Where the light of `scenes/bunny.toml` sits: shadow rays aim at it.
const LIGHT: Vec3 = Vec3::new(0.0, 1.98, 0.0);

/// One mesh in the bunny's box, with its ray sets.
struct Case {
    name: &'static str,
    scene: Arc<Scene>,
    triangles: u64,
    rays: RaySets,
}

struct RaySets {
    camera: Vec<Ray>,
    bounce: Vec<Ray>,
    shadow: Vec<Ray>,
}

/// The meshes that `$LUZ_ASSETS` has, each in the bunny scene.
fn cases() -> Vec<Case> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml");
    let bunny = match luz::scene::load(&path) {
        Ok(scene) => scene,
        Err(e) => {
            eprintln!("skipped the backend benchmarks: {e}");
            return Vec::new();
        }
    };
    let bunny_bounds = mesh_bounds(&bunny);
    MESHES
        .iter()
        .filter_map(|&(name, file)| {
            let mut scene = bunny.clone();
            if name != "bunny" {
                let mut mesh = luz::scene::mesh_io::load_mesh(&assets().join(file))
                    .map_err(|e| eprintln!("skipped {name}: {e}"))
                    .ok()?;
                let from = Aabb::from_points(&mesh.positions);
                mesh.transform(&fit(from, bunny_bounds));
                *mesh_slot(&mut scene) = Geometry::from(mesh);
            }
            let triangles = match mesh_slot(&mut scene) {
                Geometry::Mesh(m) => m.triangle_count() as u64,
                _ => unreachable!("mesh_slot returns the mesh"),
            };
            let rays = ray_sets(&scene);
            Some(Case {
                name,
                scene: Arc::new(scene),
                triangles,
                rays,
            })
        })
        .collect()
}

/// The bunny scene's last shape, its mesh.
fn mesh_slot(scene: &mut Scene) -> &mut Geometry {
    let geometry = &mut scene.shapes.last_mut().expect("the bunny").geometry;
    assert!(matches!(geometry, Geometry::Mesh(_)), "the bunny is a mesh");
    geometry
}

fn mesh_bounds(scene: &Scene) -> Aabb {
    match &scene.shapes.last().expect("the bunny").geometry {
        Geometry::Mesh(m) => Aabb::from_points(&m.positions),
        _ => panic!("the bunny scene's last shape is its mesh"),
    }
}

/// Uniform scale and translation taking `from` to `to`'s largest extent,
/// centred on it horizontally and resting on its bottom.
fn fit(from: Aabb, to: Aabb) -> Mat4 {
    let scale = to.extent().max_element() / from.extent().max_element();
    let anchor = |b: Aabb| PackedVec3::new(b.centroid().x, b.min.y, b.centroid().z);
    Mat4::from_translation(anchor(to))
        * Mat4::from_scale(PackedVec3::splat(scale))
        * Mat4::from_translation(-anchor(from))
}

/// Camera rays through every pixel of a 256×256 image (jittered), and from
/// each first hit one cosine-distributed bounce ray and one shadow ray to
/// the light. Fixed seeds and the native backend's hits: the same rays on
/// every run.
fn ray_sets(scene: &Scene) -> RaySets {
    let native = build_accel(scene, BackendKind::Rust, &BuildOptions::default())
        .expect("the native backend builds");
    let mut cam = scene.camera.clone();
    cam.width = 256;
    cam.height = 256;
    let basis = cam.basis();
    let mut rng = Rng::new(5, 6);
    let mut sets = RaySets {
        camera: Vec::new(),
        bounce: Vec::new(),
        shadow: Vec::new(),
    };
    for y in 0..cam.height {
        for x in 0..cam.width {
            let ray = cam.ray(&basis, Vec2::new(x as f32, y as f32) + rng.next_2d());
            sets.camera.push(ray);
            let Some(hit) = native.intersect(&ray) else {
                continue;
            };
            let sp = scene.surface(&ray, &hit);
            let n = if sp.n.dot(ray.dir) < 0.0 { sp.n } else { -sp.n };
            let dir = Frame::from_normal(n).to_world(cosine_hemisphere(rng.next_2d()));
            sets.bounce.push(spawn_ray(sp.p, sp.p_err, n, dir));
            sets.shadow
                .push(spawn_ray_to(sp.p, sp.p_err, n, LIGHT, Vec3::ZERO, -Vec3::Y));
        }
    }
    sets
}

/// The compiled backends, each with the build options to bench it with:
/// the native BVH, and Embree at every quality.
fn build_variants() -> Vec<(String, BackendKind, BuildOptions)> {
    let mut variants = vec![(
        "rust".to_string(),
        BackendKind::Rust,
        BuildOptions::default(),
    )];
    if luz::accel::compiled_backends().contains(&"embree") {
        for quality in [Quality::Low, Quality::Medium, Quality::High] {
            let options = BuildOptions {
                embree_quality: quality,
                ..BuildOptions::default()
            };
            variants.push((
                format!("embree-{}", quality.name()),
                BackendKind::Embree,
                options,
            ));
        }
    }
    variants
}

/// Few samples of whole operations: builds and ray sets take milliseconds,
/// and criterion's default 100 samples would take minutes per figure.
fn group<'a>(c: &'a mut Criterion, name: &str) -> BenchmarkGroup<'a, WallTime> {
    let mut group = c.benchmark_group(name);
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    group
}

fn builds(c: &mut Criterion, cases: &[Case]) {
    let mut group = group(c, "build");
    for case in cases {
        group.throughput(Throughput::Elements(case.triangles));
        for (name, kind, options) in build_variants() {
            group.bench_function(format!("{}/{name}", case.name), |b| {
                b.iter(|| build_accel(&case.scene, kind, &options).expect("builds"))
            });
        }
    }
    group.finish();
}

fn traversal(c: &mut Criterion, cases: &[Case]) {
    let mut group = group(c, "traversal");
    for case in cases {
        let accels: Vec<(&str, Accel)> = luz::accel::compiled_backends()
            .into_iter()
            .map(|name| {
                let kind = name.parse().expect("compiled backends parse");
                let accel = build_accel(&case.scene, kind, &BuildOptions::default());
                (name, accel.expect("builds"))
            })
            .collect();
        for (what, rays) in [
            ("camera", &case.rays.camera),
            ("bounce", &case.rays.bounce),
            ("shadow", &case.rays.shadow),
        ] {
            let shadow = what == "shadow";
            group.throughput(Throughput::Elements(rays.len() as u64));
            for (backend, accel) in &accels {
                // Counting hits keeps the traversal from being optimised away.
                let trace = |r: &Ray| {
                    if shadow {
                        accel.occluded(r)
                    } else {
                        accel.intersect(r).is_some()
                    }
                };
                let id = |threads| format!("{}/{what}/{threads}/{backend}", case.name);
                group.bench_function(id("1-thread"), |b| {
                    b.iter_custom(|iterations| {
                        let start = thread_cpu_time();
                        for _ in 0..iterations {
                            black_box(rays.iter().filter(|r| trace(r)).count());
                        }
                        thread_cpu_time() - start
                    })
                });
                group.bench_function(id("all-threads"), |b| {
                    b.iter(|| rays.par_iter().filter(|r| trace(r)).count())
                });
            }
        }
    }
    group.finish();
}

/// CPU time the calling thread has run.
#[cfg(unix)]
fn thread_cpu_time() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec for clock_gettime to fill.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

/// Elsewhere, wall time since the first call.
#[cfg(not(unix))]
fn thread_cpu_time() -> Duration {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    START.get_or_init(std::time::Instant::now).elapsed()
}

pub fn backends(c: &mut Criterion) {
    let cases = cases();
    builds(c, &cases);
    traversal(c, &cases);
}
