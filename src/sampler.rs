//! Sample warping. Random numbers come from [`crate::rng::Pcg32`], one
//! independent stream per pixel, so an image is the same whatever the thread
//! count or the order pixels are rendered in.

/// Map a unit-square sample to the unit disk, preserving stratification
/// (Shirley and Chiu's concentric mapping, as Mitsuba's thin lens uses).
pub fn concentric_disk(u: f32, v: f32) -> (f32, f32) {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (b, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b))
    };
    (r * phi.cos(), r * phi.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concentric_disk_stays_in_the_disk() {
        for i in 0..33 {
            for j in 0..33 {
                let (x, y) = concentric_disk(i as f32 / 32.0, j as f32 / 32.0);
                assert!(x * x + y * y <= 1.0 + 1e-6);
            }
        }
    }
}
