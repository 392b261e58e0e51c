//! Intel Embree 4 as a ground-truth tracer backend (cargo feature `embree`).
//!
//! [`ffi`] holds hand-written bindings laid out as the Embree 4.4 headers;
//! [`Device`] and [`Scene`] wrap them safely (errors become [`crate::Error`]);
//! [`EmbreeTracer`] implements [`crate::accel::Tracer`] with `rtcIntersect1`
//! and `rtcOccluded1`.

pub mod device;
pub mod ffi;
pub mod scene;
pub mod tracer;

pub use device::Device;
pub use scene::Scene;
pub use tracer::EmbreeTracer;
