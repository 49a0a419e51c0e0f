//! The tree against brute force, at every scale and on the inputs that
//! break naive trees.

use super::*;
use crate::geometry::intersect_triangle;
use crate::math::{Ray, Vec3};
use crate::sampling::{uniform_sphere, Rng};

type Tri = [Vec3; 3];

/// Every preset: the Morton build (`Low`) and the two SAH builds.
const QUALITIES: [BuildQuality; 3] = [BuildQuality::Low, BuildQuality::Medium, BuildQuality::High];

fn boxes_of(tris: &[Tri]) -> Vec<Aabb> {
    tris.iter().map(|t| Aabb::from_points(t)).collect()
}

fn isect(t: &Tri, r: &Ray) -> Option<f32> {
    intersect_triangle(*t, r).map(|h| h.t)
}

fn brute(tris: &[Tri], ray: &Ray) -> Option<(f32, u32)> {
    let mut r = *ray;
    let mut best = None;
    for (i, t) in tris.iter().enumerate() {
        if let Some(t) = isect(t, &r) {
            r.t_max = t;
            best = Some((t, i as u32));
        }
    }
    best
}

/// Closest hit through the BVH, as the original primitive index.
fn closest(bvh: &Bvh, tris: &[Tri], ray: &Ray) -> Option<(f32, u32)> {
    let order = bvh.primitive_indices();
    bvh.intersect_with(ray, |slot, r| {
        isect(&tris[order[slot as usize] as usize], r).map(|t| (t, ()))
    })
    .map(|(t, slot, ())| (t, order[slot as usize]))
}

fn any(bvh: &Bvh, tris: &[Tri], ray: &Ray) -> bool {
    let order = bvh.primitive_indices();
    bvh.occluded(ray, |slot, r| {
        isect(&tris[order[slot as usize] as usize], r).is_some()
    })
}

fn point(rng: &mut Rng, scale: f32) -> Vec3 {
    (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE) * scale
}

fn soup(rng: &mut Rng, n: usize, scale: f32, size: f32) -> Vec<Tri> {
    (0..n)
        .map(|_| {
            let a = point(rng, scale);
            [
                a,
                a + size * scale * uniform_sphere(rng.next_2d()),
                a + size * scale * uniform_sphere(rng.next_2d()),
            ]
        })
        .collect()
}

fn random_ray(rng: &mut Rng, scale: f32) -> Ray {
    let o = point(rng, 1.5 * scale);
    let mut d = uniform_sphere(rng.next_2d());
    if rng.next_f32() < 0.1 {
        let axis = (rng.next_u32() % 3) as usize;
        d = Vec3::ZERO;
        d[axis] = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
    }
    let mut r = Ray::new(o, d);
    if rng.next_f32() < 0.2 {
        r.t_max = scale * rng.next_f32();
    }
    r
}

/// Closest hit and any hit agree with brute force on every ray.
fn check(tris: &[Tri], rays: &[Ray], quality: BuildQuality) -> usize {
    let expected: Vec<_> = rays.iter().map(|r| brute(tris, r)).collect();
    check_against(tris, rays, &expected, quality)
}

fn check_against(
    tris: &[Tri],
    rays: &[Ray],
    expected: &[Option<(f32, u32)>],
    quality: BuildQuality,
) -> usize {
    let bvh = Bvh::build(&boxes_of(tris), quality);
    assert!(bvh.depth() <= MAX_DEPTH);
    let mut hits = 0;
    for (ray, &e) in rays.iter().zip(expected) {
        let g = closest(&bvh, tris, ray);
        match (e, g) {
            (Some(e), Some(g)) => {
                hits += 1;
                assert_eq!(e.0, g.0, "{ray:?}");
                if e.1 != g.1 {
                    // A tie: the other triangle must report the same t.
                    assert_eq!(isect(&tris[g.1 as usize], ray), Some(g.0), "{ray:?}");
                }
            }
            (None, None) => {}
            _ => panic!("brute force {e:?}, bvh {g:?} for {ray:?}"),
        }
        assert_eq!(any(&bvh, tris, ray), e.is_some(), "occluded {ray:?}");
    }
    hits
}

#[test]
fn matches_brute_force_on_1e5_random_rays() {
    let mut rng = Rng::new(7, 1);
    let tris = soup(&mut rng, 3000, 1.0, 0.08);
    let rays: Vec<Ray> = (0..100_000).map(|_| random_ray(&mut rng, 1.0)).collect();
    for q in QUALITIES {
        let hits = check(&tris, &rays, q);
        assert!(hits > 10_000 && hits < 90_000, "{hits} hits");
    }
}

/// 4-aligned leaves: every real primitive has exactly one slot, leaves
/// start on multiples of four, and leaf-level traversal never hands out
/// a padding slot; results still match brute force.
#[test]
fn aligned_leaves_pad_and_match_brute_force() {
    let mut rng = Rng::new(10, 1);
    let tris = soup(&mut rng, 2000, 1.0, 0.08);
    for quality in QUALITIES {
        let settings = BuildSettings {
            quality,
            align: 4,
            ..BuildSettings::default()
        };
        check_aligned(
            &tris,
            &Bvh::build_with(&boxes_of(&tris), &settings),
            &mut rng,
        );
    }
}

/// The Morton build given a box for the centroids: exact, four times
/// looser (both used), a hundred times looser (a sample shows it too
/// large: the centroids' own bounds are used), half-size (codes outside
/// are clamped), flat on an axis, infinite, NaN or empty (not used). Every
/// primitive still gets its slot, and hits still match brute force.
#[test]
fn morton_codes_within_given_centroid_bounds() {
    let mut rng = Rng::new(12, 1);
    let tris = soup(&mut rng, 2000, 1.0, 0.08);
    let boxes = boxes_of(&tris);
    let centroids = boxes.iter().fold(Aabb::EMPTY, |b, t| b.grow(t.centroid()));
    let centre = centroids.centroid();
    let scaled = |k: f32| {
        Aabb::new(
            centre + k * (centroids.min - centre),
            centre + k * (centroids.max - centre),
        )
    };
    let flat = Aabb::new(
        centroids.min,
        Vec3::new(centroids.max.x, centroids.min.y, centroids.max.z),
    );
    let infinite = Aabb::new(Vec3::splat(f32::NEG_INFINITY), Vec3::splat(f32::INFINITY));
    let nan = Aabb::new(centroids.min, Vec3::splat(f32::NAN));
    for given in [
        centroids,
        scaled(4.0),
        scaled(100.0),
        scaled(0.5),
        flat,
        infinite,
        nan,
        Aabb::EMPTY,
    ] {
        let settings = BuildSettings {
            quality: BuildQuality::Low,
            align: 4,
            centroid_bounds: Some(given),
            ..BuildSettings::default()
        };
        check_aligned(&tris, &Bvh::build_with(&boxes, &settings), &mut rng);
    }
}

fn check_aligned(tris: &[Tri], bvh: &Bvh, rng: &mut Rng) {
    let order = bvh.primitive_indices();
    assert_eq!(order.len() % 4, 0);
    let mut real: Vec<u32> = order.iter().copied().filter(|&i| i != PADDING).collect();
    real.sort_unstable();
    assert!(real.iter().enumerate().all(|(i, &p)| i as u32 == p));
    for _ in 0..20_000 {
        let ray = random_ray(rng, 1.0);
        let got = bvh.intersect_leaves(&ray, |first, count, r| {
            assert_eq!(first % 4, 0);
            let mut r = *r;
            let mut best = None;
            for slot in first..first + count {
                let i = order[slot as usize];
                assert_ne!(i, PADDING);
                if let Some(t) = isect(&tris[i as usize], &r) {
                    r.t_max = t;
                    best = Some((t, i));
                }
            }
            best
        });
        assert_eq!(got.map(|g| g.0), brute(tris, &ray).map(|e| e.0), "{ray:?}");
    }
}

#[test]
fn huge_and_tiny_scales() {
    let mut rng = Rng::new(8, 1);
    for scale in [1e-4f32, 1e-2, 1e2, 1e4] {
        let tris = soup(&mut rng, 800, scale, 0.1);
        let rays: Vec<Ray> = (0..20_000).map(|_| random_ray(&mut rng, scale)).collect();
        for quality in QUALITIES {
            let hits = check(&tris, &rays, quality);
            assert!(hits > 1000, "scale {scale}, {quality:?}: {hits} hits");
        }
    }
}

/// Axis-aligned triangles (flat boxes) on a grid, hit by exactly
/// axis-parallel rays, many starting in the boxes' planes.
#[test]
fn axis_parallel_rays_and_flat_boxes() {
    let mut tris = Vec::new();
    for i in 0..10 {
        for j in 0..10 {
            let (x, y) = (i as f32 * 0.2, j as f32 * 0.2);
            let z = ((i + j) % 3) as f32 * 0.5;
            // In a z plane, an x plane and a y plane.
            tris.push([
                Vec3::new(x, y, z),
                Vec3::new(x + 0.2, y, z),
                Vec3::new(x, y + 0.2, z),
            ]);
            tris.push([
                Vec3::new(z, x, y),
                Vec3::new(z, x + 0.2, y),
                Vec3::new(z, x, y + 0.2),
            ]);
            tris.push([
                Vec3::new(y, z, x),
                Vec3::new(y, z, x + 0.2),
                Vec3::new(y + 0.2, z, x),
            ]);
        }
    }
    // Degenerate triangles: a segment and a point.
    tris.push([Vec3::ZERO, Vec3::X, Vec3::X]);
    tris.push([Vec3::ONE; 3]);
    let mut rng = Rng::new(9, 2);
    let mut rays = Vec::new();
    for _ in 0..20_000 {
        let axis = (rng.next_u32() % 3) as usize;
        let mut d = Vec3::ZERO;
        d[axis] = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
        // Coordinates on the grid lines (box planes) half the time.
        let mut o = Vec3::ZERO;
        for k in 0..3 {
            o[k] = if rng.next_f32() < 0.5 {
                (rng.next_u32() % 11) as f32 * 0.2
            } else {
                rng.next_f32() * 2.2 - 0.1
            };
        }
        o[axis] = if d[axis] > 0.0 { -1.0 } else { 3.0 };
        rays.push(Ray::new(o, d));
        // Also from inside, and with -0.0 components.
        let mut r = Ray::new(o, d);
        r.origin[axis] = rng.next_f32() * 2.0;
        r.dir[(axis + 1) % 3] = -0.0;
        rays.push(r);
    }
    let hits = check(&tris, &rays, BuildQuality::Medium);
    assert!(hits > 5000, "{hits} hits");
    // No NaN ever reaches a result.
    let bvh = Bvh::build(&boxes_of(&tris), BuildQuality::Medium);
    for r in &rays {
        if let Some((t, _)) = closest(&bvh, &tris, r) {
            assert!(t.is_finite());
        }
    }
}

#[test]
fn empty_single_and_invalid_inputs() {
    for quality in QUALITIES {
        empty_single_and_invalid(quality);
    }
}

fn empty_single_and_invalid(quality: BuildQuality) {
    let ray = Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z);
    let empty = Bvh::build(&[], quality);
    assert!(empty.primitive_indices().is_empty());
    assert!(empty.intersect_with(&ray, |_, _| Some((1.0, ()))).is_none());
    assert!(!empty.occluded(&ray, |_, _| true));

    let tri = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
    let one = Bvh::build(&boxes_of(&tri), quality);
    assert_eq!(one.primitive_indices(), &[0]);
    assert_eq!(closest(&one, &tri, &ray), Some((1.0, 0)));
    assert!(any(&one, &tri, &ray));
    assert!(!any(&one, &tri, &Ray::new(Vec3::splat(2.0), Vec3::Z)));

    // NaN and empty boxes get no slot; NaN rays hit nothing.
    let nan = Aabb::new(Vec3::splat(f32::NAN), Vec3::ONE);
    let boxes = [nan, boxes_of(&tri)[0], Aabb::EMPTY];
    let bvh = Bvh::build(&boxes, quality);
    assert_eq!(bvh.primitive_indices(), &[1]);
    let bad = Ray::new(Vec3::splat(f32::NAN), Vec3::Z);
    assert!(bvh.intersect_with(&bad, |_, _| Some((1.0, ()))).is_none());
    assert!(!bvh.occluded(&bad, |_, _| true));
    let bad = Ray::new(Vec3::ZERO, Vec3::new(f32::INFINITY, 0.0, 1.0));
    assert!(!bvh.occluded(&bad, |_, _| true));
}

/// Identical boxes and exponentially spread ones: the depth guard holds
/// and every primitive is still found.
#[test]
fn depth_guard_and_identical_boxes() {
    for quality in QUALITIES {
        depth_guard(quality);
    }
}

fn depth_guard(quality: BuildQuality) {
    let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 10_000];
    let bvh = Bvh::build(&same, quality);
    assert!(bvh.depth() <= MAX_DEPTH);
    let mut seen = vec![false; same.len()];
    let ray = Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::Z);
    assert!(!bvh.occluded(&ray, |slot, _| {
        seen[bvh.primitive_indices()[slot as usize] as usize] = true;
        false
    }));
    assert!(seen.iter().all(|&s| s));

    let spread: Vec<Aabb> = (0..2000)
        .map(|i| {
            let x = 1.02f32.powi(i) - 1.0;
            Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x, 1.0, 1.0))
        })
        .collect();
    let bvh = Bvh::build(&spread, quality);
    assert!(bvh.depth() <= MAX_DEPTH);
    let mut order = bvh.primitive_indices().to_vec();
    order.sort_unstable();
    assert!(order.iter().enumerate().all(|(i, &p)| i as u32 == p));
    // The ray along x sees them nearest first.
    let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
    let hit = bvh.intersect_with(&ray, |slot, r| {
        let i = bvh.primitive_indices()[slot as usize] as usize;
        let t = spread[i].min.x + 1.0;
        (t > r.t_min && t < r.t_max).then_some((t, i))
    });
    assert_eq!(hit.map(|h| h.2), Some(0));
}

/// Every preset tells the step in progress of each usable primitive
/// exactly once: a tree built serially from its root, one past the
/// parallel threshold, and one with unusable boxes among the rest.
#[test]
fn builds_report_each_usable_primitive_once() {
    use crate::meter::test_support::Recorder;
    use crate::meter::{Step, StepKind};
    let mut rng = Rng::new(11, 1);
    let point = |rng: &mut Rng| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 100.0;
    for n in [100usize, 3 * PARALLEL_THRESHOLD + 17, 50_000] {
        let mut boxes: Vec<Aabb> = (0..n)
            .map(|_| {
                let p = point(&mut rng);
                Aabb::from_points(&[p, p + Vec3::splat(0.5)])
            })
            .collect();
        if n == 50_000 {
            for b in boxes.iter_mut().step_by(9) {
                *b = Aabb::EMPTY;
            }
        }
        let usable = boxes.iter().filter(|b| usable(b)).count() as u64;
        for quality in QUALITIES {
            let settings = BuildSettings {
                quality,
                ..BuildSettings::default()
            };
            let (bvh, events) = Recorder::record(|| {
                let _step = Step::begin(StepKind::BuildTree { backend: "rust" }, n as u64);
                Bvh::build_reporting(n, |i| boxes[i], &settings, &Step::current())
            });
            let steps = crate::meter::test_support::steps(&events);
            assert_eq!(steps.len(), 1, "{quality:?} {n}");
            let (_, total, done, reports) = &steps[0];
            assert_eq!((*total, *done), (n as u64, usable), "{quality:?} {n}");
            assert!(
                n < PARALLEL_THRESHOLD || *reports > 2,
                "{quality:?} {n}: {reports}"
            );
            assert_eq!(
                bvh.primitive_indices()
                    .iter()
                    .filter(|&&p| p != PADDING)
                    .count() as u64,
                usable
            );
        }
    }
}
