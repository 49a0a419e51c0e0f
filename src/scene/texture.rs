//! Textures modulate the diffuse albedo. Addressing wraps (tiling), lookups
//! are nearest-texel: textures in luz's scenes are magnified tiles, where a
//! filter buys nothing.

use crate::math::{Rgb, Vec2};

#[derive(Clone, Debug)]
pub enum Texture {
    /// Linear RGB texels, row-major, row 0 at the top (v = 1).
    Image {
        width: u32,
        height: u32,
        texels: Vec<Rgb>,
    },
    /// `squares` × `squares` checkerboard per unit of uv.
    Checker { a: Rgb, b: Rgb, squares: f32 },
}

/// Per-shape mapping of surface uv to texture uv: `uv * scale + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub scale: Vec2,
    pub offset: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        Self {
            scale: Vec2::ONE,
            offset: Vec2::ZERO,
        }
    }
}

impl UvTransform {
    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        uv * self.scale + self.offset
    }
}

impl Texture {
    /// The image with its rows in the opposite order (a checker as it is):
    /// Mitsuba's images have v = 0 on their top row, luz's on the bottom.
    pub fn upside_down(self) -> Texture {
        match self {
            Texture::Image {
                width,
                height,
                texels,
            } => Texture::Image {
                width,
                height,
                texels: texels
                    .chunks_exact(width as usize)
                    .rev()
                    .flatten()
                    .copied()
                    .collect(),
            },
            checker => checker,
        }
    }

    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let u = uv.x - uv.x.floor();
        let v = uv.y - uv.y.floor();
        match self {
            Texture::Image {
                width,
                height,
                texels,
            } => {
                let x = ((u * *width as f32) as u32).min(width - 1);
                let y = (((1.0 - v) * *height as f32) as u32).min(height - 1);
                texels[(y * width + x) as usize]
            }
            Texture::Checker { a, b, squares } => {
                let i = (uv.x * squares).floor() as i64 + (uv.y * squares).floor() as i64;
                if i.rem_euclid(2) == 0 {
                    *a
                } else {
                    *b
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_lookup_wraps_and_flips_v() {
        let t = Texture::Image {
            width: 2,
            height: 2,
            texels: vec![Rgb::X, Rgb::Y, Rgb::Z, Rgb::ONE],
        };
        assert_eq!(t.eval(Vec2::new(0.25, 0.75)), Rgb::X);
        assert_eq!(t.eval(Vec2::new(0.75, 0.25)), Rgb::ONE);
        assert_eq!(t.eval(Vec2::new(1.25, -0.75)), Rgb::Z);
        assert!(t.eval(Vec2::new(-0.052, 1.0006)).is_finite());
    }

    #[test]
    fn checker_alternates() {
        let t = Texture::Checker {
            a: Rgb::ZERO,
            b: Rgb::ONE,
            squares: 2.0,
        };
        assert_eq!(t.eval(Vec2::new(0.1, 0.1)), Rgb::ZERO);
        assert_eq!(t.eval(Vec2::new(0.6, 0.1)), Rgb::ONE);
        assert_eq!(t.eval(Vec2::new(-0.1, 0.1)), Rgb::ONE);
    }
}
