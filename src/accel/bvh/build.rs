//! The binary build tree: binned SAH, in parallel above
//! `PARALLEL_THRESHOLD` primitives, with a depth guard that falls back to
//! median splits.

use super::{Preset, MAX_DEPTH, PARALLEL_THRESHOLD};
use crate::math::{Aabb, Vec3};

/// Binary build tree, collapsed into `Node4`s afterwards.
pub(super) enum BuildNode {
    Leaf {
        first: u32,
        count: u32,
    },
    Inner {
        children: Box<[(Aabb, BuildNode); 2]>,
    },
}

pub(super) struct BuildCtx<'a> {
    pub(super) boxes: &'a [Aabb],
    pub(super) centroids: &'a [Vec3],
    pub(super) preset: Preset,
    pub(super) align: usize,
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
    pub(super) fn build(
        &self,
        idx: &mut [u32],
        first: usize,
        bounds: Aabb,
        depth: usize,
    ) -> BuildNode {
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
