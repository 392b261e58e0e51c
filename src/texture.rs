//! Image textures with nearest and bilinear lookup.
//!
//! Conventions (the reports' and Mitsuba's): `(u, v)` as in OBJ files, so
//! `v = 1` is the top row of the image; texel `(i, j)` covers
//! `[i, i+1) x [j, j+1)` in pixel units, so its centre is at `(i + 0.5, j + 0.5)`;
//! coordinates outside `[0, 1]` address the texture by the material's
//! [`WrapMode`], applied to texel indices as Mitsuba's `bitmap` does (nearest:
//! the texel of `floor(u W)`; bilinear: each of the four texels wrapped on its own).

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::limits;

/// How texture coordinates outside `[0, 1]` address a texture (Mitsuba's `bitmap` `wrap_mode`,
/// Blender's extension, the MTL `-clamp` option).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WrapMode {
    /// The texture tiles (the default, as in Mitsuba, Blender and OBJ viewers).
    #[default]
    Repeat,
    /// The texture tiles, every other copy mirrored (the edge texels repeat at each seam).
    Mirror,
    /// The border texels extend outwards (the course reports' behaviour; MTL `-clamp on`).
    Clamp,
}

impl WrapMode {
    /// The name in scene files and Mitsuba's `wrap_mode`.
    pub fn name(self) -> &'static str {
        match self {
            WrapMode::Repeat => "repeat",
            WrapMode::Mirror => "mirror",
            WrapMode::Clamp => "clamp",
        }
    }

    /// Texel index `i` of a row or column of `n` texels, wrapped into `0..n`.
    #[inline]
    pub fn index(self, i: i64, n: i64) -> usize {
        (match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
            WrapMode::Clamp => i.clamp(0, n - 1),
        }) as usize
    }
}

/// A linear-RGB texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major texels, row 0 at the top of the image.
    pub texels: Vec<Vec3>,
}

/// sRGB transfer function to linear (IEC 61966-2-1).
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Linear to sRGB transfer function (IEC 61966-2-1).
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

impl Texture {
    /// Load an image file. 8-bit images are sRGB-decoded unless `raw` (as Mitsuba's `bitmap`).
    /// The size in the file's header is checked against [`limits::MAX_TEXTURE_SIDE`] and
    /// [`limits::MAX_TEXTURE_PIXELS`] before anything is decoded.
    pub fn load(path: &Path, raw: bool) -> Result<Self> {
        if path.as_os_str().is_empty() {
            return Err(Error::Invalid("texture file name is empty".into()));
        }
        if let Err(e) = std::fs::metadata(path) {
            return Err(Error::io(path, &e));
        }
        let reader = || -> Result<image::ImageReader<std::io::BufReader<std::fs::File>>> {
            image::ImageReader::open(path)
                .map_err(|e| Error::io(path, &e))?
                .with_guessed_format()
                .map_err(|e| Error::io(path, &e))
        };
        Self::decode_with(path, raw, reader)
    }

    /// Decode an encoded image (PNG, JPEG) held in memory, such as a texture embedded in a
    /// glTF file; `name` names it in errors. The same limits and decoding as [`Texture::load`].
    pub fn from_memory(bytes: &[u8], name: &Path, raw: bool) -> Result<Self> {
        let reader = || -> Result<image::ImageReader<std::io::Cursor<&[u8]>>> {
            image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| Error::io(name, &e))
        };
        Self::decode_with(name, raw, reader)
    }

    /// Decode what `reader` reads (called twice: the header, then the pixels).
    fn decode_with<R: std::io::BufRead + std::io::Seek>(
        path: &Path,
        raw: bool,
        reader: impl Fn() -> Result<image::ImageReader<R>>,
    ) -> Result<Self> {
        let decode_err = |e: image::ImageError| Error::file(path, format!("cannot decode texture: {e}"));
        let (w, h) = reader()?.into_dimensions().map_err(decode_err)?;
        let side = limits::MAX_TEXTURE_SIDE;
        if w > side || h > side || w as u64 * h as u64 > limits::MAX_TEXTURE_PIXELS {
            return Err(Error::file(
                path,
                format!(
                    "texture is {w}x{h} texels, over the limit of {side} a side and {} in all",
                    limits::MAX_TEXTURE_PIXELS
                ),
            ));
        }
        let mut lim = image::Limits::default();
        lim.max_image_width = Some(side);
        lim.max_image_height = Some(side);
        // The decoder's own buffers: at most 16-bit RGBA (8 bytes a texel).
        lim.max_alloc = Some(limits::MAX_TEXTURE_PIXELS * 8 + (64 << 20));
        let mut r = reader()?;
        r.limits(lim);
        let img = r.decode().map_err(decode_err)?;
        let rgb = img.to_rgb32f();
        let (width, height) = rgb.dimensions();
        if width == 0 || height == 0 {
            return Err(Error::file(path, "texture has zero size"));
        }
        let decode = |c: f32| if raw { c } else { srgb_to_linear(c) };
        let texels = rgb.pixels().map(|p| Vec3::new(decode(p[0]), decode(p[1]), decode(p[2]))).collect();
        Ok(Self { width, height, texels })
    }

    #[inline]
    fn texel(&self, x: i64, y: i64, wrap: WrapMode) -> Vec3 {
        let x = wrap.index(x, self.width as i64);
        let y = wrap.index(y, self.height as i64);
        self.texels[y * self.width as usize + x]
    }

    /// The texel whose square contains `(u, v)`, outside `[0, 1]` by `wrap`.
    #[inline]
    pub fn nearest(&self, u: f32, v: f32, wrap: WrapMode) -> Vec3 {
        // `as i64` saturates: a huge or non-finite coordinate still names a texel.
        let x = (u * self.width as f32).floor() as i64;
        let y = ((1.0 - v) * self.height as f32).floor() as i64;
        self.texel(x, y, wrap)
    }

    /// Bilinear mix of the four texels whose centres surround `(u, v)`, each addressed by `wrap`.
    #[inline]
    pub fn bilinear(&self, u: f32, v: f32, wrap: WrapMode) -> Vec3 {
        let x = u * self.width as f32 - 0.5;
        let y = (1.0 - v) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let t = |dx: i64, dy: i64| self.texel(x0.saturating_add(dx), y0.saturating_add(dy), wrap);
        let top = (1.0 - fx) * t(0, 0) + fx * t(1, 0);
        let bottom = (1.0 - fx) * t(0, 1) + fx * t(1, 1);
        (1.0 - fy) * top + fy * bottom
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tex() -> Texture {
        // 2x2: top row red, green; bottom row blue, white.
        Texture { width: 2, height: 2, texels: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE] }
    }

    const C: WrapMode = WrapMode::Clamp;

    #[test]
    fn nearest_uses_texel_squares_and_obj_v() {
        let t = tex();
        assert_eq!(t.nearest(0.25, 0.75, C), Vec3::X); // top-left
        assert_eq!(t.nearest(0.75, 0.75, C), Vec3::Y); // top-right
        assert_eq!(t.nearest(0.25, 0.25, C), Vec3::Z); // bottom-left
        assert_eq!(t.nearest(0.99, 0.01, C), Vec3::ONE);
        assert_eq!(t.nearest(1.5, -3.0, C), Vec3::ONE); // clamped
    }

    /// Texel indices as Mitsuba's `bitmap` (Dr.Jit's texture `wrap`) addresses them, for a row
    /// of 3: repeat ... 1 2 | 0 1 2 | 0 1 ..., mirror ... 1 0 | 0 1 2 | 2 1 ..., clamp ... 0 0 | 0 1 2 | 2 2 ...
    #[test]
    fn wrap_modes_address_texels_as_mitsuba() {
        let idx = |w: WrapMode| (-7..=8).map(|i| w.index(i, 3)).collect::<Vec<_>>();
        assert_eq!(idx(WrapMode::Repeat), [2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0, 1, 2]);
        assert_eq!(idx(WrapMode::Mirror), [0, 0, 1, 2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0, 1, 2]);
        assert_eq!(idx(WrapMode::Clamp), [0, 0, 0, 0, 0, 0, 0, 0, 1, 2, 2, 2, 2, 2, 2, 2]);
        // One texture tile over: repeat is the same texel, mirror its reflection.
        let t = tex();
        assert_eq!(t.nearest(1.25, 0.75, WrapMode::Repeat), Vec3::X);
        assert_eq!(t.nearest(1.25, 0.75, WrapMode::Mirror), Vec3::Y);
        assert_eq!(t.nearest(-0.25, 0.75, WrapMode::Mirror), Vec3::X);
        assert_eq!(t.nearest(-0.25, 0.75, WrapMode::Repeat), Vec3::Y);
        // Bilinear at the seam: repeat blends the opposite edge, clamp and mirror do not.
        assert_eq!(t.bilinear(1.0, 0.75, WrapMode::Repeat), 0.5 * (Vec3::X + Vec3::Y));
        assert_eq!(t.bilinear(1.0, 0.75, WrapMode::Mirror), Vec3::Y);
        assert_eq!(t.bilinear(1.0, 0.75, C), Vec3::Y);
        // Far outside and non-finite coordinates still name a texel.
        for w in [WrapMode::Repeat, WrapMode::Mirror, C] {
            for u in [1e30, -1e30, f32::NAN, f32::INFINITY] {
                let _ = (t.nearest(u, u, w), t.bilinear(u, -u, w));
            }
        }
    }

    #[test]
    fn bilinear_mixes_the_four_texels_at_known_weights() {
        let t = tex();
        // At texel centres it returns the texel.
        assert_eq!(t.bilinear(0.25, 0.75, C), Vec3::X);
        // The image centre is the average of all four.
        assert_eq!(t.bilinear(0.5, 0.5, C), Vec3::new(0.5, 0.5, 0.5));
        // x = 0.6*2 - 0.5 = 0.7 -> weights 0.3 / 0.7 between the top texels; y on the top row centre.
        let c = t.bilinear(0.6, 0.75, C);
        assert!((c - (0.3 * Vec3::X + 0.7 * Vec3::Y)).length() < 1e-6, "{c}");
        // Beyond the border it clamps to the edge texel.
        assert_eq!(t.bilinear(0.0, 1.0, C), Vec3::X);
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=20 {
            let c = i as f32 / 20.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5);
        }
    }
}
