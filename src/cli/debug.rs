//! `rtdiff debug`: the reports' visual debugging, headless. Traces the camera
//! ray through one pixel and prints every ray it causes (reflections, glossy
//! and transmission rays, light samples, shadow rays and what blocks them),
//! with hit data and colours, as an indented tree or JSON.

use std::fmt::Write;
use std::path::PathBuf;

use crate::backends;
use crate::error::{Error, Result};
use crate::integrator::Counters;
use crate::integrator::Whitted;
use crate::integrator::debug::{RayKind, RayNode, RayTree};
use crate::rng::Pcg32;
use crate::scene::{Overrides, Scene};

/// Arguments of `rtdiff debug`.
#[derive(Clone, Debug, clap::Args)]
pub struct DebugArgs {
    /// Scene file (JSON).
    pub scene: PathBuf,
    /// Pixel column and row (0, 0 is the top-left); the ray goes through the pixel centre.
    #[arg(long, num_args = 2, value_names = ["X", "Y"])]
    pub pixel: Vec<u32>,
    /// Turn a feature on or off, e.g. `--feature glossy=on` (repeatable).
    #[arg(long = "feature", value_name = "NAME=on|off")]
    pub features: Vec<String>,
    /// Print JSON instead of the tree.
    #[arg(long)]
    pub json: bool,
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
                " -> hit prim {} at t {:.6}, point {}, normal {}, uv ({:.4}, {:.4}), material '{name}', colour {}",
                h.prim,
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
                    let _ = writeln!(out, "{pad}    shadow ray BLOCKED by prim {prim} at {:.4} of the way", t);
                }
            }
        }
    }
    for c in &n.children {
        print_node(scene, c, indent + 1, out);
    }
}

/// Run `rtdiff debug`.
pub fn run(args: &DebugArgs) -> Result<()> {
    let features = args.features.iter().map(|f| super::render::parse_feature(f)).collect::<Result<_>>()?;
    let scene = Scene::load_with(&args.scene, &Overrides { features, ..Default::default() })?;
    let [x, y] = args.pixel[..] else { return Err(Error::Invalid("--pixel takes X and Y".into())) };
    if x >= scene.width || y >= scene.height {
        return Err(Error::Invalid(format!("pixel ({x}, {y}) is outside the {}x{} image", scene.width, scene.height)));
    }
    let tracer = backends::build_tracer(scene.prims.clone(), &scene.accel)?;
    let integ = Whitted::new(&scene, tracer.as_ref(), scene.plan());
    let mut tree = RayTree::default();
    let mut counters = Counters::default();
    let mut rng = Pcg32::for_pixel(scene.seed, x, y);
    let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
    integ.trace_as(RayKind::Camera, &ray, 0, &mut rng, &mut counters, &mut tree);
    let root = tree.roots.first().ok_or_else(|| Error::Invalid("no ray was traced".into()))?;
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
