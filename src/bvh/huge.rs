//! Large arrays on 2 MiB pages where the system offers them.
//!
//! A tree of a million triangles spans tens of megabytes; rays that wander
//! through it touch a new 4 KiB page at almost every node and leaf, and the
//! page-table walks of those TLB misses cost as much as the cache misses.
//! Linux backs an anonymous mapping with transparent huge pages when asked
//! (`madvise(MADV_HUGEPAGE)`; the default policy on many systems only honours
//! the request), provided the advice comes before the pages are first
//! written. Embree's allocator asks the same. Elsewhere this is a plain
//! `Vec::with_capacity`.

/// Arrays smaller than this are left alone (one huge page would hold them).
const MIN_BYTES: usize = 4 << 20;

/// An empty vector with room for `n` elements whose memory the kernel is
/// asked to back with huge pages (the whole 2 MiB-aligned part of it).
pub fn vec_with_capacity<T>(n: usize) -> Vec<T> {
    let v: Vec<T> = Vec::with_capacity(n);
    advise(&v);
    v
}

#[cfg(target_os = "linux")]
fn advise<T>(v: &Vec<T>) {
    const HUGE: usize = 2 << 20;
    let bytes = v.capacity() * std::mem::size_of::<T>();
    if bytes < MIN_BYTES {
        return;
    }
    let start = (v.as_ptr() as usize).next_multiple_of(HUGE);
    let end = (v.as_ptr() as usize + bytes) / HUGE * HUGE;
    if end > start {
        // SAFETY: the range lies inside the vector's own allocation; the
        // advice changes only how the kernel backs those pages, never their
        // contents, and a refusal (an error return) is harmless.
        unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
    }
}

#[cfg(not(target_os = "linux"))]
fn advise<T>(_: &Vec<T>) {}
