//! Large buffers on transparent huge pages, where the kernel offers them.
//!
//! A fresh buffer of hundreds of megabytes that is written once (a mesh's
//! indices, the BVH's keys and triangle packs) costs the kernel one page
//! fault per 4 KiB page it touches: at 17.8M triangles the faults took a
//! quarter of loading and building. Linux's default transparent huge page
//! mode (`madvise`) backs memory with 2 MiB pages only where the program
//! asks for them, which cuts the faults 512-fold; the kernel still clears
//! each page.

/// A huge page, and the smallest buffer worth advising.
const HUGE_PAGE: usize = 2 << 20;
const ADVISE_FROM: usize = 4 * HUGE_PAGE;

/// `Vec::with_capacity(capacity)`, whose memory the kernel is asked to back
/// with huge pages when it is large. Reserve only what will be written: a
/// huge page is allocated whole at its first touch.
pub(crate) fn vec_with_capacity<T>(capacity: usize) -> Vec<T> {
    let v = Vec::with_capacity(capacity);
    advise_huge_pages(v.as_ptr() as usize, capacity.saturating_mul(size_of::<T>()));
    v
}

#[cfg(target_os = "linux")]
fn advise_huge_pages(start: usize, len: usize) {
    if len < ADVISE_FROM {
        return;
    }
    let begin = start.next_multiple_of(HUGE_PAGE);
    let end = (start + len) / HUGE_PAGE * HUGE_PAGE;
    if end > begin {
        // SAFETY: [begin, end) lies inside the allocation just made, and the
        // advice changes only the size of the pages behind it, never their
        // contents. A kernel without transparent huge pages refuses it,
        // which leaves ordinary pages: the result is ignored on purpose.
        unsafe {
            libc::madvise(begin as *mut libc::c_void, end - begin, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: usize, _len: usize) {}

/// Hands the pages of freed heap memory back to the kernel. Millions of
/// small blocks freed at once (a build tree's nodes) stay resident in the
/// allocator's arenas, where the next large buffer, mapped afresh, cannot
/// reuse them: without this they add to the peak.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub(crate) fn release_freed_memory() {
    // SAFETY: malloc_trim only returns free pages to the kernel; no live
    // allocation is touched.
    unsafe {
        libc::malloc_trim(0);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub(crate) fn release_freed_memory() {}

#[cfg(test)]
mod tests {
    use super::*;

    /// The advice may or may not be taken; either way the buffer is an
    /// ordinary vector of the capacity asked for, small or large.
    #[test]
    fn buffers_are_ordinary_vectors() {
        for n in [0, 1, 1000, 3 * HUGE_PAGE + 12345] {
            let mut v: Vec<u32> = vec_with_capacity(n);
            assert!(v.capacity() >= n);
            v.extend((0..n as u32).map(|i| i ^ 0x5a5a));
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32 ^ 0x5a5a));
        }
    }
}
