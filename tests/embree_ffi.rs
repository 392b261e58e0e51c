//! The hand-written Embree bindings match the 4.4 library (layouts, version,
//! error reporting).
#![cfg(feature = "embree")]

use std::mem::{align_of, size_of};
use std::sync::Arc;

use glam::Vec3;
use rtdiff::accel::Tracer;
use rtdiff::backends::{AccelConfig, Backend, EmbreeQuality, build_tracer};
use rtdiff::embree::{Device, EmbreeTracer, ffi};
use rtdiff::geometry::{Primitives, Ray, Triangle, sphere::Sphere};

#[test]
fn struct_layouts_match_the_4_4_headers() {
    assert_eq!((size_of::<ffi::RTCRay>(), align_of::<ffi::RTCRay>()), (48, 16));
    assert_eq!((size_of::<ffi::RTCHit>(), align_of::<ffi::RTCHit>()), (36, 4));
    assert_eq!((size_of::<ffi::RTCRayHit>(), align_of::<ffi::RTCRayHit>()), (96, 16));
    assert_eq!(std::mem::offset_of!(ffi::RTCRayHit, hit), 48);
    assert_eq!(std::mem::offset_of!(ffi::RTCHit, instID), 28);
    assert_eq!(std::mem::offset_of!(ffi::RTCHit, instPrimID), 32);
    assert_eq!((size_of::<ffi::RTCBounds>(), align_of::<ffi::RTCBounds>()), (32, 16));
}

#[test]
fn device_reports_version_4_4_or_later() {
    let d = Device::new("threads=1").unwrap();
    let v = d.version().unwrap();
    assert!(v >= 40400, "Embree version {v}");
}

#[test]
fn bad_device_config_is_a_rust_error() {
    // Embree ignores unknown keys but rejects a malformed value.
    let e = Device::new("threads=abc").unwrap_err().to_string();
    assert!(e.contains("Embree") && e.contains("threads=abc") && e.contains("integer expected"), "{e}");
    let e = Device::new("a\0b").unwrap_err().to_string();
    assert!(e.contains("NUL"), "{e}");
}

#[test]
fn invalid_api_use_is_a_rust_error() {
    let d = Device::new("threads=1").unwrap();
    let t = EmbreeTracer::with_device(&d, one_triangle_and_sphere(), EmbreeQuality::Low).unwrap();
    assert!(d.check("nothing").is_ok());
    // SAFETY: a live scene; 99 is not a build quality, which Embree rejects
    // (it records an error and leaves the scene unchanged).
    unsafe { ffi::rtcSetSceneBuildQuality(t.scene().raw(), 99) };
    let e = d.check("setting quality 99").unwrap_err().to_string();
    assert!(e.contains("setting quality 99") && e.contains("invalid build quality"), "{e}");
    assert!(d.check("after the error was taken").is_ok());
}

#[test]
fn memory_monitor_counts_a_scene_and_its_release() {
    // 1,000 triangles: Embree's own copy of the geometry is exactly three
    // float3 vertices and one uint3 index triple per triangle (48 bytes; the
    // buffers may be padded by a few bytes), the BVH is more than nothing,
    // and releasing the scene gives everything back.
    let n = 1000;
    let triangles = (0..n)
        .map(|i| {
            let o = Vec3::new(i as f32, (i % 7) as f32, (i % 13) as f32);
            Triangle { v: [o, o + Vec3::X, o + Vec3::Y] }
        })
        .collect();
    let prims = Arc::new(Primitives { triangles, spheres: Vec::new() });
    let d = Device::new("threads=1").unwrap();
    let start = d.memory_bytes();
    let t = EmbreeTracer::with_mode(&d, prims, EmbreeQuality::Medium, rtdiff::embree::EmbreeMode::Robust).unwrap();
    let m = t.scene().memory();
    let exact = 48 * n as i64;
    assert!((exact..exact + 4096).contains(&m.geometry_bytes), "geometry {} bytes for {n} triangles", m.geometry_bytes);
    assert!(m.bvh_bytes >= 16 * n as i64, "BVH {} bytes for {n} triangles", m.bvh_bytes);
    assert_eq!(d.memory_bytes(), start + m.geometry_bytes + m.bvh_bytes);
    drop(t);
    assert_eq!(d.memory_bytes(), start, "memory left after the scene was released");
}

fn one_triangle_and_sphere() -> Arc<Primitives> {
    let tri = Triangle { v: [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)] };
    let sph = Sphere { center: Vec3::new(5.0, 0.0, 0.0), radius: 1.0 };
    Arc::new(Primitives { triangles: vec![tri], spheres: vec![sph] })
}

#[test]
fn hits_carry_rtdiff_ids_barycentrics_and_distances() {
    let prims = one_triangle_and_sphere();
    let t = EmbreeTracer::new(prims.clone(), EmbreeQuality::High).unwrap();
    let r = Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
    let h = t.intersect(&r).unwrap();
    assert_eq!(h.prim, 0);
    assert!((h.t - 2.0).abs() <= 4.0 * f32::EPSILON, "{h:?}");
    assert!((h.u - 0.25).abs() <= 4.0 * f32::EPSILON && (h.v - 0.5).abs() <= 4.0 * f32::EPSILON, "{h:?}");
    // The sphere is primitive 1 (= triangle count + sphere index), hit at t = 4
    // from x = 0, and u, v follow rtdiff's own parameterisation.
    let r = Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::X);
    let h = t.intersect(&r).unwrap();
    let (ts, us, vs) = prims.spheres[0].intersect(&r).unwrap();
    assert_eq!(h.prim, 1);
    assert!((h.t - ts).abs() <= 4.0 * f32::EPSILON * ts, "{h:?} vs {ts}");
    assert!((h.u - us).abs() <= 1e-5 && (h.v - vs).abs() <= 1e-5, "{h:?} vs {us} {vs}");
    // From inside the sphere the far side is reported, as rtdiff does.
    let r = Ray::new(Vec3::new(5.0, 0.0, 0.0), Vec3::X);
    assert!((t.intersect(&r).unwrap().t - 1.0).abs() <= 4.0 * f32::EPSILON);
    // Misses and interval limits.
    assert!(t.intersect(&Ray::new(Vec3::new(0.0, 3.0, 0.0), Vec3::X)).is_none());
    let r = Ray::with_range(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.0, 0.0, -1.0), 0.0, 0.999);
    assert!(t.intersect(&r).is_none() && !t.occluded(&r));
    let r = Ray::with_range(r.origin, r.dir, 0.0, 1.0);
    assert!(t.intersect(&r).is_some() && t.occluded(&r), "tfar is inclusive");
}

#[test]
fn build_tracer_gives_embree_with_each_quality() {
    let prims = one_triangle_and_sphere();
    for q in [EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High] {
        let cfg = AccelConfig { backend: Backend::Embree, embree_quality: q, ..Default::default() };
        let t = build_tracer(prims.clone(), &cfg).unwrap();
        assert!(t.name().starts_with("embree"));
        assert!(t.occluded(&Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::X)));
        assert!(!t.occluded(&Ray::new(Vec3::new(0.0, 3.0, 0.0), Vec3::X)));
    }
}

#[test]
fn empty_scene_misses() {
    let t = EmbreeTracer::new(Arc::new(Primitives::default()), EmbreeQuality::Medium).unwrap();
    assert!(t.intersect(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
}

#[test]
fn scene_bounds_match_the_primitives() {
    let prims = one_triangle_and_sphere();
    let t = EmbreeTracer::new(prims.clone(), EmbreeQuality::High).unwrap();
    let b = t.scene().bounds().unwrap();
    let w = prims.world_bounds();
    assert!(b.min.cmple(w.min).all() && b.max.cmpge(w.max).all(), "{b:?} vs {w:?}");
}

/// Why embree4-sys's 4.2 layout (80-byte `RTCRayHit`) is unsound with this
/// library: on a hit, Embree 4.4 writes `instPrimID[0]` at byte 80.
#[test]
fn library_writes_inst_prim_id_at_byte_80() {
    let t = EmbreeTracer::new(one_triangle_and_sphere(), EmbreeQuality::High).unwrap();
    let mut rh = ffi::RTCRayHit {
        ray: ffi::RTCRay {
            org_x: 0.25,
            org_y: 0.25,
            org_z: 1.0,
            dir_z: -1.0,
            tfar: f32::INFINITY,
            mask: u32::MAX,
            ..Default::default()
        },
        hit: ffi::RTCHit {
            geomID: ffi::RTC_INVALID_GEOMETRY_ID,
            instID: [0xDEAD_BEEF],
            instPrimID: [0xDEAD_BEEF],
            ..Default::default()
        },
    };
    // SAFETY: committed scene, a 96-byte aligned RTCRayHit, default arguments.
    unsafe { ffi::rtcIntersect1(t.scene().raw(), &mut rh, std::ptr::null_mut()) };
    assert_eq!(rh.hit.geomID, 0);
    assert_eq!(std::mem::offset_of!(ffi::RTCRayHit, hit.instPrimID), 80);
    // Both were overwritten with RTC_INVALID_GEOMETRY_ID (no instance).
    assert_eq!((rh.hit.instID[0], rh.hit.instPrimID[0]), (u32::MAX, u32::MAX));
}

#[test]
fn packet_layouts_and_answers_match_single_rays() {
    assert_eq!((size_of::<ffi::RTCRay8>(), align_of::<ffi::RTCRay8>()), (384, 32));
    assert_eq!((size_of::<ffi::RTCHit8>(), align_of::<ffi::RTCHit8>()), (288, 32));
    assert_eq!((size_of::<ffi::RTCRayHit8>(), align_of::<ffi::RTCRayHit8>()), (672, 32));
    let prims = one_triangle_and_sphere();
    let t = EmbreeTracer::new(prims, EmbreeQuality::Medium).unwrap();
    let bounds = rtdiff::geometry::Aabb::new(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(7.0, 2.0, 2.0));
    let rays = rtdiff::rays::incoherent_rays(&bounds, 4003, 5);
    let mut hits = 0;
    for chunk in rays.chunks(8) {
        let h8 = t.intersect8(chunk);
        let o8 = t.occluded8(chunk);
        for (k, r) in chunk.iter().enumerate() {
            // Same primitive; the packet kernels are different SIMD code
            // (other FMA contractions, other operation order on spheres), so t
            // may differ by rounding: at most the bound of verify::hits::bounds,
            // K u (|o| + |p|) / (|d| cos), K = 32, with cos the incidence on
            // the hit surface; (u, v) of spheres follow the hit point.
            let h1 = t.intersect(r);
            assert_eq!(h8[k].map(|h| h.prim), h1.map(|h| h.prim), "ray {r:?}");
            if let (Some(a), Some(b)) = (h8[k], h1) {
                let n = if b.prim == 0 { Vec3::Z } else { (r.at(b.t) - Vec3::new(5.0, 0.0, 0.0)).normalize() };
                let cos = n.dot(r.dir.normalize()).abs().max(1e-6);
                let mag = r.origin.abs().max_element() + r.at(b.t).abs().max_element();
                let bound = 32.0 * f32::EPSILON * 0.5 * mag / (r.dir.length() * cos);
                assert!((a.t - b.t).abs() <= bound, "{a:?} vs {b:?}, bound {bound}");
                if b.prim == 0 {
                    assert!((a.u - b.u).abs() <= 1e-5 && (a.v - b.v).abs() <= 1e-5, "{a:?} vs {b:?}");
                }
            }
            assert_eq!(o8[k], t.occluded(r));
            hits += h8[k].is_some() as usize;
        }
        // Lanes past the slice stay empty.
        assert!(h8[chunk.len()..].iter().all(Option::is_none) && !o8[chunk.len()..].iter().any(|&o| o));
    }
    assert!(hits > 100, "{hits}");
}
