//! Headless visual debugging: the reports drew each feature's rays in an
//! OpenGL view (camera ray in the computed colour, reflections, shadow rays in
//! red when blocked, area-light samples in their colours). A [`Recorder`]
//! receives the same events from the integrator; [`RayTree`] keeps them as a
//! tree that `rtdiff debug` prints or writes as JSON. The render path uses
//! [`NoRecorder`], whose empty methods compile away.

use glam::Vec3;
use serde::Serialize;

use super::whitted::Interaction;
use crate::geometry::{Hit, Ray};
use crate::light::LightSample;

/// Why a ray was traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RayKind {
    /// From the camera.
    Camera,
    /// Perfect mirror reflection.
    Reflection,
    /// Perturbed (glossy) reflection.
    Glossy,
    /// Continuation through a transparent surface.
    Transmission,
}

/// Receives the integrator's events.
pub trait Recorder {
    /// False for the no-op recorder: lets the integrator skip work done only for the record.
    const ACTIVE: bool;
    /// A ray of `kind` starts at recursion depth `depth`.
    fn begin(&mut self, _kind: RayKind, _ray: &Ray, _depth: u32) {}
    /// A light sample was shaded: its contribution `f` (before visibility) and visibility.
    fn light_sample(&mut self, _light: usize, _sample: &LightSample, _f: Vec3, _visibility: f32) {}
    /// A shadow ray and what (if anything) it hit before the light.
    fn shadow_ray(&mut self, _ray: &Ray, _blocker: Option<&Hit>) {}
    /// The current ray ends: its hit (if any) and its colour.
    fn end(&mut self, _hit: Option<(&Hit, &Interaction)>, _color: Vec3) {}
}

/// Records nothing (the render path).
pub struct NoRecorder;

impl Recorder for NoRecorder {
    const ACTIVE: bool = false;
}

/// A shadow ray in the tree.
#[derive(Clone, Debug, Serialize)]
pub struct ShadowRecord {
    /// Origin.
    pub origin: [f32; 3],
    /// Target (the light sample).
    pub target: [f32; 3],
    /// Primitive that blocked it, and where along the ray (fraction of the way to the light).
    pub blocked_by: Option<(u32, f32)>,
}

/// A light sample in the tree.
#[derive(Clone, Debug, Serialize)]
pub struct LightRecord {
    /// Index of the light in the scene.
    pub light: usize,
    /// Sample position.
    pub position: [f32; 3],
    /// Sample colour.
    pub color: [f32; 3],
    /// Shaded contribution before visibility.
    pub contribution: [f32; 3],
    /// Visibility in [0, 1].
    pub visibility: f32,
    /// Shadow rays traced for it.
    pub shadow_rays: Vec<ShadowRecord>,
}

/// One ray and everything it caused.
#[derive(Clone, Debug, Serialize)]
pub struct RayNode {
    /// Why it was traced.
    pub kind: RayKind,
    /// Recursion depth.
    pub depth: u32,
    /// Origin.
    pub origin: [f32; 3],
    /// Unit direction.
    pub direction: [f32; 3],
    /// Hit: primitive, distance, position, shading normal, uv, material index.
    pub hit: Option<HitRecord>,
    /// Light samples shaded at the hit.
    pub lights: Vec<LightRecord>,
    /// Secondary rays.
    pub children: Vec<RayNode>,
    /// Resulting colour.
    pub color: [f32; 3],
}

/// A hit in the tree.
#[derive(Clone, Debug, Serialize)]
pub struct HitRecord {
    /// Primitive id.
    pub prim: u32,
    /// Ray parameter (in units of the ray's direction).
    pub t: f32,
    /// Hit position.
    pub position: [f32; 3],
    /// Shading normal (facing the ray).
    pub normal: [f32; 3],
    /// Texture coordinates.
    pub uv: [f32; 2],
    /// Material index.
    pub material: u32,
}

/// Builds the tree of rays for one camera ray.
#[derive(Default)]
pub struct RayTree {
    stack: Vec<RayNode>,
    /// Finished top-level rays.
    pub roots: Vec<RayNode>,
}

impl Recorder for RayTree {
    const ACTIVE: bool = true;

    fn begin(&mut self, kind: RayKind, ray: &Ray, depth: u32) {
        self.stack.push(RayNode {
            kind,
            depth,
            origin: ray.origin.into(),
            direction: ray.dir.normalize_or_zero().into(),
            hit: None,
            lights: Vec::new(),
            children: Vec::new(),
            color: [0.0; 3],
        });
    }

    fn shadow_ray(&mut self, ray: &Ray, blocker: Option<&Hit>) {
        if let Some(node) = self.stack.last_mut() {
            // Shadow rays come before the light_sample event of their sample: park them on a pending record.
            let rec = ShadowRecord {
                origin: ray.origin.into(),
                target: (ray.origin + ray.dir).into(),
                blocked_by: blocker.map(|h| (h.prim, h.t)),
            };
            match node.lights.last_mut() {
                Some(l) if l.light == usize::MAX => l.shadow_rays.push(rec),
                _ => node.lights.push(LightRecord {
                    light: usize::MAX,
                    position: [0.0; 3],
                    color: [0.0; 3],
                    contribution: [0.0; 3],
                    visibility: 0.0,
                    shadow_rays: vec![rec],
                }),
            }
        }
    }

    fn light_sample(&mut self, light: usize, s: &LightSample, f: Vec3, visibility: f32) {
        if let Some(node) = self.stack.last_mut() {
            let shadow_rays = match node.lights.last() {
                Some(l) if l.light == usize::MAX => node.lights.pop().map(|l| l.shadow_rays).unwrap_or_default(),
                _ => Vec::new(),
            };
            node.lights.push(LightRecord {
                light,
                position: s.position.into(),
                color: s.color.into(),
                contribution: f.into(),
                visibility,
                shadow_rays,
            });
        }
    }

    fn end(&mut self, hit: Option<(&Hit, &Interaction)>, color: Vec3) {
        let Some(mut node) = self.stack.pop() else { return };
        node.color = color.into();
        node.hit = hit.map(|(h, it)| HitRecord {
            prim: h.prim,
            t: h.t,
            position: it.si.p.into(),
            normal: it.ns.into(),
            uv: it.uv.into(),
            material: it.material,
        });
        match self.stack.last_mut() {
            Some(parent) => parent.children.push(node),
            None => self.roots.push(node),
        }
    }
}
