//! Ray and hit files, so any other tracer's rays can be checked (`rtdiff trace`,
//! `rtdiff rays`, `rtdiff judge`).
//!
//! Rays: one per line, `ox,oy,oz,dx,dy,dz,tnear,tfar` (`inf` allowed for
//! `tfar`); blank lines, lines starting with `#` and a header line starting
//! with `ox` are skipped. Hits: a header `hit,t,prim,u,v`, then per ray
//! `1,t,prim,u,v` or `0,,,,` for a miss. Floats are written in Rust's shortest
//! round-trip form, so they read back exactly. Tags (`rtdiff rays` writes them
//! beside the rays, `NAME.tags.csv`): a header `set,tag,value,fx,fy,fz`, then per
//! ray its set and what the generator knows of it ([`RayTag`]): `plain`,
//! `crossing,T` (crosses a shared edge or closed vertex at `T`), `tangent`,
//! `degenerate`, `spawned,PRIM,FX,FY,FZ` and `shadow,PRIM,FX,FY,FZ` (leaves primitive
//! `PRIM` from the point `F`).

use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::geometry::{Hit, Ray};
use crate::limits;
use crate::rays::RayTag;

/// Read a ray file (at most [`limits::MAX_RAY_FILE_BYTES`]); errors name `path` and the line.
pub fn read_rays(path: &Path) -> Result<Vec<Ray>> {
    let size = std::fs::metadata(path).map_err(|e| Error::io(path, &e))?.len();
    if size > limits::MAX_RAY_FILE_BYTES {
        return Err(Error::file(
            path,
            format!("ray file is {size} bytes, over the limit of {} bytes", limits::MAX_RAY_FILE_BYTES),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, &e))?;
    parse_rays(path, &text)
}

/// Parse ray CSV text; errors name `path` and the line.
pub fn parse_rays(path: &Path, text: &str) -> Result<Vec<Ray>> {
    let mut rays = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || (rays.is_empty() && line.starts_with("ox")) {
            continue;
        }
        let at = |msg: String| Error::file(path, format!("line {}: {msg}", i + 1));
        if rays.len() >= limits::MAX_RAYS {
            return Err(at(format!("more than {} rays, the limit of one file", limits::MAX_RAYS)));
        }
        rays.push(parse_ray(line).map_err(at)?);
    }
    Ok(rays)
}

/// One ray line.
fn parse_ray(line: &str) -> std::result::Result<Ray, String> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() != 8 {
        return Err(format!(
            "expected 8 comma-separated values (ox,oy,oz,dx,dy,dz,tnear,tfar), found {}",
            fields.len()
        ));
    }
    let mut v = [0f32; 8];
    for (k, f) in fields.iter().enumerate() {
        v[k] = f.parse::<f32>().map_err(|_| format!("value {} ({f:?}) is not a number", k + 1))?;
    }
    let (o, d) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
    let m = limits::MAX_COORDINATE;
    if !o.is_finite() || !d.is_finite() {
        return Err("origin and direction must be finite".into());
    }
    if o.abs().max_element() > m || d.abs().max_element() > m {
        return Err(format!("origin and direction components must be at most {m:e} in absolute value"));
    }
    if d == Vec3::ZERO {
        return Err("direction is zero".into());
    }
    if v[6].is_nan() || v[7].is_nan() || v[6] < 0.0 || v[6] > v[7] {
        return Err(format!("need 0 <= tnear <= tfar, got tnear {} tfar {}", v[6], v[7]));
    }
    Ok(Ray::with_range(o, d, v[6], v[7]))
}

/// Write `hits` (one per ray, in order) as a hit file at `path`.
pub fn write_hits(path: &Path, hits: &[Option<Hit>]) -> Result<()> {
    let mut out = String::with_capacity(32 * hits.len() + 16);
    out.push_str("hit,t,prim,u,v\n");
    for h in hits {
        match h {
            Some(h) => {
                let _ = writeln!(out, "1,{},{},{},{}", h.t, h.prim, h.u, h.v);
            }
            None => out.push_str("0,,,,\n"),
        }
    }
    crate::output::write(path, out)
}

/// One set of rays to write: its name, rays and tags.
pub struct SetRays<'a> {
    /// Set name.
    pub name: &'a str,
    /// Rays.
    pub rays: &'a [Ray],
    /// One tag per ray.
    pub tags: &'a [RayTag],
}

/// The tags file beside a ray file: `rays.csv` -> `rays.tags.csv`.
pub fn tags_path(rays: &Path) -> std::path::PathBuf {
    let stem = rays.file_stem().and_then(|s| s.to_str()).unwrap_or("rays");
    rays.with_file_name(format!("{stem}.tags.csv"))
}

/// Write `sets` as one ray file at `path` (a `#` line before each set naming it, `header`
/// as `#` lines on top) and their tags at [`tags_path`].
pub fn write_rays(path: &Path, header: &str, sets: &[SetRays]) -> Result<()> {
    let n: usize = sets.iter().map(|s| s.rays.len()).sum();
    let mut out = String::with_capacity(80 * n + 256);
    let mut tags = String::with_capacity(24 * n + 32);
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    out.push_str("ox,oy,oz,dx,dy,dz,tnear,tfar\n");
    tags.push_str("set,tag,value,fx,fy,fz\n");
    let mut first = 0;
    for s in sets {
        let _ = writeln!(out, "# set {}: rays {}..{}", s.name, first, first + s.rays.len());
        first += s.rays.len();
        for (r, t) in s.rays.iter().zip(s.tags) {
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{},{}",
                r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.t_min, r.t_max
            );
            let _ = match *t {
                RayTag::Plain => writeln!(tags, "{},plain,,,,", s.name),
                RayTag::Crossing { t } => writeln!(tags, "{},crossing,{t},,,", s.name),
                RayTag::Tangent => writeln!(tags, "{},tangent,,,,", s.name),
                RayTag::Degenerate => writeln!(tags, "{},degenerate,,,,", s.name),
                RayTag::Spawned { prim, from } => {
                    writeln!(tags, "{},spawned,{prim},{},{},{}", s.name, from.x, from.y, from.z)
                }
                RayTag::Shadow { prim, from } => {
                    writeln!(tags, "{},shadow,{prim},{},{},{}", s.name, from.x, from.y, from.z)
                }
            };
        }
    }
    std::fs::write(path, out).map_err(|e| Error::file(path, format!("cannot write: {e}")))?;
    let tp = tags_path(path);
    std::fs::write(&tp, tags).map_err(|e| Error::file(&tp, format!("cannot write: {e}")))
}

/// Read a tags file (see the module docs): per ray its set name and tag; errors name the line.
pub fn read_tags(path: &Path) -> Result<Vec<(String, RayTag)>> {
    let text = read_limited(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || (i == 0 && line.starts_with("set,")) {
            continue;
        }
        let at = |msg: String| Error::file(path, format!("line {}: {msg}", i + 1));
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 6 {
            return Err(at(format!("expected 6 comma-separated values (set,tag,value,fx,fy,fz), found {}", f.len())));
        }
        let num =
            |k: usize| f[k].parse::<f32>().map_err(|_| at(format!("value {} ({:?}) is not a number", k + 1, f[k])));
        let prim = || f[2].parse::<u32>().map_err(|_| at(format!("primitive {:?} is not an id", f[2])));
        let from = || -> Result<Vec3> { Ok(Vec3::new(num(3)?, num(4)?, num(5)?)) };
        let tag = match f[1] {
            "plain" => RayTag::Plain,
            "crossing" => RayTag::Crossing { t: num(2)? },
            "tangent" => RayTag::Tangent,
            "degenerate" => RayTag::Degenerate,
            "spawned" => RayTag::Spawned { prim: prim()?, from: from()? },
            "shadow" => RayTag::Shadow { prim: prim()?, from: from()? },
            other => return Err(at(format!("unknown tag {other:?}"))),
        };
        out.push((f[0].to_string(), tag));
    }
    Ok(out)
}

/// Read a hit file (`hit,t,prim,u,v`; see the module docs): one answer per line. Values a
/// tracer may get wrong (`nan`, `inf`, distances outside the interval, ids of primitives that
/// do not exist) are read as given, for the judge to name; a line that is not a hit is an
/// error naming the line.
pub fn read_hits(path: &Path) -> Result<Vec<Option<Hit>>> {
    let text = read_limited(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || (out.is_empty() && line.starts_with("hit")) {
            continue;
        }
        let at = |msg: String| Error::file(path, format!("line {}: {msg}", i + 1));
        if out.len() >= limits::MAX_RAYS {
            return Err(at(format!("more than {} hits, the limit of one file", limits::MAX_RAYS)));
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 5 {
            return Err(at(format!("expected 5 comma-separated values (hit,t,prim,u,v), found {}", f.len())));
        }
        let num =
            |k: usize| f[k].parse::<f32>().map_err(|_| at(format!("value {} ({:?}) is not a number", k + 1, f[k])));
        match f[0] {
            "0" => out.push(None),
            "1" => {
                let prim =
                    f[2].parse::<u32>().map_err(|_| at(format!("primitive {:?} is not an id (0 to 2^32-2)", f[2])))?;
                out.push(Some(Hit { t: num(1)?, prim, u: num(3)?, v: num(4)? }));
            }
            other => return Err(at(format!("the first value must be 1 (a hit) or 0 (a miss), found {other:?}"))),
        }
    }
    Ok(out)
}

/// A text file of at most [`limits::MAX_RAY_FILE_BYTES`].
fn read_limited(path: &Path) -> Result<String> {
    let size = std::fs::metadata(path).map_err(|e| Error::io(path, &e))?.len();
    if size > limits::MAX_RAY_FILE_BYTES {
        return Err(Error::file(path, format!("{size} bytes, over the limit of {} bytes", limits::MAX_RAY_FILE_BYTES)));
    }
    std::fs::read_to_string(path).map_err(|e| Error::io(path, &e))
}
