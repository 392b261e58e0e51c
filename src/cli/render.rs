//! `rtdiff render`: parses the arguments, renders through
//! [`crate::pipeline::render_scene`] and writes the image and statistics.

use std::path::PathBuf;

use crate::backends::{Builder, TracerArg, Traversal};
use crate::error::{Error, Result};
use crate::geometry::TriangleTest;
use crate::limits;
use crate::render::RenderOptions;
use crate::scene::{Overrides, Scene};

/// Arguments of `rtdiff render`.
#[derive(Clone, Debug, clap::Args)]
pub struct RenderArgs {
    /// Scene file (JSON).
    pub scene: PathBuf,
    /// Output image: .png (8-bit sRGB) or .exr (linear float).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Image size, samples, seed and feature switches.
    #[command(flatten)]
    pub image: SceneFlags,
    /// Worker threads, 1 to 1024 (the image is identical for any count).
    #[arg(long, value_parser = limits::ranged::<usize>(1, limits::MAX_THREADS as u64))]
    pub threads: Option<usize>,
    /// Hit provider: native, brute, embree, or plugin:PATH (a shared library implementing
    /// include/rtdiff_tracer.h; docs/plugins.md).
    #[arg(long)]
    pub tracer: Option<TracerArg>,
    /// BVH builder.
    #[arg(long)]
    pub builder: Option<Builder>,
    /// BVH traversal.
    #[arg(long)]
    pub traversal: Option<Traversal>,
    /// Ray/triangle test.
    #[arg(long, value_parser = parse_triangle_test)]
    pub triangle_test: Option<TriangleTest>,
    /// Also write each bloom stage next to the output (`NAME.bloom-bright.EXT`, ...).
    #[arg(long)]
    pub bloom_stages: bool,
    /// Write the render's counters and timings as JSON to this file.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// No progress bar and no summary line.
    #[arg(short, long)]
    pub quiet: bool,
}

/// The scene overrides every scene-rendering command takes (`render`, `debug`, `export`), checked
/// against the same limits.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SceneFlags {
    /// Image width (1 to 16384, at most 2^25 pixels in all).
    #[arg(long, value_parser = limits::ranged::<u32>(1, limits::MAX_IMAGE_SIDE as u64))]
    pub width: Option<u32>,
    /// Image height (1 to 16384, at most 2^25 pixels in all).
    #[arg(long, value_parser = limits::ranged::<u32>(1, limits::MAX_IMAGE_SIDE as u64))]
    pub height: Option<u32>,
    /// Camera samples per pixel (1 to 65536).
    #[arg(long, value_parser = limits::ranged::<u32>(1, limits::MAX_SPP as u64))]
    pub spp: Option<u32>,
    /// Random seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Turn a feature on or off, e.g. `--feature bloom=on` (repeatable).
    #[arg(long = "feature", value_name = "NAME=on|off")]
    pub features: Vec<String>,
    /// Recursion depth of mirror reflections and transparency (`params.max_depth`, 0 to 64).
    #[arg(long, value_parser = limits::ranged::<u32>(0, limits::MAX_DEPTH as u64))]
    pub max_depth: Option<u32>,
}

impl SceneFlags {
    /// These flags as scene overrides (no accelerator choice).
    pub fn overrides(&self) -> Result<Overrides> {
        Ok(Overrides {
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            features: self.features.iter().map(|f| parse_feature(f)).collect::<Result<_>>()?,
            max_depth: self.max_depth,
            ..Default::default()
        })
    }
}

pub(crate) fn parse_triangle_test(s: &str) -> std::result::Result<TriangleTest, String> {
    s.parse()
}

/// Parse `NAME=on|off` feature overrides.
pub fn parse_feature(s: &str) -> Result<(String, bool)> {
    let (name, value) =
        s.split_once('=').ok_or_else(|| Error::Invalid(format!("--feature '{s}': expected NAME=on or NAME=off")))?;
    let on = match value {
        "on" | "true" | "1" => true,
        "off" | "false" | "0" => false,
        _ => return Err(Error::Invalid(format!("--feature '{s}': value must be on or off"))),
    };
    Ok((name.to_string(), on))
}

fn stage_path(out: &std::path::Path, stage: &str) -> PathBuf {
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
    let ext = out.extension().and_then(|s| s.to_str()).unwrap_or("png");
    out.with_file_name(format!("{stem}.bloom-{stage}.{ext}"))
}

impl RenderArgs {
    /// The scene overrides these arguments ask for.
    pub fn overrides(&self) -> Result<Overrides> {
        let args = self;
        Ok(Overrides {
            backend: args.tracer.as_ref().map(TracerArg::backend).transpose()?,
            builder: args.builder,
            traversal: args.traversal,
            triangle_test: args.triangle_test,
            ..args.image.overrides()?
        })
    }
}

/// Run `rtdiff render`.
pub fn run(args: &RenderArgs) -> Result<()> {
    let ov = args.overrides()?;
    let ext = args.output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("png" | "exr")) {
        return Err(Error::file(&args.output, "unknown output format: use a .png or .exr file name"));
    }
    let scene = Scene::load_with(&args.scene, &ov)?;
    if !args.quiet {
        for w in &scene.warnings {
            eprintln!("rtdiff: warning: {w}");
        }
    }
    if !args.quiet {
        super::warnings::degenerate(&args.scene, &scene.prims, scene.zero_area);
    }
    let out = crate::pipeline::render_scene(&scene, &RenderOptions { threads: args.threads, quiet: args.quiet })?;
    if let (true, Some(st)) = (args.bloom_stages, &out.bloom) {
        for (name, img) in [("bright", &st.bright), ("blurred", &st.blurred), ("scaled", &st.scaled)] {
            img.write(&stage_path(&args.output, name))?;
        }
    }
    out.image.write(&args.output)?;
    let st = &out.stats;
    if let Some(p) = &args.stats {
        let json =
            serde_json::to_string_pretty(st).map_err(|e| Error::file(p, format!("cannot serialise stats: {e}")))?;
        crate::output::write(p, json)?;
    }
    if !args.quiet {
        eprintln!(
            "{}: {} triangles, {} spheres | {} build {:.1} ms | render {:.1} ms | {} rays, {:.2} Mrays/s -> {}",
            args.scene.display(),
            st.triangles,
            st.spheres,
            st.tracer,
            st.build_ms,
            st.render_ms,
            st.rays,
            st.mrays_per_s,
            args.output.display()
        );
    }
    Ok(())
}
