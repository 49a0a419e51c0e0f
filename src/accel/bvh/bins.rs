//! The SAH build's bins: how many a node gets, what maps a reference to
//! its bin on each axis, and the bins' bounds and counts.

use super::build::{Bounds, PrimRef};
use crate::simd::F4;
use glam::Vec4;

/// Per-axis bins of one node. `N` is a constant, so a small node does not
/// pay for clearing the bins of a large one (with 64 bins always, clearing
/// them took more time than binning).
#[derive(Clone)]
pub(super) struct Bins<const N: usize> {
    pub(super) bounds: [[Bounds; N]; 3],
    pub(super) count: [[u32; N]; 3],
}

/// What maps a (doubled) centroid to its bin on each axis.
#[derive(Clone, Copy)]
pub(super) struct Binner {
    /// Bins in use, at most the bins' capacity.
    pub(super) count: usize,
    min: Vec4,
    scale: Vec4,
    /// The last bin's number, as a float in every lane.
    last: F4,
}

impl Binner {
    pub(super) fn new(centroids: &Bounds, bins: usize) -> Self {
        let ext = centroids.max - centroids.min;
        let scale = |e: f32| {
            if e > 0.0 {
                bins as f32 * (1.0 - 1e-6) / e
            } else {
                0.0
            }
        };
        Self {
            count: bins,
            min: centroids.min,
            scale: Vec4::new(scale(ext.x), scale(ext.y), scale(ext.z), 0.0),
            last: F4::splat((bins - 1) as f32),
        }
    }

    /// The bin of `r` on each axis. Clamped as floats first (NaN to 0, as
    /// `maxps` gives its second operand), all lanes are truncated by one
    /// instruction, without the fix-ups a saturating `as` needs per lane:
    /// those conversions were a fifth of a large SAH build.
    #[inline]
    fn bins_of(&self, r: &PrimRef) -> [usize; 3] {
        let k = (r.centroid2() - self.min) * self.scale;
        let k = F4::load(&k.to_array()).max(F4::splat(0.0)).min(self.last);
        let [x, y, z, _] = k.truncate_in_range();
        [x as usize, y as usize, z as usize]
    }

    /// The bin of `r` on `axis`: always that of [`Binner::bins_of`].
    #[inline]
    pub(super) fn bin_on(&self, r: &PrimRef, axis: usize) -> usize {
        self.bins_of(r)[axis]
    }
}

impl<const N: usize> Bins<N> {
    pub(super) fn new() -> Self {
        Bins {
            bounds: [[Bounds::EMPTY; N]; 3],
            count: [[0; N]; 3],
        }
    }

    pub(super) fn fill(&mut self, refs: &[PrimRef], binner: &Binner) {
        for r in refs {
            for (axis, k) in binner.bins_of(r).into_iter().enumerate() {
                self.bounds[axis][k].grow(r);
                self.count[axis][k] += 1;
            }
        }
    }

    pub(super) fn merge(mut self, o: Self) -> Self {
        for axis in 0..3 {
            for k in 0..N {
                self.bounds[axis][k] = self.bounds[axis][k].union(o.bounds[axis][k]);
                self.count[axis][k] += o.count[axis][k];
            }
        }
        self
    }
}

/// Bins for a node of `n` primitives, at most `most`: 4 + n / 20, as
/// Embree's `BinMapping`. Most nodes are small, and a node's sweep costs
/// per bin what binning costs per primitive: this took 5.7% off a medium
/// build's instructions against 8 bins up to 64 primitives, with the same
/// instructions per sample (docs/performance.md, 2026-12-06).
pub(super) fn bins_for(n: usize, most: usize) -> usize {
    (4 + n / 20).min(most)
}
