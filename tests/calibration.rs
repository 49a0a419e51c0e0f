//! Calibration of luz's error estimates on a scene whose answer is known in
//! closed form: a convex diffuse sphere under a constant sky, where every
//! pixel's expected radiance is the albedo times the sky. Russian roulette
//! makes each sample random, so the film's per-pixel standard errors and the
//! summary's estimated relative MSE can be held against the actual errors.
//!
//! Every pixel is an independent estimate of the same value, and a path's
//! three channels are one random event, so each check below draws on 4,096
//! independent pixels. The bounds are set far enough from what a calibrated
//! estimate gives that a false alarm is rarer than once in a million runs
//! (each check says how far).

use luz::accel::{BackendKind, BuildOptions};
use luz::image::metrics::RELATIVE_MSE_FLOOR;
use luz::render::{build_accel, render_with, Film, RenderOptions, Sampling};
use luz::sampling::SamplerKind;
use luz::scene::load_str;
use std::path::Path;
use std::sync::Arc;

const SCENE: &str = r#"
[camera]
eye = [0, 0, 10]
target = [0, 0, 0]
fov = 4
resolution = [64, 64]

[render]
spp = 64
max_depth = 10
russian_roulette = true

[materials.grey]
kd = 0.6

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "grey"

[environment]
radiance = [2, 1, 0.5]
"#;

/// Albedo times sky.
const EXPECTED: [f64; 3] = [1.2, 0.6, 0.3];

fn render(sampler: SamplerKind, sampling: Sampling) -> Film {
    let scene = Arc::new(load_str(SCENE, Path::new("calibration.toml")).expect("valid scene"));
    let accel = build_accel(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    let options = RenderOptions {
        sampler,
        sampling,
        ..RenderOptions::from_scene(&scene)
    };
    render_with(&scene, &accel, &options, &()).0
}

/// A film's actual errors against [`EXPECTED`], next to its own estimates.
struct Calibration {
    /// Fraction of pixel channels within two of their standard errors.
    within_two: f64,
    /// RMS of the actual error over RMS of the standard error.
    rms_ratio: f64,
    /// The summary's estimated relative MSE over the actual one.
    estimate_ratio: f64,
    /// Each pixel's largest relative error over its channels.
    relative_errors: Vec<f64>,
}

fn calibration(film: &Film) -> Calibration {
    let (mut within, mut err2, mut se2, mut rel_mse) = (0usize, 0.0, 0.0, 0.0);
    let mut relative_errors = Vec::new();
    for i in 0..film.sum.len() {
        let (mean, var) = (film.pixel_mean(i), film.pixel_variance_of_mean(i));
        let mut worst: f64 = 0.0;
        for c in 0..3 {
            let err = mean[c] - EXPECTED[c];
            within += usize::from(err.abs() <= 2.0 * var[c].sqrt());
            err2 += err * err;
            se2 += var[c];
            rel_mse += err * err / (EXPECTED[c] * EXPECTED[c] + RELATIVE_MSE_FLOOR);
            worst = worst.max(err.abs() / EXPECTED[c].max(0.1));
        }
        relative_errors.push(worst);
    }
    let values = (3 * film.sum.len()) as f64;
    Calibration {
        within_two: within as f64 / values,
        rms_ratio: (err2 / se2).sqrt(),
        estimate_ratio: film.error_estimate().rel_mse / (rel_mse / values),
        relative_errors,
    }
}

/// The checks every estimate must pass: the issue's calibration targets.
/// Over 40 seeds on these 4,096 pixels, uniform and budget renders had
/// 0.945–0.952 of their channels within two standard errors (spread
/// 0.003), an RMS ratio of 1.00 (spread 0.010) and an estimated over actual
/// relative MSE of 1.09–1.10 (spread 0.022; the estimate's denominator, the
/// smaller of a pixel's mean and its neighbourhood's, errs high). Every
/// bound lies 7 or more spreads away: a false alarm far rarer than once in
/// a million runs.
fn assert_calibrated(film: &Film, label: &str) {
    let c = calibration(film);
    assert!(
        c.within_two >= 0.9,
        "{label}: {:.3} within 2σ",
        c.within_two
    );
    assert!(
        (0.8..=1.25).contains(&c.rms_ratio),
        "{label}: RMS error / RMS stderr {:.3}",
        c.rms_ratio
    );
    assert!(
        (0.75..=1.25).contains(&c.estimate_ratio),
        "{label}: estimated / actual relative MSE {:.3}",
        c.estimate_ratio
    );
}

#[test]
fn uniform_and_budget_renders_estimate_their_own_error() {
    let independent = SamplerKind::Independent;
    assert_calibrated(&render(independent, Sampling::Uniform), "uniform");
    assert_calibrated(
        &render(independent, Sampling::Budget { spp: 64 }),
        "adaptive",
    );
}

#[test]
fn with_sobol_points_the_estimates_err_on_the_safe_side() {
    // Well-spread points beat the independent samples the variance formula
    // assumes: the actual error is smaller than the estimate, never larger.
    for sampling in [Sampling::Uniform, Sampling::Budget { spp: 64 }] {
        let c = calibration(&render(SamplerKind::Sobol, sampling));
        assert!(c.rms_ratio <= 1.25, "{sampling}: {:.3}", c.rms_ratio);
        assert!(
            c.estimate_ratio >= 0.75,
            "{sampling}: {:.3}",
            c.estimate_ratio
        );
    }
}

#[test]
fn a_noise_threshold_render_ends_near_its_threshold_and_knows_its_error() {
    let threshold = 0.08;
    let film = render(
        SamplerKind::Independent,
        Sampling::NoiseThreshold {
            threshold,
            min_spp: 16,
            max_spp: 1024,
        },
    );
    assert_calibrated(&film, "noise threshold 0.08");
    // A pixel that met the threshold has a relative standard error of at
    // most 0.08, so an error beyond twice that is at least a two-sigma
    // event; over 40 seeds on 1,024 pixels, 99.97% of pixels were within
    // (spread 0.05%), so 90% cannot fail by chance.
    let c = calibration(&film);
    let close = c.relative_errors.iter().filter(|&&e| e <= 2.0 * threshold);
    let fraction = close.count() as f64 / c.relative_errors.len() as f64;
    assert!(
        fraction >= 0.9,
        "{fraction:.3} of pixels within 2 × {threshold}"
    );
    let plan = film.plan.as_ref().expect("an adaptive film");
    assert!(plan.met.iter().all(|&m| m), "every pixel met the threshold");
}
