//! `campaign merge`: any set of shard folders of one plan into one typed campaign report.
//! Folders of different plans, result formats or rtdiff versions are refused, naming the
//! folders; items with no result are listed. The outcome does not depend on the order of
//! the folders, nor on how the items were split between shards: an item found twice keeps
//! the result whose JSON sorts first, and everything is ordered as the plan lists it.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::item::ItemResult;
use super::plan::{Item, ItemKind};
use super::run::{ITEMS, Manifest, short};
use crate::error::{Error, Result};

/// One input's line of the campaign report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputSummary {
    /// The input as the plan lists it.
    pub input: String,
    /// Its format (file extension, `.gz` looked through).
    pub format: String,
    /// Triangles (when it loaded).
    pub triangles: Option<usize>,
    /// `ok`, or the load error.
    pub load: String,
    /// Parity by set: the verdict of each tracer (`tracer -> verdict`); see [`verdict`].
    pub parity: BTreeMap<String, BTreeMap<String, String>>,
    /// Disagreements the arbiter judged, over every set and tracer.
    pub judged: u64,
    /// Of those, rays where a tracer under test is wrong.
    pub tracer_wrong: u64,
    /// Rays where the reference is wrong.
    pub reference_wrong: u64,
    /// Speed: for each tracer, its camera-ray and incoherent-ray throughput over the reference's.
    pub speed: BTreeMap<String, [f64; 2]>,
    /// Failures after loading (per item).
    pub errors: Vec<String>,
}

/// A merged campaign: the plan, every result found and what is missing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Campaign {
    /// The plan's manifest.
    pub manifest: Manifest,
    /// Results, in the plan's item order.
    pub results: Vec<ItemResult>,
    /// Items with no result in any folder.
    pub missing: Vec<Item>,
    /// One line per input, in the plan's order.
    pub inputs: Vec<InputSummary>,
}

/// A tracer's verdict on one set: `agree` (every hit the reference's, distances and
/// barycentrics within bounds), `N ok` (N disagreements, the tracer exact or
/// within its rounding bound on each), `N judged, W wrong (class n, ...)` (the tracer beyond
/// the bound on W, by class), with `, L leaks` when there are any. Distances and barycentrics
/// beyond their bounds on the same primitive count as judged: the arbiter's exact hit decides.
pub fn verdict(t: &super::item::TracerParity) -> String {
    let beyond = t.dist_over_bound + t.bary_over_bound;
    let judged = t.judged + beyond;
    let mut s = if t.disagreements == 0 && beyond == 0 && t.wrong == 0 {
        "agree".to_string()
    } else if t.wrong == 0 && t.judged == t.disagreements {
        format!("{judged} ok")
    } else {
        let by: Vec<String> = t.wrong_by.iter().map(|(k, n)| format!("{k} {n}")).collect();
        let by = if by.is_empty() { String::new() } else { format!(" ({})", by.join(", ")) };
        format!("{judged} judged, {} wrong{by}", t.wrong)
    };
    if t.leaks > 0 {
        s.push_str(&format!(", {} leaks", t.leaks));
    }
    s
}

/// Merge the shard folders `folders`.
pub fn merge(folders: &[PathBuf]) -> Result<Campaign> {
    let Some(first) = folders.first() else {
        return Err(Error::Invalid("campaign merge: name at least one output folder".into()));
    };
    let manifest = Manifest::read(first)?;
    for f in &folders[1..] {
        let m = Manifest::read(f)?;
        if m.rtdiff != manifest.rtdiff {
            return Err(Error::Invalid(format!(
                "{} was run by rtdiff {} and {} by rtdiff {}: results of different versions are not merged",
                first.display(),
                manifest.rtdiff,
                f.display(),
                m.rtdiff
            )));
        }
        if m.plan != manifest.plan {
            return Err(Error::Invalid(format!(
                "{} holds plan '{}' (digest {}) and {} plan '{}' (digest {}): shards of different plans (or of one \
                 plan over different files) are not merged",
                first.display(),
                manifest.settings.name,
                short(&manifest.plan),
                f.display(),
                m.settings.name,
                short(&m.plan)
            )));
        }
    }
    let index: HashMap<&str, usize> = manifest.items.iter().enumerate().map(|(k, i)| (i.id.as_str(), k)).collect();
    let mut found: Vec<Option<(String, ItemResult)>> = vec![None; manifest.items.len()];
    for f in folders {
        for (path, r) in read_results(f)? {
            let Some(&k) = index.get(r.item.id.as_str()) else {
                return Err(Error::file(
                    &path,
                    format!("item {} is not an item of plan {}", r.item.id, short(&manifest.plan)),
                ));
            };
            if r.plan != manifest.plan || r.item != manifest.items[k] || r.rtdiff != manifest.rtdiff {
                return Err(Error::file(
                    &path,
                    format!(
                        "a result of plan {} by rtdiff {}, in a folder of plan {} by rtdiff {}",
                        short(&r.plan),
                        r.rtdiff,
                        short(&manifest.plan),
                        manifest.rtdiff
                    ),
                ));
            }
            let key = serde_json::to_string(&r).unwrap_or_default();
            if found[k].as_ref().is_none_or(|(old, _)| key < *old) {
                found[k] = Some((key, r));
            }
        }
    }
    let mut results = Vec::new();
    let mut missing = Vec::new();
    for (item, r) in manifest.items.iter().zip(found) {
        match r {
            Some((_, r)) => results.push(r),
            None => missing.push(item.clone()),
        }
    }
    let inputs = summarise(&manifest, &results);
    Ok(Campaign { manifest, results, missing, inputs })
}

/// Every `items/*.json` of `dir`, parsed (temporary files of killed runs are skipped).
fn read_results(dir: &Path) -> Result<Vec<(PathBuf, ItemResult)>> {
    let items = dir.join(ITEMS);
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(&items) else { return Ok(out) };
    let mut paths: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            !name.starts_with('.') && name.ends_with(".json")
        })
        .collect();
    paths.sort();
    for p in paths {
        let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, &e))?;
        let r: ItemResult =
            serde_json::from_slice(&bytes).map_err(|e| Error::file(&p, format!("not an item result: {e}")))?;
        out.push((p, r));
    }
    Ok(out)
}

/// The format of `input`: its extension, `.gz` looked through.
fn format_of(input: &str) -> String {
    let name = input.to_ascii_lowercase();
    let base = name.strip_suffix(".gz").unwrap_or(&name);
    let ext = Path::new(base).extension().and_then(|e| e.to_str()).unwrap_or("");
    if name.ends_with(".gz") { format!("{ext}.gz") } else { ext.to_string() }
}

fn summarise(manifest: &Manifest, results: &[ItemResult]) -> Vec<InputSummary> {
    let mut rows: Vec<InputSummary> = Vec::new();
    let mut at: HashMap<String, usize> = HashMap::new();
    for item in &manifest.items {
        at.entry(item.input.clone()).or_insert_with(|| {
            rows.push(InputSummary {
                input: item.input.clone(),
                format: format_of(&item.input),
                triangles: None,
                load: "not run".into(),
                parity: BTreeMap::new(),
                judged: 0,
                tracer_wrong: 0,
                reference_wrong: 0,
                speed: BTreeMap::new(),
                errors: Vec::new(),
            });
            rows.len() - 1
        });
    }
    for r in results {
        let row = &mut rows[at[&r.item.input]];
        row.load = match &r.load.error {
            None => "ok".into(),
            Some(e) => e.clone(),
        };
        if r.load.ok {
            row.triangles = Some(r.load.triangles);
        }
        if let Some(e) = &r.error {
            row.errors.push(format!("{}: {e}", r.item.id));
        }
        for s in &r.parity {
            let cell = row.parity.entry(s.set.clone()).or_default();
            for t in &s.tracers {
                cell.insert(t.tracer.clone(), verdict(t));
                row.judged += t.judged + t.dist_over_bound + t.bary_over_bound;
                row.tracer_wrong += t.wrong;
                row.reference_wrong += t.reference_wrong;
            }
        }
        if let (ItemKind::Speed, Some(s)) = (r.item.kind, &r.speed)
            && let Some(reference) = s.rows.first()
        {
            let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
            for row_t in &s.rows[1..] {
                row.speed.insert(
                    row_t.tracer.clone(),
                    [
                        ratio(row_t.primary_mrays_per_s, reference.primary_mrays_per_s),
                        ratio(row_t.incoherent_mrays_per_s, reference.incoherent_mrays_per_s),
                    ],
                );
            }
        }
    }
    rows
}

impl Campaign {
    /// The campaign with every timing zeroed (speed ratios included): what two runs of one plan
    /// share byte for byte.
    pub fn without_timings(&self) -> Self {
        let results: Vec<ItemResult> = self.results.iter().map(ItemResult::without_timings).collect();
        let inputs = summarise(&self.manifest, &results);
        Self { manifest: self.manifest.clone(), results, missing: self.missing.clone(), inputs }
    }
}
