//! Conditioning of the arbiter's decisions: how far a quantity that decides a
//! ray's exact answer can move when every float32 input moves by one rounding
//! unit.
//!
//! The inputs are the ray's origin `o`, direction `d`, `t_min` and `t_max`,
//! every triangle vertex, sphere centre and radius, each a float32 taken as an
//! exact number. A *one-unit perturbation* replaces every input `x` by
//! `x (1 + delta)` with `|delta| <= u = 2^-24` (one rounding of a real number
//! to float32), each input independently; a vertex shared by several
//! triangles (bit-identical coordinates) is one input. To first order a
//! smooth quantity `q` then moves by at most `u kappa(q)`, with the
//! componentwise condition number
//!
//! `kappa(q) = sum_i |dq/dx_i| |x_i|`
//!
//! (Skeel's; the sum runs over the scalar inputs). [`Sensitivity`] holds the
//! gradient of a hit distance over the inputs, and [`edge_volume_kappa`] and
//! [`sphere_disc_kappa`] give `kappa` of the other decisive quantities; the
//! gradients are evaluated in double precision from the float32 inputs, so
//! each `kappa` carries a relative error of about `1e-12` at most, far below
//! anything the arbiter's unit threshold can see.

use glam::{DVec3, Vec3};

/// The unit roundoff of float32.
pub const U: f64 = f32::EPSILON as f64 * 0.5;

/// One scalar input other than the ray's origin and direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Input {
    /// Component `k` of a vertex, by the bits of its coordinates.
    Vertex([u32; 3], u8),
    /// Component `k` of sphere `id`'s centre.
    Centre(u32, u8),
    /// Sphere `id`'s radius.
    Radius(u32),
}

/// The gradient of a hit distance `t` over the inputs (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sensitivity {
    /// `dt/do`.
    o: DVec3,
    /// `dt/dd`.
    d: DVec3,
    /// `(input, |x|, dt/dx)` for every other input `t` depends on.
    other: Vec<(Input, f64, f64)>,
}

impl Sensitivity {
    /// `t = n.(v0 - o) / (n.d)` of a triangle with unnormalised normal `n`
    /// and `s = n.d`, at the point with barycentrics `bary` (weights of
    /// `v0, v1, v2`): `dt/do = -n / s`, `dt/dd = -t n / s`, and
    /// `dt/dv_k = bary_k n / s` (moving a vertex moves the plane at the hit
    /// point by its barycentric share of the move).
    pub fn triangle(v: &[Vec3; 3], n: DVec3, s: f64, t: f64, bary: [f64; 3]) -> Self {
        let g = n / s;
        let mut other = Vec::with_capacity(9);
        for (k, p) in v.iter().enumerate() {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            for c in 0..3 {
                push(&mut other, Input::Vertex(key, c as u8), p[c].abs() as f64, bary[k] * g[c]);
            }
        }
        Self { o: -g, d: -t * g, other }
    }

    /// The distance `t` of sphere `id` (centre `c`, radius `r`) where
    /// `g = o + t d - c` and `gd = g.d` (nonzero): from
    /// `|o + t d - c|^2 = r^2`, `dt/do = -g / gd`, `dt/dd = -t g / gd`,
    /// `dt/dc = g / gd`, `dt/dr = r / gd`.
    pub fn sphere(id: u32, c: Vec3, r: f32, t: f64, g: DVec3, gd: f64) -> Self {
        let h = g / gd;
        let mut other = Vec::with_capacity(4);
        for k in 0..3 {
            push(&mut other, Input::Centre(id, k as u8), c[k].abs() as f64, h[k]);
        }
        push(&mut other, Input::Radius(id), r.abs() as f64, r as f64 / gd);
        Self { o: -h, d: -t * h, other }
    }

    /// The gradient of `self - other` (shared inputs combined).
    pub fn minus(&self, other: &Sensitivity) -> Sensitivity {
        let mut out = self.other.clone();
        for &(k, x, g) in &other.other {
            push(&mut out, k, x, -g);
        }
        Sensitivity { o: self.o - other.o, d: self.d - other.d, other: out }
    }

    /// True when every partial derivative is exactly 0.
    pub fn is_zero(&self) -> bool {
        self.o == DVec3::ZERO && self.d == DVec3::ZERO && self.other.iter().all(|e| e.2 == 0.0)
    }

    /// `kappa` of the module docs for a ray with origin `o` and direction `d`.
    pub fn kappa(&self, o: DVec3, d: DVec3) -> f64 {
        self.o.abs().dot(o.abs()) + self.d.abs().dot(d.abs()) + self.other.iter().map(|e| e.1 * e.2.abs()).sum::<f64>()
    }
}

fn push(v: &mut Vec<(Input, f64, f64)>, key: Input, x: f64, g: f64) {
    match v.iter_mut().find(|e| e.0 == key) {
        Some(e) => e.2 += g,
        None => v.push((key, x, g)),
    }
}

/// `kappa` of the edge volume `w = d.(P x Q)`, `P = vp - o`, `Q = vq - o`
/// (the sign of a triangle's edge function): `dw/dd = P x Q`,
/// `dw/dvp = Q x d`, `dw/dvq = d x P`, `dw/do = d x (vq - vp)`.
pub fn edge_volume_kappa(o: DVec3, d: DVec3, vp: Vec3, vq: Vec3) -> f64 {
    let (vp, vq) = (vp.as_dvec3(), vq.as_dvec3());
    let (p, q) = (vp - o, vq - o);
    p.cross(q).abs().dot(d.abs())
        + q.cross(d).abs().dot(vp.abs())
        + d.cross(p).abs().dot(vq.abs())
        + d.cross(vq - vp).abs().dot(o.abs())
}

/// `kappa` of a sphere's discriminant `D = (f.d)^2 - (d.d)(f.f - r^2)`,
/// `f = o - c` (the line meets the sphere iff `D >= 0`):
/// `dD/do = -dD/dc = 2 (f.d) d - 2 (d.d) f`, `dD/dd = 2 (f.d) f - 2 (f.f - r^2) d`,
/// `dD/dr = 2 (d.d) r`.
pub fn sphere_disc_kappa(o: DVec3, d: DVec3, c: Vec3, r: f32) -> f64 {
    let (c, r) = (c.as_dvec3(), r as f64);
    let f = o - c;
    let (fd, dd, ff) = (f.dot(d), d.dot(d), f.dot(f) - r * r);
    let df = 2.0 * fd * d - 2.0 * dd * f;
    df.abs().dot(o.abs()) + df.abs().dot(c.abs()) + (2.0 * fd * f - 2.0 * ff * d).abs().dot(d.abs()) + 2.0 * dd * r * r
}

/// The signed margin of a decision in units (module docs of
/// `verify::hits::arbiter`): `sign |q| / (u kappa)`, where `sign` is the
/// exact sign of the decisive quantity (`+1` for the side of the exact
/// answer), `q_abs` its magnitude and `kappa` its condition (module docs).
/// An exact zero is a margin of 0; a nonzero quantity no input moves is
/// infinitely far.
pub fn units(sign: i32, q_abs: f64, kappa: f64) -> f64 {
    if sign == 0 { 0.0 } else { sign as f64 * (q_abs / (U * kappa)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of `t` against [`Sensitivity`]'s analytic gradient.
    #[test]
    fn triangle_and_sphere_gradients_match_finite_differences() {
        let v = [Vec3::new(0.3, -0.2, 1.1), Vec3::new(1.2, 0.4, 0.9), Vec3::new(-0.1, 1.0, 1.4)];
        let t_of = |o: DVec3, d: DVec3, v: [DVec3; 3]| {
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            n.dot(v[0] - o) / n.dot(d)
        };
        let (o, d) = (DVec3::new(0.1, 0.2, -0.5), DVec3::new(0.2, 0.1, 1.0));
        let vd = v.map(|p| p.as_dvec3());
        let t = t_of(o, d, vd);
        let n = (vd[1] - vd[0]).cross(vd[2] - vd[0]);
        let p = o + t * d;
        // Barycentrics of p.
        let area = |a: DVec3, b: DVec3, c: DVec3| (b - a).cross(c - a).dot(n);
        let bary = [area(p, vd[1], vd[2]), area(vd[0], p, vd[2]), area(vd[0], vd[1], p)].map(|x| x / n.dot(n));
        let s = Sensitivity::triangle(&v, n, n.dot(d), t, bary);
        let h = 1e-6;
        for k in 0..3 {
            let e = DVec3::AXES[k] * h;
            let go = (t_of(o + e, d, vd) - t_of(o - e, d, vd)) / (2.0 * h);
            let gd = (t_of(o, d + e, vd) - t_of(o, d - e, vd)) / (2.0 * h);
            assert!((go - s.o[k]).abs() < 1e-6 && (gd - s.d[k]).abs() < 1e-6, "{k}: {go} {gd} {s:?}");
            for j in 0..3 {
                let (mut a, mut b) = (vd, vd);
                a[j] += e;
                b[j] -= e;
                let gv = (t_of(o, d, a) - t_of(o, d, b)) / (2.0 * h);
                let key = Input::Vertex([v[j].x.to_bits(), v[j].y.to_bits(), v[j].z.to_bits()], k as u8);
                let got = s.other.iter().find(|x| x.0 == key).unwrap().2;
                assert!((gv - got).abs() < 1e-6, "vertex {j} axis {k}: {gv} vs {got}");
            }
        }
        // A sphere: the near root.
        let (c, r) = (Vec3::new(0.2, 0.3, 3.0), 0.75f32);
        let root = |o: DVec3, d: DVec3, c: DVec3, r: f64| {
            let f = o - c;
            let (a, b, cc) = (d.dot(d), -f.dot(d), f.dot(f) - r * r);
            (b - (b * b - a * cc).sqrt()) / a
        };
        let cd = c.as_dvec3();
        let t = root(o, d, cd, r as f64);
        let g = o + t * d - cd;
        let s = Sensitivity::sphere(7, c, r, t, g, g.dot(d));
        for k in 0..3 {
            let e = DVec3::AXES[k] * h;
            let go = (root(o + e, d, cd, r as f64) - root(o - e, d, cd, r as f64)) / (2.0 * h);
            let gd = (root(o, d + e, cd, r as f64) - root(o, d - e, cd, r as f64)) / (2.0 * h);
            let gc = (root(o, d, cd + e, r as f64) - root(o, d, cd - e, r as f64)) / (2.0 * h);
            assert!((go - s.o[k]).abs() < 1e-6 && (gd - s.d[k]).abs() < 1e-6, "{k}");
            assert!((gc - s.other[k].2).abs() < 1e-6, "{k}");
        }
        let gr = (root(o, d, cd, r as f64 + h) - root(o, d, cd, r as f64 - h)) / (2.0 * h);
        assert!((gr - s.other[3].2).abs() < 1e-6);
        // Differences cancel shared inputs exactly.
        assert!(s.minus(&s).is_zero());
        assert_eq!(s.minus(&s).kappa(o, d), 0.0);
    }

    /// `sum_i |dq/dx_i| |x_i|` with central differences.
    fn finite_difference_kappa<const N: usize>(q: impl Fn([f64; N]) -> f64, x0: [f64; N]) -> f64 {
        (0..N)
            .map(|i| {
                let (mut a, mut b) = (x0, x0);
                a[i] += 1e-6;
                b[i] -= 1e-6;
                ((q(a) - q(b)) / 2e-6).abs() * x0[i].abs()
            })
            .sum()
    }

    /// `kappa` of the edge volume and the discriminant against the sum of
    /// |finite-difference derivative| x |input|.
    #[test]
    fn edge_volume_and_discriminant_kappas_match_finite_differences() {
        let (o, d) = (DVec3::new(0.1, 0.2, -0.5), DVec3::new(0.2, 0.1, 1.0));
        let (vp, vq) = (Vec3::new(1.2, 0.4, 0.9), Vec3::new(-0.1, 1.0, 1.4));
        let w = |x: [f64; 12]| {
            let o = DVec3::new(x[0], x[1], x[2]);
            let d = DVec3::new(x[3], x[4], x[5]);
            let p = DVec3::new(x[6], x[7], x[8]) - o;
            let q = DVec3::new(x[9], x[10], x[11]) - o;
            d.dot(p.cross(q))
        };
        let x0 = [
            o.x,
            o.y,
            o.z,
            d.x,
            d.y,
            d.z,
            vp.x as f64,
            vp.y as f64,
            vp.z as f64,
            vq.x as f64,
            vq.y as f64,
            vq.z as f64,
        ];
        let kappa = finite_difference_kappa(w, x0);
        assert!((kappa - edge_volume_kappa(o, d, vp, vq)).abs() < 1e-6 * kappa, "{kappa}");
        let (c, r) = (Vec3::new(0.2, 0.3, 3.0), 0.75f32);
        let disc = |x: [f64; 10]| {
            let f = DVec3::new(x[0] - x[6], x[1] - x[7], x[2] - x[8]);
            let d = DVec3::new(x[3], x[4], x[5]);
            f.dot(d).powi(2) - d.dot(d) * (f.dot(f) - x[9] * x[9])
        };
        let x0 = [o.x, o.y, o.z, d.x, d.y, d.z, c.x as f64, c.y as f64, c.z as f64, r as f64];
        let kappa = finite_difference_kappa(disc, x0);
        assert!((kappa - sphere_disc_kappa(o, d, c, r)).abs() < 1e-6 * kappa, "{kappa}");
    }
}
