//! Embree behind rtdiff's [`Tracer`] trait.
//!
//! Interval semantics: rtdiff accepts hits with `t_min <= t <= t_max`. With
//! `RTC_SCENE_FLAG_ROBUST` Embree 4.4 intersects triangles with its Pluecker
//! test, whose depth test is `tnear <= t && t <= tfar`: the same closed
//! interval. Its sphere test (`SphereIntersector1`) uses the open interval
//! `tnear < t < tfar`; the two differ only for hits exactly at an end point
//! (a set of measure zero that no ray set aims at).
//!
//! Rays that are not [`Ray::is_traceable`] never reach Embree: its kernels
//! assume valid rays (unless built with `EMBREE_IGNORE_INVALID_RAYS`), and a
//! NaN direction crashes `rtcIntersect1`. They hit nothing, as in every tracer.

use std::sync::Arc;

use glam::Vec3;

use super::{EmbreeMode, EmbreeQuality, embree_label};
use crate::accel::Tracer;
use crate::error::Result;
use crate::geometry::{Hit, Primitives, Ray};

use super::scene::{SPHERE_GEOM_ID, TRIANGLE_GEOM_ID};
use super::{Device, Scene, ffi};

/// Closest-hit and occlusion queries answered by Embree.
pub struct EmbreeTracer {
    scene: Scene,
    prims: Arc<Primitives>,
    quality: EmbreeQuality,
    mode: EmbreeMode,
}

impl EmbreeTracer {
    /// Build over `prims` on a new device with Embree's default configuration.
    pub fn new(prims: Arc<Primitives>, quality: EmbreeQuality) -> Result<Self> {
        Self::with_device(&Device::new("")?, prims, quality)
    }

    /// Build over `prims` on `device` (e.g. one made with `"threads=1"` for timing).
    pub fn with_device(device: &Device, prims: Arc<Primitives>, quality: EmbreeQuality) -> Result<Self> {
        Self::with_mode(device, prims, quality, EmbreeMode::Robust)
    }

    /// Build over `prims` on `device` with the scene flags of `mode`.
    pub fn with_mode(
        device: &Device,
        prims: Arc<Primitives>,
        quality: EmbreeQuality,
        mode: EmbreeMode,
    ) -> Result<Self> {
        let scene = Scene::with_mode(device, &prims, quality, mode)?;
        Ok(Self { scene, prims, quality, mode })
    }

    /// The underlying scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    fn rtc_ray(ray: &Ray) -> ffi::RTCRay {
        ffi::RTCRay {
            org_x: ray.origin.x,
            org_y: ray.origin.y,
            org_z: ray.origin.z,
            tnear: ray.t_min,
            dir_x: ray.dir.x,
            dir_y: ray.dir.y,
            dir_z: ray.dir.z,
            time: 0.0,
            tfar: ray.t_max,
            // Embree 4 gives geometries mask 1 by default: accept every geometry.
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }
}

impl EmbreeTracer {
    fn convert_hit(&self, ray: &Ray, t: f32, geom: u32, prim: u32, u: f32, v: f32) -> Option<Hit> {
        match geom {
            TRIANGLE_GEOM_ID => Some(Hit { t, prim, u, v }),
            SPHERE_GEOM_ID => {
                // Embree reports u = v = 0 on spheres: compute rtdiff's
                // longitude / colatitude parameterisation from the hit point.
                let s = self.prims.spheres[prim as usize];
                let n: Vec3 = (ray.at(t) - s.center) / s.radius;
                let u = (n.z.atan2(n.x) / std::f32::consts::TAU).rem_euclid(1.0);
                let v = n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
                Some(Hit { t, prim: self.prims.sphere_id(prim as usize), u, v })
            }
            _ => None,
        }
    }

    /// Write `rays` (at most 8) into the lanes of `r8`; the mask marks the
    /// lanes to trace (rays that are not [`Ray::is_traceable`] stay inactive).
    fn rtc_ray8(rays: &[Ray], r8: &mut ffi::RTCRay8) -> ffi::Valid8 {
        let mut valid = ffi::Valid8::default();
        for (k, r) in rays.iter().enumerate() {
            if !r.is_traceable() {
                continue;
            }
            valid.0[k] = -1;
            (r8.org_x[k], r8.org_y[k], r8.org_z[k]) = (r.origin.x, r.origin.y, r.origin.z);
            (r8.dir_x[k], r8.dir_y[k], r8.dir_z[k]) = (r.dir.x, r.dir.y, r.dir.z);
            (r8.tnear[k], r8.tfar[k], r8.mask[k]) = (r.t_min, r.t_max, u32::MAX);
        }
        valid
    }

    /// Closest hits of up to 8 rays with one `rtcIntersect8` call (lanes
    /// beyond `rays.len()` are inactive). Same answers as [`Tracer::intersect`].
    pub fn intersect8(&self, rays: &[Ray]) -> [Option<Hit>; 8] {
        assert!(rays.len() <= 8, "intersect8 takes at most 8 rays");
        let mut rh = ffi::RTCRayHit8::default();
        let valid = Self::rtc_ray8(rays, &mut rh.ray);
        rh.hit.geomID = [ffi::RTC_INVALID_GEOMETRY_ID; 8];
        // SAFETY: committed scene; `valid` and `rh` are 32-byte aligned and
        // laid out as the 4.4 RTCRayHit8 (672 bytes, asserted in ffi.rs);
        // inactive lanes are not read or written by Embree.
        unsafe { ffi::rtcIntersect8(&valid, self.scene.raw(), &mut rh, std::ptr::null_mut()) };
        let mut out = [None; 8];
        for (k, r) in rays.iter().enumerate() {
            if valid.0[k] != 0 {
                let h = &rh.hit;
                out[k] = self.convert_hit(r, rh.ray.tfar[k], h.geomID[k], h.primID[k], h.u[k], h.v[k]);
            }
        }
        out
    }

    /// Occlusion of up to 8 rays with one `rtcOccluded8` call.
    pub fn occluded8(&self, rays: &[Ray]) -> [bool; 8] {
        assert!(rays.len() <= 8, "occluded8 takes at most 8 rays");
        let mut r8 = ffi::RTCRay8::default();
        let valid = Self::rtc_ray8(rays, &mut r8);
        // SAFETY: as in `intersect8`, with the 384-byte RTCRay8.
        unsafe { ffi::rtcOccluded8(&valid, self.scene.raw(), &mut r8, std::ptr::null_mut()) };
        std::array::from_fn(|k| valid.0[k] != 0 && r8.tfar[k] == f32::NEG_INFINITY)
    }
}

impl Tracer for EmbreeTracer {
    fn name(&self) -> String {
        embree_label(self.quality, self.mode)
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_traceable() {
            return None;
        }
        let mut rh = ffi::RTCRayHit {
            ray: Self::rtc_ray(ray),
            hit: ffi::RTCHit {
                geomID: ffi::RTC_INVALID_GEOMETRY_ID,
                primID: ffi::RTC_INVALID_GEOMETRY_ID,
                instID: [ffi::RTC_INVALID_GEOMETRY_ID; ffi::RTC_MAX_INSTANCE_LEVEL_COUNT],
                instPrimID: [ffi::RTC_INVALID_GEOMETRY_ID; ffi::RTC_MAX_INSTANCE_LEVEL_COUNT],
                ..Default::default()
            },
        };
        // SAFETY: the scene is committed and alive for `&self`; `rh` is a
        // 16-byte aligned RTCRayHit of the 4.4 layout (96 bytes, asserted in
        // ffi.rs), so Embree's writes stay inside it; NULL arguments = defaults.
        unsafe { ffi::rtcIntersect1(self.scene.raw(), &mut rh, std::ptr::null_mut()) };
        let h = rh.hit;
        self.convert_hit(ray, rh.ray.tfar, h.geomID, h.primID, h.u, h.v)
    }

    /// Groups of eight rays through `rtcIntersect8` (Embree's 8-wide packets).
    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), out.len(), "intersect_batch: one answer per ray");
        for (r, o) in rays.chunks(8).zip(out.chunks_mut(8)) {
            o.copy_from_slice(&self.intersect8(r)[..r.len()]);
        }
    }

    /// Groups of eight rays through `rtcOccluded8`.
    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "occluded_batch: one answer per ray");
        for (r, o) in rays.chunks(8).zip(out.chunks_mut(8)) {
            o.copy_from_slice(&self.occluded8(r)[..r.len()]);
        }
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_traceable() {
            return false;
        }
        let mut r = Self::rtc_ray(ray);
        // SAFETY: committed scene; `r` is a 16-byte aligned 48-byte RTCRay
        // (unchanged between 4.2 and 4.4); NULL arguments = defaults.
        unsafe { ffi::rtcOccluded1(self.scene.raw(), &mut r, std::ptr::null_mut()) };
        // Embree sets tfar to -inf when anything is hit.
        r.tfar == f32::NEG_INFINITY
    }
}
