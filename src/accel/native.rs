//! The native Rust backend: two BVHs over the shapes `Accel` does not test
//! at the root, one over mesh triangles and one over analytic shapes
//! (spheres, quads, cuboids; empty unless a scene has many quads or small
//! spheres and cuboids, `accel::root`).
//!
//! Triangles are stored by their three vertices in packs of four,
//! structure of arrays, in the triangle BVH's (4-aligned) leaf order: a leaf
//! reads its packs sequentially and tests four triangles at once, computing
//! the very values of the shared watertight `intersect_triangle`, so hits
//! are bit for bit those of the shared routine (and of brute force),
//! watertightness included. Padding lanes hold NaN vertices, which are never
//! hit; each lane's triangle number rides in the pack's last cache line,
//! and a hit maps it to its mesh (one search among the meshes' first
//! numbers) only once the closest is known.
//!
//! Why two trees: analytic shapes cost more than a pack of triangles; in one
//! packed tree the SAH, which counts packs, put several of them in one leaf
//! and every ray paid for all of them (measured: 40% slower). The
//! closest-hit query traverses the triangles first, so a mesh hit culls the
//! shapes behind it; both trees share one prepared ray. The backend keeps
//! its own copies of what it tests (triangle packs, small analytic shapes),
//! so it needs the scene's shapes only while it is built.

use super::bvh::{BuildQuality, BuildSettings, Bvh, TravRay, PADDING};
use super::Tree;
use crate::geometry::{exact_zeros, has_zero_area, Geometry, Mesh, PreliminaryHit, ShearedRay};
use crate::math::{Aabb, Ray, Vec3};
use crate::memory;
use crate::meter::{Step, StepKind};
use crate::scene::Shape;
use crate::simd::F4;
use rayon::prelude::*;

/// Four triangles: `p[v][c][k]` is coordinate `c` of vertex `v` of
/// triangle `k`; then their triangle numbers (`Triangles`), read only for
/// the final hit, from a cache line the test has already loaded. 160 bytes
/// on a 32-byte boundary: every pack spans three cache lines, as a 192-byte
/// pack on a line's boundary would, in a sixth less memory.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
struct TriPack {
    p: [[[f32; 4]; 3]; 3],
    triangle: [u32; 4],
}

impl TriPack {
    /// NaN in every lane: no ray hits it, and no edge function of it is
    /// zero, so it never takes the f64 path.
    const EMPTY: TriPack = TriPack {
        p: [[[f32::NAN; 4]; 3]; 3],
        triangle: [PADDING; 4],
    };

    fn set(&mut self, k: usize, p: [Vec3; 3], triangle: u32) {
        self.triangle[k] = triangle;
        for (v, p) in p.iter().enumerate() {
            for c in 0..3 {
                self.p[v][c][k] = p[c];
            }
        }
    }
}

/// A ray in the watertight test's frame, splatted for pack tests.
struct PackRay {
    sheared: ShearedRay,
    origin: [F4; 3],
    dir: [F4; 3],
    s: [F4; 2],
    t_min: f32,
}

impl PackRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let sheared = ShearedRay::new(ray);
        Self {
            origin: sheared.origin.to_array().map(F4::splat),
            dir: sheared.dir.to_array().map(F4::splat),
            s: sheared.s.map(F4::splat),
            sheared,
            t_min: ray.t_min,
        }
    }
}

/// `intersect_triangle` on four triangles, with the same values:
/// lane mask of hits in `(t_min, t_max)` and their `t, u, v`.
#[inline(always)]
fn intersect_pack(pack: &TriPack, r: &PackRay, t_max: f32) -> (u32, F4, F4, F4) {
    let [kx, ky, kz] = r.sheared.k;
    let [sx, sy] = r.s;
    let frame = |v: &[[f32; 4]; 3]| {
        let d = |c: usize| F4::load(&v[c]).sub(r.origin[c]);
        let (dx, dy, dz) = (d(kx), d(ky), d(kz));
        (dx.sub(sx.mul(dz)), dy.sub(sy.mul(dz)))
    };
    let (ax, ay) = frame(&pack.p[0]);
    let (bx, by) = frame(&pack.p[1]);
    let (cx, cy) = frame(&pack.p[2]);
    let mut e0 = cx.mul(by).sub(cy.mul(bx));
    let mut e1 = ax.mul(cy).sub(ay.mul(cx));
    let mut e2 = bx.mul(ay).sub(by.mul(ax));
    let zero = F4::splat(0.0);
    // Lanes whose edge functions have both signs miss, whatever their zeros
    // (only zeros change in f64), and so do NaN (padding) lanes: most packs
    // end here.
    let one_sign_of = |e0: F4, e1: F4, e2: F4| {
        e0.min(e1).min(e2).ge(zero).bits() | e0.max(e1).max(e2).le(zero).bits()
    };
    let mut one_sign = one_sign_of(e0, e1, e2);
    if one_sign == 0 {
        return (0, zero, zero, zero);
    }
    let on_edge = one_sign & (e0.eq(zero).bits() | e1.eq(zero).bits() | e2.eq(zero).bits());
    if on_edge != 0 {
        let (mut f0, mut f1, mut f2) = (e0.to_array(), e1.to_array(), e2.to_array());
        let (ax, ay, bx, by, cx, cy) = (
            ax.to_array(),
            ay.to_array(),
            bx.to_array(),
            by.to_array(),
            cx.to_array(),
            cy.to_array(),
        );
        for k in (0..4).filter(|k| on_edge & (1 << k) != 0) {
            (f0[k], f1[k], f2[k]) = exact_zeros(
                (f0[k], f1[k], f2[k]),
                [ax[k], ay[k], bx[k], by[k], cx[k], cy[k]],
            );
        }
        (e0, e1, e2) = (F4::load(&f0), F4::load(&f1), F4::load(&f2));
        one_sign &= one_sign_of(e0, e1, e2);
    }
    let det = e0.add(e1).add(e2);
    let det_ok = det.ne(zero).and(det.abs().lt(F4::splat(f32::INFINITY)));
    // `plane_distance`, operation for operation.
    let row = |v: usize| [0, 1, 2].map(|c| F4::load(&pack.p[v][c]));
    let (p0, p1, p2) = (row(0), row(1), row(2));
    let u = [0, 1, 2].map(|c| p1[c].sub(p0[c]));
    let v = [0, 1, 2].map(|c| p2[c].sub(p0[c]));
    let n = [
        u[1].mul(v[2]).sub(u[2].mul(v[1])),
        u[2].mul(v[0]).sub(u[0].mul(v[2])),
        u[0].mul(v[1]).sub(u[1].mul(v[0])),
    ];
    let w = [0, 1, 2].map(|c| p0[c].sub(r.origin[c]));
    let dot = |a: [F4; 3]| a[0].mul(n[0]).add(a[1].mul(n[1])).add(a[2].mul(n[2]));
    let t = dot(w).div(dot(r.dir));
    let inv_det = F4::splat(1.0).div(det);
    let in_range = t.gt(F4::splat(r.t_min)).and(t.lt(F4::splat(t_max)));
    let mask = one_sign & det_ok.and(in_range).bits();
    (mask, t, e1.mul(inv_det), e2.mul(inv_det))
}

/// The triangles of several meshes, numbered one after the other.
#[derive(Default)]
struct Triangles<'a> {
    meshes: Vec<(u32, &'a Mesh)>,
    /// First triangle number of each mesh.
    first: Vec<usize>,
    count: usize,
}

impl<'a> Triangles<'a> {
    fn push(&mut self, geom: u32, mesh: &'a Mesh) {
        self.meshes.push((geom, mesh));
        self.first.push(self.count);
        self.count += mesh.triangle_count();
    }

    fn count(&self) -> usize {
        self.count
    }

    /// Mesh and triangle of triangle number `i`.
    #[inline]
    fn get(&self, i: usize) -> (&'a Mesh, u32) {
        let m = self.first.partition_point(|&f| f <= i) - 1;
        (self.meshes[m].1, (i - self.first[m]) as u32)
    }

    /// What `MeshStarts::locate` needs once the meshes are gone.
    fn starts(&self) -> MeshStarts {
        MeshStarts(
            self.meshes
                .iter()
                .zip(&self.first)
                .map(|(&(geom, _), &first)| (first as u32, geom))
                .collect(),
        )
    }

    fn bounds(&self, i: usize) -> Aabb {
        let (mesh, prim) = self.get(i);
        mesh.triangle_bounds(prim)
    }

    /// The packs of the triangles in slot order `order`.
    fn packs(&self, order: &[u32]) -> Vec<TriPack> {
        let mut packs = memory::vec_with_capacity(order.len().div_ceil(4));
        order
            .par_chunks(4)
            .with_min_len(1024)
            .map(|slots| {
                let mut pack = TriPack::EMPTY;
                for (k, &i) in slots.iter().enumerate() {
                    if i == PADDING {
                        continue;
                    }
                    let (mesh, prim) = self.get(i as usize);
                    let p = mesh.vertices(prim);
                    // A triangle of zero area stays NaN, as
                    // `intersect_triangle` never hits it.
                    if !has_zero_area(p) {
                        pack.set(k, p, i);
                    }
                }
                pack
            })
            .collect_into_vec(&mut packs);
        packs
    }
}

/// The first triangle number and scene id of each mesh of `Triangles`.
struct MeshStarts(Vec<(u32, u32)>);

impl MeshStarts {
    /// Scene id and triangle of triangle number `triangle`.
    #[inline]
    fn locate(&self, triangle: u32) -> (u32, u32) {
        let m = self.0.partition_point(|&(first, _)| first <= triangle) - 1;
        let (first, geom) = self.0[m];
        (geom, triangle - first)
    }
}

pub struct NativeBackend {
    /// Over mesh triangles, 4-aligned leaves.
    tri_bvh: Bvh,
    /// Pack `slot / 4`, lane `slot % 4`.
    packs: Vec<TriPack>,
    mesh_starts: MeshStarts,
    /// Over the analytic shapes not at the root (`Accel`'s): scene id and
    /// a copy of each, in slot order. Empty in most scenes.
    analytic_bvh: Bvh,
    analytic: Vec<(u32, Geometry)>,
}

impl NativeBackend {
    /// The trees over `shapes`, less those `in_root` (which `Accel` tests),
    /// built at `quality`.
    pub fn with_quality(shapes: &[Shape], in_root: &[bool], quality: BuildQuality) -> Self {
        let mut meshes = Triangles::default();
        let mut boxes = Vec::new();
        let mut analytic = Vec::new();
        for (geom, shape) in shapes.iter().enumerate() {
            if in_root[geom] {
                continue;
            }
            match &shape.geometry {
                Geometry::Mesh(m) => meshes.push(geom as u32, m),
                g => {
                    boxes.push(g.primitive_bounds(0).expect("planes are root shapes"));
                    analytic.push((geom as u32, g.clone()));
                }
            }
        }
        let _step = Step::begin(
            StepKind::BuildTree { backend: "rust" },
            meshes.count() as u64,
        );
        let progress = Step::current();
        let (tri_bvh, analytic_bvh) = rayon::join(
            || {
                let settings = BuildSettings {
                    quality,
                    align: 4,
                    leaf_cost: 1.0,
                };
                Bvh::build_reporting(meshes.count(), |i| meshes.bounds(i), &settings, &progress)
            },
            // An analytic shape costs more than a box test: small leaves.
            || {
                Bvh::build_with(
                    &boxes,
                    &BuildSettings {
                        quality,
                        align: 1,
                        leaf_cost: 2.0,
                    },
                )
            },
        );
        let packs = meshes.packs(tri_bvh.primitive_indices());
        let mesh_starts = meshes.starts();
        let analytic = analytic_bvh
            .primitive_indices()
            .iter()
            .map(|&i| analytic[i as usize].clone())
            .collect();
        Self {
            tri_bvh,
            packs,
            mesh_starts,
            analytic_bvh,
            analytic,
        }
    }

    /// The triangle BVH.
    pub fn bvh(&self) -> &Bvh {
        &self.tri_bvh
    }

    #[inline(always)]
    fn packs_of(&self, first: u32, count: u32) -> &[TriPack] {
        let (a, n) = (first as usize / 4, (count as usize).div_ceil(4));
        &self.packs[a..a + n]
    }

    #[inline(always)]
    fn analytic_of(&self, first: u32, count: u32) -> &[(u32, Geometry)] {
        &self.analytic[first as usize..(first + count) as usize]
    }

    /// The closest triangle hit below `ray.t_max`.
    #[inline(always)]
    fn closest_triangle(&self, tr: &TravRay, ray: &Ray) -> Option<PreliminaryHit> {
        // The ray is sheared for the triangle test only once it reaches a
        // leaf: many rays never do.
        let mut sheared = None;
        let (t, (pack, k, u, v)) =
            self.tri_bvh
                .intersect_leaves_prepared(tr, ray, |first, count, r| {
                    let pr = sheared.get_or_insert_with(|| PackRay::new(ray));
                    let mut t_max = r.t_max;
                    let mut best = None;
                    for pack in self.packs_of(first, count) {
                        let (mask, t, u, v) = intersect_pack(pack, pr, t_max);
                        if mask == 0 {
                            continue;
                        }
                        let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
                        // The first of the nearest lanes, as a scalar loop finds it.
                        for k in 0..4 {
                            if mask & (1 << k) != 0 && t[k] < t_max {
                                t_max = t[k];
                                best = Some((t[k], (pack, k, u[k], v[k])));
                            }
                        }
                    }
                    best
                })?;
        let (geom, prim) = self.mesh_starts.locate(pack.triangle[k]);
        Some(PreliminaryHit {
            t,
            geom,
            prim,
            u,
            v,
        })
    }

    /// The closest hit of the analytic tree below `ray.t_max`.
    #[inline(always)]
    fn closest_analytic(&self, tr: &TravRay, ray: &Ray) -> Option<PreliminaryHit> {
        let (t, (geom, u, v)) =
            self.analytic_bvh
                .intersect_leaves_prepared(tr, ray, |first, count, r| {
                    let mut r = *r;
                    let mut best = None;
                    for (geom, g) in self.analytic_of(first, count) {
                        if let Some(h) = g.intersect(0, &r) {
                            r.t_max = h.t;
                            best = Some((h.t, (*geom, h.u, h.v)));
                        }
                    }
                    best
                })?;
        Some(PreliminaryHit {
            t,
            geom,
            prim: 0,
            u,
            v,
        })
    }
}

impl Tree for NativeBackend {
    fn name(&self) -> &'static str {
        "rust"
    }

    fn is_empty(&self) -> bool {
        self.packs.is_empty() && self.analytic.is_empty()
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<PreliminaryHit> {
        let tr = TravRay::new(ray);
        // Triangles first: a hit on the mesh culls the shapes behind it.
        let tri = self.closest_triangle(&tr, ray);
        if self.analytic.is_empty() {
            return tri;
        }
        let mut r = *ray;
        if let Some(h) = &tri {
            r.t_max = h.t;
        }
        self.closest_analytic(&tr, &r).or(tri)
    }

    #[inline]
    fn any_hit(&self, ray: &Ray) -> bool {
        let tr = TravRay::new(ray);
        let mut sheared = None;
        self.tri_bvh
            .occluded_leaves_prepared(&tr, ray, |first, count, r| {
                let pr = sheared.get_or_insert_with(|| PackRay::new(ray));
                self.packs_of(first, count)
                    .iter()
                    .any(|pack| intersect_pack(pack, pr, r.t_max).0 != 0)
            })
            || self
                .analytic_bvh
                .occluded_leaves_prepared(&tr, ray, |first, count, r| {
                    self.analytic_of(first, count)
                        .iter()
                        .any(|(_, g)| g.intersect(0, r).is_some())
                })
    }
}
