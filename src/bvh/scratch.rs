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
/// there is one (grown if needed), a new one otherwise.
fn take<T>(key: &'static LocalKey<Cell<Vec<T>>>, n: usize) -> Vec<T> {
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
