//! Running a shard of a campaign into an output folder, resumably:
//!
//! ```text
//! OUT/campaign.json        the manifest: plan, digest, version, every item (the same for every shard)
//! OUT/items/ID.json        one result per finished item, each written whole or not at all
//! ```
//!
//! A run first checks the manifest (a folder holding another plan's results is refused),
//! clears temporary files that killed runs of this host left, then runs the shard's items
//! in order, skipping every item whose result is already there. Killed at any point and
//! started again, it redoes only the item it was in. Shards may share one folder (on a
//! shared file system) or each have their own; `campaign merge` takes any set of them.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::item::{self, ItemResult, RESULT_FORMAT, RTDIFF_VERSION};
use super::plan::{Item, Plan, PlanFile};
use super::shard::{self, Shard};
use crate::error::{Error, Result};

/// The manifest file's name in an output folder.
pub const MANIFEST: &str = "campaign.json";

/// The folder of the item results.
pub const ITEMS: &str = "items";

/// What every shard folder of one plan holds in `campaign.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// [`RESULT_FORMAT`].
    pub format: u32,
    /// The rtdiff version that ran the plan.
    pub rtdiff: String,
    /// The plan's digest.
    pub plan: String,
    /// The plan's settings (defaults filled in).
    pub settings: PlanFile,
    /// Every item of the plan (all shards), in listing order.
    pub items: Vec<Item>,
}

impl Manifest {
    /// The manifest of `plan` as this build runs it.
    pub fn of(plan: &Plan) -> Self {
        Self {
            format: RESULT_FORMAT,
            rtdiff: RTDIFF_VERSION.to_string(),
            plan: plan.digest.clone(),
            settings: plan.file.clone(),
            items: plan.items.clone(),
        }
    }

    /// Read `dir/campaign.json`.
    pub fn read(dir: &Path) -> Result<Self> {
        let path = dir.join(MANIFEST);
        if !path.is_file() {
            return Err(Error::file(dir, "not a campaign output folder: it has no campaign.json"));
        }
        let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, &e))?;
        let v: serde_json::Value =
            serde_json::from_slice(&bytes).map_err(|e| Error::file(&path, format!("not a manifest: {e}")))?;
        let format = v.get("format").and_then(|f| f.as_u64()).unwrap_or(0);
        if format != u64::from(RESULT_FORMAT) {
            let by = v.get("rtdiff").and_then(|f| f.as_str()).unwrap_or("?");
            return Err(Error::file(
                &path,
                format!(
                    "result format {format} (made by rtdiff {by}); this rtdiff {RTDIFF_VERSION} reads format {RESULT_FORMAT}"
                ),
            ));
        }
        serde_json::from_value(v).map_err(|e| Error::file(&path, format!("not a manifest: {e}")))
    }
}

/// Where and how to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Output folder.
    pub out: PathBuf,
    /// Which shard.
    pub shard: Shard,
    /// No progress bar.
    pub quiet: bool,
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    /// Items of this shard.
    pub shard_items: usize,
    /// Items run now.
    pub ran: usize,
    /// Items whose result was already there.
    pub skipped: usize,
    /// Inputs that did not load (among the items run now).
    pub load_errors: usize,
    /// Items that failed after loading (among the items run now).
    pub failed: usize,
    /// Temporary files of killed runs removed.
    pub stale_temps: usize,
}

/// The result file of item `id` in `out`.
pub fn result_path(out: &Path, id: &str) -> PathBuf {
    out.join(ITEMS).join(format!("{id}.json"))
}

/// The finished result of `item` in `out`, if a valid one of this plan is there.
pub fn finished(out: &Path, plan: &str, item: &Item) -> Option<ItemResult> {
    let bytes = std::fs::read(result_path(out, &item.id)).ok()?;
    let r: ItemResult = serde_json::from_slice(&bytes).ok()?;
    (r.plan == plan && r.item == *item && r.format == RESULT_FORMAT).then_some(r)
}

/// Check that every tracer of `plan` can be built here (Embree present, ...), before any item runs.
fn check_tracers(plan: &Plan) -> Result<()> {
    use crate::geometry::{Primitives, Triangle};
    let tri = Triangle { v: [glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y] };
    let prims = std::sync::Arc::new(Primitives { triangles: vec![tri], spheres: Vec::new() });
    let mut all = plan.tracers.clone();
    all.push(plan.reference.config());
    for cfg in &all {
        crate::backends::build_tracer(prims.clone(), cfg)
            .map_err(|e| Error::file(&plan.path, format!("tracer {}: {e}", cfg.label())))?;
    }
    Ok(())
}

/// Run `opts.shard` of `plan` into `opts.out`, calling `done(result, skipped)` after each item
/// (run now, or skipped because its result was there).
pub fn run(plan: &Plan, opts: &RunOptions, mut done: impl FnMut(&ItemResult, bool)) -> Result<RunSummary> {
    check_tracers(plan)?;
    let out = &opts.out;
    let items_dir = out.join(ITEMS);
    std::fs::create_dir_all(&items_dir).map_err(|e| Error::file(&items_dir, format!("cannot create folder: {e}")))?;
    let manifest = Manifest::of(plan);
    match Manifest::read(out) {
        Ok(m) if m.plan == manifest.plan && m.rtdiff == manifest.rtdiff => {}
        Ok(m) if m.plan == manifest.plan => {
            return Err(Error::file(
                out,
                format!(
                    "holds results of rtdiff {}; this is rtdiff {RTDIFF_VERSION}: use another folder (results of two versions are not merged)",
                    m.rtdiff
                ),
            ));
        }
        Ok(m) => {
            return Err(Error::file(
                out,
                format!(
                    "holds results of another plan (digest {}, '{}'), not {} (digest {}): use another folder",
                    short(&m.plan),
                    m.settings.name,
                    plan.path.display(),
                    short(&plan.digest)
                ),
            ));
        }
        Err(_) if out.join(MANIFEST).exists() => return Err(Manifest::read(out).unwrap_err()),
        Err(_) => crate::output::write_json(&out.join(MANIFEST), &manifest)?,
    }
    let mut summary = RunSummary {
        stale_temps: crate::output::remove_stale_temps(&items_dir)? + crate::output::remove_stale_temps(out)?,
        ..Default::default()
    };
    let mine = shard::select(&plan.items, opts.shard)?;
    summary.shard_items = mine.len();
    for it in mine {
        if let Some(r) = finished(out, &plan.digest, it) {
            summary.skipped += 1;
            done(&r, true);
            continue;
        }
        let r = item::run(plan, it);
        summary.ran += 1;
        summary.load_errors += usize::from(!r.load.ok);
        summary.failed += usize::from(r.error.is_some());
        crate::output::write_json(&result_path(out, &it.id), &r)?;
        done(&r, false);
    }
    Ok(summary)
}

/// The first 12 hex digits of a digest.
pub fn short(digest: &str) -> &str {
    &digest[..digest.len().min(12)]
}
