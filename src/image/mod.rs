//! Images: linear HDR RGB buffers, tone mapping to 8-bit display values,
//! reading and (atomic) writing of EXR, Radiance HDR, PPM (including the
//! course's `#MAX=` HDR PPM) and PNG/JPEG, and error metrics between images.

mod error;
pub mod io;
pub mod metrics;
pub mod tonemap;
pub mod zscore;

pub use error::ImageError;
pub use io::{read, read_texture, write, WriteOptions};
pub use metrics::{compare, Comparison};
pub use tonemap::{ToneMap, ToneMapParams};

use crate::math::Vec3;

/// A linear RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// `width * height` pixels, linear RGB (Rec.709 primaries).
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// Wraps `pixels`. Panics when `pixels.len() != width * height`: that is
    /// a programming error; readers validate file contents before this.
    pub fn new(width: u32, height: u32, pixels: Vec<Vec3>) -> Self {
        assert_eq!(
            pixels.len(),
            width as usize * height as usize,
            "Image::new: {width}x{height} needs {} pixels, got {}",
            width as usize * height as usize,
            pixels.len()
        );
        Self {
            width,
            height,
            pixels,
        }
    }

    /// A `width` × `height` image filled with `value`.
    pub fn filled(width: u32, height: u32, value: Vec3) -> Self {
        Self::new(width, height, vec![value; width as usize * height as usize])
    }

    #[inline]
    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{}",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }

    /// The pixel at column `x`, row `y` (row 0 at the top).
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[self.index(x, y)]
    }

    #[inline]
    pub fn set(&mut self, x: u32, y: u32, value: Vec3) {
        let i = self.index(x, y);
        self.pixels[i] = value;
    }

    /// Mean pixel value (accumulated in f64); zero for an empty image.
    pub fn mean(&self) -> Vec3 {
        if self.pixels.is_empty() {
            return Vec3::ZERO;
        }
        let mut s = [0.0f64; 3];
        for p in &self.pixels {
            for (c, sc) in s.iter_mut().enumerate() {
                *sc += p[c] as f64;
            }
        }
        let n = self.pixels.len() as f64;
        Vec3::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
    }

    /// Largest finite channel value over the image (0 for an empty or
    /// all-non-finite image; negative values count as they are).
    pub fn max_value(&self) -> f32 {
        self.pixels
            .iter()
            .flat_map(|p| p.to_array())
            .filter(|v| v.is_finite())
            .fold(0.0f32, f32::max)
    }

    /// A new image with `f` applied to every pixel.
    pub fn map(&self, f: impl Fn(Vec3) -> Vec3) -> Image {
        Image::new(
            self.width,
            self.height,
            self.pixels.iter().map(|&p| f(p)).collect(),
        )
    }

    /// Position `(x, y, channel)` of the first channel value that is `bad`,
    /// in row-major order.
    pub fn first_where(&self, bad: impl Fn(f32) -> bool) -> Option<(u32, u32, usize)> {
        self.pixels.iter().enumerate().find_map(|(i, p)| {
            (0..3).find(|&c| bad(p[c])).map(|c| {
                (
                    (i % self.width as usize) as u32,
                    (i / self.width as usize) as u32,
                    c,
                )
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn get_set_mean_max_map() {
        let mut img = Image::filled(3, 2, Vec3::ONE);
        img.set(2, 1, Vec3::new(4.0, 1.0, 1.0));
        assert_eq!(img.get(2, 1), Vec3::new(4.0, 1.0, 1.0));
        assert_eq!(img.pixels[5], Vec3::new(4.0, 1.0, 1.0));
        assert_eq!(img.mean(), Vec3::new(1.5, 1.0, 1.0));
        assert_eq!(img.max_value(), 4.0);
        let doubled = img.map(|p| p * 2.0);
        assert_eq!(doubled.get(0, 0), Vec3::splat(2.0));
        assert_eq!(img.first_where(|v| !v.is_finite()), None);
        img.set(1, 1, Vec3::new(0.0, f32::NAN, 0.0));
        assert_eq!(img.first_where(|v| !v.is_finite()), Some((1, 1, 1)));
        assert_eq!(img.max_value(), 4.0);
    }

    #[test]
    fn empty_image_statistics() {
        let img = Image::new(0, 0, vec![]);
        assert_eq!(img.mean(), Vec3::ZERO);
        assert_eq!(img.max_value(), 0.0);
    }

    #[test]
    #[should_panic]
    fn new_rejects_wrong_pixel_count() {
        Image::new(2, 2, vec![Vec3::ZERO; 3]);
    }
}
