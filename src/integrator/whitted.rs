//! The reports' recursive (Whitted-style) ray tracer: direct light with hard
//! and soft shadows, mirror and glossy reflection, alpha-blended transparency.

use std::mem::MaybeUninit;

use glam::{Vec2, Vec3};

use super::debug::{NoRecorder, RayKind, Recorder};
use super::{Counters, Integrator};
use crate::accel::Tracer;
use crate::features::Plan;
use crate::geometry::offset::SpawnOffset;
use crate::geometry::{Hit, Ray, SurfaceInteraction};
use crate::light::LightSample;
use crate::material::Material;
use crate::rng::Pcg32;
use crate::scene::Scene;
use crate::shading::{ShadingModel, SurfacePoint, model};

/// Shadow rays stop this fraction of the way short of the light sample, so a
/// light lying exactly on a surface (a light quad modelled as geometry too) is
/// not occluded by that surface. A relative length, so valid at any scale.
const SHADOW_T_MAX: f32 = 1.0 - 1.0e-4;

/// Cap on transparent surfaces crossed by one shadow ray (guards against
/// pathological stacks; each crossing still attenuates).
const MAX_SHADOW_CROSSINGS: u32 = 64;

/// Everything known about a hit point.
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    /// Point, error bound and unit geometric normal, from the primitive hit
    /// ([`crate::geometry::Primitives::interaction`]); the normal flipped to
    /// face the incoming ray.
    pub si: SurfaceInteraction,
    /// Unit shading normal, on the same side as `ng`.
    pub ns: Vec3,
    /// Texture coordinates (zero without uvs).
    pub uv: Vec2,
    /// Whether `uv` is meaningful.
    pub has_uv: bool,
    /// Material index.
    pub material: u32,
}

/// What one camera sample carries down its ray tree: its random numbers, the
/// render's counters and the recorder of `rtdiff debug`.
struct Path<'p, R> {
    rng: &'p mut Pcg32,
    c: &'p mut Counters,
    rec: &'p mut R,
}

/// The recursive tracer of the reports, in either shading model.
pub struct Whitted<'a> {
    scene: &'a Scene,
    tracer: &'a dyn Tracer,
    plan: Plan,
    offset: SpawnOffset,
}

impl<'a> Whitted<'a> {
    /// An integrator over `scene` whose rays are answered by `tracer`, doing only what `plan` asks.
    pub fn new(scene: &'a Scene, tracer: &'a dyn Tracer, plan: Plan) -> Self {
        Self { scene, tracer, plan, offset: scene.params.ray_offset }
    }

    /// Surface data at `hit` along `ray`.
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let mut si = self.scene.prims.interaction(ray, hit);
        let ng = si.ng;
        let (mut ns, uv, has_uv) = if self.scene.prims.sphere_index(hit.prim as usize).is_none() {
            let w = si.b;
            let sh = &self.scene.triangle_shading[hit.prim as usize];
            let ns = if self.plan.normal_interpolation {
                (w[0] * sh.normals[0] + w[1] * sh.normals[1] + w[2] * sh.normals[2]).normalize_or(ng)
            } else {
                ng
            };
            let uv = if self.plan.textures && sh.has_uvs {
                w[0] * sh.uvs[0] + w[1] * sh.uvs[1] + w[2] * sh.uvs[2]
            } else {
                Vec2::ZERO
            };
            (ns, uv, sh.has_uvs)
        } else {
            (ng, Vec2::new(hit.u, 1.0 - hit.v), true)
        };
        // Two-sided surfaces: both normals face the side the ray came from.
        if si.ng.dot(ray.dir) > 0.0 {
            si.ng = -si.ng;
        }
        if ns.dot(si.ng) < 0.0 {
            ns = -ns;
        }
        Interaction { si, ns, uv, has_uv, material: self.scene.material_of(hit.prim) }
    }

    /// A ray leaving `it` in direction `d` (`t_max` in units of `d`).
    #[inline]
    fn spawn(&self, it: &Interaction, d: Vec3, t_max: f32) -> Ray {
        it.si.spawn_ray(self.offset, d, t_max)
    }

    /// Diffuse colour at `it` (texture lookup only when the plan has textures).
    #[inline]
    fn diffuse(&self, m: &Material, it: &Interaction, c: &mut Counters) -> Vec3 {
        if self.plan.textures
            && it.has_uv
            && let Some(t) = &m.kd_texture
        {
            c.texture_lookups += 1;
            return if self.plan.bilinear {
                t.bilinear(it.uv.x, it.uv.y, m.wrap)
            } else {
                t.nearest(it.uv.x, it.uv.y, m.wrap)
            };
        }
        m.kd
    }

    /// Fraction of light from `target` that reaches `it`: 0 or 1 for opaque
    /// blockers, attenuated by `1 - opacity` per transparent surface crossed.
    pub fn visibility<R: Recorder>(&self, it: &Interaction, target: Vec3, c: &mut Counters, rec: &mut R) -> f32 {
        let ray = it.si.spawn_ray_to(self.offset, target, SHADOW_T_MAX);
        c.shadow_rays += 1;
        if !self.plan.transparency && !R::ACTIVE {
            return if self.tracer.occluded(&ray) { 0.0 } else { 1.0 };
        }
        if self.plan.transparency {
            // Any hit first: a clear ray transmits everything (what the walk
            // would find); only a blocked one is traced again for its
            // closest blocker (a second query, counted).
            if !self.tracer.occluded(&ray) {
                rec.shadow_ray(&ray, None);
                return 1.0;
            }
            c.shadow_rays += 1;
        }
        self.transmitted(ray, target, c, rec)
    }

    /// The transparency walk of [`Self::visibility`] along its shadow ray
    /// `ray` (already counted): the closest blocker, then on through each
    /// transparent one.
    fn transmitted<R: Recorder>(&self, mut ray: Ray, target: Vec3, c: &mut Counters, rec: &mut R) -> f32 {
        let mut transmitted = 1.0;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            let hit = self.tracer.intersect(&ray);
            rec.shadow_ray(&ray, hit.as_ref());
            let Some(hit) = hit else { return transmitted };
            let blocker = self.interaction(&ray, &hit);
            let m = &self.scene.materials[blocker.material as usize];
            if !m.is_transparent() || !self.plan.transparency {
                return 0.0;
            }
            transmitted *= 1.0 - m.opacity;
            ray = blocker.si.spawn_ray_to(self.offset, target, SHADOW_T_MAX);
            c.shadow_rays += 1;
        }
        0.0
    }

    /// [`Self::visibility`] of every pending sample of `batch` from `it`,
    /// added to `sum` in sample order as `visibility * f` (an area light's
    /// samples first shaded with `shading` at `sp`): the shadow rays go
    /// to the tracer as one batch of any-hit queries; with transparency on,
    /// only the occluded ones walk on through transparent blockers (an
    /// unoccluded ray transmits everything, as the walk would find).
    fn flush_shadows(
        &self,
        it: &Interaction,
        (shading, sp): (&dyn ShadingModel, &SurfacePoint),
        batch: &mut ShadowBatch,
        c: &mut Counters,
        sum: &mut Vec3,
    ) {
        // The pending samples of an area light shaded in one loop of
        // independent work (their square roots and divisions overlap, where
        // shaded one by one between the light's sampling they did not); only
        // those that reflect something get a shadow ray.
        // One light's samples at a time: shaded entries (a point light's) or
        // pending samples (an area light's), never both.
        debug_assert!(batch.len == 0 || batch.pending == 0, "two lights' samples in one batch");
        let mut n = batch.len;
        for k in 0..batch.pending {
            // SAFETY: the first `pending` samples were written.
            let s = unsafe { batch.samples[k].assume_init_ref() };
            let f = shading.direct(sp, s);
            if f != Vec3::ZERO {
                (batch.targets[n], batch.f[n]) = (s.position, f);
                n += 1;
            }
        }
        (batch.len, batch.pending) = (0, 0);
        if n == 0 {
            return;
        }
        // One origin computation per side of the surface, not per ray.
        let spawner = it.si.spawner(self.offset);
        for k in 0..n {
            batch.rays[k] = spawner.ray_to(batch.targets[k], SHADOW_T_MAX);
        }
        c.shadow_rays += n as u64;
        self.tracer.occluded_batch(&batch.rays[..n], &mut batch.occluded[..n]);
        for k in 0..n {
            let vis = match (batch.occluded[k], self.plan.transparency) {
                (false, _) => 1.0,
                (true, false) => 0.0,
                (true, true) => {
                    // Traced again for its closest blocker, as in `visibility`.
                    c.shadow_rays += 1;
                    self.transmitted(batch.rays[k], batch.targets[k], c, &mut NoRecorder)
                }
            };
            *sum += vis * batch.f[k];
        }
    }

    /// Light reflected at `it` towards `wo` from every light, `kd` being the diffuse colour there.
    fn direct<R: Recorder>(&self, it: &Interaction, m: &Material, kd: Vec3, wo: Vec3, path: &mut Path<R>) -> Vec3 {
        let sp = SurfacePoint { p: it.si.p, n: it.ns, wo, kd, ks: m.ks, shininess: m.shininess };
        let shading = model(m.model);
        let mut sum = Vec3::ZERO;
        let mut batch = ShadowBatch::default();
        for (li, light) in self.scene.lights.iter().enumerate() {
            let point = light.is_point();
            if !point && !self.plan.area_lights {
                continue;
            }
            let shadows = if point { self.plan.hard_shadows } else { self.plan.soft_shadows };
            let (n, sampling) = (self.scene.params.light_samples, self.scene.params.light_sampling);
            let Path { rng, c, rec } = path;
            // No list, no allocation: a point light's sample is shaded as
            // the light produces it (deferred, its one sample only paid for
            // the copy: cornell_box 8% slower), an area light's samples wait
            // in `batch` and are shaded there; shadow rays go to the tracer together,
            // their contributions added in sample order. One light's samples
            // are flushed before the next light's.
            light.sample(n, sampling, rng, &mut |s: LightSample| {
                c.light_samples += 1;
                let batched = shadows && !R::ACTIVE;
                if batched && batch.len + batch.pending == SHADOW_BATCH {
                    self.flush_shadows(it, (shading, &sp), &mut batch, c, &mut sum);
                }
                if batched && !point {
                    // Shaded with the batch (`flush_shadows`).
                    batch.samples[batch.pending] = MaybeUninit::new(s);
                    batch.pending += 1;
                    return;
                }
                let f = shading.direct(&sp, &s);
                if f == Vec3::ZERO {
                    rec.light_sample(li, &s, f, 0.0);
                } else if !shadows {
                    sum += 1.0 * f;
                    rec.light_sample(li, &s, f, 1.0);
                } else if R::ACTIVE {
                    let vis = self.visibility(it, s.position, c, *rec);
                    sum += vis * f;
                    rec.light_sample(li, &s, f, vis);
                } else {
                    (batch.targets[batch.len], batch.f[batch.len]) = (s.position, f);
                    batch.len += 1;
                }
            });
            self.flush_shadows(it, (shading, &sp), &mut batch, path.c, &mut sum);
        }
        sum
    }

    /// Mirror or glossy reflection at `it` of the incoming direction `d`.
    fn reflection<R: Recorder>(&self, it: &Interaction, m: &Material, d: Vec3, depth: u32, path: &mut Path<R>) -> Vec3 {
        let r = (d - 2.0 * d.dot(it.ns) * it.ns).normalize();
        if !self.plan.glossy {
            path.c.secondary_rays += 1;
            return self.trace_path(RayKind::Reflection, &self.spawn(it, r, f32::INFINITY), depth + 1, path);
        }
        // The reports' glossy reflection: perturb r inside a square of side
        // 1 / shininess perpendicular to it and average N rays.
        let a = 1.0 / m.shininess.max(f32::MIN_POSITIVE);
        let (u, w) = r.any_orthonormal_pair();
        // Split into N rays at the first glossy bounce only: deeper glossy
        // bounces follow one perturbed ray each, so the ray count grows
        // linearly with depth instead of as N^depth (two facing glossy
        // mirrors at depth 5 would otherwise cost N^5 rays per pixel).
        let n = if depth == 0 { self.scene.params.glossy_samples } else { 1 };
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            let du = (path.rng.next_f32() - 0.5) * a;
            let dw = (path.rng.next_f32() - 0.5) * a;
            let g = (r + du * u + dw * w).normalize();
            if g.dot(it.si.ng) <= 0.0 {
                continue; // would enter the surface: no light arrives from there
            }
            path.c.secondary_rays += 1;
            sum += self.trace_path(RayKind::Glossy, &self.spawn(it, g, f32::INFINITY), depth + 1, path);
        }
        sum / n as f32
    }

    /// Radiance along `ray` at recursion depth `depth`.
    pub fn trace(&self, ray: &Ray, depth: u32, rng: &mut Pcg32, c: &mut Counters) -> Vec3 {
        self.trace_as(RayKind::Camera, ray, depth, rng, c, &mut NoRecorder)
    }

    /// [`Whitted::trace`] reporting every ray, hit, light sample and shadow ray to `rec`.
    pub fn trace_as<R: Recorder>(
        &self,
        kind: RayKind,
        ray: &Ray,
        depth: u32,
        rng: &mut Pcg32,
        c: &mut Counters,
        rec: &mut R,
    ) -> Vec3 {
        self.trace_path(kind, ray, depth, &mut Path { rng, c, rec })
    }

    /// Radiance along `ray` (a ray of kind `kind` at recursion depth `depth`) for the sample `path`.
    fn trace_path<R: Recorder>(&self, kind: RayKind, ray: &Ray, depth: u32, path: &mut Path<R>) -> Vec3 {
        path.rec.begin(kind, ray, depth);
        let hit = self.tracer.intersect(ray);
        self.shade(ray, hit, depth, path)
    }

    /// The colour along `ray` (recursion depth `depth`) whose closest hit is `hit`.
    fn shade<R: Recorder>(&self, ray: &Ray, hit: Option<Hit>, depth: u32, path: &mut Path<R>) -> Vec3 {
        let Some(hit) = hit else {
            path.rec.end(None, self.scene.background);
            return self.scene.background;
        };
        let it = self.interaction(ray, &hit);
        let m = &self.scene.materials[it.material as usize];
        let kd = self.diffuse(m, &it, path.c);
        let d = ray.dir.normalize();
        let mut color = if self.plan.shading { self.direct(&it, m, kd, -d, path) } else { kd };
        let deeper = depth < self.scene.params.max_depth;
        if self.plan.reflections && deeper && m.is_reflective() {
            color += m.ks * self.reflection(&it, m, d, depth, path);
        }
        if self.plan.transparency && deeper && m.is_transparent() {
            path.c.secondary_rays += 1;
            let behind = self.trace_path(RayKind::Transmission, &self.spawn(&it, d, f32::INFINITY), depth + 1, path);
            color = m.opacity * color + (1.0 - m.opacity) * behind;
        }
        path.rec.end(Some((&hit, &it)), color);
        color
    }
}

/// Shadow rays a shading point sends to the tracer in one batch.
const SHADOW_BATCH: usize = 16;

/// The pending shadow rays of one shading point: targets, unshadowed
/// contributions, and room for the rays and answers.
struct ShadowBatch {
    /// Shaded entries waiting for their shadow rays (`targets`, `f`).
    len: usize,
    /// Area-light samples waiting to be shaded (`samples`), shaded before
    /// the entries' rays are traced.
    pending: usize,
    /// The pending light samples (the first `pending` written).
    samples: [MaybeUninit<LightSample>; SHADOW_BATCH],
    targets: [Vec3; SHADOW_BATCH],
    f: [Vec3; SHADOW_BATCH],
    rays: [Ray; SHADOW_BATCH],
    occluded: [bool; SHADOW_BATCH],
}

impl Default for ShadowBatch {
    fn default() -> Self {
        Self {
            len: 0,
            pending: 0,
            samples: [MaybeUninit::uninit(); SHADOW_BATCH],
            targets: [Vec3::ZERO; SHADOW_BATCH],
            f: [Vec3::ZERO; SHADOW_BATCH],
            rays: [Ray::new(Vec3::ZERO, Vec3::Z); SHADOW_BATCH],
            occluded: [false; SHADOW_BATCH],
        }
    }
}

impl Integrator for Whitted<'_> {
    fn radiance(&self, ray: &Ray, rng: &mut Pcg32, counters: &mut Counters) -> Vec3 {
        counters.primary_rays += 1;
        self.trace(ray, 0, rng, counters)
    }

    fn radiance_with_hit(&self, ray: &Ray, hit: Option<Hit>, rng: &mut Pcg32, counters: &mut Counters) -> Vec3 {
        counters.primary_rays += 1;
        self.shade(ray, hit, 0, &mut Path { rng, c: counters, rec: &mut NoRecorder })
    }
}
