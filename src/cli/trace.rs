//! `rtdiff trace SCENE --rays FILE --out FILE`: trace rays given as CSV and
//! write the hits as CSV (formats: [`crate::rays::file`]), so any other
//! tracer's rays can be checked.

use std::path::PathBuf;

use crate::backends::{AccelConfig, Backend, trace_rays};
use crate::error::Result;
use crate::rays::file::{read_rays, write_hits};

/// Arguments of `rtdiff trace`.
#[derive(clap::Args, Debug)]
pub struct TraceArgs {
    /// Scene: a scene .json file, or a mesh: .obj, .ply, .gltf, .glb, .stl, optionally .gz (normalised to the unit sphere, like `rtdiff parity`).
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

/// Run `rtdiff trace`.
pub fn run(args: &TraceArgs) -> Result<()> {
    let (ctx, skipped) = crate::rays::load_context_counted(&args.scene)?;
    super::warnings::degenerate(&args.scene, &ctx.prims, skipped);
    let rays = read_rays(&args.rays)?;
    let hits = trace_rays(ctx.prims, &AccelConfig { backend: args.tracer, ..Default::default() }, &rays)?;
    write_hits(&args.out, &hits)?;
    eprintln!("{} rays, {} hits -> {}", rays.len(), hits.iter().flatten().count(), args.out.display());
    Ok(())
}
