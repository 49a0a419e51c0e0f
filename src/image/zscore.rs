//! Two renders compared in units of their own noise: the fraction of pixel
//! channels whose difference exceeds `k` combined standard errors. Where the
//! renders differ only by noise, the difference of a channel is about
//! normal with the combined standard error as its deviation, so the
//! fraction beyond `k` should be near `erfc(k/√2)` (0.27% at k = 3); a
//! larger fraction points at a bias, a smaller one at an overstated error
//! (as low-discrepancy samples give).

use super::metrics::RELATIVE_FLOOR;
use super::{Image, ImageError};
use std::fmt;

/// How two images with per-pixel standard errors differ, in those errors.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseComparison {
    /// The threshold, in combined standard errors.
    pub k: f64,
    /// Pixel channels compared.
    pub channels: usize,
    /// Those whose difference exceeds `k` combined standard errors (a
    /// channel with no error at all counts when the values differ).
    pub beyond: usize,
    /// The RMS of the differences over the RMS of the combined standard
    /// errors: about 1 where the errors are honest, above 1 where they
    /// understate the difference.
    pub rms_ratio: f64,
    /// Per pixel, the worst channel's `|a - b| / max(b, 0.1)`: its median
    /// and 90th percentile.
    pub relative_error_quantiles: (f64, f64),
}

impl NoiseComparison {
    pub fn fraction(&self) -> f64 {
        self.beyond as f64 / self.channels.max(1) as f64
    }

    /// The fraction beyond `k` that noise alone gives: both tails of a
    /// standard normal.
    pub fn expected_fraction(&self) -> f64 {
        erfc(self.k / std::f64::consts::SQRT_2)
    }
}

impl fmt::Display for NoiseComparison {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "beyond {} combined standard errors: {} of {} pixel channels ({:.3}%; noise alone: {:.3}%)\n\
             RMS difference / RMS combined standard error: {:.3}\n\
             per-pixel relative error |a - b| / max(b, 0.1), worst channel: median {:.4}, 90th percentile {:.4}",
            self.k,
            self.beyond,
            self.channels,
            100.0 * self.fraction(),
            100.0 * self.expected_fraction(),
            self.rms_ratio,
            self.relative_error_quantiles.0,
            self.relative_error_quantiles.1
        )
    }
}

/// Compares `a` (standard errors `a_err`) with `b` (`b_err`).
pub fn compare_in_noise(
    (a, a_err): (&Image, &Image),
    (b, b_err): (&Image, &Image),
    k: f64,
) -> Result<NoiseComparison, ImageError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(ImageError::DimensionMismatch {
            a_width: a.width,
            a_height: a.height,
            b_width: b.width,
            b_height: b.height,
        });
    }
    let (mut beyond, mut diff_sq, mut err_sq) = (0, 0.0, 0.0);
    let mut relative = Vec::with_capacity(a.pixels.len());
    for i in 0..a.pixels.len() {
        let mut worst: f64 = 0.0;
        for c in 0..3 {
            let (va, vb) = (a.pixels[i][c] as f64, b.pixels[i][c] as f64);
            let diff = (va - vb).abs();
            let (ea, eb) = (a_err.pixels[i][c] as f64, b_err.pixels[i][c] as f64);
            let combined_sq = ea * ea + eb * eb;
            if diff > k * combined_sq.sqrt() {
                beyond += 1;
            }
            diff_sq += diff * diff;
            err_sq += combined_sq;
            worst = worst.max(diff / vb.max(RELATIVE_FLOOR));
        }
        relative.push(worst);
    }
    Ok(NoiseComparison {
        k,
        channels: a.pixels.len() * 3,
        beyond,
        rms_ratio: (diff_sq / err_sq).sqrt(),
        relative_error_quantiles: (quantile(&mut relative, 0.5), quantile(&mut relative, 0.9)),
    })
}

/// The `q` quantile of `values` (the value at rank ⌊q·(n-1)⌋); 0 for none.
fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let rank = (q * (values.len() - 1) as f64) as usize;
    *values.select_nth_unstable_by(rank, f64::total_cmp).1
}

/// The complementary error function, to about 1e-7 relative (Numerical
/// Recipes' `erfcc`, a Chebyshev fit).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn image(values: &[f32]) -> Image {
        Image::new(
            values.len() as u32,
            1,
            values.iter().map(|&v| Vec3::splat(v)).collect(),
        )
    }

    #[test]
    fn erfc_matches_known_values() {
        for (x, want) in [
            (0.0, 1.0),
            (1.0, 0.157_299_207),
            (2.0, 0.004_677_735),
            (-1.0, 1.842_700_793),
        ] {
            assert!(
                (erfc(x) - want).abs() < 2e-7 * want.max(1e-3),
                "erfc({x}) = {}",
                erfc(x)
            );
        }
        let at_three = NoiseComparison {
            k: 3.0,
            channels: 1,
            beyond: 0,
            rms_ratio: 1.0,
            relative_error_quantiles: (0.0, 0.0),
        };
        assert!((at_three.expected_fraction() - 0.002_699_8).abs() < 1e-6);
    }

    #[test]
    fn counts_channels_beyond_k_combined_errors() {
        let a = image(&[1.0, 1.0, 1.0, 2.0]);
        let b = image(&[1.0, 1.4, 1.6, 2.0]);
        // Combined error 0.1·√2 ≈ 0.141 everywhere but the last pixel,
        // which has none and no difference.
        let err = image(&[0.1, 0.1, 0.1, 0.0]);
        let z = compare_in_noise((&a, &err), (&b, &err), 3.0).unwrap();
        assert_eq!(
            (z.beyond, z.channels),
            (3, 12),
            "only the 0.6 difference passes 0.42"
        );
        let z = compare_in_noise((&a, &err), (&b, &err), 2.0).unwrap();
        assert_eq!(z.beyond, 6, "0.4 and 0.6 pass 0.28");
        // Squared differences 3·(0.16 + 0.36) over 9 channels of 0.02.
        let rms = (3.0f64 * (0.16 + 0.36) / (9.0 * 0.02)).sqrt();
        assert!((z.rms_ratio - rms).abs() < 1e-6, "{}", z.rms_ratio);
        // Per pixel: 0, 0.4, 0.6 and 0 relative to 1.4, 1.6 and 2.
        let (median, p90) = z.relative_error_quantiles;
        assert_eq!(median, 0.0);
        assert!((p90 - 0.4 / 1.4).abs() < 1e-6, "{p90}");
        let other = image(&[1.0, 1.0, 1.0, 2.5]);
        let z = compare_in_noise((&a, &err), (&other, &err), 100.0).unwrap();
        assert_eq!(z.beyond, 3, "a difference without any error always counts");
    }

    #[test]
    fn images_of_different_sizes_are_refused() {
        let (a, b) = (image(&[1.0]), image(&[1.0, 2.0]));
        assert!(compare_in_noise((&a, &a), (&b, &b), 3.0).is_err());
    }
}
