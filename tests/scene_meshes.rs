//! A scene whose `meshes[]` entries name the same file many times: the file is
//! read once per scene, and every entry still gets exactly the triangles,
//! shading data and materials it gets when it is the scene's only entry.

mod common;

use common::{temp_dir, write};
use rtdiff::scene::{Scene, TriangleShading};

/// A textured, two-material quad pair with an MTL library.
const OBJ: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.3 0.2 0.7\nvt 0 0\nvt 1 0\nvt 1 1\n\
                   vt 0 1\nvn 0 0 1\nusemtl red\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\nusemtl blue\nf 1/1 2/2 5/3\n";
/// Its material library, with one statement rtdiff does not know (a warning).
const MTL: &str = "newmtl red\nKd 0.8 0.1 0.1\nfrobnicate 1\nnewmtl blue\nKd 0.1 0.1 0.8\nKs 0.5 0.5 0.5\n";

/// Entry `i`: its own transform (and every third one normalised, every fifth one with a material override).
fn entry(i: usize) -> serde_json::Value {
    let f = i as f32;
    let mut e = serde_json::json!({
        "file": "q.obj",
        "transform": { "scale": [1.0 + 0.01 * f, 1.0, -1.0], "rotate": [f, 2.0 * f, 0.5 * f], "translate": [f, -0.5 * f, 0.25] }
    });
    if i.is_multiple_of(3) {
        e["normalize"] = true.into();
    }
    if i.is_multiple_of(5) {
        e["material_overrides"] = serde_json::json!({ "red": "gold" });
    }
    e
}

fn scene_json(entries: &[serde_json::Value]) -> String {
    serde_json::json!({
        "materials": { "gold": { "kd": [0.9, 0.7, 0.2] } },
        "meshes": entries,
        "lights": [ { "type": "point", "position": [0, 2, -3], "color": [1, 1, 1] } ]
    })
    .to_string()
}

/// Everything about a triangle, as bits: vertices, normals, uvs, and its material's name and colour.
fn triangle_bits(s: &Scene, i: usize) -> (Vec<u32>, String) {
    let t = s.prims.triangles[i];
    let TriangleShading { normals, uvs, has_uvs, material } = s.triangle_shading[i];
    let m = &s.materials[material as usize];
    let mut v: Vec<u32> = t.v.iter().chain(&normals).flat_map(|p| p.to_array()).map(f32::to_bits).collect();
    v.extend(uvs.iter().flat_map(|p| p.to_array()).map(f32::to_bits));
    v.extend(m.kd.to_array().map(f32::to_bits));
    v.push(u32::from(has_uvs));
    (v, m.name.clone())
}

#[test]
fn each_entry_gets_the_triangles_it_gets_alone() {
    let d = temp_dir("scene-meshes");
    write(&d, "q.obj", OBJ);
    write(&d, "m.mtl", MTL);
    let n = 40;
    let entries: Vec<_> = (0..n).map(entry).collect();
    let all = Scene::load(&write(&d, "all.json", &scene_json(&entries))).unwrap();
    assert_eq!(all.prims.triangles.len(), 3 * n);
    for (i, e) in entries.iter().enumerate() {
        let alone = Scene::load(&write(&d, "one.json", &scene_json(std::slice::from_ref(e)))).unwrap();
        assert_eq!(alone.prims.triangles.len(), 3);
        for k in 0..3 {
            assert_eq!(triangle_bits(&all, 3 * i + k), triangle_bits(&alone, k), "entry {i}, triangle {k}");
        }
    }
    // The override reached the entries that ask for it, and only those.
    assert_eq!(triangle_bits(&all, 0).1, "gold");
    assert_eq!(triangle_bits(&all, 3).1, "red");
    assert_eq!(triangle_bits(&all, 5).1, "blue");
}

#[test]
fn five_thousand_entries_of_one_file_load() {
    let d = temp_dir("scene-meshes-5000");
    write(&d, "q.obj", OBJ);
    write(&d, "m.mtl", MTL);
    let entries: Vec<_> = (0..5000).map(entry).collect();
    let s = Scene::load(&write(&d, "s.json", &scene_json(&entries))).unwrap();
    assert_eq!(s.prims.triangles.len(), 15_000);
    // A file's warnings are reported once, not once per entry.
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("frobnicate"), "{:?}", s.warnings);
}
