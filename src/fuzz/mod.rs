//! Hostile-input fuzzing through the library, in-process.
//!
//! Input number `i` of seed `s` is rebuilt exactly by [`generate`] from the
//! corpus of real files (the scenes, OBJ, glTF, GLB and STL meshes, MTL files and texture in
//! `scenes/`, a ray CSV and the command-line flags): first a truncation of
//! every base file at every byte, then random mutations ([`mutate`]).
//! [`Runner::run`] feeds one input to the loader the product uses (scene,
//! OBJ + MTL, glTF, GLB, STL, texture, ray CSV, clap's flag parser) and, when it is accepted
//! and cheap, on through the BVH build, a tiny render, a trace or a parity
//! run. A refusal must carry a message naming the file; a panic is caught by
//! the caller (`examples/fuzz_inputs.rs` runs the inputs in a supervised child
//! process with a time limit and an allocation cap, and spawns the `rtdiff`
//! binary for a sample).

pub mod mutate;

use std::path::{Path, PathBuf};

use clap::{Args, FromArgMatches};

use crate::accel::Tracer;
use crate::backends::{AccelConfig, build_tracer};
use crate::error::{Error, Result};
use crate::rng::{Pcg32, mix64};
use crate::scene::{Overrides, Scene};

/// What an input feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    /// A scene JSON file.
    Scene,
    /// A Wavefront OBJ file (with the original MTL beside it).
    Obj,
    /// An MTL file (with the original OBJ that uses it).
    Mtl,
    /// A PNG texture.
    Texture,
    /// A glTF 2.0 JSON file (its buffer a data URI, its texture the PNG beside it).
    Gltf,
    /// A binary glTF (GLB) file with its texture inside.
    Glb,
    /// An STL file (binary or ASCII).
    Stl,
    /// A ray CSV file for `rtdiff trace`.
    Rays,
    /// Command-line flags of a subcommand.
    Flags,
}

impl Kind {
    /// Every kind, in report order.
    pub const ALL: [Kind; 9] =
        [Kind::Scene, Kind::Obj, Kind::Mtl, Kind::Texture, Kind::Gltf, Kind::Glb, Kind::Stl, Kind::Rays, Kind::Flags];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Scene => "scene",
            Kind::Obj => "obj",
            Kind::Mtl => "mtl",
            Kind::Texture => "texture",
            Kind::Gltf => "gltf",
            Kind::Glb => "glb",
            Kind::Stl => "stl",
            Kind::Rays => "rays",
            Kind::Flags => "flags",
        }
    }

    /// File name the input is written to inside the runner's folder.
    pub fn file_name(self) -> &'static str {
        match self {
            Kind::Scene => "scene.json",
            Kind::Obj => "mesh.obj",
            Kind::Mtl => "mesh.mtl",
            Kind::Texture => "texture.png",
            Kind::Gltf => "mesh.gltf",
            Kind::Glb => "mesh.glb",
            Kind::Stl => "mesh.stl",
            Kind::Rays => "rays.csv",
            Kind::Flags => "flags.txt",
        }
    }
}

/// One hostile input.
#[derive(Clone, Debug)]
pub struct Input {
    /// What it feeds.
    pub kind: Kind,
    /// The base file it was made from.
    pub base: String,
    /// How it was made from the base.
    pub how: String,
    /// The file's bytes (for [`Kind::Flags`], the arguments joined by newlines).
    pub bytes: Vec<u8>,
}

impl Input {
    /// The arguments of a [`Kind::Flags`] input.
    pub fn args(&self) -> Vec<String> {
        String::from_utf8_lossy(&self.bytes).split('\n').map(str::to_string).collect()
    }
}

/// The real files inputs are made from.
#[derive(Clone, Debug)]
pub struct Corpus {
    /// `(name, bytes)` of each base file, by kind.
    pub files: Vec<(Kind, String, Vec<u8>)>,
}

/// Scenes whose meshes live in `scenes/meshes` (the others need fetched assets).
pub const SCENES: [&str; 7] = [
    "single_triangle.json",
    "cube.json",
    "cube_textured.json",
    "cornell_box.json",
    "cornell_box_parallelogram_light.json",
    "spheres.json",
    "all_features.json",
];

/// The base ray file: a camera ray, a grazing one, a ray with `inf` far bound, one from inside the box.
pub const BASE_RAYS: &str = "ox,oy,oz,dx,dy,dz,tnear,tfar\n0,0,-3,0,0,1,0,inf\n0.5,0.5,-3,0,0,1,0,100\n\
-3,0.5,0,1,0,0,0.001,inf\n0,0,0,0.3,-1,0.2,0,1e30\n";

impl Corpus {
    /// Read the base files from the repository root `root`.
    pub fn load(root: &Path) -> Result<Self> {
        let read = |p: PathBuf| std::fs::read(&p).map_err(|e| Error::io(&p, &e));
        let mut files = Vec::new();
        for s in SCENES {
            files.push((Kind::Scene, format!("scenes/{s}"), read(root.join("scenes").join(s))?));
        }
        for m in ["cornell_box.obj", "cube_textured.obj", "single_triangle.obj", "icosphere.obj"] {
            files.push((Kind::Obj, format!("scenes/meshes/{m}"), read(root.join("scenes/meshes").join(m))?));
        }
        for m in ["cornell_box.mtl", "cube_textured.mtl"] {
            files.push((Kind::Mtl, format!("scenes/meshes/{m}"), read(root.join("scenes/meshes").join(m))?));
        }
        let png = "scenes/meshes/cube_texture.png";
        files.push((Kind::Texture, png.into(), read(root.join(png))?));
        for (kind, m) in [
            (Kind::Gltf, "cube_textured.gltf"),
            (Kind::Glb, "cube_textured.glb"),
            (Kind::Stl, "cube.stl"),
            (Kind::Stl, "cube_ascii.stl"),
        ] {
            files.push((kind, format!("scenes/meshes/{m}"), read(root.join("scenes/meshes").join(m))?));
        }
        files.push((Kind::Rays, "rays.csv".into(), BASE_RAYS.as_bytes().to_vec()));
        Ok(Self { files })
    }

    /// Number of systematic truncations (every byte of every base file).
    pub fn truncations(&self) -> u64 {
        self.files.iter().map(|f| f.2.len() as u64 + 1).sum()
    }

    fn of_kind(&self, kind: Kind, rng: &mut Pcg32) -> &(Kind, String, Vec<u8>) {
        let v: Vec<_> = self.files.iter().filter(|f| f.0 == kind).collect();
        v[rng.below(v.len() as u32) as usize]
    }
}

/// Values tried for numeric flags: usual, zero, negative, at and past limits, huge, not a number.
const FLAG_VALUES: [&str; 16] = [
    "1",
    "2",
    "3",
    "0",
    "-1",
    "16384",
    "16385",
    "65536",
    "65537",
    "1024",
    "1025",
    "16777216",
    "16777217",
    "99999999999999999999",
    "1e3",
    "x",
];

fn flags_input(rng: &mut Pcg32) -> (String, Vec<String>) {
    let pick = |rng: &mut Pcg32, v: &[&str]| v[rng.below(v.len() as u32) as usize].to_string();
    let sub = pick(rng, &["render", "render", "render", "trace", "parity", "bench", "bvh-stats", "debug"]);
    let scene = format!("scenes/{}", pick(rng, &SCENES));
    let flags: &[&str] = match sub.as_str() {
        "render" => &["--width", "--height", "--spp", "--seed", "--threads", "--feature", "--tracer", "--builder"],
        "trace" => &["--rays", "--out", "--tracer"],
        "parity" => &["--count", "--sweep-count", "--examples", "--seed", "--rays", "--reference"],
        "bench" => &["--runs", "--size", "--incoherent", "--leaf-size", "--bins", "--race"],
        "bvh-stats" => &["--leaf-size", "--bins", "--builder"],
        _ => &["--pixel", "--feature"],
    };
    let mut args = vec![sub.clone(), scene];
    if sub == "render" {
        args.extend(["-o".into(), "out.png".into(), "--quiet".into()]);
    }
    for _ in 0..1 + rng.below(4) {
        let f = pick(rng, flags);
        let v = match f.as_str() {
            "--feature" => format!(
                "{}={}",
                pick(rng, &["bloom", "glossy", "depth_of_field", "nope", ""]),
                pick(rng, &["on", "off", "maybe"])
            ),
            "--tracer" | "--reference" => pick(rng, &["native", "brute", "embree", "gpu"]),
            "--builder" => pick(rng, &["median", "sah", "sah-volume", "x"]),
            "--rays" if sub == "parity" => pick(rng, &["all", "primary", "edges", "bogus"]),
            "--rays" | "--out" => pick(rng, &["rays.csv", "", "/nonexistent/x.csv"]),
            _ => pick(rng, &FLAG_VALUES),
        };
        args.push(f.clone());
        args.push(v);
        if f == "--pixel" {
            args.push(pick(rng, &FLAG_VALUES));
        }
    }
    (sub, args)
}

/// Input `index` of `seed`: deterministic, so any failure can be replayed.
pub fn generate(corpus: &Corpus, seed: u64, index: u64) -> Input {
    let trunc = corpus.truncations();
    if index < trunc {
        let mut i = index;
        for (kind, name, bytes) in &corpus.files {
            if i <= bytes.len() as u64 {
                return Input {
                    kind: *kind,
                    base: name.clone(),
                    how: format!("truncated at byte {i}"),
                    bytes: bytes[..i as usize].to_vec(),
                };
            }
            i -= bytes.len() as u64 + 1;
        }
    }
    let mut rng = Pcg32::new(mix64(seed), index);
    let r = rng.below(100);
    let kind = match r {
        0..34 => Kind::Scene,
        34..42 => Kind::Obj,
        42..48 => Kind::Mtl,
        48..54 => Kind::Texture,
        54..59 => Kind::Gltf,
        59..62 => Kind::Glb,
        62..66 => Kind::Stl,
        66..80 => Kind::Rays,
        _ => Kind::Flags,
    };
    if kind == Kind::Flags {
        let (sub, args) = flags_input(&mut rng);
        return Input { kind, base: sub, how: "random flags".into(), bytes: args.join("\n").into_bytes() };
    }
    let (_, base, bytes) = corpus.of_kind(kind, &mut rng);
    let mut b = bytes.clone();
    let how = if kind == Kind::Texture && rng.below(4) == 0 {
        huge_png_header(&mut b, &mut rng)
    } else if matches!(kind, Kind::Scene | Kind::Gltf) && rng.below(2) == 0 {
        mutate::json(&mut b, &mut rng)
    } else {
        mutate::bytes(&mut b, &mut rng)
    };
    Input { kind, base: base.clone(), how, bytes: b }
}

/// CRC-32 (IEEE) of `data`, for PNG chunks.
fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in data {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// Rewrite the IHDR of a PNG with a large width and height and a valid CRC,
/// so the decoder believes the size.
fn huge_png_header(b: &mut [u8], rng: &mut Pcg32) -> String {
    const SIZES: [u32; 6] = [16_384, 16_385, 65_535, 1 << 20, 0x7fff_ffff, 0];
    let (w, h) = (SIZES[rng.below(6) as usize], SIZES[rng.below(6) as usize]);
    if b.len() < 33 || &b[12..16] != b"IHDR" {
        return "not a PNG".into();
    }
    b[16..20].copy_from_slice(&w.to_be_bytes());
    b[20..24].copy_from_slice(&h.to_be_bytes());
    let crc = crc32(&b[12..29]);
    b[29..33].copy_from_slice(&crc.to_be_bytes());
    format!("IHDR size set to {w}x{h}")
}

/// What became of an input.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// Loaded (and, when `ran`, built, rendered or traced).
    Accepted {
        /// Whether the input was also run past loading.
        ran: bool,
    },
    /// Refused with this message.
    Refused(String),
}

/// Largest worst-case ray count of a render the fuzzer performs on a
/// 3x3 image (others are validated only).
pub const RENDER_BUDGET: f64 = 50_000.0;

/// Runs inputs through the library inside a scratch folder.
pub struct Runner {
    /// Repository root (holds `scenes/`).
    pub root: PathBuf,
    /// Scratch folder (a copy of `scenes/meshes` lives in `meshes/`).
    pub dir: PathBuf,
    tracer: Box<dyn Tracer>,
}

impl Runner {
    /// A runner over the repository at `root`, writing into `dir`.
    pub fn new(root: &Path, dir: &Path) -> Result<Self> {
        let meshes = dir.join("meshes");
        std::fs::create_dir_all(&meshes).map_err(|e| Error::io(&meshes, &e))?;
        let src = root.join("scenes/meshes");
        for e in std::fs::read_dir(&src).map_err(|e| Error::io(&src, &e))?.flatten() {
            let to = meshes.join(e.file_name());
            std::fs::copy(e.path(), &to).map_err(|err| Error::io(&to, &err))?;
        }
        let scene = Scene::load(&root.join("scenes/cornell_box.json"))?;
        let tracer = build_tracer(scene.prims.clone(), &AccelConfig::default())?;
        Ok(Self { root: root.to_path_buf(), dir: dir.to_path_buf(), tracer })
    }

    /// Path an input of `kind` is written to.
    pub fn path_of(&self, kind: Kind) -> PathBuf {
        match kind {
            Kind::Obj | Kind::Mtl | Kind::Gltf | Kind::Glb | Kind::Stl => {
                self.dir.join("meshes").join(kind.file_name())
            }
            _ => self.dir.join(kind.file_name()),
        }
    }

    /// Write `input` where the loaders will read it (and, for OBJ/MTL, its partner file).
    pub fn stage(&self, input: &Input) -> Result<PathBuf> {
        let path = self.path_of(input.kind);
        let write = |p: &Path, b: &[u8]| std::fs::write(p, b).map_err(|e| Error::io(p, &e));
        let base_of = |ext: &str| -> Result<Vec<u8>> {
            let stem = Path::new(&input.base).file_stem().and_then(|s| s.to_str()).unwrap_or("cornell_box");
            let p = self.root.join("scenes/meshes").join(format!("{stem}.{ext}"));
            Ok(std::fs::read(&p).unwrap_or_default())
        };
        match input.kind {
            Kind::Obj => {
                write(&path, &rename_mtllib(&input.bytes))?;
                write(&self.path_of(Kind::Mtl), &base_of("mtl")?)?;
            }
            Kind::Mtl => {
                write(&path, &input.bytes)?;
                write(&self.path_of(Kind::Obj), &rename_mtllib(&base_of("obj")?))?;
            }
            Kind::Flags => {}
            _ => write(&path, &input.bytes)?,
        }
        Ok(path)
    }

    /// Run one input; `Err` is an input handled badly (a refusal whose message
    /// does not name the file, or an accepted input that fails later).
    pub fn run(&self, input: &Input) -> std::result::Result<Outcome, String> {
        self.run_with(input, true)
    }

    /// [`Runner::run`]; with `deep` false, an accepted input is only loaded
    /// (validated), not built, rendered, traced or run through parity.
    pub fn run_with(&self, input: &Input, deep: bool) -> std::result::Result<Outcome, String> {
        let path = self.stage(input).map_err(|e| format!("cannot stage the input: {e}"))?;
        let result = match input.kind {
            Kind::Scene if !deep => Scene::load(&path).map(|_| Outcome::Accepted { ran: false }),
            Kind::Scene => self.scene(&path, &Overrides::default(), None),
            Kind::Obj | Kind::Mtl if !deep => {
                crate::mesh::load_mesh(&self.path_of(Kind::Obj), crate::mesh::Content::WithMaterials)
                    .map(|_| Outcome::Accepted { ran: false })
            }
            Kind::Obj | Kind::Mtl => self.mesh(&self.path_of(Kind::Obj)),
            Kind::Gltf | Kind::Glb | Kind::Stl if !deep => {
                crate::mesh::load_mesh(&path, crate::mesh::Content::WithMaterials)
                    .map(|_| Outcome::Accepted { ran: false })
            }
            Kind::Gltf | Kind::Glb | Kind::Stl => self.mesh(&path),
            Kind::Texture => crate::texture::Texture::load(&path, false).map(|_| Outcome::Accepted { ran: false }),
            Kind::Rays => self.rays(&path),
            Kind::Flags => return self.flags(&input.args(), deep),
        };
        match result {
            Ok(o) => Ok(o),
            Err(e) => {
                let msg = e.to_string();
                let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
                let named = msg.contains(name) || (input.kind == Kind::Mtl && msg.contains(".mtl"));
                if msg.trim().is_empty() || !named {
                    Err(format!("message does not name {name}: {msg:?}"))
                } else {
                    Ok(Outcome::Refused(msg))
                }
            }
        }
    }

    fn scene(&self, path: &Path, ov: &Overrides, threads: Option<usize>) -> Result<Outcome> {
        let mut scene = Scene::load_with(path, ov)?;
        crate::scene::validate::check_render_work(&scene)?;
        let tracer = build_tracer(scene.prims.clone(), &scene.accel)?;
        // Render a 3x3 corner of the camera's view when the scene is cheap at that size.
        scene.width = scene.width.min(3);
        scene.height = scene.height.min(3);
        scene.camera.width = scene.width;
        scene.camera.height = scene.height;
        if crate::scene::validate::worst_case_rays(&scene) > RENDER_BUDGET {
            return Ok(Outcome::Accepted { ran: false });
        }
        crate::pipeline::render_with(&scene, tracer.as_ref(), &crate::render::RenderOptions { threads, quiet: true })?;
        Ok(Outcome::Accepted { ran: true })
    }

    fn mesh(&self, path: &Path) -> Result<Outcome> {
        // As `render` loads it (materials and their textures, embedded ones included), then as
        // `parity` does.
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        let json = format!(
            r#"{{ "image": {{ "width": 3, "height": 3 }}, "features": {{ "texture_mapping": true }},
                 "meshes": [ {{ "file": "{name}", "normalize": true }} ] }}"#
        );
        let scene = path.with_file_name("mesh_scene.json");
        std::fs::write(&scene, json).map_err(|e| Error::io(&scene, &e))?;
        self.scene(&scene, &Overrides::default(), None)?;
        let ctx = crate::rays::load_context(path)?;
        let opts = crate::verify::hits::ParityOptions {
            sets: crate::rays::SetKind::ALL.to_vec(),
            count: 16,
            seed: 1,
            reference: crate::verify::hits::Reference::Brute,
            stress: false,
            max_examples: 0,
            arbiter: true,
            sweep_count: None,
            variants: vec![AccelConfig::default()],
        };
        crate::verify::hits::run(&ctx, &opts)?;
        Ok(Outcome::Accepted { ran: true })
    }

    fn rays(&self, path: &Path) -> Result<Outcome> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, &e))?;
        let rays = crate::rays::file::parse_rays(path, &text)?;
        for r in rays.iter().take(10_000) {
            let _ = self.tracer.intersect(r);
            let _ = self.tracer.occluded(r);
        }
        Ok(Outcome::Accepted { ran: true })
    }

    fn flags(&self, args: &[String], deep: bool) -> std::result::Result<Outcome, String> {
        let sub = args.first().cloned().unwrap_or_default();
        let cmd = clap::Command::new("rtdiff").no_binary_name(true);
        let parsed = match sub.as_str() {
            "render" => crate::cli::render::RenderArgs::augment_args(cmd.clone()).try_get_matches_from(&args[1..]),
            "trace" => crate::cli::trace::TraceArgs::augment_args(cmd.clone()).try_get_matches_from(&args[1..]),
            "parity" => crate::cli::parity::ParityArgs::augment_args(cmd.clone()).try_get_matches_from(&args[1..]),
            "bench" => crate::cli::bench::BenchArgs::augment_args(cmd.clone()).try_get_matches_from(&args[1..]),
            "bvh-stats" => {
                crate::cli::bvh_stats::BvhStatsArgs::augment_args(cmd.clone()).try_get_matches_from(&args[1..])
            }
            _ => crate::cli::debug::DebugArgs::augment_args(cmd.clone()).try_get_matches_from(&args[1..]),
        };
        let m = match parsed {
            Ok(m) => m,
            Err(e) => {
                let msg = e.to_string();
                return if msg.trim().is_empty() {
                    Err("clap gave an empty message".into())
                } else {
                    Ok(Outcome::Refused(msg))
                };
            }
        };
        if sub != "render" || !deep {
            return Ok(Outcome::Accepted { ran: false });
        }
        let a = crate::cli::render::RenderArgs::from_arg_matches(&m).map_err(|e| e.to_string())?;
        let scene = self.root.join(&a.scene);
        let outcome = a.overrides().and_then(|ov| self.scene(&scene, &ov, a.threads));
        match outcome {
            Ok(o) => Ok(o),
            Err(e) => {
                let msg = e.to_string();
                if msg.trim().is_empty() { Err("empty message".into()) } else { Ok(Outcome::Refused(msg)) }
            }
        }
    }
}

/// Point an OBJ's `mtllib` at the staged `mesh.mtl`.
fn rename_mtllib(obj: &[u8]) -> Vec<u8> {
    let text = String::from_utf8_lossy(obj);
    if !text.contains("mtllib") || std::str::from_utf8(obj).is_err() {
        return obj.to_vec();
    }
    text.lines()
        .map(|l| if l.trim_start().starts_with("mtllib ") { "mtllib mesh.mtl".to_string() } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n")
        .into_bytes()
}
