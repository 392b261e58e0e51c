//! A plugin's scene behind rtdiff's [`Tracer`] interface.

use std::ffi::c_void;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use super::ffi::{INVALID_ID, RtdiffHit, RtdiffRay};
use super::{Plugin, PluginId};
use crate::accel::Tracer;
use crate::error::{Error, Result};
use crate::geometry::{Hit, Primitives, Ray};

/// One scene of a plugin over rtdiff's primitives: triangle `i` is primitive
/// `i` (three vertices of its own each, in rtdiff's vertex order), sphere `j`
/// primitive `triangles + j`. Answers are the plugin's, unchecked (a hit may
/// name a primitive that does not exist: [`Hit::fault`]); rays that are not
/// [`Ray::is_traceable`] miss without a call, as in every rtdiff tracer.
pub struct PluginTracer {
    plugin: &'static Plugin,
    scene: *mut c_void,
}

// SAFETY: the ABI requires the queries to be callable from several threads at
// once on one scene (they only read it); the scene is freed once, by `Drop`.
unsafe impl Send for PluginTracer {}
// SAFETY: see `Send`.
unsafe impl Sync for PluginTracer {}

impl Drop for PluginTracer {
    fn drop(&mut self) {
        // SAFETY: `scene` came from this plugin's `rtdiff_tracer_scene_new` and is freed once.
        unsafe { (self.plugin.fns.scene_free)(self.scene) };
    }
}

fn to_c(r: &Ray) -> RtdiffRay {
    RtdiffRay { org: r.origin.to_array(), dir: r.dir.to_array(), tnear: r.t_min, tfar: r.t_max }
}

fn from_c(h: &RtdiffHit) -> Option<Hit> {
    (h.prim != INVALID_ID).then_some(Hit { t: h.t, prim: h.prim, u: h.u, v: h.v })
}

/// rtdiff's primitives in the ABI's buffers: three vertices of its own per triangle
/// (`vertices`, `indices` = 0, 1, 2, ...), spheres as centre and radius.
pub struct PluginBuffers {
    vertices: Vec<f32>,
    indices: Vec<u32>,
    sphere_data: Vec<f32>,
    triangles: u32,
    spheres: u32,
}

impl PluginBuffers {
    /// The buffers of `prims`; an error when they exceed the ABI's 32-bit counts.
    pub fn new(prims: &Primitives) -> Result<Self> {
        let (nt, ns) = (prims.triangles.len(), prims.spheres.len());
        if 3 * nt as u64 > u32::MAX as u64 || (nt + ns) as u64 >= u32::MAX as u64 {
            return Err(Error::Invalid(format!(
                "too many primitives for the plugin ABI ({nt} triangles, {ns} spheres)"
            )));
        }
        Ok(Self {
            vertices: prims.triangles.iter().flat_map(|t| t.v).flat_map(|v| v.to_array()).collect(),
            indices: (0..3 * nt as u32).collect(),
            sphere_data: prims.spheres.iter().flat_map(|s| [s.center.x, s.center.y, s.center.z, s.radius]).collect(),
            triangles: nt as u32,
            spheres: ns as u32,
        })
    }
}

/// A miss, for the plugin to overwrite.
const MISS: RtdiffHit = RtdiffHit { t: f32::INFINITY, prim: INVALID_ID, u: 0.0, v: 0.0 };

impl PluginTracer {
    /// Build the plugin's scene over `prims`. Errors: spheres for a plugin
    /// without `RTDIFF_FEATURE_SPHERES`, too many primitives for the ABI's
    /// 32-bit counts, and the plugin's own refusal (its message).
    pub fn new(id: PluginId, prims: &Primitives) -> Result<Self> {
        Self::from_buffers(id, &PluginBuffers::new(prims)?)
    }

    /// Build the plugin's scene from buffers made beforehand ([`PluginBuffers::new`]): the
    /// plugin's build alone, for a timing loop.
    pub fn from_buffers(id: PluginId, b: &PluginBuffers) -> Result<Self> {
        let plugin = id.plugin();
        if b.spheres > 0 && !plugin.spheres() {
            return Err(Error::Invalid(format!(
                "{} traces triangles only (no RTDIFF_FEATURE_SPHERES), and this scene has {} spheres",
                plugin.label(),
                b.spheres
            )));
        }
        let mut error = vec![0u8; 1024];
        // SAFETY: the buffers hold the counts given and live through the call;
        // `error` has `error.len()` writable bytes.
        let scene = unsafe {
            (plugin.fns.scene_new)(
                b.vertices.as_ptr(),
                3 * b.triangles,
                b.indices.as_ptr(),
                b.triangles,
                if b.spheres > 0 { b.sphere_data.as_ptr() } else { std::ptr::null() },
                b.spheres,
                error.as_mut_ptr().cast(),
                error.len(),
            )
        };
        if scene.is_null() {
            error[1023] = 0;
            let end = error.iter().position(|&b| b == 0).unwrap_or(0);
            let msg = String::from_utf8_lossy(&error[..end]);
            let msg = if msg.is_empty() { "no message".into() } else { msg };
            return Err(Error::Invalid(format!("{} could not build the scene: {msg}", plugin.label())));
        }
        Ok(Self { plugin, scene })
    }

    /// The plugin.
    pub fn plugin(&self) -> &'static Plugin {
        self.plugin
    }

    /// `rays` in the ABI's layout, converted once (for a timing loop that should time the
    /// plugin's queries, not the conversion: [`PluginTracer::intersect_c`]).
    pub fn c_rays(rays: &[Ray]) -> Vec<RtdiffRay> {
        rays.iter().map(to_c).collect()
    }

    /// `rtdiff_tracer_intersect_n` on rays already in the ABI's layout, hits as the plugin writes them.
    ///
    /// # Panics
    /// When `rays` and `hits` differ in length.
    pub fn intersect_c(&self, rays: &[RtdiffRay], hits: &mut [RtdiffHit]) {
        assert_eq!(rays.len(), hits.len(), "intersect_c: one hit per ray");
        // SAFETY: a live scene; both buffers hold `rays.len()` items.
        unsafe { (self.plugin.fns.intersect_n)(self.scene, rays.as_ptr(), hits.as_mut_ptr(), rays.len()) };
    }
}

impl Tracer for PluginTracer {
    fn name(&self) -> String {
        self.plugin.label()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_traceable() {
            return None;
        }
        let mut h = MISS;
        // SAFETY: a live scene of this plugin; one ray in, one hit out.
        unsafe { (self.plugin.fns.intersect1)(self.scene, &to_c(ray), &mut h) };
        from_c(&h)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_traceable() {
            return false;
        }
        // SAFETY: a live scene of this plugin; one ray in.
        unsafe { (self.plugin.fns.occluded1)(self.scene, &to_c(ray)) != 0 }
    }

    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), out.len(), "intersect_batch: one answer per ray");
        let c: Vec<RtdiffRay> = rays.iter().map(to_c).collect();
        let mut hits = vec![MISS; rays.len()];
        // SAFETY: a live scene; `c` and `hits` hold `rays.len()` items each.
        unsafe { (self.plugin.fns.intersect_n)(self.scene, c.as_ptr(), hits.as_mut_ptr(), c.len()) };
        for ((o, h), r) in out.iter_mut().zip(&hits).zip(rays) {
            *o = if r.is_traceable() { from_c(h) } else { None };
        }
    }

    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "occluded_batch: one answer per ray");
        let c: Vec<RtdiffRay> = rays.iter().map(to_c).collect();
        let mut occ = vec![0u8; rays.len()];
        // SAFETY: a live scene; `c` and `occ` hold `rays.len()` items each.
        unsafe { (self.plugin.fns.occluded_n)(self.scene, c.as_ptr(), occ.as_mut_ptr(), c.len()) };
        for ((o, &x), r) in out.iter_mut().zip(&occ).zip(rays) {
            *o = r.is_traceable() && x != 0;
        }
    }
}

/// A [`PluginTracer`] for renders: a hit with a [`Hit::fault`] (an id that
/// names no primitive, a distance outside the interval, NaN) is taken as a
/// miss, and the first one is reported on stderr with the ray, so that a
/// render never indexes a primitive that does not exist. The harness uses the
/// unchecked tracer and judges such hits wrong.
pub struct Checked {
    inner: PluginTracer,
    prims: Arc<Primitives>,
    warned: AtomicBool,
}

impl Checked {
    /// `inner`, checked against `prims` (the primitives it was built over).
    pub fn new(inner: PluginTracer, prims: Arc<Primitives>) -> Self {
        Self { inner, prims, warned: AtomicBool::new(false) }
    }

    fn check(&self, ray: &Ray, h: Option<Hit>) -> Option<Hit> {
        let h = h?;
        match h.fault(ray, self.prims.len()) {
            None => Some(h),
            Some(f) => {
                if !self.warned.swap(true, Ordering::Relaxed) {
                    eprintln!(
                        "rtdiff: warning: {} returned an invalid hit ({}: t {}, primitive {}, u {}, v {}) for the ray \
                         {},{},{},{},{},{},{},{} (ox,oy,oz,dx,dy,dz,tnear,tfar); invalid hits render as misses \
                         (rtdiff parity --tracer plugin:... judges them)",
                        self.inner.name(),
                        f.name(),
                        h.t,
                        h.prim,
                        h.u,
                        h.v,
                        ray.origin.x,
                        ray.origin.y,
                        ray.origin.z,
                        ray.dir.x,
                        ray.dir.y,
                        ray.dir.z,
                        ray.t_min,
                        ray.t_max
                    );
                }
                None
            }
        }
    }
}

impl Tracer for Checked {
    fn name(&self) -> String {
        self.inner.name()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.check(ray, self.inner.intersect(ray))
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.inner.occluded(ray)
    }

    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.inner.intersect_batch(rays, out);
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.check(r, *o);
        }
    }

    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        self.inner.occluded_batch(rays, out);
    }
}
