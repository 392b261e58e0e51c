//! The pinhole and thin-lens camera, with Mitsuba 3's conventions so that the
//! two renderers shoot the same rays (see shared/notes/mitsuba.md).

use glam::Vec3;

use crate::geometry::Ray;
use crate::sampler::concentric_disk;

/// The course's default eye: 3 units from the origin, rotated 20 degrees
/// about x and y (the view of a mesh normalised to the unit sphere). The one
/// default of the scene files, `bench`, `parity` and the tests.
pub const DEFAULT_EYE: Vec3 = Vec3::new(-0.964_181, 1.026_06, -2.649_067);

/// The default vertical field of view, in degrees.
pub const DEFAULT_FOV: f32 = 50.0;

/// A perspective camera with an optional thin lens.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Unit forward axis.
    pub forward: Vec3,
    /// Unit right axis.
    pub right: Vec3,
    /// Unit up axis (orthogonal to forward and right).
    pub up: Vec3,
    /// `tan(vertical fov / 2)`.
    pub tan_half_fov: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Lens radius (0: pinhole).
    pub aperture_radius: f32,
    /// Distance from the eye to the plane in focus, along the camera axis.
    pub focus_distance: f32,
}

impl Camera {
    /// Camera at `position` looking at `target` (`up` need not be orthogonal).
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, vfov_degrees: f32, width: u32, height: u32) -> Self {
        let forward = (target - position).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Self {
            position,
            forward,
            right,
            up,
            tan_half_fov: (vfov_degrees.to_radians() * 0.5).tan(),
            width,
            height,
            aperture_radius: 0.0,
            focus_distance: (target - position).length(),
        }
    }

    /// The default view ([`DEFAULT_EYE`] looking at the origin, y up,
    /// [`DEFAULT_FOV`]) for a `width` x `height` image.
    pub fn default_view(width: u32, height: u32) -> Self {
        Self::look_at(DEFAULT_EYE, Vec3::ZERO, Vec3::Y, DEFAULT_FOV, width, height)
    }

    /// One pinhole ray through the centre of each pixel, row by row.
    pub fn pixel_centre_rays(&self) -> Vec<Ray> {
        let mut out = Vec::with_capacity(self.width as usize * self.height as usize);
        for y in 0..self.height {
            for x in 0..self.width {
                out.push(self.pixel_centre_ray(x, y));
            }
        }
        out
    }

    /// The pinhole ray through the centre of pixel `(x, y)` (the render's ray at one sample per pixel).
    #[inline]
    pub fn pixel_centre_ray(&self, x: u32, y: u32) -> Ray {
        self.ray(x as f32 + 0.5, y as f32 + 0.5)
    }

    /// Unit direction through continuous pixel position `(px, py)`, with
    /// `(0, 0)` the top-left corner of the image and `(0.5, 0.5)` the centre of
    /// the top-left pixel.
    #[inline]
    pub fn direction(&self, px: f32, py: f32) -> Vec3 {
        let aspect = self.width as f32 / self.height as f32;
        let ndc_x = 2.0 * px / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * py / self.height as f32;
        (self.forward + ndc_x * self.tan_half_fov * aspect * self.right + ndc_y * self.tan_half_fov * self.up)
            .normalize()
    }

    /// Pinhole ray through `(px, py)`.
    #[inline]
    pub fn ray(&self, px: f32, py: f32) -> Ray {
        Ray::new(self.position, self.direction(px, py))
    }

    /// Thin-lens ray through `(px, py)` for lens sample `(lu, lv)` in the unit
    /// square: the lens point is `aperture_radius * concentric_disk(lu, lv)`, and
    /// the ray passes through the point where the pinhole ray meets the focus plane.
    pub fn lens_ray(&self, px: f32, py: f32, lu: f32, lv: f32) -> Ray {
        let d = self.direction(px, py);
        if self.aperture_radius <= 0.0 {
            return Ray::new(self.position, d);
        }
        let focus = self.position + d * (self.focus_distance / d.dot(self.forward));
        let (dx, dy) = concentric_disk(lu, lv);
        let origin = self.position + self.aperture_radius * (dx * self.right + dy * self.up);
        Ray::new(origin, (focus - origin).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_forward_and_corners_are_symmetric() {
        let c = Camera::look_at(Vec3::new(0.0, 0.0, -3.0), Vec3::ZERO, Vec3::Y, 50.0, 100, 100);
        assert!((c.direction(50.0, 50.0) - Vec3::Z).length() < 1e-6);
        let tl = c.direction(0.0, 0.0);
        let br = c.direction(100.0, 100.0);
        assert!((tl.x + br.x).abs() < 1e-6 && (tl.y + br.y).abs() < 1e-6);
        // Top of the image is +y; with forward +z and up +y, right is -x... as Mitsuba: cross(fwd, up).
        assert!(tl.y > 0.0);
        // Vertical half-angle equals fov / 2.
        let top = c.direction(50.0, 0.0);
        assert!((top.y.atan2(top.z).to_degrees() - 25.0).abs() < 1e-4);
    }

    #[test]
    fn lens_rays_converge_on_the_focus_plane() {
        let mut c = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 40.0, 64, 48);
        c.aperture_radius = 0.2;
        c.focus_distance = 5.0;
        let pin = c.ray(10.3, 20.7);
        let p_focus = pin.at(5.0 / pin.dir.dot(c.forward));
        for (u, v) in [(0.1, 0.9), (0.5, 0.5), (0.8, 0.2)] {
            let r = c.lens_ray(10.3, 20.7, u, v);
            let t = (5.0 - r.origin.dot(c.forward)) / r.dir.dot(c.forward);
            assert!((r.at(t) - p_focus).length() < 1e-5);
        }
    }
}
