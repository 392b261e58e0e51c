//! The assimp regression corpus (Debian `assimp-testmodels`: `models/OBJ`, `models/PLY`,
//! `models/invalid`, unpacked into `assets/assimp/` by scripts/fetch-assets.sh): every OBJ
//! and PLY file is loaded. The meshes load, render at a small size (with their materials
//! and textures) and hold hit parity against Embree on a small ray set; the point clouds
//! and broken files give an error naming the file and line and a non-zero exit from the
//! command line, never a panic. The table in docs/scene-format.md lists the outcomes.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use rtdiff::mesh::{Content, load_mesh};

fn corpus() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/assimp");
    assert!(d.join("OBJ/spider.obj").is_file(), "{} is missing: run scripts/fetch-assets.sh", d.display());
    d
}

/// Every mesh file of the corpus: (path relative to assets/assimp, expected outcome).
/// `Ok(n)`: loads with n triangles of non-zero area (zero-area ones are kept in place and counted); `Err(s)`: fails with a message containing `file:s`.
const FILES: &[(&str, Result<usize, &str>)] = &[
    ("OBJ/WusonOBJ.obj", Ok(3732)),
    ("OBJ/box.obj", Ok(12)),
    ("OBJ/box_UTF16BE.obj", Ok(12)),
    ("OBJ/box_longline.obj", Ok(478)),
    ("OBJ/box_mat_with_spaces.obj", Ok(12)),
    ("OBJ/box_without_lineending.obj", Ok(12)),
    ("OBJ/concave_polygon.obj", Ok(64)),
    ("OBJ/cube_mtllib_after_g.obj", Ok(12)),
    ("OBJ/cube_usemtl.obj", Ok(12)),
    ("OBJ/cube_with_vertexcolors.obj", Ok(12)),
    ("OBJ/cube_with_vertexcolors_uni.obj", Ok(12)),
    ("OBJ/empty_mat.obj", Ok(256)),
    ("OBJ/multiple_spaces.obj", Ok(1)),
    ("OBJ/number_formats.obj", Err("11: '3.1+e2' is not a number")),
    ("OBJ/point_cloud.obj", Err("17: no triangles: 3 vertices")),
    ("OBJ/regr01.obj", Ok(2706)),
    ("OBJ/regr_3429812.obj", Ok(4)),
    ("OBJ/space_in_material_name.obj", Ok(64)),
    ("OBJ/spider.obj", Ok(1312)),
    ("OBJ/testline.obj", Err("10: no triangles: 8 vertices")),
    ("OBJ/testmixed.obj", Ok(12)),
    ("OBJ/testpoints.obj", Err("10: no triangles: 8 vertices")),
    ("invalid/empty.obj", Err(" the file is empty")),
    ("invalid/malformed.obj", Err("23: '12': vertex index 12 is out of range (the file has 8)")),
    ("invalid/malformed2.obj", Err("23: 'f' with no vertices")),
    ("PLY/Wuson.ply", Ok(3732)),
    ("PLY/cube.ply", Ok(12)),
    ("PLY/cube_binary.ply", Ok(12)),
    ("PLY/cube_uv.ply", Ok(12)),
    ("PLY/float-color.ply", Ok(1)),
    ("PLY/issue623.ply", Err("4: a point cloud: 24 vertices")),
    ("PLY/points.ply", Err("3: a point cloud: 4 vertices")),
    ("PLY/pond.0.ply", Err("3: a point cloud: 70051 vertices")),
    ("invalid/empty.ply", Err(" the file is empty")),
];

#[test]
fn the_table_covers_every_obj_and_ply_file_of_the_corpus() {
    let dir = corpus();
    let mut found = Vec::new();
    for sub in ["OBJ", "PLY", "invalid"] {
        for e in std::fs::read_dir(dir.join(sub)).unwrap() {
            let p = e.unwrap().path();
            if rtdiff::mesh::is_mesh_file(&p) {
                found.push(format!("{sub}/{}", p.file_name().unwrap().to_str().unwrap()));
            }
        }
    }
    found.sort();
    let mut listed: Vec<String> = FILES.iter().map(|(f, _)| f.to_string()).collect();
    listed.sort();
    assert_eq!(found, listed);
    let objs = listed.iter().filter(|f| f.ends_with(".obj")).count();
    let plys = listed.iter().filter(|f| f.ends_with(".ply")).count();
    assert_eq!((objs, plys), (25, 9), "the issue's 25 OBJ and 9 PLY files");
}

#[test]
fn every_file_loads_or_names_the_line() {
    let dir = corpus();
    for (name, expected) in FILES {
        let path = dir.join(name);
        for content in [Content::Geometry, Content::WithMaterials] {
            let got = load_mesh(&path, content);
            match (expected, got) {
                (Ok(n), Ok(m)) => {
                    assert_eq!(m.indices.len() - m.zero_area, *n, "{name}: triangles of non-zero area")
                }
                (Err(want), Err(e)) => {
                    let e = e.to_string();
                    let want = format!("{}:{want}", path.display());
                    assert!(e.starts_with(&want), "{name}: got '{e}', want it to start with '{want}'");
                }
                (Ok(_), Err(e)) => panic!("{name} should load: {e}"),
                (Err(want), Ok(_)) => panic!("{name} should fail with '{want}'"),
            }
        }
    }
}

/// A scene JSON rendering `mesh` normalised to the unit sphere from the default camera.
fn scene_for(dir: &Path, mesh: &Path, size: u32) -> String {
    let json = serde_json::json!({
        "image": {"width": size, "height": size, "spp": 1},
        "meshes": [{"file": mesh, "normalize": true}],
        "lights": [{"type": "point", "position": [-1, 1, -3], "color": [1, 1, 1]}],
    });
    common::write(dir, &format!("{}.json", mesh.file_name().unwrap().to_str().unwrap()), &json.to_string())
        .to_str()
        .unwrap()
        .to_owned()
}

#[test]
fn every_mesh_renders_at_a_small_size() {
    let dir = corpus();
    let tmp = common::temp_dir("corpus-render");
    for (name, expected) in FILES {
        if expected.is_err() {
            continue;
        }
        let scene_path = scene_for(&tmp, &dir.join(name), 24);
        let scene = rtdiff::scene::Scene::load(Path::new(&scene_path)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let result = common::render_with(&scene, Some(2));
        assert_eq!((result.image.width, result.image.height), (24, 24), "{name}");
        assert!(result.image.pixels.iter().all(|p| p.is_finite()), "{name}: non-finite pixel");
    }
}

#[test]
fn spider_renders_with_its_five_textures() {
    let dir = corpus();
    let tmp = common::temp_dir("corpus-spider");
    let scene_path = scene_for(&tmp, &dir.join("OBJ/spider.obj"), 48);
    let scene = rtdiff::scene::Scene::load(Path::new(&scene_path)).unwrap();
    let textured: Vec<&str> =
        scene.materials.iter().filter(|m| m.kd_texture.is_some()).map(|m| m.name.as_str()).collect();
    assert_eq!(textured.len(), 5, "materials with a map_Kd: {textured:?}");
    assert!(scene.plan().textures, "the render plan must look textures up");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let with = common::render_with(&scene, Some(2));
    let plain = rtdiff::scene::Scene::load_with(
        Path::new(&scene_path),
        &rtdiff::scene::Overrides { features: vec![("texture_mapping".into(), false)], ..Default::default() },
    )
    .unwrap();
    let without = common::render_with(&plain, Some(2));
    let differ = with.image.pixels.iter().zip(&without.image.pixels).filter(|(a, b)| a != b).count();
    assert!(differ > 100, "textures change only {differ} pixels");
}

#[test]
fn broken_files_exit_non_zero_with_the_line_never_a_panic() {
    let dir = corpus();
    for (name, expected) in FILES {
        let Err(want) = expected else { continue };
        let path = dir.join(name);
        for cmd in ["bvh-stats", "parity"] {
            let mut c = Command::new(env!("CARGO_BIN_EXE_rtdiff"));
            c.arg(cmd).arg(&path);
            if cmd == "parity" {
                c.args(["--count", "10", "--reference", "brute"]);
            }
            let out = c.output().unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{cmd} {name}: {stderr}");
            assert!(!stderr.contains("panicked"), "{cmd} {name}: {stderr}");
            let at = format!("{}:{want}", path.display());
            assert!(stderr.contains(&at), "{cmd} {name}: {stderr}");
        }
    }
}

#[cfg(feature = "embree")]
#[test]
fn every_mesh_holds_hit_parity_against_embree() {
    use rtdiff::backends::AccelConfig;
    use rtdiff::rays::SetKind;
    use rtdiff::verify::hits::{self as parity, ParityOptions};
    let dir = corpus();
    for (name, expected) in FILES {
        if expected.is_err() {
            continue;
        }
        let ctx = rtdiff::rays::load_context(&dir.join(name)).unwrap();
        let opts = ParityOptions {
            // Not the incoherent set: its origins are drawn inside the mesh's bounding box, which
            // for a flat mesh (concave_polygon.obj) is the mesh's own plane, so every ray starts on
            // the surface and hit-at-t=0 versus miss is a tie both tracers may answer either way.
            sets: vec![SetKind::Primary, SetKind::Shadow, SetKind::Edges, SetKind::Vertices],
            count: 2_000,
            seed: 17,
            variants: vec![AccelConfig::default()],
            max_examples: 3,
            ..ParityOptions::default()
        };
        let r = parity::run(&ctx, &opts).unwrap();
        for s in &r.sets {
            for v in &s.variants {
                let at = format!("{name}, set {}, {}", s.set, v.tracer);
                // As in tests/embree_parity.rs: the only hit/miss disagreement allowed is a hit within
                // the float error bound of the ray origin (pbrt-v4 rejects an unprovable t, Embree not).
                let at_origin: u64 =
                    ["interval-end", "unprovable-t"].iter().map(|c| v.classes.get(*c).copied().unwrap_or(0)).sum();
                if matches!(s.kind, SetKind::Primary | SetKind::Shadow) {
                    assert_eq!(v.native_miss_ref_hit + v.native_hit_ref_miss, at_origin, "{at}: {:#?}", v.examples);
                    assert_eq!(v.occluded_disagree, 0, "{at}: {:#?}", v.examples);
                }
                assert_eq!(v.leaks, 0, "{at}: {:#?}", v.examples);
                assert_eq!(v.classes.get("unclassified"), None, "{at}: {:#?}", v.examples);
                assert_eq!(v.prim_classes.get("unclassified"), None, "{at}: {:#?}", v.examples);
                // No distance or barycentrics beyond the bound of Embree's. regr01.obj's vertex set
                // (seed 17) had 4 such distances, pinned here, until the watertight test sent hits whose
                // edge-function error may move `t` too far to double precision
                // (`rtdiff::geometry::triangle::T_SPREAD_MAX`).
                assert_eq!(v.dist_over_bound + v.bary_over_bound, 0, "{at}: {:#?}", v.examples);
            }
        }
    }
}
