//! Embree behind rtdiff's [`Tracer`] trait.
//!
//! Interval semantics: rtdiff accepts hits with `t_min <= t <= t_max`. With
//! `RTC_SCENE_FLAG_ROBUST` Embree 4.4 intersects triangles with its Pluecker
//! test, whose depth test is `tnear <= t && t <= tfar`: the same closed
//! interval. Its sphere test (`SphereIntersector1`) uses the open interval
//! `tnear < t < tfar`; the two differ only for hits exactly at an end point
//! (a set of measure zero that no ray set aims at).

use std::sync::Arc;

use glam::Vec3;

use crate::accel::{EmbreeQuality, Tracer};
use crate::error::Result;
use crate::geometry::{Hit, Primitives, Ray};

use super::scene::{SPHERE_GEOM_ID, TRIANGLE_GEOM_ID};
use super::{Device, Scene, ffi};

/// Closest-hit and occlusion queries answered by Embree.
pub struct EmbreeTracer {
    scene: Scene,
    prims: Arc<Primitives>,
    quality: EmbreeQuality,
}

impl EmbreeTracer {
    /// Build over `prims` on a new device with Embree's default configuration.
    pub fn new(prims: Arc<Primitives>, quality: EmbreeQuality) -> Result<Self> {
        Self::with_device(&Device::new("")?, prims, quality)
    }

    /// Build over `prims` on `device` (e.g. one made with `"threads=1"` for timing).
    pub fn with_device(device: &Device, prims: Arc<Primitives>, quality: EmbreeQuality) -> Result<Self> {
        let scene = Scene::new(device, &prims, quality)?;
        Ok(Self { scene, prims, quality })
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

impl Tracer for EmbreeTracer {
    fn name(&self) -> String {
        let q = match self.quality {
            EmbreeQuality::Low => "low",
            EmbreeQuality::Medium => "medium",
            EmbreeQuality::High => "high",
        };
        format!("embree-{q}")
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if ray.t_min > ray.t_max {
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
        match h.geomID {
            TRIANGLE_GEOM_ID => Some(Hit { t: rh.ray.tfar, prim: h.primID, u: h.u, v: h.v }),
            SPHERE_GEOM_ID => {
                // Embree reports u = v = 0 on spheres: compute rtdiff's
                // longitude / colatitude parameterisation from the hit point.
                let s = self.prims.spheres[h.primID as usize];
                let t = rh.ray.tfar;
                let n: Vec3 = (ray.at(t) - s.center) / s.radius;
                let u = (n.z.atan2(n.x) / std::f32::consts::TAU).rem_euclid(1.0);
                let v = n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
                Some(Hit { t, prim: self.prims.triangles.len() as u32 + h.primID, u, v })
            }
            _ => None,
        }
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if ray.t_min > ray.t_max {
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
