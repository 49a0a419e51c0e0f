//! Adaptive sampling: how many samples each pixel gets, decided from the
//! film's own per-pixel sums at fixed points, so that the image stays a pure
//! function of (scene, seed, options) whatever the thread count.
//!
//! - **Noise threshold** ([`Sampling::NoiseThreshold`]): pixels sample in
//!   rounds that end at `min_spp`, twice that, four times, … up to
//!   `max_spp`. At each round's end a pixel whose relative standard error
//!   (per channel, the standard error over `max(mean, 0.1)`) is at most the
//!   threshold in every channel has *met* it; a pixel stops after meeting it
//!   at two decisions in a row. One decision alone would stop pixels whose
//!   noise merely *looks* low in their first samples (a caustic pixel that
//!   has not yet seen its rare bright paths), which biases both the image
//!   and the error estimate low; the second decision is made on twice the
//!   samples, half of them new. A pixel is judged by the largest error
//!   in its 3×3 neighbourhood, as in Cycles: a pixel whose own noise is low
//!   by chance goes on while its neighbours do, so where pixels stop
//!   depends less on their own luck.
//! - **Budget** ([`Sampling::Budget`]): `spp × pixels` samples in all. A
//!   quarter of them go to every pixel alike; then, at half and at all of
//!   the budget, each pixel's goal is its share of the budget in proportion
//!   to its per-sample relative standard deviation, the allocation that
//!   minimises the image's relative MSE, with a floor so that no pixel is
//!   starved on the strength of a few samples. The deviation is pooled
//!   over the pixel's 3×3 neighbourhood (its variance and its mean): a
//!   pixel's own estimate from a few samples is noisy, and goals that follow
//!   that noise give fewer samples to pixels whose variance happens to look
//!   low, which then keep the error their estimate hides. Averaging each
//!   pixel's own deviation over the neighbourhood still let pixels that
//!   caught one rare bright path steer the goals: on soft-shadows-sphere
//!   at 64 spp the budget's relative MSE was 1.29× uniform's; pooled,
//!   0.94×, and below uniform's on all 19 scenes of `scenes/`.
//!
//! Decisions happen only when every pixel has reached its goal
//! ([`PixelPlan::at_goals`]); the render loop moves pixels towards their
//! goals in passes of any length, so checkpoints and signals may come
//! between decisions.

use super::film::{Film, PixelPlan};
pub use crate::image::metrics::{RELATIVE_FLOOR, RELATIVE_MSE_FLOOR};
use std::fmt;

/// How a render spreads its samples over the pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// Every pixel gets every sample of the render's range.
    Uniform,
    /// Each pixel samples until its relative standard error is at most
    /// `threshold` at two decisions in a row, or it holds `max_spp`.
    NoiseThreshold {
        threshold: f64,
        min_spp: u32,
        max_spp: u32,
    },
    /// `spp × pixels` samples in all, spent where the relative error is
    /// largest.
    Budget { spp: u32 },
}

/// The share of a budget spent alike on every pixel, and then the shares
/// after which the goals are decided again.
const BUDGET_STEPS: [f64; 3] = [0.25, 0.5, 1.0];

/// The floor on a pixel's weight in a budget, as a fraction of the mean
/// weight.
const WEIGHT_FLOOR: f64 = 0.1;

/// A pixel's goal in a budget is at most this many times the uniform spp.
const MAX_SHARE: u32 = 64;

impl Sampling {
    pub fn is_adaptive(&self) -> bool {
        !matches!(self, Self::Uniform)
    }

    /// The samples per pixel a pixel may reach: the range's end for the
    /// caller to use with a uniform render.
    pub fn max_spp(&self, uniform: u32) -> u32 {
        match *self {
            Self::Uniform => uniform,
            Self::NoiseThreshold { max_spp, .. } => max_spp,
            Self::Budget { spp } => spp.saturating_mul(MAX_SHARE),
        }
    }

    /// The plan of an empty film of `pixels` pixels: every pixel headed for
    /// the first decision.
    pub fn first_plan(&self, pixels: usize) -> Option<PixelPlan> {
        match *self {
            Self::Uniform => None,
            Self::NoiseThreshold {
                min_spp, max_spp, ..
            } => Some(PixelPlan::uniform(pixels, 0, min_spp.min(max_spp))),
            Self::Budget { spp } => Some(PixelPlan::uniform(pixels, 0, first_share(spp))),
        }
    }

    /// Whether an adaptive `film` has a pass to render: some pixel short of
    /// its goal, once the decision due when every pixel has reached its
    /// goal is made. A film without a plan has none here; its sample range
    /// says when it is done.
    pub fn pass_due(&self, film: &mut Film) -> bool {
        match &film.plan {
            None => false,
            Some(plan) if !plan.at_goals() => true,
            Some(_) => self.decide(film),
        }
    }

    /// Makes the decision due on `film` (every pixel at its goal): new goals
    /// for the pixels that go on. Returns whether any pixel goes on.
    pub fn decide(&self, film: &mut Film) -> bool {
        match *self {
            Self::Uniform => false,
            Self::NoiseThreshold {
                threshold, max_spp, ..
            } => decide_threshold(film, threshold, max_spp),
            Self::Budget { spp } => decide_budget(film, spp),
        }
    }
}

/// The uniform share of a budget of `spp`: at least 2 samples, for a
/// variance.
fn first_share(spp: u32) -> u32 {
    ((spp as f64 * BUDGET_STEPS[0]).round() as u32).clamp(2.min(spp), spp)
}

/// Pixel `i`'s largest relative standard error over its channels.
pub fn relative_error(film: &Film, i: usize) -> f64 {
    let mean = film.pixel_mean(i);
    let var = film.pixel_variance_of_mean(i);
    (0..3)
        .map(|c| var[c].sqrt() / mean[c].max(RELATIVE_FLOOR))
        .fold(0.0, f64::max)
}

fn decide_threshold(film: &mut Film, threshold: f64, max_spp: u32) -> bool {
    let checkpoint = film.samples as u32;
    let own: Vec<f64> = (0..film.sum.len())
        .map(|i| relative_error(film, i))
        .collect();
    let errors: Vec<Option<f64>> = {
        let plan = film.plan.as_ref().expect("an adaptive film has a plan");
        (0..plan.count.len())
            .map(|i| {
                (plan.count[i] == checkpoint)
                    .then(|| film.neighbourhood(i).map(|j| own[j]).fold(0.0, f64::max))
            })
            .collect()
    };
    let next = checkpoint.saturating_mul(2).min(max_spp);
    let plan = film.plan.as_mut().expect("an adaptive film has a plan");
    let mut any = false;
    for (i, error) in errors.into_iter().enumerate() {
        // Pixels that stopped earlier lag behind the checkpoint.
        let Some(error) = error else { continue };
        let met = error <= threshold;
        if (met && plan.met[i]) || checkpoint >= max_spp {
            plan.met[i] = met;
            continue;
        }
        plan.met[i] = met;
        plan.goal[i] = next;
        any = true;
    }
    any
}

/// Each pixel's per-sample relative standard deviation, in the relative
/// MSE's own measure (`σ² / (μ² + 0.01)`, averaged over channels), with σ²
/// and μ pooled over the pixel's 3×3 neighbourhood: a ratio of pooled
/// sums, not a mean of per-pixel ratios, which pixels that caught one rare
/// bright path among few samples (a tiny mean, a large variance) dominate.
/// Not the pixel's own mean either ([`Film::robust_mean`]): a black pixel
/// next to a noisy edge would then divide the edge's variance by 0.01 and
/// take samples by the thousand.
fn budget_weights(film: &Film) -> Vec<f64> {
    let pixels = film.sum.len();
    let means = film.pixel_means();
    let variances: Vec<[f64; 3]> = (0..pixels)
        .map(|i| {
            let n = film.count(i) as f64;
            film.pixel_variance_of_mean(i).map(|v| v * n)
        })
        .collect();
    (0..pixels)
        .map(|i| {
            let mean = film.neighbourhood_mean(i, &means);
            let var = film.neighbourhood_mean(i, &variances);
            let rel: f64 = (0..3)
                .map(|c| var[c] / (mean[c] * mean[c] + RELATIVE_MSE_FLOOR))
                .sum();
            (rel / 3.0).sqrt()
        })
        .collect()
}

fn decide_budget(film: &mut Film, spp: u32) -> bool {
    let pixels = film.sum.len();
    let budget = spp as f64 * pixels as f64;
    let held = film.total_samples();
    let Some(step) = BUDGET_STEPS
        .iter()
        .map(|s| (s * budget).round() as u64)
        .find(|&s| s > held)
    else {
        return false;
    };
    let mut weights = budget_weights(film);
    let mean = weights.iter().sum::<f64>() / pixels as f64;
    let cap = spp.saturating_mul(MAX_SHARE) as f64;
    if mean > 0.0 {
        for w in &mut weights {
            *w = w.max(WEIGHT_FLOOR * mean);
        }
    } else {
        weights.fill(1.0);
    }
    let total: f64 = weights.iter().sum();
    let plan = film.plan.as_mut().expect("an adaptive film has a plan");
    let deficits: Vec<f64> = weights
        .iter()
        .zip(&plan.count)
        .map(|(w, &c)| ((step as f64 * w / total).min(cap) - c as f64).max(0.0))
        .collect();
    let extra = allocate(step - held, &deficits);
    for (goal, (count, e)) in plan.goal.iter_mut().zip(plan.count.iter().zip(extra)) {
        *goal = count + e;
    }
    true
}

/// Splits `samples` over pixels in proportion to `deficits`, in whole
/// samples that add up exactly: each pixel gets the floor of its share,
/// and the samples left go one each to the largest remainders (ties to the
/// lower index, so the split is deterministic).
fn allocate(samples: u64, deficits: &[f64]) -> Vec<u32> {
    let total: f64 = deficits.iter().sum();
    if total <= 0.0 {
        let even = vec![1.0; deficits.len()];
        return allocate(samples, &even);
    }
    let shares: Vec<f64> = deficits
        .iter()
        .map(|d| samples as f64 * d / total)
        .collect();
    let mut extra: Vec<u32> = shares.iter().map(|s| s.floor() as u32).collect();
    let given: u64 = extra.iter().map(|&e| e as u64).sum();
    let mut order: Vec<usize> = (0..shares.len()).collect();
    order.sort_by(|&a, &b| {
        let (fa, fb) = (shares[a] - shares[a].floor(), shares[b] - shares[b].floor());
        fb.total_cmp(&fa).then(a.cmp(&b))
    });
    let left = samples.saturating_sub(given) as usize;
    for &i in order.iter().cycle().take(left) {
        extra[i] += 1;
    }
    extra
}

impl fmt::Display for Sampling {
    /// The text of a part's `luz:sampling` attribute, which [`FromStr`]
    /// reads back.
    ///
    /// [`FromStr`]: std::str::FromStr
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Self::Uniform => write!(f, "uniform"),
            Self::NoiseThreshold {
                threshold,
                min_spp,
                max_spp,
            } => write!(f, "noise-threshold {threshold} {min_spp}..{max_spp}"),
            Self::Budget { spp } => write!(f, "adaptive {spp}"),
        }
    }
}

impl std::str::FromStr for Sampling {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || {
            format!(
                "expected `uniform`, `noise-threshold E MIN..MAX` or `adaptive SPP`, found `{s}`"
            )
        };
        let words: Vec<&str> = s.split(' ').collect();
        match words.as_slice() {
            ["uniform"] => Ok(Self::Uniform),
            ["adaptive", spp] => Ok(Self::Budget {
                spp: spp.parse().map_err(|_| bad())?,
            }),
            ["noise-threshold", threshold, range] => {
                let (min, max) = range.split_once("..").ok_or_else(bad)?;
                let threshold: f64 = threshold.parse().map_err(|_| bad())?;
                if !(threshold.is_finite() && threshold > 0.0) {
                    return Err(bad());
                }
                Ok(Self::NoiseThreshold {
                    threshold,
                    min_spp: min.parse().map_err(|_| bad())?,
                    max_spp: max.parse().map_err(|_| bad())?,
                })
            }
            _ => Err(bad()),
        }
    }
}

#[cfg(test)]
#[path = "adaptive_tests.rs"]
mod tests;
