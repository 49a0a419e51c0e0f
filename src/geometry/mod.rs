//! Geometry, below both `accel` and `scene`: the shapes, one per file, each
//! with its intersection routine (shared by both backends), the surface
//! point it builds from a preliminary hit, and, where it can be an area
//! light, its sampling routines; and what the layers above share about
//! them, the backends' `PreliminaryHit` and the shading's `SurfacePoint`.

mod cuboid;
mod mesh;
mod plane;
mod quad;
mod sphere;

pub use cuboid::Cuboid;
pub use mesh::{exact_zeros, has_zero_area, intersect_triangle, Mesh, ShearedRay};
pub use plane::Plane;
pub use quad::Quad;
pub use sphere::Sphere;

use crate::math::{Aabb, PackedVec3, Ray, Vec2, Vec3};
use std::sync::Arc;

/// The largest coordinate magnitude a scene may place anything at. The
/// intersection routines are f32 (as Embree is) and raise coordinate
/// differences to the third power (a triangle's plane distance is the dot
/// product of an offset with a cross product of edges); at ±1e12 the cube
/// of the largest difference stays finite with room for the sums, where at
/// ±1e20 a mesh silently vanished on both backends. The loader refuses
/// scenes whose derived positions (transformed vertices, a sphere's bounds,
/// the eye, lights) reach past it.
pub const MAX_COORDINATE: f32 = 1e12;

/// Whether `p` is finite and within [`MAX_COORDINATE`] on every axis.
#[inline]
pub fn within_bounds(p: Vec3) -> bool {
    p.is_finite() && p.abs().cmple(Vec3::splat(MAX_COORDINATE)).all()
}

/// The first of `points` that is not [`within_bounds`], and its index.
/// Blocks are checked in parallel without a branch per point first: a
/// search that stops at the first one checks a shared index at every
/// point (55 ms for 8.9M vertices on two threads, the blocks 10 ms).
pub fn first_outside_bounds(points: &[PackedVec3]) -> Option<(usize, Vec3)> {
    use rayon::prelude::*;
    let all_within = points.par_chunks(1 << 14).all(|block| {
        block
            .iter()
            .fold(true, |ok, &p| ok & within_bounds(p.into()))
    });
    if all_within {
        return None;
    }
    points
        .par_iter()
        .enumerate()
        .find_first(|(_, &p)| !within_bounds(p.into()))
        .map(|(i, &p)| (i, p.into()))
}

/// Preliminary hit: ray parameter, the scene's shape id (`geom`), the
/// primitive within it (`prim`: triangle index, 0 otherwise) and two
/// shape-specific coordinates (barycentrics of vertices 1 and 2 for
/// triangles, quad parameters for quads).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreliminaryHit {
    pub t: f32,
    pub geom: u32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// What a primitive intersection routine returns: the ray parameter and two
/// shape-specific coordinates (barycentrics, quad parameters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

impl PrimHit {
    /// The hit as the preliminary hit of scene shape `geom`, a shape of
    /// one primitive (a sphere, quad, cuboid or plane).
    #[inline(always)]
    pub fn of_shape(self, geom: u32) -> PreliminaryHit {
        PreliminaryHit {
            t: self.t,
            geom,
            prim: 0,
            u: self.u,
            v: self.v,
        }
    }
}

/// A point on a surface as shading needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Absolute error bound of `p`, per axis.
    pub p_err: Vec3,
    /// Unit geometric normal, on the shape's front side.
    pub n: Vec3,
    /// Unit shading normal: a mesh's vertex normals interpolated at the
    /// point, else `n`. Always in `n`'s hemisphere (`ns · n ≥ 0`), so the
    /// geometric normal alone decides the front side (see
    /// [`Mesh::shading_normal`]).
    pub ns: Vec3,
    /// Whether `ns` comes from vertex normals: only then can it differ from
    /// `n`, and only then does shading pay for the tests that need both.
    pub smooth: bool,
}

impl SurfacePoint {
    /// A point whose shading normal is its geometric normal.
    #[inline]
    pub fn flat(p: Vec3, p_err: Vec3, n: Vec3) -> Self {
        Self {
            p,
            p_err,
            n,
            ns: n,
            smooth: false,
        }
    }
}

/// Closed set of shapes (an enum, not a trait object, in the hot path).
#[derive(Clone, Debug)]
pub enum Geometry {
    Sphere(Sphere),
    Plane(Plane),
    Quad(Quad),
    Cuboid(Cuboid),
    /// Shared, so that a backend can keep the vertices it reads in place
    /// (Embree's shared buffers, the native gathered leaves) without the
    /// rest of the scene.
    Mesh(Arc<Mesh>),
}

impl From<Mesh> for Geometry {
    fn from(mesh: Mesh) -> Self {
        Geometry::Mesh(Arc::new(mesh))
    }
}

impl Geometry {
    /// The surface area, which an emitter's power is its emission times;
    /// `None` for an infinite plane.
    pub fn area(&self) -> Option<f32> {
        Some(match self {
            Geometry::Sphere(s) => s.area(),
            Geometry::Quad(q) => q.area(),
            Geometry::Cuboid(c) => c.area(),
            Geometry::Mesh(m) => (0..m.triangle_count() as u32)
                .map(|i| m.triangle_area(i))
                .sum(),
            Geometry::Plane(_) => return None,
        })
    }

    /// Number of primitives the backends see (triangles for a mesh).
    pub fn primitive_count(&self) -> usize {
        match self {
            Geometry::Mesh(m) => m.triangle_count(),
            _ => 1,
        }
    }

    /// Bounds of the whole shape; `None` for the unbounded plane.
    pub fn bounds(&self) -> Option<Aabb> {
        match self {
            Geometry::Mesh(m) => Some(m.bounds()),
            g => g.primitive_bounds(0),
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

    /// Always inlined: rustc kept it out of line, which cost the native
    /// bunny 57 instructions per sample and cornell-area 63.
    #[inline(always)]
    pub fn surface(&self, prim: u32, ray: &Ray, hit: &PrimHit) -> SurfacePoint {
        match self {
            Geometry::Sphere(s) => s.surface(ray, hit),
            Geometry::Plane(p) => p.surface(ray, hit),
            Geometry::Quad(q) => q.surface(ray, hit),
            Geometry::Cuboid(c) => c.surface(ray, hit),
            Geometry::Mesh(m) => m.surface(prim, hit),
        }
    }

    /// Texture coordinates of a hit, asked for only by textured materials:
    /// a scene without textures never pays for them.
    pub fn uv(&self, prim: u32, hit: &PrimHit, sp: &SurfacePoint) -> Vec2 {
        match self {
            Geometry::Sphere(s) => s.uv(sp),
            Geometry::Plane(p) => p.uv(sp),
            Geometry::Quad(_) => Vec2::new(hit.u, hit.v),
            Geometry::Cuboid(c) => c.uv(sp),
            Geometry::Mesh(m) => m.uv(prim, hit),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::spawn_ray;
    use crate::sampling::{uniform_sphere, Rng};

    /// Shapes of size `s` around the origin.
    fn shapes(s: f32) -> Vec<(Geometry, bool)> {
        let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * s;
        vec![
            (
                Geometry::Sphere(Sphere {
                    center: v(0.3, -0.2, 0.1),
                    radius: s,
                }),
                true,
            ),
            (
                Geometry::Cuboid(Cuboid {
                    min: v(-1.0, -0.5, -0.7),
                    max: v(0.8, 0.9, 0.6),
                }),
                true,
            ),
            (
                Geometry::Quad(
                    Quad::new(v(-1.0, 0.1, -1.0), v(2.0, 0.3, 0.0), v(0.0, 0.2, 2.0)).unwrap(),
                ),
                false,
            ),
            (
                Geometry::Plane(Plane::new(v(0.0, 0.2, 0.0), Vec3::new(0.1, 1.0, 0.2))),
                false,
            ),
            (
                Geometry::from(Mesh {
                    positions: [v(-1.0, 0.0, -1.0), v(1.0, 0.2, -0.5), v(0.0, -0.1, 1.0)]
                        .map(PackedVec3::from)
                        .to_vec(),
                    indices: vec![[0, 1, 2]],
                    uvs: None,
                    normals: None,
                }),
                false,
            ),
        ]
    }

    /// From points on each shape, 1,000 random directions: leaving rays
    /// never hit the (convex or flat) shape again; entering rays of closed
    /// shapes always find the exit, away from where they started.
    #[test]
    fn reintersection_has_no_self_hits_and_finds_exits_at_every_scale() {
        let mut rng = Rng::new(42, 1);
        for scale in [1e-4f32, 1e-2, 1.0, 1e2, 1e4] {
            for (g, closed) in shapes(scale) {
                let mut hits = 0;
                for _ in 0..20 {
                    // A ray from far outside towards the shape's middle.
                    let target = Vec3::new(0.0, 0.1, 0.0) * scale
                        + 0.3 * scale * uniform_sphere(rng.next_2d());
                    let origin = target + 10.0 * scale * uniform_sphere(rng.next_2d());
                    let ray = Ray::new(origin, (target - origin).normalize());
                    let Some(h) = g.intersect(0, &ray) else {
                        continue;
                    };
                    hits += 1;
                    let sp = g.surface(0, &ray, &h);
                    assert!(
                        sp.p.is_finite() && sp.n.is_finite(),
                        "{} at {scale}",
                        g.name()
                    );
                    let (mut self_hits, mut missed_exits) = (0, 0);
                    for _ in 0..1000 {
                        let w = uniform_sphere(rng.next_2d());
                        let r = spawn_ray(sp.p, sp.p_err, sp.n, w);
                        let again = g.intersect(0, &r);
                        let leaving = w.dot(sp.n) > 0.0;
                        if leaving || !closed {
                            if again.is_some() {
                                self_hits += 1;
                            }
                        } else {
                            match again {
                                Some(e) if (r.at(e.t) - sp.p).length() > 1e-4 * scale => {}
                                Some(e) if w.dot(sp.n).abs() < 1e-3 && e.t > 0.0 => {}
                                _ => missed_exits += 1,
                            }
                        }
                    }
                    assert_eq!(self_hits, 0, "{} at scale {scale}: self-hits", g.name());
                    assert_eq!(
                        missed_exits,
                        0,
                        "{} at scale {scale}: missed exits",
                        g.name()
                    );
                }
                assert!(
                    hits >= 5,
                    "{} at scale {scale}: only {hits} probe hits",
                    g.name()
                );
            }
        }
    }

    #[test]
    fn axis_parallel_rays_give_no_nan() {
        for (g, _) in shapes(1.0) {
            for d in [Vec3::X, -Vec3::Y, Vec3::Z] {
                let ray = Ray::new(Vec3::new(0.0, 0.15, 0.0) - 5.0 * d, d);
                if let Some(h) = g.intersect(0, &ray) {
                    assert!(
                        h.t.is_finite() && h.u.is_finite() && h.v.is_finite(),
                        "{}",
                        g.name()
                    );
                    let sp = g.surface(0, &ray, &h);
                    assert!(sp.p.is_finite() && sp.n.is_finite());
                }
            }
        }
    }

    #[test]
    fn degenerate_triangles_are_never_hit() {
        let m = Mesh {
            positions: vec![
                PackedVec3::ZERO,
                PackedVec3::X,
                2.0 * PackedVec3::X,
                PackedVec3::ZERO,
            ],
            indices: vec![[0, 1, 2], [0, 0, 1], [0, 3, 1]],
            uvs: None,
            normals: None,
        };
        let mut rng = Rng::new(3, 3);
        for _ in 0..10_000 {
            let o = 2.0 * uniform_sphere(rng.next_2d());
            let target = Vec3::new(rng.next_f32() * 2.0, 0.0, 0.0);
            let ray = Ray::new(o, target - o);
            for prim in 0..3 {
                assert!(m.intersect_triangle(prim, &ray).is_none());
            }
        }
    }
}
