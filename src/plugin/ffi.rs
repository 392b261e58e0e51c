//! The C ABI of `include/rtdiff_tracer.h`, mirrored: types, constants and the
//! entry points resolved from a plugin library.

use std::ffi::{c_char, c_void};

// The header's constants and layouts, from the crate that plugins written in Rust use too.
use rtdiff_plugin_abi::SceneNewFn as SceneNew;
pub use rtdiff_plugin_abi::{ABI_VERSION, FEATURE_SPHERES, Hit as RtdiffHit, INVALID_ID, Ray as RtdiffRay};

const _: () = assert!(std::mem::size_of::<RtdiffRay>() == 32 && std::mem::size_of::<RtdiffHit>() == 16);

/// The entry points of one plugin (valid while its library is loaded, i.e. for the process).
#[derive(Clone, Copy)]
pub(crate) struct Fns {
    pub(crate) abi_version: unsafe extern "C" fn() -> u32,
    pub(crate) name: unsafe extern "C" fn() -> *const c_char,
    pub(crate) features: unsafe extern "C" fn() -> u32,
    pub(crate) scene_new: SceneNew,
    pub(crate) scene_free: unsafe extern "C" fn(*mut c_void),
    pub(crate) intersect1: unsafe extern "C" fn(*const c_void, *const RtdiffRay, *mut RtdiffHit),
    pub(crate) occluded1: unsafe extern "C" fn(*const c_void, *const RtdiffRay) -> i32,
    pub(crate) intersect_n: unsafe extern "C" fn(*const c_void, *const RtdiffRay, *mut RtdiffHit, usize),
    pub(crate) occluded_n: unsafe extern "C" fn(*const c_void, *const RtdiffRay, *mut u8, usize),
}

impl Fns {
    /// Resolve every entry point of `lib`; the error names the first missing symbol.
    pub(crate) fn resolve(lib: &libloading::Library) -> std::result::Result<Self, &'static str> {
        /// One symbol as a function pointer of type `T`.
        fn get<T: Copy>(lib: &libloading::Library, name: &'static str) -> std::result::Result<T, &'static str> {
            // SAFETY: the ABI fixes each symbol's signature; `T` is that signature
            // (a function pointer), and the library outlives the pointer (never unloaded).
            unsafe { lib.get::<T>(name.as_bytes()).map(|s| *s).map_err(|_| name) }
        }
        Ok(Self {
            abi_version: get(lib, "rtdiff_tracer_abi_version")?,
            name: get(lib, "rtdiff_tracer_name")?,
            features: get(lib, "rtdiff_tracer_features")?,
            scene_new: get(lib, "rtdiff_tracer_scene_new")?,
            scene_free: get(lib, "rtdiff_tracer_scene_free")?,
            intersect1: get(lib, "rtdiff_tracer_intersect1")?,
            occluded1: get(lib, "rtdiff_tracer_occluded1")?,
            intersect_n: get(lib, "rtdiff_tracer_intersect_n")?,
            occluded_n: get(lib, "rtdiff_tracer_occluded_n")?,
        })
    }
}

/// A NUL-terminated C string as UTF-8 text, `None` for NULL or invalid text.
///
/// # Safety
/// `p` is NULL or points to a NUL-terminated string that lives while the call reads it.
pub(crate) unsafe fn c_string(p: *const c_char) -> Option<String> {
    if p.is_null() {
        return None;
    }
    // SAFETY: non-NULL and NUL-terminated by the caller's contract.
    unsafe { std::ffi::CStr::from_ptr(p) }.to_str().ok().map(str::to_string)
}
