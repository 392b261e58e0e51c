//! `rtdiff trace SCENE --rays FILE --out FILE`: trace rays given as CSV and
//! write the hits as CSV, so any other tracer's rays can be checked.
//!
//! Input: one ray per line, `ox,oy,oz,dx,dy,dz,tnear,tfar` (`inf` allowed for
//! `tfar`); blank lines, lines starting with `#` and a header line starting
//! with `ox` are skipped. Output: a header `hit,t,prim,u,v`, then per ray
//! `1,t,prim,u,v` or `0,,,,` for a miss. Floats are written in Rust's
//! shortest round-trip form, so they read back exactly.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;

use crate::accel::{AccelConfig, Backend, build_tracer};
use crate::error::{Error, Result};
use crate::geometry::Ray;

/// Arguments of `rtdiff trace`.
#[derive(clap::Args, Debug)]
pub struct TraceArgs {
    /// Scene: a scene .json file, or a Wavefront .obj mesh (normalised to the unit sphere, like `rtdiff parity`).
    pub scene: PathBuf,
    /// Rays, CSV: ox,oy,oz,dx,dy,dz,tnear,tfar.
    #[arg(long)]
    pub rays: PathBuf,
    /// Where to write the hits, CSV: hit,t,prim,u,v.
    #[arg(long)]
    pub out: PathBuf,
    /// Tracer backend.
    #[arg(long, value_enum, default_value = "native")]
    pub tracer: Backend,
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
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != 8 {
            return Err(at(format!(
                "expected 8 comma-separated values (ox,oy,oz,dx,dy,dz,tnear,tfar), found {}",
                fields.len()
            )));
        }
        let mut v = [0f32; 8];
        for (k, f) in fields.iter().enumerate() {
            v[k] = f.parse::<f32>().map_err(|_| at(format!("value {} ({f:?}) is not a number", k + 1)))?;
        }
        let (o, d) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
        if !o.is_finite() || !d.is_finite() {
            return Err(at("origin and direction must be finite".into()));
        }
        if d == Vec3::ZERO {
            return Err(at("direction is zero".into()));
        }
        if v[6].is_nan() || v[7].is_nan() || v[6] < 0.0 || v[6] > v[7] {
            return Err(at(format!("need 0 <= tnear <= tfar, got tnear {} tfar {}", v[6], v[7])));
        }
        rays.push(Ray::with_range(o, d, v[6], v[7]));
    }
    Ok(rays)
}

/// Run `rtdiff trace`.
pub fn run(args: &TraceArgs) -> Result<()> {
    let ctx = crate::rays::load_context(&args.scene)?;
    let text = std::fs::read_to_string(&args.rays).map_err(|e| Error::io(&args.rays, &e))?;
    let rays = parse_rays(&args.rays, &text)?;
    let cfg = AccelConfig { backend: args.tracer, ..Default::default() };
    let tracer = build_tracer(Arc::clone(&ctx.prims), &cfg)?;
    let hits: Vec<_> = {
        use rayon::prelude::*;
        rays.par_iter().map(|r| tracer.intersect(r)).collect()
    };
    let mut out = String::with_capacity(32 * hits.len() + 16);
    out.push_str("hit,t,prim,u,v\n");
    for h in &hits {
        match h {
            Some(h) => out.push_str(&format!("1,{},{},{},{}\n", h.t, h.prim, h.u, h.v)),
            None => out.push_str("0,,,,\n"),
        }
    }
    let mut f = std::fs::File::create(&args.out).map_err(|e| Error::file(&args.out, format!("cannot create: {e}")))?;
    f.write_all(out.as_bytes()).map_err(|e| Error::file(&args.out, format!("cannot write: {e}")))?;
    eprintln!("{} rays, {} hits -> {}", rays.len(), hits.iter().flatten().count(), args.out.display());
    Ok(())
}
