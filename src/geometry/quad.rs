//! Bounded plane: the parallelogram `p0 + u e1 + v e2`, `u, v ∈ [0, 1]`.
//!
//! Corners are given counter-clockwise seen from the front, as in
//! SCENES.md: `p0, p1, p2, p3` with `e1 = p1 − p0`, `e2 = p3 − p0` and the
//! front normal `e1 × e2`. The hit's `(u, v)` are these parameters, so the
//! surface point is rebuilt from the corners, not from the ray.

use super::{PrimHit, SurfacePoint};
use crate::math::{gamma, Aabb, Ray, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Quad {
    pub p0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    normal: Vec3,
    area: f32,
    /// Dual basis: `u = (p − p0)·du`, `v = (p − p0)·dv`.
    du: Vec3,
    dv: Vec3,
}

impl Quad {
    /// `None` when the edges are parallel or zero (no area).
    pub fn new(p0: Vec3, e1: Vec3, e2: Vec3) -> Option<Self> {
        let c = e1.cross(e2);
        let area = c.length();
        if !(area.is_finite() && area > 0.0) {
            return None;
        }
        let normal = c / area;
        // c / |c|², without squaring |c| (which overflows for edges of
        // 1e12, well inside the coordinates a scene may use).
        let w = normal / area;
        Some(Self {
            p0,
            e1,
            e2,
            normal,
            area,
            du: e2.cross(w),
            dv: w.cross(e1),
        })
    }

    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The dual basis `(du, dv)`: a point `p` of the quad's plane has
    /// parameters `u = (p − p0)·du`, `v = (p − p0)·dv`.
    pub fn dual(&self) -> (Vec3, Vec3) {
        (self.du, self.dv)
    }

    pub fn area(&self) -> f32 {
        self.area
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&[
            self.p0,
            self.p0 + self.e1,
            self.p0 + self.e2,
            self.p0 + self.e1 + self.e2,
        ])
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<PrimHit> {
        let denom = self.normal.dot(ray.dir);
        if denom == 0.0 {
            return None;
        }
        let t = (self.p0 - ray.origin).dot(self.normal) / denom;
        if !(t > ray.t_min && t < ray.t_max) {
            return None;
        }
        // u and v as affine functions of t, whose terms do not wait for
        // the division.
        let from_p0 = ray.origin - self.p0;
        let u = from_p0.dot(self.du) + t * ray.dir.dot(self.du);
        let v = from_p0.dot(self.dv) + t * ray.dir.dot(self.dv);
        ((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)).then_some(PrimHit { t, u, v })
    }

    pub fn surface(&self, _ray: &Ray, hit: &PrimHit) -> SurfacePoint {
        self.point_at(Vec2::new(hit.u, hit.v))
    }

    pub fn point_at(&self, uv: Vec2) -> SurfacePoint {
        let a = self.p0;
        let b = uv.x * self.e1;
        let c = uv.y * self.e2;
        let p = a + b + c;
        SurfacePoint::flat(p, gamma(7) * (a.abs() + b.abs() + c.abs()), self.normal)
    }
}
