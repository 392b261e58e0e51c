//! Ray and hit files, so any other tracer's rays can be checked (`rtdiff trace`).
//!
//! Rays: one per line, `ox,oy,oz,dx,dy,dz,tnear,tfar` (`inf` allowed for
//! `tfar`); blank lines, lines starting with `#` and a header line starting
//! with `ox` are skipped. Hits: a header `hit,t,prim,u,v`, then per ray
//! `1,t,prim,u,v` or `0,,,,` for a miss. Floats are written in Rust's shortest
//! round-trip form, so they read back exactly.

use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::geometry::{Hit, Ray};
use crate::limits;

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
