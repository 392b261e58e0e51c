//! The film: a linear RGB image and its file formats ([`io`]).

pub mod io;

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
            Some("png") => io::write_png(self, path),
            // Byte-deterministic (see [`io::encode_exr`]): same pixels, same file.
            Some("exr") => io::write_exr(self, path),
            _ => Err(Error::file(path, "unknown output format: use a .png or .exr file name")),
        }
    }

    /// Read the R, G and B channels of an EXR (see [`io::read_exr`]).
    pub fn read_exr(path: &Path) -> Result<Self> {
        io::read_exr(path)
    }
}
