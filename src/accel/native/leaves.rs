//! The triangles of the meshes, numbered, and the two layouts of a leaf's
//! packs: stored (`Packed`), or gathered from the meshes (`Gathered`).

use super::pack::{intersect_pack, Hit, Nearest, PackRay, TriPack};
use crate::accel::bvh::PADDING;
use crate::geometry::{has_zero_area, Mesh};
use crate::math::{Aabb, Vec3};
use crate::memory;
use crate::simd::F4;
use rayon::prelude::*;
use std::sync::Arc;

/// The triangles of several meshes, numbered one after the other (the
/// numbers are the tree's primitives, so they fit in u32 as its slots do).
#[derive(Default)]
pub(super) struct Triangles {
    meshes: Vec<Arc<Mesh>>,
    starts: MeshStarts,
    count: usize,
}

impl Triangles {
    pub(super) fn push(&mut self, geom: u32, mesh: Arc<Mesh>) {
        self.starts.0.push((self.count as u32, geom));
        self.count += mesh.triangle_count();
        self.meshes.push(mesh);
    }

    pub(super) fn count(&self) -> usize {
        self.count
    }

    /// Mesh and triangle of triangle number `i`.
    #[inline]
    fn get(&self, i: usize) -> (&Mesh, u32) {
        let (m, prim) = self.starts.mesh_of(i as u32);
        (&self.meshes[m], prim)
    }

    /// What `MeshStarts::locate` needs once the triangles are packed.
    pub(super) fn starts(&self) -> MeshStarts {
        self.starts.clone()
    }

    /// Bounds of the meshes' vertices, which hold every triangle's
    /// centroid: one sequential pass, where the triangles' own would
    /// gather three vertices each.
    pub(super) fn vertex_bounds(&self) -> Aabb {
        self.meshes
            .par_iter()
            .map(|mesh| mesh.bounds())
            .reduce(|| Aabb::EMPTY, Aabb::union)
    }

    /// Empty for a triangle of zero area, which `intersect_triangle` never
    /// hits: the tree leaves it out.
    pub(super) fn bounds(&self, i: usize) -> Aabb {
        let (mesh, prim) = self.get(i);
        let p = mesh.vertices(prim);
        if has_zero_area(p) {
            return Aabb::EMPTY;
        }
        Aabb::from_points(&p)
    }

    /// The packs of the triangles in slot order `order`.
    pub(super) fn packs(&self, order: &[u32]) -> Packed {
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
                    pack.set(k, mesh.vertices(prim), i);
                }
                pack
            })
            .collect_into_vec(&mut packs);
        Packed(packs)
    }
}

/// The first triangle number and scene id of each mesh of `Triangles`.
#[derive(Clone, Default)]
pub(super) struct MeshStarts(Vec<(u32, u32)>);

impl MeshStarts {
    /// Index (among the meshes) and triangle of triangle number `triangle`.
    #[inline]
    fn mesh_of(&self, triangle: u32) -> (usize, u32) {
        let m = self.0.partition_point(|&(first, _)| first <= triangle) - 1;
        (m, triangle - self.0[m].0)
    }

    /// Scene id and triangle of triangle number `triangle`.
    #[inline]
    pub(super) fn locate(&self, triangle: u32) -> (u32, u32) {
        let (m, prim) = self.mesh_of(triangle);
        (self.0[m].1, prim)
    }
}

/// The meshes a gathering leaf reads: `only` when there is one.
struct Source<'s> {
    meshes: &'s [Arc<Mesh>],
    starts: &'s MeshStarts,
    only: Option<&'s Mesh>,
}

impl Source<'_> {
    /// The vertices of the four triangles of `slots`, coordinates in
    /// lanes, built in registers where they are tested (written out:
    /// `array::from_fn` was left out of line), and their numbers.
    #[inline(always)]
    fn gather(&self, slots: &[u32]) -> ([[F4; 3]; 3], [u32; 4]) {
        let [s0, s1, s2, s3] = [slots[0], slots[1], slots[2], slots[3]];
        let (t0, t1) = (self.vertices(s0), self.vertices(s1));
        let (t2, t3) = (self.vertices(s2), self.vertices(s3));
        let lanes = |v: usize| {
            let c = |c: usize| F4::load(&[t0[v][c], t1[v][c], t2[v][c], t3[v][c]]);
            [c(0), c(1), c(2)]
        };
        ([lanes(0), lanes(1), lanes(2)], [s0, s1, s2, s3])
    }

    /// The vertices of triangle number `triangle`; NaN for padding.
    #[inline(always)]
    fn vertices(&self, triangle: u32) -> [Vec3; 3] {
        if triangle == PADDING {
            return [Vec3::NAN; 3];
        }
        if let Some(mesh) = self.only {
            return mesh.vertices(triangle);
        }
        let (m, prim) = self.starts.mesh_of(triangle);
        self.meshes[m].vertices(prim)
    }
}

/// A leaf test over one layout of packs. A trait, not an enum: each
/// layout gets a traversal of its own, since a choice inside the leaf test
/// cost the traversal loop registers (+2% of the bunny's instructions).
pub trait Leaves: Send + Sync {
    /// The nearest hit below `t_max` among the triangles of the leaf at
    /// `slots[first..first + count]`: its `t`, triangle number, `u`, `v`.
    fn nearest(&self, slots: &[u32], leaf: (u32, u32), r: &PackRay, t_max: f32) -> Option<Hit>;

    /// Whether any triangle of the leaf is hit below `t_max`.
    fn any(&self, slots: &[u32], leaf: (u32, u32), r: &PackRay, t_max: f32) -> bool;
}

/// The packs stored, pack `slot / 4`, lane `slot % 4`: 40 bytes a
/// triangle, read sequentially.
pub struct Packed(Vec<TriPack>);

impl Packed {
    #[inline(always)]
    fn of(&self, (first, count): (u32, u32)) -> &[TriPack] {
        let (a, n) = (first as usize / 4, (count as usize).div_ceil(4));
        &self.0[a..a + n]
    }
}

impl Leaves for Packed {
    #[inline(always)]
    fn nearest(&self, _: &[u32], leaf: (u32, u32), r: &PackRay, t_max: f32) -> Option<Hit> {
        let mut nearest = Nearest::below(t_max);
        for pack in self.of(leaf) {
            nearest.test(|v, c| pack.coord(v, c), &pack.triangle, r);
        }
        nearest.best
    }

    #[inline(always)]
    fn any(&self, _: &[u32], leaf: (u32, u32), r: &PackRay, t_max: f32) -> bool {
        self.of(leaf)
            .iter()
            .any(|pack| intersect_pack(|v, c| pack.coord(v, c), r, t_max).0 != 0)
    }
}

/// The packs gathered from the meshes by the tree's slots, as Embree's
/// compact layout does: no memory of their own (the meshes are shared),
/// for a tree that serves few rays per triangle.
pub struct Gathered {
    meshes: Vec<Arc<Mesh>>,
    starts: MeshStarts,
}

impl Gathered {
    pub(super) fn new(triangles: Triangles) -> Self {
        let Triangles { meshes, starts, .. } = triangles;
        Self { meshes, starts }
    }

    /// Where the leaf reads its triangles.
    #[inline(always)]
    fn source(&self) -> Source<'_> {
        // With one mesh (most scenes), it is looked up once per leaf.
        let only = match self.meshes.as_slice() {
            [mesh] => Some(&**mesh),
            _ => None,
        };
        Source {
            meshes: &self.meshes,
            starts: &self.starts,
            only,
        }
    }
}

/// The slots of the leaf, padded to packs.
#[inline(always)]
fn slots_of(slots: &[u32], (first, count): (u32, u32)) -> std::slice::ChunksExact<'_, u32> {
    let (a, n) = (first as usize, (count as usize).next_multiple_of(4));
    slots[a..a + n].chunks_exact(4)
}

impl Leaves for Gathered {
    #[inline(always)]
    fn nearest(&self, slots: &[u32], leaf: (u32, u32), r: &PackRay, t_max: f32) -> Option<Hit> {
        let source = self.source();
        let mut nearest = Nearest::below(t_max);
        for slots in slots_of(slots, leaf) {
            let (p, triangle) = source.gather(slots);
            nearest.test(|v, c| p[v][c], &triangle, r);
        }
        nearest.best
    }

    #[inline(always)]
    fn any(&self, slots: &[u32], leaf: (u32, u32), r: &PackRay, t_max: f32) -> bool {
        let source = self.source();
        slots_of(slots, leaf).any(|slots| {
            let (p, _) = source.gather(slots);
            intersect_pack(|v, c| p[v][c], r, t_max).0 != 0
        })
    }
}
