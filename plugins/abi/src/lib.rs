//! The C ABI of rtdiff's `include/rtdiff_tracer.h` for plugins written in Rust:
//! the ray and hit layouts, the [`Tracer`] a plugin implements, and
//! [`export_tracer!`], which exports every function of the header for it.
//!
//! A plugin crate is a `cdylib` with one line: `rtdiff_plugin_abi::export_tracer!(MyScene);`.

use std::ffi::{CStr, c_char};

/// `RTDIFF_TRACER_ABI_VERSION`.
pub const ABI_VERSION: u32 = 1;
/// `RTDIFF_INVALID_ID`: the primitive id of a miss.
pub const INVALID_ID: u32 = u32::MAX;
/// `RTDIFF_FEATURE_SPHERES`.
pub const FEATURE_SPHERES: u32 = 1;

/// The type of `rtdiff_tracer_scene_new`, for a host that resolves it from a library.
pub type SceneNewFn = unsafe extern "C" fn(
    vertices: *const f32,
    vertex_count: u32,
    indices: *const u32,
    triangle_count: u32,
    spheres: *const f32,
    sphere_count: u32,
    error: *mut c_char,
    error_len: usize,
) -> *mut std::ffi::c_void;

/// `rtdiff_ray`: `org + t dir`, `t` in `[tnear, tfar]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ray {
    /// Origin.
    pub org: [f32; 3],
    /// Direction (not normalised).
    pub dir: [f32; 3],
    /// Start of the interval.
    pub tnear: f32,
    /// End of the interval (may be infinite).
    pub tfar: f32,
}

/// `rtdiff_hit`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance.
    pub t: f32,
    /// Primitive id; [`INVALID_ID`] for a miss.
    pub prim: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

impl Hit {
    /// A miss.
    pub const MISS: Hit = Hit { t: f32::INFINITY, prim: INVALID_ID, u: 0.0, v: 0.0 };
}

/// What a plugin builds from rtdiff's primitives and answers queries with.
pub trait Tracer: Sized + Sync {
    /// Name and version of the library, NUL-terminated (`c"tinybvh 1.6.8"`).
    const NAME: &'static CStr;
    /// `RTDIFF_FEATURE_*` bits.
    const FEATURES: u32;

    /// Build over `triangles` (three vertices each: primitive `i` is `triangles[i]`) and `spheres`
    /// (centre and radius; empty unless [`Tracer::FEATURES`] has [`FEATURE_SPHERES`]).
    fn build(triangles: Vec<[[f32; 3]; 3]>, spheres: Vec<[f32; 4]>) -> Result<Self, String>;

    /// The closest hit of `ray`, or [`Hit::MISS`].
    fn intersect(&self, ray: &Ray) -> Hit;

    /// Whether anything is hit in the interval (default: a closest-hit query).
    fn occluded(&self, ray: &Ray) -> bool {
        self.intersect(ray).prim != INVALID_ID
    }
}

/// Copy `msg` into the caller's error buffer (truncated, NUL-terminated).
///
/// # Safety
/// `error` is NULL or points to `len` writable bytes.
pub unsafe fn write_error(error: *mut c_char, len: usize, msg: &str) {
    if error.is_null() || len == 0 {
        return;
    }
    let n = msg.len().min(len - 1);
    // SAFETY: `n + 1 <= len` bytes are writable by the caller's contract.
    unsafe {
        std::ptr::copy_nonoverlapping(msg.as_ptr(), error.cast::<u8>(), n);
        *error.add(n) = 0;
    }
}

#[allow(clippy::too_many_arguments)] // the C signature of the header
/// The body of `rtdiff_tracer_scene_new` for `T`: checks the buffers, builds,
/// and returns a boxed `T` (NULL with a message on any failure, panics included).
///
/// # Safety
/// The pointers hold the counts the header describes; `error` has `error_len` bytes.
pub unsafe fn scene_new<T: Tracer>(
    vertices: *const f32,
    vertex_count: u32,
    indices: *const u32,
    triangle_count: u32,
    spheres: *const f32,
    sphere_count: u32,
    error: *mut c_char,
    error_len: usize,
) -> *mut T {
    let fail = |msg: &str| {
        // SAFETY: the caller's contract on `error`.
        unsafe { write_error(error, error_len, msg) };
        std::ptr::null_mut()
    };
    if sphere_count > 0 && T::FEATURES & FEATURE_SPHERES == 0 {
        return fail("this plugin traces triangles only");
    }
    let (nv, nt, ns) = (vertex_count as usize, triangle_count as usize, sphere_count as usize);
    if (nv > 0 && vertices.is_null()) || (nt > 0 && indices.is_null()) || (ns > 0 && spheres.is_null()) {
        return fail("a buffer is NULL");
    }
    // SAFETY: non-NULL buffers of the given counts (caller's contract); empty ones are not read.
    let (v, i, s) = unsafe {
        (
            if nv > 0 { std::slice::from_raw_parts(vertices, 3 * nv) } else { &[][..] },
            if nt > 0 { std::slice::from_raw_parts(indices, 3 * nt) } else { &[][..] },
            if ns > 0 { std::slice::from_raw_parts(spheres, 4 * ns) } else { &[][..] },
        )
    };
    if let Some(bad) = i.iter().find(|&&k| k as usize >= nv) {
        return fail(&format!("vertex index {bad} out of range ({nv} vertices)"));
    }
    let vertex = |k: u32| [v[3 * k as usize], v[3 * k as usize + 1], v[3 * k as usize + 2]];
    let triangles: Vec<[[f32; 3]; 3]> = i.chunks_exact(3).map(|t| [vertex(t[0]), vertex(t[1]), vertex(t[2])]).collect();
    let spheres: Vec<[f32; 4]> = s.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
    match std::panic::catch_unwind(|| T::build(triangles, spheres)) {
        Ok(Ok(t)) => Box::into_raw(Box::new(t)),
        Ok(Err(e)) => fail(&e),
        Err(_) => fail("the build panicked"),
    }
}

/// `rtdiff_tracer_name`'s C string.
pub fn name<T: Tracer>() -> *const c_char {
    T::NAME.as_ptr()
}

/// Export every function of `include/rtdiff_tracer.h` for the [`Tracer`] type `$t`.
#[macro_export]
macro_rules! export_tracer {
    ($t:ty) => {
        /// `rtdiff_tracer_abi_version`.
        #[unsafe(no_mangle)]
        pub extern "C" fn rtdiff_tracer_abi_version() -> u32 {
            $crate::ABI_VERSION
        }

        /// `rtdiff_tracer_name`.
        #[unsafe(no_mangle)]
        pub extern "C" fn rtdiff_tracer_name() -> *const ::std::ffi::c_char {
            $crate::name::<$t>()
        }

        /// `rtdiff_tracer_features`.
        #[unsafe(no_mangle)]
        pub extern "C" fn rtdiff_tracer_features() -> u32 {
            <$t as $crate::Tracer>::FEATURES
        }

        /// `rtdiff_tracer_scene_new`.
        ///
        /// # Safety
        /// The header's contract on the buffers.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn rtdiff_tracer_scene_new(
            vertices: *const f32,
            vertex_count: u32,
            indices: *const u32,
            triangle_count: u32,
            spheres: *const f32,
            sphere_count: u32,
            error: *mut ::std::ffi::c_char,
            error_len: usize,
        ) -> *mut ::std::ffi::c_void {
            // SAFETY: forwarded contract.
            unsafe {
                $crate::scene_new::<$t>(
                    vertices,
                    vertex_count,
                    indices,
                    triangle_count,
                    spheres,
                    sphere_count,
                    error,
                    error_len,
                )
                .cast()
            }
        }

        /// `rtdiff_tracer_scene_free`.
        ///
        /// # Safety
        /// `scene` came from `rtdiff_tracer_scene_new` and is freed once.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn rtdiff_tracer_scene_free(scene: *mut ::std::ffi::c_void) {
            if !scene.is_null() {
                // SAFETY: a box made by rtdiff_tracer_scene_new.
                drop(unsafe { Box::from_raw(scene.cast::<$t>()) });
            }
        }

        /// `rtdiff_tracer_intersect1`.
        ///
        /// # Safety
        /// A live scene, one ray, one hit.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn rtdiff_tracer_intersect1(
            scene: *const ::std::ffi::c_void,
            ray: *const $crate::Ray,
            hit: *mut $crate::Hit,
        ) {
            // SAFETY: the header's contract.
            unsafe { *hit = <$t as $crate::Tracer>::intersect(&*scene.cast::<$t>(), &*ray) };
        }

        /// `rtdiff_tracer_occluded1`.
        ///
        /// # Safety
        /// A live scene, one ray.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn rtdiff_tracer_occluded1(
            scene: *const ::std::ffi::c_void,
            ray: *const $crate::Ray,
        ) -> i32 {
            // SAFETY: the header's contract.
            unsafe { <$t as $crate::Tracer>::occluded(&*scene.cast::<$t>(), &*ray) as i32 }
        }

        /// `rtdiff_tracer_intersect_n`.
        ///
        /// # Safety
        /// A live scene, `count` rays and hits.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn rtdiff_tracer_intersect_n(
            scene: *const ::std::ffi::c_void,
            rays: *const $crate::Ray,
            hits: *mut $crate::Hit,
            count: usize,
        ) {
            // SAFETY: the header's contract.
            unsafe {
                $crate::for_each_ray::<$t, $crate::Hit>(scene, rays, hits, count, <$t as $crate::Tracer>::intersect)
            }
        }

        /// `rtdiff_tracer_occluded_n`.
        ///
        /// # Safety
        /// A live scene, `count` rays and answers.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn rtdiff_tracer_occluded_n(
            scene: *const ::std::ffi::c_void,
            rays: *const $crate::Ray,
            occluded: *mut u8,
            count: usize,
        ) {
            // SAFETY: the header's contract.
            unsafe {
                $crate::for_each_ray::<$t, u8>(scene, rays, occluded, count, |s, r| {
                    <$t as $crate::Tracer>::occluded(s, r) as u8
                })
            }
        }
    };
}

/// The batch calls' common part ([`export_tracer!`]'s `rtdiff_tracer_intersect_n` and
/// `rtdiff_tracer_occluded_n`): `f` on each ray, its answer into `out`.
///
/// # Safety
/// `scene` points to a live `T`; `rays` and `out` hold `count` items each (they may be
/// dangling when `count` is 0).
#[doc(hidden)]
pub unsafe fn for_each_ray<T, O>(
    scene: *const std::ffi::c_void,
    rays: *const Ray,
    out: *mut O,
    count: usize,
    f: impl Fn(&T, &Ray) -> O,
) {
    if count == 0 {
        return;
    }
    // SAFETY: the caller's contract.
    let (s, r, o) = unsafe {
        (&*scene.cast::<T>(), std::slice::from_raw_parts(rays, count), std::slice::from_raw_parts_mut(out, count))
    };
    for (ray, out) in r.iter().zip(o) {
        *out = f(s, ray);
    }
}
