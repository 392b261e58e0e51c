//! [`Lines`] as a Wavefront OBJ file of `l` elements, for any 3D viewer:
//! one vertex per segment end with its colour appended (`v x y z r g b`, the
//! vertex-colour extension MeshLab, Blender and most viewers read).

use std::fmt::Write as _;
use std::path::Path;

use super::lines::Lines;
use crate::error::Result;

/// The OBJ text of `lines`, with `comment` in its header.
pub fn to_obj(lines: &Lines, comment: &str) -> String {
    let mut s = String::new();
    for c in comment.lines() {
        let _ = writeln!(s, "# {c}");
    }
    let _ = writeln!(s, "# {} segments, written by rtdiff debug", lines.len());
    for seg in &lines.segments {
        let c = seg.color.clamp(glam::Vec3::ZERO, glam::Vec3::ONE);
        for p in [seg.a, seg.b] {
            let _ = writeln!(s, "v {} {} {} {:.4} {:.4} {:.4}", p.x, p.y, p.z, c.x, c.y, c.z);
        }
    }
    for i in 0..lines.len() {
        let _ = writeln!(s, "l {} {}", 2 * i + 1, 2 * i + 2);
    }
    s
}

/// Write `lines` to `path` as OBJ.
pub fn write_obj(lines: &Lines, comment: &str, path: &Path) -> Result<()> {
    crate::output::write(path, to_obj(lines, comment))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    #[test]
    fn obj_has_a_vertex_pair_and_a_line_per_segment() {
        let mut l = Lines::default();
        l.segment(Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 0.0));
        l.segment(Vec3::Y, Vec3::Z, Vec3::new(0.0, 2.0, 0.0));
        let s = to_obj(&l, "test");
        let v: Vec<&str> = s.lines().filter(|x| x.starts_with("v ")).collect();
        assert_eq!(
            v,
            [
                "v 0 0 0 1.0000 0.0000 0.0000",
                "v 1 0 0 1.0000 0.0000 0.0000",
                "v 0 1 0 0.0000 1.0000 0.0000",
                "v 0 0 1 0.0000 1.0000 0.0000"
            ]
        );
        assert_eq!(s.lines().filter(|x| x.starts_with("l ")).collect::<Vec<_>>(), ["l 1 2", "l 3 4"]);
    }
}
