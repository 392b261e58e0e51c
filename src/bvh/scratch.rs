//! Build scratch kept between builds on one thread.
//!
//! A build allocates its temporaries (the primitive references, the binary
//! node slots, the leaf order), then frees them; a freed block that leaves
//! more than the allocator's trim threshold free at the top of a thread's
//! heap is returned to the system, and the next build faults its pages back
//! in. Whether that happens depends on what else the thread allocated in
//! between (glibc: in a thread's own arena it did in a user's loop that
//! built Embree scenes between rtdiff builds, and not in `rtdiff bench
//! --race`), so a small mesh's build time depended on the caller's
//! allocation history. Each temporary is taken from and given back to a
//! buffer of its own per thread instead, kept when it holds at most
//! [`KEEP_BYTES`] (meshes of up to about 16,000 triangles), freed otherwise.
//! At most three such buffers live per thread that built a tree.
//!
//! Larger temporaries are not kept; they are asked for on huge pages
//! ([`super::huge`], as the tree's own arrays, which leaves arrays under
//! 4 MiB alone), whose fresh pages fault in 2 MiB at a time wherever the
//! allocator found the memory. Before, a large
//! build's time followed the process's history as well: dragon_full's
//! one-thread build took 119 ms in a fresh outside loop and 128 ms after
//! suzanne's and dragon_87k's builds in the same process (137.7 ms when every
//! block came fresh from the system, `MALLOC_MMAP_THRESHOLD_=131072`); with
//! huge pages 113 ms (122 ms fresh), and the race level (dragon_full
//! 1.99-2.05 -> 2.04, dragon_87k 2.14-2.22 -> 2.21-2.24 against robust
//! MEDIUM, two alternated pairs of `--race 3`).

use std::cell::Cell;
use std::mem::MaybeUninit;
use std::thread::LocalKey;

use super::Node;
use super::build::PrimRef;

/// Largest buffer kept for the next build, in bytes.
pub const KEEP_BYTES: usize = 1 << 20;

thread_local! {
    static REFS: Cell<Vec<PrimRef>> = const { Cell::new(Vec::new()) };
    static NODES: Cell<Vec<MaybeUninit<Node>>> = const { Cell::new(Vec::new()) };
    static ORDER: Cell<Vec<u32>> = const { Cell::new(Vec::new()) };
}

/// An empty vector with room for `n` elements: the thread's kept buffer when
/// there is one (grown if needed), a new one otherwise (on huge pages when
/// it is too large to keep).
fn take<T>(key: &'static LocalKey<Cell<Vec<T>>>, n: usize) -> Vec<T> {
    if n * std::mem::size_of::<T>() > KEEP_BYTES {
        return super::huge::vec_with_capacity(n);
    }
    let mut v = key.take();
    v.clear();
    v.reserve_exact(n);
    v
}

/// Keep `v`'s buffer for the thread's next build if it is at most
/// [`KEEP_BYTES`] (and larger than the one kept); free it otherwise.
fn give<T>(key: &'static LocalKey<Cell<Vec<T>>>, mut v: Vec<T>) {
    if v.capacity() * std::mem::size_of::<T>() <= KEEP_BYTES {
        v.clear();
        let old = key.take();
        key.set(if old.capacity() > v.capacity() { old } else { v });
    }
}

/// Room for `n` primitive references.
pub fn refs(n: usize) -> Vec<PrimRef> {
    take(&REFS, n)
}

/// Give back the references' buffer.
pub fn give_refs(v: Vec<PrimRef>) {
    give(&REFS, v);
}

/// Room for `n` binary node slots.
pub fn nodes(n: usize) -> Vec<MaybeUninit<Node>> {
    take(&NODES, n)
}

/// Give back a node slots' buffer.
pub fn give_nodes(v: Vec<MaybeUninit<Node>>) {
    give(&NODES, v);
}

/// Room for a leaf order of `n` primitive ids.
pub fn order(n: usize) -> Vec<u32> {
    take(&ORDER, n)
}

/// Give back a leaf order's buffer.
pub fn give_order(v: Vec<u32>) {
    give(&ORDER, v);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_come_back_empty_and_large_ones_are_not_kept() {
        let mut v = order(10);
        v.extend(0..10);
        let p = v.as_ptr();
        give_order(v);
        let w = order(5);
        assert!(w.is_empty() && w.capacity() >= 5);
        assert_eq!(w.as_ptr(), p, "the kept buffer is reused");
        give_order(w);
        let big = order(KEEP_BYTES / 4 + 1);
        give_order(big);
        // The small buffer stays kept; the large one was freed.
        assert!(ORDER.take().capacity() <= KEEP_BYTES / 4);
    }
}
