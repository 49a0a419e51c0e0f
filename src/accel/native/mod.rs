//! The native Rust backend: two BVHs over the shapes `Accel` does not test
//! at the root, one over mesh triangles and one over analytic shapes
//! (spheres, quads, cuboids; empty unless a scene has many quads or small
//! spheres and cuboids, `accel::root`).
//!
//! Triangles are tested four at a time (`pack`), from packs of their three
//! vertices, structure of arrays, in the triangle BVH's (4-aligned) leaf
//! order. After the SAH builds the packs are stored, and a leaf reads its
//! packs sequentially; after the quick Morton build, which serves few rays
//! per triangle, a leaf gathers its packs from the meshes by the tree's
//! slots, as Embree's compact layout does (`leaves`): no copy of the
//! vertices, whose fresh memory cost more than the gathers on large
//! meshes. Either way the test computes the very values of the shared
//! watertight `intersect_triangle`, so hits are bit for bit those of the
//! shared routine (and of brute force), watertightness included. Padding
//! lanes hold NaN vertices, which are never hit; each lane's triangle
//! number rides along, and a hit maps it to its mesh (one search among the
//! meshes' first numbers) only once the closest is known.
//!
//! Why two trees: analytic shapes cost more than a pack of triangles; in one
//! packed tree the SAH, which counts packs, put several of them in one leaf
//! and every ray paid for all of them (measured: 40% slower). The
//! closest-hit query traverses the triangles first, so a mesh hit culls the
//! shapes behind it; both trees share one prepared ray.

mod leaves;
mod pack;

pub use leaves::{Gathered, Packed};

use super::bvh::{BuildQuality, BuildSettings, Bvh, TravRay};
use super::{AccelTree, Tree};
use crate::geometry::{Geometry, PreliminaryHit};
use crate::math::Ray;
use crate::meter::{Step, StepKind};
use leaves::{Leaves, MeshStarts, Triangles};
use pack::PackRay;

/// The native backend's trees over `shapes`, less those `in_root` (which
/// `Accel` tests), built at `quality`: leaves gathered after the `Low`
/// build, stored after the others; the `AccelTree` variant is the leaf
/// layout's. A hit's `geom` is the shape's index in `shapes`.
pub fn build(shapes: &[Geometry], in_root: &[bool], quality: BuildQuality) -> AccelTree {
    let mut meshes = Triangles::default();
    let mut boxes = Vec::new();
    let mut analytic = Vec::new();
    for (geom, shape) in shapes.iter().enumerate() {
        if in_root[geom] {
            continue;
        }
        match shape {
            Geometry::Mesh(m) => meshes.push(geom as u32, m.clone()),
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
                centroid_bounds: (quality == BuildQuality::Low).then(|| meshes.vertex_bounds()),
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
                    centroid_bounds: None,
                },
            )
        },
    );
    let mesh_starts = meshes.starts();
    let analytic = analytic_bvh
        .primitive_indices()
        .iter()
        .map(|&i| analytic[i as usize].clone())
        .collect();
    let backend = NativeBackend {
        tri_bvh,
        leaves: (),
        mesh_starts,
        analytic_bvh,
        analytic,
    };
    match quality {
        BuildQuality::Low => AccelTree::NativeGathered(backend.with_leaves(Gathered::new(meshes))),
        _ => {
            let packs = meshes.packs(backend.tri_bvh.primitive_indices());
            AccelTree::Native(backend.with_leaves(packs))
        }
    }
}

pub struct NativeBackend<L> {
    /// Over mesh triangles, 4-aligned leaves.
    tri_bvh: Bvh,
    leaves: L,
    mesh_starts: MeshStarts,
    /// Over the analytic shapes not at the root (`Accel`'s): scene id and
    /// a copy of each, in slot order. Empty in most scenes.
    analytic_bvh: Bvh,
    analytic: Vec<(u32, Geometry)>,
}

impl NativeBackend<()> {
    fn with_leaves<L>(self, leaves: L) -> NativeBackend<L> {
        NativeBackend {
            tri_bvh: self.tri_bvh,
            leaves,
            mesh_starts: self.mesh_starts,
            analytic_bvh: self.analytic_bvh,
            analytic: self.analytic,
        }
    }
}

impl<L: Leaves> NativeBackend<L> {
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
        let slots = self.tri_bvh.primitive_indices();
        let (t, (triangle, u, v)) =
            self.tri_bvh
                .intersect_leaves_prepared(tr, ray, |first, count, r| {
                    let pr = sheared.get_or_insert_with(|| PackRay::new(ray));
                    self.leaves.nearest(slots, (first, count), pr, r.t_max)
                })?;
        let (geom, prim) = self.mesh_starts.locate(triangle);
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
        self.analytic_bvh
            .intersect_leaves_prepared(tr, ray, |first, count, r| {
                let mut r = *r;
                let mut best = None;
                for (geom, g) in self.analytic_of(first, count) {
                    if let Some(h) = g.intersect(0, &r) {
                        r.t_max = h.t;
                        best = Some((h.t, h.of_shape(*geom)));
                    }
                }
                best
            })
            .map(|(_, hit)| hit)
    }
}

impl<L: Leaves> Tree for NativeBackend<L> {
    fn name(&self) -> &'static str {
        "rust"
    }

    fn is_empty(&self) -> bool {
        self.tri_bvh.primitive_indices().is_empty() && self.analytic.is_empty()
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
        let slots = self.tri_bvh.primitive_indices();
        self.tri_bvh
            .occluded_leaves_prepared(&tr, ray, |first, count, r| {
                let pr = sheared.get_or_insert_with(|| PackRay::new(ray));
                self.leaves.any(slots, (first, count), pr, r.t_max)
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
