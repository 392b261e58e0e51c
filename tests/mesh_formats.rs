//! Mesh files as users have them: the same triangles from OBJ, PLY (ASCII, binary both
//! endiannesses, the layout of `rtdiff export`) and gzip, bit for bit; materials that never
//! cost the geometry; and the OBJ/MTL causes of issue 13 (short colours, mixed face forms,
//! non-finite MTL values, index 0), each a warning or an error naming the file and line.

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};

use rtdiff::mesh::{Content, Mesh, load_mesh};
use rtdiff::scene::Scene;

fn asset(name: &str) -> PathBuf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join(name);
    assert!(p.is_file(), "{} is missing: run scripts/fetch-assets.sh", p.display());
    p
}

#[derive(Clone, Copy)]
enum Enc {
    Ascii,
    Little,
    Big,
}

/// A PLY with `vertex` x y z nx ny nz u v (float) and `face` vertex_indices (uchar, int): the
/// layout `rtdiff export --to mitsuba` writes, here in any encoding.
fn write_ply(mesh: &Mesh, enc: Enc) -> Vec<u8> {
    let format = match enc {
        Enc::Ascii => "ascii",
        Enc::Little => "binary_little_endian",
        Enc::Big => "binary_big_endian",
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.indices.len()
    )
    .into_bytes();
    let uv = |i: usize| mesh.uvs.as_ref().map_or([0.0; 2], |u| u[i].to_array());
    for (i, p) in mesh.positions.iter().enumerate() {
        let n = mesh.normals[i];
        let vals = [p.x, p.y, p.z, n.x, n.y, n.z, uv(i)[0], uv(i)[1]];
        match enc {
            // Rust prints the shortest decimal that parses back to the same f32.
            Enc::Ascii => out.extend(vals.map(|v| format!("{v}")).join(" ").bytes().chain([b'\n'])),
            Enc::Little => vals.iter().for_each(|v| out.extend(v.to_le_bytes())),
            Enc::Big => vals.iter().for_each(|v| out.extend(v.to_be_bytes())),
        }
    }
    for t in &mesh.indices {
        match enc {
            Enc::Ascii => out.extend(format!("3 {} {} {}\n", t[0], t[1], t[2]).bytes()),
            Enc::Little => {
                out.push(3);
                t.iter().for_each(|&i| out.extend((i as i32).to_le_bytes()));
            }
            Enc::Big => {
                out.push(3);
                t.iter().for_each(|&i| out.extend((i as i32).to_be_bytes()));
            }
        }
    }
    out
}

fn triangle_bits(m: &Mesh) -> Vec<[u32; 9]> {
    m.to_primitives()
        .triangles
        .iter()
        .map(|t| {
            let v = t.v;
            [v[0].x, v[0].y, v[0].z, v[1].x, v[1].y, v[1].z, v[2].x, v[2].y, v[2].z].map(f32::to_bits)
        })
        .collect()
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

#[test]
fn dragon_as_ply_and_as_obj_gives_bit_identical_triangles() {
    let obj = load_mesh(&asset("dragon_87k.obj"), Content::WithMaterials).unwrap();
    let want = triangle_bits(&obj);
    assert_eq!(want.len(), 87_141, "the dragon's triangles in file order");
    assert_eq!(obj.zero_area, 108, "PROVENANCE.md: 108 zero-area triangles, kept in place");
    let dir = common::temp_dir("ply-dragon");
    for (enc, name) in [(Enc::Little, "le.ply"), (Enc::Big, "be.ply"), (Enc::Ascii, "ascii.ply")] {
        let bytes = write_ply(&obj, enc);
        for (file, data) in [(name.to_string(), bytes.clone()), (format!("{name}.gz"), gzip(&bytes))] {
            let p = dir.join(&file);
            std::fs::write(&p, &data).unwrap();
            for content in [Content::Geometry, Content::WithMaterials] {
                let ply = load_mesh(&p, content).unwrap_or_else(|e| panic!("{e}"));
                assert!(triangle_bits(&ply) == want, "{file}: triangles differ from the OBJ's");
                assert_eq!(ply.indices, obj.indices, "{file}");
            }
            let ply = load_mesh(&p, Content::WithMaterials).unwrap();
            let bits = |m: &Mesh| m.normals.iter().map(|n| n.to_array().map(f32::to_bits)).collect::<Vec<_>>();
            assert!(ply.file_normals && bits(&ply) == bits(&obj), "{file}: normals not read back bit for bit");
        }
    }
}

#[test]
fn compressed_obj_reads_like_the_plain_one() {
    let gz = load_mesh(&asset("dragon_full.obj.gz"), Content::Geometry).unwrap();
    let plain = load_mesh(&asset("dragon_full.obj"), Content::Geometry).unwrap();
    assert_eq!(gz.indices.len(), 871_414);
    assert!(triangle_bits(&gz) == triangle_bits(&plain));
}

/// Write `files` (name, bytes) into a fresh folder; return the folder.
fn folder(name: &str, files: &[(&str, &[u8])]) -> PathBuf {
    let dir = common::temp_dir(name);
    for (f, b) in files {
        let p = dir.join(f);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, b).unwrap();
    }
    dir
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";

fn scene_with(dir: &Path, obj: &str) -> rtdiff::Result<Scene> {
    let json = format!(
        r#"{{"image": {{"width": 8, "height": 8}}, "meshes": [{{"file": "{obj}", "normalize": true}}],
            "lights": [{{"type": "point", "position": [0, 0, -3], "color": [1, 1, 1]}}]}}"#
    );
    Scene::load(&common::write(dir, "scene.json", &json))
}

#[test]
fn mtl_colour_with_one_number_is_grey_not_a_panic() {
    let obj = format!("mtllib m.mtl\n{TRI}usemtl a\nf 1 2 3\n");
    let dir = folder("mtl-short", &[("t.obj", obj.as_bytes()), ("m.mtl", b"newmtl a\nKd 0.5\nKs 0.1 0.2\n")]);
    let scene = scene_with(&dir, "t.obj").unwrap();
    let a = scene.materials.iter().find(|m| m.name == "a").unwrap();
    assert_eq!(a.kd, glam::Vec3::splat(0.5));
    assert_eq!(a.ks, glam::Vec3::ZERO, "the two-number Ks is ignored");
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(scene.warnings[0].contains("m.mtl:3: 'Ks' needs 1 or 3 numbers, found 2"), "{:?}", scene.warnings);
}

#[test]
fn non_finite_mtl_values_are_warnings_and_defaults() {
    let obj = format!("mtllib m.mtl\n{TRI}usemtl a\nf 1 2 3\n");
    let mtl = b"newmtl a\nKd nan 0 0\nKs inf 1 1\nNs -inf\nd nan\n";
    let dir = folder("mtl-nan", &[("t.obj", obj.as_bytes()), ("m.mtl", mtl)]);
    let scene = scene_with(&dir, "t.obj").unwrap();
    let a = scene.materials.iter().find(|m| m.name == "a").unwrap();
    assert!(a.kd.is_finite() && a.ks.is_finite() && a.shininess.is_finite() && a.opacity.is_finite());
    assert_eq!(scene.warnings.len(), 4, "{:?}", scene.warnings);
    for (w, n) in scene.warnings.iter().zip(2..) {
        assert!(w.contains(&format!("m.mtl:{n}:")) && w.contains("not a finite number"), "{w}");
    }
}

#[test]
fn faces_mixing_uv_and_plain_forms_warn_and_render() {
    let obj = format!("{TRI}f 1/1 2/2 3/3\nv 1 1 0\nf 2 4 3\n");
    let dir = folder("mixed", &[("t.obj", obj.as_bytes())]);
    let scene = scene_with(&dir, "t.obj").unwrap();
    assert_eq!(scene.prims.triangles.len(), 2);
    assert!(scene.triangle_shading.iter().all(|t| !t.has_uvs));
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(scene.warnings[0].contains("t.obj:9: faces with and without texture coordinates"), "{:?}", scene.warnings);
    common::render_image(&scene);
}

#[test]
fn texture_and_normal_index_zero_is_an_error_naming_the_line() {
    for (face, what) in [("f 1/0 2/2 3/3", "texture coordinate index 0"), ("f 1//0 2//1 3//1", "normal index 0")] {
        let obj = format!("{TRI}vn 0 0 1\n{face}\n");
        let dir = folder("index0", &[("t.obj", obj.as_bytes())]);
        for content in [Content::Geometry, Content::WithMaterials] {
            let e = load_mesh(&dir.join("t.obj"), content).unwrap_err().to_string();
            assert!(e.contains("t.obj:8:") && e.contains(what), "{e}");
        }
    }
}

#[test]
fn geometry_commands_never_open_the_material_library() {
    // The library is a folder: reading it fails, so any attempt would show as a warning.
    let obj = format!("mtllib lib.mtl\n{TRI}usemtl a\nf 1 2 3\n");
    let dir = folder("geometry-only", &[("t.obj", obj.as_bytes())]);
    std::fs::create_dir_all(dir.join("lib.mtl")).unwrap();
    let m = load_mesh(&dir.join("t.obj"), Content::Geometry).unwrap();
    assert!(m.warnings.is_empty() && m.materials.is_empty(), "{:?}", m.warnings);
    let m = load_mesh(&dir.join("t.obj"), Content::WithMaterials).unwrap();
    assert_eq!(m.indices.len(), 1);
    assert!(
        m.warnings[0].contains("t.obj:1: mtllib 'lib.mtl'") && m.warnings[0].contains("default material"),
        "{:?}",
        m.warnings
    );
}

#[test]
fn latin1_names_match_between_obj_and_mtl() {
    let mut obj = b"mtllib m.mtl\n".to_vec();
    obj.extend_from_slice(TRI.as_bytes());
    obj.extend_from_slice(b"usemtl Caf\xe9 cr\xe8me\nf 1/1 2/2 3/3\n");
    let dir = folder("latin1", &[("t.obj", &obj), ("m.mtl", b"newmtl Caf\xe9 cr\xe8me\r\nKd 1 0 0\r\n")]);
    let scene = scene_with(&dir, "t.obj").unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let m = &scene.materials[scene.triangle_shading[0].material as usize];
    assert_eq!((m.name.as_str(), m.kd), ("Caf\u{e9} cr\u{e8}me", glam::Vec3::X));
}

fn png(w: u32) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbImage::from_pixel(w, w, image::Rgb([200, 10, 10])).write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

#[test]
fn textures_with_windows_separators_and_quotes_resolve_beside_the_mtl() {
    let obj = format!("mtllib mat\\m.mtl\n{TRI}usemtl a\nf 1/1 2/2 3/3\n");
    let mtl = b"newmtl a\nmap_Kd -s 1 1 1 \"..\\tex\\red.png\"\n";
    let dir = folder("winpath", &[("t.obj", obj.as_bytes()), ("mat/m.mtl", mtl), ("tex/red.png", &png(4))]);
    let scene = scene_with(&dir, "t.obj").unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert!(scene.materials.iter().any(|m| m.name == "a" && m.kd_texture.is_some()));
}

#[test]
fn a_texture_that_does_not_exist_names_the_mtl_line_and_the_paths_tried() {
    let obj = format!("mtllib m.mtl\n{TRI}usemtl a\nf 1/1 2/2 3/3\n");
    let dir =
        folder("missing-tex", &[("t.obj", obj.as_bytes()), ("m.mtl", b"newmtl a\nKd 1 1 1\nmap_Kd .\\gone\\x.png\n")]);
    let e = scene_with(&dir, "t.obj").unwrap_err().to_string();
    assert!(e.contains("m.mtl:3: map_Kd '.\\gone\\x.png'"), "{e}");
    assert!(
        e.contains(&dir.join("./gone/x.png").display().to_string())
            && e.contains(&dir.join("x.png").display().to_string()),
        "{e}"
    );
    // Geometry never looks at it.
    assert!(load_mesh(&dir.join("t.obj"), Content::Geometry).is_ok());
}

#[test]
fn cli_reports_a_bad_number_with_line_and_exit_1() {
    let dir = folder("cli-number", &[("n.obj.gz", &gzip(b"v 0 0 0\nv 1 0 0\nv 0 1 3.1+e2\nf 1 2 3\n"))]);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .arg("bvh-stats")
        .arg(dir.join("n.obj.gz"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("n.obj.gz:3: '3.1+e2' is not a number") && !err.contains("panicked"), "{err}");
}
