//! A committed Embree scene built from rtdiff's primitives.

use super::{EmbreeMode, EmbreeQuality};
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Primitives};

use super::{Device, ffi};

/// Geometry id of the triangles (primitive id = triangle index).
pub const TRIANGLE_GEOM_ID: u32 = 0;
/// Geometry id of the spheres (`RTC_GEOMETRY_TYPE_SPHERE_POINT`; primitive id
/// = sphere index, so rtdiff's global id is `triangles.len() + primID`).
pub const SPHERE_GEOM_ID: u32 = 1;

/// A committed, immutable Embree scene (`RTCScene`), built with
/// `RTC_SCENE_FLAG_ROBUST` unless asked for Embree's default flags.
#[derive(Debug)]
pub struct Scene {
    raw: ffi::RTCScene,
    device: Device,
    quality: i32,
    memory: SceneMemory,
}

/// What a scene's construction added to its device's memory (Embree's memory
/// monitor, [`Device::memory_bytes`]; exact when no other scene of the device
/// is built or released meanwhile).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneMemory {
    /// The geometry buffers (Embree's own copy of the vertices and indices).
    pub geometry_bytes: i64,
    /// What `rtcCommitScene` kept: the acceleration structure (nodes and leaf
    /// primitives), net of the scratch the build released.
    pub bvh_bytes: i64,
}

// SAFETY: a committed scene is only read (rtcIntersect1 / rtcOccluded1 /
// rtcGetSceneBounds), which Embree documents as thread-safe; nothing mutates
// it after `Scene::new` returns.
unsafe impl Send for Scene {}
// SAFETY: see `Send`.
unsafe impl Sync for Scene {}

fn quality_code(q: EmbreeQuality) -> i32 {
    match q {
        EmbreeQuality::Low => ffi::RTC_BUILD_QUALITY_LOW,
        EmbreeQuality::Medium => ffi::RTC_BUILD_QUALITY_MEDIUM,
        EmbreeQuality::High => ffi::RTC_BUILD_QUALITY_HIGH,
    }
}

/// Owns an `RTCGeometry` until it is attached (released on every path).
struct GeomGuard(ffi::RTCGeometry);

impl Drop for GeomGuard {
    fn drop(&mut self) {
        // SAFETY: the handle came from rtcNewGeometry; after attaching, the
        // scene holds its own reference, so releasing ours is always correct.
        unsafe { ffi::rtcReleaseGeometry(self.0) };
    }
}

impl Scene {
    /// Build a scene over `prims` on `device` with build quality `quality`
    /// and the robust flag. Triangles are geometry 0 (one vertex triple per
    /// triangle, so ids and vertex order match rtdiff's exactly), spheres
    /// geometry 1.
    pub fn new(device: &Device, prims: &Primitives, quality: EmbreeQuality) -> Result<Self> {
        Self::with_mode(device, prims, quality, EmbreeMode::Robust)
    }

    /// [`Scene::new`] with the scene flags of `mode`.
    pub fn with_mode(device: &Device, prims: &Primitives, quality: EmbreeQuality, mode: EmbreeMode) -> Result<Self> {
        let nt = prims.triangles.len();
        let ns = prims.spheres.len();
        if nt > (u32::MAX / 3) as usize || ns >= u32::MAX as usize {
            return Err(Error::Invalid(format!("too many primitives for Embree ({nt} triangles, {ns} spheres)")));
        }
        let mut scene = Self::empty(device, quality, mode)?;
        let start = device.memory_bytes();
        if nt > 0 {
            scene.attach_triangles(prims)?;
        }
        if ns > 0 {
            scene.attach_spheres(prims)?;
        }
        scene.commit(start)?;
        Ok(scene)
    }

    /// A scene of one indexed triangle mesh (geometry 0), as Embree's users
    /// hand it over: `positions` once each and three indices per triangle
    /// (primitive id = triangle index), built with `quality` and the flags
    /// of `mode`. Spheres have no indexed form here: use [`Scene::with_mode`].
    pub fn indexed(
        device: &Device,
        positions: &[glam::Vec3],
        indices: &[[u32; 3]],
        quality: EmbreeQuality,
        mode: EmbreeMode,
    ) -> Result<Self> {
        if indices.len() > u32::MAX as usize || positions.len() > u32::MAX as usize {
            return Err(Error::Invalid(format!("too many triangles for Embree ({})", indices.len())));
        }
        if let Some(t) = indices.iter().find(|t| t.iter().any(|&i| i as usize >= positions.len())) {
            return Err(Error::Invalid(format!("triangle {t:?} names a vertex beyond the {} given", positions.len())));
        }
        let mut scene = Self::empty(device, quality, mode)?;
        let start = device.memory_bytes();
        if !indices.is_empty() {
            let g = scene.new_geometry(ffi::RTC_GEOMETRY_TYPE_TRIANGLE)?;
            let vb = scene.new_buffer(&g, ffi::RTC_BUFFER_TYPE_VERTEX, ffi::RTC_FORMAT_FLOAT3, 12, positions.len())?;
            // SAFETY: Embree returned a buffer of `positions.len()` items of 12 bytes (f32 x 3).
            let verts = unsafe { std::slice::from_raw_parts_mut(vb.cast::<[f32; 3]>(), positions.len()) };
            for (v, p) in verts.iter_mut().zip(positions) {
                *v = p.to_array();
            }
            let ib = scene.new_buffer(&g, ffi::RTC_BUFFER_TYPE_INDEX, ffi::RTC_FORMAT_UINT3, 12, indices.len())?;
            // SAFETY: as above, `indices.len()` items of 3 x u32.
            unsafe { std::slice::from_raw_parts_mut(ib.cast::<[u32; 3]>(), indices.len()) }.copy_from_slice(indices);
            scene.commit_and_attach(g, TRIANGLE_GEOM_ID)?;
        }
        scene.commit(start)?;
        Ok(scene)
    }

    /// A new scene with `quality` and the flags of `mode`, nothing attached.
    fn empty(device: &Device, quality: EmbreeQuality, mode: EmbreeMode) -> Result<Self> {
        // SAFETY: `device.raw()` is a live device.
        let raw = unsafe { ffi::rtcNewScene(device.raw()) };
        device.check("creating a scene")?;
        if raw.is_null() {
            return Err(Error::Invalid("Embree: rtcNewScene returned NULL".into()));
        }
        // Keep our own reference to the device for error checks.
        let scene =
            Self { raw, device: device.clone(), quality: quality_code(quality), memory: SceneMemory::default() };
        // SAFETY: `raw` is a live, uncommitted scene; flag and quality are valid enum values.
        unsafe {
            let flags = match mode {
                EmbreeMode::Robust => ffi::RTC_SCENE_FLAG_ROBUST,
                EmbreeMode::Default => ffi::RTC_SCENE_FLAG_NONE,
            };
            ffi::rtcSetSceneFlags(raw, flags);
            ffi::rtcSetSceneBuildQuality(raw, quality_code(quality));
        }
        device.check("setting scene flags and build quality")?;
        Ok(scene)
    }

    /// Commit (build) the scene whose geometries were attached after the
    /// device held `start` bytes, and record what each part took.
    fn commit(&mut self, start: i64) -> Result<()> {
        let attached = self.device.memory_bytes();
        // SAFETY: `raw` is a live scene whose geometries are committed.
        unsafe { ffi::rtcCommitScene(self.raw) };
        self.device.check("committing the scene (BVH build)")?;
        self.memory =
            SceneMemory { geometry_bytes: attached - start, bvh_bytes: self.device.memory_bytes() - attached };
        Ok(())
    }

    fn new_geometry(&self, kind: i32) -> Result<GeomGuard> {
        // SAFETY: live device; `kind` is a valid RTCGeometryType.
        let g = unsafe { ffi::rtcNewGeometry(self.device.raw(), kind) };
        self.device.check("creating a geometry")?;
        if g.is_null() {
            return Err(Error::Invalid("Embree: rtcNewGeometry returned NULL".into()));
        }
        Ok(GeomGuard(g))
    }

    /// Allocate an Embree-owned buffer of `count` items of `stride` bytes.
    fn new_buffer(&self, g: &GeomGuard, kind: i32, format: i32, stride: usize, count: usize) -> Result<*mut u8> {
        // SAFETY: live geometry; Embree allocates (and pads) the buffer itself.
        let p = unsafe { ffi::rtcSetNewGeometryBuffer(g.0, kind, 0, format, stride, count) };
        self.device.check("allocating a geometry buffer")?;
        if p.is_null() {
            return Err(Error::Invalid("Embree: rtcSetNewGeometryBuffer returned NULL".into()));
        }
        Ok(p.cast())
    }

    fn commit_and_attach(&self, g: GeomGuard, id: u32) -> Result<()> {
        // SAFETY: live geometry and scene; `id` is unused in this scene; the
        // quality is a valid RTCBuildQuality.
        unsafe {
            // Geometries default to MEDIUM; the scene's quality alone does not
            // select the HIGH (spatial split) builder for their primitives.
            ffi::rtcSetGeometryBuildQuality(g.0, self.quality);
            ffi::rtcCommitGeometry(g.0);
            ffi::rtcAttachGeometryByID(self.raw, g.0, id);
        }
        self.device.check("committing and attaching a geometry")
    }

    fn attach_triangles(&self, prims: &Primitives) -> Result<()> {
        let nt = prims.triangles.len();
        let g = self.new_geometry(ffi::RTC_GEOMETRY_TYPE_TRIANGLE)?;
        let vb = self.new_buffer(&g, ffi::RTC_BUFFER_TYPE_VERTEX, ffi::RTC_FORMAT_FLOAT3, 12, 3 * nt)?;
        // SAFETY: Embree returned a buffer of 3 * nt items of 12 bytes (f32 x 3),
        // 16-byte aligned and exclusively ours until commit.
        let verts = unsafe { std::slice::from_raw_parts_mut(vb.cast::<[f32; 3]>(), 3 * nt) };
        for (i, t) in prims.triangles.iter().enumerate() {
            for k in 0..3 {
                verts[3 * i + k] = t.v[k].to_array();
            }
        }
        let ib = self.new_buffer(&g, ffi::RTC_BUFFER_TYPE_INDEX, ffi::RTC_FORMAT_UINT3, 12, nt)?;
        // SAFETY: as above, nt items of 3 x u32.
        let idx = unsafe { std::slice::from_raw_parts_mut(ib.cast::<[u32; 3]>(), nt) };
        for (i, tri) in idx.iter_mut().enumerate() {
            let b = 3 * i as u32;
            *tri = [b, b + 1, b + 2];
        }
        self.commit_and_attach(g, TRIANGLE_GEOM_ID)
    }

    fn attach_spheres(&self, prims: &Primitives) -> Result<()> {
        let ns = prims.spheres.len();
        let g = self.new_geometry(ffi::RTC_GEOMETRY_TYPE_SPHERE_POINT)?;
        let vb = self.new_buffer(&g, ffi::RTC_BUFFER_TYPE_VERTEX, ffi::RTC_FORMAT_FLOAT4, 16, ns)?;
        // SAFETY: Embree returned a buffer of ns items of 16 bytes (x, y, z, radius).
        let pts = unsafe { std::slice::from_raw_parts_mut(vb.cast::<[f32; 4]>(), ns) };
        for (p, s) in pts.iter_mut().zip(&prims.spheres) {
            *p = [s.center.x, s.center.y, s.center.z, s.radius];
        }
        self.commit_and_attach(g, SPHERE_GEOM_ID)
    }

    /// The raw handle (valid while `self` lives).
    pub fn raw(&self) -> ffi::RTCScene {
        self.raw
    }

    /// What building the scene added to its device's memory.
    pub fn memory(&self) -> SceneMemory {
        self.memory
    }

    /// The device the scene was built on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Bounds of the committed scene as Embree sees them.
    pub fn bounds(&self) -> Result<Aabb> {
        let mut b = ffi::RTCBounds::default();
        // SAFETY: committed scene; `b` is a properly aligned RTCBounds.
        unsafe { ffi::rtcGetSceneBounds(self.raw, &mut b) };
        self.device.check("reading the scene bounds")?;
        Ok(Aabb::new(
            glam::Vec3::new(b.lower_x, b.lower_y, b.lower_z),
            glam::Vec3::new(b.upper_x, b.upper_y, b.upper_z),
        ))
    }
}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewScene and is released exactly once.
        unsafe { ffi::rtcReleaseScene(self.raw) };
    }
}
