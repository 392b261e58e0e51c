//! The differential harness's checks, beside the render pipeline: image
//! comparisons against reference renderers ([`image`]).

pub mod image;
