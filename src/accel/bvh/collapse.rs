//! Collapse of the binary build tree into 4-wide nodes.

use super::build::BuildNode;
use super::node::Node4;
use super::PADDING;
use crate::math::{Aabb, Vec3};

/// Collapse of the binary tree into `Node4`s, assigning (padded) slots to
/// leaves in the order traversal meets them.
pub(super) struct Collapse<'a> {
    pub(super) nodes: Vec<Node4>,
    /// Primitive order of the binary build.
    pub(super) src: &'a [u32],
    pub(super) slots: Vec<u32>,
    pub(super) align: usize,
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
    pub(super) fn node(&mut self, node: &BuildNode, depth: usize) -> usize {
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
                // At most four: a fixed array, not a heap allocation per node.
                let mut kids: [&(Aabb, BuildNode); 4] = [&children[0]; 4];
                kids[1] = &children[1];
                let mut len = 2;
                // Open the largest inner child until there are four.
                while len < 4 {
                    let widest = kids[..len]
                        .iter()
                        .enumerate()
                        .filter(|(_, k)| matches!(k.1, BuildNode::Inner { .. }))
                        .max_by(|a, b| a.1 .0.half_area().total_cmp(&b.1 .0.half_area()))
                        .map(|(i, _)| i);
                    let Some(w) = widest else { break };
                    let BuildNode::Inner { children } = &kids[w].1 else {
                        unreachable!()
                    };
                    // As `Vec::swap_remove` then two pushes.
                    kids[w] = kids[len - 1];
                    kids[len - 1] = &children[0];
                    kids[len] = &children[1];
                    len += 1;
                }
                let kids = &mut kids[..len];
                // Leaves first: their slots then sit next to each other.
                kids.sort_by_key(|k| matches!(k.1, BuildNode::Inner { .. }));
                for (k, (b, kid)) in kids.iter().copied().enumerate() {
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
