//! Every compiled backend against brute force (every primitive's own
//! intersection routine, in order) on random scenes and random rays.

mod common;

use luz::accel::{Backend, BackendKind, BuildOptions, Quality};
use luz::geometry::Geometry;
use luz::geometry::PreliminaryHit;
use luz::geometry::{Cuboid, Mesh, Plane, Quad, Sphere};
use luz::math::{Ray, Vec3};
use luz::render::build_accel;
use luz::sampling::{uniform_sphere, Rng};
use luz::scene::{Material, RenderSettings, Scene, Shape};
use std::sync::Arc;

fn random_scene(rng: &mut Rng, scale: f32) -> Arc<Scene> {
    let mut shapes = Vec::new();
    let p = |rng: &mut Rng| {
        Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 * scale - Vec3::splat(scale)
    };
    for _ in 0..30 {
        let c = p(rng);
        shapes.push(Geometry::Sphere(Sphere {
            center: c,
            radius: 0.05 * scale + 0.1 * scale * rng.next_f32(),
        }));
    }
    for _ in 0..30 {
        let o = p(rng);
        let e1 = 0.2 * scale * uniform_sphere(rng.next_2d());
        let e2 = 0.2 * scale * uniform_sphere(rng.next_2d());
        if let Some(q) = Quad::new(o, e1, e2) {
            shapes.push(Geometry::Quad(q));
        }
    }
    for _ in 0..20 {
        let a = p(rng);
        let b = a
            + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.3 * scale
            + Vec3::splat(1e-3 * scale);
        shapes.push(Geometry::Cuboid(Cuboid { min: a, max: b }));
    }
    for _ in 0..3 {
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for i in 0..400u32 {
            let a = p(rng);
            positions.push(a.into());
            positions.push((a + 0.15 * scale * uniform_sphere(rng.next_2d())).into());
            positions.push((a + 0.15 * scale * uniform_sphere(rng.next_2d())).into());
            indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        shapes.push(Geometry::from(Mesh {
            positions,
            indices,
            uvs: None,
            normals: None,
        }));
    }
    shapes.push(Geometry::Plane(Plane::new(
        Vec3::new(0.0, -1.5 * scale, 0.0),
        Vec3::new(0.1, 1.0, -0.2),
    )));
    Arc::new(Scene::of_geometry(shapes))
}

fn brute_force(scene: &Scene, ray: &Ray) -> Option<PreliminaryHit> {
    let mut r = *ray;
    let mut best = None;
    for (geom, s) in scene.shapes.iter().enumerate() {
        for prim in 0..s.geometry.primitive_count() as u32 {
            if let Some(h) = s.geometry.intersect(prim, &r) {
                r.t_max = h.t;
                best = Some(PreliminaryHit {
                    t: h.t,
                    geom: geom as u32,
                    prim,
                    u: h.u,
                    v: h.v,
                });
            }
        }
    }
    best
}

fn random_ray(rng: &mut Rng, scale: f32) -> Ray {
    let o = 2.0 * scale * uniform_sphere(rng.next_2d()) * rng.next_f32().sqrt();
    let mut d = uniform_sphere(rng.next_2d());
    // A tenth of the rays are exactly axis-parallel.
    if rng.next_f32() < 0.1 {
        let axis = (rng.next_u32() % 3) as usize;
        let mut a = Vec3::ZERO;
        a[axis] = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
        d = a;
    }
    let mut ray = Ray::new(o, d);
    if rng.next_f32() < 0.2 {
        ray.t_max = scale * rng.next_f32();
    }
    ray
}

#[test]
fn native_backend_matches_brute_force_on_1e5_rays_at_three_scales_with_both_leaf_layouts() {
    let mut rng = Rng::new(11, 0);
    // Low: leaves gathered from the meshes; medium: stored packs.
    for (scale, bvh_quality) in [
        (1e-3f32, Quality::Medium),
        (1.0, Quality::Low),
        (1.0, Quality::Medium),
        (1e4, Quality::Low),
    ] {
        let scene = random_scene(&mut rng, scale);
        let options = BuildOptions {
            bvh_quality,
            ..BuildOptions::default()
        };
        let native = build_accel(&scene, BackendKind::Rust, &options).unwrap();
        assert_eq!(native.name(), "rust");
        let (mut hits, mut occluded) = (0, 0);
        for _ in 0..100_000 {
            let ray = random_ray(&mut rng, scale);
            let expected = brute_force(&scene, &ray);
            let got = native.intersect(&ray);
            match (expected, got) {
                (Some(e), Some(g)) => {
                    hits += 1;
                    // Two primitives may share the exact t; then only t must agree.
                    assert_eq!(e.t, g.t, "scale {scale}, {bvh_quality:?}: {ray:?}");
                    if (e.geom, e.prim) != (g.geom, g.prim) {
                        let other = &scene.shapes[g.geom as usize].geometry;
                        assert_eq!(other.intersect(g.prim, &ray).map(|h| h.t), Some(g.t));
                    } else {
                        assert_eq!((e.u, e.v), (g.u, g.v));
                    }
                }
                (None, None) => {}
                (e, g) => panic!(
                    "scale {scale}, {bvh_quality:?}: brute force {e:?}, native {g:?} for {ray:?}"
                ),
            }
            let occ = native.occluded(&ray);
            assert_eq!(
                occ,
                expected.is_some(),
                "occluded, scale {scale}, {bvh_quality:?}: {ray:?}"
            );
            occluded += occ as u32;
        }
        // The test only has teeth if many rays hit and many miss.
        assert!(hits > 10_000 && hits < 95_000, "scale {scale}: {hits} hits");
        assert_eq!(occluded, hits);
    }
}

fn embree_compiled() -> bool {
    let compiled = common::embree_compiled();
    if compiled {
        let version = luz::accel::embree_version().expect("Embree is compiled in");
        assert!(version.starts_with("3."), "{version}");
    }
    compiled
}

fn t_error(ray: &Ray, a: f32, b: f32) -> f32 {
    let scale = a
        .abs()
        .max(ray.origin.abs().max_element() / ray.dir.length());
    (a - b).abs() / scale.max(f32::MIN_POSITIVE)
}

/// Embree against the native backend on 1e5 random rays per scale and per
/// build setting: the same closest (geom, prim) for at least 99.9% of rays
/// (Embree's triangle test and the native one round differently, so they
/// may disagree on rays through an edge), `t` within 1e-4 relative where they agree, and
/// occlusion answers that agree as often.
///
/// "Relative" is to the length scale of the computation: `max(t, |o| / |d|)`.
/// A hit 1 unit from an origin 1e4 units from the scene's origin has `t`
/// known only to about ulp(1e4) ≈ 1e-3 in either backend, since both
/// subtract the origin from the vertices first.
#[test]
fn embree_matches_native_on_1e5_rays_at_four_scales() {
    if !embree_compiled() {
        return;
    }
    let settings = [
        (1e-3f32, Quality::Medium, false),
        (1.0, Quality::Low, false),
        (1.0, Quality::High, true),
        (1e4, Quality::Medium, true),
        (1e6, Quality::Medium, false),
    ];
    let mut rng = Rng::new(12, 0);
    for (scale, quality, robust) in settings {
        let scene = random_scene(&mut rng, scale);
        let native = build_accel(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
        let options = BuildOptions {
            embree_quality: quality,
            embree_robust: robust,
            ..BuildOptions::default()
        };
        let embree = build_accel(&scene, BackendKind::Embree, &options).unwrap();
        assert_eq!(embree.name(), "embree");
        let n = 100_000;
        let (mut hits, mut triangle_hits, mut differ, mut occ_differ) = (0, 0, 0, 0);
        let mut worst_t = 0.0f32;
        for _ in 0..n {
            let ray = random_ray(&mut rng, scale);
            let (a, b) = (native.intersect(&ray), embree.intersect(&ray));
            match (a, b) {
                (Some(a), Some(b)) if (a.geom, a.prim) == (b.geom, b.prim) => {
                    hits += 1;
                    let rel = t_error(&ray, a.t, b.t);
                    worst_t = worst_t.max(rel);
                    assert!(
                        rel <= 1e-4,
                        "scale {scale}: t {} vs {} for {ray:?}",
                        a.t,
                        b.t
                    );
                    if matches!(scene.shapes[a.geom as usize].geometry, Geometry::Mesh(_)) {
                        triangle_hits += 1;
                        assert!((a.u - b.u).abs() < 1e-3 && (a.v - b.v).abs() < 1e-3);
                    } else {
                        // Analytic shapes run the very same routine.
                        assert_eq!(a, b, "scale {scale}: {ray:?}");
                    }
                }
                (None, None) => {}
                (a, b) => {
                    differ += 1;
                    // Both answers must be real hits at (almost) the same t.
                    if let (Some(a), Some(b)) = (a, b) {
                        let rel = t_error(&ray, a.t, b.t);
                        assert!(rel <= 1e-4, "scale {scale}: native {a:?}, embree {b:?}");
                    }
                }
            }
            if native.occluded(&ray) != embree.occluded(&ray) {
                occ_differ += 1;
            }
            // Embree's own answers are consistent with each other.
            if let Some(b) = b {
                assert!(embree.occluded(&ray) || b.t >= ray.t_max * (1.0 - 1e-6));
            }
        }
        eprintln!(
            "scale {scale:e} {quality:?} robust={robust}: {hits} same hits \
             ({triangle_hits} on triangles), {differ} differ, {occ_differ} occlusion \
             answers differ, worst relative t {worst_t:e}"
        );
        assert!(
            hits > 10_000 && triangle_hits > 1_000,
            "scale {scale}: {hits} hits"
        );
        assert!(
            differ * 1000 <= n,
            "scale {scale}: {differ} of {n} rays differ"
        );
        assert!(
            occ_differ * 1000 <= n,
            "scale {scale}: {occ_differ} occlusions differ"
        );
    }
}

/// A scene of only planes and a scene with no shapes at all build and
/// answer like the native backend.
#[test]
fn embree_handles_planes_only_and_empty_scenes() {
    if !embree_compiled() {
        return;
    }
    let mut rng = Rng::new(5, 0);
    let full = random_scene(&mut rng, 1.0);
    for keep in [&["plane"][..], &[]] {
        let shapes: Vec<Shape> = full
            .shapes
            .iter()
            .filter(|s| keep.contains(&s.geometry.name()))
            .cloned()
            .collect();
        let scene = Arc::new(Scene::new(
            full.camera.clone(),
            vec![Material::default()],
            vec![],
            shapes,
            vec![],
            None,
            RenderSettings::default(),
        ));
        let native = build_accel(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
        let embree = build_accel(&scene, BackendKind::Embree, &BuildOptions::default()).unwrap();
        for _ in 0..1000 {
            let ray = random_ray(&mut rng, 1.0);
            assert_eq!(native.intersect(&ray), embree.intersect(&ray));
            assert_eq!(native.occluded(&ray), embree.occluded(&ray));
        }
    }
}
