//! Coloured 3D line segments: what every overlay produces, what the
//! rasteriser draws and the OBJ export writes.

use glam::Vec3;
use serde::Serialize;

use crate::geometry::Aabb;

/// Linear RGB colours of the reports' visual debugging.
pub mod color {
    use glam::Vec3;

    /// Nodes that lead to the hit, the chosen split.
    pub const GREEN: Vec3 = Vec3::new(0.05, 0.9, 0.05);
    /// Nodes tested in vain, blocked shadow rays, rejected splits, rays that miss.
    pub const RED: Vec3 = Vec3::new(0.95, 0.03, 0.03);
    /// Neutral outlines.
    pub const WHITE: Vec3 = Vec3::new(1.0, 1.0, 1.0);
    /// Highlights (the leaf's box, the interpolated normal, the focal plane).
    pub const YELLOW: Vec3 = Vec3::new(1.0, 0.85, 0.0);
    /// Secondary highlights (a leaf's triangles).
    pub const CYAN: Vec3 = Vec3::new(0.0, 0.8, 1.0);
    /// Vertex normals.
    pub const BLUE: Vec3 = Vec3::new(0.15, 0.35, 1.0);
    /// Secondary outlines.
    pub const MAGENTA: Vec3 = Vec3::new(1.0, 0.1, 0.9);

    /// A saturated colour for item `i` of `n` (hues around the wheel).
    pub fn palette(i: usize, n: usize) -> Vec3 {
        let h = 6.0 * i as f32 / n.max(1) as f32;
        let x = 1.0 - ((h % 2.0) - 1.0).abs();
        match h as u32 {
            0 => Vec3::new(1.0, x, 0.0),
            1 => Vec3::new(x, 1.0, 0.0),
            2 => Vec3::new(0.0, 1.0, x),
            3 => Vec3::new(0.0, x, 1.0),
            4 => Vec3::new(x, 0.0, 1.0),
            _ => Vec3::new(1.0, 0.0, x),
        }
    }
}

/// One coloured segment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Segment {
    /// Start point.
    pub a: Vec3,
    /// End point.
    pub b: Vec3,
    /// Linear RGB colour.
    pub color: Vec3,
}

/// Segments in drawing order (later ones are drawn over earlier ones).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Lines {
    /// The segments.
    pub segments: Vec<Segment>,
}

impl Lines {
    /// Add the segment `a`-`b`.
    pub fn segment(&mut self, a: Vec3, b: Vec3, color: Vec3) {
        self.segments.push(Segment { a, b, color });
    }

    /// Add the 12 edges of `b` (nothing for an empty box).
    pub fn aabb(&mut self, b: &Aabb, color: Vec3) {
        if b.is_empty() {
            return;
        }
        let c = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            )
        };
        for i in 0..8 {
            for bit in [1, 2, 4] {
                if i & bit == 0 {
                    self.segment(c(i), c(i | bit), color);
                }
            }
        }
    }

    /// Add the three edges of a triangle.
    pub fn triangle(&mut self, v: [Vec3; 3], color: Vec3) {
        self.polygon(&v, color);
    }

    /// Add the closed polygon through `points`.
    pub fn polygon(&mut self, points: &[Vec3], color: Vec3) {
        for (i, &p) in points.iter().enumerate() {
            self.segment(p, points[(i + 1) % points.len()], color);
        }
    }

    /// Add a circle of `radius` around `center` in the plane with normal `normal` (`n` segments).
    pub fn circle(&mut self, center: Vec3, normal: Vec3, radius: f32, n: usize, color: Vec3) {
        let (u, w) = normal.normalize_or(Vec3::Z).any_orthonormal_pair();
        let points: Vec<Vec3> = (0..n)
            .map(|k| {
                let a = std::f32::consts::TAU * k as f32 / n as f32;
                center + radius * (a.cos() * u + a.sin() * w)
            })
            .collect();
        self.polygon(&points, color);
    }

    /// Mark point `p` with three axis-aligned strokes of length `size`.
    pub fn cross(&mut self, p: Vec3, size: f32, color: Vec3) {
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            self.segment(p - 0.5 * size * axis, p + 0.5 * size * axis, color);
        }
    }

    /// Append `other`'s segments (drawn after these).
    pub fn extend(&mut self, other: Lines) {
        self.segments.extend(other.segments);
    }

    /// Number of segments.
    pub fn len(&self) -> usize {
        self.segments.len()
    }

    /// True when there is nothing to draw.
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_has_twelve_edges_of_its_extents() {
        let mut l = Lines::default();
        l.aabb(&Aabb::new(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)), color::WHITE);
        assert_eq!(l.len(), 12);
        let total: f32 = l.segments.iter().map(|s| (s.b - s.a).length()).sum();
        assert!((total - 4.0 * (1.0 + 2.0 + 3.0)).abs() < 1e-6);
    }
}
