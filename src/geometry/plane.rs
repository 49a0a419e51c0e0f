//! Infinite plane through `point` with unit normal `normal`.
//!
//! It has no finite bounds, so backends test it outside their hierarchy
//! (Embree gets clamped finite bounds). Texture coordinates are the position
//! in a tangent frame of the plane, so a texture tiles across it.

use super::{PrimHit, SurfacePoint};
use crate::math::{gamma, Frame, Ray, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    pub point: Vec3,
    pub normal: Vec3,
    frame: Frame,
}

impl Plane {
    /// `normal` must be finite and non-zero; it is normalised here, after
    /// dividing by its largest component, so that neither a huge nor a tiny
    /// normal over- or underflows on the way (`[0, 3e38, 3e38]` is a
    /// direction like any other).
    pub fn new(point: Vec3, normal: Vec3) -> Self {
        let normal = (normal / normal.abs().max_element()).normalize();
        Self {
            point,
            normal,
            frame: Frame::from_normal(normal),
        }
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<PrimHit> {
        let denom = self.normal.dot(ray.dir);
        if denom == 0.0 {
            return None;
        }
        let t = (self.point - ray.origin).dot(self.normal) / denom;
        (t > ray.t_min && t < ray.t_max).then_some(PrimHit { t, u: 0.0, v: 0.0 })
    }

    pub fn surface(&self, ray: &Ray, hit: &PrimHit) -> SurfacePoint {
        let p = ray.at(hit.t);
        // Snap onto the plane so that the error is that of the projection.
        let p = p - (p - self.point).dot(self.normal) * self.normal;
        SurfacePoint::flat(p, gamma(6) * (p.abs() + self.point.abs()), self.normal)
    }

    /// Coordinates along the plane's tangent axes.
    pub fn uv(&self, sp: &SurfacePoint) -> Vec2 {
        let local = sp.p - self.point;
        Vec2::new(local.dot(self.frame.s), local.dot(self.frame.t))
    }

    /// Tangent axes used for texture coordinates.
    pub fn tangents(&self) -> (Vec3, Vec3) {
        (self.frame.s, self.frame.t)
    }
}
