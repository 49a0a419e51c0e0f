//! Triangle mesh: shared vertex positions, index triples, optional
//! per-vertex texture coordinates. A lone `triangle` in a scene is a mesh of
//! one triangle.
//!
//! A hit's `(u, v)` are the barycentrics of vertices 1 and 2, the convention
//! Embree uses, so both backends hand shading the same numbers.
//!
//! The ray-triangle test is watertight (Woop, Benthin and Wald 2013, as in
//! pbrt-v4): in a frame where the ray runs along +z from the origin, a
//! triangle is hit when the three 2D edge functions of the ray's point have
//! one sign. Two triangles sharing an edge compute its edge function from
//! the same two vertices, with opposite signs, so a ray through the edge
//! hits at least one of them: no ray slips between the triangles of a
//! closed mesh. An edge function that rounds to exactly zero is recomputed
//! in f64, so a ray through a shared vertex is decided exactly too. The
//! hit's distance is the ray's distance to the triangle's plane (see
//! `plane_distance`).

use super::{PrimHit, SurfacePoint};
use crate::math::{gamma, Aabb, PackedVec3, Ray, Vec2, Vec3};
use crate::sampling::{uniform_triangle, Discrete};

#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<PackedVec3>,
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex texture coordinates, same length as `positions` when present.
    pub uvs: Option<Vec<Vec2>>,
    /// Per-vertex shading normals, same length as `positions` when present.
    pub normals: Option<Vec<PackedVec3>>,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    #[inline]
    pub fn vertices(&self, prim: u32) -> [Vec3; 3] {
        let [a, b, c] = self.indices[prim as usize];
        [a, b, c].map(|i| Vec3::from(self.positions[i as usize]))
    }

    /// Bounds of all the mesh's vertices, gathered in parallel chunks
    /// (a large mesh has millions).
    pub fn bounds(&self) -> Aabb {
        use rayon::prelude::*;
        self.positions
            .par_chunks(1 << 16)
            .map(Aabb::from_points)
            .reduce(|| Aabb::EMPTY, Aabb::union)
    }

    pub fn triangle_bounds(&self, prim: u32) -> Aabb {
        Aabb::from_points(&self.vertices(prim))
    }

    pub fn triangle_area(&self, prim: u32) -> f32 {
        let [a, b, c] = self.vertices(prim);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The watertight test; a triangle of zero area is never hit.
    #[inline]
    pub fn intersect_triangle(&self, prim: u32, ray: &Ray) -> Option<PrimHit> {
        intersect_triangle(self.vertices(prim), ray)
    }

    /// The point of a hit, with the shading normal of the vertex normals
    /// when the mesh has them: a mesh without pays one branch.
    pub fn surface(&self, prim: u32, hit: &PrimHit) -> SurfacePoint {
        let b = Vec2::new(hit.u, hit.v);
        let mut sp = self.point_at(prim, b);
        if let Some(normals) = &self.normals {
            sp.ns = shading_normal(normals, self.indices[prim as usize], b, sp.n);
            sp.smooth = true;
        }
        sp
    }

    pub fn point_at(&self, prim: u32, b: Vec2) -> SurfacePoint {
        let [p0, p1, p2] = self.vertices(prim);
        let b0 = 1.0 - b.x - b.y;
        let (a, bb, c) = (b0 * p0, b.x * p1, b.y * p2);
        let p = a + bb + c;
        let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        SurfacePoint::flat(p, gamma(7) * (a.abs() + bb.abs() + c.abs()), n)
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

    /// Applies an affine transform to the positions, and its inverse
    /// transpose to the normals (renormalised; a zero normal stays zero),
    /// which keeps them perpendicular to the surface under a non-uniform
    /// scale.
    pub fn transform(&mut self, m: &crate::math::Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        if let Some(normals) = &mut self.normals {
            let to_normal = crate::math::Mat3::from_mat4(*m).inverse().transpose();
            for n in normals {
                *n = (to_normal * *n).normalize_or_zero();
            }
        }
    }

    /// Smooth vertex normals computed from the faces, as Mitsuba 3's
    /// `Mesh::recompute_vertex_normals` does (Thürmer and Wüthrich 1998):
    /// the sum of the unit normals of the faces around a vertex, each
    /// weighted by the face's angle at the vertex, normalised. A vertex
    /// whose faces cancel out gets a zero normal, which shading replaces
    /// with the face normal (Mitsuba writes an arbitrary (1, 0, 0)).
    pub fn compute_vertex_normals(&mut self) {
        // Summed in the stored layout, in place: a large mesh's normals
        // need not exist twice.
        let mut sums = vec![PackedVec3::ZERO; self.positions.len()];
        for &tri in &self.indices {
            let p = tri.map(|i| Vec3::from(self.positions[i as usize]));
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            for k in 0..3 {
                let d0 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let d1 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                sums[tri[k] as usize] += PackedVec3::from(n * unit_angle(d0, d1));
            }
        }
        for n in &mut sums {
            *n = Vec3::from(*n).normalize_or_zero().into();
        }
        self.normals = Some(sums);
    }
}

/// The angle between unit vectors, accurate near 0 and π too (Mitsuba's
/// `unit_angle`, where an arc cosine loses precision).
fn unit_angle(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 {
        std::f32::consts::PI - 2.0 * (0.5 * (a + b).length()).min(1.0).asin()
    } else {
        2.0 * (0.5 * (b - a).length()).min(1.0).asin()
    }
}

/// The vertex normals of triangle `tri` interpolated at barycentrics `b`
/// and normalised, on the side of the geometric normal `n`. A zero vertex
/// normal stands in for `n` at its corner, and a zero interpolation gives
/// `n`.
///
/// pbrt-v4 turns the geometric normal towards the shading normal; Mitsuba 3
/// keeps both as they are. luz turns the shading normal instead, so the
/// winding alone decides a triangle's front side (emission, one-sided
/// materials, the sides of a dielectric), as it does for meshes without
/// normals; the shading only bends within that side. A file whose normals
/// all point against its winding is therefore shaded as its winding says.
#[inline]
fn shading_normal(normals: &[PackedVec3], tri: [u32; 3], b: Vec2, n: Vec3) -> Vec3 {
    let corner = |i: u32| {
        let v = Vec3::from(normals[i as usize]);
        if v == Vec3::ZERO {
            n
        } else {
            v
        }
    };
    let [i0, i1, i2] = tri;
    let ns =
        ((1.0 - b.x - b.y) * corner(i0) + b.x * corner(i1) + b.y * corner(i2)).normalize_or_zero();
    if ns == Vec3::ZERO {
        n
    } else if ns.dot(n) < 0.0 {
        -ns
    } else {
        ns
    }
}

/// A ray in the frame of the watertight test: `k` permutes the axes so the
/// direction's largest component becomes z (x and y swapped when it is
/// negative, keeping the orientation), and the shear `s` maps the direction
/// onto the z axis: a point `d` relative to the origin lands at
/// `(d[kx] - sx d[kz], d[ky] - sy d[kz])` in the plane the edge functions
/// are computed in.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub k: [usize; 3],
    pub s: [f32; 2],
}

impl ShearedRay {
    /// Without branches: the axes depend on the direction, which for
    /// bounce rays is random, so branches on it would be mispredicted.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir.to_array();
        let a = ray.dir.abs();
        let x_largest = (a.x > a.y) & (a.x > a.z);
        let y_largest = (a.x <= a.y) & (a.y > a.z);
        let kz = y_largest as usize | (((!x_largest & !y_largest) as usize) << 1);
        let (kx, ky) = (NEXT_AXIS[kz], NEXT_AXIS[NEXT_AXIS[kz]]);
        let (kx, ky) = if d[kz] < 0.0 { (ky, kx) } else { (kx, ky) };
        Self {
            origin: ray.origin,
            dir: ray.dir,
            k: [kx, ky, kz],
            s: [d[kx] / d[kz], d[ky] / d[kz]],
        }
    }
}

const NEXT_AXIS: [usize; 3] = [1, 2, 0];

/// The watertight test of the triangle `p` against `ray`; `None` for a
/// triangle of zero area. `(u, v)` of the hit are the barycentrics of `p[1]`
/// and `p[2]`. The native backend's four-wide version computes the very
/// same values.
#[inline]
pub fn intersect_triangle(p: [Vec3; 3], ray: &Ray) -> Option<PrimHit> {
    if has_zero_area(p) {
        return None;
    }
    let r = ShearedRay::new(ray);
    let [kx, ky, kz] = r.k;
    let [sx, sy] = r.s;
    let frame = |v: Vec3| {
        let d = (v - r.origin).to_array();
        (d[kx] - sx * d[kz], d[ky] - sy * d[kz])
    };
    let (ax, ay) = frame(p[0]);
    let (bx, by) = frame(p[1]);
    let (cx, cy) = frame(p[2]);
    let (mut e0, mut e1, mut e2) = (cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        (e0, e1, e2) = exact_zeros((e0, e1, e2), [ax, ay, bx, by, cx, cy]);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let t = plane_distance(p, ray.origin, ray.dir);
    let inv_det = 1.0 / det;
    (t > ray.t_min && t < ray.t_max).then_some(PrimHit {
        t,
        u: e1 * inv_det,
        v: e2 * inv_det,
    })
}

/// Whether the triangle `p` has zero area. The edge functions of such a
/// triangle are zero only in exact arithmetic; rounded, they can share a
/// sign, so the test alone could hit it (pbrt-v4 checks the same). The
/// loaders drop more: `mesh_io::is_degenerate` also takes nearly collinear
/// triangles out of the files they read.
#[inline]
pub fn has_zero_area(p: [Vec3; 3]) -> bool {
    (p[2] - p[0]).cross(p[1] - p[0]).length_squared() == 0.0
}

/// The ray parameter at which `origin + t dir` meets the plane of the
/// triangle `p`, as Möller–Trumbore computes it, written out so the native
/// backend's four-wide version can repeat it operation for operation. The watertight
/// test's own `t`, the barycentric mean of the vertices' depths, inherits
/// the rounding of a small determinant on thin triangles: on slivers it put
/// rays spawned off the surface back onto it (thousands of self-hits in
/// the extremes tests), where this distance keeps them behind their origin.
#[inline]
fn plane_distance(p: [Vec3; 3], origin: Vec3, dir: Vec3) -> f32 {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let n = Vec3::new(
        e1.y * e2.z - e1.z * e2.y,
        e1.z * e2.x - e1.x * e2.z,
        e1.x * e2.y - e1.y * e2.x,
    );
    let w = p[0] - origin;
    (w.x * n.x + w.y * n.y + w.z * n.z) / (dir.x * n.x + dir.y * n.y + dir.z * n.z)
}

/// The edge functions `e`, each that rounded to zero recomputed in f64
/// from the sheared `x, y` of the three vertices. Only zeros change: a
/// nonzero sign stands as computed, the same for both triangles of an edge.
#[inline(never)]
pub fn exact_zeros(e: (f32, f32, f32), [ax, ay, bx, by, cx, cy]: [f32; 6]) -> (f32, f32, f32) {
    let exact = |e: f32, a: f32, b: f32, c: f32, d: f32| {
        if e == 0.0 {
            (a as f64 * b as f64 - c as f64 * d as f64) as f32
        } else {
            e
        }
    };
    (
        exact(e.0, cx, by, cy, bx),
        exact(e.1, ax, cy, ay, cx),
        exact(e.2, bx, ay, by, ax),
    )
}
