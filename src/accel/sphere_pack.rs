//! The root's large spheres, turned away four at a time.
//!
//! Most rays miss most spheres, and `Sphere`'s quick rejection decides that
//! for one sphere in about twenty instructions. At the root every query
//! meets every sphere there (a Cornell box's two, up to `ROOT_OTHERS`), so
//! that test runs here for all of them in one SSE register; only the
//! spheres it cannot turn away go on to `Sphere::intersect_precisely`, the
//! test that finds the hit. The quick test only filters, with a margin far
//! above its rounding (`Sphere::clearly_missed_by`), so hits are those of
//! the scalar routine whatever order its sums take here.

use crate::geometry::{PrimHit, Sphere};
use crate::math::Ray;
use crate::simd::F4;

/// Spheres one pack holds: one SSE register's lanes.
pub const SPHERE_LANES: usize = 4;

/// Up to four spheres, their centres and squared radii as structure of
/// arrays, and the spheres themselves (with their scene ids) for the
/// precise test.
#[derive(Clone, Debug, Default)]
pub struct SpherePack {
    center: [[f32; SPHERE_LANES]; 3],
    radius_sq: [f32; SPHERE_LANES],
    spheres: Vec<(u32, Sphere)>,
}

impl SpherePack {
    /// Adds sphere `geom`; `false` (and nothing added) when the pack is full.
    pub fn push(&mut self, geom: u32, sphere: &Sphere) -> bool {
        let k = self.spheres.len();
        if k == SPHERE_LANES {
            return false;
        }
        for c in 0..3 {
            self.center[c][k] = sphere.center[c];
        }
        self.radius_sq[k] = sphere.radius * sphere.radius;
        self.spheres.push((geom, sphere.clone()));
        true
    }

    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty()
    }

    /// The closest hit in `(ray.t_min, t_max)` with its sphere's scene id;
    /// of hits at the same distance, the first sphere's.
    #[inline(always)]
    pub fn closest(&self, ray: &Ray, mut t_max: f32) -> Option<(u32, PrimHit)> {
        let mut best = None;
        let mut candidates = self.candidates(ray);
        while candidates != 0 {
            let (geom, sphere) = &self.spheres[candidates.trailing_zeros() as usize];
            candidates &= candidates - 1;
            if let Some(h) = sphere.intersect_precisely(ray, t_max) {
                t_max = h.t;
                best = Some((*geom, h));
            }
        }
        best
    }

    /// Whether any sphere is hit in `(ray.t_min, ray.t_max)`.
    #[inline(always)]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        let mut candidates = self.candidates(ray);
        while candidates != 0 {
            let (_, sphere) = &self.spheres[candidates.trailing_zeros() as usize];
            candidates &= candidates - 1;
            if sphere.intersect_precisely(ray, ray.t_max).is_some() {
                return true;
            }
        }
        false
    }

    /// Bit `k` set where sphere `k` is not clearly missed by the ray's
    /// line: `Sphere::clearly_missed_by`, lane by lane. A NaN ray leaves
    /// every sphere a candidate, for the precise test to reject.
    #[inline(always)]
    fn candidates(&self, ray: &Ray) -> u32 {
        if self.is_empty() {
            return 0;
        }
        let f = [0, 1, 2].map(|c| F4::splat(ray.origin[c]).sub(F4::load(&self.center[c])));
        let d = [0, 1, 2].map(|c| F4::splat(ray.dir[c]));
        let a = F4::splat(ray.dir.length_squared());
        let minus_b = f[0].mul(d[0]).add(f[1].mul(d[1])).add(f[2].mul(d[2]));
        let ff = f[0].mul(f[0]).add(f[1].mul(f[1])).add(f[2].mul(f[2]));
        let (b2, rr) = (minus_b.mul(minus_b), F4::load(&self.radius_sq));
        let disc = b2.sub(a.mul(ff.sub(rr)));
        let margin = F4::splat(-1e-3).mul(b2.add(a.mul(ff.add(rr))));
        let used = (1u32 << self.spheres.len()) - 1;
        !disc.lt(margin).bits() & used
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::sampling::{uniform_sphere, Rng};

    /// Four spheres from tiny to huge, rays from near and far: the pack
    /// finds the scalar routine's closest hit and any hit, bit for bit.
    #[test]
    fn the_pack_finds_the_scalar_spheres_hits() {
        let spheres = [
            Sphere {
                center: Vec3::new(0.3, 0.2, -0.1),
                radius: 0.25,
            },
            Sphere {
                center: Vec3::new(-0.5, 0.0, 0.4),
                radius: 1e-3,
            },
            Sphere {
                center: Vec3::new(0.0, -1e3, 0.0),
                radius: 999.0,
            },
            Sphere {
                center: Vec3::new(-0.2, 0.6, 0.1),
                radius: 0.4,
            },
        ];
        let mut pack = SpherePack::default();
        for (k, s) in spheres.iter().enumerate() {
            assert!(pack.push(k as u32 + 10, s));
        }
        assert!(!pack.push(99, &spheres[0]), "a fifth sphere does not fit");
        let mut rng = Rng::new(5, 1);
        let mut hits = 0;
        for i in 0..40_000 {
            let reach = [0.5, 2.0, 1e4][i % 3];
            let o = reach * uniform_sphere(rng.next_2d());
            // Half the rays aim near a sphere, so that the small one is met.
            let aim = spheres[i % 4].center + 0.3 * uniform_sphere(rng.next_2d());
            let dir = if i % 2 == 0 {
                (aim - o).normalize()
            } else {
                uniform_sphere(rng.next_2d())
            };
            let mut ray = Ray::new(o, dir);
            if i % 5 == 0 {
                ray.t_max = reach * rng.next_f32();
            }
            let mut expected = None;
            let mut t_max = ray.t_max;
            for (k, s) in spheres.iter().enumerate() {
                if let Some(h) = s.intersect_below(&ray, t_max) {
                    t_max = h.t;
                    expected = Some((k as u32 + 10, h.t));
                }
            }
            let got = pack.closest(&ray, ray.t_max).map(|(g, h)| (g, h.t));
            assert_eq!(got, expected, "{ray:?}");
            assert_eq!(pack.any_hit(&ray), expected.is_some(), "{ray:?}");
            hits += expected.is_some() as u32;
        }
        assert!(hits > 10_000, "{hits} hits");
    }

    #[test]
    fn an_empty_pack_is_never_hit() {
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert!(SpherePack::default().closest(&ray, f32::INFINITY).is_none());
        assert!(!SpherePack::default().any_hit(&ray));
    }
}
