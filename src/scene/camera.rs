//! Pinhole camera with the conventions of SCENES.md: vertical field of view,
//! pixel (0, 0) at the top left, box filter one pixel wide.

use crate::math::{Ray, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// Ray through the image-plane position `(i + u, j + v)` in pixels.
    #[inline]
    pub fn ray(&self, basis: &CameraBasis, pixel: Vec2) -> Ray {
        let sx = 2.0 * pixel.x / self.width as f32 - 1.0;
        let sy = 1.0 - 2.0 * pixel.y / self.height as f32;
        let dir = basis.forward + sx * basis.right + sy * basis.up;
        Ray::new(self.eye, dir.normalize())
    }

    pub fn basis(&self) -> CameraBasis {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        let t = (0.5 * self.fov_y.to_radians()).tan();
        let aspect = self.width as f32 / self.height as f32;
        CameraBasis {
            forward,
            right: right * t * aspect,
            up: up * t,
        }
    }
}

/// Precomputed image-plane axes, scaled by the field of view.
#[derive(Clone, Copy, Debug)]
pub struct CameraBasis {
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenes_md_camera_centre_and_corners() {
        let cam = Camera {
            eye: Vec3::new(0.0, 1.0, 3.7),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y: 40.0,
            width: 512,
            height: 512,
        };
        let b = cam.basis();
        let centre = cam.ray(&b, Vec2::new(256.0, 256.0));
        assert!((centre.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        let top_left = cam.ray(&b, Vec2::ZERO).dir;
        let t = 20f32.to_radians().tan();
        let expect = Vec3::new(-t, t, -1.0).normalize();
        assert!((top_left - expect).length() < 1e-6);
    }
}
