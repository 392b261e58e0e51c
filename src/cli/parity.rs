//! `rtdiff parity SCENE`: hit parity of every native builder x traversal
//! against Embree (or brute force) on seeded ray sets.

use std::path::PathBuf;

use crate::error::Result;
use crate::rays::SetKind;
use crate::verify::hits::{self as parity, ParityOptions, Reference};

/// `--rays`: one set, or `None` for `all` (every set plus the numerical stress report).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RaySelection(pub Option<SetKind>);

fn parse_rays(s: &str) -> std::result::Result<RaySelection, String> {
    use clap::ValueEnum;
    if s == "all" {
        return Ok(RaySelection(None));
    }
    SetKind::from_str(s, false).map(|k| RaySelection(Some(k))).map_err(|_| {
        let names: Vec<String> = SetKind::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value())
            .map(|p| p.get_name().to_string())
            .collect();
        format!("unknown ray set '{s}' (expected all, {})", names.join(", "))
    })
}

/// Arguments of `rtdiff parity`.
#[derive(clap::Args, Debug)]
pub struct ParityArgs {
    /// Scene: a scene .json file, or a mesh: .obj, .ply, .gltf, .glb, .stl, optionally .gz (normalised to the unit sphere).
    pub scene: PathBuf,
    /// Ray set to run: all, primary, incoherent, shadow, edges, vertices, grazing, axis, surface, scaled
    /// (`all` adds the numerical stress report).
    #[arg(long, value_parser = parse_rays, default_value = "all")]
    pub rays: RaySelection,
    /// Rays per set (1 to 2^24).
    #[arg(long, default_value_t = 100_000, value_parser = crate::limits::ranged::<usize>(1, crate::limits::MAX_RAYS as u64))]
    pub count: usize,
    /// Seed of the ray sets.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the report as JSON (the verdict, and every table of --verbose).
    #[arg(long)]
    pub json: bool,
    /// Print every table: each set and tracer, the arbiter's lines, the stress report.
    #[arg(long, short)]
    pub verbose: bool,
    /// The reference tracer.
    #[arg(long, value_enum, default_value = "embree")]
    pub reference: Reference,
    /// Compare only the default native configuration instead of every builder x traversal.
    #[arg(long, conflicts_with = "tracer")]
    pub default_only: bool,
    /// The tracer under test instead of every native builder x traversal (repeatable): native,
    /// brute, embree, or plugin:PATH (a shared library implementing include/rtdiff_tracer.h).
    #[arg(long)]
    pub tracer: Vec<crate::backends::TracerArg>,
    /// Rays per set for the builder x traversal variants other than the default
    /// `sah/fast` (which always sees every ray); 0 = all rays.
    #[arg(long, default_value_t = 10_000, value_parser = crate::limits::ranged::<usize>(0, crate::limits::MAX_RAYS as u64))]
    pub sweep_count: usize,
    /// Skip the exact arbiter (which judges every disagreement).
    #[arg(long)]
    pub no_arbiter: bool,
    /// Disagreeing rays to print per set and tracer (0 to 10000).
    #[arg(long, default_value_t = 3, value_parser = crate::limits::ranged::<usize>(0, crate::limits::MAX_EXAMPLES as u64))]
    pub examples: usize,
}

/// Run `rtdiff parity`.
pub fn run(args: &ParityArgs) -> Result<()> {
    // Plugins first: a missing library or symbol is reported before the scene is loaded.
    let backends = args.tracer.iter().map(|t| t.backend()).collect::<Result<Vec<_>>>()?;
    let (ctx, skipped) = crate::rays::load_context_counted(&args.scene)?;
    super::warnings::degenerate(&args.scene, &ctx.prims, skipped);
    let sets = match args.rays.0 {
        None => SetKind::ALL.to_vec(),
        Some(set) => vec![set],
    };
    let opts = ParityOptions {
        sets,
        count: args.count,
        seed: args.seed,
        reference: args.reference,
        stress: args.rays.0.is_none(),
        max_examples: args.examples,
        arbiter: !args.no_arbiter,
        sweep_count: (args.sweep_count > 0).then_some(args.sweep_count),
        variants: if !backends.is_empty() {
            backends.into_iter().map(|backend| crate::backends::AccelConfig { backend, ..Default::default() }).collect()
        } else if args.default_only {
            vec![crate::backends::AccelConfig::default()]
        } else {
            parity::native_variants()
        },
    };
    let report = parity::run(&ctx, &opts)?;
    if args.json {
        let s = serde_json::to_string_pretty(&report)
            .map_err(|e| crate::Error::Invalid(format!("cannot serialise the report: {e}")))?;
        println!("{s}");
    } else if args.verbose {
        print!("{}", parity::format_report(&report));
        println!("{} in {:.2} s", args.scene.display(), report.seconds);
    } else {
        let reference = args.reference.config().label();
        print!("{}", parity::format_verdict(&report, &reference, args.examples.max(1)));
        println!(
            "{}: {} sets in {:.2} s (--verbose: every table)",
            args.scene.display(),
            report.sets.len(),
            report.seconds
        );
    }
    super::exit_on_fail(report.verdict.passed)
}
