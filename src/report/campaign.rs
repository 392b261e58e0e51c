//! A merged campaign ([`crate::campaign::Campaign`]) as files: `campaign.json` (the typed
//! report), `campaign.md` and `index.html` (the same tables as the other reports' pages).
//! Without timings every figure that depends on the machine or the moment is left out, so
//! that two runs of one plan give the same bytes.

use std::path::{Path, PathBuf};

use super::html::{Block, Section};
use super::table::{Table, fmt_num};
use crate::campaign::Campaign;
use crate::error::{Error, Result};

/// How to write the report.
#[derive(Clone, Debug)]
pub struct CampaignReportOptions {
    /// Output folder.
    pub out: PathBuf,
    /// Include timings (speed, seconds per item).
    pub timings: bool,
    /// The command that made it (shown under each table).
    pub command: String,
}

/// The report's tables, in page order: summary, inputs, load errors, disputes, speed, missing items.
pub fn tables(c: &Campaign, timings: bool) -> Vec<(String, Table)> {
    let m = &c.manifest;
    let s = &m.settings;
    let loaded = c.inputs.iter().filter(|i| i.load == "ok").count();
    let mut out = Vec::new();
    let summary = Table {
        title: String::new(),
        header: vec!["campaign".into(), "".into()],
        rows: vec![
            vec!["plan".into(), if s.name.is_empty() { "(unnamed)".into() } else { s.name.clone() }],
            vec!["digest".into(), m.plan.clone()],
            vec!["rtdiff".into(), m.rtdiff.clone()],
            vec!["inputs (loaded)".into(), format!("{} ({loaded})", c.inputs.len())],
            vec!["items (missing)".into(), format!("{} ({})", m.items.len(), c.missing.len())],
            vec!["tracers".into(), s.tracers.join(", ")],
            vec!["reference".into(), s.reference.clone()],
            vec![
                "ray sets".into(),
                format!("{} x {} rays, seed {}", s.rays.sets.join(", "), s.rays.count, s.rays.seed),
            ],
        ],
        notes: Vec::new(),
    };
    out.push(("summary".to_string(), summary));

    let mut sets: Vec<String> = Vec::new();
    let mut tracers: Vec<String> = Vec::new();
    for i in &c.inputs {
        for (set, by) in &i.parity {
            if !sets.contains(set) {
                sets.push(set.clone());
            }
            for t in by.keys() {
                if !tracers.contains(t) {
                    tracers.push(t.clone());
                }
            }
        }
    }
    let order = |s: &String| crate::rays::SetKind::ALL.iter().position(|k| s.starts_with(k.name())).unwrap_or(99);
    sets.sort_by_key(|s| (order(s), s.clone()));
    let speed_tracers: Vec<String> =
        c.inputs.iter().flat_map(|i| i.speed.keys().cloned()).fold(Vec::new(), |mut v, t| {
            if !v.contains(&t) {
                v.push(t);
            }
            v
        });
    let mut header = vec!["input".to_string(), "format".into(), "triangles".into(), "load".into()];
    header.extend(sets.iter().cloned());
    header.extend(["judged".into(), "tracer wrong".into(), "reference wrong".into()]);
    if timings {
        header.extend(speed_tracers.iter().map(|t| format!("{t} speed (camera / incoherent)")));
    }
    let rows = c
        .inputs
        .iter()
        .map(|i| {
            let mut r = vec![
                i.input.clone(),
                i.format.clone(),
                i.triangles.map_or_else(|| "-".into(), |t| t.to_string()),
                if i.load == "ok" || i.load == "not run" { i.load.clone() } else { "error".into() },
            ];
            for set in &sets {
                r.push(match i.parity.get(set) {
                    None => "-".into(),
                    Some(by) if tracers.len() == 1 => by.values().next().cloned().unwrap_or_default(),
                    Some(by) => by.iter().map(|(t, v)| format!("{t}: {v}")).collect::<Vec<_>>().join("; "),
                });
            }
            r.extend([i.judged.to_string(), i.tracer_wrong.to_string(), i.reference_wrong.to_string()]);
            if timings {
                for t in &speed_tracers {
                    r.push(
                        i.speed
                            .get(t)
                            .map_or_else(|| "-".into(), |[p, q]| format!("{} / {}", fmt_num(*p), fmt_num(*q))),
                    );
                }
            }
            r
        })
        .collect();
    let mut notes = vec![format!(
        "Parity against {}: `agree` (every closest hit the reference's, within the error bounds), `N ok` (N rays \
         differ from the reference, and the exact arbiter finds the tracer exact or within its rounding bound on each), \
         `N judged, W wrong (class n, ...)` (the tracer beyond the bound on W of them), `, L leaks` (rays through a \
         shared edge or vertex). Tracers: {}.",
        s.reference,
        tracers.join(", ")
    )];
    if timings {
        notes.push(
            "Speed: the tracer's throughput over the reference's on the same rays (above 1: faster), median of \
                    interleaved rounds."
                .into(),
        );
    }
    out.push(("inputs".to_string(), Table { title: "Inputs".into(), header, rows, notes }));

    let errors: Vec<Vec<String>> = c
        .inputs
        .iter()
        .filter(|i| i.load != "ok" && i.load != "not run")
        .map(|i| vec![i.input.clone(), i.load.clone()])
        .chain(c.inputs.iter().flat_map(|i| i.errors.iter().map(move |e| vec![i.input.clone(), e.clone()])))
        .collect();
    if !errors.is_empty() {
        out.push((
            "errors".to_string(),
            Table {
                title: "Inputs that did not load, and failures".into(),
                header: vec!["input".into(), "error".into()],
                rows: errors,
                notes: Vec::new(),
            },
        ));
    }

    let mut disputes = Vec::new();
    for r in &c.results {
        for s in &r.parity {
            for t in &s.tracers {
                for d in &t.disputes {
                    disputes.push(vec![
                        r.item.input.clone(),
                        s.set.clone(),
                        t.tracer.clone(),
                        d.index.to_string(),
                        d.class.clone(),
                        d.tracer.clone(),
                        d.reference.clone(),
                        d.line.clone(),
                    ]);
                }
            }
        }
    }
    if !disputes.is_empty() {
        out.push((
            "disputes".to_string(),
            Table {
                title: "The arbiter's disputes (rays where a tracer is not exact; first few per set)".into(),
                header: [
                    "input",
                    "set",
                    "tracer",
                    "ray",
                    "class",
                    "tracer verdict",
                    "reference verdict",
                    "ray (hex, then decimal)",
                ]
                .map(String::from)
                .to_vec(),
                rows: disputes,
                notes: vec![
                    "Replay a ray with `rtdiff parity INPUT --rays SET --seed SEED` (its index) or feed its \
                             line to `rtdiff trace`."
                        .into(),
                ],
            },
        ));
    }

    if timings {
        let mut rows = Vec::new();
        for r in &c.results {
            if let Some(s) = &r.speed {
                for row in &s.rows {
                    rows.push(vec![
                        r.item.input.clone(),
                        row.tracer.clone(),
                        fmt_num(row.build_ms),
                        fmt_num(row.primary_mrays_per_s),
                        fmt_num(row.incoherent_mrays_per_s),
                        row.differences.to_string(),
                    ]);
                }
            }
        }
        if !rows.is_empty() {
            out.push((
                "speed".to_string(),
                Table {
                    title: "Speed".into(),
                    header: [
                        "input",
                        "tracer",
                        "build ms",
                        "camera Mrays/s",
                        "incoherent Mrays/s",
                        "camera rays differing",
                    ]
                    .map(String::from)
                    .to_vec(),
                    rows,
                    notes: vec![format!(
                        "{}x{} camera rays and {} incoherent rays, all threads, median of {} interleaved rounds; the \
                         reference first.",
                        s.speed.size, s.speed.size, s.speed.incoherent, s.speed.runs
                    )],
                },
            ));
        }
    }

    if !c.missing.is_empty() {
        out.push((
            "missing".to_string(),
            Table {
                title: format!("Missing items ({} of {})", c.missing.len(), m.items.len()),
                header: vec!["item".into(), "input".into()],
                rows: c.missing.iter().map(|i| vec![i.id.clone(), i.input.clone()]).collect(),
                notes: vec!["Run the shards that hold them again (they resume), then merge.".into()],
            },
        ));
    }
    out
}

/// The report as Markdown: the tables of the HTML page but the per-tracer speed table (a
/// row per input and tracer; the inputs table has each tracer's speed over the reference's),
/// which stays in `index.html` and `campaign.json`, so that a corpus report stays readable.
pub fn markdown(c: &Campaign, timings: bool, command: &str) -> String {
    let name = &c.manifest.settings.name;
    let mut o = format!("# Campaign {}\n\n`{command}`\n\n", if name.is_empty() { "(unnamed)" } else { name });
    for (id, t) in tables(c, timings) {
        if id == "speed" {
            o.push_str("Build times and throughputs per input and tracer: the Speed table of `index.html` and `campaign.json`.\n\n");
            continue;
        }
        o.push_str(&t.to_markdown());
        o.push('\n');
    }
    o
}

/// Write `campaign.json`, `campaign.md` and `index.html` into `opts.out`; returns the files.
pub fn write(c: &Campaign, opts: &CampaignReportOptions) -> Result<Vec<PathBuf>> {
    let dir = &opts.out;
    std::fs::create_dir_all(dir).map_err(|e| Error::file(dir, format!("cannot create folder: {e}")))?;
    let c = if opts.timings { c.clone() } else { c.without_timings() };
    let file = |n: &str| -> PathBuf { Path::new(dir).join(n) };
    crate::output::write_json(&file("campaign.json"), &c)?;
    crate::output::write(&file("campaign.md"), markdown(&c, opts.timings, &opts.command))?;
    let sections: Vec<Section> = tables(&c, opts.timings)
        .into_iter()
        .map(|(id, t)| Section {
            title: if t.title.is_empty() { "Campaign".into() } else { t.title.clone() },
            id,
            intro: String::new(),
            blocks: vec![Block::Table(t)],
            command: opts.command.clone(),
            data: vec!["campaign.json".into(), "campaign.md".into()],
        })
        .collect();
    let name = &c.manifest.settings.name;
    let title = format!("rtdiff campaign {}", if name.is_empty() { "(unnamed)" } else { name });
    crate::output::write(&file("index.html"), super::html::page(&title, &[], &sections))?;
    Ok(vec![file("campaign.json"), file("campaign.md"), file("index.html")])
}
