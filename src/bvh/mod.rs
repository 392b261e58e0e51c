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
pub mod node;
pub mod packet;
pub mod prims;
pub mod slab;
pub mod stats;
pub mod traverse_basic;
pub mod traverse_nth_element;
pub mod traverse_ordered;
pub mod traverse_priority_queue;
pub mod traverse_sorted_vector;
pub mod wide;

pub use build::BinaryBvh;
pub use count::{Count, TraversalCounts, VisitLog};
pub use node::Node;
pub use prims::LeafPrims;
pub use stats::BvhStats;
pub use wide::WideBvh;

pub use config::{Builder, BvhConfig, Traversal};

use crate::accel::Tracer;
use crate::geometry::{Hit, Primitives, Ray};

/// Build a binary BVH over `prims` with the builder and parameters of `cfg`
/// (`leaf_size` for `median`, `bins` for `sah`).
pub fn build_binary(prims: &Primitives, cfg: impl Into<BvhConfig>) -> BinaryBvh {
    let cfg = cfg.into();
    build::build_with(prims, splitter(&cfg).as_ref(), cfg.builder)
}

/// The split strategy of `cfg`'s builder.
fn splitter(cfg: &BvhConfig) -> Box<dyn build::Splitter> {
    match cfg.builder {
        Builder::Median => Box::new(build_median::MedianSplit { leaf_size: cfg.leaf_size }),
        Builder::SahVolume => Box::new(build_sah_volume::VolumeSplit),
        Builder::Sah => Box::new(build_sah::SahSplit { bins: cfg.bins }),
    }
}

/// Build the tree `cfg` asks for and collapse it into the 8-wide BVH of the
/// `fast` traversal, gathering the leaves' triangles straight into packets.
pub fn build_wide(prims: &Primitives, cfg: impl Into<BvhConfig>) -> WideBvh {
    WideBvh::from_tree(prims, &build::build_tree(prims, splitter(&cfg.into()).as_ref()))
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
    Wide(WideBvh),
}

/// A [`Tracer`] over rtdiff's BVH with a chosen builder and traversal.
pub struct BvhTracer {
    tree: Tree,
    cfg: BvhConfig,
}

impl BvhTracer {
    /// Build the BVH `cfg` asks for (the `fast` traversal also collapses it to 8-wide nodes).
    pub fn new(prims: &Primitives, cfg: impl Into<BvhConfig>) -> Self {
        let cfg = cfg.into();
        let tree = if cfg.traversal == Traversal::Fast {
            Tree::Wide(build_wide(prims, cfg))
        } else {
            Tree::Binary(build_binary(prims, cfg))
        };
        Self { tree, cfg }
    }

    /// Use the portable scalar box test in the `fast` traversal even when AVX2 is available.
    pub fn force_scalar(&mut self) {
        if let Tree::Wide(w) = &mut self.tree {
            w.set_scalar();
        }
    }
}

impl BvhTracer {
    /// The binary tree walked by the reports' traversals (None for `fast`).
    pub fn binary(&self) -> Option<&BinaryBvh> {
        match &self.tree {
            Tree::Binary(b) => Some(b),
            Tree::Wide(_) => None,
        }
    }

    /// The 8-wide tree walked by the `fast` traversal (None otherwise).
    pub fn wide(&self) -> Option<&WideBvh> {
        match &self.tree {
            Tree::Wide(w) => Some(w),
            Tree::Binary(_) => None,
        }
    }

    /// [`Tracer::intersect`] reporting the ray and the traversal's work to
    /// `counts` (the same traversal code; `()` counts nothing).
    #[inline]
    pub fn intersect_with<C: Count>(&self, ray: &Ray, counts: &mut C) -> Option<Hit> {
        counts.ray();
        if !ray.is_traceable() {
            return None;
        }
        let t = self.cfg.triangle_test;
        match &self.tree {
            Tree::Wide(w) => w.intersect_counting(ray, t, counts),
            Tree::Binary(b) => match self.cfg.traversal {
                Traversal::Basic | Traversal::Fast => traverse_basic::intersect_counting(b, ray, t, counts),
                Traversal::PriorityQueue => {
                    traverse_ordered::intersect_counting::<traverse_priority_queue::HeapFrontier, C>(b, ray, t, counts)
                }
                Traversal::SortedVector => {
                    traverse_ordered::intersect_counting::<traverse_sorted_vector::SortedFrontier, C>(b, ray, t, counts)
                }
                Traversal::NthElement => {
                    traverse_ordered::intersect_counting::<traverse_nth_element::NthFrontier, C>(b, ray, t, counts)
                }
            },
        }
    }

    /// [`Tracer::occluded`] reporting the ray and the traversal's work to `counts`.
    #[inline]
    pub fn occluded_with<C: Count>(&self, ray: &Ray, counts: &mut C) -> bool {
        counts.ray();
        if !ray.is_traceable() {
            return false;
        }
        let t = self.cfg.triangle_test;
        match &self.tree {
            Tree::Wide(w) => w.occluded_counting(ray, t, counts),
            Tree::Binary(b) => match self.cfg.traversal {
                Traversal::Basic | Traversal::Fast => traverse_basic::occluded_counting(b, ray, t, counts),
                Traversal::PriorityQueue => {
                    traverse_ordered::occluded_counting::<traverse_priority_queue::HeapFrontier, C>(b, ray, t, counts)
                }
                Traversal::SortedVector => {
                    traverse_ordered::occluded_counting::<traverse_sorted_vector::SortedFrontier, C>(b, ray, t, counts)
                }
                Traversal::NthElement => {
                    traverse_ordered::occluded_counting::<traverse_nth_element::NthFrontier, C>(b, ray, t, counts)
                }
            },
        }
    }
}

impl Tracer for BvhTracer {
    fn name(&self) -> String {
        self.cfg.label()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_with(ray, &mut ())
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, &mut ())
    }
}
