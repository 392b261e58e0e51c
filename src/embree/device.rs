//! The Embree device: library instance, thread pool and error state.

use std::ffi::{CStr, CString, c_void};
use std::sync::Arc;
use std::sync::atomic::{AtomicI64, Ordering};

use crate::error::{Error, Result};

use super::ffi;

/// An Embree device (`RTCDevice`), reference counted: `clone` retains it,
/// drop releases it; a [`super::Scene`] keeps its own reference.
#[derive(Debug)]
pub struct Device {
    raw: ffi::RTCDevice,
    /// Bytes the device holds, as its memory monitor reports them (shared by
    /// every clone; the monitor's payload points at it).
    memory: Arc<AtomicI64>,
}

/// The device's memory monitor: every allocation and release of the
/// device's important memory blocks (buffers, BVH nodes and leaves, build
/// scratch), added to the counter behind `user_ptr`. Embree may call it from
/// its worker threads, hence the atomic. Never refuses an allocation.
unsafe extern "C" fn count_memory(user_ptr: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: `user_ptr` is the `AtomicI64` of an `Arc` that every clone of
    // the device holds, and the last clone releases the device (which may
    // call this) before its `Arc` is dropped.
    let counter = unsafe { &*user_ptr.cast::<AtomicI64>() };
    counter.fetch_add(bytes as i64, Ordering::Relaxed);
    true
}

// SAFETY: Embree devices are internally synchronised; the API documents every
// device function as thread-safe, and error codes are stored per thread.
unsafe impl Send for Device {}
// SAFETY: see `Send`: shared references only call thread-safe API functions.
unsafe impl Sync for Device {}

fn error_name(code: i32) -> &'static str {
    match code {
        ffi::RTC_ERROR_NONE => "no error",
        ffi::RTC_ERROR_UNKNOWN => "unknown error",
        ffi::RTC_ERROR_INVALID_ARGUMENT => "invalid argument",
        ffi::RTC_ERROR_INVALID_OPERATION => "invalid operation",
        ffi::RTC_ERROR_OUT_OF_MEMORY => "out of memory",
        ffi::RTC_ERROR_UNSUPPORTED_CPU => "unsupported CPU",
        ffi::RTC_ERROR_CANCELLED => "cancelled",
        ffi::RTC_ERROR_LEVEL_ZERO_RAYTRACING_SUPPORT_MISSING => "Level Zero ray tracing support missing",
        _ => "unrecognised error code",
    }
}

/// The pending error of `raw` (NULL asks for the error of a failed
/// `rtcNewDevice`), as a Rust error mentioning `what` was being done.
fn take_error(raw: ffi::RTCDevice, what: &str) -> Result<()> {
    // SAFETY: `raw` is a live device or NULL, both accepted by rtcGetDeviceError.
    let code = unsafe { ffi::rtcGetDeviceError(raw) };
    if code == ffi::RTC_ERROR_NONE {
        return Ok(());
    }
    // SAFETY: as above; the returned string is owned by Embree, NUL-terminated,
    // and valid until the next API call on this thread: it is copied at once.
    let msg = unsafe {
        let p = ffi::rtcGetDeviceLastErrorMessage(raw);
        if p.is_null() { String::new() } else { CStr::from_ptr(p).to_string_lossy().into_owned() }
    };
    let detail = if msg.is_empty() { String::new() } else { format!(": {msg}") };
    Err(Error::Invalid(format!("Embree: {what} failed ({}, code {code}){detail}", error_name(code))))
}

impl Device {
    /// A new device with Embree's configuration string `config` (e.g.
    /// `"threads=1"`; empty for the defaults). The string is passed
    /// NUL-terminated; an interior NUL or a configuration Embree rejects is
    /// an error.
    pub fn new(config: &str) -> Result<Self> {
        let dev = Self::unmonitored(config)?;
        // SAFETY: live device; the payload outlives the device (see `count_memory`).
        unsafe {
            ffi::rtcSetDeviceMemoryMonitorFunction(
                dev.raw,
                Some(count_memory),
                Arc::as_ptr(&dev.memory).cast_mut().cast(),
            );
        }
        dev.check("registering the memory monitor")?;
        Ok(dev)
    }

    /// [`Device::new`] without the memory monitor, as Embree's users make a
    /// device (timing: the monitor is a call per allocation of the build);
    /// [`Device::memory_bytes`] then stays 0.
    pub fn unmonitored(config: &str) -> Result<Self> {
        let c = CString::new(config)
            .map_err(|_| Error::Invalid(format!("Embree device config {config:?} contains a NUL byte")))?;
        // SAFETY: `c` is a valid NUL-terminated string that outlives the call.
        let raw = unsafe { ffi::rtcNewDevice(c.as_ptr()) };
        if raw.is_null() {
            take_error(std::ptr::null_mut(), &format!("creating a device with config {config:?}"))?;
            return Err(Error::Invalid(format!("Embree: creating a device with config {config:?} failed")));
        }
        let dev = Self { raw, memory: Arc::new(AtomicI64::new(0)) };
        dev.check(&format!("creating a device with config {config:?}"))?;
        Ok(dev)
    }

    /// Bytes of memory the device holds now (buffers, acceleration
    /// structures, and any build scratch not yet released), as Embree's
    /// memory monitor reports them.
    pub fn memory_bytes(&self) -> i64 {
        self.memory.load(Ordering::Relaxed)
    }

    /// The raw handle (valid while `self` lives).
    pub fn raw(&self) -> ffi::RTCDevice {
        self.raw
    }

    /// Turn this device's pending error, if any, into a Rust error.
    pub fn check(&self, what: &str) -> Result<()> {
        take_error(self.raw, what)
    }

    /// Embree's version as `major * 10000 + minor * 100 + patch` (40400 for 4.4.0).
    pub fn version(&self) -> Result<u32> {
        // SAFETY: `self.raw` is a live device; the property id is valid.
        let v = unsafe { ffi::rtcGetDeviceProperty(self.raw, ffi::RTC_DEVICE_PROPERTY_VERSION) };
        self.check("reading the device version")?;
        u32::try_from(v).map_err(|_| Error::Invalid(format!("Embree reported an invalid version {v}")))
    }
}

impl Clone for Device {
    /// Another owner of the same device (reference counted by Embree).
    fn clone(&self) -> Self {
        // SAFETY: `raw` is live; the matching release happens in `Drop`.
        unsafe { ffi::rtcRetainDevice(self.raw) };
        Self { raw: self.raw, memory: self.memory.clone() }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewDevice and is released exactly once.
        unsafe { ffi::rtcReleaseDevice(self.raw) };
    }
}
