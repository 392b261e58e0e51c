//! `rtdiff debug`: the reports' visual debugging, headless. Traces the camera
//! ray through one pixel and prints every ray it causes (reflections, glossy
//! and transmission rays, light samples, shadow rays and what blocks them),
//! with hit data and colours, as an indented tree or JSON; with `--draw`,
//! draws an overlay over the render ([`crate::debug`]); with `--heatmap`,
//! writes the per-pixel traversal work.

use std::fmt::Write;
use std::path::PathBuf;

use crate::backends::{Builder, Traversal};
use crate::debug::{self, Metric};
use crate::error::{Error, Result};
use crate::integrator::debug::{RayKind, RayNode};
use crate::render::RenderOptions;
use crate::scene::{Overrides, Scene};

/// Arguments of `rtdiff debug`.
#[derive(Clone, Debug, clap::Args)]
pub struct DebugArgs {
    /// Scene file (JSON).
    pub scene: PathBuf,
    /// Pixel column and row (0, 0 is the top-left); the ray goes through the pixel centre.
    #[arg(long, num_args = 2, value_names = ["X", "Y"])]
    pub pixel: Vec<u32>,
    /// Print JSON instead of the tree.
    #[arg(long)]
    pub json: bool,
    /// Draw over the render: bvh-level=N, bvh-leaf=N, traversal, rays, normals (these three need
    /// --pixel), sah-splits (with --node), focal-plane. Needs -o.
    #[arg(long, value_name = "WHAT")]
    pub draw: Option<String>,
    /// Node of `--draw sah-splits` (depth-first index, 0 = root).
    #[arg(long)]
    pub node: Option<u32>,
    /// Write the per-pixel count of node visits, triangle tests or rays traced (any builder x
    /// traversal) as a PNG with a colour bar; the counts also go to OUT.exr. Needs -o.
    #[arg(long, value_name = "METRIC")]
    pub heatmap: Option<Metric>,
    /// Fixed top of the heatmap's colour scale (default: the image's maximum), to compare images.
    #[arg(long, value_name = "COUNT")]
    pub scale_max: Option<u64>,
    /// Output picture (.png, or .exr for the linear image or the heatmap's counts).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write the overlay's lines as an OBJ file (`l` elements with vertex colours).
    #[arg(long, value_name = "FILE.obj")]
    pub obj: Option<PathBuf>,
    /// Draw from the scene's camera turned by this many degrees about its up axis (pixels still
    /// refer to the scene's camera), so rays along the view become visible.
    #[arg(long, value_name = "DEGREES", allow_hyphen_values = true)]
    pub orbit: Option<f32>,
    /// BVH builder (of the render and the BVH overlays and heatmaps).
    #[arg(long)]
    pub builder: Option<Builder>,
    /// BVH traversal (of the render and the `traversal` overlay and heatmaps).
    #[arg(long)]
    pub traversal: Option<Traversal>,
    /// Image size, samples, seed and feature switches.
    #[command(flatten)]
    pub image: super::render::SceneFlags,
    /// Worker threads (the pictures are identical for any count).
    #[arg(long)]
    pub threads: Option<usize>,
    /// No progress bar and no summary line.
    #[arg(short, long)]
    pub quiet: bool,
}

fn v3(v: [f32; 3]) -> String {
    format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2])
}

fn print_node(scene: &Scene, n: &RayNode, indent: usize, out: &mut String) {
    let pad = "  ".repeat(indent);
    let kind = match n.kind {
        RayKind::Camera => "camera",
        RayKind::Reflection => "reflection",
        RayKind::Glossy => "glossy",
        RayKind::Transmission => "transmission",
    };
    let _ = write!(out, "{pad}{kind} ray (depth {}) from {} dir {}", n.depth, v3(n.origin), v3(n.direction));
    match &n.hit {
        None => {
            let _ = writeln!(out, " -> miss, colour {}", v3(n.color));
        }
        Some(h) => {
            let name = &scene.materials[h.material as usize].name;
            let _ = writeln!(
                out,
                " -> hit prim {} ({}) at t {:.6}, point {}, normal {}, uv ({:.4}, {:.4}), material '{name}', colour {}",
                h.prim,
                scene.primitive_origin(h.prim),
                h.t,
                v3(h.position),
                v3(h.normal),
                h.uv[0],
                h.uv[1],
                v3(n.color)
            );
        }
    }
    for l in &n.lights {
        let _ = writeln!(
            out,
            "{pad}  light {} sample at {} colour {}: contribution {} x visibility {:.3}",
            l.light,
            v3(l.position),
            v3(l.color),
            v3(l.contribution),
            l.visibility
        );
        for s in &l.shadow_rays {
            match s.blocked_by {
                None => {
                    let _ = writeln!(out, "{pad}    shadow ray reaches the light");
                }
                Some((prim, t)) => {
                    let _ = writeln!(
                        out,
                        "{pad}    shadow ray BLOCKED by prim {prim} ({}) at {:.4} of the way",
                        scene.primitive_origin(prim),
                        t
                    );
                }
            }
        }
    }
    for c in &n.children {
        print_node(scene, c, indent + 1, out);
    }
}

fn output_ext(args: &DebugArgs) -> Result<(PathBuf, String)> {
    let out = args.output.clone().ok_or_else(|| Error::Invalid("--draw and --heatmap need -o OUT.png".into()))?;
    let ext = out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    if ext != "png" && ext != "exr" {
        return Err(Error::file(&out, "unknown output format: use a .png or .exr file name"));
    }
    Ok((out, ext))
}

fn run_draw(args: &DebugArgs, mut scene: Scene, what: &str) -> Result<()> {
    let (out, _) = output_ext(args)?;
    let pixel = match args.pixel[..] {
        [x, y] => Some((x, y)),
        _ => None,
    };
    let overlay = debug::overlay::parse(what, pixel, args.node)?;
    let view = args.orbit.map(|deg| debug::draw::orbit(&scene.camera, deg));
    let accel = scene.accel;
    let opts = RenderOptions { threads: args.threads, quiet: args.quiet };
    let d = debug::draw(&mut scene, overlay.as_ref(), &accel, view, &opts)?;
    d.image.write(&out)?;
    if let Some(obj) = &args.obj {
        let comment = format!("{} of {}", d.name, args.scene.display());
        debug::obj::write_obj(&d.lines, &comment, obj)?;
    }
    if !args.quiet {
        let changed = d.mask.iter().filter(|&&m| m).count();
        eprintln!(
            "{}: {} ({} segments, {changed} pixels drawn) -> {}",
            args.scene.display(),
            d.name,
            d.lines.len(),
            out.display()
        );
    }
    Ok(())
}

fn run_heatmap(args: &DebugArgs, scene: &Scene, metric: Metric) -> Result<()> {
    let (out, ext) = output_ext(args)?;
    let opts = RenderOptions { threads: args.threads, quiet: args.quiet };
    let hm = debug::heatmap(scene, &scene.accel, &opts)?;
    let exr = out.with_extension("exr");
    if ext == "png" {
        hm.write_png(metric, args.scale_max, &out)?;
    }
    hm.write_exr(&exr)?;
    if !args.quiet {
        let t = hm.totals;
        let px = f64::from(hm.width) * f64::from(hm.height);
        eprintln!(
            "{}: {} | {} rays, {} node visits ({:.2}/ray), {} triangle tests ({:.2}/ray), {:.1} {} per pixel -> {}{}",
            args.scene.display(),
            hm.tracer,
            t.rays,
            t.nodes,
            t.nodes as f64 / t.rays.max(1) as f64,
            t.triangles,
            t.triangles as f64 / t.rays.max(1) as f64,
            hm.total(metric) as f64 / px,
            metric.name(),
            if ext == "png" { format!("{}, ", out.display()) } else { String::new() },
            exr.display()
        );
    }
    Ok(())
}

/// Run `rtdiff debug`.
pub fn run(args: &DebugArgs) -> Result<()> {
    let ov = Overrides { builder: args.builder, traversal: args.traversal, ..args.image.overrides()? };
    let scene = Scene::load_with(&args.scene, &ov)?;
    if args.draw.is_some() && args.heatmap.is_some() {
        return Err(Error::Invalid("--draw and --heatmap are separate pictures: give one".into()));
    }
    if let Some(what) = &args.draw {
        return run_draw(args, scene, what);
    }
    if let Some(metric) = args.heatmap {
        return run_heatmap(args, &scene, metric);
    }
    let [x, y] = args.pixel[..] else {
        return Err(Error::Invalid("give --pixel X Y (the ray tree), --draw WHAT or --heatmap METRIC".into()));
    };
    let debug::PixelTrace { root, counters } = debug::trace_pixel(&scene, x, y)?;
    let root = &root;
    if args.json {
        let json = serde_json::json!({ "pixel": [x, y], "counters": counters, "ray": root });
        println!("{}", serde_json::to_string_pretty(&json).unwrap_or_default());
    } else {
        let mut out = String::new();
        print_node(&scene, root, 0, &mut out);
        let _ = writeln!(
            out,
            "rays: {} secondary, {} shadow; {} light samples; {} texture lookups",
            counters.secondary_rays, counters.shadow_rays, counters.light_samples, counters.texture_lookups
        );
        print!("{out}");
    }
    Ok(())
}
