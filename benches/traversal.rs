//! Native BVH benchmarks: build time, closest-hit and any-hit throughput on
//! incoherent rays, and (with `-- render`) the bunny render at the project's
//! reference settings (512x512, 64 spp, max depth 5, no Russian roulette).
//!
//! `cargo bench --bench traversal` runs the criterion groups;
//! `cargo bench --bench traversal -- rays` prints Mrays/s and build times
//! once; `RAYON_NUM_THREADS=2 cargo bench --bench traversal -- render` times
//! the render. The bunny comes from `$LUZ_ASSETS` (default
//! `../shared/assets`); without it the benchmark says so and skips.

use criterion::{black_box, Criterion, Throughput};
use luz::accel::bvh::{BuildQuality, Bvh};
use luz::accel::native::NativeBackend;
use luz::accel::{Accel, Backend, BackendKind, BuildOptions};
use luz::math::{Aabb, Ray, Vec3};
use luz::sampling::{uniform_sphere, Rng};
use luz::scene::shape::Mesh;
use luz::scene::{Geometry, Scene};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

fn assets() -> PathBuf {
    std::env::var_os("LUZ_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets"))
}

/// The bunny scene of scenes/bunny.toml; `None` (the benchmark skips) when
/// `$LUZ_ASSETS` lacks the bunny.
fn bunny_scene() -> Option<Scene> {
    if std::env::var_os("LUZ_ASSETS").is_none() {
        std::env::set_var("LUZ_ASSETS", assets());
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml");
    luz::scene::load(&path)
        .map_err(|e| eprintln!("skipped: {e}"))
        .ok()
}

fn triangle_boxes(mesh: &Mesh) -> Vec<Aabb> {
    (0..mesh.triangle_count() as u32)
        .map(|i| mesh.triangle_bounds(i))
        .collect()
}

/// Rays from random points in the box towards random directions, and
/// shadow segments between random points: both incoherent.
fn rays(n: usize) -> (Vec<Ray>, Vec<Ray>) {
    let mut rng = Rng::new(1, 2);
    let mut p = || {
        Vec3::new(
            rng.next_f32() * 1.9 - 0.95,
            rng.next_f32() * 1.9 + 0.05,
            rng.next_f32() * 1.9 - 0.95,
        )
    };
    let pts: Vec<(Vec3, Vec3)> = (0..n).map(|_| (p(), p())).collect();
    let mut rng = Rng::new(3, 4);
    let closest = pts
        .iter()
        .map(|&(a, _)| Ray::new(a, uniform_sphere(rng.next_2d())))
        .collect();
    let shadow = pts
        .iter()
        .map(|&(a, b)| Ray::segment(a, b - a, 1.0 - 1e-4))
        .collect();
    (closest, shadow)
}

/// Seconds this thread has spent on a CPU (Linux; wall time elsewhere):
/// the machine is shared, and CPU time is far less noisy than wall time.
fn cpu_time(start: Instant) -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .map(|ns| ns as f64 * 1e-9)
        .unwrap_or_else(|| start.elapsed().as_secs_f64())
}

/// Mrays/s per CPU-second of `f` (which traces `n` rays), and its result.
/// Rays as a path tracer casts them: camera rays (one per pixel of a
/// 512x512 image), then two diffuse bounces, with a shadow ray towards the
/// light's middle from every hit.
fn render_rays(scene: &Scene) -> RaySets {
    use luz::math::{spawn_ray, spawn_ray_to, Frame};
    let b = NativeBackend::new(Arc::new(scene.clone()));
    let cam = &scene.camera;
    let basis = cam.basis();
    let mut rng = Rng::new(5, 6);
    let light = Vec3::new(0.0, 1.98, 0.0);
    let (mut camera, mut bounce, mut shadow) = (Vec::new(), Vec::new(), Vec::new());
    for y in 0..512 {
        for x in 0..512 {
            let px =
                luz::math::Vec2::new(x as f32, y as f32) * cam.width as f32 / 512.0 + rng.next_2d();
            let mut ray = cam.ray(&basis, px);
            for depth in 0..3 {
                if depth == 0 {
                    camera.push(ray);
                } else {
                    bounce.push(ray);
                }
                let Some(hit) = b.intersect(&ray) else { break };
                let sp = scene.surface(&ray, &hit);
                let n = if sp.n.dot(ray.dir) < 0.0 { sp.n } else { -sp.n };
                shadow.push(spawn_ray_to(sp.p, sp.p_err, n, light, Vec3::ZERO, -Vec3::Y));
                let d =
                    Frame::from_normal(n).to_world(luz::sampling::cosine_hemisphere(rng.next_2d()));
                ray = spawn_ray(sp.p, sp.p_err, n, d);
            }
        }
    }
    RaySets {
        camera,
        bounce,
        shadow,
    }
}

/// The rays of `render_rays`, by kind.
struct RaySets {
    camera: Vec<Ray>,
    bounce: Vec<Ray>,
    shadow: Vec<Ray>,
}

/// Mrays/s of every compiled backend on each ray kind, on one thread (per
/// CPU-second) and on all threads (wall time).
fn print_backend_rays(scene: &Arc<Scene>, sets: &RaySets) {
    use rayon::prelude::*;
    for name in luz::accel::compiled_backends() {
        let kind: BackendKind = name.parse().expect("compiled backends parse");
        let start = Instant::now();
        let accel = Accel::build(scene, kind, &BuildOptions::default()).expect("builds");
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut line = format!("{name} (build {build_ms:.1} ms):");
        for (what, rays, shadow) in [
            ("camera", &sets.camera, false),
            ("bounce", &sets.bounce, false),
            ("shadow", &sets.shadow, true),
        ] {
            let trace = |r: &Ray| {
                if shadow {
                    accel.occluded(r)
                } else {
                    accel.intersect(r).is_some()
                }
            };
            let (one, _) = mrays(rays.len(), || rays.iter().filter(|r| trace(r)).count());
            let start = Instant::now();
            let reps = 3;
            for _ in 0..reps {
                black_box(rays.par_iter().filter(|r| trace(r)).count());
            }
            let all = (rays.len() * reps) as f64 / start.elapsed().as_secs_f64() / 1e6;
            line += &format!(
                " {what} {one:.2} Mrays/s (1 thread), {all:.2} ({} threads);",
                rayon::current_num_threads()
            );
        }
        println!("{line}");
    }
}

fn mrays(n: usize, f: impl Fn() -> usize) -> (f64, usize) {
    f(); // warm up
    let wall = Instant::now();
    let t0 = cpu_time(wall);
    let mut reps = 0;
    let mut hits = 0;
    while cpu_time(wall) - t0 < 1.0 || reps < 2 {
        hits = f();
        reps += 1;
    }
    ((n * reps) as f64 / (cpu_time(wall) - t0) / 1e6, hits)
}

fn print_rays(scene: &Arc<Scene>, what: &str) {
    let mesh = match &scene.shapes.last().unwrap().geometry {
        Geometry::Mesh(m) => m,
        _ => unreachable!(),
    };
    let boxes = triangle_boxes(mesh);
    for q in [
        BuildQuality::Fast,
        BuildQuality::Balanced,
        BuildQuality::High,
    ] {
        let t = Instant::now();
        let bvh = Bvh::build(&boxes, q);
        println!(
            "build {what} ({} tris) {q:?}: {:.1} ms, {} nodes, depth {}",
            boxes.len(),
            t.elapsed().as_secs_f64() * 1e3,
            bvh.node_count(),
            bvh.depth()
        );
    }
    for name in [
        "dragon/dragon_vrip.ply",
        "dragon/dragon_vrip_res2.ply.gz",
        "dragon/dragon_vrip_res3.ply",
        "lucy/lucy.ply",
        "armadillo/armadillo.obj",
    ] {
        let path = assets().join("stanford").join(name);
        if !path.exists() {
            continue;
        }
        let m = match luz::scene::mesh_io::load_mesh(&path) {
            Ok(m) => m,
            Err(e) => {
                println!("{name}: {e}");
                continue;
            }
        };
        {
            let boxes = triangle_boxes(&m);
            let t = Instant::now();
            let bvh = Bvh::build(&boxes, BuildQuality::Balanced);
            println!(
                "build {name} ({} tris) Balanced: {:.1} ms, {} nodes",
                boxes.len(),
                t.elapsed().as_secs_f64() * 1e3,
                bvh.node_count()
            );
        }
        // The whole backend, in the bunny's place.
        let mut with_mesh = (**scene).clone();
        with_mesh.shapes.last_mut().expect("the bunny").geometry = Geometry::Mesh(m);
        let with_mesh = Arc::new(with_mesh);
        for backend in luz::accel::compiled_backends() {
            let kind: BackendKind = backend.parse().expect("compiled backends parse");
            let t = Instant::now();
            let accel = Accel::build(&with_mesh, kind, &BuildOptions::default()).expect("builds");
            println!(
                "backend {backend} on {name}: built in {:.1} ms",
                t.elapsed().as_secs_f64() * 1e3
            );
            drop(accel);
        }
    }
    let (closest, shadow) = if std::env::args().any(|a| a == "box") {
        rays(1 << 20)
    } else {
        let sets = render_rays(scene);
        print_backend_rays(scene, &sets);
        let mut closest = sets.camera;
        closest.extend(sets.bounce);
        (closest, sets.shadow)
    };
    for q in [
        BuildQuality::Fast,
        BuildQuality::Balanced,
        BuildQuality::High,
    ] {
        let b = NativeBackend::with_quality(scene.clone(), q);
        println!(
            "{what} scene {q:?}: triangle BVH {} nodes ({} KiB), {} slots, depth {}",
            b.bvh().node_count(),
            b.bvh().node_count() * 128 / 1024,
            b.bvh().primitive_indices().len(),
            b.bvh().depth()
        );
        let (c, hits) = mrays(closest.len(), || {
            closest.iter().filter(|r| b.intersect(r).is_some()).count()
        });
        let (o, occ) = mrays(shadow.len(), || {
            shadow.iter().filter(|r| b.occluded(r)).count()
        });
        println!(
            "{what} scene {q:?}, 1 thread: closest {c:.2} Mrays/s ({hits} hits), \
             occluded {o:.2} Mrays/s ({occ} occluded)"
        );
    }
}

fn render(scene: Scene, what: &str) {
    let mut scene = scene;
    scene.camera.width = 512;
    scene.camera.height = 512;
    scene.render.spp = std::env::var("SPP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(64);
    scene.render.max_depth = 5;
    scene.render.russian_roulette = false;
    let scene = Arc::new(scene);
    let t = Instant::now();
    let accel = Accel::build(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    let build = t.elapsed();
    let opts = luz::render::RenderOptions::from_scene(&scene);
    let (_film, stats) = luz::render::render_with(&scene, &accel, &opts, &());
    println!(
        "render {what} 512x512 {} spp depth 5, {} threads: {:.2} s (build {:.1} ms), \
         {:.1} Mrays/s ({} camera, {} bounce, {} shadow)",
        scene.render.spp,
        rayon::current_num_threads(),
        stats.wall.as_secs_f64(),
        build.as_secs_f64() * 1e3,
        stats.mrays_per_s(),
        stats.rays.camera,
        stats.rays.bounce,
        stats.rays.shadow
    );
}

fn criterion_groups(scene: &Arc<Scene>) {
    let mut c = Criterion::default().configure_from_args().sample_size(10);
    let mesh = match &scene.shapes.last().unwrap().geometry {
        Geometry::Mesh(m) => m.clone(),
        _ => unreachable!(),
    };
    let boxes = triangle_boxes(&mesh);
    let mut g = c.benchmark_group("build");
    for q in [
        BuildQuality::Fast,
        BuildQuality::Balanced,
        BuildQuality::High,
    ] {
        g.bench_function(format!("{q:?}"), |b| {
            b.iter(|| Bvh::build(black_box(&boxes), q))
        });
    }
    g.finish();
    let (closest, shadow) = rays(1 << 16);
    let b = NativeBackend::new(scene.clone());
    let mut g = c.benchmark_group("traversal");
    g.throughput(Throughput::Elements(closest.len() as u64));
    g.bench_function("closest", |bn| {
        bn.iter(|| closest.iter().filter(|r| b.intersect(r).is_some()).count())
    });
    g.bench_function("occluded", |bn| {
        bn.iter(|| shadow.iter().filter(|r| b.occluded(r)).count())
    });
    g.finish();
    c.final_summary();
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(scene) = bunny_scene() else {
        return;
    };
    let what = "bunny";
    if args.iter().any(|a| a == "render") {
        render(scene, what);
    } else if args.iter().any(|a| a == "rays") {
        print_rays(&Arc::new(scene), what);
    } else {
        criterion_groups(&Arc::new(scene));
    }
}
