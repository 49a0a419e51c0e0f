//! Rough plastic: a diffuse base under a rough dielectric coating, as
//! Mitsuba 3's `roughplastic` models it. Light either reflects off the
//! coating (a microfacet lobe with the dielectric Fresnel term) or enters,
//! scatters diffusely, and leaves, attenuated by the coating's rough
//! transmittance on the way in and out and by the light the coating
//! reflects back inside.

use super::microfacet::Microfacet;
use super::numeric::gauss_legendre;
use super::BsdfSample;
use crate::math::{fresnel_dielectric, reflect, refract, Rgb, Vec2, Vec3};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;

/// Cosines at which the coating's transmittance is tabulated (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`), evenly from 0 to 1.
const TABLE: usize = 64;

#[derive(Clone, Debug, PartialEq)]
pub struct RoughPlastic {
    pub microfacet: Microfacet,
    /// Index of refraction of the coating relative to the outside.
    pub eta: f32,
    /// Mitsuba's `specular_reflectance` (1 when absent).
    pub tint: Rgb,
    /// Whether the diffuse base's colour saturates through repeated
    /// internal bounces (Mitsuba's `nonlinear`).
    pub nonlinear: bool,
    /// The share of samples sent to the coating before the Fresnel
    /// weighting: tint mean / (diffuse mean + tint mean).
    specular_weight: f32,
    /// The coating's transmittance from outside, by incidence cosine.
    transmittance: Box<[f32; TABLE]>,
    /// Its reflectance from inside, averaged over the cosine-weighted
    /// hemisphere.
    internal_reflectance: f32,
}

impl RoughPlastic {
    /// `diffuse_mean` is the mean of the base's reflectance (of its
    /// texture, if any), which steers samples as in Mitsuba.
    pub fn new(
        microfacet: Microfacet,
        eta: f32,
        tint: Rgb,
        diffuse_mean: f32,
        nonlinear: bool,
    ) -> Self {
        let cosines: Vec<f32> = (0..TABLE)
            .map(|i| (i as f32 / (TABLE - 1) as f32).max(1e-6))
            .collect();
        let mut transmittance = Box::new([0.0; TABLE]);
        let t: Vec<f32> = cosines
            .par_iter()
            .map(|&c| coating_average(&microfacet, c, eta, Interaction::Transmit))
            .collect();
        transmittance.copy_from_slice(&t);
        let reflectance: f32 = cosines
            .par_iter()
            .map(|&c| coating_average(&microfacet, c, 1.0 / eta, Interaction::Reflect) * c)
            .sum();
        let s_mean = (tint.x + tint.y + tint.z) / 3.0;
        Self {
            microfacet,
            eta,
            tint,
            nonlinear,
            specular_weight: s_mean / (diffuse_mean + s_mean),
            transmittance,
            internal_reflectance: 2.0 * reflectance / TABLE as f32,
        }
    }

    fn transmittance(&self, cos: f32) -> f32 {
        let x = cos * (TABLE - 1) as f32;
        let i = (x as usize).min(TABLE - 2);
        let (a, b) = (self.transmittance[i], self.transmittance[i + 1]);
        a + (b - a) * (x - i as f32)
    }

    fn specular_probability(&self, cos_o: f32) -> f32 {
        let t = self.transmittance(cos_o);
        let specular = (1.0 - t) * self.specular_weight;
        let diffuse = t * (1.0 - self.specular_weight);
        specular / (specular + diffuse)
    }

    /// About the fraction reflected towards `wo`: the coating's share
    /// plus the base's, each at its largest channel.
    pub fn survival(&self, wo: Vec3, diffuse: Rgb) -> f32 {
        let t = self.transmittance(wo.z.clamp(0.0, 1.0));
        ((1.0 - t) * self.tint.max_element() + t * diffuse.max_element()).min(1.0)
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, diffuse: Rgb) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.specular_probability(wo.z) {
            reflect(wo, self.microfacet.sample(wo, u))
        } else {
            cosine_hemisphere(u)
        };
        by_density(wi, self.eval(wo, wi, diffuse), self.pdf(wo, wi))
    }

    /// f·cos θi.
    pub fn eval(&self, wo: Vec3, wi: Vec3, diffuse: Rgb) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let md = &self.microfacet;
        let h = (wo + wi).normalize();
        let coat =
            fresnel_dielectric(wo.dot(h), self.eta) * md.d(h) * md.g(wo, wi, h) / (4.0 * wo.z);
        let bounced = if self.nonlinear {
            diffuse * self.internal_reflectance
        } else {
            Rgb::splat(self.internal_reflectance)
        };
        let base = diffuse / (Rgb::ONE - bounced)
            * (FRAC_1_PI / (self.eta * self.eta)
                * wi.z
                * self.transmittance(wo.z)
                * self.transmittance(wi.z));
        self.tint * coat + base
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let md = &self.microfacet;
        let h = (wo + wi).normalize();
        let p = self.specular_probability(wo.z);
        p * md.d(h) * md.smith_g1(wo, h) / (4.0 * wo.z) + (1.0 - p) * cosine_hemisphere_pdf(wi.z)
    }
}

/// A sample of a lobe mixture: weighted by the whole mixture's `f_cos` and
/// `pdf` at `wi`, so that MIS sees one density.
fn by_density(wi: Vec3, f_cos: Rgb, pdf: f32) -> Option<BsdfSample> {
    (pdf > 0.0).then(|| BsdfSample {
        wi,
        weight: f_cos / pdf,
        pdf,
        delta: false,
    })
}

#[derive(Clone, Copy, PartialEq)]
enum Interaction {
    Reflect,
    Transmit,
}

/// The fraction of light arriving at cosine `cos` that a rough interface of
/// relative index `eta` reflects or transmits (shadowing on the way out
/// included), by Gauss–Legendre quadrature over its visible normals, as
/// Mitsuba's `eval_reflectance` / `eval_transmittance` compute it.
fn coating_average(md: &Microfacet, cos: f32, eta: f32, what: Interaction) -> f32 {
    let wi = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
    let rule = gauss_legendre(if eta > 1.0 { 32 } else { 128 });
    let mut sum = 0.0f64;
    for &(x, wx) in &rule {
        for &(y, wy) in &rule {
            let u = Vec2::new((0.5 * x + 0.5) as f32, (0.5 * y + 0.5) as f32);
            let m = md.sample(wi, u);
            let f = fresnel_dielectric(wi.dot(m), eta);
            let kept = match what {
                Interaction::Reflect => {
                    let wo = reflect(wi, m);
                    if wo.z > 0.0 {
                        md.smith_g1(wo, m) * f
                    } else {
                        0.0
                    }
                }
                Interaction::Transmit => match refract(wi, m, eta) {
                    Some(wt) if wt.z < 0.0 => md.smith_g1(wt, m) * (1.0 - f),
                    _ => 0.0,
                },
            };
            sum += kept as f64 * wx * wy * 0.25;
        }
    }
    sum as f32
}

/// Smooth plastic: a diffuse base under a smooth dielectric coating, as
/// Mitsuba 3's `plastic`. The coating reflects as a mirror (a delta lobe) by
/// its Fresnel term; the base's light crosses it twice and is attenuated by
/// the coating's diffuse reflectance from inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    pub eta: f32,
    pub tint: Rgb,
    pub nonlinear: bool,
    specular_weight: f32,
    /// The coating's hemispherical (diffuse) reflectance from inside.
    internal_reflectance: f32,
}

impl Plastic {
    pub fn new(eta: f32, tint: Rgb, diffuse_mean: f32, nonlinear: bool) -> Self {
        let s_mean = (tint.x + tint.y + tint.z) / 3.0;
        Self {
            eta,
            tint,
            nonlinear,
            specular_weight: s_mean / (diffuse_mean + s_mean),
            internal_reflectance: fresnel_diffuse_reflectance(1.0 / eta),
        }
    }

    fn specular_probability(&self, cos_o: f32) -> f32 {
        let f = fresnel_dielectric(cos_o, self.eta);
        let specular = f * self.specular_weight;
        specular / (specular + (1.0 - f) * (1.0 - self.specular_weight))
    }

    pub fn survival(&self, wo: Vec3, diffuse: Rgb) -> f32 {
        let f = fresnel_dielectric(wo.z.clamp(0.0, 1.0), self.eta);
        (f * self.tint.max_element() + (1.0 - f) * diffuse.max_element()).min(1.0)
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, diffuse: Rgb) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.specular_probability(wo.z);
        if u_lobe < p {
            let f = fresnel_dielectric(wo.z, self.eta);
            return Some(BsdfSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                weight: self.tint * (f / p),
                pdf: p,
                delta: true,
            });
        }
        let wi = cosine_hemisphere(u);
        by_density(wi, self.eval(wo, wi, diffuse), self.pdf(wo, wi))
    }

    /// f·cos θi of the diffuse lobe (the mirror is a delta).
    pub fn eval(&self, wo: Vec3, wi: Vec3, diffuse: Rgb) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let bounced = if self.nonlinear {
            diffuse * self.internal_reflectance
        } else {
            Rgb::splat(self.internal_reflectance)
        };
        let crossing =
            (1.0 - fresnel_dielectric(wo.z, self.eta)) * (1.0 - fresnel_dielectric(wi.z, self.eta));
        diffuse / (Rgb::ONE - bounced)
            * (cosine_hemisphere_pdf(wi.z) * crossing / (self.eta * self.eta))
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - self.specular_probability(wo.z)) * cosine_hemisphere_pdf(wi.z)
    }
}

/// The hemispherical reflectance of a smooth interface of relative index
/// `eta` under uniform diffuse light, by the fits Mitsuba uses: Egan and
/// Hilgeman (1973) for η < 1, d'Eon and Irving (2011) otherwise.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        [-3.4793, 6.75335, -7.80989, 4.98554, -1.36881]
            .iter()
            .rev()
            .fold(0.0, |acc, c| c + inv * acc)
            * inv
            + 0.919317
    }
}
