//! Error metrics between two images of the same size.
//!
//! `a` is the image under test, `b` the reference. All sums run over every
//! channel value (3 per pixel) in f64.

use super::error::ImageError;
use super::Image;
use std::fmt;

/// The denominator floor of a relative error: radiance below it is judged
/// by its absolute error, so black pixels neither dominate a relative MSE
/// nor need endless sampling.
pub const RELATIVE_FLOOR: f64 = 0.1;

/// `RELATIVE_FLOOR²`, the floor under a squared value in a relative MSE
/// (pbrt's `1e-2`).
pub const RELATIVE_MSE_FLOOR: f64 = RELATIVE_FLOOR * RELATIVE_FLOOR;

/// The result of [`compare`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    pub width: u32,
    pub height: u32,
    /// Mean channel value of `a` and of `b` (over finite values).
    pub mean_a: f64,
    pub mean_b: f64,
    /// Root mean squared error `sqrt(mean((a - b)²))`.
    pub rmse: f64,
    /// pbrt's relative MSE: `mean((a - b)² / (b² + 1e-2))`.
    pub rel_mse: f64,
    /// Largest `|a - b|`, and where: `(x, y, channel)`.
    pub max_abs_diff: f64,
    pub max_abs_diff_at: Option<(u32, u32, usize)>,
    /// Fraction of channel values with `|a - b| <= abs_tol + rel_tol * |b|`
    /// (1 for empty images).
    pub fraction_within: f64,
    pub abs_tol: f64,
    pub rel_tol: f64,
    /// Channel value pairs where `a` or `b` is NaN or infinite. Any makes
    /// `rmse`, `rel_mse` and `max_abs_diff` infinite (so thresholds on them
    /// fail), and none of them counts as within tolerance.
    pub non_finite: u64,
}

/// Compares `a` against the reference `b`. Different sizes are an error.
pub fn compare(a: &Image, b: &Image, abs_tol: f64, rel_tol: f64) -> Result<Comparison, ImageError> {
    if (a.width, a.height) != (b.width, b.height) || a.pixels.len() != b.pixels.len() {
        return Err(ImageError::DimensionMismatch {
            a_width: a.width,
            a_height: a.height,
            b_width: b.width,
            b_height: b.height,
        });
    }
    if !(abs_tol >= 0.0 && rel_tol >= 0.0) {
        return Err(ImageError::InvalidParameter(format!(
            "comparison tolerances must be non-negative, got abs {abs_tol}, rel {rel_tol}"
        )));
    }
    let (mut sum_a, mut sum_b, mut n_a, mut n_b) = (0.0f64, 0.0f64, 0u64, 0u64);
    let (mut se, mut rel, mut within, mut non_finite) = (0.0f64, 0.0f64, 0u64, 0u64);
    let mut max_abs = 0.0f64;
    let mut max_at = None;
    for (i, (pa, pb)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..3 {
            let (x, y) = (pa[c] as f64, pb[c] as f64);
            if x.is_finite() {
                sum_a += x;
                n_a += 1;
            }
            if y.is_finite() {
                sum_b += y;
                n_b += 1;
            }
            if !(x.is_finite() && y.is_finite()) {
                non_finite += 1;
                continue;
            }
            let d = x - y;
            se += d * d;
            rel += d * d / (y * y + RELATIVE_MSE_FLOOR);
            if d.abs() > max_abs || max_at.is_none() {
                max_abs = d.abs();
                let w = a.width.max(1) as usize;
                max_at = Some(((i % w) as u32, (i / w) as u32, c));
            }
            if d.abs() <= abs_tol + rel_tol * y.abs() {
                within += 1;
            }
        }
    }
    let n = 3 * a.pixels.len() as u64;
    let mean = |s: f64, k: u64| if k == 0 { 0.0 } else { s / k as f64 };
    let finite = n - non_finite;
    let (rmse, rel_mse, max_abs_diff) = if non_finite > 0 {
        (f64::INFINITY, f64::INFINITY, f64::INFINITY)
    } else {
        (mean(se, finite).sqrt(), mean(rel, finite), max_abs)
    };
    Ok(Comparison {
        width: a.width,
        height: a.height,
        mean_a: mean(sum_a, n_a),
        mean_b: mean(sum_b, n_b),
        rmse,
        rel_mse,
        max_abs_diff,
        max_abs_diff_at: max_at,
        fraction_within: if n == 0 {
            1.0
        } else {
            within as f64 / n as f64
        },
        abs_tol,
        rel_tol,
        non_finite,
    })
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const CH: [&str; 3] = ["red", "green", "blue"];
        writeln!(f, "size:            {}x{}", self.width, self.height)?;
        writeln!(f, "mean (a):        {:.6e}", self.mean_a)?;
        writeln!(f, "mean (b):        {:.6e}", self.mean_b)?;
        writeln!(f, "RMSE:            {:.6e}", self.rmse)?;
        writeln!(f, "relMSE:          {:.6e}", self.rel_mse)?;
        write!(f, "max |a - b|:     {:.6e}", self.max_abs_diff)?;
        if let Some((x, y, c)) = self.max_abs_diff_at {
            write!(f, " at pixel ({x}, {y}) {}", CH[c])?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "within tolerance: {:.4}% (|a - b| <= {} + {} * |b|)",
            100.0 * self.fraction_within,
            self.abs_tol,
            self.rel_tol
        )?;
        write!(f, "non-finite:      {}", self.non_finite)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn img(values: &[f32]) -> Image {
        Image::new(
            values.len() as u32,
            1,
            values.iter().map(|&v| Vec3::splat(v)).collect(),
        )
    }

    #[test]
    fn identical_images() {
        let a = img(&[0.0, 1.0, 2.0]);
        let c = compare(&a, &a, 0.0, 0.0).unwrap();
        assert_eq!(c.rmse, 0.0);
        assert_eq!(c.rel_mse, 0.0);
        assert_eq!(c.max_abs_diff, 0.0);
        assert_eq!(c.fraction_within, 1.0);
        assert_eq!(c.mean_a, 1.0);
        assert_eq!(c.mean_b, 1.0);
    }

    #[test]
    fn known_differences() {
        let a = img(&[1.0, 2.0, 3.0, 4.0]);
        let b = img(&[1.0, 2.0, 3.0, 6.0]);
        let c = compare(&a, &b, 0.5, 0.0).unwrap();
        // Squared errors per value: 0, 0, 0, 4 (×3 channels each).
        assert!((c.rmse - 1.0).abs() < 1e-12);
        assert!((c.rel_mse - (4.0 / 36.01) / 4.0).abs() < 1e-12);
        assert_eq!(c.max_abs_diff, 2.0);
        assert_eq!(c.max_abs_diff_at, Some((3, 0, 0)));
        assert_eq!(c.fraction_within, 0.75);
        assert_eq!(c.mean_a, 2.5);
        assert_eq!(c.mean_b, 3.0);
        // Relative tolerance: |4 - 6| <= 0.5 * 6.
        let c = compare(&a, &b, 0.0, 0.5).unwrap();
        assert_eq!(c.fraction_within, 1.0);
        let c = compare(&a, &b, 0.0, 0.3).unwrap();
        assert_eq!(c.fraction_within, 0.75);
    }

    #[test]
    fn display_labels_every_metric() {
        let a = img(&[1.0, 2.0]);
        let b = img(&[1.0, 3.0]);
        let s = compare(&a, &b, 0.0, 1e-4).unwrap().to_string();
        for label in [
            "RMSE",
            "relMSE",
            "mean (a)",
            "mean (b)",
            "max |a - b|",
            "within",
            "non-finite",
        ] {
            assert!(s.contains(label), "{label} missing in {s}");
        }
        assert!(s.contains("at pixel (1, 0) red"), "{s}");
    }

    #[test]
    fn dimension_mismatch_is_an_error() {
        let e = compare(&img(&[1.0]), &img(&[1.0, 2.0]), 0.0, 0.0).unwrap_err();
        assert!(e.to_string().contains("1x1 vs 2x1"), "{e}");
    }

    #[test]
    fn non_finite_values_poison_the_error_metrics() {
        let a = img(&[1.0, f32::NAN]);
        let b = img(&[1.0, 1.0]);
        let c = compare(&a, &b, 1.0, 1.0).unwrap();
        assert_eq!(c.non_finite, 3);
        assert_eq!(c.rmse, f64::INFINITY);
        assert_eq!(c.max_abs_diff, f64::INFINITY);
        assert_eq!(c.fraction_within, 0.5);
        assert_eq!(c.mean_a, 1.0);
    }

    #[test]
    fn empty_images_and_bad_tolerances() {
        let e = Image::new(0, 0, vec![]);
        let c = compare(&e, &e, 0.0, 0.0).unwrap();
        assert_eq!(c.fraction_within, 1.0);
        assert_eq!(c.rmse, 0.0);
        assert!(compare(&e, &e, -1.0, 0.0).is_err());
        assert!(compare(&e, &e, 0.0, f64::NAN).is_err());
    }
}
