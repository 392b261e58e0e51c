//! One mesh normalisation: `rtdiff bench` (`rays::load_primitives` with
//! normalisation), `rtdiff parity` / `trace` (`rays::load_context` on an
//! `.obj`) and `rtdiff render` (a scene with `"normalize": true`) load the
//! same mesh to the same bits.

use std::path::{Path, PathBuf};

use rtdiff::geometry::Primitives;

fn bits(p: &Primitives) -> Vec<[u32; 9]> {
    p.triangles.iter().map(|t| std::array::from_fn(|k| t.v[k / 3][k % 3].to_bits())).collect()
}

fn check(mesh: &Path) {
    let bench = rtdiff::rays::load_primitives(mesh, true).unwrap();
    let parity = rtdiff::rays::load_context(mesh).unwrap().prims;
    let dir = std::env::temp_dir().join(format!("rtdiff-same-mesh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("scene.json");
    let json = serde_json::json!({ "meshes": [{ "file": mesh, "normalize": true }] });
    std::fs::write(&scene, json.to_string()).unwrap();
    let render = rtdiff::scene::Scene::load(&scene).unwrap().prims;
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!bench.triangles.is_empty());
    assert_eq!(bits(&bench), bits(&parity), "{}: bench and parity differ", mesh.display());
    assert_eq!(bits(&bench), bits(&render), "{}: bench and render differ", mesh.display());
    // Normalised: the farthest vertex at distance 1 (within f32 rounding of the
    // f64 result: one rounding per coordinate, a few ulps of the length).
    let r = bench.triangles.iter().flat_map(|t| t.v).map(|v| v.length()).fold(0.0f32, f32::max);
    assert!((r - 1.0).abs() < 4.0 * f32::EPSILON, "{}: radius {r}", mesh.display());
}

#[test]
fn bench_parity_and_render_load_the_same_bits() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    // An authored mesh (always present) and the benchmark's dragon (after scripts/fetch-assets.sh).
    let mut meshes: Vec<PathBuf> = std::fs::read_dir(root.join("scenes/meshes"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
        .collect();
    meshes.sort();
    meshes.truncate(2);
    let dragon = root.join("assets/dragon_87k.obj");
    assert!(dragon.exists(), "run scripts/fetch-assets.sh first ({} is missing)", dragon.display());
    meshes.push(dragon);
    for m in &meshes {
        check(m);
    }
}
