//! The arbiter's candidate search: a double-precision bounding volume
//! hierarchy that lists every triangle whose box comes within a slack of a
//! ray's line. It must never lose a triangle the line meets, so boxes are
//! widened by a relative slack and tested over the whole line, not with the
//! tight tests of the tracers under judgement.

use glam::DVec3;

use crate::geometry::aabb::Slab;

/// Leaf size of the index.
const LEAF: usize = 4;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first index into `order`; inner: index of the right child (the left is next).
    first: u32,
    /// Leaf: number of items; inner: 0.
    count: u32,
}

/// A bounding volume hierarchy over boxes, queried by lines.
#[derive(Clone, Debug, Default)]
pub struct LineIndex {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

fn union(boxes: &[(DVec3, DVec3)], items: &[u32]) -> (DVec3, DVec3) {
    items.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
        let (a, b) = boxes[i as usize];
        (lo.min(a), hi.max(b))
    })
}

impl LineIndex {
    /// Build over `boxes` (item `i` has box `boxes[i]`) by median splits of
    /// the box centres along their widest axis.
    pub fn new(boxes: &[(DVec3, DVec3)]) -> Self {
        let mut idx = Self { nodes: Vec::with_capacity(2 * boxes.len() / LEAF + 1), order: Vec::new() };
        let mut items: Vec<u32> = (0..boxes.len() as u32).collect();
        if !items.is_empty() {
            idx.build(boxes, &mut items, 0);
        }
        idx.order = items;
        idx
    }

    fn build(&mut self, boxes: &[(DVec3, DVec3)], items: &mut [u32], offset: usize) -> usize {
        let (lo, hi) = union(boxes, items);
        let me = self.nodes.len();
        self.nodes.push(Node { lo, hi, first: offset as u32, count: items.len() as u32 });
        if items.len() <= LEAF {
            return me;
        }
        let centre = |i: u32| (boxes[i as usize].0 + boxes[i as usize].1) * 0.5;
        let (clo, chi) = items.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), &i| {
            let c = centre(i);
            (a.min(c), b.max(c))
        });
        let ext = chi - clo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        let (left, right) = items.split_at_mut(mid);
        self.build(boxes, left, offset);
        let r = self.build(boxes, right, offset + mid);
        self.nodes[me].first = r as u32;
        self.nodes[me].count = 0;
        me
    }

    /// Call `f` on every item of every leaf whose box, widened by
    /// `slack(lo, hi)` on every side, meets the line `o + t d` (all `t`): a
    /// superset of the items whose own widened boxes meet it.
    pub fn visit(&self, o: DVec3, d: DVec3, slack: impl Fn(DVec3, DVec3) -> f64, mut f: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let line = Slab::from_line(o.to_array(), d.to_array());
        let meets = |n: &Node| {
            let s = DVec3::splat(slack(n.lo, n.hi));
            // The whole line: finite ends, so a line parallel to a slab and outside it misses.
            line.clip((n.lo - s).to_array(), (n.hi + s).to_array(), -f64::MAX, f64::MAX, 1.0).is_some()
        };
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if !meets(n) {
                continue;
            }
            if n.count > 0 {
                for &item in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    f(item);
                }
            } else {
                stack.push(n.first as usize);
                stack.push(i + 1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_every_box_on_the_line_and_few_others() {
        // A 10 x 10 grid of unit boxes in the plane z = 0.
        let boxes: Vec<(DVec3, DVec3)> = (0..100)
            .map(|k| {
                let lo = DVec3::new((k % 10) as f64, (k / 10) as f64, 0.0);
                (lo, lo + DVec3::new(1.0, 1.0, 0.0))
            })
            .collect();
        let idx = LineIndex::new(&boxes);
        let query = |o: DVec3, d: DVec3, s: f64| {
            let mut got = Vec::new();
            idx.visit(o, d, |_, _| s, |i| got.push(i));
            got.sort_unstable();
            got
        };
        // The vertical line through (3.5, 7.5) meets box 73 only: a few leaves come back.
        let got = query(DVec3::new(3.5, 7.5, 5.0), DVec3::new(0.0, 0.0, -1.0), 0.0);
        assert!(got.contains(&73) && got.len() <= 3 * LEAF, "{got:?}");
        // A line along y = 0.5 in the plane: the ten boxes of the first row, and few others.
        let got = query(DVec3::new(-5.0, 0.5, 0.0), DVec3::X, 0.0);
        assert!((0..10).all(|i| got.contains(&i)) && got.len() <= 30, "{got:?}");
        // With a slack of 0.6 the second row joins.
        let got = query(DVec3::new(-5.0, 0.5, 0.0), DVec3::X, 0.6);
        assert!((0..20).all(|i| got.contains(&i)), "{got:?}");
        // A diagonal line: every box it crosses (brute force over the grid).
        let (o, d) = (DVec3::new(0.1, 0.0, 0.0), DVec3::new(1.0, 1.3, 0.0));
        let got = query(o, d, 0.0);
        for (k, (lo, hi)) in boxes.iter().enumerate() {
            let (t0, t1) = ((lo.x - o.x).max((lo.y - o.y) / 1.3), (hi.x - o.x).min((hi.y - o.y) / 1.3));
            if t0 <= t1 {
                assert!(got.contains(&(k as u32)), "box {k} missing");
            }
        }
    }
}
