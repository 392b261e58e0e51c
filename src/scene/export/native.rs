//! The Mitsuba-native oracle: a scene written for Mitsuba 3's own emitters, BSDFs and
//! integrators, wherever they express rtdiff's physical model exactly.
//!
//! | rtdiff | Mitsuba |
//! |---|---|
//! | point light (intensity `I`) | `point` emitter |
//! | parallelogram light, one colour (radiance) | `area` emitter on a `rectangle` (front side `edge01 x edge02`) |
//! | physical Lambert `Kd / pi` (colour or texture) | `twosided` `diffuse` (`bitmap`, same filter and wrap mode) |
//! | pure mirror (`Kd` 0, `Ks`) | `twosided` smooth `conductor` (`material` none, `specular_reflectance` `Ks`) |
//! | `Kd` + mirror `Ks` (max `Kd` + max `Ks` <= 1) | `twosided` `blendbsdf` (weight `w` = 1 - max `Kd`): `diffuse` `Kd / (1 - w)`, `conductor` `Ks / w` |
//! | Whitted without reflections | `direct` (emitter samples only, `hide_emitters`) |
//! | Whitted with one mirror bounce (`max_depth` 1, point lights) | `path` `max_depth` 3, two renders (see below) |
//!
//! Mitsuba's `path` tracer also carries diffuse interreflection, which the Whitted model does
//! not have. Every path's contribution is a product over its vertices, and a diffuse vertex
//! contributes one factor of its reflectance: scaling every diffuse reflectance by `s` makes the
//! image `L(s) = s A + s^2 B` at `max_depth` 3 (no emitter is ever hit: point lights only), where
//! `A` is exactly the Whitted image (direct light, and direct light seen in one mirror) and `B`
//! the interreflection. Two renders with the same seed give `A = 4 L(1/2) - L(1)` (`1/2` is
//! exact in floating point, and Russian roulette is off so both renders draw the same random
//! numbers). The halved reflectances live in a second BSDF file ([`Recipe::terms`]).
//!
//! `direct` and `path` choose one emitter at random per sample: an export with several lights
//! renders each from its own file and sums ([`Recipe::lights`]), so that one sample per pixel
//! sees every light and many samples carry no noise from the choice.
//! Everything else keeps the `rtdiff_whitted` plugin, and [`blockers`] says why.

use std::fmt::Write as _;

use glam::Vec3;

use crate::features::Plan;
use crate::material::Material;
use crate::scene::Scene;
use crate::scene::file::LightSpec;
use crate::shading::ShadingModelKind;

/// Why Mitsuba's own plugins cannot render `scene` as rtdiff does (empty: they can).
pub fn blockers(scene: &Scene, plan: &Plan, lights: &[LightSpec]) -> Vec<String> {
    let mut why = Vec::new();
    if !plan.shading {
        why.push("shading is off (rtdiff returns Kd): no Mitsuba integrator returns a BSDF's albedo".into());
    }
    let used = used_materials(scene);
    let phong: Vec<String> = used
        .iter()
        .map(|&i| &scene.materials[i])
        .filter(|m| plan.shading && m.model == ShadingModelKind::Phong)
        .map(|m| format!("'{}'", m.name))
        .collect();
    if !phong.is_empty() {
        why.push(format!(
            "the Phong model (I Kd n.l + I Ks (r.v)^n; materials {}): Mitsuba has no Phong BSDF",
            phong.join(", ")
        ));
    }
    for (i, l) in lights.iter().enumerate() {
        match l {
            LightSpec::Point { .. } => {}
            LightSpec::Segment { .. } => why.push(format!("light {}: segment lights have no Mitsuba emitter", i + 1)),
            LightSpec::Parallelogram { colors, .. } => {
                if colors.iter().any(|c| *c != colors[0]) {
                    why.push(format!(
                        "light {}: a parallelogram light with different corner colours (bilinear): Mitsuba's \
                         area emitter on a rectangle has one radiance",
                        i + 1
                    ));
                }
            }
        }
    }
    let points = lights.iter().any(|l| matches!(l, LightSpec::Point { .. }));
    if plan.shading && points && !plan.hard_shadows {
        why.push("hard shadows are off: Mitsuba's integrators always trace shadow rays".into());
    }
    if plan.area_lights && !plan.soft_shadows {
        why.push("soft shadows are off: Mitsuba's integrators always trace shadow rays".into());
    }
    if plan.glossy {
        why.push("glossy reflection (the reports' perturbed mirror ray) has no Mitsuba BSDF".into());
    }
    if plan.transparency {
        why.push("alpha blending (opacity < 1) has no Mitsuba BSDF: `mask` lets light through differently".into());
    }
    if scene.background != Vec3::ZERO {
        why.push(
            "a background colour: in Mitsuba it could only be an environment emitter, which lights the scene".into(),
        );
    }
    if plan.reflections {
        if scene.params.max_depth > 1 {
            why.push(format!(
                "mirror recursion deeper than one bounce (params.max_depth {}): Mitsuba's path tracer adds diffuse \
                 interreflection, separated exactly only for one bounce (export with --max-depth 1)",
                scene.params.max_depth
            ));
        }
        if plan.area_lights {
            why.push(
                "mirrors with an area light: Mitsuba's path tracer also carries light a mirror reflects onto a \
                 diffuse surface, which the Whitted model has not"
                    .into(),
            );
        }
    }
    for m in used.iter().map(|&i| &scene.materials[i]) {
        let (kd, ks) = (max_kd(m, plan), if plan.reflections { m.ks.max_element() } else { 0.0 });
        if ks > 0.0 && kd > 0.0 && kd + ks > 1.0 {
            why.push(format!(
                "material '{}': max Kd {kd} + max Ks {ks} > 1: no blendbsdf weight keeps both reflectances within [0, 1]",
                m.name
            ));
        } else if kd > 1.0 || ks > 1.0 {
            why.push(format!("material '{}': a reflectance above 1 (Kd {kd}, Ks {ks}): Mitsuba refuses it", m.name));
        }
    }
    let noisy = plan.depth_of_field || (plan.shading && plan.area_lights) || needs_blend(scene, plan);
    if noisy && scene.spp == 1 {
        why.push(
            "one camera sample at each pixel centre with lens, area-light or blended-BSDF sampling: Mitsuba's own \
             render loop integrates over the pixel (export with --spp 4 or more)"
                .into(),
        );
    }
    why
}

/// Indices of the materials some triangle or sphere uses.
fn used_materials(scene: &Scene) -> Vec<usize> {
    let mut used = vec![false; scene.materials.len()];
    for t in &scene.triangle_shading {
        used[t.material as usize] = true;
    }
    for &m in &scene.sphere_materials {
        used[m as usize] = true;
    }
    used.iter().enumerate().filter(|(_, u)| **u).map(|(i, _)| i).collect()
}

/// Largest diffuse reflectance of `m` (over its texels when textured).
fn max_kd(m: &Material, plan: &Plan) -> f32 {
    match (&m.kd_texture, plan.textures) {
        (Some(t), true) => t.texels.iter().fold(m.kd.max_element(), |a, c| a.max(c.max_element())),
        _ => m.kd.max_element(),
    }
}

/// True when some used material mixes a diffuse and a mirror component (a `blendbsdf`, which
/// picks one component per sample: the image is then noisy).
pub fn needs_blend(scene: &Scene, plan: &Plan) -> bool {
    plan.reflections && used_materials(scene).iter().any(|&i| matches!(kind(&scene.materials[i], plan), Kind::Blend(_)))
}

/// The Mitsuba BSDF of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// `diffuse`.
    Diffuse,
    /// Smooth `conductor` (a perfect mirror weighted by Ks).
    Mirror,
    /// `blendbsdf` of `diffuse` and `conductor` with the conductor's weight.
    Blend(f32),
}

/// The BSDF kind of `m` under `plan`.
pub fn kind(m: &Material, plan: &Plan) -> Kind {
    if !plan.reflections || !m.is_reflective() {
        Kind::Diffuse
    } else if m.kd == Vec3::ZERO && (m.kd_texture.is_none() || !plan.textures) {
        Kind::Mirror
    } else {
        // The largest weight that keeps the diffuse reflectance within [0, 1]: the fewest samples
        // spent on the diffuse component, whose continuation only carries interreflection.
        Kind::Blend(1.0 - max_kd(m, plan))
    }
}

impl Kind {
    /// Factor on the diffuse reflectance (the blend divides it by `1 - w`; the products are
    /// clamped to 1, which only removes the rounding of `1 / (1 - w)`).
    pub fn diffuse_factor(self) -> f32 {
        match self {
            Kind::Blend(w) => 1.0 / (1.0 - w),
            _ => 1.0,
        }
    }

    /// Mitsuba's plugin names, for the export report.
    pub fn describe(self) -> &'static str {
        match self {
            Kind::Diffuse => "twosided(diffuse)",
            Kind::Mirror => "twosided(conductor, material none)",
            Kind::Blend(_) => "twosided(blendbsdf(diffuse, conductor material none))",
        }
    }
}

/// How the Mitsuba side makes one image of a native export (in `rtdiff.json`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Recipe {
    /// Emitter files, one render each, summed (one per light when there are several).
    pub lights: Vec<String>,
    /// `(BSDF file, weight)`: the image is the weighted sum of one render per file, all with
    /// the same seed (`4 L(1/2) - L(1)` for one mirror bounce, else one term of weight 1).
    pub terms: Vec<(String, f64)>,
    /// Samples per pixel of each render.
    pub spp: u32,
}

/// Diffuse-reflectance scales of the BSDF files: `[1]`, or `[1/2, 1]` for one mirror bounce.
pub fn albedo_scales(plan: &Plan) -> &'static [f32] {
    if plan.reflections { &[0.5, 1.0] } else { &[1.0] }
}

/// File name of the BSDFs with diffuse reflectances scaled by `s`.
pub fn bsdf_file(s: f32) -> String {
    if s == 1.0 { "bsdfs/albedo_1.xml".into() } else { "bsdfs/albedo_half.xml".into() }
}

/// The recipe of an export with `n_lights` lights: each light from its own file when there are
/// several (Mitsuba's integrators pick one emitter at random per sample: one sample per pixel
/// would see one light, and many samples would carry the choice's noise).
pub fn recipe(plan: &Plan, n_lights: usize, spp: u32) -> Recipe {
    let lights = if n_lights > 1 {
        (0..n_lights).map(|k| format!("emitters/light{k}.xml")).collect()
    } else {
        vec!["emitters/all.xml".into()]
    };
    let terms = if plan.reflections {
        vec![(bsdf_file(0.5), 4.0), (bsdf_file(1.0), -1.0)]
    } else {
        vec![(bsdf_file(1.0), 1.0)]
    };
    Recipe { lights, terms, spp }
}

/// The integrator element.
pub fn write_integrator(xml: &mut String, plan: &Plan, scene: &Scene) {
    if plan.reflections {
        let _ =
            writeln!(xml, "    <!-- One mirror bounce: camera, mirror, diffuse, light. max_depth 3 also carries one");
        let _ = writeln!(xml, "         bounce of diffuse interreflection, removed by the recipe in rtdiff.json. -->");
        let _ = writeln!(xml, "    <integrator type=\"path\">");
        let _ = writeln!(xml, "        <integer name=\"max_depth\" value=\"3\"/>");
        let _ = writeln!(xml, "        <integer name=\"rr_depth\" value=\"1000\"/>");
    } else {
        let samples = if plan.area_lights { scene.params.light_samples.max(1) } else { 1 };
        let _ = writeln!(xml, "    <integrator type=\"direct\">");
        let _ = writeln!(xml, "        <integer name=\"emitter_samples\" value=\"{samples}\"/>");
        let _ = writeln!(xml, "        <integer name=\"bsdf_samples\" value=\"0\"/>");
    }
    // rtdiff's lights are not surfaces: a camera ray never sees one.
    let _ = writeln!(xml, "        <boolean name=\"hide_emitters\" value=\"true\"/>");
    let _ = writeln!(xml, "    </integrator>");
}

/// One BSDF element with id `id` (the material's diffuse part given by `reflectance`, an
/// `<rgb>` or `<texture>` element named "reflectance", already scaled).
pub fn write_bsdf(xml: &mut String, id: &str, kind: Kind, reflectance: &str, ks: Vec3) {
    let _ = writeln!(xml, "    <bsdf type=\"twosided\" id=\"{id}\">");
    match kind {
        Kind::Diffuse => {
            let _ = writeln!(xml, "        <bsdf type=\"diffuse\">\n{reflectance}        </bsdf>");
        }
        Kind::Mirror => write_conductor(xml, ks),
        Kind::Blend(w) => {
            let _ = writeln!(xml, "        <bsdf type=\"blendbsdf\">");
            let _ = writeln!(xml, "            <float name=\"weight\" value=\"{w}\"/>");
            let _ = writeln!(xml, "            <bsdf type=\"diffuse\">\n{reflectance}            </bsdf>");
            write_conductor(xml, ks / w);
            let _ = writeln!(xml, "        </bsdf>");
        }
    }
    let _ = writeln!(xml, "    </bsdf>");
}

fn write_conductor(xml: &mut String, ks: Vec3) {
    let _ = writeln!(xml, "        <bsdf type=\"conductor\">");
    let _ = writeln!(xml, "            <string name=\"material\" value=\"none\"/>");
    let _ = writeln!(xml, "            <rgb name=\"specular_reflectance\" value=\"{}, {}, {}\"/>", ks.x, ks.y, ks.z);
    let _ = writeln!(xml, "        </bsdf>");
}

/// The emitter elements of one light.
pub fn write_light(xml: &mut String, light: &LightSpec) {
    match *light {
        LightSpec::Point { position, color } => {
            let _ = writeln!(xml, "    <emitter type=\"point\">");
            let _ = writeln!(
                xml,
                "        <point name=\"position\" value=\"{}, {}, {}\"/>",
                position.x, position.y, position.z
            );
            let _ = writeln!(xml, "        <rgb name=\"intensity\" value=\"{}, {}, {}\"/>", color.x, color.y, color.z);
            let _ = writeln!(xml, "    </emitter>");
        }
        LightSpec::Parallelogram { v0, edge01, edge02, colors } => {
            // The rectangle's [-1, 1]^2 mapped onto the parallelogram; local +z (its emitting side)
            // onto edge01 x edge02, the side rtdiff's light emits on.
            let n = crate::geometry::unit_or_zero(edge01.cross(edge02));
            let (c0, c1, c3) = (edge01 * 0.5, edge02 * 0.5, v0 + (edge01 + edge02) * 0.5);
            let m = [[c0.x, c1.x, n.x, c3.x], [c0.y, c1.y, n.y, c3.y], [c0.z, c1.z, n.z, c3.z], [0.0, 0.0, 0.0, 1.0]];
            let values: Vec<String> = m.iter().flatten().map(|v| v.to_string()).collect();
            let c = colors[0];
            let _ = writeln!(xml, "    <shape type=\"rectangle\">");
            let _ = writeln!(xml, "        <transform name=\"to_world\">");
            let _ = writeln!(xml, "            <matrix value=\"{}\"/>", values.join(" "));
            let _ = writeln!(xml, "        </transform>");
            // Black: the light's surface reflects nothing (rtdiff's lights are not surfaces).
            let _ =
                writeln!(xml, "        <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0, 0, 0\"/></bsdf>");
            let _ = writeln!(xml, "        <emitter type=\"area\">");
            let _ = writeln!(xml, "            <rgb name=\"radiance\" value=\"{}, {}, {}\"/>", c.x, c.y, c.z);
            let _ = writeln!(xml, "        </emitter>");
            let _ = writeln!(xml, "    </shape>");
        }
        // Never written: a segment light is a blocker.
        LightSpec::Segment { .. } => {}
    }
}

/// A file of the export holding `body` as a Mitsuba scene fragment (for `<include>`).
pub fn fragment(body: &str) -> String {
    format!("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<scene version=\"3.0.0\">\n{body}</scene>\n")
}
