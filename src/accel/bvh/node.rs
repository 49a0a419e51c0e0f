//! The 4-wide node the binary build tree collapses into.

use crate::math::Aabb;

/// A 4-wide node: the four children's boxes (structure of arrays:
/// `bounds[2 * axis]` holds the minima along `axis`, `bounds[2 * axis + 1]`
/// the maxima) and what each child is. 128 bytes, two cache lines.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub(super) struct Node4 {
    pub(super) bounds: [[f32; 4]; 6],
    /// Inner child: its node index. Leaf: its first slot.
    pub(super) child: [u32; 4],
    /// Leaf: its number of slots. 0: an inner node, or an unused child
    /// (whose empty box no finite ray ever hits).
    pub(super) count: [u32; 4],
}

impl Node4 {
    pub(super) const EMPTY: Node4 = Node4 {
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

    pub(super) fn set_box(&mut self, k: usize, b: &Aabb) {
        for axis in 0..3 {
            self.bounds[2 * axis][k] = b.min[axis];
            self.bounds[2 * axis + 1][k] = b.max[axis];
        }
    }
}
