//! Wavefront MTL material libraries. tobj parses them; a first pass over the lines
//! checks every statement tobj would trust (colour triples, finite numbers, non-empty
//! names and texture paths) and turns each bad one into a warning naming the file and
//! line, so a broken library never costs the geometry and never panics inside tobj.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::{MtlMaterial, TextureSource, encoding};

/// Statements of the MTL format that rtdiff knows and ignores (no warning).
const IGNORED: &[&str] = &[
    "Ka",
    "Ke",
    "Ni",
    "Tf",
    "illum",
    "sharpness",
    "map_Ka",
    "map_Ks",
    "map_Ke",
    "map_Ns",
    "map_d",
    "map_bump",
    "map_Bump",
    "bump",
    "disp",
    "decal",
    "refl",
    "Pr",
    "Pm",
    "Ps",
    "Pc",
    "Pcr",
    "aniso",
    "anisor",
    "norm",
    "map_Pr",
    "map_Pm",
    "map_Ps",
    "map_Pc",
    "map_aat",
    "map_refl",
];

/// A parsed material library.
pub(crate) struct Library {
    /// Materials in file order.
    pub materials: Vec<tobj::Material>,
    /// Material name to index, as tobj's `usemtl` lookup wants it.
    pub names: HashMap<String, usize>,
    /// For each material with a `map_Kd`, where that statement is.
    pub map_kd: HashMap<String, (usize, String)>,
}

/// Read the library at `path`. `Err` carries a warning (the file cannot be read at all);
/// problems inside the file are pushed to `warnings` and the statement is ignored.
pub(crate) fn load(path: &Path, warnings: &mut Vec<String>) -> Result<Library, String> {
    let bytes = std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => format!("{}: material library not found", path.display()),
        _ => format!("{}: cannot read material library: {e}", path.display()),
    })?;
    let (text, _) = encoding::decode_text(bytes);
    Ok(parse(path, &text, warnings))
}

/// Parse MTL `text` (already decoded); `path` names the file in warnings.
pub(crate) fn parse(path: &Path, text: &str, warnings: &mut Vec<String>) -> Library {
    let mut clean = String::with_capacity(text.len() + 64);
    let mut map_kd = HashMap::new();
    let mut current = String::new();
    let mut unknown_seen: Vec<String> = Vec::new();
    for (i, line) in text.split('\n').enumerate() {
        let n = i + 1;
        let mut warn = |msg: String| warnings.push(format!("{}:{n}: {msg}", path.display()));
        match check_line(line) {
            Ok(Checked::Keep) => clean.push_str(line),
            Ok(Checked::Replace(s)) => clean.push_str(&s),
            Ok(Checked::NewMaterial(name)) => {
                current = name;
                clean.push_str(line);
            }
            Ok(Checked::Texture(written)) => {
                map_kd.insert(current.clone(), (n, written));
                clean.push_str(line);
            }
            Ok(Checked::Unknown(word)) => {
                if !unknown_seen.contains(&word) {
                    warn(format!("unknown statement '{word}' ignored (reported once per file)"));
                    unknown_seen.push(word);
                }
            }
            Err(Problem::EmptyName) => {
                warn("'newmtl' without a name: the statements that follow belong to no material and are ignored; faces that name it use the default material".into());
                current = format!("\u{1}unnamed material at line {n}");
                clean.push_str("newmtl ");
                clean.push_str(&current);
            }
            Err(Problem::Ignored(msg)) => warn(format!("{msg}: statement ignored")),
        }
        clean.push('\n');
    }
    match tobj::load_mtl_buf(&mut clean.as_bytes()) {
        Ok((materials, names)) => Library { materials, names: names.into_iter().collect(), map_kd },
        Err(e) => {
            // Every statement tobj rejects is checked above; reaching this is a gap in check_line.
            warnings
                .push(format!("{}: cannot read material library ({e}): the default material is used", path.display()));
            Library { materials: Vec::new(), names: HashMap::new(), map_kd: HashMap::new() }
        }
    }
}

enum Checked {
    Keep,
    Replace(String),
    NewMaterial(String),
    Texture(String),
    Unknown(String),
}

enum Problem {
    EmptyName,
    Ignored(String),
}

/// The words of a statement up to a `#` comment.
fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().take_while(|w| !w.starts_with('#')).collect()
}

fn number(word: &str, what: &str) -> Result<f32, Problem> {
    match word.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(Problem::Ignored(format!("{what}: '{word}' is not a finite number"))),
        Err(_) => Err(Problem::Ignored(format!("{what}: '{word}' is not a number"))),
    }
}

fn check_line(line: &str) -> Result<Checked, Problem> {
    let w = words(line);
    let Some(&head) = w.first() else { return Ok(Checked::Keep) };
    let rest = || line.trim_start()[head.len()..].trim();
    match head {
        "newmtl" => {
            let name = rest();
            if name.is_empty() { Err(Problem::EmptyName) } else { Ok(Checked::NewMaterial(name.to_owned())) }
        }
        "Ka" | "Kd" | "Ks" | "Ke" => {
            let args = &w[1..];
            if let Some(kind) = args.first().filter(|a| matches!(**a, "spectral" | "xyz")) {
                return Err(Problem::Ignored(format!("'{head} {kind}' colours are not supported")));
            }
            let v = args.iter().map(|a| number(a, head)).collect::<Result<Vec<_>, _>>()?;
            match v.as_slice() {
                // The MTL specification: "g and b are optional; if only r is specified, g and b equal r".
                [r] => Ok(Checked::Replace(format!("{head} {r} {r} {r}"))),
                [r, g, b] => Ok(Checked::Replace(format!("{head} {r} {g} {b}"))),
                _ => Err(Problem::Ignored(format!("'{head}' needs 1 or 3 numbers, found {}", v.len()))),
            }
        }
        "Ns" | "Ni" | "d" | "Tr" | "sharpness" => {
            let v = w[1..].iter().filter(|a| **a != "-halo").map(|a| number(a, head)).collect::<Result<Vec<_>, _>>()?;
            match v.as_slice() {
                [x] if matches!(head, "d" | "Tr") && !(0.0..=1.0).contains(x) => {
                    Err(Problem::Ignored(format!("'{head}' must be in [0, 1], found {x}")))
                }
                [x] => Ok(Checked::Replace(format!("{head} {x}"))),
                _ => Err(Problem::Ignored(format!("'{head}' needs one number, found {}", v.len()))),
            }
        }
        "illum" => match w.get(1).map(|a| a.parse::<u8>()) {
            Some(Ok(_)) if w.len() == 2 => Ok(Checked::Keep),
            _ => Err(Problem::Ignored("'illum' needs one integer from 0 to 10".into())),
        },
        "map_Kd" => {
            let written = rest();
            if written.is_empty() {
                return Err(Problem::Ignored("'map_Kd' without a file name".into()));
            }
            Ok(Checked::Texture(written.to_owned()))
        }
        h if h.starts_with("map_") || matches!(h, "bump" | "disp" | "decal" | "refl" | "norm") => {
            if rest().is_empty() {
                return Err(Problem::Ignored(format!("'{h}' without a file name")));
            }
            if IGNORED.contains(&h) { Ok(Checked::Keep) } else { Ok(Checked::Unknown(h.to_owned())) }
        }
        h if IGNORED.contains(&h) => Ok(Checked::Keep),
        h => Ok(Checked::Unknown(h.to_owned())),
    }
}

/// The file name in a texture statement's arguments: options (`-s 1 1 1`, `-clamp on`, ...)
/// skipped, surrounding quotes removed, Windows separators turned into `/`.
pub fn texture_file_name(written: &str) -> String {
    let mut rest = written.trim();
    while let Some(opt) = rest.split_whitespace().next().filter(|o| o.starts_with('-') && o.len() > 1) {
        // Option arity from the MTL specification; -o, -s and -t take 1 to 3 numbers.
        let (min, max) = match opt {
            "-mm" => (2, 2),
            "-o" | "-s" | "-t" => (1, 3),
            "-blendu" | "-blendv" | "-bm" | "-boost" | "-cc" | "-clamp" | "-imfchan" | "-texres" | "-type" => (1, 1),
            _ => break,
        };
        let mut after = rest[opt.len()..].trim_start();
        for k in 0..max {
            let Some(arg) = after.split_whitespace().next() else { break };
            if k >= min && arg.parse::<f32>().is_err() {
                break;
            }
            after = after[arg.len()..].trim_start();
        }
        rest = after;
    }
    let unquoted = rest.trim().trim_matches('"').trim_matches('\'');
    unquoted.replace('\\', "/")
}

/// Resolve a texture named in `mtl` (written as `written`) relative to the MTL's folder.
/// When the path as written does not exist, the bare file name beside the MTL is tried.
/// Returns the path to load (the first one tried when neither exists) and the paths tried.
pub fn resolve_texture(mtl: &Path, written: &str) -> (PathBuf, Vec<PathBuf>) {
    let dir = mtl.parent().unwrap_or(Path::new("."));
    let name = texture_file_name(written);
    let first = dir.join(&name);
    let mut tried = vec![first.clone()];
    if first.is_file() {
        return (first, tried);
    }
    if let Some(base) = Path::new(&name).file_name() {
        let beside = dir.join(base);
        if beside != first {
            tried.push(beside.clone());
            if beside.is_file() {
                return (beside, tried);
            }
        }
    }
    (first, tried)
}

/// Convert a tobj material; `source` is where its `map_Kd` was written.
pub(crate) fn convert(m: tobj::Material, mtl: &Path, source: Option<&(usize, String)>) -> MtlMaterial {
    let opacity =
        m.dissolve.or_else(|| m.unknown_param.get("Tr").and_then(|t| t.trim().parse::<f32>().ok()).map(|tr| 1.0 - tr));
    let (map_kd, map_kd_source) = match (&m.diffuse_texture, source) {
        (Some(_), Some((line, written))) => {
            let (path, tried) = resolve_texture(mtl, written);
            (Some(path), Some(TextureSource { mtl: mtl.to_path_buf(), line: *line, written: written.clone(), tried }))
        }
        _ => (None, None),
    };
    MtlMaterial {
        name: m.name,
        kd: m.diffuse.map(Vec3::from),
        ks: m.specular.map(Vec3::from),
        ns: m.shininess,
        opacity,
        map_kd_wrap: if source.is_some_and(|(_, written)| texture_clamp(written)) {
            crate::texture::WrapMode::Clamp
        } else {
            crate::texture::WrapMode::Repeat
        },
        map_kd,
        map_kd_source,
        ..Default::default()
    }
}

/// True when a texture statement's options hold `-clamp on` (the MTL specification's default is
/// off: the texture repeats).
pub fn texture_clamp(written: &str) -> bool {
    let w: Vec<&str> = written.split_whitespace().collect();
    // Options come before the file name; the last `-clamp` wins.
    let name_at = w.len().saturating_sub(1);
    w[..name_at].windows(2).rfind(|p| p[0] == "-clamp").is_some_and(|p| p[1] == "on")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(text: &str) -> (Library, Vec<String>) {
        let mut w = Vec::new();
        let lib = parse(Path::new("m.mtl"), text, &mut w);
        (lib, w)
    }

    #[test]
    fn map_kd_clamp_option() {
        assert!(texture_clamp("-clamp on tex.png"));
        assert!(texture_clamp("-s 2 2 1 -clamp on \"my tex.png\""));
        assert!(!texture_clamp("-clamp off tex.png"));
        assert!(!texture_clamp("tex.png"));
        assert!(!texture_clamp("-clamp on -clamp off tex.png"));
        // A file named like the option is a file name, not an option.
        assert!(!texture_clamp("-clamp"));
        let (lib, _) = parse_str("newmtl a\nmap_Kd -clamp on t.png\n");
        let m = convert(lib.materials[0].clone(), Path::new("m.mtl"), lib.map_kd.get("a"));
        assert_eq!(m.map_kd_wrap, crate::texture::WrapMode::Clamp);
        assert!(m.map_kd.unwrap().ends_with("t.png"));
    }

    #[test]
    fn one_number_colour_is_grey_and_two_is_a_warning() {
        let (lib, w) = parse_str("newmtl a\nKd 0.5\nKs 0.1 0.2\n");
        assert_eq!(lib.materials[0].diffuse, Some([0.5; 3]));
        assert_eq!(lib.materials[0].specular, None);
        assert_eq!(w.len(), 1);
        assert!(w[0].starts_with("m.mtl:3:") && w[0].contains("1 or 3 numbers"), "{w:?}");
    }

    #[test]
    fn non_finite_values_are_warnings_naming_the_line() {
        let (lib, w) = parse_str("newmtl a\nKd nan 1 1\nNs inf\nd 1e39\nKs 1 1 1\n");
        assert_eq!(lib.materials[0].diffuse, None);
        assert_eq!(lib.materials[0].shininess, None);
        assert_eq!(lib.materials[0].dissolve, None);
        assert_eq!(lib.materials[0].specular, Some([1.0; 3]));
        assert!(w[0].starts_with("m.mtl:2:") && w[0].contains("'nan' is not a finite number"), "{w:?}");
        assert!(w[1].starts_with("m.mtl:3:") && w[2].starts_with("m.mtl:4:"), "{w:?}");
    }

    #[test]
    fn empty_name_and_unknown_statements_warn() {
        let (lib, w) = parse_str("newmtl good\nKd 1 0 0\nnewmtl\nKd 0 1 0\nfoo 1\nfoo 2\n");
        assert_eq!(lib.materials[0].name, "good");
        assert_eq!(lib.materials[0].diffuse, Some([1.0, 0.0, 0.0]));
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0].starts_with("m.mtl:3:") && w[1].starts_with("m.mtl:5:") && w[1].contains("'foo'"), "{w:?}");
    }

    #[test]
    fn texture_names_windows_quotes_and_options() {
        assert_eq!(texture_file_name(r".\SpiderTex.jpg"), "./SpiderTex.jpg");
        assert_eq!(texture_file_name("\"my tex.png\""), "my tex.png");
        assert_eq!(texture_file_name("-s 1 1 1 -clamp on tex\\a.png"), "tex/a.png");
        assert_eq!(texture_file_name("-o 0.5 tex.png"), "tex.png");
    }
}
