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
/// asked to back with huge pages (the whole 2 MiB-aligned part of it, whose
/// old pages, if the allocator reused memory, are dropped first).
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
        // The allocator may hand back memory that an earlier array used,
        // already backed by 4 KiB pages, which the advice does not change:
        // those pages are dropped, so that the first writes fault in huge
        // pages. In a race of suzanne, dragon_87k and dragon_full in one
        // process, dragon_full's incoherent rays ran at 2.47 Mrays/s without
        // this (Embree 2.67) and at 2.58 with it (Embree 2.64); alone, in a
        // fresh process, at 2.59 (stop 30, `rtdiff bench --race 3 --threads 1`).
        // SAFETY: as above; the vector is empty, so no element lives in the
        // range, whose contents read as zeros afterwards and are written
        // before they are read. The allocator's bookkeeping lies outside it
        // (before the vector's first byte; the range starts at or after it).
        unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_DONTNEED) };
    }
}

#[cfg(not(target_os = "linux"))]
fn advise<T>(_: &Vec<T>) {}
