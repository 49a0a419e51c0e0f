//! Sums no render can produce, refused whatever the checksum says (see the
//! module docs of [`super`] for the checks and the rounding they allow).

use super::attributes::NON_FINITE;
use super::channels::RGB;
use super::PartError;
use crate::render::Film;
use std::fmt;
use std::path::Path;

/// Which of a pixel's two sums a [`SumProblem`] is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SumKind {
    /// `luz.sum.*`: the sum of the samples.
    Sum,
    /// `luz.sumsq.*`: the sum of their squares.
    SumSq,
}

impl SumKind {
    fn name(self) -> &'static str {
        match self {
            Self::Sum => "sum",
            Self::SumSq => "sumsq",
        }
    }
}

/// What is impossible about a pixel's sums.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SumProblem {
    /// A sum below zero: radiance never is.
    Negative { kind: SumKind, value: f64 },
    /// An infinite or NaN sum: luz drops non-finite samples.
    NotFinite { kind: SumKind, value: f64 },
    /// `sum² > n·sumsq` beyond rounding, which no `samples` real numbers
    /// allow (Cauchy–Schwarz).
    CauchySchwarz { sum: f64, sum_sq: f64, samples: u64 },
}

impl SumProblem {
    /// The channels the problem is in, for `channel` (`R`, `G` or `B`).
    pub(super) fn field(&self, channel: &str) -> String {
        match self {
            Self::Negative { kind, .. } | Self::NotFinite { kind, .. } => {
                format!("luz.{}.{channel}", kind.name())
            }
            Self::CauchySchwarz { .. } => format!("luz.sum.{channel}, luz.sumsq.{channel}"),
        }
    }
}

impl fmt::Display for SumProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Negative { value, .. } => {
                write!(f, "holds {value}, a negative sum (radiance never is)")
            }
            Self::NotFinite { value, .. } => write!(f, "holds {value}, not a finite sum"),
            Self::CauchySchwarz {
                sum,
                sum_sq,
                samples,
            } => write!(
                f,
                "sum {sum} and sum of squares {sum_sq} of {samples} samples break \
                 sum² ≤ n·sumsq (Cauchy–Schwarz)"
            ),
        }
    }
}

/// The first impossible sum of `film`, as (pixel index, channel, problem).
fn implausible_sum(film: &Film) -> Option<(usize, usize, SumProblem)> {
    for (i, (s, q)) in film.sum.iter().zip(&film.sum_sq).enumerate() {
        let n = film.count(i) as f64;
        let slack = 1.0 + 4.0 * n * f64::EPSILON;
        for c in 0..3 {
            for (kind, value) in [(SumKind::Sum, s[c]), (SumKind::SumSq, q[c])] {
                if !value.is_finite() {
                    return Some((i, c, SumProblem::NotFinite { kind, value }));
                }
                if value < 0.0 {
                    return Some((i, c, SumProblem::Negative { kind, value }));
                }
            }
            if s[c] * s[c] > n * q[c] * slack {
                let problem = SumProblem::CauchySchwarz {
                    sum: s[c],
                    sum_sq: q[c],
                    samples: film.count(i),
                };
                return Some((i, c, problem));
            }
        }
    }
    None
}

/// Refuses `film`, read from `path`, if a sum is impossible or it dropped
/// more samples than it has.
pub(super) fn check_plausible(path: &Path, film: &Film) -> Result<(), PartError> {
    let (width, height) = (film.width as usize, film.height as usize);
    if let Some((i, c, problem)) = implausible_sum(film) {
        return Err(PartError::Sum {
            path: path.to_path_buf(),
            channel: RGB[c],
            x: i % width,
            y: i / width,
            problem,
        });
    }
    let most = film.total_samples();
    if film.non_finite > most {
        return Err(PartError::invalid(
            path,
            NON_FINITE,
            format!(
                "{} dropped samples, more than the {most} samples of {width}x{height} pixels",
                film.non_finite
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_in_real_sums_passes_the_cauchy_schwarz_check() {
        // Equal samples are the equality case, where rounding alone decides.
        for (value, n) in [
            (0.1f32, 1000),
            (1.0 / 3.0, 100_000),
            (7e-30, 3),
            (3e37, 999),
        ] {
            let mut p = crate::render::film::PixelSum::default();
            for _ in 0..n {
                p.add(crate::math::Rgb::splat(value));
            }
            let mut film = Film::new(1, 1);
            (film.sum[0], film.sum_sq[0], film.samples) = (p.sum, p.sum_sq, n);
            assert_eq!(implausible_sum(&film), None, "{value} x {n}");
        }
        // Samples of a thousand magnitudes, summed in two orders.
        let samples: Vec<f64> = (0..5000)
            .map(|i| ((i * 7919) % 1000) as f64 * 1e-3)
            .collect();
        for order in [samples.clone(), samples.iter().rev().copied().collect()] {
            let mut film = Film::new(1, 1);
            film.samples = order.len() as u64;
            for v in order {
                film.sum[0][0] += v;
                film.sum_sq[0][0] += v * v;
            }
            assert_eq!(implausible_sum(&film), None);
        }
    }
}
