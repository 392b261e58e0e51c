//! The import rules of docs/architecture.md, checked on the sources.
//!
//! Reads every `src/**/*.rs`, drops comments, string and character literals
//! and `#[cfg(test)]` items (unit tests may draw rays from `rays/` like every
//! other test), and collects each file's references to other top-level
//! modules: `crate::x`, `crate::{x, y::z}` and `super::` chains that climb to
//! the crate root. The rules:
//!
//! 1. every top-level module has a place in the map below (a new module is
//!    placed here and in docs/architecture.md);
//! 2. `accel/` (the `Tracer` interface and brute force) imports no backend;
//! 3. nothing in the pipeline depends on the harness and tools beside it
//!    (`rays`, `verify`, `perf`, `report`, `cli`, `fuzz`, `debug`), directly
//!    or through another module;
//! 4. `cli/` parses and prints: it builds no tracer, traces no ray, runs no
//!    integrator and times nothing (it calls library entry points for that);
//! 5. the graph of top-level modules has no cycle.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The renderer's pipeline: scene -> accel -> integrator -> film -> post.
const PIPELINE: &[&str] = &[
    "scene",
    "accel",
    "bvh",
    "embree",
    "plugin",
    "integrator",
    "render",
    "film",
    "post",
    "camera",
    "light",
    "material",
    "texture",
    "shading",
    "geometry",
    "pipeline",
];

/// What the pipeline builds on: errors, limits, switches, random numbers, mesh files, atomic output
/// files, the backend factory.
const FOUNDATION: &[&str] = &["error", "limits", "features", "rng", "sampler", "mesh", "output", "backends"];

/// The differential harness and the tools beside the pipeline: they read from it, never the reverse.
const BESIDE: &[&str] = &["rays", "verify", "perf", "report", "cli", "fuzz", "debug", "campaign"];

/// The tracer backends and their factory, which `accel/` must not import.
const BACKENDS: &[&str] = &["bvh", "embree", "plugin", "backends"];

/// Rendering and measuring logic that `cli/` reaches only through library entry points.
const CLI_FORBIDDEN: &[&str] = &[
    "build_tracer",
    ".intersect(",
    ".occluded(",
    "trace_as",
    "Whitted",
    "integrator::create",
    "render::render",
    "Instant::now",
    "clock::",
];

/// One source file: its path below `src/` (with `/` separators) and its text.
struct Source {
    path: String,
    text: String,
}

/// `text` without comments, string and character literals (each replaced by a space).
fn strip_comments_and_literals(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        match c[i] {
            '/' if c.get(i + 1) == Some(&'/') => {
                while i < c.len() && c[i] != '\n' {
                    i += 1;
                }
            }
            '/' if c.get(i + 1) == Some(&'*') => {
                let mut depth = 0;
                while i < c.len() {
                    if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                        depth += 1;
                        i += 2;
                    } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                        depth -= 1;
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        i += 1;
                    }
                }
                out.push(' ');
            }
            'r' if matches!(c.get(i + 1), Some('"' | '#')) && starts_word(&c, i) => {
                // Raw string r"..." or r#"..."# (or br"...").
                let mut j = i + 1;
                let mut hashes = 0;
                while c.get(j) == Some(&'#') {
                    hashes += 1;
                    j += 1;
                }
                if c.get(j) != Some(&'"') {
                    out.push(c[i]);
                    i += 1;
                    continue;
                }
                j += 1;
                loop {
                    if j >= c.len() {
                        break;
                    }
                    if c[j] == '"' && (0..hashes).all(|k| c.get(j + 1 + k) == Some(&'#')) {
                        j += 1 + hashes;
                        break;
                    }
                    j += 1;
                }
                out.push(' ');
                i = j;
            }
            '"' => {
                i += 1;
                while i < c.len() && c[i] != '"' {
                    i += if c[i] == '\\' { 2 } else { 1 };
                }
                i += 1;
                out.push(' ');
            }
            '\'' if c.get(i + 1) == Some(&'\\') => {
                // An escaped character literal: '\n', '\'', '\u{..}'.
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
                out.push(' ');
            }
            '\'' if c.get(i + 2) == Some(&'\'') => {
                i += 3;
                out.push(' ');
            }
            ch => {
                out.push(ch);
                i += 1;
            }
        }
    }
    out
}

/// True when `c[i]` starts a word (or follows the `b` of a byte-string prefix).
fn starts_word(c: &[char], i: usize) -> bool {
    let before = |k: usize| i >= k && is_ident(c[i - k]);
    !before(1) || (c[i - 1] == 'b' && !before(2))
}

fn is_ident(ch: char) -> bool {
    ch.is_alphanumeric() || ch == '_'
}

/// `text` (already without comments and literals) without `#[cfg(test)]` items.
fn strip_test_items(text: &str) -> String {
    const ATTR: &str = "#[cfg(test)]";
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while let Some(at) = text[i..].find(ATTR) {
        out.push_str(&text[i..i + at]);
        let mut j = i + at + ATTR.len();
        // The item ends at its first `;` or at the brace closing its first `{`.
        while j < b.len() && b[j] != b';' && b[j] != b'{' {
            j += 1;
        }
        if j < b.len() && b[j] == b'{' {
            let mut depth = 0;
            while j < b.len() {
                match b[j] {
                    b'{' => depth += 1,
                    b'}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    _ => {}
                }
                j += 1;
            }
        }
        i = (j + 1).min(b.len());
    }
    out.push_str(&text[i..]);
    out
}

/// The module path of a file below `src/`: `a/b/mod.rs` and `a/b.rs` are `[a, b]`.
fn module_path(path: &str) -> Vec<String> {
    let mut parts: Vec<String> = path.trim_end_matches(".rs").split('/').map(str::to_string).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The identifier starting at byte `i` of `s`, if any.
fn ident_at(s: &str, i: usize) -> Option<&str> {
    let rest = &s[i..];
    let end = rest.find(|ch: char| !is_ident(ch)).unwrap_or(rest.len());
    (end > 0).then(|| &rest[..end])
}

/// The first identifier of each item of the `{...}` group opening at byte `i` of `s`.
fn group_heads(s: &str, i: usize) -> Vec<String> {
    let mut heads = Vec::new();
    let mut depth = 0;
    let mut expect_head = true;
    for (k, ch) in s[i..].char_indices() {
        match ch {
            '{' => {
                depth += 1;
                expect_head = depth == 1;
            }
            '}' => {
                depth -= 1;
                if depth == 0 {
                    break;
                }
            }
            ',' if depth == 1 => expect_head = true,
            ch if expect_head && depth == 1 && is_ident(ch) => {
                if let Some(id) = ident_at(s, i + k) {
                    heads.push(id.to_string());
                }
                expect_head = false;
            }
            _ => {}
        }
    }
    heads
}

/// Top-level modules that `text` (of the file whose module path is `me`) refers to.
fn references(text: &str, me: &[String]) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let bytes = text.as_bytes();
    for (start, word) in [("crate::", 0usize), ("super::", 1)] {
        let mut from = 0;
        while let Some(at) = text[from..].find(start) {
            let at = from + at;
            from = at + start.len();
            if at > 0 && is_ident(bytes[at - 1] as char) {
                continue;
            }
            // Resolve `super::super::...` to a prefix of `me`; `crate::` is the root.
            let mut depth_up = word;
            let mut i = at + start.len();
            if word == 1 {
                while text[i..].starts_with("super::") {
                    depth_up += 1;
                    i += "super::".len();
                }
                if depth_up < me.len() {
                    continue; // still inside this file's top-level module
                }
            }
            if text[i..].starts_with('{') {
                found.extend(group_heads(text, i));
            } else if let Some(id) = ident_at(text, i) {
                found.insert(id.to_string());
            }
        }
    }
    found
}

/// The dependency graph of top-level modules, with the files behind each edge.
type Graph = BTreeMap<String, BTreeMap<String, BTreeSet<String>>>;

/// The top-level modules of `sources` (files and folders below `src/`, without `lib.rs` and `main.rs`).
fn top_level_modules(sources: &[Source]) -> BTreeSet<String> {
    sources.iter().map(|s| module_path(&s.path)[0].clone()).filter(|m| m != "lib" && m != "main").collect()
}

fn graph(sources: &[Source]) -> Graph {
    let modules = top_level_modules(sources);
    let mut g = Graph::new();
    for m in &modules {
        g.entry(m.clone()).or_default();
    }
    for s in sources {
        let me = module_path(&s.path);
        if !modules.contains(&me[0]) {
            continue;
        }
        let text = strip_test_items(&strip_comments_and_literals(&s.text));
        for r in references(&text, &me) {
            if r != me[0] && modules.contains(&r) {
                g.entry(me[0].clone()).or_default().entry(r).or_default().insert(s.path.clone());
            }
        }
    }
    g
}

/// A path `from -> ... -> to` in `g`, if there is one.
fn path_between(g: &Graph, from: &str, to: &str) -> Option<Vec<String>> {
    let mut prev: BTreeMap<String, String> = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([from.to_string()]);
    let mut seen = BTreeSet::from([from.to_string()]);
    while let Some(m) = queue.pop_front() {
        for next in g.get(&m).into_iter().flat_map(|e| e.keys()) {
            if next == to {
                let mut path = vec![to.to_string(), m.clone()];
                let mut cur = m.clone();
                while let Some(p) = prev.get(&cur) {
                    path.push(p.clone());
                    cur = p.clone();
                }
                path.reverse();
                return Some(path);
            }
            if seen.insert(next.clone()) {
                prev.insert(next.clone(), m.clone());
                queue.push_back(next.clone());
            }
        }
    }
    None
}

/// Every broken rule, one line each (empty when the sources keep them all).
fn violations(sources: &[Source]) -> Vec<String> {
    let g = graph(sources);
    let edge_files = |a: &str, b: &str| -> String { g[a][b].iter().cloned().collect::<Vec<_>>().join(", ") };
    let mut out = Vec::new();
    for m in g.keys() {
        if ![PIPELINE, FOUNDATION, BESIDE].iter().any(|l| l.contains(&m.as_str())) {
            out.push(format!(
                "module `{m}` has no place in the architecture (add it to docs/architecture.md and here)"
            ));
        }
    }
    if let Some(deps) = g.get("accel") {
        for b in BACKENDS.iter().filter(|b| deps.contains_key(**b)) {
            out.push(format!("accel imports the backend `{b}` ({})", edge_files("accel", b)));
        }
    }
    for p in PIPELINE.iter().filter(|p| g.contains_key(**p)) {
        for b in BESIDE {
            if let Some(path) = path_between(&g, p, b) {
                let via = path.windows(2).map(|w| format!("{} -> {} ({})", w[0], w[1], edge_files(&w[0], &w[1])));
                out.push(format!("pipeline module `{p}` depends on `{b}`: {}", via.collect::<Vec<_>>().join("; ")));
            }
        }
    }
    for s in sources.iter().filter(|s| s.path.starts_with("cli/")) {
        let text = strip_test_items(&strip_comments_and_literals(&s.text));
        for f in CLI_FORBIDDEN.iter().filter(|f| text.contains(**f)) {
            out.push(format!("cli/ holds rendering or measuring logic: `{f}` in {}", s.path));
        }
    }
    for m in g.keys() {
        for next in g[m].keys() {
            if let Some(back) = path_between(&g, next, m) {
                let cycle: Vec<String> = std::iter::once(m.clone()).chain(back).collect();
                let line = format!("import cycle: {}", cycle.join(" -> "));
                if !out.contains(&line) && !out.iter().any(|l| l.starts_with("import cycle") && same_cycle(l, &cycle)) {
                    out.push(line);
                }
            }
        }
    }
    out
}

/// True when the reported cycle `line` visits the same modules as `cycle`.
fn same_cycle(line: &str, cycle: &[String]) -> bool {
    let a: BTreeSet<&str> = line.trim_start_matches("import cycle: ").split(" -> ").collect();
    let b: BTreeSet<&str> = cycle.iter().map(String::as_str).collect();
    a == b
}

/// Every `.rs` file below `dir`, with paths relative to `root`.
fn read_sources(root: &Path, dir: &Path, out: &mut Vec<Source>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            read_sources(root, &p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            let rel = p.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
            out.push(Source { path: rel, text: std::fs::read_to_string(&p).unwrap() });
        }
    }
}

#[test]
fn the_sources_keep_the_import_rules() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut sources = Vec::new();
    read_sources(&src, &src, &mut sources);
    assert!(sources.len() > 100, "only {} source files found", sources.len());
    let g = graph(&sources);
    // The checker sees the real structure: the pipeline's known edges are there.
    for (a, b) in
        [("scene", "mesh"), ("integrator", "scene"), ("backends", "bvh"), ("cli", "pipeline"), ("bvh", "accel")]
    {
        assert!(g[a].contains_key(b), "the checker missed {a} -> {b}");
    }
    let v = violations(&sources);
    assert!(v.is_empty(), "docs/architecture.md's import rules are broken:\n{}", v.join("\n"));
}

/// The checker itself, on small synthetic crates: each rule fails on a deliberately bad import.
mod checker {
    use super::*;

    fn sources(files: &[(&str, &str)]) -> Vec<Source> {
        files.iter().map(|(p, t)| Source { path: p.to_string(), text: t.to_string() }).collect()
    }

    /// A small crate that keeps every rule.
    fn good() -> Vec<(&'static str, &'static str)> {
        vec![
            ("lib.rs", "pub mod accel; pub mod bvh; pub mod scene; pub mod rays; pub mod cli;"),
            ("accel/mod.rs", "use crate::geometry::Ray; pub trait Tracer {}"),
            ("geometry/mod.rs", "pub struct Ray;"),
            ("bvh/mod.rs", "use crate::accel::Tracer;\n#[cfg(test)]\nmod tests { use crate::rays::Rng; }"),
            ("backends.rs", "use crate::{accel::Tracer, bvh};"),
            ("scene/mod.rs", "// crate::rays is only named in a comment\nconst S: &str = \"crate::rays\";"),
            ("scene/export/mitsuba.rs", "use super::super::Scene; use super::super::super::geometry::Ray;"),
            ("rays/mod.rs", "use crate::scene::Scene; use crate::accel::Tracer;"),
            ("cli/render.rs", "fn run() { crate::pipeline::render_scene(); println!(\"build_tracer\"); }"),
            ("pipeline.rs", "use crate::backends::build_tracer; use crate::scene::Scene;"),
        ]
    }

    fn with(extra: &[(&'static str, &'static str)]) -> Vec<String> {
        let mut files = good();
        for (p, t) in extra {
            files.retain(|(q, _)| q != p);
            files.push((*p, *t));
        }
        violations(&sources(&files))
    }

    #[test]
    fn a_crate_that_keeps_the_rules_passes() {
        assert_eq!(violations(&sources(&good())), Vec::<String>::new());
        let g = graph(&sources(&good()));
        assert!(g["scene"].contains_key("geometry"), "super::super::super:: climbs to the root");
        assert!(!g["bvh"].contains_key("rays"), "cfg(test) items are left out");
        assert!(!g["scene"].contains_key("rays"), "comments and strings are left out");
        assert_eq!(g["backends"].keys().collect::<Vec<_>>(), ["accel", "bvh"], "crate::{{..}} groups are read");
    }

    #[test]
    fn accel_importing_a_backend_fails() {
        let v = with(&[("accel/brute.rs", "use crate::bvh::BvhTracer;")]);
        assert!(v.iter().any(|l| l.starts_with("accel imports the backend `bvh` (accel/brute.rs)")), "{v:?}");
        let v = with(&[("accel/mod.rs", "fn f() -> Box<dyn Tracer> { crate::backends::build_tracer() }")]);
        assert!(v.iter().any(|l| l.starts_with("accel imports the backend `backends`")), "{v:?}");
    }

    #[test]
    fn the_pipeline_importing_the_harness_fails() {
        let v = with(&[("scene/validate.rs", "use crate::rays::Rng;")]);
        assert!(v.iter().any(|l| l.starts_with("pipeline module `scene` depends on `rays`")), "{v:?}");
        // Through a module in between: geometry -> backends -> rays.
        let v = with(&[("geometry/mod.rs", "use crate::backends::X;"), ("backends.rs", "use crate::rays::Rng;")]);
        assert!(
            v.iter().any(|l| l.starts_with("pipeline module `geometry` depends on `rays`: geometry -> backends")),
            "{v:?}"
        );
        let v = with(&[("film/mod.rs", "fn w() { crate::verify::image::write_exr(); }"), ("verify/mod.rs", "")]);
        assert!(v.iter().any(|l| l.contains("`film` depends on `verify`")), "{v:?}");
    }

    #[test]
    fn logic_in_the_cli_fails() {
        let v = with(&[("cli/trace.rs", "fn run() { let t = build_tracer(p, &c); t.intersect(&r); }")]);
        assert!(v.contains(&"cli/ holds rendering or measuring logic: `build_tracer` in cli/trace.rs".to_string()));
        assert!(v.contains(&"cli/ holds rendering or measuring logic: `.intersect(` in cli/trace.rs".to_string()));
        let v = with(&[("cli/debug.rs", "use crate::integrator::Whitted;")]);
        assert!(v.iter().any(|l| l.contains("`Whitted` in cli/debug.rs")), "{v:?}");
    }

    #[test]
    fn an_import_cycle_fails() {
        let v = with(&[("geometry/mod.rs", "use crate::scene::Scene;"), ("scene/mod.rs", "use crate::geometry::Ray;")]);
        let cycles: Vec<_> = v.iter().filter(|l| l.starts_with("import cycle")).collect();
        assert_eq!(cycles.len(), 1, "{v:?}");
        assert!(same_cycle(cycles[0], &["geometry".into(), "scene".into()]), "{v:?}");
    }

    #[test]
    fn an_unplaced_module_fails() {
        let v = with(&[("gpu/mod.rs", "use crate::accel::Tracer;")]);
        assert!(v.iter().any(|l| l.starts_with("module `gpu` has no place")), "{v:?}");
    }

    #[test]
    fn literals_and_comments_are_stripped() {
        let s = strip_comments_and_literals(
            "a /* crate::x /* nested */ */ b 'c' '\\n' r#\"crate::y\"# \"q\\\"crate::z\" 'l: x // crate::w\nend",
        );
        assert!(!s.contains("crate::"), "{s}");
        assert!(s.contains("'l: x") && s.contains("end") && s.contains('b'), "{s}");
    }
}
