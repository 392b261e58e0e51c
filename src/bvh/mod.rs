//! rtdiff's own bounding volume hierarchy.
//!
//! Builders ([`build_median`], [`build_sah_volume`], [`build_sah`]) share one
//! framework ([`build`]) and produce a flattened binary BVH ([`BinaryBvh`]:
//! 32-byte [`Node`]s and a reordered primitive array [`LeafPrims`]).
//! Traversals are separate: the reports' [`traverse_basic`],
//! [`traverse_priority_queue`], [`traverse_sorted_vector`] and
//! [`traverse_nth_element`] walk the binary nodes; the production `fast`
//! traversal collapses them into 8-wide SIMD nodes ([`wide`]).
//!
//! Every traversal returns exactly the brute-force closest hit: the same
//! primitive tests on the same data, boxes culled conservatively, and the
//! same tie rule (lowest primitive id among hits at equal distance).

pub mod build;
pub mod build_median;
pub mod build_sah;
pub mod build_sah_volume;
pub mod collapse;
pub mod config;
pub mod count;
pub mod huge;
pub mod node;
pub mod packet;
pub mod prims;
pub mod scratch;
pub mod slab;
pub mod stats;
pub mod traverse_basic;
pub mod traverse_nth_element;
pub mod traverse_ordered;
pub mod traverse_priority_queue;
pub mod traverse_sorted_vector;
pub mod wide;
pub mod wide_packet;

pub use build::BinaryBvh;
pub use count::{Count, TraversalCounts, VisitLog};
pub use node::Node;
pub use prims::LeafPrims;
pub use stats::BvhStats;
pub use wide::{WalkIsa, WideBvh};

pub use config::{BinaryOrder, Builder, BvhConfig, NodeLayout, Traversal};

use crate::accel::Tracer;
use crate::geometry::{Hit, Primitives, Ray, TriangleKernel};

/// Build a binary BVH over `prims` with the builder and parameters of `cfg`
/// (`leaf_size` for `median`, `bins` for `sah`).
pub fn build_binary(prims: &Primitives, cfg: impl Into<BvhConfig>) -> BinaryBvh {
    let cfg = cfg.into();
    build::build_with(prims, splitter(&cfg, prims.len()).as_ref(), cfg.builder)
}

/// The split strategy of `cfg`'s builder for a tree over `prims` primitives.
fn splitter(cfg: &BvhConfig, prims: usize) -> Box<dyn build::Splitter> {
    match cfg.builder {
        Builder::Median => Box::new(build_median::MedianSplit { leaf_size: cfg.leaf_size }),
        Builder::SahVolume => Box::new(build_sah_volume::VolumeSplit),
        Builder::Sah => Box::new(build_sah::SahSplit { bins: cfg.bins, block: packet::leaf_block(prims) }),
    }
}

/// Build the tree `cfg` asks for and collapse it into the 8-wide BVH of the
/// `fast` traversal, gathering the leaves' triangles straight into packets.
pub fn build_wide(prims: &Primitives, cfg: impl Into<BvhConfig>) -> WideBvh {
    let table = collapse::CostTable { block: packet::leaf_block(prims.len()) };
    let tree = build::build_gapped(prims, splitter(&cfg.into(), prims.len()).as_ref(), &table);
    let wide = WideBvh::from_tree(prims, &tree);
    tree.recycle();
    wide
}

/// Build the binary BVH `cfg` asks for and its 8-wide collapse, and gather
/// their statistics (`build_ms` covers the binary build plus the collapse).
pub fn stats_for(prims: &Primitives, cfg: impl Into<BvhConfig>) -> BvhStats {
    let bin = build_binary(prims, cfg);
    let mut stats = BvhStats::of(&bin, None);
    let start = std::time::Instant::now();
    let wide = WideBvh::from_binary(bin);
    stats.build_ms += start.elapsed().as_secs_f64() * 1e3;
    stats.wide_nodes = wide.nodes.len();
    stats.wide_bytes = wide.bytes();
    stats
}

/// The tree a [`BvhTracer`] walks.
enum Tree {
    Binary(BinaryBvh),
    /// The 8-wide tree and the entry points chosen for it.
    Wide(WideBvh, wide::Kernels),
}

/// A [`Tracer`] over rtdiff's BVH with a chosen builder, node layout and triangle test.
pub struct BvhTracer {
    tree: Tree,
    cfg: BvhConfig,
}

impl BvhTracer {
    /// Build the BVH `cfg` asks for (the 8-wide layout collapses the binary tree).
    pub fn new(prims: &Primitives, cfg: impl Into<BvhConfig>) -> Self {
        let cfg = cfg.into();
        let tree = match cfg.layout {
            NodeLayout::Wide8 => {
                let w = build_wide(prims, cfg);
                let k = w.kernels(cfg.triangle_test);
                Tree::Wide(w, k)
            }
            NodeLayout::Binary(_) => Tree::Binary(build_binary(prims, cfg)),
        };
        Self { tree, cfg }
    }

    /// Run the 8-wide traversal's walks compiled for `isa` (tests and
    /// measurements; the widest set the CPU runs is the default). Returns
    /// false, changing nothing, when the CPU does not run `isa` or the tree
    /// is not 8-wide.
    pub fn force_isa(&mut self, isa: WalkIsa) -> bool {
        if let Tree::Wide(w, k) = &mut self.tree
            && w.set_isa(isa)
        {
            *k = w.kernels(self.cfg.triangle_test);
            return true;
        }
        false
    }

    /// The binary tree walked by the reports' traversals (None for the 8-wide layout).
    pub fn binary(&self) -> Option<&BinaryBvh> {
        match &self.tree {
            Tree::Binary(b) => Some(b),
            Tree::Wide(..) => None,
        }
    }

    /// The 8-wide tree (None for the binary layouts).
    pub fn wide(&self) -> Option<&WideBvh> {
        match &self.tree {
            Tree::Wide(w, _) => Some(w),
            Tree::Binary(_) => None,
        }
    }

    /// [`Tracer::intersect`] reporting the ray and the traversal's work to
    /// `counts` (the same traversal code; `()` counts nothing).
    pub fn intersect_with<C: Count>(&self, ray: &Ray, counts: &mut C) -> Option<Hit> {
        counts.ray();
        if !ray.is_traceable() {
            return None;
        }
        match &self.tree {
            Tree::Wide(w, _) => w.intersect_counting(ray, self.cfg.triangle_test, counts),
            Tree::Binary(b) => {
                crate::with_triangle_kernel!(self.cfg.triangle_test, K => binary_closest::<K, C>(b, self.order(), ray, counts))
            }
        }
    }

    /// [`Tracer::occluded`] reporting the ray and the traversal's work to `counts`.
    pub fn occluded_with<C: Count>(&self, ray: &Ray, counts: &mut C) -> bool {
        counts.ray();
        if !ray.is_traceable() {
            return false;
        }
        match &self.tree {
            Tree::Wide(w, _) => w.occluded_counting(ray, self.cfg.triangle_test, counts),
            Tree::Binary(b) => {
                crate::with_triangle_kernel!(self.cfg.triangle_test, K => binary_any::<K, C>(b, self.order(), ray, counts))
            }
        }
    }

    /// The walk order of a binary layout.
    fn order(&self) -> BinaryOrder {
        match self.cfg.layout {
            NodeLayout::Binary(o) => o,
            NodeLayout::Wide8 => BinaryOrder::DepthFirst,
        }
    }
}

/// Closest hit in a binary tree walked in `order`, triangle test `K`.
fn binary_closest<K: TriangleKernel, C: Count>(b: &BinaryBvh, order: BinaryOrder, ray: &Ray, c: &mut C) -> Option<Hit> {
    use traverse_ordered::intersect_counting as ordered;
    match order {
        BinaryOrder::DepthFirst => traverse_basic::intersect_counting::<K, C>(b, ray, c),
        BinaryOrder::PriorityQueue => ordered::<traverse_priority_queue::HeapFrontier, K, C>(b, ray, c),
        BinaryOrder::SortedVector => ordered::<traverse_sorted_vector::SortedFrontier, K, C>(b, ray, c),
        BinaryOrder::NthElement => ordered::<traverse_nth_element::NthFrontier, K, C>(b, ray, c),
    }
}

/// Any hit in a binary tree walked in `order`, triangle test `K`.
fn binary_any<K: TriangleKernel, C: Count>(b: &BinaryBvh, order: BinaryOrder, ray: &Ray, c: &mut C) -> bool {
    use traverse_ordered::occluded_counting as ordered;
    match order {
        BinaryOrder::DepthFirst => traverse_basic::occluded_counting::<K, C>(b, ray, c),
        BinaryOrder::PriorityQueue => ordered::<traverse_priority_queue::HeapFrontier, K, C>(b, ray, c),
        BinaryOrder::SortedVector => ordered::<traverse_sorted_vector::SortedFrontier, K, C>(b, ray, c),
        BinaryOrder::NthElement => ordered::<traverse_nth_element::NthFrontier, K, C>(b, ray, c),
    }
}

impl Tracer for BvhTracer {
    fn name(&self) -> String {
        self.cfg.label()
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match &self.tree {
            // (`Kernels` answers none for a ray that is not traceable.)
            Tree::Wide(w, k) => k.closest(w, ray),
            Tree::Binary(_) => self.intersect_with(ray, &mut ()),
        }
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        match &self.tree {
            Tree::Wide(w, k) => k.any(w, ray),
            Tree::Binary(_) => self.occluded_with(ray, &mut ()),
        }
    }

    /// Packets of eight rays through the 8-wide tree ([`wide_packet`]); ray by ray on binary layouts.
    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        match &self.tree {
            Tree::Wide(w, k) => k.closest_batch(w, rays, out),
            Tree::Binary(_) => {
                assert_eq!(rays.len(), out.len(), "intersect_batch: one answer per ray");
                for (r, o) in rays.iter().zip(out) {
                    *o = self.intersect_with(r, &mut ());
                }
            }
        }
    }

    /// Packets of eight rays through the 8-wide tree; ray by ray on binary layouts.
    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        match &self.tree {
            Tree::Wide(w, k) => k.any_batch(w, rays, out),
            Tree::Binary(_) => {
                assert_eq!(rays.len(), out.len(), "occluded_batch: one answer per ray");
                for (r, o) in rays.iter().zip(out) {
                    *o = self.occluded_with(r, &mut ());
                }
            }
        }
    }
}
