//! Tests every model the way Mitsuba and pbrt test theirs: energy (a white
//! furnace), sampling against the density (a chi-square test) and
//! reciprocity, plus the consistency of `sample` with `eval` and `pdf`.

use super::*;
use crate::sampling::Rng;
use std::f64::consts::TAU;

const PERFECT_MIRROR: (Rgb, Rgb) = (Rgb::ZERO, Rgb::ONE);

fn gold() -> (Rgb, Rgb) {
    (Rgb::new(0.143, 0.374, 1.442), Rgb::new(3.983, 2.385, 1.603))
}

fn rough_conductor(d: Distribution, alpha: f32, (eta, k): (Rgb, Rgb)) -> Bsdf {
    Bsdf::Conductor(Conductor {
        eta,
        k,
        tint: Rgb::ONE,
        roughness: Some(Microfacet::new(d, alpha)),
    })
}

fn plastic(d: Distribution, alpha: f32, eta: f32, nonlinear: bool) -> Bsdf {
    let coat = Microfacet::new(d, alpha);
    Bsdf::RoughPlastic(RoughPlastic::new(coat, eta, Rgb::ONE, 0.5, nonlinear))
}

fn rough_dielectric(d: Distribution, alpha: f32, eta: f32) -> Bsdf {
    Bsdf::RoughDielectric(RoughDielectric {
        microfacet: Microfacet::new(d, alpha),
        eta,
        tint_r: Rgb::ONE,
        tint_t: Rgb::ONE,
    })
}

fn ctx(diffuse: Rgb, front: bool) -> Context {
    Context { diffuse, front }
}

/// Glossy models and the vertex they are evaluated at.
fn glossy() -> Vec<(String, Bsdf, Context)> {
    let mut out = Vec::new();
    for d in [Distribution::Beckmann, Distribution::Ggx] {
        for alpha in [0.1, 0.3, 0.7] {
            let name = |kind: &str| format!("{kind} {d:?} {alpha}");
            let white = ctx(Rgb::ONE, true);
            out.push((name("conductor"), rough_conductor(d, alpha, gold()), white));
            let base = ctx(Rgb::splat(0.8), true);
            out.push((name("plastic"), plastic(d, alpha, 1.5, false), base));
            for front in [true, false] {
                let model = rough_dielectric(d, alpha, 1.5);
                out.push((
                    name(&format!("dielectric front {front}")),
                    model,
                    ctx(Rgb::ONE, front),
                ));
            }
        }
    }
    for eta in [1.3, 1.9] {
        let smooth = Bsdf::Plastic(Plastic::new(eta, Rgb::ONE, 0.5, false));
        out.push((
            format!("smooth plastic {eta}"),
            smooth,
            ctx(Rgb::splat(0.8), true),
        ));
    }
    let coloured = ctx(Rgb::new(0.9, 0.5, 0.1), true);
    let model = plastic(Distribution::Ggx, 0.2, 2.0, true);
    out.push(("plastic nonlinear".into(), model, coloured));
    out
}

fn direction(cos_theta: f64, phi: f64) -> Vec3 {
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new(
        (s * phi.cos()) as f32,
        (s * phi.sin()) as f32,
        cos_theta as f32,
    )
}

fn views() -> [Vec3; 3] {
    [
        direction(0.95, 0.4),
        direction(0.5, 1.3),
        direction(0.15, 2.0),
    ]
}

/// The cos θ range a model's directions fall in: the sphere for a model
/// that transmits, else the upper hemisphere.
fn cos_range(bsdf: &Bsdf) -> (f64, f64) {
    if bsdf.transmits() {
        (-1.0, 2.0)
    } else {
        (0.0, 1.0)
    }
}

/// A white furnace: with a perfectly reflecting Fresnel term (or an
/// index-matched interface) and a white base, the fraction kept, E[weight],
/// is at most 1, exactly 1 for the smooth mirror, and the rough models lose
/// only what single scattering misses (a few percent at α = 0.1 head-on).
#[test]
fn white_furnace() {
    let mut rng = Rng::new(3, 0);
    let white = ctx(Rgb::ONE, true);
    let smooth = Bsdf::Conductor(Conductor {
        eta: PERFECT_MIRROR.0,
        k: PERFECT_MIRROR.1,
        tint: Rgb::ONE,
        roughness: None,
    });
    for wo in views() {
        let s = smooth.sample(wo, 0.5, Vec2::splat(0.5), &white).unwrap();
        let exact = (s.weight - Rgb::ONE).abs().max_element() < 1e-5;
        assert!(s.delta && exact, "{s:?}");
    }
    let mut models = Vec::new();
    for d in [Distribution::Beckmann, Distribution::Ggx] {
        for alpha in [0.1, 0.4, 1.0] {
            let mirror = rough_conductor(d, alpha, PERFECT_MIRROR);
            models.push((format!("mirror {d:?} {alpha}"), mirror, alpha, true));
            let coat = plastic(d, alpha, 1.5, false);
            models.push((format!("plastic {d:?} {alpha}"), coat, alpha, false));
            let smooth = Bsdf::Plastic(Plastic::new(1.5, Rgb::ONE, 0.5, false));
            models.push((
                format!("smooth plastic {d:?} {alpha}"),
                smooth,
                alpha,
                false,
            ));
            let matched = rough_dielectric(d, alpha, 1.0001);
            models.push((format!("dielectric {d:?} {alpha}"), matched, alpha, true));
        }
    }
    for (name, bsdf, alpha, lossless) in models {
        for wo in views() {
            let n = 100_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d(), &white) {
                    sum += s.weight.x as f64;
                }
            }
            let kept = sum / n as f64;
            assert!(kept <= 1.0 + 0.01, "{name} wo {wo}: keeps {kept}");
            if lossless && alpha <= 0.1 && wo.z > 0.9 {
                assert!(kept > 0.97, "{name} wo {wo}: keeps only {kept}");
            }
        }
    }
}

/// f(wo, wi) = f(wi, wo): eval is f·cos θi. Transmission is left out: with
/// radiance scaled by η² across the interface it is reciprocal only up to
/// that factor (f(wo, wi)/η_i² = f(wi, wo)/η_o²).
#[test]
fn reciprocity() {
    let mut rng = Rng::new(5, 0);
    for (name, bsdf, vertex) in glossy() {
        for _ in 0..2000 {
            let a = crate::sampling::cosine_hemisphere(rng.next_2d());
            let b = crate::sampling::cosine_hemisphere(rng.next_2d());
            let f_ab = bsdf.eval(a, b, &vertex) / b.z;
            let f_ba = bsdf.eval(b, a, &vertex) / a.z;
            let scale = f_ab.max_element().max(f_ba.max_element()).max(1e-3);
            let close = (f_ab - f_ba).abs().max_element() <= 2e-3 * scale;
            assert!(close, "{name}: {f_ab} vs {f_ba} at {a} {b}");
        }
    }
}

/// `sample`'s weight and pdf are `eval` / `pdf` at the sampled direction
/// (for the samples of non-delta lobes).
#[test]
fn samples_agree_with_eval_and_pdf() {
    let mut rng = Rng::new(9, 0);
    for (name, bsdf, vertex) in glossy() {
        for wo in views() {
            for _ in 0..2000 {
                let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d(), &vertex) else {
                    continue;
                };
                // A delta sample's weight is not a density ratio.
                if s.delta {
                    continue;
                }
                let pdf = bsdf.pdf(wo, s.wi, &vertex);
                let same_pdf = (pdf - s.pdf).abs() <= 2e-3 * pdf.max(1e-3);
                assert!(
                    same_pdf,
                    "{name} wo {wo} wi {}: pdf {pdf} vs {}",
                    s.wi, s.pdf
                );
                let weight = bsdf.eval(wo, s.wi, &vertex) / pdf;
                let scale = weight.max_element().max(1e-3);
                let same = (weight - s.weight).abs().max_element() <= 2e-3 * scale;
                assert!(same, "{name} wo {wo} wi {}: {weight} vs {}", s.wi, s.weight);
            }
        }
    }
}

/// Pearson's chi-square test of sampled directions against the pdf
/// integrated over cells of (cos θ, φ), cells of fewer than 5 expected
/// samples pooled. The cells at the poles, where lobes through them fold
/// into a narrow band of cos θ, are integrated four times finer. The threshold is the chi-square quantile at a
/// significance of 1e-4 (Wilson–Hilferty), so a correct model fails a
/// random seed once in 10,000 runs; the seed here is fixed.
#[test]
fn sampling_matches_the_pdf_chi_square() {
    let (n_cos, n_phi) = (16, 32);
    let n = 400_000;
    let mut rng = Rng::new(11, 0);
    for (name, bsdf, vertex) in glossy() {
        let (lo, span) = cos_range(&bsdf);
        for wo in views() {
            let mut observed = vec![0u32; n_cos * n_phi];
            for _ in 0..n {
                // A delta lobe's samples fall outside the density; `pdf`
                // integrates to the share of the others.
                let sample = bsdf.sample(wo, rng.next_f32(), rng.next_2d(), &vertex);
                if let Some(s) = sample.filter(|s| !s.delta) {
                    let c = (s.wi.z as f64 - lo) / span;
                    let cell_c = ((c * n_cos as f64) as usize).min(n_cos - 1);
                    let phi = (s.wi.y as f64).atan2(s.wi.x as f64).rem_euclid(TAU);
                    let cell_p = ((phi / TAU * n_phi as f64) as usize).min(n_phi - 1);
                    observed[cell_c * n_phi + cell_p] += 1;
                }
            }
            let mut expected = vec![0.0f64; n_cos * n_phi];
            for (cell, e) in expected.iter_mut().enumerate() {
                let row = cell / n_phi;
                let sub = if row == 0 || row == n_cos - 1 { 96 } else { 24 };
                let (dc, dp) = (span / (n_cos * sub) as f64, TAU / (n_phi * sub) as f64);
                let c0 = lo + span * row as f64 / n_cos as f64;
                let p0 = (cell % n_phi) as f64 / n_phi as f64 * TAU;
                for i in 0..sub {
                    for j in 0..sub {
                        let wi = direction(c0 + (i as f64 + 0.5) * dc, p0 + (j as f64 + 0.5) * dp);
                        *e += bsdf.pdf(wo, wi, &vertex) as f64 * dc * dp * n as f64;
                    }
                }
            }
            let (chi2, dof) = chi_square(&observed, &expected);
            let limit = chi_square_quantile(dof as f64, 3.719);
            assert!(
                chi2 < limit,
                "{name} wo {wo}: chi² {chi2:.1} over {dof} dof (limit {limit:.1})"
            );
        }
    }
}

fn chi_square(observed: &[u32], expected: &[f64]) -> (f64, usize) {
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut chi2, mut cells) = (0.0, 0);
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    for i in order {
        let (o, e) = (observed[i] as f64, expected[i]);
        if e < 5.0 {
            pooled_o += o;
            pooled_e += e;
            if pooled_e >= 5.0 {
                chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
                cells += 1;
                (pooled_o, pooled_e) = (0.0, 0.0);
            }
        } else {
            chi2 += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pooled_e > 0.0 {
        chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e.max(1.0);
        cells += 1;
    }
    (chi2, cells - 1)
}

/// The chi-square quantile for `k` degrees of freedom at the normal
/// quantile `z` (Wilson and Hilferty's cube-root approximation).
fn chi_square_quantile(k: f64, z: f64) -> f64 {
    let h = 2.0 / (9.0 * k);
    k * (1.0 - h + z * h.sqrt()).powi(3)
}

/// The integral of `eval` over the directions (by uniform quadrature) is
/// the mean sampled weight of the non-delta lobes: no energy is lost or
/// gained between the two.
#[test]
fn eval_integrates_to_the_sampled_albedo() {
    let mut rng = Rng::new(13, 0);
    for (name, bsdf, vertex) in glossy() {
        let wo = direction(0.7, 0.5);
        let (lo, span) = cos_range(&bsdf);
        let (n_cos, n_phi) = (800, 200);
        let cell = span * TAU / (n_cos * n_phi) as f64;
        let mut integral = 0.0f64;
        for i in 0..n_cos {
            for j in 0..n_phi {
                let c = lo + span * (i as f64 + 0.5) / n_cos as f64;
                let wi = direction(c, (j as f64 + 0.5) / n_phi as f64 * TAU);
                integral += bsdf.eval(wo, wi, &vertex).y as f64 * cell;
            }
        }
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let sample = bsdf.sample(wo, rng.next_f32(), rng.next_2d(), &vertex);
            if let Some(s) = sample.filter(|s| !s.delta) {
                sum += s.weight.y as f64;
            }
        }
        let sampled = sum / n as f64;
        let agree = (integral - sampled).abs() < 0.01 + 0.01 * integral;
        assert!(agree, "{name}: ∫ eval {integral} vs E[weight] {sampled}");
    }
}

/// Mitsuba's fits of the diffuse Fresnel reflectance against 2∫F(μ)μ dμ.
#[test]
fn diffuse_fresnel_reflectance_matches_its_integral() {
    for eta in [0.5, 0.67, 0.8, 1.2, 1.5, 2.0, 3.0] {
        let n = 100_000;
        let integral: f64 = (0..n)
            .map(|i| {
                let mu = (i as f64 + 0.5) / n as f64;
                2.0 * crate::math::fresnel_dielectric(mu as f32, eta) as f64 * mu / n as f64
            })
            .sum();
        let fit = plastic::fresnel_diffuse_reflectance(eta) as f64;
        assert!(
            (fit - integral).abs() < 0.01 * integral.max(0.05),
            "η {eta}: fit {fit} vs {integral}"
        );
    }
}
