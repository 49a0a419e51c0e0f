//! Traversal: the closest-hit and any-hit queries, leaf by leaf or
//! primitive by primitive, with a prepared ray and a fixed stack.

use super::node::Node4;
use super::{Bvh, MAX_DEPTH};
use crate::accel::traceable;
use crate::math::{gamma, Ray, Vec3};
use crate::simd::F4;

/// Stack of a traversal: each 4-wide level pushes at most three entries.
const STACK_SIZE: usize = 3 * MAX_DEPTH + 4;

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
pub(crate) const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

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
