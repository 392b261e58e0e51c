//! Scenes: loading a scene file into the primitives, shading data, lights and
//! camera that the renderer and every tracer use.

pub mod digest;
pub mod export;
pub mod file;
pub mod validate;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Mat3, Vec2, Vec3};

use crate::backends::{AccelConfig, Backend, Builder};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::features::{Features, Params, Plan};
use crate::geometry::{Primitives, Sphere, Triangle};
use crate::light::{Light, ParallelogramLight, PointLight, SegmentLight};
use crate::material::Material;
use crate::mesh::{Mesh, MtlMaterial};
use crate::shading::ShadingModelKind;
use crate::texture::Texture;

pub use file::SceneFile;

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

/// Command-line overrides applied on top of a scene file.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// Image width.
    pub width: Option<u32>,
    /// Image height.
    pub height: Option<u32>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Seed.
    pub seed: Option<u64>,
    /// Feature switches `(name, on)`.
    pub features: Vec<(String, bool)>,
    /// Backend.
    pub backend: Option<Backend>,
    /// BVH builder.
    pub builder: Option<Builder>,
    /// BVH traversal.
    pub traversal: Option<crate::backends::Traversal>,
    /// Triangle test.
    pub triangle_test: Option<crate::geometry::TriangleTest>,
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
    /// Zero-area triangles dropped while loading.
    pub degenerate_skipped: usize,
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
        if let Some(w) = ov.width {
            file.image.width = w;
        }
        if let Some(h) = ov.height {
            file.image.height = h;
        }
        if let Some(s) = ov.spp {
            file.image.spp = s;
        }
        if let Some(s) = ov.seed {
            file.image.seed = s;
        }
        for (name, on) in &ov.features {
            *file.features.get_mut(name).ok_or_else(|| {
                Error::Invalid(format!(
                    "unknown feature '{name}' (known: {})",
                    crate::features::FEATURE_NAMES.join(", ")
                ))
            })? = *on;
        }
        let a = &mut file.accel;
        a.backend = ov.backend.or(a.backend);
        a.builder = ov.builder.or(a.builder);
        a.traversal = ov.traversal.or(a.traversal);
        a.triangle_test = ov.triangle_test.or(a.triangle_test);
        let dir = path.parent().unwrap_or(Path::new("."));
        Self::from_file(&file, dir, path)
    }

    /// Build a scene from a parsed file; relative paths resolve against `dir`,
    /// and errors name `path`.
    pub fn from_file(file: &SceneFile, dir: &Path, path: &Path) -> Result<Self> {
        validate::check_file(file, path)?;
        let bad = |msg: String| Error::file(path, msg);
        let img = &file.image;
        if img.width == 0 || img.height == 0 {
            return Err(bad(format!(
                "image size {}x{} is empty: width and height must be at least 1",
                img.width, img.height
            )));
        }
        if img.spp == 0 {
            return Err(bad("image.spp must be at least 1".into()));
        }
        let p = &file.params;
        if p.light_samples == 0 || p.glossy_samples == 0 || p.dof_samples == 0 {
            return Err(bad("params: light_samples, glossy_samples and dof_samples must be at least 1".into()));
        }
        let kernel_ok = p.bloom.kernel_size.is_finite() && p.bloom.kernel_size >= 1.0;
        if !kernel_ok || !p.bloom.threshold.is_finite() {
            return Err(bad("params.bloom: kernel_size must be >= 1 and threshold finite".into()));
        }
        if let crate::geometry::offset::SpawnOffset::Fixed { epsilon } = p.ray_offset
            && !(epsilon >= 0.0 && epsilon.is_finite())
        {
            return Err(bad("params.ray_offset.epsilon must be a finite number >= 0".into()));
        }
        let cam = &file.camera;
        if !(cam.fov > 0.0 && cam.fov < 180.0) {
            return Err(bad(format!("camera.fov must be in (0, 180) degrees, got {}", cam.fov)));
        }
        if (cam.look_at - cam.position).length_squared() == 0.0
            || (cam.look_at - cam.position).normalize().cross(cam.up).length_squared() == 0.0
        {
            return Err(bad("camera: look_at must differ from position and not lie along up".into()));
        }
        let aperture_ok = cam.aperture.is_finite() && cam.aperture >= 0.0;
        if !aperture_ok || cam.focus_distance.is_some_and(|d| d.is_nan() || d <= 0.0) {
            return Err(bad("camera: aperture must be >= 0 and focus_distance > 0".into()));
        }
        let mut camera = Camera::look_at(cam.position, cam.look_at, cam.up, cam.fov, img.width, img.height);
        camera.aperture_radius = cam.aperture;
        if let Some(d) = cam.focus_distance {
            camera.focus_distance = d;
        }

        let mut materials = vec![Material { model: file.shading_model, ..Material::default() }];
        let mut textures: HashMap<PathBuf, Arc<Texture>> = HashMap::new();
        let mut load_texture = |p: &Path, raw: bool| -> Result<Arc<Texture>> {
            if let Some(t) = textures.get(p) {
                return Ok(t.clone());
            }
            let t = Arc::new(Texture::load(p, raw)?);
            textures.insert(p.to_path_buf(), t.clone());
            Ok(t)
        };
        let mut named: HashMap<&str, u32> = HashMap::new();
        for (name, m) in &file.materials {
            let transparency = m.transparency.unwrap_or(0.0);
            if !(0.0..=1.0).contains(&transparency) {
                return Err(bad(format!("material '{name}': transparency must be in [0, 1]")));
            }
            let kd_texture = match &m.kd_texture {
                Some(t) => Some(
                    load_texture(&dir.join(t), m.texture_raw)
                        .map_err(|e| bad(format!("materials.{name}.kd_texture: {e}")))?,
                ),
                None => None,
            };
            let mat = Material {
                name: name.clone(),
                kd: m.kd.unwrap_or(Vec3::ONE),
                ks: m.ks.unwrap_or(Vec3::ZERO),
                shininess: m.shininess.unwrap_or(1.0),
                opacity: 1.0 - transparency,
                kd_texture,
                model: m.shading_model.unwrap_or(file.shading_model),
            };
            if !(mat.kd.is_finite() && mat.ks.is_finite() && mat.shininess.is_finite()) {
                return Err(bad(format!("material '{name}' has a non-finite value")));
            }
            named.insert(name.as_str(), materials.len() as u32);
            materials.push(mat);
        }
        let lookup = |name: &str, what: &str| -> Result<u32> {
            named.get(name).copied().ok_or_else(|| bad(format!("{what} uses unknown material '{name}'")))
        };

        let mut prims = Primitives::default();
        let mut triangle_shading = Vec::new();
        let mut degenerate_skipped = 0;
        let mut warnings = Vec::new();
        for (mi, spec) in file.meshes.iter().enumerate() {
            let obj_path = dir.join(&spec.file);
            let mut mesh = crate::mesh::load_mesh(&obj_path, crate::mesh::Content::WithMaterials)
                .map_err(|e| bad(format!("meshes[{mi}].file: {e}")))?;
            degenerate_skipped += mesh.degenerate_skipped;
            warnings.append(&mut mesh.warnings);
            place_mesh(&mut mesh, spec);
            validate::check_mesh_bounds(path, &format!("meshes[{mi}]"), &spec.file, &mesh.positions)?;
            let forced = match &spec.material {
                Some(name) => Some(lookup(name, &format!("mesh {} ({})", mi + 1, spec.file))?),
                None => None,
            };
            let mut mtl_ids = Vec::with_capacity(mesh.materials.len());
            for m in &mesh.materials {
                let id = match spec.material_overrides.get(&m.name) {
                    Some(name) => lookup(name, &format!("mesh {} material override", mi + 1))?,
                    None => {
                        let mat = convert_mtl(m, file.shading_model, &mut load_texture)
                            .map_err(|e| bad(format!("meshes[{mi}] ({}): {e}", spec.file)))?;
                        materials.push(mat);
                        materials.len() as u32 - 1
                    }
                };
                mtl_ids.push(id);
            }
            for (f, t) in mesh.indices.iter().enumerate() {
                let material = forced.or_else(|| mesh.face_material[f].map(|i| mtl_ids[i as usize])).unwrap_or(0);
                let uvs = mesh.uvs.as_ref().map(|uv| t.map(|i| uv[i as usize]));
                prims.triangles.push(Triangle { v: t.map(|i| mesh.positions[i as usize]) });
                triangle_shading.push(TriangleShading {
                    normals: t.map(|i| mesh.normals[i as usize]),
                    uvs: uvs.unwrap_or([Vec2::ZERO; 3]),
                    has_uvs: uvs.is_some(),
                    material,
                });
            }
        }
        let mut sphere_materials = Vec::new();
        for (i, s) in file.spheres.iter().enumerate() {
            if !(s.radius > 0.0 && s.radius.is_finite() && s.center.is_finite()) {
                return Err(bad(format!("sphere {} needs a finite centre and a radius > 0", i + 1)));
            }
            prims.spheres.push(Sphere { center: s.center, radius: s.radius });
            sphere_materials.push(match &s.material {
                Some(n) => lookup(n, &format!("sphere {}", i + 1))?,
                None => 0,
            });
        }

        let mut lights: Vec<Box<dyn Light>> = Vec::new();
        for (i, l) in file.lights.iter().enumerate() {
            let light: Box<dyn Light> = match *l {
                file::LightSpec::Point { position, color } => Box::new(PointLight { position, color }),
                file::LightSpec::Segment { endpoints, colors } => {
                    Box::new(SegmentLight { p0: endpoints[0], p1: endpoints[1], c0: colors[0], c1: colors[1] })
                }
                file::LightSpec::Parallelogram { v0, edge01, edge02, colors } => {
                    if edge01.cross(edge02).length_squared() == 0.0 {
                        return Err(bad(format!("light {}: parallelogram edges are parallel (zero area)", i + 1)));
                    }
                    Box::new(ParallelogramLight { v0, edge01, edge02, colors })
                }
            };
            let finite = [light.position_at(0.0, 0.0), light.position_at(1.0, 1.0), light.color_at(0.5, 0.5)]
                .iter()
                .all(|v| v.is_finite());
            if !finite {
                return Err(bad(format!("light {} has a non-finite position or colour", i + 1)));
            }
            lights.push(light);
        }

        let a = &file.accel;
        let d = AccelConfig::default();
        let accel = AccelConfig {
            backend: a.backend.unwrap_or(if file.features.bvh { Backend::Native } else { Backend::Brute }),
            builder: a.builder.unwrap_or(if file.features.sah { Builder::Sah } else { Builder::Median }),
            traversal: a.traversal.unwrap_or(d.traversal),
            triangle_test: a.triangle_test.unwrap_or(d.triangle_test),
            leaf_size: a.leaf_size.unwrap_or(d.leaf_size).max(1),
            bins: a.bins.unwrap_or(d.bins).max(2),
            embree_quality: a.embree_quality.unwrap_or(d.embree_quality),
        };

        Ok(Self {
            path: path.to_path_buf(),
            prims: Arc::new(prims),
            triangle_shading,
            sphere_materials,
            materials,
            lights,
            camera,
            width: img.width,
            height: img.height,
            spp: img.spp,
            seed: img.seed,
            background: img.background,
            features: file.features,
            params: file.params,
            accel,
            degenerate_skipped,
            warnings,
        })
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

/// Normalise (optionally) and transform a mesh in place, normals included.
fn place_mesh(mesh: &mut Mesh, spec: &file::MeshSpec) {
    if spec.normalize {
        crate::geometry::normalize_to_unit_sphere(&mut mesh.positions);
    }
    if let Some(t) = &spec.transform {
        let r = t.rotate * (std::f32::consts::PI / 180.0);
        let rot = Mat3::from_rotation_z(r.z) * Mat3::from_rotation_y(r.y) * Mat3::from_rotation_x(r.x);
        let linear = rot * Mat3::from_diagonal(t.scale);
        mesh.map_positions(|p| linear * p + t.translate);
        let normal_matrix = linear.inverse().transpose();
        for n in &mut mesh.normals {
            *n = (normal_matrix * *n).normalize_or_zero();
        }
        if linear.determinant() < 0.0 {
            // A mirroring transform flips the winding: keep geometric normals consistent with shading normals.
            for t in &mut mesh.indices {
                t.swap(1, 2);
            }
        }
    }
}

fn convert_mtl(
    m: &MtlMaterial,
    model: ShadingModelKind,
    load_texture: &mut impl FnMut(&Path, bool) -> Result<Arc<Texture>>,
) -> Result<Material> {
    let kd_texture = match (&m.map_kd, &m.map_kd_source) {
        (Some(p), Some(src)) => Some(load_texture(p, false).map_err(|e| texture_error(src, e))?),
        (Some(p), None) => Some(load_texture(p, false)?),
        _ => None,
    };
    Ok(Material {
        name: m.name.clone(),
        kd: m.kd.unwrap_or(Vec3::ONE),
        ks: m.ks.unwrap_or(Vec3::ZERO),
        shininess: m.ns.unwrap_or(1.0),
        opacity: m.opacity.unwrap_or(1.0).clamp(0.0, 1.0),
        kd_texture,
        model,
    })
}

/// A texture named in an MTL file that cannot be loaded: the error names the MTL line,
/// the name as written and the paths tried.
fn texture_error(src: &crate::mesh::TextureSource, e: Error) -> Error {
    let tried: Vec<String> = src.tried.iter().map(|p| p.display().to_string()).collect();
    Error::at(&src.mtl, src.line, format!("map_Kd '{}': {e} (tried {})", src.written, tried.join(", ")))
}
