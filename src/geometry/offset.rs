//! Spawning secondary rays without self-intersection.
//!
//! The robust method follows pbrt-v4 (section 6.8): bound the absolute error
//! of the computed hit point, push the origin along the geometric normal just
//! past that bound, and round the result away from the surface. It is relative
//! to the magnitude of the coordinates, so it works for a scene 1e-4 units wide
//! and for one translated 1e4 units away alike. The fixed epsilon the reports
//! used (origin + 1e-4 * direction) is kept for comparison.

use glam::Vec3;

/// `gamma(n) = n u / (1 - n u)` with `u = 2^-24`, the bound on the relative
/// error of `n` chained single-precision operations (pbrt-v4, eq. 6.31).
#[inline]
pub fn gamma(n: i32) -> f32 {
    let nu = n as f32 * f32::EPSILON * 0.5;
    nu / (1.0 - nu)
}

/// How secondary rays leave a surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind", deny_unknown_fields)]
pub enum SpawnOffset {
    /// Error-bound offset along the geometric normal (pbrt-v4).
    #[default]
    Robust,
    /// The reports' fixed offset along the new ray's direction.
    Fixed {
        /// Distance along the (unit) direction.
        epsilon: f32,
    },
    /// Mitsuba 3's `spawn_ray`: the origin pushed `epsilon (1 + max|p|)` along the geometric
    /// normal, to the side the new ray goes (Mitsuba's epsilon is 1500 * 2^-24 = 8.94e-5).
    /// The image checks re-render with it to tell which pixels differ only by where Mitsuba's
    /// own integrators start their rays.
    ScaledNormal {
        /// Push per unit of `1 + max|p|`.
        epsilon: f32,
    },
}

/// Mitsuba 3's ray epsilon (`math::RayEpsilon<float>` = 1500 * 2^-24), the `epsilon` of
/// [`SpawnOffset::ScaledNormal`] that reproduces its `spawn_ray`.
pub const MITSUBA_RAY_EPSILON: f32 = 1500.0 * (f32::EPSILON * 0.5);

/// Error bound of a point on a triangle computed as `b0 p0 + b1 p1 + b2 p2`
/// (pbrt-v4, eq. 6.34): `gamma(7) (|b0 p0| + |b1 p1| + |b2 p2|)`, floored on
/// every axis at `gamma(7)` times the largest vertex coordinate.
///
/// The floor matters where pbrt's bound is zero: a triangle lying in a
/// coordinate plane (all vertices with `x = 0`) computes `x = 0` exactly, so
/// the offset along its normal would vanish and a ray leaving it would meet
/// the triangle again at `t = +-0`, which the closed interval `[0, t_max]`
/// (Embree's convention) accepts; pbrt avoids it only by rejecting `t` below a
/// bound in its triangle test. The ray/triangle distance is computed from
/// vertex coordinates of this magnitude, so an offset of this size puts the
/// origin clearly behind the surface's rounding.
#[inline]
pub fn triangle_point_error(b: [f32; 3], p: [Vec3; 3]) -> Vec3 {
    let scale = p[0].abs().max(p[1].abs()).max(p[2].abs()).max_element();
    (gamma(7) * ((b[0] * p[0]).abs() + (b[1] * p[1]).abs() + (b[2] * p[2]).abs())).max(Vec3::splat(gamma(7) * scale))
}

/// Next representable float above `v` (towards +inf).
#[inline]
pub fn next_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v >= 0.0 { bits + 1 } else { bits - 1 })
}

/// Next representable float below `v` (towards -inf).
#[inline]
pub fn next_down(v: f32) -> f32 {
    -next_up(-v)
}

/// Origin for a ray leaving point `p` (error bound `p_err`) in direction `w`,
/// on the side of the geometric normal `n` that `w` points to.
#[inline]
pub fn offset_origin(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let n = n.normalize_or_zero();
    offset_along(p, p_err, if w.dot(n) < 0.0 { -n } else { n })
}

/// `p` moved off the surface along the unit normal `n` (already turned to
/// the side the ray leaves on): [`offset_origin`]'s arithmetic.
#[inline]
fn offset_along(p: Vec3, p_err: Vec3, n: Vec3) -> Vec3 {
    // pbrt-v4's offset: the error bound projected on the normal (the bound is
    // floored at the vertex scale, see `triangle_point_error`, so it never vanishes).
    let d = n.abs().dot(p_err);
    let mut po = p + d * n;
    // Round away from the surface in every component the normal moves. Unlike
    // pbrt-v4 this also steps one ulp when the error bound is zero (a point
    // exactly on an axis-aligned plane), because rays here accept t = t_min = 0
    // (Embree's closed interval) where pbrt rejects t <= 0.
    for i in 0..3 {
        if n[i] > 0.0 {
            po[i] = next_up(po[i]);
        } else if n[i] < 0.0 {
            po[i] = next_down(po[i]);
        }
    }
    po
}

/// The two origins [`offset_origin`] can give for one surface point, made
/// once: a point that sends many rays (the shadow rays towards an area
/// light's samples) picks one by the side each ray leaves on, with the same
/// bits as [`offset_origin`] computes ray by ray.
#[derive(Clone, Copy, Debug)]
pub struct SideOrigins {
    /// The unit geometric normal (zero for a degenerate one).
    n: Vec3,
    /// The origin for rays leaving on the normal's side.
    front: Vec3,
    /// The origin for rays leaving on the other side.
    back: Vec3,
}

impl SideOrigins {
    /// Both origins of point `p` (error bound `p_err`, geometric normal `n`).
    #[inline]
    pub fn new(p: Vec3, p_err: Vec3, n: Vec3) -> Self {
        let n = n.normalize_or_zero();
        Self { n, front: offset_along(p, p_err, n), back: offset_along(p, p_err, -n) }
    }

    /// `offset_origin(p, p_err, n, w)`.
    #[inline]
    pub fn origin(&self, w: Vec3) -> Vec3 {
        if w.dot(self.n) < 0.0 { self.back } else { self.front }
    }
}

/// Origin for a ray leaving `p` in direction `w` under the chosen policy.
#[inline]
pub fn spawn_origin(policy: SpawnOffset, p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    match policy {
        SpawnOffset::Robust => offset_origin(p, p_err, n, w),
        SpawnOffset::Fixed { epsilon } => p + epsilon * w.normalize_or_zero(),
        SpawnOffset::ScaledNormal { epsilon } => {
            let n = n.normalize_or_zero();
            let push = epsilon * (1.0 + p.abs().max_element());
            p + if w.dot(n) < 0.0 { -push } else { push } * n
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_up_down_step_one_ulp() {
        assert_eq!(next_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_down(1.0), 1.0 - f32::EPSILON / 2.0);
        assert!(next_up(0.0) > 0.0);
        assert!(next_down(0.0) < 0.0);
        assert_eq!(next_up(-1.0), -1.0 + f32::EPSILON / 2.0);
    }

    #[test]
    fn side_origins_are_the_per_ray_origins() {
        // Directions on both sides, in the plane (w.n = 0), a NaN one, with
        // normals of any length (including a degenerate one).
        let ws = [
            Vec3::new(0.3, 1.0, -0.2),
            Vec3::new(0.3, -1.0, -0.2),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-2.0, 1e-30, 5.0),
            Vec3::new(f32::NAN, 1.0, 0.0),
        ];
        let cases = [
            (Vec3::new(1.0e4, 2.0, -3.0), Vec3::new(0.1, 3.0, 0.2)),
            (Vec3::new(0.5, 0.0, 0.25), Vec3::Y),
            (Vec3::new(-7.0, 1e-20, 3.5), Vec3::new(-1e-3, 2e-3, 5.0)),
            (Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO),
        ];
        for (p, n) in cases {
            let e = triangle_point_error([0.2, 0.3, 0.5], [p, p * 0.5, p + Vec3::ONE]);
            let s = SideOrigins::new(p, e, n);
            for w in ws {
                let (a, b) = (s.origin(w), offset_origin(p, e, n, w));
                assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits), "p {p} n {n} w {w}");
            }
        }
    }

    #[test]
    fn scaled_normal_is_mitsubas_spawn_ray() {
        // Mitsuba: o = p + mulsign(n (1 + max|p|) RayEpsilon, dot(n, d)).
        let p = Vec3::new(-3.0, 0.5, 1.0);
        let policy = SpawnOffset::ScaledNormal { epsilon: MITSUBA_RAY_EPSILON };
        let up = spawn_origin(policy, p, Vec3::ZERO, Vec3::Y * 2.0, Vec3::new(0.3, 1.0, 0.0));
        let down = spawn_origin(policy, p, Vec3::ZERO, Vec3::Y * 2.0, Vec3::new(0.3, -1.0, 0.0));
        assert!((up.y - p.y - 4.0 * 8.9407e-5).abs() < 1e-7, "{up}");
        assert!((p.y - down.y - 4.0 * 8.9407e-5).abs() < 1e-7, "{down}");
        assert_eq!((up.x, up.z), (p.x, p.z));
    }

    #[test]
    fn offset_moves_to_the_side_of_w() {
        let p = Vec3::new(1.0e4, 2.0, -3.0);
        let e = triangle_point_error([0.2, 0.3, 0.5], [p, p, p]);
        let n = Vec3::Y;
        let up = offset_origin(p, e, n, Vec3::new(0.1, 1.0, 0.0));
        let down = offset_origin(p, e, n, Vec3::new(0.1, -1.0, 0.0));
        assert!(up.y > p.y && down.y < p.y);
        assert!(up.y - p.y >= e.y);
        // Zero error bound (point exactly on the plane y = 0): still leaves the plane.
        let q = Vec3::new(0.5, 0.0, 0.25);
        assert!(offset_origin(q, Vec3::ZERO, n, Vec3::Y).y > 0.0);
        assert!(offset_origin(q, Vec3::ZERO, n, -Vec3::Y).y < 0.0);
    }
}
