//! Property-based tests (proptest) of the loaders and the flag parser on
//! hostile values: whatever the input, a loader returns a value or an error
//! naming its file, and never panics; what it accepts is finite and within
//! the limits of `rtdiff::limits`.

mod common;

use std::path::Path;

use clap::Args;
use proptest::prelude::*;
use rtdiff::limits;

/// Floats as a hostile file gives them: ordinary, zero, huge, tiny, infinite, NaN.
fn hostile_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -10.0f32..10.0,
        1 => Just(0.0f32),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::NAN),
        1 => Just(1e38f32),
        1 => Just(3.4e38f32),
        1 => Just(-1e13f32),
        1 => Just(1e-45f32),
        1 => any::<f32>(),
    ]
}

/// JSON text of a float (JSON has no NaN or infinity: they become 1e39 / -1e39 / a string).
fn json_f32(v: f32) -> String {
    if v.is_nan() {
        "\"NaN\"".into()
    } else if v == f32::INFINITY {
        "1e39".into()
    } else if v == f32::NEG_INFINITY {
        "-1e39".into()
    } else {
        format!("{v:e}")
    }
}

fn vec3() -> impl Strategy<Value = String> {
    (hostile_f32(), hostile_f32(), hostile_f32())
        .prop_map(|(a, b, c)| format!("[{}, {}, {}]", json_f32(a), json_f32(b), json_f32(c)))
}

fn count() -> impl Strategy<Value = i64> {
    prop_oneof![4 => 0i64..8, 1 => Just(-1i64), 1 => Just(4_294_967_296i64), 1 => Just(65_537i64), 1 => Just(16_385i64), 1 => any::<i64>()]
}

fn scene_json() -> impl Strategy<Value = String> {
    (
        (vec3(), vec3(), vec3(), hostile_f32(), hostile_f32()),
        (count(), count(), count(), count(), count(), count()),
        (vec3(), vec3(), hostile_f32(), vec3(), vec3(), vec3()),
        (hostile_f32(), hostile_f32(), any::<bool>(), any::<bool>()),
    )
        .prop_map(|((pos, look, up, fov, ap), (w, h, spp, depth, ls, gs), (sc, sr, rad, lp, lc, tr), (ks, sh, bloom, glossy))| {
            format!(
                r#"{{ "camera": {{ "position": {pos}, "look_at": {look}, "up": {up}, "fov": {}, "aperture": {} }},
                    "image": {{ "width": {w}, "height": {h}, "spp": {spp} }},
                    "features": {{ "bloom": {bloom}, "glossy": {glossy}, "depth_of_field": true }},
                    "params": {{ "max_depth": {depth}, "light_samples": {ls}, "glossy_samples": {gs}, "dof_samples": 1,
                                 "bloom": {{ "kernel_size": {}, "scale": {} }} }},
                    "materials": {{ "m": {{ "ks": [{}, 0.5, 0.5], "shininess": {} }} }},
                    "meshes": [ {{ "file": "t.obj", "material": "m", "transform": {{ "translate": {tr}, "scale": {sc} }} }} ],
                    "spheres": [ {{ "center": {sr}, "radius": {} }} ],
                    "lights": [ {{ "type": "point", "position": {lp}, "color": {lc} }} ] }}"#,
                json_f32(fov), json_f32(ap), json_f32(ks.abs()), json_f32(sh.abs()), json_f32(ks), json_f32(sh),
                json_f32(rad),
            )
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

    #[test]
    fn scene_loader_never_panics_and_accepts_only_bounded_numbers(json in scene_json()) {
        let d = common::temp_dir("prop-scene");
        common::write(&d, "t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        let s = common::write(&d, "s.json", &json);
        match rtdiff::scene::Scene::load(&s) {
            Ok(scene) => {
                prop_assert!(scene.width <= limits::MAX_IMAGE_SIDE && scene.height <= limits::MAX_IMAGE_SIDE);
                prop_assert!(scene.spp >= 1 && scene.spp <= limits::MAX_SPP);
                prop_assert!(scene.params.max_depth <= limits::MAX_DEPTH);
                prop_assert!(scene.camera.position.is_finite());
                for t in &scene.prims.triangles {
                    for v in t.v {
                        prop_assert!(v.is_finite() && v.abs().max_element() <= limits::MAX_COORDINATE);
                    }
                }
                for sp in &scene.prims.spheres {
                    prop_assert!(sp.center.is_finite() && sp.radius > 0.0 && sp.radius <= limits::MAX_COORDINATE);
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("s.json"), "{}", e),
        }
    }

    #[test]
    fn scene_parser_never_panics_on_arbitrary_text(text in ".{0,400}") {
        if let Err(e) = rtdiff::scene::validate::parse_scene(Path::new("x.json"), &text) {
            prop_assert!(e.to_string().contains("x.json"));
        }
    }

    #[test]
    fn ray_csv_parser_accepts_only_finite_bounded_rays(
        fields in proptest::collection::vec(hostile_f32(), 8),
        junk in "[0-9a-z.,e+-]{0,30}",
    ) {
        let line = fields.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(",");
        let text = format!("{line}\n{junk}\n");
        match rtdiff::rays::file::parse_rays(Path::new("r.csv"), &text) {
            Ok(rays) => {
                for r in rays {
                    prop_assert!(r.origin.is_finite() && r.dir.is_finite() && r.dir != glam::Vec3::ZERO);
                    prop_assert!(r.origin.abs().max_element() <= limits::MAX_COORDINATE);
                    prop_assert!(r.t_min >= 0.0 && r.t_min <= r.t_max);
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("r.csv") && e.to_string().contains("line")),
        }
    }

    #[test]
    fn texture_loader_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..200), w in any::<u32>(), h in any::<u32>()) {
        // A PNG signature and IHDR with a hostile size, then random bytes.
        let mut png = vec![0x89, b'P', b'N', b'G', 13, 10, 26, 10, 0, 0, 0, 13, b'I', b'H', b'D', b'R'];
        png.extend(w.to_be_bytes());
        png.extend(h.to_be_bytes());
        png.extend([8, 2, 0, 0, 0, 0, 0, 0, 0]);
        png.extend(bytes);
        let d = common::temp_dir("prop-texture");
        let p = d.join("t.png");
        std::fs::write(&p, &png).unwrap();
        match rtdiff::texture::Texture::load(&p, false) {
            Ok(t) => prop_assert!(t.width <= limits::MAX_TEXTURE_SIDE && t.height <= limits::MAX_TEXTURE_SIDE),
            Err(e) => prop_assert!(e.to_string().contains("t.png")),
        }
    }

    #[test]
    fn obj_loader_never_panics(lines in proptest::collection::vec(
        prop_oneof![
            (hostile_f32(), hostile_f32(), hostile_f32()).prop_map(|(a, b, c)| format!("v {a} {b} {c}")),
            (hostile_f32(), hostile_f32()).prop_map(|(a, b)| format!("vt {a} {b}")),
            (-3i64..6, -3i64..6, -3i64..6).prop_map(|(a, b, c)| format!("f {a} {b} {c}")),
            (-1i64..4, -1i64..4, -1i64..4).prop_map(|(a, b, c)| format!("f {a}/{b}/{c} {b}/{c}/{a} {c}/{a}/{b}")),
            "[a-z0-9 ./-]{0,20}",
        ],
        0..12,
    )) {
        let d = common::temp_dir("prop-obj");
        let p = d.join("m.obj");
        std::fs::write(&p, lines.join("\n")).unwrap();
        match rtdiff::mesh::load_mesh(&p, rtdiff::mesh::Content::WithMaterials) {
            Ok(m) => prop_assert!(m.positions.iter().all(|v| v.is_finite())),
            Err(e) => prop_assert!(e.to_string().contains("m.obj"), "{}", e),
        }
    }

    #[test]
    fn render_flags_never_panic(args in proptest::collection::vec(
        prop_oneof![
            Just("--width".to_string()), Just("--height".to_string()), Just("--spp".to_string()),
            Just("--threads".to_string()), Just("--seed".to_string()), Just("--feature".to_string()),
            "-?[0-9]{1,25}", "[a-z=_]{0,12}",
        ],
        0..8,
    )) {
        let cmd = rtdiff::cli::render::RenderArgs::augment_args(clap::Command::new("render").no_binary_name(true));
        let mut argv = vec!["s.json".to_string(), "-o".into(), "o.png".into()];
        argv.extend(args);
        if let Ok(m) = cmd.try_get_matches_from(&argv) {
            let a = <rtdiff::cli::render::RenderArgs as clap::FromArgMatches>::from_arg_matches(&m).unwrap();
            prop_assert!(a.image.width.is_none_or(|w| (1..=limits::MAX_IMAGE_SIDE).contains(&w)));
            prop_assert!(a.image.spp.is_none_or(|s| (1..=limits::MAX_SPP).contains(&s)));
            prop_assert!(a.threads.is_none_or(|t| (1..=limits::MAX_THREADS).contains(&t)));
            let _ = a.overrides();
        }
    }
}
