//! Sphere given by centre and radius.
//!
//! Intersection follows "Precision Improvements for Ray/Sphere Intersection"
//! (Haines et al., Ray Tracing Gems ch. 7): the discriminant is computed from
//! the distance of the centre to the ray line, and the near root from
//! `c / q`, so hits stay accurate at radii from 1e-4 to 1e6 and a ray leaving
//! the surface does not find it again. Emitting spheres are sampled by the
//! cone of directions they subtend (uniform area sampling from inside).

use super::{PrimHit, SurfacePoint};
use crate::math::{gamma, Aabb, Frame, Ray, Vec2, Vec3};
use crate::sampling::{uniform_cone, uniform_cone_pdf, uniform_sphere};
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn bounds(&self) -> Aabb {
        Aabb::new(
            self.center - Vec3::splat(self.radius),
            self.center + Vec3::splat(self.radius),
        )
    }

    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    /// Always inlined, the precise test never: most rays are turned away
    /// by the quick test, in the caller's registers.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray) -> Option<PrimHit> {
        self.intersect_below(ray, ray.t_max)
    }

    /// `intersect` with `t_max` in place of the ray's, so that a caller
    /// narrowing it need not write a copy of the ray, whose wide reads
    /// here would wait for the copy's narrow writes.
    #[inline(always)]
    pub fn intersect_below(&self, ray: &Ray, t_max: f32) -> Option<PrimHit> {
        if self.clearly_missed_by(ray) {
            return None;
        }
        self.intersect_precisely(ray, t_max)
    }

    /// Whether the ray's line passes the sphere by a clear margin, decided
    /// without the square roots and divisions of the precise test: most
    /// rays miss, and those operations are the slow part of their test.
    /// The discriminant `b² − a(|f|² − r²)` is `a(r² − ℓ²)`, ℓ the distance
    /// from the centre to the line; it cancels badly when the origin is far
    /// away, so a miss counts only below −10⁻³ of the terms' size, a margin
    /// far above the rounding of either test. The precise test rejects such
    /// a line too, so hits do not change; NaN and infinities fall through
    /// to it.
    #[inline(always)]
    fn clearly_missed_by(&self, ray: &Ray) -> bool {
        let f = ray.origin - self.center;
        let (a, b, ff) = (
            ray.dir.length_squared(),
            -f.dot(ray.dir),
            f.length_squared(),
        );
        let (b2, rr) = (b * b, self.radius * self.radius);
        b2 - a * (ff - rr) < -1e-3 * (b2 + a * (ff + rr))
    }

    /// The hit in `(ray.t_min, t_max)`, for callers that have made the
    /// quick rejection themselves (the root's `SpherePack`).
    #[inline(never)]
    pub fn intersect_precisely(&self, ray: &Ray, t_max: f32) -> Option<PrimHit> {
        let f = ray.origin - self.center;
        let a = ray.dir.length_squared();
        let b = -f.dot(ray.dir);
        let r = self.radius;
        // |f|^2 - r^2 written as a product of a difference: no cancellation
        // when the origin sits on the surface.
        let fl = f.length();
        let c = (fl - r) * (fl + r);
        // Squared distance from the centre to the ray line, times a.
        let l = f + (b / a) * ray.dir;
        let disc = a * (r - l.length()) * (r + l.length());
        if disc < 0.0 {
            return None;
        }
        let q = b + b.signum() * disc.sqrt();
        if q == 0.0 {
            return None;
        }
        let (mut t0, mut t1) = (c / q, q / a);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = if t0 > ray.t_min && t0 < t_max {
            t0
        } else if t1 > ray.t_min && t1 < t_max {
            t1
        } else {
            return None;
        };
        Some(PrimHit { t, u: 0.0, v: 0.0 })
    }

    pub fn surface(&self, ray: &Ray, hit: &PrimHit) -> SurfacePoint {
        let dir = ray.at(hit.t) - self.center;
        let n = dir.normalize();
        // Re-project onto the surface: the error then only depends on |p|.
        let p = self.center + self.radius * n;
        let p_err = gamma(5) * (p.abs() + Vec3::splat(self.radius));
        SurfacePoint::flat(p, p_err, n)
    }

    /// Equirectangular coordinates of the normal's direction.
    pub fn uv(&self, sp: &SurfacePoint) -> Vec2 {
        let n = sp.n;
        let phi = n.z.atan2(n.x);
        let u = 0.5 + phi / (2.0 * PI);
        // v = 1 at the +y pole, so an equirectangular image stands upright.
        let v = 1.0 - n.y.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(u, v)
    }

    /// Samples a point on the sphere as seen from `from`; returns the point
    /// and the pdf with respect to solid angle at `from`.
    pub fn sample(&self, from: Vec3, u: Vec2) -> Option<(SurfacePoint, f32)> {
        let to_center = self.center - from;
        let d2 = to_center.length_squared();
        let r2 = self.radius * self.radius;
        if d2 <= r2 * (1.0 + 1e-4) {
            // Inside (or on) the sphere: uniform area sampling.
            let n = uniform_sphere(u);
            let p = self.center + self.radius * n;
            let sp = self.point(p, n);
            let w = p - from;
            let dist2 = w.length_squared();
            let cos = n.dot(-w).abs() / dist2.sqrt();
            if cos == 0.0 || dist2 == 0.0 {
                return None;
            }
            return Some((sp, dist2 / (cos * self.area())));
        }
        let sin2_max = r2 / d2;
        let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
        let frame = Frame::from_normal(to_center / d2.sqrt());
        let dir = frame.to_world(uniform_cone(u, cos_max));
        // Point on the sphere along dir (nearest root); fall back to the
        // tangent point when rounding misses the sphere at the cone's rim.
        let ray = Ray::new(from, dir);
        let t = match self.intersect(&ray) {
            Some(h) => h.t,
            None => dir.dot(to_center),
        };
        let n = (from + t * dir - self.center).normalize();
        let p = self.center + self.radius * n;
        Some((self.point(p, n), uniform_cone_pdf(cos_max)))
    }

    /// Solid-angle pdf of `sample` producing the point `p` seen from `from`.
    pub fn pdf(&self, from: Vec3, p: Vec3, n: Vec3) -> f32 {
        let d2 = (self.center - from).length_squared();
        let r2 = self.radius * self.radius;
        if d2 <= r2 * (1.0 + 1e-4) {
            let w = p - from;
            let dist2 = w.length_squared();
            let cos = n.dot(w).abs() / dist2.sqrt();
            if cos == 0.0 {
                return 0.0;
            }
            return dist2 / (cos * self.area());
        }
        let cos_max = (1.0 - r2 / d2).max(0.0).sqrt();
        uniform_cone_pdf(cos_max)
    }

    fn point(&self, p: Vec3, n: Vec3) -> SurfacePoint {
        SurfacePoint::flat(p, gamma(5) * (p.abs() + Vec3::splat(self.radius)), n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Every ray the quick test turns away, the precise test misses too,
    /// from near and far, at small and large radii; and it turns most
    /// misses away.
    #[test]
    fn the_quick_rejection_never_drops_a_hit() {
        let mut rng = Rng::new(11, 3);
        // Radius, origin's distance, aim's spread, share of misses at least
        // turned away (from far away, the margin is wide).
        let cases = [
            (1e-4f32, 3e-4f32, 2e-4f32, 0.9f32),
            (1.0, 1.5, 2.0, 0.9),
            (1.0, 1e5, 2e4, 0.5),
            (1e6, 3e6, 2e6, 0.9),
        ];
        for (radius, distance, spread, share) in cases {
            let sphere = Sphere {
                center: Vec3::new(0.2, -0.1, 0.3) * radius,
                radius,
            };
            let (mut quick, mut misses) = (0, 0);
            for _ in 0..50_000 {
                let from = sphere.center + distance * uniform_sphere(rng.next_2d());
                // Aimed near the centre, so that many rays graze; half of
                // them not of unit length.
                let at = sphere.center + spread * rng.next_f32() * uniform_sphere(rng.next_2d());
                let length = if rng.next_f32() < 0.5 {
                    1.0
                } else {
                    (at - from).length()
                };
                let ray = Ray::new(from, (at - from) / length);
                let precise = sphere.intersect_precisely(&ray, ray.t_max);
                if sphere.clearly_missed_by(&ray) {
                    assert_eq!(precise, None, "{sphere:?} {ray:?}");
                    quick += 1;
                }
                misses += precise.is_none() as u32;
            }
            eprintln!("r {radius}, at {distance}: {quick} of {misses} misses turned away");
            assert!(quick as f32 >= share * misses as f32 && misses > 5_000);
        }
    }
}
