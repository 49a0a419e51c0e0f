//! The native BVH. It sees only primitive bounding boxes; the caller's
//! closures intersect the primitives themselves (the obvhs style), so one
//! tree serves triangles and analytic shapes alike.
//!
//! Build: a binary tree by binned SAH (rayon-parallel above a few thousand
//! primitives, with a depth guard that falls back to median splits), then
//! collapsed into a 4-wide BVH whose nodes hold their children's boxes as
//! structure-of-arrays, so one ray is tested against four boxes at once
//! with SSE. Leaves are contiguous ranges of *slots*; `primitive_indices`
//! maps a slot to the caller's primitive, and the caller stores its
//! primitives in slot order so a leaf reads memory sequentially.
//! `BuildSettings::align` starts every leaf on a multiple of `align` slots
//! and pads it to one, so a caller can store primitives in SIMD packs (the
//! native backend tests four triangles at once); the SAH then counts leaf
//! cost in packs. Presets (`BuildQuality`): Low = a Morton-code build
//! (`morton`), leaves up to 8; Medium = binned SAH with 16 bins, leaves up
//! to 6 (8 when packed by 4); High = 48 bins, up to 4. Both SAH presets
//! bin a node of n primitives with at most 4 + n / 20 bins.
//!
//! The 4-wide tree is what the binary SAH tree becomes: a flattened array
//! of 128-byte nodes (two cache lines; six SoA bound rows, child indices,
//! leaf counts) in depth-first order, leaves first within a node. On the
//! Stanford bunny (69,451 triangles, packed by 4) that is 6.5k nodes
//! (815 KiB) at depth 9, against about 35k nodes for a binary tree.
//!
//! Traversal: reciprocal direction precomputed, near/far planes chosen once
//! per ray by the direction's signs, children visited nearest first with a
//! small fixed stack (no allocation, no initialisation), `t_max` shrinking
//! as hits are found and stacked subtrees beyond it skipped, pushed nodes
//! prefetched; the any-hit query for shadow rays stops at the first hit.
//! Callers get both a per-primitive API (`intersect_with`, `occluded`) and a
//! per-leaf one (`intersect_leaves`, `occluded_leaves`), the latter also
//! with a `TravRay` prepared once and shared between trees.
//!
//! Robustness: slabs are computed as `(plane - origin) * (1 / dir)`, whose
//! far distance is widened by `1 + 2 gamma(3)` (pbrt-v4), so rounding never
//! culls a box the ray touches. A zero direction component gives an infinite
//! reciprocal; the `0 * inf = NaN` it produces for a ray lying in a slab's
//! plane is dropped by min/max operations whose operand order ignores NaN.

mod bins;
mod build;
mod collapse;
mod morton;
mod node;
mod progress;
mod traverse;

pub use traverse::TravRay;
pub(crate) use traverse::FAR_SCALE;

use crate::math::Aabb;
use crate::memory;
use crate::meter::Reporter;
use build::{prim_refs, BuildCtx, PrimRef};
use collapse::Collapse;
use node::Node4;

/// Named build presets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BuildQuality {
    /// A Morton-code (LBVH) build: the quickest, for few rays per triangle.
    Low,
    /// Binned SAH: what most renders use.
    #[default]
    Medium,
    /// Many bins, small leaves: slowest build, fastest traversal (slightly).
    High,
}

#[derive(Clone, Copy, Debug)]
struct Preset {
    bins: usize,
    max_leaf: usize,
    /// Cost of a 4-wide node visit ...
    traversal_cost: f32,
    /// ... and of testing one pack of `align` primitives.
    pack_cost: f32,
}

impl BuildQuality {
    fn preset(self) -> Preset {
        match self {
            // The Morton build reads only `max_leaf`.
            BuildQuality::Low => Preset {
                bins: 8,
                max_leaf: 8,
                traversal_cost: 1.0,
                pack_cost: 1.0,
            },
            BuildQuality::Medium => Preset {
                bins: 16,
                max_leaf: 6,
                traversal_cost: 1.0,
                pack_cost: 1.0,
            },
            BuildQuality::High => Preset {
                bins: 48,
                max_leaf: 4,
                traversal_cost: 1.0,
                pack_cost: 1.0,
            },
        }
    }
}

/// How to build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildSettings {
    pub quality: BuildQuality,
    /// Every leaf's first slot is a multiple of `align`, and its slot range
    /// is padded up to a multiple of `align` (padding slots map to
    /// `PADDING` in `primitive_indices`). A caller that stores primitives
    /// in packs of `align` then tests a leaf pack by pack. At most 16, and
    /// rounded up to a power of two.
    pub align: usize,
    /// Cost of testing one pack of `align` primitives, relative to a visit
    /// of one 4-wide node (the SAH's two constants).
    pub leaf_cost: f32,
    /// A box that holds every usable primitive's centroid, where the
    /// caller has one for less than a pass over the primitives (a mesh's
    /// vertex bounds): the Morton build then quantizes its codes within it
    /// instead of finding the centroids' bounds first, unless a sample of
    /// the centroids shows it much larger than they are
    /// (`morton::centroid_grid`).
    pub centroid_bounds: Option<Aabb>,
}

impl Default for BuildSettings {
    fn default() -> Self {
        Self {
            quality: BuildQuality::Medium,
            align: 1,
            leaf_cost: 1.0,
            centroid_bounds: None,
        }
    }
}

/// Whether a primitive's box can be hit: finite (no NaN) and not empty.
/// The others get no slot.
fn usable(b: &Aabb) -> bool {
    b.is_finite() && !b.is_empty()
}

/// `primitive_indices` entry of a padding slot.
pub const PADDING: u32 = u32::MAX;

/// Deepest level of the binary tree (and hence of the 4-wide one).
const MAX_DEPTH: usize = 64;
/// Subtrees of at least this many primitives are built in parallel.
const PARALLEL_THRESHOLD: usize = 4096;
/// From this many primitives on, the binary tree's freed nodes (about
/// 100 bytes a leaf) are handed back to the kernel before the caller
/// allocates its own large buffers; below, they are a few megabytes.
const RELEASE_FROM: usize = 1 << 16;

pub struct Bvh {
    nodes: Vec<Node4>,
    /// Original primitive index of each slot.
    order: Vec<u32>,
    depth: usize,
}

impl Bvh {
    /// Builds the tree over `boxes`. Boxes that are empty or not finite
    /// (NaN) can never be hit and are left out: they get no slot.
    pub fn build(boxes: &[Aabb], quality: BuildQuality) -> Bvh {
        Self::build_with(
            boxes,
            &BuildSettings {
                quality,
                ..BuildSettings::default()
            },
        )
    }

    /// As `build`, with the leaf layout and costs of `settings`.
    pub fn build_with(boxes: &[Aabb], settings: &BuildSettings) -> Bvh {
        Self::build_over(boxes.len(), |i| boxes[i], settings)
    }

    /// As `build_with`, over the boxes `box_of(0..count)`, which it asks
    /// for in parallel (once each for the SAH builds, three times for the
    /// Morton build), so the caller need not store them.
    pub fn build_over(
        count: usize,
        box_of: impl Fn(usize) -> Aabb + Sync,
        settings: &BuildSettings,
    ) -> Bvh {
        Self::build_reporting(count, box_of, settings, &Reporter::none())
    }

    /// As `build_over`, telling `progress` of every usable primitive once
    /// it is in a finished subtree.
    pub(crate) fn build_reporting(
        count: usize,
        box_of: impl Fn(usize) -> Aabb + Sync,
        settings: &BuildSettings,
        progress: &Reporter,
    ) -> Bvh {
        let align = settings.align.clamp(1, 16).next_power_of_two();
        let mut preset = settings.quality.preset();
        preset.max_leaf = preset.max_leaf.div_ceil(align) * align;
        if settings.leaf_cost.is_finite() && settings.leaf_cost > 0.0 {
            preset.pack_cost = settings.leaf_cost;
        }
        let (root, order) = if settings.quality == BuildQuality::Low {
            morton::build(
                count,
                &box_of,
                settings.centroid_bounds,
                (preset.max_leaf, align),
                progress,
            )
        } else {
            let mut refs = prim_refs(count, box_of);
            let root = BuildCtx {
                preset,
                align_log2: align.trailing_zeros(),
                progress,
            }
            .build(&mut refs, 0, 0);
            (root, refs.iter().map(PrimRef::index).collect())
        };
        if order.is_empty() {
            return Bvh {
                nodes: Vec::new(),
                order,
                depth: 0,
            };
        }
        let mut out = Collapse {
            nodes: memory::vec_with_capacity(order.len() / 2 + 1),
            src: &order,
            slots: memory::vec_with_capacity(order.len() + order.len() / 2),
            align,
        };
        let depth = out.node(&root, 1);
        drop(root);
        if order.len() >= RELEASE_FROM {
            memory::release_freed_memory();
        }
        Bvh {
            nodes: out.nodes,
            order: out.slots,
            depth,
        }
    }
}

impl Bvh {
    /// Original primitive index of every slot, in slot order.
    pub fn primitive_indices(&self) -> &[u32] {
        &self.order
    }

    /// Number of 4-wide nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Levels of 4-wide nodes.
    pub fn depth(&self) -> usize {
        self.depth
    }
}

#[cfg(test)]
mod tests;
