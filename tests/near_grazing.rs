//! A deliberate search for rays like issue 12's: near-grazing rays at
//! interior points of the smallest triangles of every mesh in `assets/`
//! (normalised as `rtdiff parity` does), every ray judged by the exact
//! arbiter. The native tracer must be exact on every ray that is not
//! ill-conditioned; Embree's verdicts are printed beside it.

use std::collections::BTreeMap;
use std::path::Path;

use rayon::prelude::*;
use rtdiff::backends::{AccelConfig, build_tracer};
use rtdiff::rays::near_grazing::near_grazing;
use rtdiff::verify::hits::arbiter::{Arbiter, Verdict, replay_line};

/// Rays per mesh (the whole search over the eight meshes stays well under a minute).
const RAYS: usize = 2000;

#[test]
fn near_grazing_rays_on_every_mesh() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let mut meshes: Vec<_> = std::fs::read_dir(&dir)
        .expect("assets/ (run scripts/fetch-assets.sh)")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
        .collect();
    meshes.sort();
    assert!(meshes.len() >= 4, "{meshes:?}");
    let mut failures = Vec::new();
    for path in &meshes {
        let ctx = rtdiff::rays::load_context(path).unwrap();
        let rays = near_grazing(&ctx.prims, RAYS, 12);
        let native = build_tracer(ctx.prims.clone(), &AccelConfig::default()).unwrap();
        #[cfg(feature = "embree")]
        let embree = build_tracer(
            ctx.prims.clone(),
            &AccelConfig { backend: rtdiff::backends::Backend::Embree, ..Default::default() },
        )
        .unwrap();
        let arb = Arbiter::new(ctx.prims.clone());
        let judged: Vec<(bool, Verdict, Option<Verdict>)> = rays
            .par_iter()
            .map(|r| {
                let truth = arb.truth(r);
                let n = arb.judge(r, &truth, native.intersect(r).map(|h| h.prim));
                #[cfg(feature = "embree")]
                let e = Some(arb.judge(r, &truth, embree.intersect(r).map(|h| h.prim)));
                #[cfg(not(feature = "embree"))]
                let e = None;
                (truth.ill_conditioned(), n, e)
            })
            .collect();
        let mut counts: BTreeMap<String, usize> = BTreeMap::new();
        for (i, (ill, n, e)) in judged.iter().enumerate() {
            let c = if *ill { "ill-conditioned" } else { "well-conditioned" };
            *counts.entry(format!("{c} native {n:?}")).or_default() += 1;
            if let Some(e) = e {
                *counts.entry(format!("{c} embree {e:?}")).or_default() += 1;
            }
            if !ill && *n != Verdict::Exact {
                failures.push(format!("{}: ray {i}: native {n:?}: {}", path.display(), replay_line(&rays[i])));
            }
        }
        eprintln!("{}: {} rays: {counts:?}", path.file_name().unwrap().to_string_lossy(), rays.len());
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
