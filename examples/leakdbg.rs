use rtdiff::accel::*;
use rtdiff::geometry::*;
use rtdiff::harness::raysets::*;
use std::sync::Arc;
fn main() {
    let ctx = rtdiff::harness::load_context(std::path::Path::new(&std::env::args().nth(1).unwrap())).unwrap();
    let cfg = AccelConfig { backend: Backend::Embree, ..Default::default() };
    let e = build_tracer(ctx.prims.clone(), &cfg).unwrap();
    let of = |p: Arc<Primitives>| build_tracer(p, &cfg);
    for kind in [SetKind::Edges, SetKind::Vertices] {
        let s = &generate(&ctx, kind, 1, 20000, e.as_ref(), &of).unwrap()[0];
        let mut n = 0;
        let mut nc = 0;
        let mut miss = 0;
        for (r, t) in s.rays.iter().zip(&s.tags) {
            if let RayTag::Crossing { t } = t {
                nc += 1;
                let he = e.intersect(r);
                if he.is_none() {
                    miss += 1;
                }
                if match he {
                    None => true,
                    Some(h) => h.t > t * 1.0001,
                } {
                    n += 1;
                }
            }
        }
        println!("{kind:?} crossing {nc} leaks {n} (misses {miss})");
    }
}
