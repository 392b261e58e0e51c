//! `rtdiff export SCENE --to mitsuba|obj -o DIR`: write a scene for another renderer.

use std::path::PathBuf;

use crate::error::Result;
use crate::scene::export::mitsuba::{OracleChoice, export_mitsuba_file, oracle_line};
use crate::shading::ShadingModelKind;

/// Target renderers of `rtdiff export`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportTarget {
    /// Mitsuba 3 (scene.xml + PLY meshes + EXR textures + rtdiff.json for the Whitted plugin).
    Mitsuba,
    /// Wavefront OBJ + MTL for any renderer (face i is rtdiff's primitive i), camera and lights in scene.json.
    Obj,
}

/// The oracle an export writes (`--oracle`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum OracleArg {
    /// Native wherever Mitsuba's own plugins express the scene, else the plugin.
    Auto,
    /// Mitsuba's own emitters, BSDFs and integrators, or an error saying why not.
    Native,
    /// The rtdiff_whitted plugin (the reports' model in Python on Mitsuba's intersections).
    Plugin,
}

impl From<OracleArg> for OracleChoice {
    fn from(a: OracleArg) -> Self {
        match a {
            OracleArg::Auto => OracleChoice::Auto,
            OracleArg::Native => OracleChoice::Native,
            OracleArg::Plugin => OracleChoice::Plugin,
        }
    }
}

/// Arguments of `rtdiff export`.
#[derive(Clone, Debug, clap::Args)]
pub struct ExportArgs {
    /// Scene file (JSON).
    pub scene: PathBuf,
    /// Renderer to export for.
    #[arg(long, value_enum, default_value = "mitsuba")]
    pub to: ExportTarget,
    /// Output folder (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Image size, samples, seed and feature switches.
    #[command(flatten)]
    pub image: super::render::SceneFlags,
    /// Switch every material to this shading model (default: as the scene file says).
    #[arg(long, value_parser = parse_model)]
    pub model: Option<ShadingModelKind>,
    /// Which oracle to write: Mitsuba's own emitters, BSDFs and integrators (native), the
    /// rtdiff_whitted plugin, or native wherever Mitsuba can express the scene (auto).
    #[arg(long, value_enum, default_value = "auto")]
    pub oracle: OracleArg,
    /// Print the export report as JSON.
    #[arg(long)]
    pub json: bool,
    /// No warnings on stderr.
    #[arg(short, long)]
    pub quiet: bool,
}

fn parse_model(s: &str) -> std::result::Result<ShadingModelKind, String> {
    match s {
        "phong" => Ok(ShadingModelKind::Phong),
        "physical" => Ok(ShadingModelKind::Physical),
        _ => Err(format!("unknown shading model '{s}' (phong or physical)")),
    }
}

/// Run `rtdiff export`.
pub fn run(args: &ExportArgs) -> Result<()> {
    let ov = args.image.overrides()?;
    let report = match args.to {
        ExportTarget::Obj => return run_obj(args, &ov),
        ExportTarget::Mitsuba => export_mitsuba_file(&args.scene, &ov, args.model, &args.output, args.oracle.into())?,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report).unwrap_or_default());
    } else {
        println!(
            "{} -> {} ({} files, {})",
            args.scene.display(),
            args.output.join("scene.xml").display(),
            report.files.len(),
            if report.deterministic { "deterministic: 1 sample per pixel" } else { "stochastic" }
        );
        println!("oracle: {}", oracle_line(&report));
    }
    if !args.quiet {
        for w in &report.warnings {
            eprintln!("rtdiff: warning: {}: {w}", args.scene.display());
        }
    }
    Ok(())
}

/// `rtdiff export --to obj`.
fn run_obj(args: &ExportArgs, ov: &crate::scene::Overrides) -> Result<()> {
    let scene = crate::scene::Scene::load_with(&args.scene, ov)?;
    let r = crate::scene::export::obj::export_obj(&scene, &args.output)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r).unwrap_or_default());
    } else {
        println!("{} -> {} ({} triangles)", args.scene.display(), args.output.join("scene.obj").display(), r.triangles);
    }
    if !args.quiet {
        for w in &r.warnings {
            eprintln!("rtdiff: warning: {}: {w}", args.scene.display());
        }
    }
    Ok(())
}
