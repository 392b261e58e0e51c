//! `rtdiff campaign PLAN [--list] [--shard K/N] -o OUT` and `rtdiff campaign merge OUT... -o
//! REPORT`: parse the arguments, call [`crate::campaign`] and [`crate::report::campaign`], print.

use std::path::PathBuf;

use crate::campaign::{RunOptions, Shard};
use crate::error::{Error, Result};
use crate::report::campaign::CampaignReportOptions;

/// Arguments of `rtdiff campaign`.
#[derive(clap::Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct CampaignArgs {
    /// Merge shard folders into one report.
    #[command(subcommand)]
    pub command: Option<CampaignCommand>,
    /// The plan: a TOML (or JSON) file naming meshes, scenes, ray sets, tracers and reports (docs/campaigns.md).
    #[arg(required = true)]
    pub plan: Option<PathBuf>,
    /// Print the work items (id, kind, set, input, estimated cost, shard) and stop.
    #[arg(long)]
    pub list: bool,
    /// Run only shard K of N (1 <= K <= N): a deterministic split balanced by estimated cost.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// Output folder: one JSON result per item; a run resumes where a killed one stopped.
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// No progress bar and no summary line.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `rtdiff campaign merge`.
#[derive(clap::Subcommand, Debug)]
pub enum CampaignCommand {
    /// Merge any set of shard folders of one plan into one report (Markdown, JSON, HTML).
    Merge(MergeArgs),
}

/// Arguments of `rtdiff campaign merge`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Shard output folders (of one plan, made by one rtdiff version).
    #[arg(required = true)]
    pub folders: Vec<PathBuf>,
    /// Report folder: campaign.json, campaign.md, index.html.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Leave out every timing (speed, seconds): two runs of one plan then give the same bytes.
    #[arg(long)]
    pub no_timings: bool,
    /// Fail (exit 1) when items have no result, instead of listing them in the report.
    #[arg(long)]
    pub require_complete: bool,
}

/// Run `rtdiff campaign`.
pub fn run(args: &CampaignArgs) -> Result<()> {
    if let Some(CampaignCommand::Merge(m)) = &args.command {
        return merge(m);
    }
    let path = args.plan.as_ref().ok_or_else(|| Error::Invalid("campaign: name a plan file".into()))?;
    let plan = crate::campaign::load(path)?;
    if args.list {
        let owner = crate::campaign::shard::assign(&plan.items, args.shard.count)?;
        println!("# plan {} ({} items, digest {})", path.display(), plan.items.len(), &plan.digest[..12]);
        println!("# id\tkind\tset\tinput\tcost\tshard");
        for (item, s) in plan.items.iter().zip(owner) {
            if args.shard.count > 1 && s != args.shard.index {
                continue;
            }
            let set = item.set.as_deref().unwrap_or("-");
            println!(
                "{}\t{}\t{set}\t{}\t{}\t{s}/{}",
                item.id,
                item.kind.name(),
                item.input,
                item.cost,
                args.shard.count
            );
        }
        return Ok(());
    }
    let out = args.out.clone().ok_or_else(|| {
        Error::Invalid("campaign: name the output folder with -o OUT (or print the items with --list)".into())
    })?;
    let shard_items = crate::campaign::shard::select(&plan.items, args.shard)?.len();
    let bar = crate::perf::progress::bar(shard_items as u64, &format!("campaign shard {}", args.shard), args.quiet);
    let opts = RunOptions { out: out.clone(), shard: args.shard, quiet: args.quiet };
    let s = crate::campaign::run::run(&plan, &opts, |r, _| {
        bar.set_message(r.item.id.clone());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    if !args.quiet {
        eprintln!(
            "rtdiff campaign: shard {}: {} items ({} run now, {} already done; {} inputs did not load, {} failed) -> {}",
            args.shard,
            s.shard_items,
            s.ran,
            s.skipped,
            s.load_errors,
            s.failed,
            out.display()
        );
    }
    Ok(())
}

fn merge(m: &MergeArgs) -> Result<()> {
    let c = crate::campaign::merge(&m.folders)?;
    // The same report whatever the folders are called or how many shards there were.
    let mut command = "rtdiff campaign merge OUT... -o REPORT".to_string();
    if m.no_timings {
        command.push_str(" --no-timings");
    }
    let opts = CampaignReportOptions { out: m.out.clone(), timings: !m.no_timings, command };
    let files = crate::report::campaign::write(&c, &opts)?;
    for i in &c.missing {
        eprintln!("rtdiff campaign merge: missing {} ({})", i.id, i.input);
    }
    eprintln!(
        "rtdiff campaign merge: {} of {} items from {} folders, {} missing -> {}",
        c.results.len(),
        c.manifest.items.len(),
        m.folders.len(),
        c.missing.len(),
        files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>().join(", ")
    );
    if m.require_complete && !c.missing.is_empty() {
        return Err(Error::Invalid(format!("{} items have no result (--require-complete)", c.missing.len())));
    }
    Ok(())
}
