//! Conductors: a smooth mirror or a rough microfacet surface whose Fresnel
//! reflectance comes from a complex index of refraction η + ik per channel,
//! as Mitsuba 3's `conductor` and `roughconductor` evaluate it.

use super::microfacet::Microfacet;
use super::BsdfSample;
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Real part of the index of refraction, relative to the outside.
    pub eta: Rgb,
    /// Imaginary part (absorption).
    pub k: Rgb,
    /// Mitsuba's `specular_reflectance`: a tint that is not physical.
    pub tint: Rgb,
    /// `None` for a smooth mirror.
    pub roughness: Option<Microfacet>,
}

/// Unpolarised reflectance of a conductor at incidence cosine `cos_i`
/// (Mitsuba's `fresnel_conductor`, after K. D. Moeller, "Optics", 1988).
pub fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let cos2 = cos_i * cos_i;
    let sin2 = 1.0 - cos2;
    let sin4 = sin2 * sin2;
    let t1 = eta * eta - k * k - sin2;
    let a2_b2 = (t1 * t1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2_b2 + t1)).max(0.0).sqrt();
    let term1 = a2_b2 + cos2;
    let term2 = 2.0 * cos_i * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2_b2 * cos2 + sin4;
    let term4 = term2 * sin2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    0.5 * (r_s + r_p)
}

impl Conductor {
    fn fresnel(&self, cos_i: f32) -> Rgb {
        let f = |eta, k| fresnel_conductor(cos_i, eta, k);
        Rgb::new(
            f(self.eta.x, self.k.x),
            f(self.eta.y, self.k.y),
            f(self.eta.z, self.k.z),
        ) * self.tint
    }

    /// The largest reflectance at normal incidence: about what the
    /// surface reflects.
    pub fn survival(&self) -> f32 {
        self.fresnel(1.0).max_element()
    }

    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let Some(md) = self.roughness else {
            return Some(BsdfSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                weight: self.fresnel(wo.z),
                pdf: 1.0,
                delta: true,
            });
        };
        let m = md.sample(wo, u);
        let wi = crate::math::reflect(wo, m);
        let pdf = md.d(m) * md.smith_g1(wo, m) / (4.0 * wo.z);
        if wi.z <= 0.0 || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.fresnel(wo.dot(m)) * md.smith_g1(wi, m),
            pdf,
            delta: false,
        })
    }

    /// f·cos θi; zero for the smooth mirror (a delta).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self.roughness {
            Some(md) if wo.z > 0.0 && wi.z > 0.0 => {
                let h = (wo + wi).normalize();
                self.fresnel(wo.dot(h)) * (md.d(h) * md.g(wo, wi, h) / (4.0 * wo.z))
            }
            _ => Rgb::ZERO,
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self.roughness {
            Some(md) if wo.z > 0.0 && wi.z > 0.0 => {
                let h = (wo + wi).normalize();
                if wo.dot(h) <= 0.0 || wi.dot(h) <= 0.0 {
                    return 0.0;
                }
                md.d(h) * md.smith_g1(wo, h) / (4.0 * wo.z)
            }
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conductor_fresnel_limits() {
        // A perfect mirror (η = 0, k = 1) reflects everything at every angle.
        for c in [1.0, 0.5, 0.01] {
            assert!((fresnel_conductor(c, 0.0, 1.0) - 1.0).abs() < 1e-5);
        }
        // With k = 0 it is the dielectric reflectance.
        for c in [1.0, 0.7, 0.3] {
            let want = crate::math::fresnel_dielectric(c, 1.5);
            assert!((fresnel_conductor(c, 1.5, 0.0) - want).abs() < 1e-5, "{c}");
        }
        // Normal incidence: ((η − 1)² + k²) / ((η + 1)² + k²).
        let (eta, k) = (0.2, 3.9);
        let want = ((eta - 1.0f32).powi(2) + k * k) / ((eta + 1.0f32).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, eta, k) - want).abs() < 1e-5);
        // Grazing: everything is reflected.
        assert!(fresnel_conductor(1e-4, eta, k) > 0.99);
    }
}
