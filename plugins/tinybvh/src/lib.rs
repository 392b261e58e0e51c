//! tinybvh 1.6.8 (Jacco Bikker's C++ library, through the `tinybvh-rs` crate) as an
//! rtdiff tracer plugin: `BVH::Build` (binned SAH, Wald layout) and `BVH::Intersect`,
//! the library's defaults (Moller-Trumbore triangle test). docs/plugins.md.
//!
//! tinybvh normalises the ray direction and has no `tnear`: distances are scaled
//! back by the direction's length, the interval's end is passed as the initial
//! `hit.t`, and a `tnear` above 0 is not honoured (a hit before it is returned as
//! tinybvh found it; rtdiff's ray sets start every interval at 0).
//!
//! tinybvh-rs 0.1.0-beta.3's `Ray` (64 bytes, 16-aligned, `hit.t` at offset 48) does not
//! match the `Ray` of the tiny_bvh.h it vendors (1.6.8: `ALIGNED(64)`, 128 bytes, the
//! packed `Intersection` at 44 starting with `uint32_t inst`, then `auxData` and 56 bytes
//! of user data): `tinybvh_rs::Ray::new` and `Intersector::intersect` write 128 bytes into
//! the 64-byte Rust value and smash the stack (a crash on the first ray). This wrapper builds the ray in the C++ layout itself ([`CRay`],
//! what tinybvh's `Ray` constructor computes) and hands tinybvh a pointer to it.

use rtdiff_plugin_abi::{Hit, INVALID_ID, Ray, Tracer};
use tinybvh_rs::{Intersector, bvh};

/// A tinybvh BVH over a copy of the triangles (tinybvh keeps a reference to them).
struct TinyScene {
    bvh: Option<bvh::BVH<'static>>,
    verts: *mut [[f32; 4]],
}

// SAFETY: `BVH::Intersect` is a const method that only reads the nodes and the
// vertices; nothing mutates the scene after the build.
unsafe impl Sync for TinyScene {}
// SAFETY: see `Sync`; the scene owns its buffers.
unsafe impl Send for TinyScene {}

impl Drop for TinyScene {
    fn drop(&mut self) {
        self.bvh.take();
        // SAFETY: `verts` came from `Box::into_raw` in `build` and the BVH that borrowed it is gone.
        drop(unsafe { Box::from_raw(self.verts) });
    }
}

impl Tracer for TinyScene {
    const NAME: &'static std::ffi::CStr = c"tinybvh 1.6.8";
    const FEATURES: u32 = 0;

    fn build(triangles: Vec<[[f32; 3]; 3]>, _spheres: Vec<[f32; 4]>) -> Result<Self, String> {
        let verts: Box<[[f32; 4]]> =
            triangles.iter().flat_map(|t| t.iter().map(|v| [v[0], v[1], v[2], 0.0])).collect::<Vec<_>>().into();
        let verts = Box::into_raw(verts);
        if triangles.is_empty() {
            return Ok(Self { bvh: None, verts });
        }
        // SAFETY: the box lives until `Drop`, which drops the BVH first.
        let slice: &'static [[f32; 4]] = unsafe { &*verts };
        match bvh::BVH::new(slice.into()) {
            Ok(b) => Ok(Self { bvh: Some(b), verts }),
            Err(e) => {
                // SAFETY: not borrowed by anything any more.
                drop(unsafe { Box::from_raw(verts) });
                Err(format!("tinybvh: {e:?}"))
            }
        }
    }

    fn intersect(&self, ray: &Ray) -> Hit {
        let Some(bvh) = &self.bvh else { return Hit::MISS };
        let (mut r, len) = CRay::new(ray.org, ray.dir);
        let far = ray.tfar * len;
        r.t = if far < tinybvh_rs::INFINITE { far } else { tinybvh_rs::INFINITE };
        // tinybvh writes the primitive only when it registers a hit.
        r.prim = INVALID_ID;
        // SAFETY: `CRay` has the size, alignment and layout of tiny_bvh.h's `Ray`, which is what
        // the C++ `BVH::Intersect(Ray&)` behind this reference reads and writes.
        bvh.intersect(unsafe { &mut *(&mut r as *mut CRay).cast::<tinybvh_rs::Ray>() });
        if r.prim == INVALID_ID {
            return Hit::MISS;
        }
        Hit { t: r.t / len, prim: r.prim, u: r.u, v: r.v }
    }
}

/// tiny_bvh.h 1.6.8's `struct ALIGNED(64) Ray` with `INST_IDX_BITS == 32` (the default):
/// `O, mask, D, instIdx, rD` (16-aligned vectors), then the packed
/// `Intersection { inst, t, u, v, prim, auxData, user[56] }` at offset 44 (measured with
/// `offsetof` on the vendored header: size 128, `t` at 48, `prim` at 60).
#[repr(C, align(64))]
struct CRay {
    o: [f32; 3],
    mask: u32,
    d: [f32; 3],
    inst_idx: u32,
    rd: [f32; 3],
    inst: u32,
    t: f32,
    u: f32,
    v: f32,
    prim: u32,
    aux: [u32; 16],
}

const _: () = assert!(
    std::mem::size_of::<CRay>() == 128
        && std::mem::align_of::<CRay>() == 64
        && std::mem::offset_of!(CRay, t) == 48
        && std::mem::offset_of!(CRay, prim) == 60
);

impl CRay {
    /// What tinybvh's `Ray(origin, direction)` constructor computes: `D` normalised
    /// (`direction * (1 / length)`), `rD` its safe reciprocal, every other field 0 but the
    /// mask; and the direction's length.
    fn new(o: [f32; 3], d: [f32; 3]) -> (Self, f32) {
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let rl = if len == 0.0 { 0.0 } else { 1.0 / len };
        let dn = d.map(|x| x * rl);
        let safe_rcp = |x: f32| {
            if !(-1e-12..=1e-12).contains(&x) {
                1.0 / x
            } else if x >= 0.0 {
                tinybvh_rs::INFINITE
            } else {
                -tinybvh_rs::INFINITE
            }
        };
        let ray = Self {
            o,
            mask: 0xffff,
            d: dn,
            inst_idx: 0,
            rd: dn.map(safe_rcp),
            inst: 0,
            t: tinybvh_rs::INFINITE,
            u: 0.0,
            v: 0.0,
            prim: 0,
            aux: [0; 16],
        };
        (ray, len)
    }
}

rtdiff_plugin_abi::export_tracer!(TinyScene);
