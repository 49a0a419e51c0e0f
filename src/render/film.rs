//! The film: per-pixel sums of sample radiance in f64, plus sums of squares
//! (for per-pixel variance estimates) and the count of non-finite samples,
//! which are dropped (counted as zero) so an image never holds NaN or Inf.

use crate::image::Image;
use crate::math::{Rgb, Vec3};

/// The largest width and height luz renders, loads, writes and merges. One
/// limit everywhere, so nothing is rendered that a later merge refuses.
pub const MAX_RESOLUTION: u32 = 1 << 15;

/// Refuses a resolution with a side of 0 or above [`MAX_RESOLUTION`].
pub fn check_resolution(width: u32, height: u32) -> Result<(), String> {
    let side = 1..=MAX_RESOLUTION;
    if side.contains(&width) && side.contains(&height) {
        Ok(())
    } else {
        Err(format!(
            "resolution {width}x{height} is outside 1..={MAX_RESOLUTION} per side"
        ))
    }
}

#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FilmError {
    #[error("a {width}x{height} film needs {:.1} GB of memory, which could not be allocated", *bytes as f64 / 1e9)]
    OutOfMemory { width: u32, height: u32, bytes: u64 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel accumulated so far (the same for every pixel).
    pub samples: u64,
    pub sum: Vec<[f64; 3]>,
    pub sum_sq: Vec<[f64; 3]>,
    pub non_finite: u64,
}

/// Accumulator for one pixel's samples.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelSum {
    pub sum: [f64; 3],
    pub sum_sq: [f64; 3],
    pub non_finite: u64,
}

impl PixelSum {
    #[inline]
    pub fn add(&mut self, l: Rgb) {
        if !l.is_finite() {
            self.non_finite += 1;
            return;
        }
        for c in 0..3 {
            let v = l[c] as f64;
            self.sum[c] += v;
            self.sum_sq[c] += v * v;
        }
    }
}

impl Film {
    /// An empty film. Panics when memory runs out; see [`Film::try_new`].
    pub fn new(width: u32, height: u32) -> Self {
        Self::try_new(width, height).unwrap_or_else(|e| panic!("{e}"))
    }

    /// An empty film, or an error saying how much memory it needed when the
    /// allocation fails: a scene may ask for 32768×32768 pixels (51 GB of
    /// sums), which must end in a message, not an abort.
    pub fn try_new(width: u32, height: u32) -> Result<Self, FilmError> {
        let n = width as usize * height as usize;
        let zeroed = || -> Option<Vec<[f64; 3]>> {
            let mut v = Vec::new();
            v.try_reserve_exact(n).ok()?;
            v.resize(n, [0.0; 3]);
            Some(v)
        };
        let too_large = || FilmError::OutOfMemory {
            width,
            height,
            bytes: 2 * n as u64 * size_of::<[f64; 3]>() as u64,
        };
        Ok(Self {
            width,
            height,
            samples: 0,
            sum: zeroed().ok_or_else(too_large)?,
            sum_sq: zeroed().ok_or_else(too_large)?,
            non_finite: 0,
        })
    }

    /// Mean radiance per pixel.
    pub fn image(&self) -> Image {
        let inv = if self.samples == 0 {
            0.0
        } else {
            1.0 / self.samples as f64
        };
        let pixels = self
            .sum
            .iter()
            .map(|s| {
                Vec3::new(
                    (s[0] * inv) as f32,
                    (s[1] * inv) as f32,
                    (s[2] * inv) as f32,
                )
            })
            .collect();
        Image::new(self.width, self.height, pixels)
    }

    /// Estimated variance of each pixel's mean (sample variance / n).
    pub fn variance_of_mean(&self) -> Image {
        let n = self.samples as f64;
        let pixels = self
            .sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| {
                let mut v = [0.0f32; 3];
                if n > 1.0 {
                    for c in 0..3 {
                        let mean = s[c] / n;
                        let var = ((q[c] / n - mean * mean) * n / (n - 1.0)).max(0.0);
                        v[c] = (var / n) as f32;
                    }
                }
                Vec3::from(v)
            })
            .collect();
        Image::new(self.width, self.height, pixels)
    }

    /// Adds another film's samples (disjoint sample ranges of one scene).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height));
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        for (a, b) in self.sum_sq.iter_mut().zip(&other.sum_sq) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        self.samples += other.samples;
        self.non_finite += other.non_finite;
    }
}
