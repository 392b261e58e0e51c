//! `rtdiff export --to obj`: a loaded scene as a Wavefront OBJ + MTL pair that any other
//! renderer or course tracer reads, with the camera and lights (which OBJ cannot hold) in a
//! small JSON file beside it.
//!
//! The OBJ holds every triangle rtdiff traces, in primitive-id order (face `i` of the file is
//! primitive `i`, so hits compare id for id with `rtdiff trace` and `rtdiff judge` on the OBJ),
//! with three vertices of its own each, the float32 coordinates written exactly (shortest
//! round-trip decimals), vertex normals and texture coordinates, and a `usemtl` per run of
//! one material. Spheres have no OBJ form: they are listed in the JSON and named in a warning.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{Error, Result};
use crate::scene::Scene;

/// What `export --to obj` wrote.
#[derive(Clone, Debug, Serialize)]
pub struct ObjExport {
    /// Files written (`scene.obj`, `scene.mtl`, `scene.json`).
    pub files: Vec<PathBuf>,
    /// Triangles written (primitive ids `0..triangles`).
    pub triangles: usize,
    /// What the OBJ cannot hold (spheres, textures by file).
    pub warnings: Vec<String>,
}

/// The camera and lights of the exported scene, in the OBJ's coordinates.
#[derive(Serialize)]
struct Sidecar<'a> {
    obj: &'a str,
    width: u32,
    height: u32,
    camera: CameraJson,
    lights: Vec<String>,
    spheres: Vec<[f32; 4]>,
}

#[derive(Serialize)]
struct CameraJson {
    position: [f32; 3],
    forward: [f32; 3],
    up: [f32; 3],
    right: [f32; 3],
    vertical_fov_degrees: f32,
}

fn f(x: f32) -> String {
    // Shortest round-trip form: reads back to the same float32.
    format!("{x}")
}

/// Write `scene` as `out/scene.obj`, `out/scene.mtl` and `out/scene.json`.
pub fn export_obj(scene: &Scene, out: &Path) -> Result<ObjExport> {
    std::fs::create_dir_all(out).map_err(|e| Error::file(out, format!("cannot create the folder: {e}")))?;
    let mut obj = String::from("# rtdiff export --to obj: face i is rtdiff's primitive i\nmtllib scene.mtl\n");
    let mut current = None;
    for (i, (t, sh)) in scene.prims.triangles.iter().zip(&scene.triangle_shading).enumerate() {
        for p in t.v {
            let _ = writeln!(obj, "v {} {} {}", f(p.x), f(p.y), f(p.z));
        }
        for n in sh.normals {
            let _ = writeln!(obj, "vn {} {} {}", f(n.x), f(n.y), f(n.z));
        }
        for uv in sh.uvs {
            let _ = writeln!(obj, "vt {} {}", f(uv.x), f(uv.y));
        }
        if current != Some(sh.material) {
            current = Some(sh.material);
            let _ = writeln!(obj, "usemtl m{}", sh.material);
        }
        let b = 3 * i + 1;
        let _ = writeln!(obj, "f {}/{}/{} {}/{}/{} {}/{}/{}", b, b, b, b + 1, b + 1, b + 1, b + 2, b + 2, b + 2);
    }
    let mut warnings = Vec::new();
    let mut mtl = String::from("# rtdiff export --to obj\n");
    for (k, m) in scene.materials.iter().enumerate() {
        let _ = writeln!(
            mtl,
            "newmtl m{k}\n# {}\nKd {} {} {}\nKs {} {} {}\nNs {}\nd {}",
            m.name,
            f(m.kd.x),
            f(m.kd.y),
            f(m.kd.z),
            f(m.ks.x),
            f(m.ks.y),
            f(m.ks.z),
            f(m.shininess),
            f(m.opacity)
        );
        if m.kd_texture.is_some() {
            warnings.push(format!(
                "material {} has a Kd texture, not written to the MTL (rtdiff export --to mitsuba writes the texels)",
                m.name
            ));
        }
    }
    if !scene.prims.spheres.is_empty() {
        warnings.push(format!(
            "{} spheres have no OBJ form: listed in scene.json (their ids follow the triangles')",
            scene.prims.spheres.len()
        ));
    }
    let c = &scene.camera;
    let side = Sidecar {
        obj: "scene.obj",
        width: scene.width,
        height: scene.height,
        camera: CameraJson {
            position: c.position.to_array(),
            forward: c.forward.to_array(),
            up: c.up.to_array(),
            right: c.right.to_array(),
            vertical_fov_degrees: 2.0 * c.tan_half_fov.atan().to_degrees(),
        },
        lights: scene.lights.iter().map(|l| format!("{l:?}")).collect(),
        spheres: scene.prims.spheres.iter().map(|s| [s.center.x, s.center.y, s.center.z, s.radius]).collect(),
    };
    let json = serde_json::to_string_pretty(&side).map_err(|e| Error::Invalid(format!("cannot serialise: {e}")))?;
    let mut files = Vec::new();
    for (name, text) in [("scene.obj", obj), ("scene.mtl", mtl), ("scene.json", json)] {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| Error::file(&p, format!("cannot write: {e}")))?;
        files.push(p);
    }
    Ok(ObjExport { files, triangles: scene.prims.triangles.len(), warnings })
}
