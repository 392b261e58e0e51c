//! Shared edges and closed vertex fans of a triangle soup (where the
//! adversarial `edges` and `vertices` rays aim).

use std::collections::HashMap;

use glam::Vec3;

use crate::geometry::Primitives;

/// The triangles of `prims` as an indexed mesh: each distinct vertex
/// position once (in order of first use) and three indices per triangle, in
/// triangle order. Vertices are welded by exact position (bit for bit).
pub fn welded(prims: &Primitives) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let key = |p: Vec3| (p.x.to_bits(), p.y.to_bits(), p.z.to_bits());
    let mut ids: HashMap<(u32, u32, u32), u32> = HashMap::new();
    let mut pos = Vec::new();
    let tris = prims
        .triangles
        .iter()
        .map(|t| {
            t.v.map(|p| {
                *ids.entry(key(p)).or_insert_with(|| {
                    pos.push(p);
                    pos.len() as u32 - 1
                })
            })
        })
        .collect();
    (pos, tris)
}

/// Shared-edge and vertex-fan topology of the triangles, with vertices
/// welded by exact position (so unwelded seams with identical coordinates,
/// like the teapot's, count as shared).
pub struct Topology {
    /// Edges used by exactly two triangles: `(a, b, tri0, tri1)`.
    pub shared_edges: Vec<(Vec3, Vec3, u32, u32)>,
    /// Vertices whose fan is a closed, consistently oriented cycle: `(position, triangles)`.
    pub closed_vertices: Vec<(Vec3, Vec<u32>)>,
}

impl Topology {
    /// Compute the topology of `prims.triangles`.
    pub fn new(prims: &Primitives) -> Self {
        let (pos, tris) = welded(prims);
        let mut edges: HashMap<(u32, u32), Vec<(u32, bool)>> = HashMap::new();
        let mut fans: Vec<Vec<u32>> = vec![Vec::new(); pos.len()];
        for (i, t) in tris.iter().enumerate() {
            // Zero-area triangles (kept in the primitives so that ids are file positions) are
            // no part of the surface.
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || prims.triangles[i].normal() == Vec3::ZERO {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.entry((a.min(b), a.max(b))).or_default().push((i as u32, a < b));
                fans[a as usize].push(i as u32);
            }
        }
        let mut shared: Vec<_> = edges
            .iter()
            // Two triangles, opposite directions: a manifold, consistently wound edge.
            .filter(|(_, v)| v.len() == 2 && v[0].1 != v[1].1)
            .map(|(&(a, b), v)| (v[0].0, v[1].0, a, b))
            .collect();
        // HashMap order is random: sort for determinism, by the triangle pair
        // and then by the edge's vertices (two triangles may share more than
        // one edge: a triangle and its reversed copy share all three).
        shared.sort_unstable();
        let shared_edges =
            shared.into_iter().map(|(t0, t1, a, b)| (pos[a as usize], pos[b as usize], t0, t1)).collect();
        let mut closed_vertices = Vec::new();
        for (vi, fan) in fans.into_iter().enumerate() {
            if fan.len() < 3 {
                continue;
            }
            // Closed fan: every edge from the vertex is shared by exactly two
            // fan triangles, in opposite directions, and is manifold.
            let vi = vi as u32;
            let closed = fan.iter().all(|&t| {
                let tri = tris[t as usize];
                tri.iter()
                    .filter(|&&w| w != vi)
                    .all(|&w| edges.get(&(vi.min(w), vi.max(w))).is_some_and(|v| v.len() == 2 && v[0].1 != v[1].1))
            });
            if closed {
                closed_vertices.push((pos[vi as usize], fan));
            }
        }
        Self { shared_edges, closed_vertices }
    }
}
