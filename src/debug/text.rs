//! Text on 8-bit images with the public-domain 8x8 bitmap font of the
//! `font8x8` crate (ASCII), for the scales and labels of heatmaps.

use image::{Rgb, RgbImage};

/// Width in pixels of `text` drawn at `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * 8 * scale
}

/// Draw `text` with its top-left corner at `(x, y)`, each font pixel a
/// `scale` x `scale` square; non-ASCII characters and pixels outside the
/// image are skipped.
pub fn draw_text(img: &mut RgbImage, x: u32, y: u32, text: &str, scale: u32, color: Rgb<u8>) {
    for (i, ch) in text.chars().enumerate() {
        let Some(glyph) = font8x8::legacy::BASIC_LEGACY.get(ch as usize) else { continue };
        let gx = x + i as u32 * 8 * scale;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (px, py) = (gx + col * scale + dx, y + row as u32 * scale + dy);
                        if px < img.width() && py < img.height() {
                            img.put_pixel(px, py, color);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_leave_ink_inside_their_cells_only() {
        let mut img = RgbImage::new(40, 10);
        draw_text(&mut img, 0, 0, "1", 1, Rgb([255, 255, 255]));
        let ink: Vec<(u32, u32)> =
            img.enumerate_pixels().filter(|(_, _, p)| p.0[0] == 255).map(|(x, y, _)| (x, y)).collect();
        assert!(!ink.is_empty() && ink.iter().all(|&(x, y)| x < 8 && y < 8));
        assert_eq!(text_width("123", 2), 48);
    }
}
