//! The scene's material table as it is built: the default material, the
//! scene file's named materials, then the MTL materials of each mesh entry,
//! with every texture file read once.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::material::Material;
use crate::mesh::{MtlMaterial, TextureSource};
use crate::shading::ShadingModelKind;
use crate::texture::Texture;

use super::SceneFile;

/// Textures read once per scene, by path and colour decoding.
#[derive(Default)]
struct TextureCache {
    loaded: HashMap<(PathBuf, bool), Arc<Texture>>,
}

impl TextureCache {
    /// The texture at `path` (`raw`: 8-bit values read as linear instead of sRGB).
    fn load(&mut self, path: &Path, raw: bool) -> Result<Arc<Texture>> {
        let key = (path.to_path_buf(), raw);
        if let Some(t) = self.loaded.get(&key) {
            return Ok(t.clone());
        }
        let t = Arc::new(Texture::load(path, raw)?);
        self.loaded.insert(key, t.clone());
        Ok(t)
    }

    /// A texture embedded in a mesh file (sRGB-decoded), once per name.
    fn embedded(&mut self, img: &crate::mesh::EmbeddedImage) -> Result<Arc<Texture>> {
        let key = (PathBuf::from(&img.name), false);
        if let Some(t) = self.loaded.get(&key) {
            return Ok(t.clone());
        }
        let t = Arc::new(Texture::from_memory(&img.bytes, Path::new(&img.name), false)?);
        self.loaded.insert(key, t.clone());
        Ok(t)
    }
}

/// The materials of a scene being built; index 0 is the default material.
pub(crate) struct MaterialTable<'f> {
    materials: Vec<Material>,
    named: HashMap<&'f str, u32>,
    textures: TextureCache,
    /// The scene's default shading model (MTL materials use it).
    model: ShadingModelKind,
    /// The scene file, for errors.
    path: &'f Path,
}

impl<'f> MaterialTable<'f> {
    /// The default material and the named materials of `file` (textures
    /// relative to `dir`; errors name `path`).
    pub(crate) fn from_file(file: &'f SceneFile, dir: &Path, path: &'f Path) -> Result<Self> {
        let mut table = Self {
            materials: vec![Material { model: file.shading_model, ..Material::default() }],
            named: HashMap::new(),
            textures: TextureCache::default(),
            model: file.shading_model,
            path,
        };
        for (name, m) in &file.materials {
            let kd_texture = match &m.kd_texture {
                Some(t) => Some(
                    table
                        .textures
                        .load(&dir.join(t), m.texture_raw)
                        .map_err(|e| Error::file(path, format!("materials.{name}.kd_texture: {e}")))?,
                ),
                None => None,
            };
            table.named.insert(name.as_str(), table.materials.len() as u32);
            table.materials.push(Material {
                name: name.clone(),
                kd: m.kd.unwrap_or(Vec3::ONE),
                ks: m.ks.unwrap_or(Vec3::ZERO),
                shininess: m.shininess.unwrap_or(1.0),
                opacity: 1.0 - m.transparency.unwrap_or(0.0),
                kd_texture,
                wrap: m.texture_wrap.unwrap_or_default(),
                model: m.shading_model.unwrap_or(file.shading_model),
            });
        }
        Ok(table)
    }

    /// Index of the named material `name`; `what` names the user in the error.
    pub(crate) fn lookup(&self, name: &str, what: &str) -> Result<u32> {
        self.named
            .get(name)
            .copied()
            .ok_or_else(|| Error::file(self.path, format!("{what} uses unknown material '{name}'")))
    }

    /// Add a material read from an MTL library (in the scene's shading model); returns its index.
    pub(crate) fn add_mtl(&mut self, m: &MtlMaterial) -> Result<u32> {
        let mut kd_texture = match (&m.map_kd, &m.map_kd_source, &m.map_kd_embedded) {
            (Some(p), Some(src), _) => Some(self.textures.load(p, false).map_err(|e| texture_error(src, e))?),
            (Some(p), None, _) => Some(self.textures.load(p, false)?),
            (None, _, Some(img)) => Some(self.textures.embedded(img)?),
            _ => None,
        };
        // glTF multiplies the texture by the base colour factor.
        if let (Some(t), Some(f)) = (&kd_texture, m.kd_texture_factor)
            && f != Vec3::ONE
        {
            let mut scaled = (**t).clone();
            scaled.texels.iter_mut().for_each(|c| *c *= f);
            kd_texture = Some(Arc::new(scaled));
        }
        self.materials.push(Material {
            name: m.name.clone(),
            kd: m.kd.unwrap_or(Vec3::ONE),
            ks: m.ks.unwrap_or(Vec3::ZERO),
            shininess: m.ns.unwrap_or(1.0),
            opacity: m.opacity.unwrap_or(1.0).clamp(0.0, 1.0),
            kd_texture,
            wrap: m.map_kd_wrap,
            model: self.model,
        });
        Ok(self.materials.len() as u32 - 1)
    }

    /// The finished table.
    pub(crate) fn into_materials(self) -> Vec<Material> {
        self.materials
    }
}

/// A texture named in an MTL file that cannot be loaded: the error names the MTL line,
/// the name as written and the paths tried.
fn texture_error(src: &TextureSource, e: Error) -> Error {
    let tried: Vec<String> = src.tried.iter().map(|p| p.display().to_string()).collect();
    Error::at(&src.mtl, src.line, format!("map_Kd '{}': {e} (tried {})", src.written, tried.join(", ")))
}
