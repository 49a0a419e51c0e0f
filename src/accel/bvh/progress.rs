//! What a build tells the step in progress: each primitive once, in
//! subtrees where the build turns serial (a subtree under
//! [`PARALLEL_THRESHOLD`] whose parent was built in parallel), so a report
//! costs nothing next to the thousands of primitives it counts and two
//! threads never wait on each other to count.

use super::PARALLEL_THRESHOLD;
use crate::meter::Reporter;

/// A subtree of `n` primitives is done, either a child of a parent built
/// in parallel or the whole tree: counted here when it was built serially.
#[inline]
pub(super) fn report_serial(progress: &Reporter, n: usize) {
    if n < PARALLEL_THRESHOLD {
        progress.advance(n);
    }
}

/// A leaf of `n` primitives is done: counted here when it is large enough
/// that it was not inside a serial subtree.
#[inline]
pub(super) fn report_parallel_leaf(progress: &Reporter, n: usize) {
    if n >= PARALLEL_THRESHOLD {
        progress.advance(n);
    }
}
