//! `traversal --pixel X Y`: the boxes the traversal visited for the camera
//! ray through one pixel, recorded by the traversal code itself
//! ([`crate::bvh::VisitLog`]): green where they lead to the hit (the hit
//! leaf and its ancestors), red where they were tested in vain, as the
//! reports. Binary traversals show binary node boxes; `fast` shows the
//! 8-wide nodes (the union of their children) and the leaf boxes it tested.
//! A ray that hits nothing leaves only red boxes.

use std::collections::{BTreeSet, HashMap};

use glam::Vec3;

use super::{Context, Overlay};
use crate::backends::AccelConfig;
use crate::bvh::count::Visit;
use crate::bvh::wide::{WIDTH, WideNode};
use crate::bvh::{BvhTracer, VisitLog};
use crate::debug::lines::{Lines, color};
use crate::error::Result;
use crate::geometry::Aabb;

/// The visited boxes of one camera ray.
pub struct TraversalPath {
    /// The pixel whose centre the ray goes through.
    pub pixel: (u32, u32),
}

/// Box of lane `l` of a wide node.
fn lane_box(n: &WideNode, l: usize) -> Aabb {
    Aabb::new(Vec3::new(n.b[0][l], n.b[1][l], n.b[2][l]), Vec3::new(n.b[3][l], n.b[4][l], n.b[5][l]))
}

/// Box around every used lane of a wide node.
fn node_box(n: &WideNode) -> Aabb {
    (0..WIDTH).filter(|&l| n.child[l] != u32::MAX).fold(Aabb::EMPTY, |b, l| b.union(lane_box(n, l)))
}

/// Visited boxes: (box, leads to the hit).
fn visited_binary(bvh: &crate::bvh::BinaryBvh, log: &VisitLog) -> Vec<(Aabb, bool)> {
    let mut parent = vec![u32::MAX; bvh.nodes.len()];
    for (i, n) in bvh.nodes.iter().enumerate() {
        if !n.is_leaf() {
            parent[i + 1] = i as u32;
            parent[n.offset as usize] = i as u32;
        }
    }
    let mut path = BTreeSet::new();
    let mut at = log.hit_leaf();
    while let Some(i) = at.filter(|&i| i != u32::MAX) {
        path.insert(i);
        at = Some(parent[i as usize]);
    }
    let visited: BTreeSet<u32> =
        log.events.iter().filter_map(|e| if let Visit::Node(i) = e { Some(*i) } else { None }).collect();
    visited.into_iter().map(|i| (bvh.nodes[i as usize].bounds(), path.contains(&i))).collect()
}

fn visited_wide(nodes: &[WideNode], log: &VisitLog) -> Vec<(Aabb, bool)> {
    let mut parent = vec![u32::MAX; nodes.len()];
    let mut leaf_at = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        for l in 0..WIDTH {
            if n.child[l] == u32::MAX {
                continue;
            }
            if n.count[l] == 0 {
                parent[n.child[l] as usize] = i as u32;
            } else {
                leaf_at.insert(n.child[l], (i, l));
            }
        }
    }
    let hit = log.hit_leaf();
    let mut path = BTreeSet::new();
    let mut at = hit.and_then(|leaf| leaf_at.get(&leaf)).map(|&(i, _)| i as u32);
    while let Some(i) = at.filter(|&i| i != u32::MAX) {
        path.insert(i);
        at = Some(parent[i as usize]);
    }
    let mut out = Vec::new();
    let mut seen = BTreeSet::new();
    for e in &log.events {
        match *e {
            Visit::Node(i) if seen.insert((0, i)) => out.push((node_box(&nodes[i as usize]), path.contains(&i))),
            Visit::Leaf(leaf, _) if seen.insert((1, leaf)) => {
                if let Some(&(i, l)) = leaf_at.get(&leaf) {
                    out.push((lane_box(&nodes[i], l), Some(leaf) == hit));
                }
            }
            _ => {}
        }
    }
    out
}

impl Overlay for TraversalPath {
    fn name(&self) -> String {
        format!("traversal --pixel {} {}", self.pixel.0, self.pixel.1)
    }

    fn lines(&self, ctx: &Context) -> Result<Lines> {
        let ray = ctx.pixel_ray(self.pixel.0, self.pixel.1)?;
        let cfg = AccelConfig { backend: crate::backends::Backend::Native, ..ctx.accel };
        let bvh = BvhTracer::new(&ctx.scene.prims, &cfg);
        let mut log = VisitLog::default();
        let hit = bvh.intersect_with(&ray, &mut log);
        let boxes = match (bvh.binary(), bvh.wide()) {
            (Some(b), _) => visited_binary(b, &log),
            (None, Some(w)) => visited_wide(w.nodes(), &log),
            (None, None) => Vec::new(),
        };
        let mut lines = Lines::default();
        for green in [false, true] {
            for (b, _) in boxes.iter().filter(|(_, g)| *g == green) {
                lines.aabb(b, if green { color::GREEN } else { color::RED });
            }
        }
        if let Some(h) = hit {
            let p = ray.at(h.t);
            lines.segment(ray.origin, p, color::WHITE);
            lines.cross(p, ctx.world_size(p, 12.0), color::WHITE);
            if let Some(t) = ctx.scene.prims.triangles.get(h.prim as usize) {
                lines.triangle(t.v, color::YELLOW);
            }
        }
        Ok(lines)
    }
}
