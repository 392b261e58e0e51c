//! Hand-written bindings to the Embree 4.4 C API: only what rtdiff calls.
//!
//! Layouts follow `embree4/rtcore_ray.h` and `rtcore_common.h` of the 4.4.0
//! release, which is built with instance arrays
//! (`RTC_GEOMETRY_INSTANCE_ARRAY`): `RTCHit` therefore ends with
//! `instPrimID[RTC_MAX_INSTANCE_LEVEL_COUNT]` after `instID[..]`, and
//! `RTCRayHit` is 96 bytes, not the 80 bytes of the 4.2 headers bundled by
//! embree4-sys (with those, every hit writes past the struct). The sizes are
//! asserted at compile time below and again in `tests/embree_ffi.rs`.

#![allow(non_camel_case_types, non_snake_case)]

use std::ffi::{c_char, c_void};

/// `RTC_MAX_INSTANCE_LEVEL_COUNT` of the release build (single-level instancing).
pub const RTC_MAX_INSTANCE_LEVEL_COUNT: usize = 1;
/// `RTC_INVALID_GEOMETRY_ID`: `geomID` of a ray that hit nothing.
pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;

/// Opaque device handle.
pub type RTCDevice = *mut c_void;
/// Opaque scene handle.
pub type RTCScene = *mut c_void;
/// Opaque geometry handle.
pub type RTCGeometry = *mut c_void;

// enum RTCError
/// `RTC_ERROR_NONE` of the Embree 4.4 headers.
pub const RTC_ERROR_NONE: i32 = 0;
/// `RTC_ERROR_UNKNOWN` of the Embree 4.4 headers.
pub const RTC_ERROR_UNKNOWN: i32 = 1;
/// `RTC_ERROR_INVALID_ARGUMENT` of the Embree 4.4 headers.
pub const RTC_ERROR_INVALID_ARGUMENT: i32 = 2;
/// `RTC_ERROR_INVALID_OPERATION` of the Embree 4.4 headers.
pub const RTC_ERROR_INVALID_OPERATION: i32 = 3;
/// `RTC_ERROR_OUT_OF_MEMORY` of the Embree 4.4 headers.
pub const RTC_ERROR_OUT_OF_MEMORY: i32 = 4;
/// `RTC_ERROR_UNSUPPORTED_CPU` of the Embree 4.4 headers.
pub const RTC_ERROR_UNSUPPORTED_CPU: i32 = 5;
/// `RTC_ERROR_CANCELLED` of the Embree 4.4 headers.
pub const RTC_ERROR_CANCELLED: i32 = 6;
/// `RTC_ERROR_LEVEL_ZERO_RAYTRACING_SUPPORT_MISSING` of the Embree 4.4 headers.
pub const RTC_ERROR_LEVEL_ZERO_RAYTRACING_SUPPORT_MISSING: i32 = 7;

// enum RTCDeviceProperty
/// `RTC_DEVICE_PROPERTY_VERSION` of the Embree 4.4 headers.
pub const RTC_DEVICE_PROPERTY_VERSION: i32 = 0;

// enum RTCGeometryType
/// `RTC_GEOMETRY_TYPE_TRIANGLE` of the Embree 4.4 headers.
pub const RTC_GEOMETRY_TYPE_TRIANGLE: i32 = 0;
/// `RTC_GEOMETRY_TYPE_SPHERE_POINT` of the Embree 4.4 headers.
pub const RTC_GEOMETRY_TYPE_SPHERE_POINT: i32 = 50;

// enum RTCBufferType
/// `RTC_BUFFER_TYPE_INDEX` of the Embree 4.4 headers.
pub const RTC_BUFFER_TYPE_INDEX: i32 = 0;
/// `RTC_BUFFER_TYPE_VERTEX` of the Embree 4.4 headers.
pub const RTC_BUFFER_TYPE_VERTEX: i32 = 1;

// enum RTCFormat
/// `RTC_FORMAT_UINT3` of the Embree 4.4 headers.
pub const RTC_FORMAT_UINT3: i32 = 0x5003;
/// `RTC_FORMAT_FLOAT3` of the Embree 4.4 headers.
pub const RTC_FORMAT_FLOAT3: i32 = 0x9003;
/// `RTC_FORMAT_FLOAT4` of the Embree 4.4 headers.
pub const RTC_FORMAT_FLOAT4: i32 = 0x9004;

// enum RTCSceneFlags
/// `RTC_SCENE_FLAG_NONE` of the Embree 4.4 headers (Embree's default flags).
pub const RTC_SCENE_FLAG_NONE: i32 = 0;
/// `RTC_SCENE_FLAG_ROBUST` of the Embree 4.4 headers.
pub const RTC_SCENE_FLAG_ROBUST: i32 = 1 << 2;

// enum RTCBuildQuality
/// `RTC_BUILD_QUALITY_LOW` of the Embree 4.4 headers.
pub const RTC_BUILD_QUALITY_LOW: i32 = 0;
/// `RTC_BUILD_QUALITY_MEDIUM` of the Embree 4.4 headers.
pub const RTC_BUILD_QUALITY_MEDIUM: i32 = 1;
/// `RTC_BUILD_QUALITY_HIGH` of the Embree 4.4 headers.
pub const RTC_BUILD_QUALITY_HIGH: i32 = 2;

/// `struct RTC_ALIGN(16) RTCRay` (48 bytes).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRay {
    /// C member `org_x`.
    pub org_x: f32,
    /// C member `org_y`.
    pub org_y: f32,
    /// C member `org_z`.
    pub org_z: f32,
    /// C member `tnear`.
    pub tnear: f32,
    /// C member `dir_x`.
    pub dir_x: f32,
    /// C member `dir_y`.
    pub dir_y: f32,
    /// C member `dir_z`.
    pub dir_z: f32,
    /// C member `time`.
    pub time: f32,
    /// C member `tfar`.
    pub tfar: f32,
    /// C member `mask`.
    pub mask: u32,
    /// C member `id`.
    pub id: u32,
    /// C member `flags`.
    pub flags: u32,
}

/// `struct RTCHit` of a build with instance arrays (36 bytes, 4-byte aligned).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCHit {
    /// C member `Ng_x`.
    pub Ng_x: f32,
    /// C member `Ng_y`.
    pub Ng_y: f32,
    /// C member `Ng_z`.
    pub Ng_z: f32,
    /// C member `u`.
    pub u: f32,
    /// C member `v`.
    pub v: f32,
    /// C member `primID`.
    pub primID: u32,
    /// C member `geomID`.
    pub geomID: u32,
    /// C member `instID`.
    pub instID: [u32; RTC_MAX_INSTANCE_LEVEL_COUNT],
    /// C member `instPrimID`.
    pub instPrimID: [u32; RTC_MAX_INSTANCE_LEVEL_COUNT],
}

/// `struct RTC_ALIGN(16) RTCRayHit` (96 bytes: 48 + 36, padded to 16).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRayHit {
    /// C member `ray`.
    pub ray: RTCRay,
    /// C member `hit`.
    pub hit: RTCHit,
}

/// `struct RTC_ALIGN(32) RTCRay8`: structure of arrays (384 bytes).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRay8 {
    /// C member `org_x`.
    pub org_x: [f32; 8],
    /// C member `org_y`.
    pub org_y: [f32; 8],
    /// C member `org_z`.
    pub org_z: [f32; 8],
    /// C member `tnear`.
    pub tnear: [f32; 8],
    /// C member `dir_x`.
    pub dir_x: [f32; 8],
    /// C member `dir_y`.
    pub dir_y: [f32; 8],
    /// C member `dir_z`.
    pub dir_z: [f32; 8],
    /// C member `time`.
    pub time: [f32; 8],
    /// C member `tfar`.
    pub tfar: [f32; 8],
    /// C member `mask`.
    pub mask: [u32; 8],
    /// C member `id`.
    pub id: [u32; 8],
    /// C member `flags`.
    pub flags: [u32; 8],
}

/// `struct RTC_ALIGN(32) RTCHit8` of a build with instance arrays (288 bytes).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCHit8 {
    /// C member `Ng_x`.
    pub Ng_x: [f32; 8],
    /// C member `Ng_y`.
    pub Ng_y: [f32; 8],
    /// C member `Ng_z`.
    pub Ng_z: [f32; 8],
    /// C member `u`.
    pub u: [f32; 8],
    /// C member `v`.
    pub v: [f32; 8],
    /// C member `primID`.
    pub primID: [u32; 8],
    /// C member `geomID`.
    pub geomID: [u32; 8],
    /// C member `instID`.
    pub instID: [[u32; 8]; RTC_MAX_INSTANCE_LEVEL_COUNT],
    /// C member `instPrimID`.
    pub instPrimID: [[u32; 8]; RTC_MAX_INSTANCE_LEVEL_COUNT],
}

/// `struct RTCRayHit8` (672 bytes, 32-byte aligned).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRayHit8 {
    /// C member `ray`.
    pub ray: RTCRay8,
    /// C member `hit`.
    pub hit: RTCHit8,
}

/// The `valid` mask of the 8-wide calls: -1 = active lane, 0 = inactive (32-byte aligned).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default)]
pub struct Valid8(pub [i32; 8]);

/// `struct RTCBounds` (32 bytes, 16-byte aligned).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCBounds {
    /// C member `lower_x`.
    pub lower_x: f32,
    /// C member `lower_y`.
    pub lower_y: f32,
    /// C member `lower_z`.
    pub lower_z: f32,
    /// C member `align0`.
    pub align0: f32,
    /// C member `upper_x`.
    pub upper_x: f32,
    /// C member `upper_y`.
    pub upper_y: f32,
    /// C member `upper_z`.
    pub upper_z: f32,
    /// C member `align1`.
    pub align1: f32,
}

/// `RTCIntersectArguments` and `RTCOccludedArguments` are only ever passed
/// as NULL (Embree's defaults), so their layout is not needed.
pub type RTCIntersectArgumentsPtr = *mut c_void;

/// `typedef void (*RTCErrorFunction)(void* userPtr, enum RTCError code, const char* str)`.
pub type RTCErrorFunction = Option<unsafe extern "C" fn(user_ptr: *mut c_void, code: i32, msg: *const c_char)>;

/// `typedef bool (*RTCMemoryMonitorFunction)(void* userPtr, ssize_t bytes, bool post)`.
pub type RTCMemoryMonitorFunction =
    Option<unsafe extern "C" fn(user_ptr: *mut c_void, bytes: isize, post: bool) -> bool>;

const _: () = assert!(std::mem::size_of::<RTCRay>() == 48 && std::mem::align_of::<RTCRay>() == 16);
const _: () = assert!(std::mem::size_of::<RTCHit>() == 36 && std::mem::align_of::<RTCHit>() == 4);
const _: () = assert!(std::mem::size_of::<RTCRayHit>() == 96 && std::mem::align_of::<RTCRayHit>() == 16);
const _: () = assert!(std::mem::size_of::<RTCBounds>() == 32);
const _: () = assert!(std::mem::size_of::<RTCRay8>() == 384 && std::mem::align_of::<RTCRay8>() == 32);
const _: () = assert!(std::mem::size_of::<RTCHit8>() == 288 && std::mem::align_of::<RTCHit8>() == 32);
const _: () = assert!(std::mem::size_of::<RTCRayHit8>() == 672 && std::mem::align_of::<RTCRayHit8>() == 32);

#[link(name = "embree4")]
unsafe extern "C" {
    /// `rtcNewDevice` (see the Embree 4 API documentation).
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    /// `rtcRetainDevice` (see the Embree 4 API documentation).
    pub fn rtcRetainDevice(device: RTCDevice);
    /// `rtcReleaseDevice` (see the Embree 4 API documentation).
    pub fn rtcReleaseDevice(device: RTCDevice);
    /// `rtcGetDeviceError` (see the Embree 4 API documentation).
    pub fn rtcGetDeviceError(device: RTCDevice) -> i32;
    /// `rtcGetDeviceLastErrorMessage` (see the Embree 4 API documentation).
    pub fn rtcGetDeviceLastErrorMessage(device: RTCDevice) -> *const c_char;
    /// `rtcSetDeviceErrorFunction` (see the Embree 4 API documentation).
    pub fn rtcSetDeviceErrorFunction(device: RTCDevice, error: RTCErrorFunction, user_ptr: *mut c_void);
    /// `rtcSetDeviceMemoryMonitorFunction` (see the Embree 4 API documentation).
    pub fn rtcSetDeviceMemoryMonitorFunction(
        device: RTCDevice,
        monitor: RTCMemoryMonitorFunction,
        user_ptr: *mut c_void,
    );
    /// `rtcGetDeviceProperty` (see the Embree 4 API documentation).
    pub fn rtcGetDeviceProperty(device: RTCDevice, prop: i32) -> isize;

    /// `rtcNewScene` (see the Embree 4 API documentation).
    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    /// `rtcReleaseScene` (see the Embree 4 API documentation).
    pub fn rtcReleaseScene(scene: RTCScene);
    /// `rtcSetSceneFlags` (see the Embree 4 API documentation).
    pub fn rtcSetSceneFlags(scene: RTCScene, flags: i32);
    /// `rtcSetSceneBuildQuality` (see the Embree 4 API documentation).
    pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: i32);
    /// `rtcAttachGeometryByID` (see the Embree 4 API documentation).
    pub fn rtcAttachGeometryByID(scene: RTCScene, geometry: RTCGeometry, geom_id: u32);
    /// `rtcCommitScene` (see the Embree 4 API documentation).
    pub fn rtcCommitScene(scene: RTCScene);
    /// `rtcGetSceneBounds` (see the Embree 4 API documentation).
    pub fn rtcGetSceneBounds(scene: RTCScene, bounds: *mut RTCBounds);

    /// `rtcNewGeometry` (see the Embree 4 API documentation).
    pub fn rtcNewGeometry(device: RTCDevice, kind: i32) -> RTCGeometry;
    /// `rtcReleaseGeometry` (see the Embree 4 API documentation).
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);
    /// `rtcSetNewGeometryBuffer` (see the Embree 4 API documentation).
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: i32,
        slot: u32,
        format: i32,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    /// `rtcSetGeometryBuildQuality` (see the Embree 4 API documentation).
    pub fn rtcSetGeometryBuildQuality(geometry: RTCGeometry, quality: i32);
    /// `rtcCommitGeometry` (see the Embree 4 API documentation).
    pub fn rtcCommitGeometry(geometry: RTCGeometry);

    /// `rtcIntersect1` (see the Embree 4 API documentation).
    pub fn rtcIntersect1(scene: RTCScene, rayhit: *mut RTCRayHit, args: RTCIntersectArgumentsPtr);
    /// `rtcOccluded1` (see the Embree 4 API documentation).
    pub fn rtcOccluded1(scene: RTCScene, ray: *mut RTCRay, args: RTCIntersectArgumentsPtr);
    /// `rtcIntersect8` (see the Embree 4 API documentation).
    pub fn rtcIntersect8(
        valid: *const Valid8,
        scene: RTCScene,
        rayhit: *mut RTCRayHit8,
        args: RTCIntersectArgumentsPtr,
    );
    /// `rtcOccluded8` (see the Embree 4 API documentation).
    pub fn rtcOccluded8(valid: *const Valid8, scene: RTCScene, ray: *mut RTCRay8, args: RTCIntersectArgumentsPtr);
}
