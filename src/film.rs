//! The film: a linear RGB image and its output formats.

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::texture::linear_to_srgb;

/// A linear RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, pixels: vec![Vec3::ZERO; width as usize * height as usize] }
    }

    /// Pixel at column `x`, row `y`.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// 8-bit sRGB-encoded bytes (values clamped to [0, 1]).
    pub fn to_srgb8(&self) -> Vec<u8> {
        let enc = |c: f32| (linear_to_srgb(c.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
        self.pixels.iter().flat_map(|p| [enc(p.x), enc(p.y), enc(p.z)]).collect()
    }

    /// Write by extension: `.png` (8-bit sRGB) or `.exr` (linear float).
    pub fn write(&self, path: &Path) -> Result<()> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => image::save_buffer(path, &self.to_srgb8(), self.width, self.height, image::ColorType::Rgb8)
                .map_err(|e| Error::file(path, format!("cannot write PNG: {e}"))),
            Some("exr") => exr::prelude::write_rgb_file(path, self.width as usize, self.height as usize, |x, y| {
                let p = self.pixels[y * self.width as usize + x];
                (p.x, p.y, p.z)
            })
            .map_err(|e| Error::file(path, format!("cannot write EXR: {e}"))),
            _ => Err(Error::file(path, "unknown output format: use a .png or .exr file name")),
        }
    }

    /// Read a linear EXR written by [`Image::write`] (or any RGB EXR).
    pub fn read_exr(path: &Path) -> Result<Self> {
        let img = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| Image::new(res.width() as u32, res.height() as u32),
            |img: &mut Image, pos: exr::prelude::Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = img.width as usize;
                img.pixels[pos.y() * w + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .map_err(|e| Error::file(path, format!("cannot read EXR: {e}")))?;
        Ok(img.layer_data.channel_data.pixels)
    }
}
