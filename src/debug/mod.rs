//! Visual debugging as pictures: the reports drew each feature into an
//! OpenGL view; rtdiff draws the same things over its own render, headless.
//!
//! An [`overlay::Overlay`] turns the scene (and the BVH, the traversal, the ray
//! tree of one pixel, ...) into 3D [`lines::Lines`]; [`raster`] projects them
//! with the scene's own [`crate::camera::Camera`] and draws them over the
//! render, depth-tested against the render's first hits (hidden parts dimmed,
//! not dropped); [`obj`] exports the same lines as an OBJ file for any 3D
//! viewer. [`heatmap()`] draws the per-pixel work of any builder x traversal,
//! counted by the traversal code itself.

pub mod draw;
pub mod heatmap;
pub mod lines;
pub mod obj;
pub mod overlay;
pub mod pixel;
pub mod project;
pub mod raster;
pub mod text;

pub use draw::{DrawOutput, draw};
pub use heatmap::{Heatmap, Metric, heatmap};
pub use lines::{Lines, Segment};
pub use overlay::{Context, Overlay};
pub use pixel::{PixelTrace, pixel_ray, trace_pixel, trace_pixel_with};
