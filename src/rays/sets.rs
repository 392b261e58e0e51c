//! Seeded, deterministic ray sets: ordinary workloads (`primary`,
//! `incoherent`, `shadow`) and rays built to break a tracer (`edges`,
//! `vertices`, `grazing`, `axis`, `surface`, `scaled`).
//!
//! Every set is a pure function of the scene, the set kind, the seed, the
//! count and (for `shadow` and `surface`, which start at hits of earlier rays)
//! the hits of the tracer given as oracle. Ray `i` of a set can be replayed
//! from `(set, seed, count, i)`.

use std::sync::Arc;

use glam::{DVec3, Vec3};

use crate::accel::Tracer;
use crate::geometry::offset::SpawnOffset;
use crate::geometry::{Aabb, Primitives, Ray};

use super::{RayContext, Rng, Topology};

/// The ray sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SetKind {
    /// Camera rays through random points of random pixels.
    Primary,
    /// Random origins in the bounds, random directions.
    Incoherent,
    /// From primary hits (robustly offset) to light sample points.
    Shadow,
    /// Aimed at random points on edges shared by two triangles.
    Edges,
    /// Aimed at vertices whose triangle fan is closed.
    Vertices,
    /// Nearly parallel to a triangle (1e-1 to 1e-7 radians off its plane), through it.
    Grazing,
    /// Axis-aligned and in-plane diagonal directions (zero components), origins on vertex coordinates.
    Axis,
    /// Leaving a surface from a previous hit, offset with the robust policy.
    Surface,
    /// The mesh scaled by 1e-4 and 1e5 and moved 1e4 from the origin (primary, edge and surface rays).
    Scaled,
}

impl SetKind {
    /// Every set, in report order.
    pub const ALL: [SetKind; 9] = [
        SetKind::Primary,
        SetKind::Incoherent,
        SetKind::Shadow,
        SetKind::Edges,
        SetKind::Vertices,
        SetKind::Grazing,
        SetKind::Axis,
        SetKind::Surface,
        SetKind::Scaled,
    ];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            SetKind::Primary => "primary",
            SetKind::Incoherent => "incoherent",
            SetKind::Shadow => "shadow",
            SetKind::Edges => "edges",
            SetKind::Vertices => "vertices",
            SetKind::Grazing => "grazing",
            SetKind::Axis => "axis",
            SetKind::Surface => "surface",
            SetKind::Scaled => "scaled",
        }
    }

    fn stream(self) -> u64 {
        self as u64 + 1
    }
}

/// What the generator knows about a ray (used to classify disagreements).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RayTag {
    /// Nothing special.
    Plain,
    /// Crosses the surface at a shared edge or closed vertex at parameter
    /// `t`: every triangle sharing it faces the ray the same way and the ray
    /// meets one of them (checked in double precision), so a watertight
    /// tracer must hit something at `t` or before.
    Crossing {
        /// Parameter of the aimed-at point.
        t: f32,
    },
    /// Aimed at a shared edge or vertex that is a silhouette for this ray
    /// (the triangles sharing it face it opposite ways): touching it or not
    /// are both correct.
    Tangent,
    /// Aimed at an edge or vertex of triangles thinner than rounding (see
    /// `crossing_tag`): no answer can be required.
    Degenerate,
    /// Spawned from a hit on primitive `prim` (hitting it again is a false
    /// self-intersection).
    Spawned {
        /// The primitive the ray starts on.
        prim: u32,
        /// The hit point before the robust offset.
        from: Vec3,
    },
    /// A shadow ray from a hit on primitive `prim`: compared with `occluded`
    /// as well, and hitting `prim` again is a false self-intersection.
    Shadow {
        /// The primitive the ray starts on.
        prim: u32,
        /// The hit point before the robust offset.
        from: Vec3,
    },
}

/// A generated set of rays over one scene.
#[derive(Clone)]
pub struct RaySet {
    /// Name (the kind, or `scaled-1e-4` etc. for the parts of `scaled`).
    pub name: String,
    /// The kind it was generated as.
    pub kind: SetKind,
    /// The seed.
    pub seed: u64,
    /// The primitives the rays are meant for (the scaled sets have their own).
    pub prims: Arc<Primitives>,
    /// The rays.
    pub rays: Vec<Ray>,
    /// One tag per ray.
    pub tags: Vec<RayTag>,
}

/// Largest absolute coordinate of the scene and the camera: the scale that
/// every relative tolerance refers to.
pub fn scene_scale(prims: &Primitives) -> f32 {
    prims.world_bounds().max_abs_coord().max(f32::MIN_POSITIVE)
}

fn unit_normal(prims: &Primitives, tri: u32) -> DVec3 {
    let t = prims.triangles[tri as usize];
    let [a, b, c] = t.v.map(|p| p.as_dvec3());
    (b - a).cross(c - a).normalize_or_zero()
}

/// Double-precision ray/triangle test (Moller-Trumbore, inclusive edges):
/// the parameter where the exact f32 ray `(o, d)` meets triangle `tri`.
/// Its rounding (about 1e-16 relative) is far below anything f32 resolves.
fn hit_f64(prims: &Primitives, tri: u32, o: Vec3, d: Vec3) -> Option<f64> {
    let [a, b, c] = prims.triangles[tri as usize].v.map(|p| p.as_dvec3());
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let tv = o - a;
    let u = tv.dot(p) / det;
    let q = tv.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= 0.0).then_some(t)
}

/// Tag for `ray` aimed at point `p` shared by `tris`.
///
/// Crossing when every triangle faces the ray the same way by a margin far
/// above rounding (|cos| > 1e-2) and the ray, evaluated in double precision
/// exactly as given, meets one of them. A watertight test decides exactly on
/// a configuration whose vertices are moved by rounding (translation and
/// shear, a few ulps of `mag = |o|_inf + |p|_inf`); the crossing is only
/// guaranteed when that cannot fold a triangle over, i.e. when every
/// triangle's smallest altitude, projected along the ray, exceeds
/// `64 u mag` (about 8x the displacement, `u = 2^-24`). Thinner triangles
/// (slivers, near-coincident vertices, as in the decimated dragon) make the
/// ray `Degenerate`. Tangent when the triangles face the ray opposite ways.
fn crossing_tag(prims: &Primitives, tris: &[u32], ray: &Ray, p: Vec3) -> RayTag {
    let d = ray.dir.as_dvec3().normalize();
    let cos: Vec<f64> = tris.iter().map(|&i| unit_normal(prims, i).dot(d)).collect();
    if !(cos.iter().all(|&c| c > 1e-2) || cos.iter().all(|&c| c < -1e-2)) {
        return RayTag::Tangent;
    }
    let mag = ray.origin.abs().max_element() as f64 + p.abs().max_element() as f64;
    let margin = 64.0 * (f32::EPSILON as f64 * 0.5) * mag;
    let thin = tris.iter().zip(&cos).any(|(&i, &c)| {
        let [a, b, cc] = prims.triangles[i as usize].v.map(|v| v.as_dvec3());
        let longest = (b - a).length().max((cc - b).length()).max((a - cc).length());
        let altitude = (b - a).cross(cc - a).length() / longest;
        altitude * c.abs() <= margin
    });
    if thin {
        return RayTag::Degenerate;
    }
    let t = tris.iter().filter_map(|&i| hit_f64(prims, i, ray.origin, ray.dir)).fold(f64::INFINITY, f64::min);
    if t.is_finite() { RayTag::Crossing { t: t as f32 } } else { RayTag::Plain }
}

/// A ray from a random point at distance `0.5..2` scene radii towards `p`
/// (unit direction).
fn ray_towards(rng: &mut Rng, p: Vec3, radius: f32) -> Ray {
    let d = rng.unit_vector();
    let dist = radius * (0.5 + 1.5 * rng.f32());
    Ray::new(p - dist * d, d)
}

/// Generate set `kind` with `count` rays (the `scaled` kind returns three
/// sets, one per transformed scene, `count / 3` rays each). `oracle` must
/// trace `ctx.prims`; `oracle_for` builds an oracle for the transformed
/// scenes of `scaled`.
pub fn generate(
    ctx: &RayContext,
    kind: SetKind,
    seed: u64,
    count: usize,
    oracle: &dyn Tracer,
    oracle_for: &dyn Fn(Arc<Primitives>) -> crate::Result<Box<dyn Tracer>>,
) -> crate::Result<Vec<RaySet>> {
    if kind != SetKind::Scaled {
        return Ok(vec![generate_one(ctx, kind, kind.name().to_string(), seed, count, oracle)]);
    }
    let r = scene_scale(&ctx.prims);
    let parts = [
        ("scaled-1e-4", 1.0e-4_f32, Vec3::ZERO),
        ("scaled-1e5", 1.0e5, Vec3::ZERO),
        // Moved 1e4 scene radii away along (1, 1, 1)/sqrt(3).
        ("moved-1e4", 1.0, Vec3::splat(1.0e4 * r / 3f32.sqrt())),
    ];
    let mut out = Vec::new();
    for (pi, (name, scale, off)) in parts.into_iter().enumerate() {
        let sub = ctx.transformed(scale, off);
        let o = oracle_for(sub.prims.clone())?;
        let n = count / 3;
        let mut rng_seed = Rng::stream(seed, 100 + pi as u64);
        // A third each of primary, edge and surface rays on the transformed scene.
        let mut rays = Vec::new();
        let mut tags = Vec::new();
        for (k, part) in [SetKind::Primary, SetKind::Edges, SetKind::Surface].into_iter().enumerate() {
            let m = if k == 2 { n - 2 * (n / 3) } else { n / 3 };
            let s = generate_one(&sub, part, name.to_string(), rng_seed.next_u64(), m, o.as_ref());
            rays.extend(s.rays);
            tags.extend(s.tags);
        }
        out.push(RaySet { name: name.to_string(), kind, seed, prims: sub.prims.clone(), rays, tags });
    }
    Ok(out)
}

fn generate_one(ctx: &RayContext, kind: SetKind, name: String, seed: u64, count: usize, oracle: &dyn Tracer) -> RaySet {
    let prims = &ctx.prims;
    let mut rng = Rng::stream(seed, kind.stream());
    let bounds = prims.world_bounds();
    let radius = (0.5 * bounds.extent().length()).max(f32::MIN_POSITIVE);
    let mut rays = Vec::with_capacity(count);
    let mut tags = Vec::with_capacity(count);
    let (w, h) = ctx.image;
    let camera_ray = |rng: &mut Rng| (ctx.camera)(rng.f32() * w as f32, rng.f32() * h as f32);
    // Triangles of non-zero area (zero-area ones keep their ids but are no part of the surface).
    let live = || (0..prims.triangles.len()).filter(|&i| prims.triangles[i].normal() != Vec3::ZERO);
    // Generators that may fail to produce a ray (misses, empty topology) stop
    // after this many attempts, so a degenerate scene gives a short set.
    let max_attempts = 20 * count + 1000;
    let mut attempts = 0;
    match kind {
        SetKind::Primary | SetKind::Scaled => {
            for _ in 0..count {
                rays.push(camera_ray(&mut rng));
                tags.push(RayTag::Plain);
            }
        }
        SetKind::Incoherent => {
            for _ in 0..count {
                rays.push(Ray::new(rng.in_box(&bounds), rng.unit_vector()));
                tags.push(RayTag::Plain);
            }
        }
        SetKind::Shadow | SetKind::Surface => {
            while rays.len() < count && attempts < max_attempts && !(kind == SetKind::Shadow && ctx.lights.is_empty()) {
                attempts += 1;
                let r = camera_ray(&mut rng);
                let Some(hit) = oracle.intersect(&r) else { continue };
                let si = prims.interaction(&r, &hit);
                let (p, n) = (si.p, si.ng);
                if kind == SetKind::Shadow {
                    let light = &ctx.lights[rng.below(ctx.lights.len())];
                    let lp = light(rng.f32(), rng.f32());
                    // Up to the light point (which is not geometry): t in [0, 1].
                    rays.push(si.spawn_ray_to(SpawnOffset::Robust, lp, 1.0));
                    tags.push(RayTag::Shadow { prim: hit.prim, from: p });
                } else {
                    // Half the rays leave on the side they arrived from
                    // (reflection), half go through (transmission).
                    let mut w = rng.unit_vector();
                    let towards_eye = -r.dir.dot(n).signum();
                    let side = if rng.f32() < 0.5 { towards_eye } else { -towards_eye };
                    if w.dot(n) * side < 0.0 {
                        w = -w;
                    }
                    rays.push(Ray::new(si.spawn_origin(SpawnOffset::Robust, w), w));
                    tags.push(RayTag::Spawned { prim: hit.prim, from: p });
                }
            }
        }
        SetKind::Edges | SetKind::Vertices => {
            let topo = Topology::new(prims);
            let n_items = if kind == SetKind::Edges { topo.shared_edges.len() } else { topo.closed_vertices.len() };
            if n_items > 0 {
                for _ in 0..count {
                    let (p, tris): (Vec3, Vec<u32>) = if kind == SetKind::Edges {
                        let (a, b, t0, t1) = topo.shared_edges[rng.below(n_items)];
                        // Away from the ends: near a vertex other triangles of
                        // its fan matter, and the vertices set covers those.
                        let s = 0.05 + 0.9 * rng.f32();
                        (a + s * (b - a), vec![t0, t1])
                    } else {
                        let (p, fan) = &topo.closed_vertices[rng.below(n_items)];
                        (*p, fan.clone())
                    };
                    let ray = ray_towards(&mut rng, p, radius);
                    tags.push(crossing_tag(prims, &tris, &ray, p));
                    rays.push(ray);
                }
            }
        }
        SetKind::Grazing => {
            let live: Vec<usize> = live().collect();
            if !live.is_empty() {
                while rays.len() < count && attempts < max_attempts {
                    attempts += 1;
                    let tri = prims.triangles[live[rng.below(live.len())]];
                    let nrm = crate::geometry::unit_or_zero(tri.normal());
                    if nrm == Vec3::ZERO {
                        continue;
                    }
                    // A random in-plane direction tilted 1e-1..1e-7 rad out of the plane.
                    let tangent = rng.unit_vector().reject_from_normalized(nrm).normalize_or_zero();
                    if tangent == Vec3::ZERO {
                        continue;
                    }
                    let angle = 10f32.powf(-1.0 - 6.0 * rng.f32());
                    let sign = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
                    let d = (tangent * angle.cos() + sign * nrm * angle.sin()).normalize();
                    let p = rng.point_on_triangle(&tri);
                    let dist = radius * (0.1 + rng.f32());
                    rays.push(Ray::new(p - dist * d, d));
                    tags.push(RayTag::Plain);
                }
            }
        }
        SetKind::Axis => {
            let verts: Vec<Vec3> = live().flat_map(|i| prims.triangles[i].v).collect();
            let big = Aabb::new(bounds.min - 0.1 * bounds.extent(), bounds.max + 0.1 * bounds.extent());
            for _ in 0..count {
                let a = rng.below(3);
                let mut d = Vec3::ZERO;
                d[a] = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
                if rng.f32() < 0.5 {
                    // An in-plane diagonal: exactly one zero component.
                    d[(a + 1) % 3] = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
                }
                let mut o = rng.in_box(&big);
                if !verts.is_empty() && rng.f32() < 0.5 {
                    // Put the zero-direction coordinates exactly on a vertex:
                    // the ray then runs in a bounding-box face plane.
                    let v = verts[rng.below(verts.len())];
                    for k in 0..3 {
                        if d[k] == 0.0 {
                            o[k] = v[k];
                        }
                    }
                }
                rays.push(Ray::new(o, d));
                tags.push(RayTag::Plain);
            }
        }
    }
    RaySet { name, kind, seed, prims: prims.clone(), rays, tags }
}

/// A closed tetrahedron of edge `sqrt(2)` centred on the origin (every edge
/// shared, every vertex fan closed): the unit-test fixture of the ray sets
/// and of hit parity.
#[cfg(test)]
pub(crate) fn tetra() -> Arc<Primitives> {
    use crate::geometry::Triangle;
    let p =
        [Vec3::new(1.0, 1.0, 1.0), Vec3::new(1.0, -1.0, -1.0), Vec3::new(-1.0, 1.0, -1.0), Vec3::new(-1.0, -1.0, 1.0)]
            .map(|v| v * 0.5);
    let f = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
    Arc::new(Primitives { triangles: f.iter().map(|t| Triangle { v: t.map(|i| p[i]) }).collect(), spheres: vec![] })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BruteForce;
    use crate::camera::Camera;
    use crate::geometry::TriangleTest;

    #[test]
    fn rng_is_deterministic_and_uniform_enough() {
        let a: Vec<u64> = (0..5).scan(Rng::new(7), |r, _| Some(r.next_u64())).collect();
        let b: Vec<u64> = (0..5).scan(Rng::new(7), |r, _| Some(r.next_u64())).collect();
        assert_eq!(a, b);
        let mut r = Rng::new(1);
        let mean = (0..100_000).map(|_| r.f64()).sum::<f64>() / 100_000.0;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        assert!((0..1000).all(|_| r.below(7) < 7));
    }

    #[test]
    fn topology_of_a_closed_mesh() {
        let t = Topology::new(&tetra());
        assert_eq!(t.shared_edges.len(), 6);
        assert_eq!(t.closed_vertices.len(), 4);
    }

    /// A triangle and its reversed copy share all three edges, each one
    /// pair of triangles: the edges still come in one order, whatever order
    /// the hash map of each construction lists them in (before, sorted by the
    /// triangle pair alone, the edge set's rays changed from run to run on
    /// meshes with such pairs).
    #[test]
    fn shared_edges_come_in_one_order() {
        let tri = |a: Vec3, b: Vec3, c: Vec3| crate::geometry::Triangle { v: [a, b, c] };
        let (p, q, r) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let prims = Primitives { triangles: vec![tri(p, q, r), tri(p, r, q)], spheres: Vec::new() };
        let first = Topology::new(&prims).shared_edges;
        assert_eq!(first.len(), 3);
        for _ in 0..32 {
            assert_eq!(Topology::new(&prims).shared_edges, first);
        }
    }

    #[test]
    fn every_set_is_deterministic_and_sized() {
        let prims = tetra();
        let ctx = RayContext::with_defaults(prims.clone());
        let oracle = BruteForce::new(prims.clone(), TriangleTest::Watertight);
        let of = |p: Arc<Primitives>| Ok(Box::new(BruteForce::new(p, TriangleTest::Watertight)) as Box<dyn Tracer>);
        for kind in SetKind::ALL {
            let a = generate(&ctx, kind, 42, 300, &oracle, &of).unwrap();
            let b = generate(&ctx, kind, 42, 300, &oracle, &of).unwrap();
            let c = generate(&ctx, kind, 43, 300, &oracle, &of).unwrap();
            let total: usize = a.iter().map(|s| s.rays.len()).sum();
            assert!(total >= 297, "{kind:?}: {total} rays");
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.rays, y.rays, "{kind:?} is not deterministic");
                assert_eq!(x.tags, y.tags);
                assert_eq!(x.rays.len(), x.tags.len());
            }
            assert_ne!(a[0].rays, c[0].rays, "{kind:?} ignores the seed");
            assert!(
                a.iter()
                    .flat_map(|s| &s.rays)
                    .all(|r| r.origin.is_finite() && r.dir.is_finite() && r.dir != Vec3::ZERO)
            );
        }
    }

    #[test]
    fn crossing_rays_reach_the_surface_at_their_tag() {
        let prims = tetra();
        let ctx = RayContext::with_defaults(prims.clone());
        let oracle = BruteForce::new(prims.clone(), TriangleTest::Watertight);
        let of = |p: Arc<Primitives>| Ok(Box::new(BruteForce::new(p, TriangleTest::Watertight)) as Box<dyn Tracer>);
        let s = &generate(&ctx, SetKind::Edges, 1, 2000, &oracle, &of).unwrap()[0];
        let mut crossing = 0;
        for (r, tag) in s.rays.iter().zip(&s.tags) {
            if let RayTag::Crossing { t } = *tag {
                crossing += 1;
                let h = oracle.intersect(r).expect("a crossing ray hits");
                assert!(h.t <= t * (1.0 + 1e-5), "hit at {} after the edge at {t}", h.t);
            }
        }
        assert!(crossing > 500, "{crossing}");
    }

    #[test]
    fn camera_centre_ray_looks_at_the_target() {
        let c = Camera::default_view(800, 800);
        let r = c.ray(400.0, 400.0);
        let want = (Vec3::ZERO - c.position).normalize();
        assert!(r.dir.dot(want) > 1.0 - 1e-6);
        // Top-left pixel looks up and to the left of the view direction.
        let tl = c.ray(0.5, 0.5);
        assert!(tl.dir.y > r.dir.y);
    }
}
