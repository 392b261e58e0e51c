//! glTF 2.0 (`.gltf`, `.glb`) and STL (ASCII, binary) meshes: the authored cube in every
//! format gives the OBJ's triangles bit for bit and in its order, and renders the same
//! image with its texture; node transforms (nested, mirrored, instanced), strips and fans
//! follow the specification; malformed files name the file and the place.

mod common;

use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use rtdiff::mesh::{Content, load_mesh};

fn authored(name: &str) -> PathBuf {
    common::root().join("scenes/meshes").join(name)
}

fn triangle_bits(path: &Path) -> Vec<[u32; 9]> {
    let m = load_mesh(path, Content::Geometry).unwrap_or_else(|e| panic!("{e}"));
    m.to_primitives()
        .triangles
        .iter()
        .map(|t| {
            let v: Vec<u32> = t.v.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect();
            v.try_into().unwrap()
        })
        .collect()
}

#[test]
fn the_cube_in_every_format_has_the_objs_triangles_in_its_order() {
    let obj = triangle_bits(&authored("cube_textured.obj"));
    assert_eq!(obj.len(), 12);
    for f in ["cube_textured.gltf", "cube_textured.glb", "cube.stl", "cube_ascii.stl"] {
        assert_eq!(triangle_bits(&authored(f)), obj, "{f}");
    }
    // gzip is looked through as for OBJ and PLY.
    let d = common::temp_dir("gltf-stl-gz");
    let gz = d.join("cube.stl.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    std::io::Write::write_all(&mut enc, &std::fs::read(authored("cube.stl")).unwrap()).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    assert_eq!(triangle_bits(&gz), obj);
}

/// The textured cube as OBJ + MTL, as glTF naming the PNG, and as GLB holding it: one image.
#[test]
fn the_textured_cube_renders_the_same_from_obj_gltf_and_glb() {
    let d = common::temp_dir("gltf-render");
    let render = |mesh: &str| {
        let json = format!(
            r#"{{ "image": {{ "width": 48, "height": 48 }}, "features": {{ "texture_mapping": true, "normal_interpolation": true }},
                "meshes": [ {{ "file": "{}", "normalize": true }} ],
                "lights": [ {{ "type": "point", "position": [-1, 1, -3], "color": [1, 1, 1] }} ] }}"#,
            authored(mesh).display()
        );
        let scene = common::scene(&d, &json);
        assert!(scene.plan().textures, "{mesh}: the render looks textures up");
        common::render_image(&scene)
    };
    let obj = render("cube_textured.obj");
    let distinct: std::collections::HashSet<[u32; 3]> =
        obj.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
    assert!(distinct.len() > 8, "the texture shows ({} colours)", distinct.len());
    for f in ["cube_textured.gltf", "cube_textured.glb"] {
        assert!(render(f).pixels == obj.pixels, "{f} renders differently from the OBJ");
    }
}

/// A glTF with one mesh (a triangle strip of 4 vertices and a fan of 4) used by three
/// nodes: a root translated and scaled, its child rotated, and a mirrored one.
fn transformed_gltf(dir: &Path) -> PathBuf {
    let pos: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let mut buf: Vec<u8> = pos.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let bytes = buf.len();
    buf.extend([0u16, 1, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    let uri = format!("data:application/octet-stream;base64,{}", base64::encode(&buf));
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [ { "nodes": [0, 2] } ],
        "nodes": [
            { "mesh": 0, "translation": [10, 0, 0], "scale": [2, 2, 2], "children": [1] },
            { "mesh": 0, "rotation": [0, 0, 0.70710677, 0.70710677] },
            { "mesh": 0, "scale": [-1, 1, 1] }
        ],
        "meshes": [ { "primitives": [
            { "attributes": { "POSITION": 0 }, "indices": 1, "mode": 5 },
            { "attributes": { "POSITION": 0 }, "indices": 1, "mode": 6 },
            { "attributes": { "POSITION": 0 }, "mode": 1 }
        ] } ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3" },
            { "bufferView": 1, "componentType": 5123, "count": 4, "type": "SCALAR" }
        ],
        "bufferViews": [ { "buffer": 0, "byteLength": bytes }, { "buffer": 0, "byteOffset": bytes, "byteLength": 8 } ],
        "buffers": [ { "byteLength": buf.len(), "uri": uri } ]
    });
    common::write(dir, "nodes.gltf", &doc.to_string())
}

#[test]
fn nodes_strips_and_fans_follow_the_specification() {
    let d = common::temp_dir("gltf-nodes");
    let m = load_mesh(&transformed_gltf(&d), Content::WithMaterials).unwrap();
    let strip = [[0, 1, 2], [1, 3, 2]];
    let fan = [[1, 2, 0], [2, 3, 0]];
    let local: Vec<[usize; 3]> = strip.iter().chain(&fan).copied().collect();
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
    let root = Mat4::from_scale_rotation_translation(Vec3::splat(2.0), Quat::IDENTITY, Vec3::new(10.0, 0.0, 0.0));
    let child = root * Mat4::from_quat(Quat::from_xyzw(0.0, 0.0, 0.707_106_77, 0.707_106_77));
    let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    // Depth first: root, its child, then the mirrored node; lines skipped; 4 triangles each.
    let mut want = Vec::new();
    for (world, flip) in [(root, false), (child, false), (mirror, true)] {
        for t in &local {
            let t = if flip { [t[0], t[2], t[1]] } else { *t };
            want.push(t.map(|i| world.transform_point3(p[i])));
        }
    }
    let got: Vec<[Vec3; 3]> = m.indices.iter().map(|t| t.map(|i| m.positions[i as usize])).collect();
    assert_eq!(got.len(), 12);
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        for c in 0..3 {
            assert!((g[c] - w[c]).length() < 1e-5, "triangle {k} corner {c}: {} vs {}", g[c], w[c]);
        }
    }
    // The mirrored copy keeps its faces pointing the same way as the original's (winding reversed).
    let normal = |t: &[Vec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]);
    assert!(normal(&got[0]).z > 0.0 && normal(&got[8]).z > 0.0);
    assert!(m.warnings.iter().any(|w| w.contains("points or lines skipped")), "{:?}", m.warnings);
}

/// Broken files: each error names the file and where in it the problem is.
#[test]
fn malformed_gltf_and_stl_name_the_file_and_the_place() {
    let d = common::temp_dir("gltf-bad");
    let good = std::fs::read_to_string(transformed_gltf(&d)).unwrap();
    let glb = std::fs::read(authored("cube_textured.glb")).unwrap();
    // Found by the fuzzer: what the gltf crates index without checking (they panicked).
    let mut cube: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(authored("cube_textured.gltf")).unwrap()).unwrap();
    cube["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 65537.into();
    let bad_position = cube.to_string().into_bytes();
    cube["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 0.into();
    cube["images"][0] = serde_json::json!({});
    let no_image_source = cube.to_string().into_bytes();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("syntax.gltf", good.replacen("\"scene\":0", "\"scene\":0,,", 1).into_bytes(), "syntax.gltf:1: "),
        ("index.gltf", good.replacen("\"mesh\":0", "\"mesh\":7", 1).into_bytes(), "nodes[0].mesh: Index out of bounds"),
        (
            "cycle.gltf",
            good.replacen("\"mesh\":0,\"rotation\"", "\"children\":[0],\"mesh\":0,\"rotation\"", 1).into_bytes(),
            "nodes[0]: a cycle",
        ),
        (
            "count.gltf",
            good.replacen("\"count\":4,\"type\":\"SCALAR\"", "\"count\":40,\"type\":\"SCALAR\"", 1).into_bytes(),
            "indices (accessors[1]): 40 elements of 2 bytes",
        ),
        (
            "type.gltf",
            good.replacen("\"type\":\"VEC3\"", "\"type\":\"VEC2\"", 1).into_bytes(),
            "POSITION (accessors[0]) is Vec2 of F32; expected Vec3 of F32",
        ),
        (
            "bin.gltf",
            good.replacen("data:application/octet-stream;base64,", "missing.bin#", 1).into_bytes(),
            "buffers[0]: 'missing.bin#",
        ),
        ("short.glb", glb[..glb.len() - 100].to_vec(), "invalid GLB container, byte 8"),
        ("magic.glb", [b"gltf", &glb[4..]].concat(), "invalid GLB container, byte 0"),
        ("json.glb", [&glb[..30], b"?", &glb[31..]].concat(), "GLB JSON chunk, byte 30: "),
        ("none.stl", b"solid x\nendsolid x\n".to_vec(), "none.stl:2: no facets"),
        ("position.gltf", bad_position, "meshes[0].primitives[0].attributes.POSITION: accessor 65537 does not exist"),
        ("image.gltf", no_image_source, "images[0]: neither a uri nor a bufferView"),
    ];
    for (name, bytes, want) in cases {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        let e = load_mesh(&p, Content::WithMaterials).expect_err(name).to_string();
        assert!(e.contains(name) && e.contains(want), "{name}: got '{e}', want '{want}'");
    }
}

/// Every mesh file below `dir` that rtdiff reads.
#[cfg(feature = "embree")]
fn mesh_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            mesh_files(&p, out);
        } else if rtdiff::mesh::is_mesh_file(&p) {
            out.push(p);
        }
    }
}

/// The authored cubes and assimp's glTF 2.0 and STL test models (`assets/assimp/glTF2`,
/// `STL`, fetched by scripts/fetch-assets.sh): each file loads, renders and holds hit parity
/// against Embree, or is refused with an error naming it (never a panic).
#[cfg(feature = "embree")]
#[test]
fn gltf_and_stl_files_render_and_hold_parity_against_embree() {
    use rtdiff::backends::AccelConfig;
    use rtdiff::rays::SetKind;
    use rtdiff::verify::hits::ParityOptions;
    let assimp = common::root().join("assets/assimp");
    assert!(assimp.join("glTF2").is_dir(), "{} is missing: run scripts/fetch-assets.sh", assimp.display());
    let mut files = Vec::new();
    for f in ["cube_textured.gltf", "cube_textured.glb", "cube.stl", "cube_ascii.stl"] {
        files.push(authored(f));
    }
    mesh_files(&assimp.join("glTF2"), &mut files);
    mesh_files(&assimp.join("STL"), &mut files);
    let d = common::temp_dir("gltf-stl-parity");
    let mut loaded = 0;
    for path in &files {
        let name = path.file_name().unwrap().to_str().unwrap();
        let ctx = match rtdiff::rays::load_context(path) {
            Ok(c) => c,
            Err(e) => {
                assert!(e.to_string().contains(name), "{}: the error names the file: {e}", path.display());
                continue;
            }
        };
        loaded += 1;
        let json = serde_json::json!({
            "image": {"width": 16, "height": 16}, "features": {"texture_mapping": true},
            "meshes": [{"file": path, "normalize": true}],
            "lights": [{"type": "point", "position": [-1, 1, -3], "color": [1, 1, 1]}],
        });
        let scene = rtdiff::scene::Scene::load(&common::write(&d, "s.json", &json.to_string()))
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(common::render_image(&scene).pixels.iter().all(|p| p.is_finite()), "{}", path.display());
        let opts = ParityOptions {
            sets: vec![SetKind::Primary, SetKind::Shadow, SetKind::Edges, SetKind::Vertices],
            count: 1_000,
            seed: 17,
            variants: vec![AccelConfig::default()],
            max_examples: 3,
            ..ParityOptions::default()
        };
        let r = rtdiff::verify::hits::run(&ctx, &opts).unwrap();
        for s in &r.sets {
            for v in &s.variants {
                let at = format!("{}, set {}", path.display(), s.set);
                let a = v.arbiter.clone().unwrap_or_default();
                assert_eq!(a.native.get("wrong"), None, "{at}: the arbiter finds rtdiff wrong: {:#?}", a.replays);
                assert_eq!(v.leaks, 0, "{at}: {:#?}", v.examples);
                assert_eq!(v.classes.get("unclassified"), None, "{at}: {:#?}", v.examples);
            }
        }
    }
    assert!(loaded >= 30, "only {loaded} of {} files loaded", files.len());
}

/// A glTF sampler's wrap modes reach the material: CLAMP_TO_EDGE (the authored cube), REPEAT
/// (the default), MIRRORED_REPEAT; S and T that differ are named in a warning where the uvs
/// leave [0, 1].
#[test]
fn gltf_sampler_wrap_modes_reach_the_material() {
    use rtdiff::texture::WrapMode;
    let d = common::temp_dir("gltf-wrap");
    let base: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(authored("cube_textured.gltf")).unwrap()).unwrap();
    // The authored file's buffer is a data URI; its image is a file beside it.
    std::fs::copy(authored("cube_texture.png"), d.join("cube_texture.png")).unwrap();
    let wrap = |s: Option<u32>, t: Option<u32>| {
        let mut doc = base.clone();
        let sampler = &mut doc["samplers"][0];
        let o = sampler.as_object_mut().unwrap();
        o.remove("wrapS");
        o.remove("wrapT");
        if let Some(s) = s {
            o.insert("wrapS".into(), s.into());
        }
        if let Some(t) = t {
            o.insert("wrapT".into(), t.into());
        }
        let p = common::write(&d, &format!("w_{s:?}_{t:?}.gltf"), &doc.to_string());
        let m = load_mesh(&p, Content::WithMaterials).unwrap_or_else(|e| panic!("{e}"));
        (m.materials[0].map_kd_wrap, m.warnings)
    };
    assert_eq!(wrap(Some(33071), Some(33071)).0, WrapMode::Clamp);
    assert_eq!(wrap(None, None).0, WrapMode::Repeat);
    assert_eq!(wrap(Some(33648), Some(33648)).0, WrapMode::Mirror);
    let (mode, warnings) = wrap(Some(10497), Some(33071));
    assert_eq!(mode, WrapMode::Repeat);
    // The authored cube's uvs stay in [0, 1]: nothing to warn about.
    assert!(warnings.iter().all(|w| !w.contains("wrap modes")), "{warnings:?}");
}
