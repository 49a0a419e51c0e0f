//! Shapes: one per file, each with its intersection routine (shared by both
//! backends), the surface point it builds from a preliminary hit, and, where
//! it can be an area light, its sampling routines.

mod cuboid;
mod mesh;
mod plane;
mod quad;
mod sphere;

pub use cuboid::Cuboid;
pub use mesh::{intersect_triangle, Mesh};
pub use plane::Plane;
pub use quad::Quad;
pub use sphere::Sphere;

use crate::math::{Aabb, Ray, Vec2, Vec3};

/// What a primitive intersection routine returns: the ray parameter and two
/// shape-specific coordinates (barycentrics, quad parameters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// A point on a surface as shading needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Absolute error bound of `p`, per axis.
    pub p_err: Vec3,
    /// Unit geometric normal, on the shape's front side.
    pub n: Vec3,
    /// Texture coordinates.
    pub uv: Vec2,
}

/// Closed set of shapes (an enum, not a trait object, in the hot path).
#[derive(Clone, Debug)]
pub enum Geometry {
    Sphere(Sphere),
    Plane(Plane),
    Quad(Quad),
    Cuboid(Cuboid),
    Mesh(Mesh),
}

impl Geometry {
    /// Number of primitives the backends see (triangles for a mesh).
    pub fn primitive_count(&self) -> usize {
        match self {
            Geometry::Mesh(m) => m.triangle_count(),
            _ => 1,
        }
    }

    /// Bounds of primitive `prim`; `None` for the unbounded plane.
    pub fn primitive_bounds(&self, prim: u32) -> Option<Aabb> {
        match self {
            Geometry::Sphere(s) => Some(s.bounds()),
            Geometry::Plane(_) => None,
            Geometry::Quad(q) => Some(q.bounds()),
            Geometry::Cuboid(c) => Some(c.bounds()),
            Geometry::Mesh(m) => Some(m.triangle_bounds(prim)),
        }
    }

    #[inline]
    pub fn intersect(&self, prim: u32, ray: &Ray) -> Option<PrimHit> {
        match self {
            Geometry::Sphere(s) => s.intersect(ray),
            Geometry::Plane(p) => p.intersect(ray),
            Geometry::Quad(q) => q.intersect(ray),
            Geometry::Cuboid(c) => c.intersect(ray),
            Geometry::Mesh(m) => m.intersect_triangle(prim, ray),
        }
    }

    pub fn surface(&self, prim: u32, ray: &Ray, hit: &PrimHit) -> SurfacePoint {
        match self {
            Geometry::Sphere(s) => s.surface(ray, hit),
            Geometry::Plane(p) => p.surface(ray, hit),
            Geometry::Quad(q) => q.surface(ray, hit),
            Geometry::Cuboid(c) => c.surface(ray, hit),
            Geometry::Mesh(m) => m.surface(prim, hit),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Geometry::Sphere(_) => "sphere",
            Geometry::Plane(_) => "plane",
            Geometry::Quad(_) => "quad",
            Geometry::Cuboid(_) => "cuboid",
            Geometry::Mesh(_) => "mesh",
        }
    }
}
