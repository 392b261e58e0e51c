//! False-colour pictures of where two images differ: the per-pixel error
//! (absolute or relative) or a FLIP map through FLIP's magma colour map
//! (black = no error, yellow-white = the scale's top), written as PNG.

use std::path::Path;

use crate::error::Result;
use crate::film::io::write_rgb8_png;
use crate::verify::image::flip::Flip;

/// Colour a per-pixel error map with magma: `value / scale` clamped to [0, 1]
/// indexes the 256-entry map. Returns row-major 8-bit RGB bytes.
pub fn magma_rgb8(values: &[f32], scale: f32) -> Vec<u8> {
    let lut = nv_flip::magma_lut().to_vec();
    let inv = if scale > 0.0 { 1.0 / scale } else { 0.0 };
    values
        .iter()
        .flat_map(|&v| {
            let i = ((v * inv).clamp(0.0, 1.0) * 255.0 + 0.5) as usize;
            [lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]]
        })
        .collect()
}

/// Write the per-pixel `errors` (e.g. [`absolute_difference`] or
/// [`relative_difference`]) as a magma PNG, full scale at `scale` (or at the
/// largest error when `None`). Returns the scale used.
///
/// [`absolute_difference`]: crate::verify::image::metrics::absolute_difference
/// [`relative_difference`]: crate::verify::image::metrics::relative_difference
pub fn write_error_png(errors: &[f32], width: u32, height: u32, scale: Option<f32>, path: &Path) -> Result<f32> {
    let scale = scale.unwrap_or_else(|| errors.iter().copied().fold(0.0, f32::max));
    write_rgb8_png(&magma_rgb8(errors, scale), width, height, path)?;
    Ok(scale)
}

/// Write a FLIP error map as a magma PNG (scale 1, as FLIP's own tools).
pub fn write_flip_png(flip: &Flip, path: &Path) -> Result<()> {
    write_rgb8_png(&magma_rgb8(&flip.error_map, 1.0), flip.width, flip.height, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn magma_ends_are_dark_and_bright_and_scale_clamps() {
        let rgb = magma_rgb8(&[0.0, 0.5, 1.0, 7.0], 1.0);
        let lum = |i: usize| rgb[3 * i] as u32 + rgb[3 * i + 1] as u32 + rgb[3 * i + 2] as u32;
        assert!(lum(0) < 30, "zero must be near black: {:?}", &rgb[0..3]);
        assert!(lum(0) < lum(1) && lum(1) < lum(2), "magma must brighten: {rgb:?}");
        assert_eq!(&rgb[6..9], &rgb[9..12], "values above the scale clamp to its top");
    }
}
