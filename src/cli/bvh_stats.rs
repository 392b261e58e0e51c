//! `rtdiff bvh-stats SCENE [--builder ...] [--json]`: build the BVH with each
//! builder and print its statistics.

use std::path::PathBuf;

use crate::backends::{AccelConfig, Builder, Traversal};
use crate::bvh::BvhStats;
use crate::error::{Error, Result};

/// Arguments of `rtdiff bvh-stats`.
#[derive(clap::Args, Debug)]
pub struct BvhStatsArgs {
    /// Scene: a scene JSON file, or a mesh (.obj, .ply, .gltf, .glb, .stl, optionally .gz) used as is.
    pub scene: PathBuf,
    /// Builders to report (all when none is given).
    #[arg(long, value_enum)]
    pub builder: Vec<Builder>,
    /// Primitives per leaf for the median builder.
    #[arg(long, default_value_t = 1, value_parser = crate::limits::ranged::<usize>(1, crate::limits::MAX_LEAF_SIZE as u64))]
    pub leaf_size: usize,
    /// Bins per axis for the sah builder.
    #[arg(long, default_value_t = 16, value_parser = crate::limits::ranged::<usize>(crate::limits::MIN_BINS as u64, crate::limits::MAX_BINS as u64))]
    pub bins: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub use crate::rays::load_primitives;

/// Run `rtdiff bvh-stats`.
pub fn run(args: &BvhStatsArgs) -> Result<()> {
    if args.bins < 2 {
        return Err(Error::Invalid(format!("--bins must be at least 2 (got {})", args.bins)));
    }
    let prims = load_primitives(&args.scene, false)?;
    let builders = if args.builder.is_empty() { crate::backends::builders() } else { args.builder.clone() };
    let stats: Vec<BvhStats> = builders
        .iter()
        .map(|&builder| {
            let cfg = AccelConfig {
                builder,
                traversal: Traversal::Fast,
                leaf_size: args.leaf_size,
                bins: args.bins,
                ..Default::default()
            };
            crate::bvh::stats_for(&prims, &cfg)
        })
        .collect();
    if args.json {
        let s = serde_json::to_string_pretty(&stats).map_err(|e| Error::Invalid(e.to_string()))?;
        println!("{s}");
        return Ok(());
    }
    println!("{} ({} primitives)", args.scene.display(), prims.len());
    println!(
        "{:<11} {:>9} {:>9} {:>6} {:>9} {:>10} {:>9} {:>10} {:>10} {:>11} {:>9}",
        "builder",
        "nodes",
        "leaves",
        "levels",
        "max/leaf",
        "mean/leaf",
        "SAH cost",
        "bytes",
        "wide nodes",
        "wide bytes",
        "build ms"
    );
    for s in &stats {
        println!(
            "{:<11} {:>9} {:>9} {:>6} {:>9} {:>10.2} {:>9.2} {:>10} {:>10} {:>11} {:>9.2}",
            s.builder,
            s.nodes,
            s.leaves,
            s.levels,
            s.max_prims_per_leaf,
            s.mean_prims_per_leaf,
            s.sah_cost,
            s.bytes,
            s.wide_nodes,
            s.wide_bytes,
            s.build_ms
        );
    }
    Ok(())
}
