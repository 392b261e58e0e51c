//! `rtdiff trace SCENE --rays FILE --out FILE`: trace rays given as CSV and
//! write the hits as CSV (formats: [`crate::rays::file`]), so any other
//! tracer's rays can be checked.

use std::path::PathBuf;

use crate::backends::{AccelConfig, TracerArg, trace_rays};
use crate::error::Result;
use crate::rays::file::{read_rays, write_hits};

/// Arguments of `rtdiff trace`.
#[derive(clap::Args, Debug)]
pub struct TraceArgs {
    /// Scene: a scene .json file, or a mesh: .obj, .ply, .gltf, .glb, .stl, optionally .gz, in the file's own
    /// coordinates (as `rtdiff rays` and `rtdiff judge` take it; --normalize: on the unit sphere, as `rtdiff parity`).
    pub scene: PathBuf,
    /// Normalise a mesh to the unit sphere first, as `rtdiff parity` and `rtdiff bench` do.
    #[arg(long)]
    pub normalize: bool,
    /// Rays, CSV: ox,oy,oz,dx,dy,dz,tnear,tfar.
    #[arg(long)]
    pub rays: PathBuf,
    /// Where to write the hits, CSV: hit,t,prim,u,v.
    #[arg(long)]
    pub out: PathBuf,
    /// Tracer: native, brute, embree, or plugin:PATH (a shared library implementing
    /// include/rtdiff_tracer.h; its hits are written as it returns them).
    #[arg(long, default_value = "native")]
    pub tracer: TracerArg,
}

/// Run `rtdiff trace`.
pub fn run(args: &TraceArgs) -> Result<()> {
    let backend = args.tracer.backend()?;
    let (ctx, skipped) = if args.normalize {
        crate::rays::load_context_counted(&args.scene)?
    } else {
        crate::rays::load_context_file_coordinates(&args.scene)?
    };
    super::warnings::degenerate(&args.scene, &ctx.prims, skipped);
    let rays = read_rays(&args.rays)?;
    let hits = trace_rays(ctx.prims, &AccelConfig { backend, ..Default::default() }, &rays)?;
    write_hits(&args.out, &hits)?;
    eprintln!("{} rays, {} hits -> {}", rays.len(), hits.iter().flatten().count(), args.out.display());
    Ok(())
}
