//! Every upper limit on a number that comes from a file or a flag, in one
//! place. Each is checked before any work starts (scene validation in
//! [`crate::scene::validate`], the subcommands' flags in [`crate::cli`]), named
//! in the error when it is exceeded, listed by `--help` and documented in
//! docs/scene-format.md ("Limits"). An input at a limit works; one past it is
//! refused with a message naming the file or flag, the field and the limit.

/// Largest image width or height in pixels (`image.width`, `image.height`,
/// `--width`, `--height`, `bench --size`).
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// Largest number of pixels in one image (`width * height`): 2^25, e.g.
/// 8192 x 4096. A render holds about seven float RGB copies of the image
/// (film, bloom stages, output), 12 bytes a pixel each: 2.8 GB at this limit.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 25;

/// Largest number of camera samples per pixel (`image.spp`, `--spp`).
pub const MAX_SPP: u32 = 65_536;

/// Largest number of samples per area light, glossy rays and lens samples
/// (`params.light_samples`, `params.glossy_samples`, `params.dof_samples`).
pub const MAX_FEATURE_SAMPLES: u32 = 4_096;

/// Largest recursion depth (`params.max_depth`). The integrator recurses once
/// per bounce, so this also bounds its stack use: a closed mirror box at this
/// depth renders; a larger value is refused instead of overflowing the stack.
pub const MAX_DEPTH: u32 = 64;

/// Largest worst-case number of rays one render may need: pixels x spp x lens
/// samples x the ray tree per camera ray (glossy split at the first bounce,
/// doubling per level where a material both reflects and transmits) x (1 +
/// shadow rays per hit). 2^40 rays is about 15 hours at 20 Mrays/s; a scene
/// past it would never finish and is refused with the estimate.
pub const MAX_RENDER_RAYS: f64 = 1_099_511_627_776.0;

/// Largest bloom kernel width in pixels (`params.bloom.kernel_size`): the blur
/// costs `2 * kernel_size` multiply-adds a pixel.
pub const MAX_BLOOM_KERNEL: f32 = 1_024.0;

/// Largest absolute value of any coordinate, distance or radius in a scene
/// (camera, lights, spheres, mesh transforms and the vertices after them).
/// Products of three coordinates (ray/triangle determinants) and box areas
/// times primitive counts (the SAH costs) stay finite in `f32` below it:
/// (2e12)^3 = 8e36 < 3.4e38.
pub const MAX_COORDINATE: f32 = 1.0e12;

/// Smallest sphere radius relative to the largest absolute coordinate of its
/// centre, 2^-20: at least 8 to 16 units in the last place of that
/// coordinate in `f32`. Below it the sphere's surface points cannot be told
/// from its centre (a radius of 0.75 at z = 4.29e9, where one unit in the
/// last place is 512), the hit point's rounding error exceeds the radius and
/// shading and secondary rays are noise; a sphere at the ratio renders, with
/// visibly quantised shading. Spheres near the origin are unaffected.
pub const MIN_SPHERE_RADIUS_RELATIVE: f32 = 1.0 / 1_048_576.0;

/// Largest absolute value of a colour or intensity component (material `kd`,
/// `ks`, light colours, background, bloom scale): sums of millions of
/// samples stay finite in `f32`.
pub const MAX_COLOR: f32 = 1.0e12;

/// Largest Phong exponent (`shininess`, MTL `Ns`).
pub const MAX_SHININESS: f32 = 1.0e6;

/// Largest absolute rotation angle in degrees (`transform.rotate`).
pub const MAX_ROTATION_DEGREES: f32 = 1.0e6;

/// Largest number of meshes, spheres, lights or materials in one scene file.
pub const MAX_SCENE_ITEMS: usize = 65_536;

/// Largest number of primitives (triangles and spheres) in one scene or mesh
/// file, 2^26 (77 times the full Stanford dragon): about 300 bytes each
/// once loaded and built (triangle, shading data, BVH), 20 GB at the limit.
/// Primitive ids are `u32`; this keeps them, and Embree's `3 * triangles`
/// vertex indices, far from overflowing. Checked as each mesh is added,
/// before its triangles are copied into the scene.
pub const MAX_PRIMITIVES: usize = 1 << 26;

/// Largest mesh file in bytes, 4 GiB: the file on disk (checked before it is
/// read) and, for gzip files, the decompressed data (checked while
/// decompressing, so a small file that expands without end, a "gzip bomb",
/// stops at the limit).
pub const MAX_MESH_FILE_BYTES: u64 = 4 << 30;

/// Largest scene file in bytes (checked before it is read).
pub const MAX_SCENE_FILE_BYTES: u64 = 16 << 20;

/// Largest median-builder leaf size (`accel.leaf_size`, `--leaf-size`).
pub const MAX_LEAF_SIZE: usize = 1 << 20;

/// Largest number of SAH bins per axis (`accel.bins`, `--bins`); the builder's own maximum.
pub const MAX_BINS: usize = crate::bvh::build_sah::SAH_MAX_BINS;

/// Smallest number of SAH bins per axis.
pub const MIN_BINS: usize = 2;

/// Largest texture width or height in texels (checked from the file's header, before decoding).
pub const MAX_TEXTURE_SIDE: u32 = 16_384;

/// Largest texture in texels (`width * height`), 2^26: 768 MB as float RGB.
pub const MAX_TEXTURE_PIXELS: u64 = 1 << 26;

/// Largest number of rays in one set or file (`parity --count`, `--sweep-count`,
/// `bench --incoherent`, `bench --size` squared, the lines of `trace --rays`):
/// 2^24 rays, 512 MB of rays and as much again of hits.
pub const MAX_RAYS: usize = 1 << 24;

/// Largest ray CSV file in bytes (`trace --rays`, checked before it is read).
pub const MAX_RAY_FILE_BYTES: u64 = 2 << 30;

/// Largest number of worker threads (`--threads`).
pub const MAX_THREADS: usize = 1_024;

/// Largest number of timed runs or race rounds (`bench --runs`, `--race`).
pub const MAX_RUNS: usize = 10_000;

/// Largest number of disagreeing rays printed per set (`parity --examples`).
pub const MAX_EXAMPLES: usize = 10_000;

/// Largest `bench --size` (primary rays = size^2 <= [`MAX_RAYS`]).
pub const MAX_BENCH_SIZE: u32 = 4_096;

/// A clap value parser for an integer flag in `min..=max`: past the limit,
/// clap's message names the flag, the value and the range, and the exit code is 2.
pub fn ranged<T>(min: u64, max: u64) -> clap::builder::RangedU64ValueParser<T>
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
    <T as TryFrom<u64>>::Error: std::fmt::Display,
{
    clap::builder::RangedU64ValueParser::<T>::new().range(min..=max)
}

/// Check a count from a flag against `min..=max`; the error names the flag and the limit.
pub fn check_flag<T: PartialOrd + std::fmt::Display + Copy>(flag: &str, value: T, min: T, max: T) -> crate::Result<T> {
    if value < min {
        return Err(crate::Error::Invalid(format!("{flag} {value} is below the minimum {min}")));
    }
    if value > max {
        return Err(crate::Error::Invalid(format!("{flag} {value} exceeds the limit {max}")));
    }
    Ok(value)
}

/// The limits as a `--help` paragraph.
pub const HELP: &str = "Limits (an input past one is refused with a message naming it): \
image side 16384 px and 2^25 px in all; spp 65536; light/glossy/dof samples 4096; max_depth 64; \
worst-case rays per render 2^40; bloom kernel 1024 px; |coordinates| 1e12; |colours| 1e12; \
shininess 1e6; |rotation| 1e6 degrees; sphere radius at least 2^-20 of its centre's largest |coordinate|; \
65536 meshes/spheres/lights/materials; 2^26 primitives; scene file 16 MiB; mesh file 4 GiB (gzip: decompressed); \
textures 16384 px a side and 2^26 texels; rays per set or file 2^24 (file 2 GiB); bench --size 4096; \
threads 1024; runs/rounds 10000; parity --examples 10000. See docs/scene-format.md.";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn help_text_matches_the_constants() {
        for s in [
            MAX_IMAGE_SIDE.to_string(),
            MAX_SPP.to_string(),
            MAX_FEATURE_SAMPLES.to_string(),
            format!("max_depth {MAX_DEPTH}"),
            format!("kernel {}", MAX_BLOOM_KERNEL),
            format!("threads {MAX_THREADS}"),
            format!("{MAX_SCENE_ITEMS} meshes"),
        ] {
            assert!(HELP.contains(&s), "HELP lacks {s}");
        }
        assert_eq!(MAX_IMAGE_PIXELS, 1 << 25);
        assert_eq!(MAX_RAYS, 1 << 24);
        assert_eq!(MAX_RENDER_RAYS, (1u64 << 40) as f64);
        assert_eq!(MAX_TEXTURE_PIXELS, 1 << 26);
        assert_eq!(MAX_SCENE_FILE_BYTES, 16 << 20);
        assert_eq!(MAX_RAY_FILE_BYTES, 2 << 30);
        assert_eq!(MAX_PRIMITIVES, 1 << 26);
        assert_eq!(MAX_MESH_FILE_BYTES, 1 << 32);
        assert_eq!(MIN_SPHERE_RADIUS_RELATIVE, 2f32.powi(-20));
        assert!(HELP.contains("2^26 primitives") && HELP.contains("mesh file 4 GiB") && HELP.contains("2^-20"));
    }

    #[test]
    fn three_coordinate_products_stay_finite() {
        let e = 2.0 * MAX_COORDINATE;
        assert!((e * e * e).is_finite());
    }
}
