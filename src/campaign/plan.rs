//! A campaign plan: data (TOML or JSON) naming the meshes and scenes, the ray sets, the
//! tracers and the reports to make; and the work items it expands to, each with a stable
//! id and an estimated cost. Nothing here depends on timing or on the machine: the same
//! plan over the same files gives the same items, ids, costs and digest everywhere.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::backends::{AccelConfig, Backend, Builder, EmbreeMode, EmbreeQuality, Traversal};
use crate::error::{Error, Result};
use crate::geometry::TriangleTest;
use crate::rays::SetKind;

/// The plan format this build reads (`version` in the file).
pub const PLAN_VERSION: u32 = 1;

/// A plan as written (absent fields take the defaults below).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlanFile {
    /// Plan format version: [`PLAN_VERSION`].
    pub version: u32,
    /// A name for the reports.
    pub name: String,
    /// The folder inputs are found from and named relative to, itself relative to the plan's
    /// folder (default: the plan's folder).
    pub root: String,
    /// Mesh files, folders (searched recursively for every mesh format rtdiff reads) and
    /// globs (`assets/**/*.stl`), relative to `root`.
    pub meshes: Vec<String>,
    /// Globs of paths to leave out (matched against the paths as listed, relative to the plan).
    pub exclude: Vec<String>,
    /// Scene files (`.json`): their primitives, camera and lights.
    pub scenes: Vec<String>,
    /// Tracers under test: `rtdiff`, `rtdiff:BUILDER/TRAVERSAL[/moller-trumbore]`, `embree`,
    /// `embree:QUALITY[:default]`, `brute` (see [`parse_tracer`]).
    pub tracers: Vec<String>,
    /// What the tracers are judged against: `embree` (robust, HIGH) or `brute`.
    pub reference: String,
    /// The item kinds to run: `parity` (one item per input and ray set) and `speed` (one per input).
    pub reports: Vec<String>,
    /// Ray sets of the parity items.
    pub rays: RaysSection,
    /// Rays and repeats of the speed items.
    pub speed: SpeedSection,
}

/// `[rays]`: the parity items' ray sets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RaysSection {
    /// Set names (`primary`, `incoherent`, `shadow`, `edges`, `vertices`, `grazing`, `axis`,
    /// `surface`, `scaled`) or `all`.
    pub sets: Vec<String>,
    /// Rays per set.
    pub count: usize,
    /// Seed of every set.
    pub seed: u64,
}

/// `[speed]`: what a speed item times.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpeedSection {
    /// Camera rays: `size` x `size` through the pixel centres of the input's camera.
    pub size: u32,
    /// Incoherent rays (random origins in the bounds, random directions).
    pub incoherent: usize,
    /// Interleaved rounds (each tracer built and traced once per round); medians are reported.
    pub runs: usize,
}

impl Default for PlanFile {
    fn default() -> Self {
        Self {
            version: PLAN_VERSION,
            name: String::new(),
            root: ".".into(),
            meshes: Vec::new(),
            exclude: Vec::new(),
            scenes: Vec::new(),
            tracers: vec!["rtdiff".into()],
            reference: "embree".into(),
            reports: vec!["parity".into(), "speed".into()],
            rays: RaysSection::default(),
            speed: SpeedSection::default(),
        }
    }
}

impl Default for RaysSection {
    fn default() -> Self {
        Self { sets: vec!["all".into()], count: 2000, seed: 1 }
    }
}

impl Default for SpeedSection {
    fn default() -> Self {
        Self { size: 128, incoherent: 16384, runs: 3 }
    }
}

/// What one item does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ItemKind {
    /// Hit parity of every tracer against the reference on one ray set, every disagreement judged
    /// by the exact arbiter.
    Parity,
    /// Build and trace times of every tracer and the reference (interleaved rounds).
    Speed,
}

impl ItemKind {
    /// The name used in plans, ids and reports.
    pub fn name(self) -> &'static str {
        match self {
            ItemKind::Parity => "parity",
            ItemKind::Speed => "speed",
        }
    }
}

/// One unit of work: an input (mesh or scene) and what to do with it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Item {
    /// Stable id: kind, set, the input's file stem and a hash of all three with the plan's
    /// parameters for the kind (`parity-edges-bunny-1f3a5c7e90`).
    pub id: String,
    /// What it does.
    pub kind: ItemKind,
    /// The input as listed: a path relative to the plan's folder, `/`-separated.
    pub input: String,
    /// The parity item's ray set.
    pub set: Option<String>,
    /// Estimated cost: estimated triangles (from the file's size and format) x rays.
    pub cost: u64,
}

/// A plan ready to run: the file's settings, checked and resolved, and its items.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The plan file's path.
    pub path: PathBuf,
    /// The folder inputs are relative to (the plan's folder joined with its `root`).
    pub dir: PathBuf,
    /// The settings (defaults filled in).
    pub file: PlanFile,
    /// The tracers under test.
    pub tracers: Vec<AccelConfig>,
    /// The reference.
    pub reference: crate::verify::hits::Reference,
    /// The parity ray sets.
    pub sets: Vec<SetKind>,
    /// Every item, in listing order (inputs sorted, then kind and set).
    pub items: Vec<Item>,
    /// SHA-256 of the settings and the item list: results of one plan carry it, and merge refuses
    /// to mix digests.
    pub digest: String,
}

/// Parse a tracer as a plan names it:
/// - `rtdiff` (the default configuration, `bvh-sah/fast`), `rtdiff:BUILDER/TRAVERSAL` and
///   `rtdiff:BUILDER/TRAVERSAL/moller-trumbore` (builders `median`, `sah-volume`, `sah`;
///   traversals `basic`, `priority-queue`, `sorted-vector`, `nth-element`, `fast`);
/// - `embree` (robust flag, HIGH quality), `embree:QUALITY` (`low`, `medium`, `high`) and
///   `embree:QUALITY:default` (Embree's default scene flags);
/// - `brute` (every triangle against every ray, watertight);
/// - `plugin:PATH`, a shared library implementing `include/rtdiff_tracer.h`, loaded here (a
///   relative path is taken from the current folder; [`resolve`] takes it from the plan's).
pub fn parse_tracer(spec: &str) -> Result<AccelConfig> {
    use clap::ValueEnum;
    let bad = |why: String| Error::Invalid(format!("tracer '{spec}': {why}"));
    let mut parts = spec.split(':');
    let head = parts.next().unwrap_or_default();
    let rest: Vec<&str> = parts.collect();
    match head {
        "rtdiff" => {
            let mut cfg = AccelConfig::default();
            if let Some(v) = rest.first() {
                let f: Vec<&str> = v.split('/').collect();
                if rest.len() > 1 || !(2..=3).contains(&f.len()) {
                    return Err(bad("expected rtdiff:BUILDER/TRAVERSAL[/moller-trumbore]".into()));
                }
                cfg.builder = Builder::from_str(f[0], false).map_err(|_| bad(format!("unknown builder '{}'", f[0])))?;
                cfg.traversal =
                    Traversal::from_str(f[1], false).map_err(|_| bad(format!("unknown traversal '{}'", f[1])))?;
                if let Some(t) = f.get(2) {
                    cfg.triangle_test = t.parse::<TriangleTest>().map_err(bad)?;
                }
            }
            Ok(cfg)
        }
        "embree" => {
            let mut cfg = AccelConfig { backend: Backend::Embree, ..Default::default() };
            if rest.len() > 2 {
                return Err(bad("expected embree[:QUALITY[:default]]".into()));
            }
            if let Some(q) = rest.first() {
                cfg.embree_quality =
                    EmbreeQuality::from_str(q, false).map_err(|_| bad(format!("unknown quality '{q}'")))?;
            }
            if let Some(m) = rest.get(1) {
                cfg.embree_mode = EmbreeMode::from_str(m, false).map_err(|_| bad(format!("unknown mode '{m}'")))?;
            }
            Ok(cfg)
        }
        "brute" if rest.is_empty() => Ok(AccelConfig { backend: Backend::Brute, ..Default::default() }),
        "plugin" if !rest.is_empty() && !rest.join(":").is_empty() => {
            let id = crate::plugin::load(Path::new(&rest.join(":"))).map_err(|e| bad(e.to_string()))?;
            Ok(AccelConfig { backend: Backend::Plugin(id), ..Default::default() })
        }
        _ => Err(bad("expected rtdiff[:BUILDER/TRAVERSAL], embree[:QUALITY[:default]], brute or plugin:PATH".into())),
    }
}

/// Read the plan at `path` (`.toml`, or `.json`), check it, find its inputs and list its items.
pub fn load(path: &Path) -> Result<Plan> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, &e))?;
    let is_json = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let file: PlanFile = if is_json {
        let de = &mut serde_json::Deserializer::from_str(&text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            let inner = e.inner();
            Error::at(path, inner.line(), format!("{}: {}", e.path(), inner))
        })?
    } else {
        toml::from_str(&text).map_err(|e| {
            let line = e.span().map_or(0, |s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            let msg = e.message().to_string();
            if line > 0 { Error::at(path, line, msg) } else { Error::file(path, msg) }
        })?
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let dir = if file.root == "." { dir } else { dir.join(&file.root) };
    if !dir.is_dir() {
        return Err(Error::file(path, format!("root '{}' ({}): no such folder", file.root, dir.display())));
    }
    resolve(path, &dir, file)
}

/// Check `file` (read from `path`, inputs relative to `dir`) and expand it into items.
pub fn resolve(path: &Path, dir: &Path, file: PlanFile) -> Result<Plan> {
    let err = |msg: String| Error::file(path, msg);
    if file.version != PLAN_VERSION {
        return Err(err(format!("version {}: this rtdiff reads plan version {PLAN_VERSION}", file.version)));
    }
    if file.tracers.is_empty() {
        return Err(err("tracers: name at least one tracer".into()));
    }
    let tracers = file
        .tracers
        .iter()
        .map(|t| {
            // A plugin's relative path is relative to the plan's folder, like the inputs.
            let t = match t.strip_prefix("plugin:") {
                Some(p) if !p.is_empty() && Path::new(p).is_relative() => {
                    format!("plugin:{}", path.parent().unwrap_or(Path::new("")).join(p).display())
                }
                _ => t.clone(),
            };
            parse_tracer(&t).map_err(|e| err(format!("tracers: {e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    let reference = match file.reference.as_str() {
        "embree" => crate::verify::hits::Reference::Embree,
        "brute" => crate::verify::hits::Reference::Brute,
        other => return Err(err(format!("reference '{other}': expected embree or brute"))),
    };
    let mut kinds = BTreeSet::new();
    for r in &file.reports {
        kinds.insert(match r.as_str() {
            "parity" => ItemKind::Parity,
            "speed" => ItemKind::Speed,
            other => return Err(err(format!("reports: '{other}' is not a report (expected parity or speed)"))),
        });
    }
    if kinds.is_empty() {
        return Err(err("reports: name at least one of parity, speed".into()));
    }
    let sets = parse_sets(&file.rays.sets).map_err(|e| err(format!("rays.sets: {e}")))?;
    let limit = crate::limits::MAX_RAYS;
    if kinds.contains(&ItemKind::Parity) && !(1..=limit).contains(&file.rays.count) {
        return Err(err(format!("rays.count: {} is not between 1 and {limit}", file.rays.count)));
    }
    let s = &file.speed;
    if kinds.contains(&ItemKind::Speed)
        && (!(1..=4096).contains(&s.size) || s.incoherent > limit || !(1..=crate::limits::MAX_RUNS).contains(&s.runs))
    {
        return Err(err(format!(
            "speed: size {} (1 to 4096), incoherent {} (0 to {limit}), runs {} (1 to {}) out of range",
            s.size,
            s.incoherent,
            s.runs,
            crate::limits::MAX_RUNS
        )));
    }
    let inputs = find_inputs(path, dir, &file)?;
    if inputs.is_empty() {
        return Err(err("no inputs: meshes and scenes find no file".into()));
    }
    let mut items = Vec::new();
    for (rel, bytes_est) in &inputs {
        for &kind in &kinds {
            match kind {
                ItemKind::Parity => {
                    for set in &sets {
                        let rays = file.rays.count as u64;
                        items.push(make_item(&file, kind, rel, Some(set.name()), bytes_est.saturating_mul(rays)));
                    }
                }
                ItemKind::Speed => {
                    let rays = (s.size as u64).pow(2) + s.incoherent as u64;
                    let cost = bytes_est.saturating_mul(rays).saturating_mul(s.runs as u64);
                    items.push(make_item(&file, kind, rel, None, cost));
                }
            }
        }
    }
    let mut seen = BTreeSet::new();
    if let Some(dup) = items.iter().find(|i| !seen.insert(i.id.clone())) {
        return Err(err(format!("two items share the id {} (the same input listed twice?)", dup.id)));
    }
    let digest = digest(&file, &items);
    Ok(Plan { path: path.to_path_buf(), dir: dir.to_path_buf(), file, tracers, reference, sets, items, digest })
}

fn parse_sets(names: &[String]) -> std::result::Result<Vec<SetKind>, String> {
    use clap::ValueEnum;
    let mut out = Vec::new();
    for n in names {
        if n == "all" {
            out.extend(SetKind::ALL);
        } else {
            out.push(SetKind::from_str(n, false).map_err(|_| {
                let all: Vec<&str> = SetKind::ALL.iter().map(|k| k.name()).collect();
                format!("unknown set '{n}' (expected all, {})", all.join(", "))
            })?);
        }
    }
    let mut seen = std::collections::HashSet::new();
    out.retain(|k| seen.insert(*k));
    if out.is_empty() {
        return Err("name at least one set".into());
    }
    Ok(out)
}

/// The item's id: kind, set and the input's file stem, then 10 hex digits of a hash over them
/// and the parameters the kind depends on.
fn make_item(file: &PlanFile, kind: ItemKind, input: &str, set: Option<&str>, cost: u64) -> Item {
    let params = match kind {
        ItemKind::Parity => format!("{}|{}|{:?}|{}", file.rays.count, file.rays.seed, file.tracers, file.reference),
        ItemKind::Speed => format!("{:?}|{:?}|{}", file.speed, file.tracers, file.reference),
    };
    let h = Sha256::digest(format!("{}|{}|{input}|{params}", kind.name(), set.unwrap_or("")).as_bytes());
    let hex: String = h.iter().take(5).map(|b| format!("{b:02x}")).collect();
    let stem = Path::new(input).file_name().and_then(|s| s.to_str()).unwrap_or("input");
    let stem: String = stem
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
        .take(40)
        .collect();
    let id = match set {
        Some(s) => format!("{}-{s}-{stem}-{hex}", kind.name()),
        None => format!("{}-{stem}-{hex}", kind.name()),
    };
    Item { id, kind, input: input.to_string(), set: set.map(str::to_string), cost: cost.max(1) }
}

fn digest(file: &PlanFile, items: &[Item]) -> String {
    let text = serde_json::to_string(&(file, items)).unwrap_or_default();
    Sha256::digest(text.as_bytes()).iter().map(|b| format!("{b:02x}")).collect()
}

/// `p` relative to `dir`, `/`-separated (as is when it is not inside `dir`).
fn relative(dir: &Path, p: &Path) -> String {
    match p.strip_prefix(dir) {
        Ok(rel) => rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect::<Vec<_>>().join("/"),
        Err(_) => p.to_string_lossy().replace('\\', "/"),
    }
}

/// Every input with its estimated size in triangle units, sorted by path, duplicates dropped.
fn find_inputs(path: &Path, dir: &Path, file: &PlanFile) -> Result<Vec<(String, u64)>> {
    let err = |msg: String| Error::file(path, msg);
    let exclude = file
        .exclude
        .iter()
        .map(|g| glob::Pattern::new(g).map_err(|e| err(format!("exclude '{g}': {e}"))))
        .collect::<Result<Vec<_>>>()?;
    let mut found = BTreeSet::new();
    for (entry, scene) in file.meshes.iter().map(|m| (m, false)).chain(file.scenes.iter().map(|s| (s, true))) {
        let full = dir.join(entry);
        let what = if scene { "scenes" } else { "meshes" };
        let accept = |p: &Path| if scene { is_scene(p) } else { crate::mesh::is_mesh_file(p) };
        let mut matched = Vec::new();
        if full.is_dir() {
            walk(&full, &mut matched).map_err(|e| err(format!("{what}: '{entry}': {e}")))?;
        } else if full.is_file() {
            matched.push(full.clone());
        } else if entry.contains(['*', '?', '[']) {
            let pattern = full.to_string_lossy().into_owned();
            let paths = glob::glob(&pattern).map_err(|e| err(format!("{what}: '{entry}': {e}")))?;
            matched.extend(paths.flatten().filter(|p| p.is_file()));
        } else {
            return Err(err(format!("{what}: '{entry}' ({}): no such file or folder", full.display())));
        }
        let before = found.len();
        for p in matched.into_iter().filter(|p| accept(p)) {
            let rel = relative(dir, &p);
            if !exclude.iter().any(|g| g.matches(&rel)) {
                found.insert(rel);
            }
        }
        if found.len() == before && !full.is_dir() && !entry.contains(['*', '?', '[']) {
            return Err(err(format!(
                "{what}: '{entry}' is not a {} file",
                if scene { "scene (.json)" } else { "mesh" }
            )));
        }
    }
    Ok(found.into_iter().map(|rel| (rel.clone(), triangle_estimate(&dir.join(&rel)))).collect())
}

fn is_scene(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Every file below `dir` (sorted walk; links to folders are not followed).
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    let mut entries: Vec<_> = std::fs::read_dir(dir)?.collect::<std::io::Result<Vec<_>>>()?;
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let t = e.file_type()?;
        if t.is_dir() {
            walk(&e.path(), out)?;
        } else if t.is_file() {
            out.push(e.path());
        }
    }
    Ok(())
}

/// Estimated triangles of a mesh or scene from file sizes alone (a `stat`, no read but a
/// scene's JSON or a glTF's, so that listing 10,000 inputs stays cheap): bytes / the typical
/// bytes per triangle of the format, 4 times the size for gzip.
pub fn triangle_estimate(path: &Path) -> u64 {
    let size = |p: &Path| std::fs::metadata(p).map_or(0, |m| m.len());
    let name = path.to_string_lossy().to_ascii_lowercase();
    let (base, gz) = match name.strip_suffix(".gz") {
        Some(b) => (b.to_string(), 4),
        None => (name.clone(), 1),
    };
    let per_triangle = |b: &str| match b.rsplit('.').next().unwrap_or("") {
        "obj" => 60,
        "ply" => 30,
        "stl" => 50,
        "glb" | "gltf" => 30,
        _ => 60,
    };
    if base.ends_with(".json") || base.ends_with(".gltf") {
        // The files a scene or a glTF names (meshes[].file, buffers[].uri) count with its own size.
        let dir = path.parent().unwrap_or(Path::new("."));
        let json: serde_json::Value = std::fs::read(path)
            .ok()
            .filter(|b| b.len() < 64 << 20)
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default();
        let (list, key) = if base.ends_with(".json") { ("meshes", "file") } else { ("buffers", "uri") };
        let mut total = if base.ends_with(".gltf") { size(path) / 30 } else { 0 };
        for e in json.get(list).and_then(|v| v.as_array()).into_iter().flatten() {
            if let Some(f) = e.get(key).and_then(|f| f.as_str()).filter(|f| !f.starts_with("data:")) {
                let p = dir.join(f);
                total += if base.ends_with(".json") { triangle_estimate(&p) } else { size(&p) / 30 };
            }
        }
        return total.max(1);
    }
    if gz == 1
        && let Some(n) = header_count(path, &base)
    {
        return n.max(1);
    }
    (size(path) * gz / per_triangle(&base)).max(1)
}

/// The triangle count a binary STL's header or a PLY's `element face` line states (the first
/// 64 KiB of the file are read); `None` for other files.
fn header_count(path: &Path, base: &str) -> Option<u64> {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path).ok()?.take(64 << 10).read_to_end(&mut head).ok()?;
    if base.ends_with(".stl") {
        let size = std::fs::metadata(path).ok()?.len();
        let n = u64::from(u32::from_le_bytes(head.get(80..84)?.try_into().ok()?));
        // Binary when the size matches the count; ASCII facets take about 250 bytes each.
        return Some(if 84 + 50 * n == size { n } else { size / 250 });
    }
    if base.ends_with(".ply") {
        let text = String::from_utf8_lossy(&head);
        let line = text.lines().take_while(|l| !l.starts_with("end_header")).find(|l| l.starts_with("element face"))?;
        return line.split_whitespace().nth(2)?.parse().ok();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracers_parse_and_bad_ones_say_what_is_expected() {
        assert_eq!(parse_tracer("rtdiff").unwrap(), AccelConfig::default());
        let c = parse_tracer("rtdiff:median/basic/moller-trumbore").unwrap();
        assert_eq!(
            (c.builder, c.traversal, c.triangle_test),
            (Builder::Median, Traversal::Basic, TriangleTest::MollerTrumbore)
        );
        let e = parse_tracer("embree:medium:default").unwrap();
        assert_eq!(
            (e.backend, e.embree_quality, e.embree_mode),
            (Backend::Embree, EmbreeQuality::Medium, EmbreeMode::Default)
        );
        assert_eq!(parse_tracer("brute").unwrap().backend, Backend::Brute);
        for (bad, want) in [
            ("rtdiff:sah", "expected rtdiff:BUILDER/TRAVERSAL"),
            ("rtdiff:fast/sah", "unknown builder 'fast'"),
            ("embree:ultra", "unknown quality 'ultra'"),
            ("optix", "expected rtdiff"),
            ("plugin:./libx.so", "not found"),
            ("plugin:", "expected rtdiff"),
        ] {
            let e = parse_tracer(bad).unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains(want), "{bad}: {e}");
        }
    }

    #[test]
    fn ids_are_stable_and_change_with_what_the_item_does() {
        let f = PlanFile::default();
        let a = make_item(&f, ItemKind::Parity, "m/bunny.obj", Some("edges"), 5);
        assert_eq!(a, make_item(&f, ItemKind::Parity, "m/bunny.obj", Some("edges"), 5));
        assert!(a.id.starts_with("parity-edges-bunny_obj-"), "{}", a.id);
        let other = PlanFile { rays: RaysSection { count: 10, ..Default::default() }, ..Default::default() };
        assert_ne!(a.id, make_item(&other, ItemKind::Parity, "m/bunny.obj", Some("edges"), 5).id);
        assert_ne!(a.id, make_item(&f, ItemKind::Parity, "n/bunny.obj", Some("edges"), 5).id);
    }
}
