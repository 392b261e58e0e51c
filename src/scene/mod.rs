//! Scenes: loading a scene file into the primitives, shading data, lights and
//! camera that the renderer and every tracer use.

pub mod digest;
pub mod export;
pub mod file;
mod materials;
mod meshes;
mod overrides;
pub mod validate;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Vec2, Vec3};

use crate::backends::AccelConfig;
use crate::camera::Camera;
use crate::error::Result;
use crate::features::{Features, Params, Plan};
use crate::geometry::{Primitives, Sphere};
use crate::light::Light;
use crate::material::Material;

pub use file::SceneFile;
pub use overrides::Overrides;

/// Shading data of one triangle (indexed like the triangle's primitive id).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleShading {
    /// Unit vertex normals.
    pub normals: [Vec3; 3],
    /// Vertex texture coordinates (zero when the mesh has none).
    pub uvs: [Vec2; 3],
    /// Whether `uvs` came from the file.
    pub has_uvs: bool,
    /// Index into [`Scene::materials`].
    pub material: u32,
}

/// A loaded scene.
pub struct Scene {
    /// The scene file (for messages).
    pub path: PathBuf,
    /// Geometry as the tracers see it.
    pub prims: Arc<Primitives>,
    /// Per-triangle shading data.
    pub triangle_shading: Vec<TriangleShading>,
    /// Per-sphere material index.
    pub sphere_materials: Vec<u32>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Vec<Box<dyn Light>>,
    /// Camera (already sized to the image).
    pub camera: Camera,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Camera samples per pixel.
    pub spp: u32,
    /// Random seed.
    pub seed: u64,
    /// Colour of missed rays.
    pub background: Vec3,
    /// Feature switches.
    pub features: Features,
    /// Feature parameters.
    pub params: Params,
    /// Acceleration structure to build.
    pub accel: AccelConfig,
    /// Zero-area triangles among the meshes' triangles (kept in place: ids are file positions).
    pub zero_area: usize,
    /// The primitive id of each `meshes[]` entry's first triangle ([`Scene::primitive_origin`]).
    pub mesh_starts: Vec<u32>,
    /// Problems in the mesh files that did not stop the load (`file:line: what`).
    pub warnings: Vec<String>,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("path", &self.path)
            .field("triangles", &self.prims.triangles.len())
            .field("spheres", &self.prims.spheres.len())
            .field("lights", &self.lights.len())
            .finish()
    }
}

impl Scene {
    /// Load a scene file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_with(path, &Overrides::default())
    }

    /// Load a scene file and apply command-line overrides.
    pub fn load_with(path: &Path, ov: &Overrides) -> Result<Self> {
        Self::from_file_with(validate::read_scene_file(path)?, path, ov)
    }

    /// Read a scene file without building the scene (errors name `path`).
    pub fn read_file(path: &Path) -> Result<SceneFile> {
        validate::read_scene_file(path)
    }

    /// Build a scene from a parsed file that lives at `path` (relative paths
    /// resolve against its folder), with command-line overrides applied.
    pub fn from_file_with(mut file: SceneFile, path: &Path, ov: &Overrides) -> Result<Self> {
        ov.apply(&mut file)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Self::from_file(&file, dir, path)
    }

    /// Build a scene from a parsed file; relative paths resolve against `dir`,
    /// and errors name `path`. Steps: check the file ([`validate::check_file`]),
    /// the named materials, the meshes (each file read once) with their MTL
    /// materials, the spheres, the lights, the camera and the acceleration
    /// structure's configuration.
    pub fn from_file(file: &SceneFile, dir: &Path, path: &Path) -> Result<Self> {
        validate::check_file(file, path)?;
        let mut materials = materials::MaterialTable::from_file(file, dir, path)?;
        let meshes = meshes::load_meshes(&file.meshes, dir, path, &mut materials)?;
        let (spheres, sphere_materials) = spheres(file, &materials)?;
        validate::check_primitive_total(path, "spheres", meshes.triangles.len(), spheres.len())?;
        let img = &file.image;
        Ok(Self {
            path: path.to_path_buf(),
            prims: Arc::new(Primitives { triangles: meshes.triangles, spheres }),
            triangle_shading: meshes.shading,
            sphere_materials,
            materials: materials.into_materials(),
            lights: file.lights.iter().map(file::LightSpec::light).collect(),
            camera: file.camera.camera(img.width, img.height),
            width: img.width,
            height: img.height,
            spp: img.spp,
            seed: img.seed,
            background: img.background,
            features: file.features,
            params: file.params,
            accel: file.accel.resolve(&file.features),
            zero_area: meshes.zero_area,
            mesh_starts: meshes.mesh_starts,
            warnings: meshes.warnings,
        })
    }

    /// Where primitive `prim` comes from in the scene file: `meshes[M] triangle K` (`K` the
    /// triangle's position in that mesh's file) or `sphere J`.
    pub fn primitive_origin(&self, prim: u32) -> String {
        match self.prims.sphere_index(prim as usize) {
            Some(j) => format!("sphere {j}"),
            None => {
                let m = self.mesh_starts.partition_point(|&s| s <= prim).saturating_sub(1);
                let start = self.mesh_starts.get(m).copied().unwrap_or(0);
                format!("meshes[{m}] triangle {}", prim - start)
            }
        }
    }

    /// Material index of primitive `prim`.
    #[inline]
    pub fn material_of(&self, prim: u32) -> u32 {
        match self.prims.sphere_index(prim as usize) {
            None => self.triangle_shading[prim as usize].material,
            Some(s) => self.sphere_materials[s],
        }
    }

    /// Decide once what this render needs (see [`Plan`]).
    pub fn plan(&self) -> Plan {
        let mut used = vec![false; self.materials.len()];
        for t in &self.triangle_shading {
            used[t.material as usize] = true;
        }
        for &m in &self.sphere_materials {
            used[m as usize] = true;
        }
        let any = |f: &dyn Fn(&Material) -> bool| self.materials.iter().zip(&used).any(|(m, &u)| u && f(m));
        let f = &self.features;
        let depth = self.params.max_depth > 0;
        let textured = any(&|m| m.kd_texture.is_some()) && self.triangle_shading.iter().any(|t| t.has_uvs);
        let reflections = f.recursive && depth && any(&|m| m.is_reflective());
        let area_lights = self.lights.iter().any(|l| !l.is_point());
        Plan {
            shading: f.shading,
            textures: f.texture_mapping && textured,
            bilinear: f.bilinear_filtering,
            normal_interpolation: f.normal_interpolation && !self.triangle_shading.is_empty(),
            reflections,
            glossy: reflections && f.glossy,
            transparency: f.transparency && depth && any(&|m| m.is_transparent()),
            hard_shadows: f.shading && f.hard_shadows && self.lights.iter().any(|l| l.is_point()),
            soft_shadows: f.shading && f.soft_shadows && area_lights,
            area_lights: f.shading && area_lights,
            depth_of_field: f.depth_of_field && self.camera.aperture_radius > 0.0,
            bloom: f.bloom,
        }
    }
}

/// The spheres of `file` and the index of each one's material.
fn spheres(file: &SceneFile, materials: &materials::MaterialTable) -> Result<(Vec<Sphere>, Vec<u32>)> {
    let shapes = file.spheres.iter().map(|s| Sphere { center: s.center, radius: s.radius }).collect();
    let ids = file
        .spheres
        .iter()
        .enumerate()
        .map(|(i, s)| match &s.material {
            Some(n) => materials.lookup(n, &format!("sphere {}", i + 1)),
            None => Ok(0),
        })
        .collect::<Result<_>>()?;
    Ok((shapes, ids))
}
