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
    /// The image axis along which the scene gave its field of view: the one
    /// that keeps its angle when the resolution changes.
    pub fov_axis: FovAxis,
    pub width: u32,
    pub height: u32,
}

/// Mitsuba's `fov_axis`; luz's own scenes give a vertical field of view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    X,
    #[default]
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            _ => return None,
        })
    }

    /// The length of this axis over the height, for a `width`×`height` image.
    fn over_height(self, width: u32, height: u32) -> f64 {
        let (w, h) = (width as f64, height as f64);
        match self {
            FovAxis::X => w / h,
            FovAxis::Y => 1.0,
            FovAxis::Diagonal => (w * w + h * h).sqrt() / h,
            FovAxis::Smaller => w.min(h) / h,
            FovAxis::Larger => w.max(h) / h,
        }
    }

    /// The vertical field of view (degrees) of a `fov` measured along this
    /// axis of a `width`×`height` image.
    pub fn vertical_fov(self, fov: f64, width: u32, height: u32) -> f64 {
        let t = (0.5 * fov.to_radians()).tan() / self.over_height(width, height);
        2.0 * t.atan().to_degrees()
    }

    /// The field of view along this axis of a vertical `fov_y`.
    fn fov_along(self, fov_y: f64, width: u32, height: u32) -> f64 {
        let t = (0.5 * fov_y.to_radians()).tan() * self.over_height(width, height);
        2.0 * t.atan().to_degrees()
    }
}

impl Camera {
    /// A new image size, keeping the field of view along `fov_axis` (as
    /// Mitsuba does when a film's size changes).
    pub fn resize(&mut self, width: u32, height: u32) {
        let axis = self.fov_axis;
        let fov = axis.fov_along(self.fov_y as f64, self.width, self.height);
        self.fov_y = axis.vertical_fov(fov, width, height) as f32;
        self.width = width;
        self.height = height;
    }

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
    fn fov_axes() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(close(FovAxis::Y.vertical_fov(40.0, 200, 100), 40.0));
        let half = 2.0 * 0.5f64.atan().to_degrees();
        assert!(close(FovAxis::X.vertical_fov(90.0, 200, 100), half));
        assert!(close(FovAxis::Smaller.vertical_fov(90.0, 200, 100), 90.0));
        let double = 2.0 * 2f64.atan().to_degrees();
        assert!(close(FovAxis::Smaller.vertical_fov(90.0, 100, 200), double));
        assert!(close(FovAxis::Larger.vertical_fov(90.0, 100, 200), 90.0));
        let d = FovAxis::Diagonal.vertical_fov(90.0, 300, 400);
        assert!(close(d, 2.0 * 0.8f64.atan().to_degrees()));
        assert_eq!(FovAxis::parse("z"), None);
    }

    /// A new resolution keeps the angle along the scene's axis: a 35°
    /// horizontal field stays 35° across when a 320×180 film becomes
    /// square, and a vertical one stays vertical.
    #[test]
    fn resizing_keeps_the_field_of_view_along_its_axis() {
        for axis in [
            FovAxis::X,
            FovAxis::Y,
            FovAxis::Diagonal,
            FovAxis::Smaller,
            FovAxis::Larger,
        ] {
            let mut cam = Camera {
                eye: Vec3::Z,
                target: Vec3::ZERO,
                up: Vec3::Y,
                fov_y: axis.vertical_fov(35.0, 320, 180) as f32,
                fov_axis: axis,
                width: 320,
                height: 180,
            };
            cam.resize(256, 256);
            let fov = axis.fov_along(cam.fov_y as f64, 256, 256);
            assert!((fov - 35.0).abs() < 1e-3, "{axis:?}: {fov}");
            assert_eq!((cam.width, cam.height), (256, 256));
        }
    }

    #[test]
    fn scenes_md_camera_centre_and_corners() {
        let cam = Camera {
            eye: Vec3::new(0.0, 1.0, 3.7),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y: 40.0,
            fov_axis: FovAxis::Y,
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
