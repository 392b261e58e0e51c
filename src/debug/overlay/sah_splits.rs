//! `sah-splits --node N`: the split candidates the builder weighed for
//! binary node N (depth-first index, 0 the root), as planes across the
//! node's box: red, and green for the one the tree actually took, as the
//! reports' SAH debug. The candidates are each builder's own: `sah` the bin
//! boundaries of the centroid box on all three axes (`bins` bins), `sah-volume`
//! the reports' 5 bins of the node box's largest axis (vertex means), and
//! `median` its one median cut on axis `level % 3`. The green plane is the
//! candidate whose centroid partition best reproduces the node's real left
//! child (found from the built tree, not assumed).

use glam::Vec3;

use super::{Context, Overlay, node_levels};
use crate::backends::Builder;
use crate::bvh::BinaryBvh;
use crate::bvh::build_sah::SAH_MAX_BINS;
use crate::bvh::build_sah_volume::VOLUME_BINS;
use crate::debug::lines::{Lines, color};
use crate::error::{Error, Result};
use crate::geometry::Aabb;

/// The split candidates of one node.
pub struct SahSplits {
    /// Node index (depth-first order).
    pub node: u32,
}

/// First and one-past-last leaf-order position of node `i`'s primitives.
fn prim_range(bvh: &BinaryBvh, i: usize) -> (usize, usize) {
    let mut first = i;
    while !bvh.nodes[first].is_leaf() {
        first += 1;
    }
    let mut last = i;
    while !bvh.nodes[last].is_leaf() {
        last = bvh.nodes[last].offset as usize;
    }
    let (f, l) = (&bvh.nodes[first], &bvh.nodes[last]);
    (f.offset as usize, (l.offset + l.count) as usize)
}

/// A candidate plane: axis and position.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Plane {
    axis: usize,
    at: f32,
}

/// The rectangle where `plane` cuts box `b`.
fn plane_quad(b: &Aabb, p: Plane) -> [Vec3; 4] {
    let (u, v) = ((p.axis + 1) % 3, (p.axis + 2) % 3);
    let corner = |cu: f32, cv: f32| {
        let mut q = Vec3::ZERO;
        q[p.axis] = p.at;
        q[u] = cu;
        q[v] = cv;
        q
    };
    [corner(b.min[u], b.min[v]), corner(b.max[u], b.min[v]), corner(b.max[u], b.max[v]), corner(b.min[u], b.max[v])]
}

impl Overlay for SahSplits {
    fn name(&self) -> String {
        format!("sah-splits --node {}", self.node)
    }

    fn lines(&self, ctx: &Context) -> Result<Lines> {
        let bvh = ctx.binary_bvh();
        let i = self.node as usize;
        let node = *bvh.nodes.get(i).ok_or_else(|| {
            Error::Invalid(format!("sah-splits: node {i} does not exist (the BVH has {} nodes)", bvh.nodes.len()))
        })?;
        if node.is_leaf() {
            return Err(Error::Invalid(format!(
                "sah-splits: node {i} is a leaf of {} primitives: the builder did not split it",
                node.count
            )));
        }
        let prims = &ctx.scene.prims;
        let builder = ctx.accel.builder;
        // Each builder's centroid: the box centre, or the reports' vertex mean (the builder's own input).
        let input = crate::bvh::build::BuildInput::new(prims, builder == Builder::SahVolume);
        let centroid = |id: u32| -> Vec3 {
            match input.vertex_means.get(id as usize) {
                Some(&mean) => mean.into(),
                None => prims.bounds(id as usize).center(),
            }
        };
        let (first, end) = prim_range(&bvh, i);
        let (_, left_end) = prim_range(&bvh, i + 1);
        let cents: Vec<(Vec3, bool)> =
            (first..end).map(|k| (centroid(bvh.prims.entries[k].id), k < left_end)).collect();
        let cb = cents.iter().fold(Aabb::EMPTY, |b, &(c, _)| b.grow(c));
        let bounds = node.bounds();
        let mut planes = Vec::new();
        match builder {
            Builder::Sah => {
                let nb = ctx.accel.bins.clamp(2, SAH_MAX_BINS).min(cents.len().max(4));
                for axis in 0..3 {
                    let ext = cb.max[axis] - cb.min[axis];
                    if ext > 0.0 {
                        planes.extend((1..nb).map(|k| Plane { axis, at: cb.min[axis] + ext * k as f32 / nb as f32 }));
                    }
                }
            }
            Builder::SahVolume => {
                let axis = bounds.largest_axis();
                let len = bounds.extent()[axis];
                planes.extend(
                    (1..VOLUME_BINS)
                        .map(|k| Plane { axis, at: bounds.min[axis] + len * k as f32 / VOLUME_BINS as f32 }),
                );
            }
            Builder::Median => {
                let axis = (node_levels(&bvh)[i] % 3) as usize;
                let left_max = cents.iter().filter(|c| c.1).map(|c| c.0[axis]).fold(f32::NEG_INFINITY, f32::max);
                let right_min = cents.iter().filter(|c| !c.1).map(|c| c.0[axis]).fold(f32::INFINITY, f32::min);
                planes.push(Plane { axis, at: 0.5 * (left_max + right_min) });
            }
        }
        // The chosen plane: fewest primitives on the wrong side of it.
        let wrong = |p: &Plane| cents.iter().filter(|&&(c, left)| (c[p.axis] < p.at) != left).count();
        let chosen = (0..planes.len()).min_by_key(|&k| (wrong(&planes[k]), k));
        let mut lines = Lines::default();
        lines.aabb(&bounds, color::WHITE);
        for (k, p) in planes.iter().enumerate() {
            if Some(k) != chosen {
                lines.polygon(&plane_quad(&bounds, *p), color::RED);
            }
        }
        if let Some(k) = chosen {
            lines.polygon(&plane_quad(&bounds, planes[k]), color::GREEN);
            let q = plane_quad(&bounds, planes[k]);
            lines.segment(q[0], q[2], color::GREEN);
            lines.segment(q[1], q[3], color::GREEN);
        }
        Ok(lines)
    }
}
