//! The binary build tree: binned SAH over primitive references, in
//! parallel above `PARALLEL_THRESHOLD` primitives, with a depth guard that
//! falls back to median splits.
//!
//! A primitive reference carries its box and its index together (32 bytes,
//! as Embree's `PrimRef`), and partitioning moves the references
//! themselves, so every pass over a node reads memory sequentially. Reading
//! boxes and centroids through an index array instead made the build of a
//! 17.8M-triangle mesh cache-bound: 15 s, 5× more per triangle than at
//! 69k.
//!
//! Binning is parallel too (per chunk, then merged) where a node is large,
//! so the first splits, which see every primitive, use every thread.

use super::bins::{bins_for, Binner, Bins};
use super::progress::{report_parallel_leaf, report_serial};
use super::{usable, Preset, MAX_DEPTH, PARALLEL_THRESHOLD};
use crate::math::{Aabb, Vec3};
use crate::memory;
use crate::meter::Reporter;
use glam::{BVec4A, Vec4};
use rayon::prelude::*;

/// A primitive's box with its index in the `w` lane of `min` (as bits).
#[derive(Clone, Copy, Debug)]
pub(super) struct PrimRef {
    min: Vec4,
    max: Vec4,
}

impl PrimRef {
    pub(super) fn new(b: &Aabb, index: u32) -> Self {
        Self {
            min: b.min.extend(f32::from_bits(index)),
            max: b.max.extend(0.0),
        }
    }

    #[inline]
    pub(super) fn index(&self) -> u32 {
        self.min.w.to_bits()
    }

    /// Twice the centroid (the SAH only compares them), with `w` zero.
    ///
    /// `min.w` holds the index's bits: as a float, a subnormal below 2^23
    /// and a tiny normal above. Left in the sum, the binning's arithmetic
    /// on that lane underflowed into subnormals, each a microcode assist
    /// on Intel cores: at 17.8M triangles the medium build took 1.7x the
    /// time it takes with the lane cleared (docs/performance.md,
    /// 2026-12-06).
    #[inline]
    pub(super) fn centroid2(&self) -> Vec4 {
        let sum = self.min + self.max;
        Vec4::select(BVec4A::new(true, true, true, false), sum, Vec4::ZERO)
    }
}

/// Bounds kept as two SIMD rows; `w` lanes are ignored.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bounds {
    pub(super) min: Vec4,
    pub(super) max: Vec4,
}

impl Bounds {
    pub(super) const EMPTY: Bounds = Bounds {
        min: Vec4::splat(f32::INFINITY),
        max: Vec4::splat(f32::NEG_INFINITY),
    };

    #[inline]
    pub(super) fn grow(&mut self, r: &PrimRef) {
        self.min = self.min.min(r.min);
        self.max = self.max.max(r.max);
    }

    #[inline]
    fn grow_point(&mut self, p: Vec4) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    #[inline]
    pub(super) fn union(self, o: Bounds) -> Bounds {
        Bounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    fn aabb(&self) -> Aabb {
        Aabb::new(Vec3::from_vec4(self.min), Vec3::from_vec4(self.max))
    }

    #[inline]
    fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec4::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

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
    pub(super) preset: Preset,
    /// log2 of the pack width `align` (a power of two): the SAH asks for
    /// pack counts of every candidate split, and a division there was a
    /// tenth of the build's instructions.
    pub(super) align_log2: u32,
    pub(super) progress: &'a Reporter,
}

enum Split {
    /// The references partitioned: this many go left.
    At(usize, Side, Side),
    /// The SAH prefers a leaf.
    Leaf,
    /// No SAH split (centroids all equal, or the depth guard).
    Unsplittable,
}

fn log2_ceil(n: usize) -> usize {
    (usize::BITS - n.saturating_sub(1).leading_zeros()) as usize
}

/// Bounds and (doubled) centroid bounds of `refs`.
fn bounds_of(refs: &[PrimRef]) -> (Bounds, Bounds) {
    let one = |refs: &[PrimRef]| {
        refs.iter()
            .fold((Bounds::EMPTY, Bounds::EMPTY), |(mut b, mut c), r| {
                b.grow(r);
                c.grow_point(r.centroid2());
                (b, c)
            })
    };
    if refs.len() < PARALLEL_THRESHOLD * 4 {
        return one(refs);
    }
    refs.par_chunks(PARALLEL_THRESHOLD).map(one).reduce(
        || (Bounds::EMPTY, Bounds::EMPTY),
        |a, b| (a.0.union(b.0), a.1.union(b.1)),
    )
}

impl BuildCtx<'_> {
    /// Builds the tree over `refs` (slots `first..first + refs.len()`), at
    /// binary depth `depth`; `bounds` are those of `refs`.
    pub(super) fn build(&self, refs: &mut [PrimRef], first: usize, depth: usize) -> BuildNode {
        let (bounds, centroids) = bounds_of(refs);
        let root = self.build_in(refs, first, depth, bounds, centroids).1;
        report_serial(self.progress, refs.len());
        root
    }

    fn build_in(
        &self,
        refs: &mut [PrimRef],
        first: usize,
        depth: usize,
        bounds: Bounds,
        centroids: Bounds,
    ) -> (Aabb, BuildNode) {
        let n = refs.len();
        let leaf = BuildNode::Leaf {
            first: first as u32,
            count: n as u32,
        };
        // A split costs a node visit at least, so a leaf that costs no more
        // is chosen without binning. Most leaves are such, and were binned
        // and swept only to be chosen.
        if n <= 1 || (n <= self.preset.max_leaf && self.packs(n) <= self.preset.traversal_cost) {
            return (bounds.aabb(), leaf);
        }
        // Depth guard: from here, halving splits keep every leaf above
        // MAX_DEPTH.
        let guard = depth + 1 + log2_ceil(n) >= MAX_DEPTH;
        let split = if guard {
            Split::Unsplittable
        } else {
            self.sah_split(refs, &centroids, &bounds)
        };
        // The left count, and each side's bounds where the split gathered
        // them.
        let (mid, ls, rs) = match split {
            Split::At(mid, l, r) => (mid, Some(l), Some(r)),
            Split::Leaf => {
                report_parallel_leaf(self.progress, n);
                return (bounds.aabb(), leaf);
            }
            Split::Unsplittable if n <= self.preset.max_leaf => return (bounds.aabb(), leaf),
            Split::Unsplittable => (median_split(refs, &centroids), None, None),
        };
        let (l, r) = refs.split_at_mut(mid);
        let build = |refs: &mut [PrimRef], first: usize, side: Option<Side>| {
            let (b, c) = match side {
                Some(s) => (s.bounds, s.centroids),
                None => bounds_of(refs),
            };
            self.build_in(refs, first, depth + 1, b, c)
        };
        let (left, right) = if n >= PARALLEL_THRESHOLD {
            let reported = |refs: &mut [PrimRef], first: usize, side: Option<Side>| {
                let built = build(refs, first, side);
                report_serial(self.progress, refs.len());
                built
            };
            rayon::join(|| reported(l, first, ls), || reported(r, first + mid, rs))
        } else {
            (build(l, first, ls), build(r, first + mid, rs))
        };
        (
            bounds.aabb(),
            BuildNode::Inner {
                children: Box::new([left, right]),
            },
        )
    }

    /// Cost of testing `n` primitives: packs of `align`.
    #[inline]
    fn packs(&self, n: usize) -> f32 {
        let packs = (n + (1 << self.align_log2) - 1) >> self.align_log2;
        packs as f32 * self.preset.pack_cost
    }

    /// Binned SAH over the three axes with [`bins_for`] the node's size
    /// and the preset; on `Split::At`, `refs` is partitioned. The bins'
    /// capacity is a constant, so a small node does not clear a large
    /// node's.
    fn sah_split(&self, refs: &mut [PrimRef], centroids: &Bounds, bounds: &Bounds) -> Split {
        let bins = bins_for(refs.len(), self.preset.bins);
        match bins {
            0..=8 => self.sah_split_in::<8>(refs, bins, centroids, bounds),
            9..=16 => self.sah_split_in::<16>(refs, bins, centroids, bounds),
            _ => self.sah_split_in::<48>(refs, bins, centroids, bounds),
        }
    }

    /// As `sah_split`, with `bins` of the capacity `N`.
    fn sah_split_in<const N: usize>(
        &self,
        refs: &mut [PrimRef],
        bins: usize,
        centroids: &Bounds,
        bounds: &Bounds,
    ) -> Split {
        let n = refs.len();
        let binner = Binner::new(centroids, bins.min(N));
        // The serial bins are swept where they were filled: moved out of
        // the branch, 1.7 KB of them were copied once per node.
        let best = if n >= PARALLEL_THRESHOLD * 4 {
            let bins = refs
                .par_chunks(PARALLEL_THRESHOLD)
                .fold(Bins::<N>::new, |mut b, chunk| {
                    b.fill(chunk, &binner);
                    b
                })
                .reduce(Bins::new, Bins::merge);
            self.best_split(&bins, binner.count, centroids)
        } else {
            let mut bins = Bins::<N>::new();
            bins.fill(refs, &binner);
            self.best_split(&bins, binner.count, centroids)
        };
        let Some((cost, axis, k)) = best else {
            return Split::Unsplittable;
        };
        let area = bounds.half_area();
        let split_cost = self.preset.traversal_cost + cost / area.max(f32::MIN_POSITIVE);
        if n <= self.preset.max_leaf && self.packs(n) <= split_cost {
            return Split::Leaf;
        }
        let (mid, left, right) = partition(refs, |r| binner.bin_on(r, axis) < k);
        debug_assert!(mid > 0 && mid < n);
        Split::At(mid, left, right)
    }

    /// The cheapest (cost, axis, first right bin) over the axes that have
    /// an extent, among the first `nb` bins.
    fn best_split<const N: usize>(
        &self,
        bins: &Bins<N>,
        nb: usize,
        centroids: &Bounds,
    ) -> Option<(f32, usize, usize)> {
        let ext = centroids.max - centroids.min;
        let mut best: Option<(f32, usize, usize)> = None;
        let mut right_area = [0.0f32; N];
        let mut right_count = [0u32; N];
        for axis in 0..3 {
            if ext[axis].is_nan() || ext[axis] <= 0.0 {
                continue;
            }
            let (bounds, count) = (&bins.bounds[axis], &bins.count[axis]);
            // right_*[k]: bins k..nb.
            let (mut rb, mut rc) = (Bounds::EMPTY, 0);
            for k in (1..nb).rev() {
                rb = rb.union(bounds[k]);
                rc += count[k];
                right_area[k] = rb.half_area();
                right_count[k] = rc;
            }
            let (mut lb, mut lc) = (Bounds::EMPTY, 0);
            for k in 1..nb {
                lb = lb.union(bounds[k - 1]);
                lc += count[k - 1];
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
        best
    }
}

/// Median split along the widest centroid axis (by index when every
/// centroid is the same); returns the left count.
fn median_split(refs: &mut [PrimRef], centroids: &Bounds) -> usize {
    let e = centroids.max - centroids.min;
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let half = refs.len() / 2;
    refs.select_nth_unstable_by(half, |a, b| {
        a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
    });
    half
}

/// Bounds of every finite, non-empty box as references, in index order.
pub(super) fn prim_refs(count: usize, box_of: impl Fn(usize) -> Aabb + Sync) -> Vec<PrimRef> {
    // Written in place (a filtered collect would copy every reference once
    // more); an unusable box's reference is marked in the ignored `max.w`
    // and removed after, which is rare.
    let mut refs = memory::vec_with_capacity(count);
    (0..count)
        .into_par_iter()
        .with_min_len(PARALLEL_THRESHOLD)
        .map(|i| {
            let b = box_of(i);
            let mut r = PrimRef::new(&b, i as u32);
            r.max.w = if usable(&b) { 0.0 } else { UNUSABLE };
            r
        })
        .collect_into_vec(&mut refs);
    if refs.par_iter().any(|r| r.max.w == UNUSABLE) {
        refs.retain(|r| r.max.w != UNUSABLE);
    }
    refs
}

/// `max.w` of a reference to leave out.
const UNUSABLE: f32 = 1.0;

/// The bounds and (doubled) centroid bounds of one side of a partition.
#[derive(Clone, Copy)]
struct Side {
    bounds: Bounds,
    centroids: Bounds,
}

impl Side {
    const EMPTY: Side = Side {
        bounds: Bounds::EMPTY,
        centroids: Bounds::EMPTY,
    };

    #[inline]
    fn grow(&mut self, r: &PrimRef) {
        self.bounds.grow(r);
        self.centroids.grow_point(r.centroid2());
    }
}

/// In-place partition: elements satisfying `left` first; returns their
/// count and the bounds of each side, gathered as every element passes
/// (each is looked at once), which saves the children a pass of their own.
fn partition(refs: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> (usize, Side, Side) {
    let (mut l, mut r) = (Side::EMPTY, Side::EMPTY);
    let mut i = 0;
    let mut j = refs.len();
    loop {
        while i < j && left(&refs[i]) {
            l.grow(&refs[i]);
            i += 1;
        }
        while i < j && !left(&refs[j - 1]) {
            r.grow(&refs[j - 1]);
            j -= 1;
        }
        if i >= j {
            return (i, l, r);
        }
        refs.swap(i, j - 1);
        l.grow(&refs[i]);
        r.grow(&refs[j - 1]);
        i += 1;
        j -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    /// The index's bits are a subnormal float below 2^23 and a tiny normal
    /// one above; neither may reach the centroid, whose every lane goes
    /// through the binning's arithmetic.
    #[test]
    fn centroids_carry_no_index_bits() {
        let b = Aabb::new(Vec3::new(1.0, -2.0, 0.5), Vec3::new(3.0, 2.0, 0.5));
        for index in [0, 1, (1 << 23) - 1, 1 << 23, 17_800_000, u32::MAX - 1] {
            let r = PrimRef::new(&b, index);
            assert_eq!(r.index(), index);
            assert_eq!(r.centroid2().to_array(), [4.0, 0.0, 1.0, 0.0]);
        }
    }
}
