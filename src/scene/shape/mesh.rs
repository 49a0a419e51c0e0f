//! Triangle mesh: shared vertex positions, index triples, optional
//! per-vertex texture coordinates. A lone `triangle` in a scene is a mesh of
//! one triangle.
//!
//! A hit's `(u, v)` are the barycentrics of vertices 1 and 2, the convention
//! Embree uses, so both backends hand shading the same numbers.

use super::{PrimHit, SurfacePoint};
use crate::math::{gamma, Aabb, Ray, Vec2, Vec3};
use crate::sampling::{uniform_triangle, Discrete};

#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex texture coordinates, same length as `positions` when present.
    pub uvs: Option<Vec<Vec2>>,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    #[inline]
    pub fn vertices(&self, prim: u32) -> [Vec3; 3] {
        let [a, b, c] = self.indices[prim as usize];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    pub fn triangle_bounds(&self, prim: u32) -> Aabb {
        Aabb::from_points(&self.vertices(prim))
    }

    pub fn triangle_area(&self, prim: u32) -> f32 {
        let [a, b, c] = self.vertices(prim);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Möller–Trumbore. A triangle of zero area is never hit.
    #[inline]
    pub fn intersect_triangle(&self, prim: u32, ray: &Ray) -> Option<PrimHit> {
        let [p0, p1, p2] = self.vertices(prim);
        intersect_triangle(p0, p1 - p0, p2 - p0, ray)
    }

    pub fn surface(&self, prim: u32, hit: &PrimHit) -> SurfacePoint {
        self.point_at(prim, Vec2::new(hit.u, hit.v))
    }

    pub fn point_at(&self, prim: u32, b: Vec2) -> SurfacePoint {
        let [p0, p1, p2] = self.vertices(prim);
        let b0 = 1.0 - b.x - b.y;
        let (a, bb, c) = (b0 * p0, b.x * p1, b.y * p2);
        let p = a + bb + c;
        let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        SurfacePoint {
            p,
            p_err: gamma(7) * (a.abs() + bb.abs() + c.abs()),
            n,
        }
    }

    /// Per-vertex uvs interpolated at the hit, else its barycentrics.
    pub fn uv(&self, prim: u32, hit: &PrimHit) -> Vec2 {
        let b = Vec2::new(hit.u, hit.v);
        match &self.uvs {
            Some(uvs) => {
                let [i0, i1, i2] = self.indices[prim as usize];
                (1.0 - b.x - b.y) * uvs[i0 as usize]
                    + b.x * uvs[i1 as usize]
                    + b.y * uvs[i2 as usize]
            }
            None => b,
        }
    }

    /// Area-proportional distribution over the triangles (for emitters).
    pub fn area_distribution(&self) -> Option<Discrete> {
        Discrete::new((0..self.indices.len() as u32).map(|i| self.triangle_area(i)))
    }

    /// Uniform point on triangle `prim`.
    pub fn sample_triangle(&self, prim: u32, u: Vec2) -> SurfacePoint {
        self.point_at(prim, uniform_triangle(u))
    }

    /// Applies an affine transform to the positions.
    pub fn transform(&mut self, m: &crate::math::Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
    }
}

/// Möller–Trumbore on `p0 + u e1 + v e2`; `None` for a degenerate triangle.
#[inline]
pub fn intersect_triangle(p0: Vec3, e1: Vec3, e2: Vec3, ray: &Ray) -> Option<PrimHit> {
    let pvec = ray.dir.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let tvec = ray.origin - p0;
    let u = tvec.dot(pvec) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let v = ray.dir.dot(qvec) * inv_det;
    if !(v >= 0.0 && u + v <= 1.0) {
        return None;
    }
    let t = e2.dot(qvec) * inv_det;
    (t > ray.t_min && t < ray.t_max).then_some(PrimHit { t, u, v })
}
