//! Collapsing a binary BVH into 8-wide nodes by dynamic programming on the
//! surface-area cost (after Ylitie, Karras and Laine, "Efficient incoherent
//! ray traversal on GPUs through compressed wide BVHs", HPG 2017).
//!
//! Each binary subtree `n` can appear in a wide node as one lane (a wide child
//! node, or a leaf when it holds at most [`MAX_LEAF`] primitives, which the
//! binary build placed contiguously) or be opened into several lanes spread
//! over its children. `cost[n][i]` is the cheapest way to represent `n` in at
//! most `i` lanes, under the surface-area model: a wide node visit costs
//! [`NODE_COST`] times its area, a leaf [`PACKET_COST`] times its area per
//! packet of four triangles. The table is filled bottom-up and the wide tree is
//! read off top-down.
//!
//! Compared with a greedy collapse (open the child of largest area until eight
//! lanes are full), this fills nodes better near the bottom, where greedy
//! collapsing leaves many two-lane nodes, and merges small sibling leaves into
//! one leaf where a node visit costs more than the extra packet.

use super::Node;
use super::packet::packets_for;
use super::wide::{WIDTH, WideNode};

/// Cost of visiting one wide node per unit of (half) surface area.
pub const NODE_COST: f32 = 1.0;
/// Cost of testing one leaf packet (four triangles), relative to [`NODE_COST`].
///
/// Measured with `rtdiff bench --race` on dragon_87k (ratios to Embree in
/// the same rounds, two runs each): 0.67, 1.0, 1.5 and 2.0 all gave primary
/// 1.00-1.14, incoherent 1.06-1.11 and shadow 1.19-1.24; 1.0 was the most
/// consistent (primary 1.131 and 1.136, incoherent 1.099 and 1.106). Lower
/// values merge more sibling leaves (fewer node visits, more packet tests).
pub const PACKET_COST: f32 = 1.0;
/// Largest leaf the collapse may form by merging a subtree (two packets).
pub const MAX_LEAF: u32 = 8;

/// Lanes a subtree may use, `1..=WIDTH`; index 0 is unused.
type Row = [f32; WIDTH + 1];

/// The dynamic-programming tables of one binary tree.
struct Plan<'a> {
    bin: &'a [Node],
    /// `cost[n][i]`: cheapest representation of subtree `n` in at most `i` lanes.
    cost: Vec<Row>,
    /// `split[n][i]`: lanes given to the left child in the cheapest way to
    /// open `n` into its children's representations with at most `i` lanes.
    split: Vec<[u8; WIDTH + 1]>,
    /// `as_leaf[n]`: a one-lane `n` is a leaf (else a wide node).
    as_leaf: Vec<bool>,
    /// First primitive and primitive count of each subtree.
    range: Vec<(u32, u32)>,
}

/// Half surface area of a binary node's box.
#[inline]
fn half_area(n: &Node) -> f32 {
    n.bounds().surface_area() * 0.5
}

impl<'a> Plan<'a> {
    fn new(bin: &'a [Node]) -> Self {
        let len = bin.len();
        let mut plan = Plan {
            bin,
            cost: vec![[0.0; WIDTH + 1]; len],
            split: vec![[0; WIDTH + 1]; len],
            as_leaf: vec![false; len],
            range: vec![(0, 0); len],
        };
        // Depth-first order puts every child after its parent: a reverse sweep
        // visits children first.
        for n in (0..len).rev() {
            plan.fill(n);
        }
        plan
    }

    fn fill(&mut self, n: usize) {
        let node = &self.bin[n];
        let area = half_area(node);
        if node.is_leaf() {
            self.range[n] = (node.offset, node.count);
            self.as_leaf[n] = true;
            let c = PACKET_COST * packets_for(node.count) as f32 * area;
            self.cost[n] = [c; WIDTH + 1];
            return;
        }
        let (l, r) = (n + 1, node.offset as usize);
        self.range[n] = (self.range[l].0, self.range[l].1 + self.range[r].1);
        // dist[i]: both children in at most i lanes (each needs at least one).
        let (cl, cr) = (self.cost[l], self.cost[r]);
        let mut dist = [f32::INFINITY; WIDTH + 1];
        let mut split = [0u8; WIDTH + 1];
        for i in 2..=WIDTH {
            for j in 1..i {
                let c = cl[j] + cr[i - j];
                // `split[i] == 0`: take the first candidate even when every cost
                // is infinite or NaN (box areas that overflow f32), so that
                // `emit` always splits into 1..i lanes; a 0 here made it ask
                // for lane count 0 and index `cost[n][0 - 1]`.
                if c < dist[i] || split[i] == 0 {
                    dist[i] = c;
                    split[i] = j as u8;
                }
            }
        }
        let as_node = NODE_COST * area + dist[WIDTH];
        let count = self.range[n].1;
        let as_leaf = if count <= MAX_LEAF { PACKET_COST * packets_for(count) as f32 * area } else { f32::INFINITY };
        self.as_leaf[n] = as_leaf <= as_node;
        let mut row = [0.0; WIDTH + 1];
        row[1] = as_leaf.min(as_node);
        for i in 2..=WIDTH {
            // Opening n only pays when its children together are cheaper;
            // otherwise the row keeps the cost of fewer lanes (see `emit`).
            row[i] = dist[i].min(row[i - 1]);
        }
        self.cost[n] = row;
        self.split[n] = split;
    }

    /// Append the lanes representing subtree `n` in at most `i` lanes.
    fn emit(&self, n: usize, i: usize, lanes: &mut Vec<Lane>, out: &mut Vec<WideNode>) {
        let node = &self.bin[n];
        if i == 1 || node.is_leaf() {
            if self.as_leaf[n] {
                let (first, count) = self.range[n];
                lanes.push(Lane { node: n, child: first, count });
            } else {
                let c = self.build_node(n, out);
                lanes.push(Lane { node: n, child: c, count: 0 });
            }
            return;
        }
        if self.cost[n][i] == self.cost[n][i - 1] {
            // Opening n into i lanes is no cheaper than using fewer.
            self.emit(n, i - 1, lanes, out);
        } else {
            let j = self.split[n][i] as usize;
            self.emit(n + 1, j, lanes, out);
            self.emit(node.offset as usize, i - j, lanes, out);
        }
    }

    /// Make binary node `n` (interior) a wide node; returns its index.
    fn build_node(&self, n: usize, out: &mut Vec<WideNode>) -> u32 {
        let me = out.len();
        out.push(WideNode::EMPTY);
        let mut lanes = Vec::with_capacity(WIDTH);
        let node = &self.bin[n];
        if node.is_leaf() {
            lanes.push(Lane { node: n, child: node.offset, count: node.count });
        } else {
            let j = self.split[n][WIDTH] as usize;
            self.emit(n + 1, j, &mut lanes, out);
            self.emit(node.offset as usize, WIDTH - j, &mut lanes, out);
        }
        let mut w = WideNode::EMPTY;
        for (k, lane) in lanes.iter().enumerate() {
            w.set_lane(k, &self.bin[lane.node], lane.child, lane.count);
        }
        out[me] = w;
        me as u32
    }
}

/// One lane of a wide node under construction: the binary node it stands
/// for (its box), and the child index or first primitive and count.
struct Lane {
    node: usize,
    child: u32,
    count: u32,
}

/// Collapse binary `bin` (depth-first, as the builders make it) into wide
/// nodes; node 0 is the root. Empty for an empty tree.
pub fn collapse(bin: &[Node]) -> Vec<WideNode> {
    let mut out = super::huge::vec_with_capacity(bin.len() / 4 + 1);
    if !bin.is_empty() {
        Plan::new(bin).build_node(0, &mut out);
    }
    out
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::backends::{AccelConfig, Builder};
    use crate::geometry::{Aabb, Primitives, Triangle};
    use crate::rng::Pcg32;

    /// Small random triangles scattered in a unit cube.
    fn scattered(n: usize, seed: u64) -> Primitives {
        let mut rng = Pcg32::new(seed, 0);
        let mut p = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let triangles = (0..n)
            .map(|_| {
                let c = p();
                Triangle { v: [c, c + 0.02 * p(), c + 0.02 * p()] }
            })
            .collect();
        Primitives { triangles, spheres: Vec::new() }
    }

    /// Walk the wide tree: every primitive slot is in exactly one leaf lane,
    /// every lane's box contains what it holds, and leaves stay small.
    fn check(wide: &[WideNode], bin: &[Node], n_prims: usize) {
        let mut seen = vec![0u32; n_prims];
        let mut stack = vec![(0usize, None::<Aabb>)];
        while let Some((i, parent)) = stack.pop() {
            let node = &wide[i];
            assert!(node.used() >= 1);
            for l in 0..WIDTH {
                if node.child[l] == u32::MAX {
                    continue;
                }
                let b = Aabb::new(
                    Vec3::new(node.b[0][l], node.b[1][l], node.b[2][l]),
                    Vec3::new(node.b[3][l], node.b[4][l], node.b[5][l]),
                );
                if let Some(p) = parent {
                    assert!(p.union(b) == p, "lane box outside its parent's");
                }
                if node.count[l] > 0 {
                    assert!(node.count[l] <= MAX_LEAF);
                    for k in node.child[l]..node.child[l] + node.count[l] {
                        seen[k as usize] += 1;
                    }
                } else {
                    stack.push((node.child[l] as usize, Some(b)));
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "a primitive slot is missing or repeated");
        let interior = bin.iter().filter(|n| !n.is_leaf()).count();
        assert!(wide.len() <= interior.max(1), "{} wide nodes for {interior} binary interior nodes", wide.len());
    }

    #[test]
    fn collapse_covers_every_primitive_once_inside_its_boxes() {
        for (n, builder) in [(1, Builder::Sah), (7, Builder::Sah), (5000, Builder::Sah), (3000, Builder::Median)] {
            let prims = scattered(n, n as u64);
            let cfg = AccelConfig { builder, ..Default::default() };
            let bin = crate::bvh::build_binary(&prims, &cfg);
            let wide = collapse(&bin.nodes);
            check(&wide, &bin.nodes, n);
        }
    }

    #[test]
    fn median_leaves_of_one_are_merged_and_nodes_fill_up() {
        // The median builder's leaves hold one triangle: the collapse merges
        // siblings into leaves of up to MAX_LEAF and fills nodes, so there
        // are far fewer wide nodes than a binary interior node per two leaves.
        let prims = scattered(4096, 9);
        let cfg = AccelConfig { builder: Builder::Median, ..Default::default() };
        let bin = crate::bvh::build_binary(&prims, &cfg);
        let wide = collapse(&bin.nodes);
        let lanes: usize = wide.iter().map(WideNode::used).sum();
        assert!(lanes as f64 / wide.len() as f64 > 4.0, "mean fill {}", lanes as f64 / wide.len() as f64);
        let max_leaf = wide.iter().flat_map(|w| w.count).max().unwrap_or(0);
        assert!(max_leaf > 1 && max_leaf <= MAX_LEAF);
    }
}
