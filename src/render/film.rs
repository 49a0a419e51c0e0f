//! The film: per-pixel sums of sample radiance in f64, plus sums of squares
//! (for per-pixel variance estimates) and the count of non-finite samples,
//! which are dropped (counted as zero) so an image never holds NaN or Inf.
//! An adaptive render's film also holds each pixel's own sample count and
//! where it is headed ([`PixelPlan`]).

use crate::image::metrics::RELATIVE_MSE_FLOOR;
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
    /// Samples per pixel accumulated so far: every pixel's count, or with a
    /// [`PixelPlan`] the largest.
    pub samples: u64,
    pub sum: Vec<[f64; 3]>,
    pub sum_sq: Vec<[f64; 3]>,
    pub non_finite: u64,
    /// Per-pixel counts and goals of an adaptive render; `None` when every
    /// pixel holds `samples` samples.
    pub plan: Option<PixelPlan>,
}

/// Where each pixel of an adaptive render stands. Pixel `i` holds samples
/// `0..count[i]` and renders on to `goal[i]` before its next decision; a
/// pixel whose goal is its count waits for that decision, or has stopped.
/// Everything the next decision needs is here, so a checkpoint of an
/// adaptive render resumes bit for bit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PixelPlan {
    pub count: Vec<u32>,
    pub goal: Vec<u32>,
    /// Whether the pixel met the noise threshold at its last decision (the
    /// rule asks for two in a row; see [`crate::render::adaptive`]).
    pub met: Vec<bool>,
}

impl PixelPlan {
    /// Every one of `pixels` pixels holding `count` samples, headed for `goal`.
    pub fn uniform(pixels: usize, count: u32, goal: u32) -> Self {
        Self {
            count: vec![count; pixels],
            goal: vec![goal; pixels],
            met: vec![false; pixels],
        }
    }

    /// Samples held by all pixels together.
    pub fn total(&self) -> u64 {
        self.count.iter().map(|&c| c as u64).sum()
    }

    /// Whether every pixel has reached its goal: the next decision is due.
    pub fn at_goals(&self) -> bool {
        self.count == self.goal
    }
}

/// An image's error, estimated from its own per-pixel sums.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorEstimate {
    /// The mean over pixels and channels of `stderr² / (mean² + 0.01)`:
    /// the relative MSE the image is expected to have.
    pub rel_mse: f64,
}

impl ErrorEstimate {
    /// The relative error: the root of the relative MSE.
    pub fn rel_error(&self) -> f64 {
        self.rel_mse.sqrt()
    }
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
            plan: None,
        })
    }

    /// The samples pixel `i` holds.
    #[inline]
    pub fn count(&self, i: usize) -> u64 {
        match &self.plan {
            Some(plan) => plan.count[i] as u64,
            None => self.samples,
        }
    }

    /// Samples held by all pixels together.
    pub fn total_samples(&self) -> u64 {
        match &self.plan {
            Some(plan) => plan.total(),
            None => self.samples * self.sum.len() as u64,
        }
    }

    /// Mean radiance per pixel.
    pub fn image(&self) -> Image {
        let pixels = (0..self.sum.len())
            .map(|i| Vec3::from(self.pixel_mean(i).map(|m| m as f32)))
            .collect();
        Image::new(self.width, self.height, pixels)
    }

    /// Estimated variance of each pixel's mean (sample variance / n).
    pub fn variance_of_mean(&self) -> Image {
        let pixels = (0..self.sum.len())
            .map(|i| Vec3::from(self.pixel_variance_of_mean(i).map(|v| v as f32)))
            .collect();
        Image::new(self.width, self.height, pixels)
    }

    /// Standard error of each pixel's mean: what `stderr.{R,G,B}` hold.
    pub fn standard_error(&self) -> Image {
        let mut image = self.variance_of_mean();
        for p in &mut image.pixels {
            *p = Vec3::new(p.x.sqrt(), p.y.sqrt(), p.z.sqrt());
        }
        image
    }

    /// The image's relative MSE as its own samples estimate it: the mean
    /// over pixels and channels of stderr² / (m² + 0.01), where m is the
    /// smaller of the pixel's mean and its 3×3 neighbourhood's
    /// ([`Film::robust_mean`]). With independent samples this is an honest
    /// estimate; with low-discrepancy samples the sample variance overstates
    /// the error of the mean.
    pub fn error_estimate(&self) -> ErrorEstimate {
        let means = self.pixel_means();
        let total: f64 = (0..self.sum.len())
            .map(|i| {
                let var = self.pixel_variance_of_mean(i);
                let m = self.robust_mean(i, &means);
                (0..3)
                    .map(|c| var[c] / (m[c] * m[c] + RELATIVE_MSE_FLOOR))
                    .sum::<f64>()
            })
            .sum();
        ErrorEstimate {
            rel_mse: total / (3 * self.sum.len().max(1)) as f64,
        }
    }

    /// Pixel `i`'s mean as the denominator of a relative error: per channel
    /// the smaller of its own mean (`means[i]`) and its neighbourhood's. A
    /// pixel's own mean alone puts its own noise in the denominator: a
    /// pixel that caught a firefly divides its large variance by its large
    /// mean, so the estimated relative MSE came out at 0.57× the actual one
    /// on cornell-area at 64 spp. The neighbourhood's mean alone takes a dim
    /// pixel's denominator from bright neighbours across an edge (0.40× on
    /// a 16×16 box). The smaller of the two: 0.87–1.25× on those, and
    /// 0.89–1.18× on 17 of the 19 scenes of `scenes/`.
    pub fn robust_mean(&self, i: usize, means: &[[f64; 3]]) -> [f64; 3] {
        let local = self.neighbourhood_mean(i, means);
        std::array::from_fn(|c| means[i][c].min(local[c]))
    }

    /// The pixels of pixel `i`'s 3×3 neighbourhood, itself included,
    /// clipped at the image's edges.
    pub fn neighbourhood(&self, i: usize) -> impl Iterator<Item = usize> {
        let (width, height) = (self.width as usize, self.height as usize);
        let (x, y) = (i % width, i / width);
        let xs = x.saturating_sub(1)..(x + 2).min(width);
        (y.saturating_sub(1)..(y + 2).min(height))
            .flat_map(move |y| xs.clone().map(move |x| y * width + x))
    }

    /// The mean of `values` over pixel `i`'s neighbourhood, per channel.
    pub fn neighbourhood_mean(&self, i: usize, values: &[[f64; 3]]) -> [f64; 3] {
        let (mut sum, mut n) = ([0.0; 3], 0.0);
        for j in self.neighbourhood(i) {
            for c in 0..3 {
                sum[c] += values[j][c];
            }
            n += 1.0;
        }
        sum.map(|s| s / n)
    }

    /// Every pixel's mean per channel, for the neighbourhood statistics.
    pub fn pixel_means(&self) -> Vec<[f64; 3]> {
        (0..self.sum.len()).map(|i| self.pixel_mean(i)).collect()
    }

    /// Pixel `i`'s mean per channel.
    #[inline]
    pub fn pixel_mean(&self, i: usize) -> [f64; 3] {
        let n = self.count(i);
        let inv = if n == 0 { 0.0 } else { 1.0 / n as f64 };
        self.sum[i].map(|s| s * inv)
    }

    /// The estimated variance of pixel `i`'s mean per channel: the unbiased
    /// sample variance over n; 0 below two samples.
    #[inline]
    pub fn pixel_variance_of_mean(&self, i: usize) -> [f64; 3] {
        let n = self.count(i) as f64;
        let (s, q) = (self.sum[i], self.sum_sq[i]);
        let mut v = [0.0; 3];
        if n > 1.0 {
            for c in 0..3 {
                let mean = s[c] / n;
                let var = ((q[c] / n - mean * mean) * n / (n - 1.0)).max(0.0);
                v[c] = var / n;
            }
        }
        v
    }

    /// Adds another film's samples (disjoint sample ranges of one scene).
    /// Films of adaptive renders do not merge: their pixels hold samples
    /// `0..count`, so two of them overlap.
    pub fn merge(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height));
        assert!(
            self.plan.is_none() && other.plan.is_none(),
            "adaptive films do not merge"
        );
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
