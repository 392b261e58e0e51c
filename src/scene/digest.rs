//! A fingerprint of what a loaded scene actually renders: the float32
//! triangles, shading normals and uvs, spheres, materials with their texture
//! texels and wrap mode, lights and camera, exactly as the tracers and the integrator see
//! them (after mesh normalisation, transforms and texture decoding).
//!
//! A reference image made from a scene (reference/, issue 9) records this
//! digest next to the scene file's sha256: a change in the code that places
//! meshes (normalisation, transforms, loaders) or decodes textures leaves the
//! scene file alone but changes the digest, so a stale reference is detected
//! instead of being compared against a different scene.

use glam::{Vec2, Vec3};
use sha2::{Digest, Sha256};

use super::Scene;

/// Version tag hashed first: bump it when the byte layout below changes.
const TAG: &[u8] = b"rtdiff-traced-scene-1";

/// Hex sha256 of everything `scene` renders (see the module doc). Floats are
/// hashed by their little-endian IEEE bits, so the digest is the same on every
/// platform and changes with any bit of any traced value.
pub fn traced_sha256(scene: &Scene) -> String {
    let mut h = Sha256::new();
    h.update(TAG);
    let u32s = |h: &mut Sha256, v: &[u32]| v.iter().for_each(|x| h.update(x.to_le_bytes()));
    let f32s = |h: &mut Sha256, v: &[f32]| v.iter().for_each(|x| h.update(x.to_le_bytes()));
    let v3 = |h: &mut Sha256, v: Vec3| f32s(h, &v.to_array());
    let v2 = |h: &mut Sha256, v: Vec2| f32s(h, &v.to_array());

    // Zero-area triangles keep their place among the primitives (ids are file positions) but
    // render nothing: they are left out, so the digest is that of what can be seen (and equals
    // the digest of the same scene loaded with them dropped, as before issue 48).
    let seen =
        || scene.prims.triangles.iter().zip(&scene.triangle_shading).filter(|(t, _)| !crate::mesh::zero_area(t.v));
    u32s(&mut h, &[seen().count() as u32, scene.prims.spheres.len() as u32]);
    for (t, sh) in seen() {
        t.v.iter().for_each(|&p| v3(&mut h, p));
        sh.normals.iter().for_each(|&n| v3(&mut h, n));
        sh.uvs.iter().for_each(|&uv| v2(&mut h, uv));
        u32s(&mut h, &[sh.has_uvs as u32, sh.material]);
    }
    for (s, &m) in scene.prims.spheres.iter().zip(&scene.sphere_materials) {
        v3(&mut h, s.center);
        f32s(&mut h, &[s.radius]);
        u32s(&mut h, &[m]);
    }
    u32s(&mut h, &[scene.materials.len() as u32]);
    for m in &scene.materials {
        v3(&mut h, m.kd);
        v3(&mut h, m.ks);
        f32s(&mut h, &[m.shininess, m.opacity]);
        u32s(&mut h, &[m.model as u32]);
        match &m.kd_texture {
            Some(t) => {
                u32s(&mut h, &[1, t.width, t.height, m.wrap as u32]);
                t.texels.iter().for_each(|&c| v3(&mut h, c));
            }
            None => u32s(&mut h, &[0]),
        }
    }
    // Lights through their parametrisation: corners' positions and colours.
    u32s(&mut h, &[scene.lights.len() as u32]);
    for l in &scene.lights {
        u32s(&mut h, &[l.is_point() as u32]);
        for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
            v3(&mut h, l.position_at(u, v));
            v3(&mut h, l.color_at(u, v));
        }
    }
    let c = &scene.camera;
    [c.position, c.forward, c.right, c.up].into_iter().for_each(|v| v3(&mut h, v));
    f32s(&mut h, &[c.tan_half_fov, c.aperture_radius, c.focus_distance]);
    u32s(&mut h, &[c.width, c.height]);
    v3(&mut h, scene.background);
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    fn scene(name: &str) -> Scene {
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap()
    }

    #[test]
    fn same_scene_same_digest() {
        assert_eq!(traced_sha256(&scene("cube_textured.json")), traced_sha256(&scene("cube_textured.json")));
        assert_ne!(traced_sha256(&scene("cube_textured.json")), traced_sha256(&scene("cube.json")));
    }

    #[test]
    fn one_ulp_of_one_vertex_changes_the_digest() {
        let mut s = scene("cornell_box.json");
        let before = traced_sha256(&s);
        let mut prims = (*s.prims).clone();
        let v = &mut prims.triangles[7].v[2];
        v.x = f32::from_bits(v.x.to_bits() + 1);
        s.prims = std::sync::Arc::new(prims);
        assert_ne!(traced_sha256(&s), before);
    }

    #[test]
    fn a_zero_area_triangle_leaves_the_digest_alone() {
        let mut s = scene("cornell_box.json");
        let before = traced_sha256(&s);
        let mut prims = (*s.prims).clone();
        let p = prims.triangles[3].v[0];
        prims.triangles.insert(5, crate::geometry::Triangle { v: [p, p, prims.triangles[3].v[1]] });
        s.triangle_shading.insert(5, s.triangle_shading[3]);
        s.prims = std::sync::Arc::new(prims);
        assert_eq!(traced_sha256(&s), before);
    }

    #[test]
    fn a_texel_and_a_normal_change_the_digest() {
        let mut s = scene("cube_textured.json");
        let before = traced_sha256(&s);
        s.triangle_shading[0].normals[1].y += 1e-6;
        let after_normal = traced_sha256(&s);
        assert_ne!(after_normal, before);
        let m = s.materials.iter_mut().find(|m| m.kd_texture.is_some()).unwrap();
        let mut t = (**m.kd_texture.as_ref().unwrap()).clone();
        t.texels[3].z += 1e-6;
        m.kd_texture = Some(std::sync::Arc::new(t));
        assert_ne!(traced_sha256(&s), after_normal);
    }
}
