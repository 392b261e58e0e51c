//! `rtdiff rays SCENE --set NAME|all -o rays.csv`: rtdiff's ray sets (the adversarial ones
//! too) as a ray file for a tracer rtdiff cannot link, with their tags beside it
//! (`rays.tags.csv`) for `rtdiff judge`.

use std::path::PathBuf;

use crate::error::Result;
use crate::rays::SetKind;
use crate::rays::file::{SetRays, tags_path, write_rays};
use crate::verify::hits::Reference;
use crate::verify::hits::judge::generate_for_file;

/// Arguments of `rtdiff rays`.
#[derive(clap::Args, Debug)]
pub struct RaysArgs {
    /// Scene: a scene .json file, or a mesh (.obj, .ply, optionally .gz) in the file's own coordinates.
    pub scene: PathBuf,
    /// Ray set: all (every set but scaled), primary, incoherent, shadow, edges, vertices, grazing, axis, surface.
    #[arg(long, default_value = "all")]
    pub set: String,
    /// Rays per set (1 to 2^24).
    #[arg(long, default_value_t = 10_000, value_parser = crate::limits::ranged::<usize>(1, crate::limits::MAX_RAYS as u64))]
    pub count: usize,
    /// Seed of the ray sets.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where the shadow and surface rays start: at the hits of this tracer.
    #[arg(long, value_enum, default_value = "embree")]
    pub reference: Reference,
    /// The ray file to write (CSV: ox,oy,oz,dx,dy,dz,tnear,tfar); the tags go beside it.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// The sets `--set` names.
pub fn parse_sets(s: &str) -> Result<Vec<SetKind>> {
    if s == "all" {
        return Ok(SetKind::ALL.into_iter().filter(|k| *k != SetKind::Scaled).collect());
    }
    s.split(',')
        .map(|n| {
            SetKind::ALL.into_iter().find(|k| k.name() == n.trim()).ok_or_else(|| {
                let names: Vec<&str> = SetKind::ALL.iter().map(|k| k.name()).collect();
                crate::error::Error::Invalid(format!("unknown ray set '{n}' (expected all or {})", names.join(", ")))
            })
        })
        .collect()
}

/// Run `rtdiff rays`.
pub fn run(args: &RaysArgs) -> Result<()> {
    let kinds = parse_sets(&args.set)?;
    let (ctx, zero_area) = crate::rays::load_context_file_coordinates(&args.scene)?;
    super::warnings::degenerate(&args.scene, &ctx.prims, zero_area);
    let sets = generate_for_file(&ctx, &kinds, args.seed, args.count, args.reference)?;
    let header = format!(
        "rtdiff rays {} --set {} --count {} --seed {} (file coordinates; primitive ids are triangle positions in the file)",
        args.scene.display(),
        args.set,
        args.count,
        args.seed
    );
    let parts: Vec<SetRays> = sets.iter().map(|s| SetRays { name: &s.name, rays: &s.rays, tags: &s.tags }).collect();
    write_rays(&args.output, &header, &parts)?;
    let n: usize = sets.iter().map(|s| s.rays.len()).sum();
    eprintln!(
        "{n} rays in {} sets -> {} (tags: {})",
        sets.len(),
        args.output.display(),
        tags_path(&args.output).display()
    );
    Ok(())
}
