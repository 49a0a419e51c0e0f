//! The native Rust backend: two BVHs over the scene's finite primitives,
//! one over mesh triangles and one over analytic shapes (spheres, quads,
//! cuboids); infinite planes are tested outside them.
//!
//! Triangles are stored pre-transformed (`p0, e1, e2`) in packs of four,
//! structure of arrays, in the triangle BVH's (4-aligned) leaf order: a leaf
//! reads its packs sequentially and tests four triangles at once with the
//! very operations of the scalar `intersect_triangle`, in the same order, so
//! hits are bit for bit those of the shared routine (and of brute force).
//! Padding lanes hold degenerate triangles, which are never hit; the scene
//! ids ride in the pack's third cache line, so a hit needs no other lookup.
//!
//! Why two trees: analytic shapes cost more than a pack of triangles and are
//! few and large (the walls of a Cornell box); in one packed tree the SAH,
//! which counts packs, put several walls in one leaf and every ray paid for
//! all of them (measured: 40% slower). The closest-hit query traverses the
//! triangles first, so a mesh hit culls the walls behind it; both trees share
//! one prepared ray.

use super::bvh::f4::F4;
use super::bvh::{BuildQuality, BuildSettings, Bvh, TravRay, PADDING};
use super::planes::InfinitePlanes;
use super::{Backend, Hit};
use crate::math::{Aabb, Ray, Vec3};
use crate::scene::{Geometry, Scene};
use std::sync::Arc;

/// Four triangles: `p0[c][k]` is coordinate `c` of triangle `k`'s vertex
/// 0; `e1`, `e2` its edges to vertices 1 and 2; then the scene's ids of the
/// four, read only for the final hit, from a cache line the test has
/// already loaded. Three cache lines.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
struct TriPack {
    p0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
    geom: [u32; 4],
    prim: [u32; 4],
}

impl TriPack {
    /// Degenerate in every lane: no ray hits it.
    const EMPTY: TriPack = TriPack {
        p0: [[0.0; 4]; 3],
        e1: [[0.0; 4]; 3],
        e2: [[0.0; 4]; 3],
        geom: [u32::MAX; 4],
        prim: [u32::MAX; 4],
    };

    fn set(&mut self, k: usize, p0: Vec3, e1: Vec3, e2: Vec3, geom: u32, prim: u32) {
        self.geom[k] = geom;
        self.prim[k] = prim;
        for c in 0..3 {
            self.p0[c][k] = p0[c];
            self.e1[c][k] = e1[c];
            self.e2[c][k] = e2[c];
        }
    }
}

/// A ray splatted for pack tests.
struct PackRay {
    o: [F4; 3],
    d: [F4; 3],
    t_min: F4,
}

impl PackRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        Self {
            o: [
                F4::splat(ray.origin.x),
                F4::splat(ray.origin.y),
                F4::splat(ray.origin.z),
            ],
            d: [
                F4::splat(ray.dir.x),
                F4::splat(ray.dir.y),
                F4::splat(ray.dir.z),
            ],
            t_min: F4::splat(ray.t_min),
        }
    }
}

/// `a × b`, glam's operation order.
#[inline(always)]
fn cross(a: [F4; 3], b: [F4; 3]) -> [F4; 3] {
    [
        a[1].mul(b[2]).sub(b[1].mul(a[2])),
        a[2].mul(b[0]).sub(b[2].mul(a[0])),
        a[0].mul(b[1]).sub(b[0].mul(a[1])),
    ]
}

/// `a · b`, glam's operation order.
#[inline(always)]
fn dot(a: [F4; 3], b: [F4; 3]) -> F4 {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}

#[inline(always)]
fn load3(v: &[[f32; 4]; 3]) -> [F4; 3] {
    [F4::load(&v[0]), F4::load(&v[1]), F4::load(&v[2])]
}

/// Möller–Trumbore on four triangles, exactly as `intersect_triangle`:
/// lane mask of hits in `(t_min, t_max)` and their `t, u, v`.
#[inline(always)]
fn intersect_pack(pack: &TriPack, r: &PackRay, t_max: f32) -> (u32, F4, F4, F4) {
    let e1 = load3(&pack.e1);
    let e2 = load3(&pack.e2);
    let pvec = cross(r.d, e2);
    let det = dot(e1, pvec);
    let zero = F4::splat(0.0);
    let one = F4::splat(1.0);
    let ok = det.ne(zero).and(det.abs().lt(F4::splat(f32::INFINITY)));
    let inv_det = one.div(det);
    let p0 = load3(&pack.p0);
    let tvec = [r.o[0].sub(p0[0]), r.o[1].sub(p0[1]), r.o[2].sub(p0[2])];
    let u = dot(tvec, pvec).mul(inv_det);
    let ok = ok.and(u.ge(zero)).and(u.le(one));
    if ok.bits() == 0 {
        return (0, zero, zero, zero);
    }
    let qvec = cross(tvec, e1);
    let v = dot(r.d, qvec).mul(inv_det);
    let ok = ok.and(v.ge(zero)).and(u.add(v).le(one));
    let t = dot(e2, qvec).mul(inv_det);
    let ok = ok.and(t.gt(r.t_min)).and(t.lt(F4::splat(t_max)));
    (ok.bits(), t, u, v)
}

pub struct NativeBackend {
    scene: Arc<Scene>,
    /// Over mesh triangles, 4-aligned leaves.
    tri_bvh: Bvh,
    /// Pack `slot / 4`, lane `slot % 4`.
    packs: Vec<TriPack>,
    /// Over analytic shapes; `analytic[slot]` is the shape.
    analytic_bvh: Bvh,
    analytic: Vec<u32>,
    planes: InfinitePlanes,
}

impl NativeBackend {
    pub fn new(scene: Arc<Scene>) -> Self {
        Self::with_quality(scene, BuildQuality::Balanced)
    }

    pub fn with_quality(scene: Arc<Scene>, quality: BuildQuality) -> Self {
        let mut tri_boxes = Vec::new();
        let mut tris = Vec::new();
        let mut boxes = Vec::new();
        let mut shapes = Vec::new();
        for (geom, shape) in scene.shapes.iter().enumerate() {
            let geom = geom as u32;
            match &shape.geometry {
                Geometry::Plane(_) => {}
                Geometry::Mesh(m) => {
                    for prim in 0..m.triangle_count() as u32 {
                        let [p0, p1, p2] = m.vertices(prim);
                        tri_boxes.push(Aabb::from_points(&[p0, p1, p2]));
                        tris.push((p0, p1 - p0, p2 - p0, geom, prim));
                    }
                }
                g => {
                    boxes.push(g.primitive_bounds(0).expect("finite shapes have bounds"));
                    shapes.push(geom);
                }
            }
        }
        let (tri_bvh, analytic_bvh) = rayon::join(
            || {
                Bvh::build_with(
                    &tri_boxes,
                    &BuildSettings {
                        quality,
                        align: 4,
                        leaf_cost: 1.0,
                    },
                )
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
        let order = tri_bvh.primitive_indices();
        let mut packs = vec![TriPack::EMPTY; order.len() / 4];
        for (slot, &i) in order.iter().enumerate() {
            if i != PADDING {
                let (p0, e1, e2, geom, prim) = tris[i as usize];
                packs[slot / 4].set(slot % 4, p0, e1, e2, geom, prim);
            }
        }
        let analytic = analytic_bvh
            .primitive_indices()
            .iter()
            .map(|&i| shapes[i as usize])
            .collect();
        Self {
            planes: InfinitePlanes::of(&scene.shapes),
            scene,
            tri_bvh,
            packs,
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
}

impl Backend for NativeBackend {
    fn name(&self) -> &'static str {
        "rust"
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let shapes = &self.scene.shapes;
        let mut best = None;
        let mut r = *ray;
        if let Some(tr) = TravRay::new(ray) {
            // Triangles first: a hit on the mesh culls the walls behind it.
            let pr = PackRay::new(&r);
            let tri = self
                .tri_bvh
                .intersect_leaves_prepared(&tr, &r, |first, count, r| {
                    let mut t_max = r.t_max;
                    let mut best = None;
                    for pack in self.packs_of(first, count) {
                        let (mask, t, u, v) = intersect_pack(pack, &pr, t_max);
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
                });
            if let Some((t, (pack, k, u, v))) = tri {
                r.t_max = t;
                best = Some(Hit {
                    t,
                    geom: pack.geom[k],
                    prim: pack.prim[k],
                    u,
                    v,
                });
            }
            // Then analytic shapes, culled by the triangle hit.
            let analytic =
                self.analytic_bvh
                    .intersect_leaves_prepared(&tr, &r, |first, count, r| {
                        let mut r = *r;
                        let mut best = None;
                        for &geom in &self.analytic[first as usize..(first + count) as usize] {
                            if let Some(h) = shapes[geom as usize].geometry.intersect(0, &r) {
                                r.t_max = h.t;
                                best = Some((h.t, (geom, h.u, h.v)));
                            }
                        }
                        best
                    });
            if let Some((t, (geom, u, v))) = analytic {
                r.t_max = t;
                best = Some(Hit {
                    t,
                    geom,
                    prim: 0,
                    u,
                    v,
                });
            }
        }
        self.planes.closest(shapes, &r, best)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        let shapes = &self.scene.shapes;
        if self.planes.any_hit(shapes, ray) {
            return true;
        }
        let Some(tr) = TravRay::new(ray) else {
            return false;
        };
        let pr = PackRay::new(ray);
        self.tri_bvh
            .occluded_leaves_prepared(&tr, ray, |first, count, r| {
                self.packs_of(first, count)
                    .iter()
                    .any(|pack| intersect_pack(pack, &pr, r.t_max).0 != 0)
            })
            || self
                .analytic_bvh
                .occluded_leaves_prepared(&tr, ray, |first, count, r| {
                    self.analytic[first as usize..(first + count) as usize]
                        .iter()
                        .any(|&g| shapes[g as usize].geometry.intersect(0, r).is_some())
                })
    }
}
