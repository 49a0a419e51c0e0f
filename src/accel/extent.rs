//! The box around everything a backend's tree holds, which `Layered` tests
//! a ray against before it asks the tree.
//!
//! Why: in a scene with one small mesh (a bunny in a Cornell box) most rays
//! miss the mesh's box, and asking either tree costs far more than the box
//! test: the native tree prepares the ray and its stack, Embree is a call
//! through its API with a ray and context to fill. A callgrind profile of
//! the bunny counted the difference (docs/performance.md).
//!
//! The test is conservative: whatever a tree would hit lies in the box,
//! and the far distance is widened as in the trees' own box tests, so a
//! miss here is a miss there and images do not change.

use super::bvh::FAR_SCALE;
use crate::geometry::Geometry;
use crate::math::{Aabb, Ray};
use crate::simd::F4;

/// The box's corners in the first three lanes; the fourth lane's
/// (−∞, +∞) leaves a ray's own interval as it is.
#[derive(Clone, Copy, Debug)]
pub(super) struct Extent {
    min: [f32; 4],
    max: [f32; 4],
}

impl Extent {
    /// The box around the shapes not `in_root`, widened by a few ulps of
    /// its coordinates so that a backend's own rounding (Embree's hit
    /// points are computed, not exact) cannot put a hit outside it.
    pub(super) fn of(shapes: &[Geometry], in_root: &[bool]) -> Self {
        let bounds = shapes
            .iter()
            .zip(in_root)
            .filter(|(_, &root)| !root)
            .fold(Aabb::EMPTY, |b, (g, _)| {
                b.union(g.bounds().unwrap_or(Aabb::EMPTY))
            });
        // The empty box's infinities stay as they are (∞ − ∞ is NaN).
        let widen = |v: f32, out: f32| {
            if v.is_finite() {
                v + out * (v.abs() * 8.0 * f32::EPSILON + f32::MIN_POSITIVE)
            } else {
                v
            }
        };
        let [x0, y0, z0] = bounds.min.to_array().map(|v| widen(v, -1.0));
        let [x1, y1, z1] = bounds.max.to_array().map(|v| widen(v, 1.0));
        Self {
            min: [x0, y0, z0, f32::NEG_INFINITY],
            max: [x1, y1, z1, f32::INFINITY],
        }
    }

    /// Whether the ray's `(t_min, t_max)` may touch the box; the ray must
    /// be traceable (`accel::traceable`). The slab test of the trees'
    /// nodes, one box wide, its three axes in the lanes of one vector: a
    /// NaN distance (a direction component of zero with the origin on the
    /// box's plane) leaves the interval unchanged, as `maxps`/`minps` keep
    /// their second operand then.
    #[inline(always)]
    pub(super) fn touches(&self, ray: &Ray) -> bool {
        let origin = F4::from(ray.origin);
        let inv = F4::splat(1.0).div(F4::from(ray.dir));
        // A traceable direction is finite, so `inv` is never ±0 and has the
        // sign of the direction, that of -0 included. The vectors' fourth
        // lanes are unspecified: whatever they hold, the box's (−∞, +∞)
        // there gives −∞ or NaN near and +∞ or NaN far, which leave the
        // interval as it is.
        let negative = inv.lt(F4::splat(0.0));
        let (min, max) = (F4::load(&self.min), F4::load(&self.max));
        let tn = negative.select(max, min).sub(origin).mul(inv);
        let tf = negative.select(min, max).sub(origin).mul(inv);
        let t0 = tn.max(F4::splat(ray.t_min)).max_lane();
        let t1 = tf.min(F4::splat(ray.t_max)).min_lane();
        t0 <= t1 * FAR_SCALE
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sphere;
    use crate::math::Vec3;
    use crate::sampling::{uniform_sphere, Rng};

    fn sphere_extent(center: Vec3, radius: f32) -> (Sphere, Extent) {
        let sphere = Sphere { center, radius };
        let shape = Geometry::Sphere(sphere.clone());
        (sphere, Extent::of(&[shape], &[false]))
    }

    /// Every ray that hits the shape touches its extent, from near and far
    /// origins, with rays cut short and along the axes (zero direction
    /// components); and rays aimed away miss it.
    #[test]
    fn every_hit_touches_the_extent() {
        let mut rng = Rng::new(3, 5);
        for scale in [1e-3f32, 1.0, 1e4] {
            let (sphere, extent) = sphere_extent(Vec3::new(0.3, -0.2, 0.1) * scale, scale);
            let (mut hits, mut misses) = (0, 0);
            for i in 0..20_000 {
                let from = sphere.center + 3.0 * scale * uniform_sphere(rng.next_2d());
                let towards = sphere.center + 1.2 * scale * uniform_sphere(rng.next_2d());
                let mut dir = (towards - from).normalize();
                if i % 4 == 0 {
                    dir = dir
                        .to_array()
                        .map(|d| if d.abs() < 0.5 { 0.0 } else { d })
                        .into();
                    dir = dir.try_normalize().unwrap_or(Vec3::X);
                }
                let mut ray = Ray::new(from, dir);
                if i % 3 == 0 {
                    ray.t_max = 3.0 * scale * rng.next_f32();
                }
                let hit = sphere.intersect(&ray).is_some();
                let touches = extent.touches(&ray);
                assert!(touches || !hit, "{ray:?}");
                hits += hit as u32;
                misses += !touches as u32;
            }
            assert!(
                hits > 5_000 && misses > 2_000,
                "{hits} hits, {misses} misses"
            );
        }
    }

    /// A ray starting on a face of the box, along that face, is not lost
    /// to the NaN of `0 * inf`.
    #[test]
    fn rays_along_a_face_touch_it() {
        let (_, extent) = sphere_extent(Vec3::ZERO, 1.0);
        let on_face = Vec3::new(extent.min[0], 0.0, 0.0);
        assert!(extent.touches(&Ray::new(on_face, Vec3::Y)));
        assert!(!extent.touches(&Ray::new(Vec3::new(-2.0, 0.0, 0.0), Vec3::Y)));
    }

    /// Whatever a vector's unused fourth lane holds, the answer is that of
    /// its three coordinates.
    #[test]
    fn the_fourth_lane_does_not_matter() {
        let (_, extent) = sphere_extent(Vec3::ZERO, 1.0);
        let with_w = |v: Vec3, w: f32| Vec3::from(F4::load(&[v.x, v.y, v.z, w]));
        let lanes = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e30,
            -1e-40,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let mut rng = Rng::new(8, 1);
        for _ in 0..200 {
            let origin = 3.0 * uniform_sphere(rng.next_2d());
            let dir = (0.8 * uniform_sphere(rng.next_2d()) - origin).normalize();
            for mut ray in [
                Ray::new(origin, dir),
                Ray::new(Vec3::new(1.0, 0.0, 0.0), Vec3::Y),
            ] {
                ray.t_max = 2.0 + 4.0 * rng.next_f32();
                let want = extent.touches(&ray);
                for (&wo, &wd) in lanes
                    .iter()
                    .zip(lanes.iter().rev())
                    .chain(lanes.iter().zip(&lanes))
                {
                    let garbled = Ray {
                        origin: with_w(ray.origin, wo),
                        dir: with_w(ray.dir, wd),
                        ..ray
                    };
                    assert_eq!(extent.touches(&garbled), want, "{ray:?} with {wo}, {wd}");
                }
            }
        }
    }

    #[test]
    fn nothing_outside_the_trees_touches_nothing() {
        let (_, extent) = sphere_extent(Vec3::ZERO, 1.0);
        let shape = Geometry::Sphere(Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        });
        let empty = Extent::of(&[shape], &[true]);
        let ray = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        assert!(extent.touches(&ray));
        assert!(!empty.touches(&ray));
    }
}
