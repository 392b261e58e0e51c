//! Reading and writing the film's linear RGB float images ([`Image`]): the
//! render's output and the image oracle's input. EXR (channels chosen by name,
//! any compression, optional alpha ignored) and PNG (sRGB-decoded to linear)
//! in; byte-deterministic EXR and 8-bit sRGB PNG out.
//!
//! Why a writer of our own: the `exr` crate's default encoding
//! (`Encoding::FAST_LOSSLESS`) declares `LineOrder::Unspecified` and compresses
//! blocks on a thread pool, writing each chunk as soon as its thread finishes.
//! Two writes of the same pixels then order the chunks (and the offset table)
//! differently, so the files differ byte for byte. [`encode_exr`] declares
//! `LineOrder::Increasing` with ZIP-compressed 16-line scan-line blocks: the
//! crate's `SortedBlocksWriter` then stashes early chunks and writes them in
//! increasing block order, so the bytes depend on the pixels only.

use std::path::Path;

use exr::prelude::{
    Blocks, Compression, Encoding, FlatSamples, LineOrder, ReadChannels, ReadLayers, SpecificChannels, WritableImage,
};
use glam::Vec3;

use super::Image;
use crate::error::{Error, Result};
use crate::texture::srgb_to_linear;

/// The EXR encoding of [`encode_exr`]: lossless ZIP over 16 scan lines,
/// chunks in increasing y (byte-deterministic, see the module doc).
pub const DETERMINISTIC_EXR_ENCODING: Encoding =
    Encoding { compression: Compression::ZIP16, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };

/// Read an image by extension: `.exr` (linear float) or `.png` (sRGB-decoded
/// to linear). Fails with the file's name on an unreadable file, an unknown
/// extension, missing R/G/B channels, or any NaN or infinite sample.
pub fn read_image(path: &Path) -> Result<Image> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let img = match ext.as_deref() {
        Some("exr") => read_exr(path)?,
        Some("png") => read_png(path)?,
        _ => return Err(Error::file(path, "unknown image format: use a .exr or .png file")),
    };
    check_finite(&img, path)?;
    Ok(img)
}

/// Read the R, G and B channels (selected by name; other channels such as A
/// are ignored) of the first layer of an EXR file. Values are converted to
/// f32 whatever the stored sample type. Does not check for NaN/Inf (see
/// [`read_image`]).
pub fn read_exr(path: &Path) -> Result<Image> {
    std::fs::metadata(path).map_err(|e| Error::io(path, &e))?;
    let img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| Error::file(path, format!("cannot read EXR: {e}")))?;
    let layer = img.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    if w == 0 || h == 0 {
        return Err(Error::file(path, "EXR image has zero size"));
    }
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    let find = |want: &str| -> Result<&FlatSamples> {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(want))
            .map(|c| &c.sample_data)
            .ok_or_else(|| Error::file(path, format!("EXR has no {want} channel (channels: {})", names.join(", "))))
    };
    let (r, g, b) = (find("R")?, find("G")?, find("B")?);
    let (r, g, b): (Vec<f32>, Vec<f32>, Vec<f32>) =
        (r.values_as_f32().collect(), g.values_as_f32().collect(), b.values_as_f32().collect());
    let n = w * h;
    if r.len() != n || g.len() != n || b.len() != n {
        return Err(Error::file(path, "EXR channels are subsampled: only full-resolution RGB is supported"));
    }
    let pixels = (0..n).map(|i| Vec3::new(r[i], g[i], b[i])).collect();
    Ok(Image { width: w as u32, height: h as u32, pixels })
}

/// Read a PNG (8 or 16 bit, grey or colour, alpha ignored) and decode its
/// sRGB values to linear.
pub fn read_png(path: &Path) -> Result<Image> {
    std::fs::metadata(path).map_err(|e| Error::io(path, &e))?;
    let img = image::open(path).map_err(|e| Error::file(path, format!("cannot read PNG: {e}")))?;
    let rgb = img.to_rgb32f();
    let (w, h) = rgb.dimensions();
    if w == 0 || h == 0 {
        return Err(Error::file(path, "PNG image has zero size"));
    }
    let pixels = rgb
        .pixels()
        .map(|p| Vec3::new(srgb_to_linear(p.0[0]), srgb_to_linear(p.0[1]), srgb_to_linear(p.0[2])))
        .collect();
    Ok(Image { width: w, height: h, pixels })
}

/// Fail (naming `path`) if any sample is NaN or infinite: the error gives the
/// count and the first such pixel.
pub fn check_finite(img: &Image, path: &Path) -> Result<()> {
    let bad = |p: &Vec3| !p.is_finite();
    let count = img.pixels.iter().filter(|p| bad(p)).count();
    if let Some(i) = img.pixels.iter().position(bad) {
        let (x, y) = (i as u32 % img.width, i as u32 / img.width);
        let p = img.pixels[i];
        return Err(Error::file(
            path,
            format!("{count} pixel(s) with NaN or infinite values, first at ({x}, {y}) = ({}, {}, {})", p.x, p.y, p.z),
        ));
    }
    Ok(())
}

/// Fail unless `a` (read from `pa`) and `b` (from `pb`) have the same size.
pub fn check_same_size(a: &Image, pa: &Path, b: &Image, pb: &Path) -> Result<()> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::Invalid(format!(
            "image sizes differ: {} is {}x{}, {} is {}x{}",
            pa.display(),
            a.width,
            a.height,
            pb.display(),
            b.width,
            b.height
        )));
    }
    if a.pixels.len() != a.width as usize * a.height as usize || b.pixels.len() != b.width as usize * b.height as usize
    {
        return Err(Error::Invalid("image pixel count does not match its width x height".into()));
    }
    Ok(())
}

/// Encode `img` as a linear float32 RGB EXR in memory, byte-deterministically
/// (same pixels, same bytes, whatever the thread count or timing).
pub fn encode_exr(img: &Image) -> std::result::Result<Vec<u8>, exr::error::Error> {
    let w = img.width as usize;
    let channels = SpecificChannels::rgb(|exr::prelude::Vec2(x, y): exr::prelude::Vec2<usize>| {
        let p = img.pixels[y * w + x];
        (p.x, p.y, p.z)
    });
    let image = exr::prelude::Image::from_encoded_channels(
        (img.width as usize, img.height as usize),
        DETERMINISTIC_EXR_ENCODING,
        channels,
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write().to_buffered(&mut bytes)?;
    Ok(bytes.into_inner())
}

/// Write `img` as a byte-deterministic linear float32 RGB EXR (see [`encode_exr`]), whole or not
/// at all ([`crate::output`]).
pub fn write_exr(img: &Image, path: &Path) -> Result<()> {
    let bytes = encode_exr(img).map_err(|e| Error::file(path, format!("cannot encode EXR: {e}")))?;
    crate::output::write(path, bytes)
}

/// Write `img` as an 8-bit sRGB-encoded PNG (values clamped to [0, 1]).
pub fn write_png(img: &Image, path: &Path) -> Result<()> {
    write_rgb8_png(&img.to_srgb8(), img.width, img.height, path)
}

/// Encode row-major 8-bit RGB bytes (already display-encoded) as a PNG in memory.
pub fn encode_rgb8_png(rgb: &[u8], width: u32, height: u32) -> image::ImageResult<Vec<u8>> {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes).write_image(rgb, width, height, image::ExtendedColorType::Rgb8)?;
    Ok(bytes)
}

/// Write row-major 8-bit RGB bytes (already display-encoded) as a PNG, whole or not at all
/// ([`crate::output`]).
pub fn write_rgb8_png(rgb: &[u8], width: u32, height: u32, path: &Path) -> Result<()> {
    let bytes =
        encode_rgb8_png(rgb, width, height).map_err(|e| Error::file(path, format!("cannot encode PNG: {e}")))?;
    crate::output::write(path, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32) -> Image {
        let mut img = Image::new(w, h);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
            *p = Vec3::new(x / w as f32, y / h as f32, (x * y).sin().abs() * 3.0 + 1e-3 * x);
        }
        img
    }

    #[test]
    fn exr_bytes_are_deterministic_and_round_trip_exactly() {
        // 300 rows = 19 ZIP16 blocks: enough for the thread pool to finish them out of order.
        let img = gradient(257, 300);
        let a = encode_exr(&img).unwrap();
        for _ in 0..8 {
            assert_eq!(a, encode_exr(&img).unwrap(), "two encodings of the same pixels differ");
        }
        let dir = std::env::temp_dir().join(format!("rtdiff-image-rs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("g.exr");
        write_exr(&img, &p).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), a);
        let back = read_image(&p).unwrap();
        assert_eq!(back, img, "float32 EXR must round-trip bit-exactly");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn png_round_trip_within_one_lsb() {
        let img = gradient(16, 8);
        let dir = std::env::temp_dir().join(format!("rtdiff-image-png-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("g.png");
        write_png(&img, &p).unwrap();
        let back = read_image(&p).unwrap();
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                let (s, t) =
                    (crate::texture::linear_to_srgb(a[c].clamp(0.0, 1.0)), crate::texture::linear_to_srgb(b[c]));
                // 8-bit quantisation: half an LSB, plus f32 rounding in the transfer functions.
                assert!((s - t).abs() <= 0.5 / 255.0 + 1e-5, "{s} vs {t}");
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
