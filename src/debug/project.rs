//! World points to continuous pixel positions through the scene's own
//! camera: the exact inverse of [`Camera::direction`], so a point on the
//! camera ray through `(px, py)` projects back to `(px, py)`.

use glam::{Vec2, Vec3};

use crate::camera::Camera;

/// Projects world points into the camera's image.
#[derive(Clone, Debug)]
pub struct Projector {
    position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Half the image plane's width and height at unit depth: `tan(fov / 2) * aspect`, `tan(fov / 2)`.
    half: Vec2,
    size: Vec2,
}

impl Projector {
    /// The projection of `camera` (its pinhole: the lens centre).
    pub fn new(camera: &Camera) -> Self {
        let aspect = camera.width as f32 / camera.height as f32;
        Self {
            position: camera.position,
            forward: camera.forward,
            right: camera.right,
            up: camera.up,
            half: Vec2::new(camera.tan_half_fov * aspect, camera.tan_half_fov),
            size: Vec2::new(camera.width as f32, camera.height as f32),
        }
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        self.position
    }

    /// Camera-space coordinates of `p`: along right, up and forward (the depth).
    #[inline]
    pub fn camera_space(&self, p: Vec3) -> Vec3 {
        let q = p - self.position;
        Vec3::new(q.dot(self.right), q.dot(self.up), q.dot(self.forward))
    }

    /// Continuous pixel position of camera-space point `c` (depth `c.z > 0`),
    /// `(0, 0)` the image's top-left corner.
    #[inline]
    pub fn to_pixel(&self, c: Vec3) -> Vec2 {
        let ndc = Vec2::new(c.x, c.y) / (c.z * self.half);
        Vec2::new((ndc.x + 1.0) * 0.5 * self.size.x, (1.0 - ndc.y) * 0.5 * self.size.y)
    }

    /// Pixel position of world point `p`, None when it is not in front of the eye.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let c = self.camera_space(p);
        (c.z > 0.0).then(|| self.to_pixel(c))
    }

    /// Half the view's extent at unit depth (x: horizontal, y: vertical).
    pub fn half_extent(&self) -> Vec2 {
        self.half
    }

    /// World length of one pixel at camera depth `depth`.
    pub fn pixel_size(&self, depth: f32) -> f32 {
        2.0 * self.half.y * depth / self.size.y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_inverts_the_camera_direction() {
        let c = Camera::look_at(Vec3::new(0.3, 1.0, -2.5), Vec3::new(0.1, 0.0, 0.2), Vec3::Y, 38.0, 160, 90);
        let p = Projector::new(&c);
        for (px, py) in [(0.5, 0.5), (80.0, 45.0), (159.5, 3.25), (17.0, 88.0)] {
            let q = c.position + 2.7 * c.direction(px, py);
            let back = p.project(q).unwrap_or(Vec2::NAN);
            assert!((back - Vec2::new(px, py)).abs().max_element() < 1e-3, "{back} vs ({px}, {py})");
        }
        assert!(p.project(c.position - c.forward).is_none());
    }
}
