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
use crate::math::{Aabb, Ray};
use crate::scene::Shape;

#[derive(Clone, Copy, Debug)]
pub(super) struct Extent {
    min: [f32; 3],
    max: [f32; 3],
}

impl Extent {
    /// The box around the shapes not `in_root`, widened by a few ulps of
    /// its coordinates so that a backend's own rounding (Embree's hit
    /// points are computed, not exact) cannot put a hit outside it.
    pub(super) fn of(shapes: &[Shape], in_root: &[bool]) -> Self {
        let bounds = shapes
            .iter()
            .zip(in_root)
            .filter(|(_, &root)| !root)
            .fold(Aabb::EMPTY, |b, (s, _)| {
                b.union(s.geometry.bounds().unwrap_or(Aabb::EMPTY))
            });
        // The empty box's infinities stay as they are (∞ − ∞ is NaN).
        let widen = |v: f32, out: f32| {
            if v.is_finite() {
                v + out * (v.abs() * 8.0 * f32::EPSILON + f32::MIN_POSITIVE)
            } else {
                v
            }
        };
        Self {
            min: bounds.min.to_array().map(|v| widen(v, -1.0)),
            max: bounds.max.to_array().map(|v| widen(v, 1.0)),
        }
    }

    /// Whether the ray's `(t_min, t_max)` may touch the box; the ray must
    /// be traceable (`accel::traceable`). The slab test of the trees'
    /// nodes, one box wide: a NaN distance (a direction component of zero
    /// with the origin on the box's plane) leaves the interval unchanged.
    #[inline(always)]
    pub(super) fn touches(&self, ray: &Ray) -> bool {
        let (origin, dir) = (ray.origin.to_array(), ray.dir.to_array());
        let mut t0 = ray.t_min;
        let mut t1 = ray.t_max;
        for axis in 0..3 {
            let inv = 1.0 / dir[axis];
            let (near, far) = if dir[axis].is_sign_negative() {
                (self.max[axis], self.min[axis])
            } else {
                (self.min[axis], self.max[axis])
            };
            let tn = (near - origin[axis]) * inv;
            let tf = (far - origin[axis]) * inv;
            if tn > t0 {
                t0 = tn;
            }
            if tf < t1 {
                t1 = tf;
            }
        }
        t0 <= t1 * FAR_SCALE
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Geometry, Sphere};
    use crate::math::Vec3;
    use crate::sampling::{uniform_sphere, Rng};

    fn sphere_extent(center: Vec3, radius: f32) -> (Sphere, Extent) {
        let sphere = Sphere { center, radius };
        let shape = Shape::new(Geometry::Sphere(sphere.clone()), 0);
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

    #[test]
    fn nothing_outside_the_trees_touches_nothing() {
        let (_, extent) = sphere_extent(Vec3::ZERO, 1.0);
        let shape = Shape::new(
            Geometry::Sphere(Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            }),
            0,
        );
        let empty = Extent::of(&[shape], &[true]);
        let ray = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        assert!(extent.touches(&ray));
        assert!(!empty.touches(&ray));
    }
}
