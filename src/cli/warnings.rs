//! Warnings the subcommands print on stderr about what a scene loaded as.

use std::path::Path;

use crate::geometry::Primitives;

/// The warning about `count` zero-area triangles in `scene`, if any: they are kept in
/// place (primitive ids are triangle positions in the file) and no ray hits them; loudly
/// when nothing else is left to hit.
pub fn zero_area_message(scene: &Path, prims: &Primitives, count: usize) -> Option<String> {
    if count == 0 {
        return None;
    }
    Some(if count == prims.triangles.len() && prims.spheres.is_empty() {
        format!("{}: all {count} triangles have zero area: every ray misses", scene.display())
    } else {
        format!(
            "{}: {count} zero-area triangles (kept, so that primitive ids are triangle positions in the file; no ray hits them)",
            scene.display()
        )
    })
}

/// Print [`zero_area_message`] on stderr.
pub fn degenerate(scene: &Path, prims: &Primitives, count: usize) {
    if let Some(m) = zero_area_message(scene, prims, count) {
        eprintln!("rtdiff: warning: {m}");
    }
}
