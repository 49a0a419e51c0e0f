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
//! cost in packs. Presets (`BuildQuality`): Fast = 8 bins, leaves up to 8;
//! Balanced = 16 bins, up to 6 (8 when packed by 4); High = 48 bins, up to 4.
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

use super::traceable;
use crate::math::{gamma, Aabb, Ray, Vec3};

/// Named build presets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BuildQuality {
    /// Few bins, bigger leaves: quickest build.
    Fast,
    /// The default: what renders use.
    #[default]
    Balanced,
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
            BuildQuality::Fast => Preset {
                bins: 8,
                max_leaf: 8,
                traversal_cost: 1.0,
                pack_cost: 1.0,
            },
            BuildQuality::Balanced => Preset {
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
    /// in packs of `align` then tests a leaf pack by pack. At most 16.
    pub align: usize,
    /// Cost of testing one pack of `align` primitives, relative to a visit
    /// of one 4-wide node (the SAH's two constants).
    pub leaf_cost: f32,
}

impl Default for BuildSettings {
    fn default() -> Self {
        Self {
            quality: BuildQuality::Balanced,
            align: 1,
            leaf_cost: 1.0,
        }
    }
}

/// `primitive_indices` entry of a padding slot.
pub const PADDING: u32 = u32::MAX;

/// Deepest level of the binary tree (and hence of the 4-wide one).
const MAX_DEPTH: usize = 64;
/// Stack of a traversal: each 4-wide level pushes at most three entries.
const STACK_SIZE: usize = 3 * MAX_DEPTH + 4;
/// Subtrees of at least this many primitives are built in parallel.
const PARALLEL_THRESHOLD: usize = 4096;

/// A 4-wide node: the four children's boxes (structure of arrays:
/// `bounds[2 * axis]` holds the minima along `axis`, `bounds[2 * axis + 1]`
/// the maxima) and what each child is. 128 bytes, two cache lines.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
struct Node4 {
    bounds: [[f32; 4]; 6],
    /// Inner child: its node index. Leaf: its first slot.
    child: [u32; 4],
    /// Leaf: its number of slots. 0: an inner node, or an unused child
    /// (whose empty box no finite ray ever hits).
    count: [u32; 4],
}

impl Node4 {
    const EMPTY: Node4 = Node4 {
        bounds: [
            [f32::INFINITY; 4],
            [f32::NEG_INFINITY; 4],
            [f32::INFINITY; 4],
            [f32::NEG_INFINITY; 4],
            [f32::INFINITY; 4],
            [f32::NEG_INFINITY; 4],
        ],
        child: [0; 4],
        count: [0; 4],
    };

    fn set_box(&mut self, k: usize, b: &Aabb) {
        for axis in 0..3 {
            self.bounds[2 * axis][k] = b.min[axis];
            self.bounds[2 * axis + 1][k] = b.max[axis];
        }
    }
}

pub struct Bvh {
    nodes: Vec<Node4>,
    /// Original primitive index of each slot.
    order: Vec<u32>,
    depth: usize,
}

use crate::simd::F4;

/// A ray prepared for box tests (reciprocal direction, near planes), to
/// share between several trees.
pub struct TravRay {
    org: [F4; 3],
    inv: [F4; 3],
    /// Row of `Node4::bounds` holding the near plane, per axis.
    near: [usize; 3],
    t_min: F4,
}

/// Widening of the far slab distance that covers the rounding of
/// `(plane - origin) * (1 / dir)` (pbrt-v4).
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

impl TravRay {
    /// For a traceable ray (`accel::traceable`): finite origin and
    /// direction, `t_min` not NaN.
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let inv = Vec3::ONE / ray.dir;
        let near = |d: f32| if d.is_sign_negative() { 1 } else { 0 };
        Self {
            org: [
                F4::splat(ray.origin.x),
                F4::splat(ray.origin.y),
                F4::splat(ray.origin.z),
            ],
            inv: [F4::splat(inv.x), F4::splat(inv.y), F4::splat(inv.z)],
            near: [near(ray.dir.x), 2 + near(ray.dir.y), 4 + near(ray.dir.z)],
            t_min: F4::splat(ray.t_min),
        }
    }

    /// Which of the node's four children the ray's `(t_min, t_max)` touches
    /// (bit mask), and the entry distances.
    #[inline(always)]
    fn hit4(&self, node: &Node4, t_max: f32) -> (u32, F4) {
        let b = &node.bounds;
        let mut t0 = self.t_min;
        let mut t1 = F4::splat(t_max);
        for axis in 0..3 {
            let n = self.near[axis];
            let f = n ^ 1;
            let tn = F4::load(&b[n]).sub(self.org[axis]).mul(self.inv[axis]);
            let tf = F4::load(&b[f]).sub(self.org[axis]).mul(self.inv[axis]);
            // NaN in `tn`/`tf` leaves the accumulated value unchanged.
            t0 = tn.max(t0);
            t1 = tf.min(t1);
        }
        let mask = t0.le_mask(t1.mul(F4::splat(FAR_SCALE)));
        (mask, t0)
    }
}

#[derive(Clone, Copy)]
struct Entry {
    /// Node index (inner) or first slot (leaf).
    node: u32,
    /// 0 for an inner node, else the leaf's slot count.
    count: u32,
    /// Entry distance, to skip subtrees beyond the closest hit so far.
    t: f32,
}

/// Fixed traversal stack, no allocation and no initialisation.
struct Stack {
    items: [std::mem::MaybeUninit<Entry>; STACK_SIZE],
    len: usize,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Self {
            items: [const { std::mem::MaybeUninit::uninit() }; STACK_SIZE],
            len: 0,
        }
    }
    #[inline(always)]
    fn push(&mut self, e: Entry) {
        // The depth guard of the build bounds the stack; indexing keeps a
        // broken invariant a panic, never a memory error.
        self.items[self.len].write(e);
        self.len += 1;
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below `len` was written by `push`.
        Some(unsafe { self.items[self.len].assume_init_read() })
    }
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
        let align = settings.align.clamp(1, 16);
        let mut preset = settings.quality.preset();
        preset.max_leaf = preset.max_leaf.div_ceil(align) * align;
        if settings.leaf_cost.is_finite() && settings.leaf_cost > 0.0 {
            preset.pack_cost = settings.leaf_cost;
        }
        let mut order: Vec<u32> = (0..boxes.len() as u32)
            .filter(|&i| {
                let b = &boxes[i as usize];
                b.is_finite() && !b.is_empty()
            })
            .collect();
        if order.is_empty() {
            return Bvh {
                nodes: Vec::new(),
                order,
                depth: 0,
            };
        }
        let centroids: Vec<Vec3> = boxes.iter().map(|b| b.centroid()).collect();
        let ctx = BuildCtx {
            boxes,
            centroids: &centroids,
            preset,
            align,
        };
        let bounds = order
            .iter()
            .fold(Aabb::EMPTY, |a, &i| a.union(boxes[i as usize]));
        let root = ctx.build(&mut order, 0, bounds, 0);
        let mut out = Collapse {
            nodes: Vec::with_capacity(order.len() / 2 + 1),
            src: &order,
            slots: Vec::with_capacity(order.len() + order.len() / 2),
            align,
        };
        let depth = out.node(&root, 1);
        Bvh {
            nodes: out.nodes,
            order: out.slots,
            depth,
        }
    }

    /// Starts loading an inner node that traversal will visit later.
    #[inline(always)]
    fn prefetch(&self, e: &Entry) {
        #[cfg(target_arch = "x86_64")]
        if e.count == 0 {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let p = self.nodes.as_ptr().wrapping_add(e.node as usize) as *const i8;
            // SAFETY: a prefetch never faults, whatever the address.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p);
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64));
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = e;
    }

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

    /// Closest hit: `hit(slot, ray)` intersects the primitive in `slot`
    /// with a ray whose `t_max` is the closest hit so far, and returns its
    /// distance and payload. Returns the closest `(t, slot, payload)`.
    /// Padding slots are never passed.
    #[inline]
    pub fn intersect_with<H, F>(&self, ray: &Ray, mut hit: F) -> Option<(f32, u32, H)>
    where
        F: FnMut(u32, &Ray) -> Option<(f32, H)>,
    {
        self.intersect_leaves(ray, |first, count, r| {
            let mut r = *r;
            let mut best = None;
            for slot in first..first + count {
                if let Some((t, h)) = hit(slot, &r) {
                    r.t_max = t;
                    best = Some((t, (slot, h)));
                }
            }
            best
        })
        .map(|(t, (slot, h))| (t, slot, h))
    }

    /// Any hit, primitive by primitive: whether `hit(slot, ray)` is true
    /// for some primitive whose box the ray touches. Stops at the first.
    #[inline]
    pub fn occluded<F>(&self, ray: &Ray, mut hit: F) -> bool
    where
        F: FnMut(u32, &Ray) -> bool,
    {
        self.occluded_leaves(ray, |first, count, r| {
            (first..first + count).any(|slot| hit(slot, r))
        })
    }

    /// Closest hit, leaf by leaf: `leaf(first, count, ray)` tests the slots
    /// `first..first + count` (then padding up to the alignment) against a
    /// ray whose `t_max` is the closest hit so far, and returns the closest
    /// of its hits below `t_max`.
    #[inline]
    pub fn intersect_leaves<H, F>(&self, ray: &Ray, leaf: F) -> Option<(f32, H)>
    where
        F: FnMut(u32, u32, &Ray) -> Option<(f32, H)>,
    {
        if self.nodes.is_empty() || !traceable(ray) {
            return None;
        }
        self.intersect_leaves_prepared(&TravRay::new(ray), ray, leaf)
    }

    /// `intersect_leaves` with a traceable ray already prepared
    /// (`TravRay::new(ray)`).
    #[inline]
    pub fn intersect_leaves_prepared<H, F>(
        &self,
        tr: &TravRay,
        ray: &Ray,
        mut leaf: F,
    ) -> Option<(f32, H)>
    where
        F: FnMut(u32, u32, &Ray) -> Option<(f32, H)>,
    {
        if self.nodes.is_empty() {
            return None;
        }
        let mut r = *ray;
        let mut best = None;
        let mut stack = Stack::new();
        let mut cur = Entry {
            node: 0,
            count: 0,
            t: ray.t_min,
        };
        loop {
            if cur.count == 0 {
                // SAFETY-free indexing: node indices come from the build.
                let node = &self.nodes[cur.node as usize];
                let (mask, t0) = tr.hit4(node, r.t_max);
                if mask != 0 {
                    let t0 = t0.to_array();
                    if mask & (mask - 1) == 0 {
                        // One child: descend without touching the stack.
                        let k = mask.trailing_zeros() as usize;
                        cur = Entry {
                            node: node.child[k],
                            count: node.count[k],
                            t: t0[k],
                        };
                        continue;
                    }
                    let entry = |k: usize| Entry {
                        node: node.child[k],
                        count: node.count[k],
                        t: t0[k],
                    };
                    let m1 = mask & (mask - 1);
                    if m1 & (m1 - 1) == 0 {
                        // Two, the common case: push the farther one.
                        let a = entry(mask.trailing_zeros() as usize);
                        let b = entry(m1.trailing_zeros() as usize);
                        let (near, far) = if b.t < a.t { (b, a) } else { (a, b) };
                        self.prefetch(&far);
                        stack.push(far);
                        cur = near;
                        continue;
                    }
                    // Three or four: sort by entry distance, push the
                    // farther ones, descend into the nearest.
                    let mut hits = [cur; 4];
                    let mut n = 0;
                    let mut m = mask;
                    while m != 0 {
                        let k = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let e = entry(k);
                        // Insertion sort, farthest first.
                        let mut j = n;
                        while j > 0 && hits[j - 1].t < e.t {
                            hits[j] = hits[j - 1];
                            j -= 1;
                        }
                        hits[j] = e;
                        n += 1;
                    }
                    for e in &hits[..n - 1] {
                        self.prefetch(e);
                        stack.push(*e);
                    }
                    cur = hits[n - 1];
                    continue;
                }
            } else if let Some((t, h)) = leaf(cur.node, cur.count, &r) {
                r.t_max = t;
                best = Some((t, h));
            }
            // Next subtree that may still hold a closer hit (with the same
            // widening as the box test).
            let limit = r.t_max * FAR_SCALE;
            loop {
                match stack.pop() {
                    None => return best,
                    Some(e) if e.t <= limit => {
                        cur = e;
                        break;
                    }
                    Some(_) => {}
                }
            }
        }
    }

    /// Any hit, leaf by leaf: whether `leaf(first, count, ray)` is true for
    /// some leaf the ray reaches. Stops at the first.
    #[inline]
    pub fn occluded_leaves<F>(&self, ray: &Ray, leaf: F) -> bool
    where
        F: FnMut(u32, u32, &Ray) -> bool,
    {
        if self.nodes.is_empty() || !traceable(ray) {
            return false;
        }
        self.occluded_leaves_prepared(&TravRay::new(ray), ray, leaf)
    }

    /// `occluded_leaves` with a traceable ray already prepared
    /// (`TravRay::new(ray)`).
    #[inline]
    pub fn occluded_leaves_prepared<F>(&self, tr: &TravRay, ray: &Ray, mut leaf: F) -> bool
    where
        F: FnMut(u32, u32, &Ray) -> bool,
    {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = Stack::new();
        let mut cur = Entry {
            node: 0,
            count: 0,
            t: 0.0,
        };
        loop {
            if cur.count == 0 {
                let node = &self.nodes[cur.node as usize];
                let (mut mask, _) = tr.hit4(node, ray.t_max);
                if mask != 0 {
                    let k = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    while mask != 0 {
                        let j = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let e = Entry {
                            node: node.child[j],
                            count: node.count[j],
                            t: 0.0,
                        };
                        self.prefetch(&e);
                        stack.push(e);
                    }
                    cur = Entry {
                        node: node.child[k],
                        count: node.count[k],
                        t: 0.0,
                    };
                    continue;
                }
            } else if leaf(cur.node, cur.count, ray) {
                return true;
            }
            match stack.pop() {
                None => return false,
                Some(e) => cur = e,
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Build.

/// Binary build tree, collapsed into `Node4`s afterwards.
enum BuildNode {
    Leaf {
        first: u32,
        count: u32,
    },
    Inner {
        children: Box<[(Aabb, BuildNode); 2]>,
    },
}

struct BuildCtx<'a> {
    boxes: &'a [Aabb],
    centroids: &'a [Vec3],
    preset: Preset,
    align: usize,
}

enum Split {
    /// `idx` partitioned: this many primitives go left.
    At(usize),
    /// The SAH prefers a leaf.
    Leaf,
    /// No SAH split (centroids all equal, or the depth guard).
    Unsplittable,
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

fn log2_ceil(n: usize) -> usize {
    (usize::BITS - n.saturating_sub(1).leading_zeros()) as usize
}

impl BuildCtx<'_> {
    /// Builds the subtree over `idx` (slots `first..first + idx.len()`),
    /// whose primitives' union is `bounds`, at binary depth `depth`.
    fn build(&self, idx: &mut [u32], first: usize, bounds: Aabb, depth: usize) -> BuildNode {
        let n = idx.len();
        let leaf = BuildNode::Leaf {
            first: first as u32,
            count: n as u32,
        };
        if n <= 1 {
            return leaf;
        }
        let cb = idx
            .iter()
            .fold(Aabb::EMPTY, |a, &i| a.grow(self.centroids[i as usize]));
        let max_leaf = self.preset.max_leaf;
        // Depth guard: from here, halving splits keep every leaf above
        // MAX_DEPTH.
        let guard = depth + 1 + log2_ceil(n) >= MAX_DEPTH;
        let split = if guard {
            Split::Unsplittable
        } else {
            self.sah_split(idx, &cb, bounds, n)
        };
        let mid = match split {
            Split::At(mid) => mid,
            Split::Leaf => return leaf,
            Split::Unsplittable if n <= max_leaf => return leaf,
            Split::Unsplittable => {
                // Median split along the widest centroid axis (by index
                // when every centroid is the same).
                let e = cb.extent();
                let axis = if e.x >= e.y && e.x >= e.z {
                    0
                } else if e.y >= e.z {
                    1
                } else {
                    2
                };
                let half = n / 2;
                let c = self.centroids;
                idx.select_nth_unstable_by(half, |&a, &b| {
                    c[a as usize][axis].total_cmp(&c[b as usize][axis])
                });
                half
            }
        };
        let (l, r) = idx.split_at_mut(mid);
        let bl = self.bounds_of(l);
        let br = self.bounds_of(r);
        let (left, right) = if n >= PARALLEL_THRESHOLD {
            rayon::join(
                || self.build(l, first, bl, depth + 1),
                || self.build(r, first + mid, br, depth + 1),
            )
        } else {
            (
                self.build(l, first, bl, depth + 1),
                self.build(r, first + mid, br, depth + 1),
            )
        };
        BuildNode::Inner {
            children: Box::new([(bl, left), (br, right)]),
        }
    }

    /// Cost of testing `n` primitives: packs of `align`.
    #[inline]
    fn packs(&self, n: usize) -> f32 {
        n.div_ceil(self.align) as f32 * self.preset.pack_cost
    }

    fn bounds_of(&self, idx: &[u32]) -> Aabb {
        idx.iter()
            .fold(Aabb::EMPTY, |a, &i| a.union(self.boxes[i as usize]))
    }

    /// Binned SAH over the three axes; on `Split::At`, `idx` is partitioned.
    fn sah_split(&self, idx: &mut [u32], cb: &Aabb, bounds: Aabb, n: usize) -> Split {
        let nb = self.preset.bins;
        let ext = cb.max - cb.min;
        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, split bin)
        let mut bins = [[Bin {
            bounds: Aabb::EMPTY,
            count: 0,
        }; 64]; 3];
        let scale = Vec3::new(
            bin_scale(nb, ext.x),
            bin_scale(nb, ext.y),
            bin_scale(nb, ext.z),
        );
        for &i in idx.iter() {
            let c = self.centroids[i as usize];
            let b = self.boxes[i as usize];
            for axis in 0..3 {
                let k = bin_of(c[axis], cb.min[axis], scale[axis], nb);
                let bin = &mut bins[axis][k];
                bin.bounds = bin.bounds.union(b);
                bin.count += 1;
            }
        }
        let mut right_area = [0.0f32; 64];
        let mut right_count = [0u32; 64];
        for axis in 0..3 {
            if ext[axis].is_nan() || ext[axis] <= 0.0 {
                continue;
            }
            let bins = &bins[axis];
            // right_*[k]: bins k..nb.
            let (mut rb, mut rc) = (Aabb::EMPTY, 0);
            for k in (1..nb).rev() {
                rb = rb.union(bins[k].bounds);
                rc += bins[k].count;
                right_area[k] = rb.half_area();
                right_count[k] = rc;
            }
            let (mut lb, mut lc) = (Aabb::EMPTY, 0);
            for k in 1..nb {
                lb = lb.union(bins[k - 1].bounds);
                lc += bins[k - 1].count;
                if lc == 0 || right_count[k] == 0 {
                    continue;
                }
                let cost = lb.half_area() * self.packs(lc as usize)
                    + right_area[k] * self.packs(right_count[k] as usize);
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, k));
                }
            }
        }
        let Some((cost, axis, k)) = best else {
            return Split::Unsplittable;
        };
        let area = bounds.half_area();
        let split_cost = self.preset.traversal_cost + cost / area.max(f32::MIN_POSITIVE);
        if n <= self.preset.max_leaf && self.packs(n) <= split_cost {
            return Split::Leaf;
        }
        let (min, s) = (cb.min[axis], scale[axis]);
        let c = self.centroids;
        let mid = partition(idx, |i| bin_of(c[i as usize][axis], min, s, nb) < k);
        debug_assert!(mid > 0 && mid < n);
        Split::At(mid)
    }
}

#[inline]
fn bin_scale(nb: usize, extent: f32) -> f32 {
    if extent > 0.0 {
        nb as f32 * (1.0 - 1e-6) / extent
    } else {
        0.0
    }
}

#[inline]
fn bin_of(c: f32, min: f32, scale: f32, nb: usize) -> usize {
    (((c - min) * scale) as usize).min(nb - 1)
}

/// In-place partition: elements satisfying `left` first; returns their count.
fn partition(idx: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    let mut j = idx.len();
    loop {
        while i < j && left(idx[i]) {
            i += 1;
        }
        while i < j && !left(idx[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        idx.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// Collapse of the binary tree into `Node4`s, assigning (padded) slots to
/// leaves in the order traversal meets them.
struct Collapse<'a> {
    nodes: Vec<Node4>,
    /// Primitive order of the binary build.
    src: &'a [u32],
    slots: Vec<u32>,
    align: usize,
}

impl Collapse<'_> {
    /// Slots for the leaf `src[first..first + count]`; returns the first.
    fn leaf(&mut self, first: u32, count: u32) -> u32 {
        let at = self.slots.len();
        let (f, c) = (first as usize, count as usize);
        self.slots.extend_from_slice(&self.src[f..f + c]);
        let padded = c.div_ceil(self.align) * self.align;
        self.slots.resize(at + padded, PADDING);
        at as u32
    }

    /// Emits the 4-wide node for binary node `node` (an inner node, or the
    /// root even when it is a leaf) and its subtree; returns the subtree's
    /// depth.
    fn node(&mut self, node: &BuildNode, depth: usize) -> usize {
        let at = self.nodes.len();
        self.nodes.push(Node4::EMPTY);
        let mut out = Node4::EMPTY;
        let mut max_depth = depth;
        match node {
            BuildNode::Leaf { first, count } => {
                // A root that is a leaf: one child holding every slot.
                let everything = Aabb::new(Vec3::splat(f32::MIN), Vec3::splat(f32::MAX));
                out.set_box(0, &everything);
                out.child[0] = self.leaf(*first, *count);
                out.count[0] = *count;
            }
            BuildNode::Inner { children } => {
                let mut kids: Vec<&(Aabb, BuildNode)> = children.iter().collect();
                // Open the largest inner child until there are four.
                while kids.len() < 4 {
                    let widest = kids
                        .iter()
                        .enumerate()
                        .filter(|(_, k)| matches!(k.1, BuildNode::Inner { .. }))
                        .max_by(|a, b| a.1 .0.half_area().total_cmp(&b.1 .0.half_area()))
                        .map(|(i, _)| i);
                    let Some(w) = widest else { break };
                    let BuildNode::Inner { children } = &kids[w].1 else {
                        unreachable!()
                    };
                    kids.swap_remove(w);
                    kids.extend(children.iter());
                }
                // Leaves first: their slots then sit next to each other.
                kids.sort_by_key(|k| matches!(k.1, BuildNode::Inner { .. }));
                for (k, (b, kid)) in kids.into_iter().enumerate() {
                    out.set_box(k, b);
                    match kid {
                        BuildNode::Leaf { first, count } => {
                            out.child[k] = self.leaf(*first, *count);
                            out.count[k] = *count;
                        }
                        inner => {
                            out.child[k] = self.nodes.len() as u32;
                            max_depth = max_depth.max(self.node(inner, depth + 1));
                        }
                    }
                }
            }
        }
        self.nodes[at] = out;
        max_depth
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{uniform_sphere, Rng};
    use crate::scene::shape::intersect_triangle;

    type Tri = [Vec3; 3];

    fn boxes_of(tris: &[Tri]) -> Vec<Aabb> {
        tris.iter().map(|t| Aabb::from_points(t)).collect()
    }

    fn isect(t: &Tri, r: &Ray) -> Option<f32> {
        intersect_triangle(*t, r).map(|h| h.t)
    }

    fn brute(tris: &[Tri], ray: &Ray) -> Option<(f32, u32)> {
        let mut r = *ray;
        let mut best = None;
        for (i, t) in tris.iter().enumerate() {
            if let Some(t) = isect(t, &r) {
                r.t_max = t;
                best = Some((t, i as u32));
            }
        }
        best
    }

    /// Closest hit through the BVH, as the original primitive index.
    fn closest(bvh: &Bvh, tris: &[Tri], ray: &Ray) -> Option<(f32, u32)> {
        let order = bvh.primitive_indices();
        bvh.intersect_with(ray, |slot, r| {
            isect(&tris[order[slot as usize] as usize], r).map(|t| (t, ()))
        })
        .map(|(t, slot, ())| (t, order[slot as usize]))
    }

    fn any(bvh: &Bvh, tris: &[Tri], ray: &Ray) -> bool {
        let order = bvh.primitive_indices();
        bvh.occluded(ray, |slot, r| {
            isect(&tris[order[slot as usize] as usize], r).is_some()
        })
    }

    fn point(rng: &mut Rng, scale: f32) -> Vec3 {
        (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE) * scale
    }

    fn soup(rng: &mut Rng, n: usize, scale: f32, size: f32) -> Vec<Tri> {
        (0..n)
            .map(|_| {
                let a = point(rng, scale);
                [
                    a,
                    a + size * scale * uniform_sphere(rng.next_2d()),
                    a + size * scale * uniform_sphere(rng.next_2d()),
                ]
            })
            .collect()
    }

    fn random_ray(rng: &mut Rng, scale: f32) -> Ray {
        let o = point(rng, 1.5 * scale);
        let mut d = uniform_sphere(rng.next_2d());
        if rng.next_f32() < 0.1 {
            let axis = (rng.next_u32() % 3) as usize;
            d = Vec3::ZERO;
            d[axis] = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
        }
        let mut r = Ray::new(o, d);
        if rng.next_f32() < 0.2 {
            r.t_max = scale * rng.next_f32();
        }
        r
    }

    /// Closest hit and any hit agree with brute force on every ray.
    fn check(tris: &[Tri], rays: &[Ray], quality: BuildQuality) -> usize {
        let expected: Vec<_> = rays.iter().map(|r| brute(tris, r)).collect();
        check_against(tris, rays, &expected, quality)
    }

    fn check_against(
        tris: &[Tri],
        rays: &[Ray],
        expected: &[Option<(f32, u32)>],
        quality: BuildQuality,
    ) -> usize {
        let bvh = Bvh::build(&boxes_of(tris), quality);
        assert!(bvh.depth() <= MAX_DEPTH);
        let mut hits = 0;
        for (ray, &e) in rays.iter().zip(expected) {
            let g = closest(&bvh, tris, ray);
            match (e, g) {
                (Some(e), Some(g)) => {
                    hits += 1;
                    assert_eq!(e.0, g.0, "{ray:?}");
                    if e.1 != g.1 {
                        // A tie: the other triangle must report the same t.
                        assert_eq!(isect(&tris[g.1 as usize], ray), Some(g.0), "{ray:?}");
                    }
                }
                (None, None) => {}
                _ => panic!("brute force {e:?}, bvh {g:?} for {ray:?}"),
            }
            assert_eq!(any(&bvh, tris, ray), e.is_some(), "occluded {ray:?}");
        }
        hits
    }

    #[test]
    fn matches_brute_force_on_1e5_random_rays() {
        let mut rng = Rng::new(7, 1);
        let tris = soup(&mut rng, 3000, 1.0, 0.08);
        let rays: Vec<Ray> = (0..100_000).map(|_| random_ray(&mut rng, 1.0)).collect();
        for q in [
            BuildQuality::Balanced,
            BuildQuality::Fast,
            BuildQuality::High,
        ] {
            let hits = check(&tris, &rays, q);
            assert!(hits > 10_000 && hits < 90_000, "{hits} hits");
        }
    }

    /// 4-aligned leaves: every real primitive has exactly one slot, leaves
    /// start on multiples of four, and leaf-level traversal never hands out
    /// a padding slot; results still match brute force.
    #[test]
    fn aligned_leaves_pad_and_match_brute_force() {
        let mut rng = Rng::new(10, 1);
        let tris = soup(&mut rng, 2000, 1.0, 0.08);
        let settings = BuildSettings {
            align: 4,
            ..BuildSettings::default()
        };
        let bvh = Bvh::build_with(&boxes_of(&tris), &settings);
        let order = bvh.primitive_indices();
        assert_eq!(order.len() % 4, 0);
        let mut real: Vec<u32> = order.iter().copied().filter(|&i| i != PADDING).collect();
        real.sort_unstable();
        assert!(real.iter().enumerate().all(|(i, &p)| i as u32 == p));
        for _ in 0..20_000 {
            let ray = random_ray(&mut rng, 1.0);
            let got = bvh.intersect_leaves(&ray, |first, count, r| {
                assert_eq!(first % 4, 0);
                let mut r = *r;
                let mut best = None;
                for slot in first..first + count {
                    let i = order[slot as usize];
                    assert_ne!(i, PADDING);
                    if let Some(t) = isect(&tris[i as usize], &r) {
                        r.t_max = t;
                        best = Some((t, i));
                    }
                }
                best
            });
            assert_eq!(got.map(|g| g.0), brute(&tris, &ray).map(|e| e.0), "{ray:?}");
        }
    }

    #[test]
    fn huge_and_tiny_scales() {
        let mut rng = Rng::new(8, 1);
        for scale in [1e-4f32, 1e-2, 1e2, 1e4] {
            let tris = soup(&mut rng, 800, scale, 0.1);
            let rays: Vec<Ray> = (0..20_000).map(|_| random_ray(&mut rng, scale)).collect();
            let hits = check(&tris, &rays, BuildQuality::Balanced);
            assert!(hits > 1000, "scale {scale}: {hits} hits");
        }
    }

    /// Axis-aligned triangles (flat boxes) on a grid, hit by exactly
    /// axis-parallel rays, many starting in the boxes' planes.
    #[test]
    fn axis_parallel_rays_and_flat_boxes() {
        let mut tris = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                let (x, y) = (i as f32 * 0.2, j as f32 * 0.2);
                let z = ((i + j) % 3) as f32 * 0.5;
                // In a z plane, an x plane and a y plane.
                tris.push([
                    Vec3::new(x, y, z),
                    Vec3::new(x + 0.2, y, z),
                    Vec3::new(x, y + 0.2, z),
                ]);
                tris.push([
                    Vec3::new(z, x, y),
                    Vec3::new(z, x + 0.2, y),
                    Vec3::new(z, x, y + 0.2),
                ]);
                tris.push([
                    Vec3::new(y, z, x),
                    Vec3::new(y, z, x + 0.2),
                    Vec3::new(y + 0.2, z, x),
                ]);
            }
        }
        // Degenerate triangles: a segment and a point.
        tris.push([Vec3::ZERO, Vec3::X, Vec3::X]);
        tris.push([Vec3::ONE; 3]);
        let mut rng = Rng::new(9, 2);
        let mut rays = Vec::new();
        for _ in 0..20_000 {
            let axis = (rng.next_u32() % 3) as usize;
            let mut d = Vec3::ZERO;
            d[axis] = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
            // Coordinates on the grid lines (box planes) half the time.
            let mut o = Vec3::ZERO;
            for k in 0..3 {
                o[k] = if rng.next_f32() < 0.5 {
                    (rng.next_u32() % 11) as f32 * 0.2
                } else {
                    rng.next_f32() * 2.2 - 0.1
                };
            }
            o[axis] = if d[axis] > 0.0 { -1.0 } else { 3.0 };
            rays.push(Ray::new(o, d));
            // Also from inside, and with -0.0 components.
            let mut r = Ray::new(o, d);
            r.origin[axis] = rng.next_f32() * 2.0;
            r.dir[(axis + 1) % 3] = -0.0;
            rays.push(r);
        }
        let hits = check(&tris, &rays, BuildQuality::Balanced);
        assert!(hits > 5000, "{hits} hits");
        // No NaN ever reaches a result.
        let bvh = Bvh::build(&boxes_of(&tris), BuildQuality::Balanced);
        for r in &rays {
            if let Some((t, _)) = closest(&bvh, &tris, r) {
                assert!(t.is_finite());
            }
        }
    }

    #[test]
    fn empty_single_and_invalid_inputs() {
        let ray = Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z);
        let empty = Bvh::build(&[], BuildQuality::Balanced);
        assert!(empty.primitive_indices().is_empty());
        assert!(empty.intersect_with(&ray, |_, _| Some((1.0, ()))).is_none());
        assert!(!empty.occluded(&ray, |_, _| true));

        let tri = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
        let one = Bvh::build(&boxes_of(&tri), BuildQuality::Balanced);
        assert_eq!(one.primitive_indices(), &[0]);
        assert_eq!(closest(&one, &tri, &ray), Some((1.0, 0)));
        assert!(any(&one, &tri, &ray));
        assert!(!any(&one, &tri, &Ray::new(Vec3::splat(2.0), Vec3::Z)));

        // NaN and empty boxes get no slot; NaN rays hit nothing.
        let nan = Aabb::new(Vec3::splat(f32::NAN), Vec3::ONE);
        let boxes = [nan, boxes_of(&tri)[0], Aabb::EMPTY];
        let bvh = Bvh::build(&boxes, BuildQuality::Balanced);
        assert_eq!(bvh.primitive_indices(), &[1]);
        let bad = Ray::new(Vec3::splat(f32::NAN), Vec3::Z);
        assert!(bvh.intersect_with(&bad, |_, _| Some((1.0, ()))).is_none());
        assert!(!bvh.occluded(&bad, |_, _| true));
        let bad = Ray::new(Vec3::ZERO, Vec3::new(f32::INFINITY, 0.0, 1.0));
        assert!(!bvh.occluded(&bad, |_, _| true));
    }

    /// Identical boxes and exponentially spread ones: the depth guard holds
    /// and every primitive is still found.
    #[test]
    fn depth_guard_and_identical_boxes() {
        let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 10_000];
        let bvh = Bvh::build(&same, BuildQuality::High);
        assert!(bvh.depth() <= MAX_DEPTH);
        let mut seen = vec![false; same.len()];
        let ray = Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::Z);
        assert!(!bvh.occluded(&ray, |slot, _| {
            seen[bvh.primitive_indices()[slot as usize] as usize] = true;
            false
        }));
        assert!(seen.iter().all(|&s| s));

        let spread: Vec<Aabb> = (0..2000)
            .map(|i| {
                let x = 1.02f32.powi(i) - 1.0;
                Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x, 1.0, 1.0))
            })
            .collect();
        let bvh = Bvh::build(&spread, BuildQuality::High);
        assert!(bvh.depth() <= MAX_DEPTH);
        let mut order = bvh.primitive_indices().to_vec();
        order.sort_unstable();
        assert!(order.iter().enumerate().all(|(i, &p)| i as u32 == p));
        // The ray along x sees them nearest first.
        let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        let hit = bvh.intersect_with(&ray, |slot, r| {
            let i = bvh.primitive_indices()[slot as usize] as usize;
            let t = spread[i].min.x + 1.0;
            (t > r.t_min && t < r.t_max).then_some((t, i))
        });
        assert_eq!(hit.map(|h| h.2), Some(0));
    }
}
