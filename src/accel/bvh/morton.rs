//! The `Low` build: primitives sorted along a Morton curve of their
//! centroids, then split top-down at the highest bit in which a range's
//! codes differ (Karras 2012's binary radix tree, built recursively). A
//! handful of passes over the primitives instead of the binned SAH's three
//! per tree level: for a build that will serve few rays (few samples, a
//! huge mesh) the time saved outweighs the slower traversal.
//!
//! The tree is the same `BuildNode` tree the SAH build makes, so it is
//! collapsed, padded and traversed by the same code.

use super::build::BuildNode;
use super::progress::report_serial;
use super::{usable, MAX_DEPTH, PARALLEL_THRESHOLD};
use crate::math::{Aabb, Vec3};
use crate::memory;
use crate::meter::Reporter;
use rayon::prelude::*;

/// Bits per axis of the Morton code.
const BITS: u32 = 10;
/// Its highest bit.
const TOP: i32 = 3 * BITS as i32 - 1;
/// The key of a primitive left out: no code reaches the high half's top
/// bits.
const UNUSABLE: u64 = u64::MAX;

/// The tree over the finite, non-empty boxes among `box_of(0..count)`,
/// with leaves of at most `max_leaf` primitives starting at multiples of
/// `align`; and the primitive of each slot. The codes are quantized within
/// the centroids' bounds, or within `given` where [`centroid_grid`] finds
/// it tight enough. It keeps only a code and an index per primitive (8
/// bytes, where a reference with its box takes 32) and asks `box_of` again
/// for the leaves' bounds: on large meshes fresh memory, which the kernel
/// must clear page by page, costs more than recomputing a box.
pub(super) fn build(
    count: usize,
    box_of: &(impl Fn(usize) -> Aabb + Sync),
    given: Option<Aabb>,
    (max_leaf, align): (usize, usize),
    progress: &Reporter,
) -> (BuildNode, Vec<u32>) {
    let valid = |i: usize| Some(box_of(i)).filter(usable);
    let centroids = centroid_grid(count, &valid, given);
    let cells = (1u32 << BITS) as f32 * (1.0 - 1e-6);
    let scale = (centroids.max - centroids.min)
        .recip()
        .min(Vec3::splat(f32::MAX))
        * cells;
    // Written in place (a filtered collect would copy them all once more)
    // with unusable boxes as `UNUSABLE`, which sorts them last.
    let mut keys: Vec<u64> = memory::vec_with_capacity(count);
    (0..count)
        .into_par_iter()
        .with_min_len(PARALLEL_THRESHOLD)
        .map(|i| match valid(i) {
            Some(b) => {
                let q = ((b.centroid() - centroids.min) * scale).max(Vec3::ZERO);
                let code = spread(q.x as u32) | spread(q.y as u32) << 1 | spread(q.z as u32) << 2;
                (code as u64) << 32 | i as u64
            }
            None => UNUSABLE,
        })
        .collect_into_vec(&mut keys);
    keys.par_sort_unstable();
    keys.truncate(keys.partition_point(|&k| k != UNUSABLE));
    let emit = Emit {
        keys: &keys,
        box_of,
        max_leaf,
        align,
        progress,
    };
    let root = emit.node(0, keys.len(), TOP, 0).1;
    report_serial(progress, keys.len());
    let mut order = memory::vec_with_capacity(keys.len());
    keys.par_iter()
        .map(|&k| k as u32)
        .collect_into_vec(&mut order);
    (root, order)
}

/// Primitives a sample of the centroids takes one in every so many of, to
/// judge a given box: about 4,096 of them.
const SAMPLES: usize = 4096;

/// The box the codes are quantized within: `given`, a box that holds every
/// centroid (the meshes' vertex bounds), when it is finite and a sample of
/// the centroids spans at least an eighth of its largest side; else the
/// centroids' bounds, from a pass over all primitives. A box much larger
/// than the centroids (a stray vertex no triangle uses, far away) would
/// put them all in a few cells, and the tree would halve them in index
/// order. A centroid outside the box is clamped into the grid's border
/// cells: its leaf is less tight, never lost.
fn centroid_grid(
    count: usize,
    valid: &(impl Fn(usize) -> Option<Aabb> + Sync),
    given: Option<Aabb>,
) -> Aabb {
    let centroids_of = |i: usize| valid(i).map(|b| Aabb::new(b.centroid(), b.centroid()));
    let largest_side = |b: Aabb| (b.max - b.min).max_element();
    let finite = |b: &Aabb| {
        let sides = b.max - b.min;
        b.min.is_finite() && sides.is_finite() && sides.cmpge(Vec3::ZERO).all()
    };
    if let Some(given) = given.filter(finite) {
        let sample = (0..count)
            .step_by((count / SAMPLES).max(1))
            .filter_map(centroids_of)
            .fold(Aabb::EMPTY, Aabb::union);
        if largest_side(sample) >= largest_side(given) / 8.0 {
            return given;
        }
    }
    (0..count)
        .into_par_iter()
        .with_min_len(PARALLEL_THRESHOLD)
        .filter_map(centroids_of)
        .reduce(|| Aabb::EMPTY, Aabb::union)
}

/// Spreads the low `BITS` bits of `x` two zeros apart.
fn spread(x: u32) -> u32 {
    let mut x = x.min((1 << BITS) - 1);
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    (x | x << 2) & 0x0924_9249
}

struct Emit<'a, F> {
    /// Morton code in the high half, primitive in the low half; sorted.
    keys: &'a [u64],
    box_of: &'a F,
    max_leaf: usize,
    /// Splits fall on multiples of this (when the node is large enough),
    /// so leaves fill whole packs: a primitive or two on the wrong side of
    /// a Morton split costs less than padding a third of the packs.
    align: usize,
    progress: &'a Reporter,
}

impl<F: Fn(usize) -> Aabb + Sync> Emit<'_, F> {
    /// The subtree over slots `first..first + n`, splitting at code bit
    /// `bit` or below; returns its bounds too.
    fn node(&self, first: usize, n: usize, bit: i32, depth: usize) -> (Aabb, BuildNode) {
        let keys = &self.keys[first..first + n];
        if n <= self.max_leaf {
            let bounds = keys.iter().fold(Aabb::EMPTY, |b, &k| {
                b.union((self.box_of)(k as u32 as usize))
            });
            let leaf = BuildNode::Leaf {
                first: first as u32,
                count: n as u32,
            };
            return (bounds, leaf);
        }
        let (mid, below) = split(keys, bit, depth);
        let a = self.align;
        let (mid, below) = match ((mid + a / 2) / a * a).clamp(a, (n - 1) / a * a) {
            // A rounded split leaves a code on the wrong side of `bit`:
            // the children look for their split from the top again.
            rounded if n >= 2 * a && rounded != mid => (rounded, TOP),
            _ => (mid, below),
        };
        let (left, right) = if n >= PARALLEL_THRESHOLD {
            let reported = |first: usize, n: usize| {
                let built = self.node(first, n, below, depth + 1);
                report_serial(self.progress, n);
                built
            };
            rayon::join(|| reported(first, mid), || reported(first + mid, n - mid))
        } else {
            (
                self.node(first, mid, below, depth + 1),
                self.node(first + mid, n - mid, below, depth + 1),
            )
        };
        let bounds = left.0.union(right.0);
        (
            bounds,
            BuildNode::Inner {
                children: Box::new([left, right]),
            },
        )
    }
}

/// Where sorted `keys` split: at the first key whose code has the highest
/// differing bit (at most `bit`) set, or in the middle when the codes are
/// all equal or the tree is about to reach `MAX_DEPTH`; and the bit to try
/// next.
fn split(keys: &[u64], mut bit: i32, depth: usize) -> (usize, i32) {
    let n = keys.len();
    let halving = depth + 1 + (usize::BITS - (n - 1).leading_zeros()) as usize >= MAX_DEPTH;
    let (lo, hi) = (keys[0], keys[n - 1]);
    while !halving && bit >= 0 {
        let mask = 1u64 << (32 + bit);
        if lo & mask != hi & mask {
            return (keys.partition_point(|k| k & mask == 0), bit - 1);
        }
        bit -= 1;
    }
    (n / 2, bit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_interleaves() {
        assert_eq!(spread(0b11), 0b1001);
        assert_eq!(spread(0b101), 0b100_0001, "bit k goes to bit 3k");
        assert_eq!(spread(u32::MAX), 0x0924_9249, "clamped to BITS bits");
    }

    #[test]
    fn splits_at_highest_differing_bit() {
        let key = |code: u64, prim: u64| code << 32 | prim;
        let keys = [
            key(0b0001, 4),
            key(0b0011, 0),
            key(0b0100, 3),
            key(0b0110, 1),
            key(0b0111, 2),
        ];
        assert_eq!(split(&keys, 3, 0), (2, 1));
        let same = [key(5, 0), key(5, 1), key(5, 2), key(5, 3)];
        assert_eq!(split(&same, 3, 0), (2, -1), "equal codes: halves");
        assert_eq!(split(&keys, 3, MAX_DEPTH), (2, 3), "depth guard: halves");
    }
}
