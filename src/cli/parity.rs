//! `rtdiff parity SCENE`: hit parity of every native builder x traversal
//! against Embree (or brute force) on seeded ray sets.

use std::path::PathBuf;

use crate::error::Result;
use crate::harness::parity::{self, ParityOptions, Reference};
use crate::harness::raysets::SetKind;

/// Which ray sets to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RaysArg {
    /// Every set, plus the numerical stress report.
    All,
    /// Camera rays.
    Primary,
    /// Random origins and directions.
    Incoherent,
    /// From primary hits to the lights.
    Shadow,
    /// Aimed at shared edges.
    Edges,
    /// Aimed at closed vertices.
    Vertices,
    /// Nearly parallel to a face.
    Grazing,
    /// Directions with zero components.
    Axis,
    /// Leaving a surface.
    Surface,
    /// The scene scaled by 1e-4 and 1e5 and moved 1e4 away.
    Scaled,
}

/// Arguments of `rtdiff parity`.
#[derive(clap::Args, Debug)]
pub struct ParityArgs {
    /// Scene: a scene .json file, or a Wavefront .obj mesh (normalised to the unit sphere).
    pub scene: PathBuf,
    /// Ray set to run (`all` adds the numerical stress report).
    #[arg(long, value_enum, default_value = "all")]
    pub rays: RaysArg,
    /// Rays per set.
    #[arg(long, default_value_t = 100_000)]
    pub count: usize,
    /// Seed of the ray sets.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// The reference tracer.
    #[arg(long, value_enum, default_value = "embree")]
    pub reference: Reference,
    /// Compare only the default native configuration instead of every builder x traversal.
    #[arg(long)]
    pub default_only: bool,
    /// Disagreeing rays to print per set and tracer.
    #[arg(long, default_value_t = 3)]
    pub examples: usize,
}

/// Run `rtdiff parity`.
pub fn run(args: &ParityArgs) -> Result<()> {
    let ctx = crate::harness::load_context(&args.scene)?;
    let sets = match args.rays {
        RaysArg::All => SetKind::ALL.to_vec(),
        RaysArg::Primary => vec![SetKind::Primary],
        RaysArg::Incoherent => vec![SetKind::Incoherent],
        RaysArg::Shadow => vec![SetKind::Shadow],
        RaysArg::Edges => vec![SetKind::Edges],
        RaysArg::Vertices => vec![SetKind::Vertices],
        RaysArg::Grazing => vec![SetKind::Grazing],
        RaysArg::Axis => vec![SetKind::Axis],
        RaysArg::Surface => vec![SetKind::Surface],
        RaysArg::Scaled => vec![SetKind::Scaled],
    };
    let opts = ParityOptions {
        sets,
        count: args.count,
        seed: args.seed,
        reference: args.reference,
        stress: args.rays == RaysArg::All,
        max_examples: args.examples,
        variants: if args.default_only {
            vec![crate::accel::AccelConfig::default()]
        } else {
            parity::native_variants()
        },
    };
    let start = std::time::Instant::now();
    let report = parity::run(&ctx, &opts)?;
    if args.json {
        let s = serde_json::to_string_pretty(&report)
            .map_err(|e| crate::Error::Invalid(format!("cannot serialise the report: {e}")))?;
        println!("{s}");
    } else {
        print!("{}", parity::format_report(&report));
        println!("{} in {:.2} s", args.scene.display(), start.elapsed().as_secs_f64());
    }
    Ok(())
}
