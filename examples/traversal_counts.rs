//! Deterministic traversal work of the `fast` path: wide-node visits, leaf
//! visits and packet tests per ray, on the `rtdiff bench` primary, incoherent
//! and shadow rays (closest hit for the first two, any hit for shadow rays;
//! the benchmark's shadow rays go to four lights, a quarter of the image
//! each), on the closest-hit sets' rays that hit and rays that miss apart,
//! and on the shadow rays of the whole image towards each of those
//! lights, so that a change of the any-hit order is not tuned to one light. Unlike timings, these counts do not depend on the
//! machine's load, so they compare tree layouts and build parameters exactly.
//!
//! `cargo run --release --example traversal_counts -- [mesh.obj] [bins]`

use rtdiff::backends::{AccelConfig, Builder, build_tracer};
use rtdiff::bvh::wide::TraversalCounts;
use rtdiff::geometry::TriangleTest;
use rtdiff::geometry::offset::SpawnOffset;
use rtdiff::perf::bench::{RaySets, SHADOW_LIGHTS};
use rtdiff::rays::workload::shadow_rays;

/// Print one line on stdout; a closed pipe (`| head`) ends the program
/// quietly, another write error with a message and exit status 1.
fn line(args: std::fmt::Arguments) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.write_all(b"\n")) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("traversal_counts: cannot write to stdout: {e}");
        std::process::exit(1);
    }
}

fn main() -> rtdiff::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "assets/dragon_87k.obj".into());
    let bins = args.next().and_then(|s| s.parse().ok()).unwrap_or(16);
    let prims = rtdiff::rays::load_primitives(std::path::Path::new(&path), true)?;
    let cfg = AccelConfig { builder: Builder::Sah, bins, ..Default::default() };
    let bvh = rtdiff::bvh::build_wide(&prims, &cfg);
    line(format_args!("{path}: {} primitives, {} wide nodes", prims.len(), bvh.nodes().len()));
    line(format_args!(
        "{:<22} {:>10} {:>10} {:>12} {:>14}",
        "rays", "nodes/ray", "leaves/ray", "packets/ray", "packets/leaf"
    ));
    let reference = build_tracer(prims.clone(), &cfg)?;
    let sets = RaySets::new(&prims, 512, 262_144, reference.as_ref());
    let hits: Vec<_> = sets.primary.iter().map(|r| reference.intersect(r)).collect();
    let per_light: Vec<(String, Vec<rtdiff::geometry::Ray>)> = SHADOW_LIGHTS
        .into_iter()
        .map(|light| (format!("shadow{light}"), shadow_rays(&prims, &sets.primary, &hits, light, SpawnOffset::Robust)))
        .collect();
    // The closest-hit sets again as the rays that hit and the rays that miss
    // (which of them a tree change helps, as `outside_loop --split` times them).
    let split: Vec<(String, Vec<rtdiff::geometry::Ray>)> = sets
        .list()
        .into_iter()
        .filter(|(_, _, any)| !any)
        .flat_map(|(name, rays, _)| {
            let (hit, miss): (Vec<_>, Vec<_>) = rays.iter().partition(|r| reference.intersect(r).is_some());
            [(format!("{name}-hits"), hit), (format!("{name}-misses"), miss)]
        })
        .collect();
    let mut list: Vec<(&str, &[rtdiff::geometry::Ray], bool)> = sets.list().to_vec();
    list.extend(split.iter().map(|(n, r)| (n.as_str(), r.as_slice(), false)));
    list.extend(per_light.iter().map(|(n, r)| (n.as_str(), r.as_slice(), true)));
    for (name, rays, any) in list {
        let mut c = TraversalCounts::default();
        for r in rays {
            if any {
                bvh.occluded_counted(r, TriangleTest::Watertight, &mut c);
            } else {
                bvh.intersect_counted(r, TriangleTest::Watertight, &mut c);
            }
        }
        let per = |x: u64| x as f64 / c.rays as f64;
        let ppl = c.packets as f64 / c.leaves.max(1) as f64;
        line(format_args!(
            "{name:<22} {:>10.3} {:>10.3} {:>12.3} {:>14.3}",
            per(c.nodes),
            per(c.leaves),
            per(c.packets),
            ppl
        ));
    }
    Ok(())
}
