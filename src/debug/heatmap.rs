//! Per-pixel cost pictures: the render's own rays (camera, secondary and
//! shadow rays, exactly those of [`crate::render::render_pixel`]) traced
//! through a BVH whose traversal reports its work ([`crate::bvh::Count`]),
//! summed per pixel: node visits, primitive tests, rays. Any builder x
//! traversal; the image carries a colour bar and its scale, and the counts
//! go to a linear EXR for tools.

use std::path::Path;
use std::sync::Mutex;

use image::{Rgb, RgbImage};
use rayon::prelude::*;
use serde::Serialize;

use super::text::{draw_text, text_width};
use crate::accel::Tracer;
use crate::backends::{AccelConfig, Backend};
use crate::bvh::{BvhTracer, TraversalCounts};
use crate::error::Result;
use crate::geometry::{Hit, Ray};
use crate::integrator::{Counters, Whitted};
use crate::render::{RenderOptions, progress_bar, render_pixel, with_threads};
use crate::scene::Scene;

/// What a heatmap counts per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Metric {
    /// Node visits (binary node boxes tested, or 8-wide nodes visited by `fast`).
    Nodes,
    /// Primitive (triangle and sphere) tests.
    Triangles,
    /// Rays traced (camera, secondary and shadow).
    Rays,
}

impl Metric {
    /// Every metric.
    pub const ALL: [Metric; 3] = [Metric::Nodes, Metric::Triangles, Metric::Rays];

    /// Short name (`nodes`, `triangles`, `rays`).
    pub fn name(self) -> &'static str {
        match self {
            Metric::Nodes => "nodes",
            Metric::Triangles => "triangles",
            Metric::Rays => "rays",
        }
    }

    /// What one count is, for the image's title (`wide`: the tree has 8-wide nodes).
    fn title(self, wide: bool) -> &'static str {
        match (self, wide) {
            (Metric::Nodes, false) => "node visits per pixel",
            (Metric::Nodes, true) => "8-wide node visits per pixel",
            (Metric::Triangles, _) => "triangle tests per pixel",
            (Metric::Rays, _) => "rays traced per pixel",
        }
    }
}

/// The per-pixel work of one render.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Heatmap {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The tracer (`bvh-BUILDER/TRAVERSAL`).
    pub tracer: String,
    /// True when node visits are of 8-wide nodes (the `fast` traversal), each testing eight boxes.
    pub wide: bool,
    /// Per-pixel counts, row-major.
    #[serde(skip)]
    pub pixels: Vec<TraversalCounts>,
    /// Sum over all pixels.
    pub totals: TraversalCounts,
}

/// A [`Tracer`] answering with a [`BvhTracer`] and counting its work.
struct CountingTracer<'a> {
    bvh: &'a BvhTracer,
    counts: Mutex<TraversalCounts>,
}

impl CountingTracer<'_> {
    fn take(&self) -> TraversalCounts {
        self.counts.lock().map(|mut c| std::mem::take(&mut *c)).unwrap_or_default()
    }
}

impl Tracer for CountingTracer<'_> {
    fn name(&self) -> String {
        self.bvh.name()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut c = TraversalCounts::default();
        let hit = self.bvh.intersect_with(ray, &mut c);
        if let Ok(mut total) = self.counts.lock() {
            total.add(&c);
        }
        hit
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let mut c = TraversalCounts::default();
        let hit = self.bvh.occluded_with(ray, &mut c);
        if let Ok(mut total) = self.counts.lock() {
            total.add(&c);
        }
        hit
    }
}

/// Render `scene` with rtdiff's BVH built as `cfg` asks (its backend is
/// ignored: the counts come from the native traversals) and count each
/// pixel's work. Deterministic for any thread count.
pub fn heatmap(scene: &Scene, cfg: &AccelConfig, opts: &RenderOptions) -> Result<Heatmap> {
    let cfg = AccelConfig { backend: Backend::Native, ..*cfg };
    let bvh = BvhTracer::new(&scene.prims, &cfg);
    let plan = scene.plan();
    let (w, h) = (scene.width, scene.height);
    let bar = progress_bar(h as u64, opts.quiet, "counting");
    let mut pixels = vec![TraversalCounts::default(); w as usize * h as usize];
    with_threads(opts.threads, || {
        pixels.par_chunks_mut(w as usize).enumerate().for_each(|(y, row)| {
            let tracer = CountingTracer { bvh: &bvh, counts: Mutex::new(TraversalCounts::default()) };
            let integ = Whitted::new(scene, &tracer, plan);
            let mut c = Counters::default();
            for (x, px) in row.iter_mut().enumerate() {
                render_pixel(scene, &integ, &plan, x as u32, y as u32, &mut c);
                *px = tracer.take();
            }
            bar.inc(1);
        })
    })?;
    bar.finish_and_clear();
    let mut totals = TraversalCounts::default();
    pixels.iter().for_each(|p| totals.add(p));
    Ok(Heatmap { width: w, height: h, tracer: bvh.name(), wide: bvh.wide().is_some(), pixels, totals })
}

/// Width of the colour-bar band right of the picture.
const BAR_BAND: u32 = 120;
/// Height of the title band above the picture.
const TITLE_BAND: u32 = 40;

impl Heatmap {
    /// Count of `metric` at every pixel, row-major.
    pub fn counts(&self, metric: Metric) -> Vec<u64> {
        self.pixels
            .iter()
            .map(|c| match metric {
                Metric::Nodes => c.nodes,
                Metric::Triangles => c.triangles,
                Metric::Rays => c.rays,
            })
            .collect()
    }

    /// Sum of `metric` over the image.
    pub fn total(&self, metric: Metric) -> u64 {
        match metric {
            Metric::Nodes => self.totals.nodes,
            Metric::Triangles => self.totals.triangles,
            Metric::Rays => self.totals.rays,
        }
    }

    /// The picture: counts mapped linearly from 0 to `scale_max` (None: the
    /// image's maximum; give the same value to compare heatmaps side by
    /// side; larger counts take the top colour) through the inferno colour
    /// map, a title with the total, mean and maximum above, a colour bar
    /// with its scale on the right (its top label reads `>=N` when counts
    /// exceed the scale).
    pub fn image(&self, metric: Metric, scale_max: Option<u64>) -> RgbImage {
        let counts = self.counts(metric);
        let data_max = counts.iter().copied().max().unwrap_or(0);
        let max = scale_max.unwrap_or(data_max).max(1);
        let (w, h) = (self.width, self.height);
        let mean = self.total(metric) as f64 / counts.len().max(1) as f64;
        let title = format!("{} ({})", metric.title(self.wide), self.tracer);
        let stats = format!("total {}  mean {:.2}  max {}  scale 0..{}", self.total(metric), mean, data_max, max);
        // The title at double size when it fits beside a small map, and the canvas wide enough
        // for both lines: text is never cut off.
        let title_scale = if text_width(&title, 2) + 12 <= w + BAR_BAND { 2 } else { 1 };
        let width = (w + BAR_BAND).max(text_width(&title, title_scale) + 12).max(text_width(&stats, 1) + 12);
        let mut img = RgbImage::from_pixel(width, h + TITLE_BAND, Rgb([24, 24, 24]));
        let cmap = |v: f64| {
            let c = colorous::INFERNO.eval_continuous(v.clamp(0.0, 1.0));
            Rgb([c.r, c.g, c.b])
        };
        for (i, &c) in counts.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            img.put_pixel(x, y + TITLE_BAND, cmap(c as f64 / max as f64));
        }
        let white = Rgb([235, 235, 235]);
        draw_text(&mut img, 6, 4, &title, title_scale, white);
        draw_text(&mut img, 6, 24, &stats, 1, white);
        // Colour bar: top = max, bottom = 0, ticks at quarters.
        let (bx, bw) = (w + 12, 20);
        let (top, bottom) = (TITLE_BAND + 8, TITLE_BAND + h.saturating_sub(8).max(9));
        let span = (bottom - top).max(1);
        for y in top..=bottom {
            let c = cmap(f64::from(bottom - y) / f64::from(span));
            for x in bx..bx + bw {
                img.put_pixel(x, y, c);
            }
        }
        for q in 0..=4u32 {
            let y = bottom - span * q / 4;
            for x in bx + bw..bx + bw + 5 {
                img.put_pixel(x, y, white);
            }
            let value = (max as f64 * f64::from(q) / 4.0).round() as u64;
            let label = if q == 4 && data_max > max { format!(">={value}") } else { value.to_string() };
            let ly = y.saturating_sub(4).min(img.height() - 8);
            let lx = (bx + bw + 8).min(img.width().saturating_sub(text_width(&label, 1)));
            draw_text(&mut img, lx, ly, &label, 1, white);
        }
        img
    }

    /// Write [`Self::image`] as PNG.
    pub fn write_png(&self, metric: Metric, scale_max: Option<u64>, path: &Path) -> Result<()> {
        let img = self.image(metric, scale_max);
        crate::film::io::write_rgb8_png(img.as_raw(), img.width(), img.height(), path)
    }

    /// Write the counts as a linear float EXR with channels `nodes`,
    /// `triangles` and `rays` (exact: every count is far below 2^24),
    /// byte-deterministic like [`crate::film::io::write_exr`].
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        use exr::prelude::*;
        let size = (self.width as usize, self.height as usize);
        let ch = |m: Metric| {
            let v: Vec<f32> = self.counts(m).iter().map(|&c| c as f32).collect();
            AnyChannel::new(m.name(), FlatSamples::F32(v))
        };
        let channels = AnyChannels::sort(Metric::ALL.iter().map(|&m| ch(m)).collect());
        // Chunks in increasing y: the same counts give the same bytes (FAST_LOSSLESS
        // leaves the chunk order to the writer's threads).
        let layer =
            Layer::new(size, LayerAttributes::named("counts"), crate::film::io::DETERMINISTIC_EXR_ENCODING, channels);
        let mut bytes = std::io::Cursor::new(Vec::new());
        Image::from_layer(layer)
            .write()
            .to_buffered(&mut bytes)
            .map_err(|e| crate::error::Error::file(path, format!("cannot encode EXR: {e}")))?;
        crate::output::write(path, bytes.into_inner())
    }
}
