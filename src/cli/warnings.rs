//! Warnings the subcommands print on stderr about what a scene loaded as.

use std::path::Path;

use crate::geometry::Primitives;

/// Warn about zero-area triangles dropped while loading `scene`, and loudly
/// when nothing is left to hit (every triangle degenerate, no sphere).
pub fn degenerate(scene: &Path, prims: &Primitives, skipped: usize) {
    if skipped == 0 {
        return;
    }
    if prims.triangles.is_empty() && prims.spheres.is_empty() {
        eprintln!(
            "rtdiff: warning: {}: all {skipped} triangles have zero area and were skipped: every ray misses",
            scene.display()
        );
    } else {
        eprintln!("rtdiff: warning: {}: skipped {skipped} zero-area triangles", scene.display());
    }
}
