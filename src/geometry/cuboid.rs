//! Axis-aligned box `[min, max]`, closed, normals pointing out.
//!
//! Slab intersection; from outside it reports the entry face, from inside
//! the exit face. The face is recovered from the hit point by shared code
//! (`surface`), so backends return only `t`.

use super::{PrimHit, SurfacePoint};
use crate::math::{gamma, Aabb, Ray, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Cuboid {
    pub min: Vec3,
    pub max: Vec3,
}

impl Cuboid {
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.min, self.max)
    }

    pub fn area(&self) -> f32 {
        let e = self.max - self.min;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<PrimHit> {
        let inv = ray.dir.recip();
        let mut t_near = f32::NEG_INFINITY;
        let mut t_far = f32::INFINITY;
        for axis in 0..3 {
            let (o, d, i) = (ray.origin[axis], ray.dir[axis], inv[axis]);
            if d == 0.0 {
                if o < self.min[axis] || o > self.max[axis] {
                    return None;
                }
                continue;
            }
            let t0 = (self.min[axis] - o) * i;
            let t1 = (self.max[axis] - o) * i;
            t_near = t_near.max(t0.min(t1));
            t_far = t_far.min(t0.max(t1));
        }
        if t_near > t_far {
            return None;
        }
        let t = if t_near > ray.t_min && t_near < ray.t_max {
            t_near
        } else if t_far > ray.t_min && t_far < ray.t_max {
            t_far
        } else {
            return None;
        };
        Some(PrimHit { t, u: 0.0, v: 0.0 })
    }

    pub fn surface(&self, ray: &Ray, hit: &PrimHit) -> SurfacePoint {
        let mut p = ray.at(hit.t);
        // The face is the one the point is nearest to, relative to the size.
        let half = 0.5 * (self.max - self.min);
        let rel = (p - 0.5 * (self.min + self.max)) / half.max(Vec3::splat(f32::MIN_POSITIVE));
        let axis = if rel.x.abs() >= rel.y.abs() && rel.x.abs() >= rel.z.abs() {
            0
        } else if rel.y.abs() >= rel.z.abs() {
            1
        } else {
            2
        };
        let positive = rel[axis] > 0.0;
        let mut n = Vec3::ZERO;
        n[axis] = if positive { 1.0 } else { -1.0 };
        p[axis] = if positive {
            self.max[axis]
        } else {
            self.min[axis]
        };
        let mut p_err = gamma(5) * (p.abs() + ray.origin.abs());
        p_err[axis] = 0.0;
        SurfacePoint::flat(p, p_err, n)
    }

    /// The position within the hit face, from its minimum corner.
    pub fn uv(&self, sp: &SurfacePoint) -> Vec2 {
        // The normal of a face is a unit axis.
        let axis = if sp.n.x != 0.0 {
            0
        } else if sp.n.y != 0.0 {
            1
        } else {
            2
        };
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        Vec2::new(
            (sp.p[a] - self.min[a]) / (self.max[a] - self.min[a]),
            (sp.p[b] - self.min[b]) / (self.max[b] - self.min[b]),
        )
    }

    /// Uniform point on the surface (faces chosen by area).
    pub fn sample_area(&self, u: Vec2) -> SurfacePoint {
        let e = self.max - self.min;
        let faces = [
            e.y * e.z,
            e.y * e.z,
            e.z * e.x,
            e.z * e.x,
            e.x * e.y,
            e.x * e.y,
        ];
        let total: f32 = faces.iter().sum();
        let mut pick = u.x * total;
        let mut face = 5;
        for (i, &a) in faces.iter().enumerate() {
            if pick < a {
                face = i;
                break;
            }
            pick -= a;
        }
        let ux = (pick / faces[face]).clamp(0.0, 1.0);
        let axis = face / 2;
        let positive = face % 2 == 0;
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut p = Vec3::ZERO;
        p[axis] = if positive {
            self.max[axis]
        } else {
            self.min[axis]
        };
        p[a] = self.min[a] + ux * e[a];
        p[b] = self.min[b] + u.y * e[b];
        let mut n = Vec3::ZERO;
        n[axis] = if positive { 1.0 } else { -1.0 };
        let mut p_err = gamma(3) * (p.abs() + self.min.abs());
        p_err[axis] = 0.0;
        SurfacePoint::flat(p, p_err, n)
    }
}
