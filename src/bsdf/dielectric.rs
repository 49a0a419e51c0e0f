//! Dielectrics: a rough interface between two indices of refraction (Mitsuba
//! 3's `roughdielectric`, after Walter et al. 2007) and a thin sheet that
//! reflects or passes light straight on (`thindielectric`).
//!
//! The shading frame has `wo` on its +z side, and `eta` is the index of the
//! side facing away from `wo` over the index of `wo`'s side (the integrator
//! inverts the material's when the viewer is inside).

use super::microfacet::Microfacet;
use super::BsdfSample;
use crate::math::{fresnel_dielectric, reflect, refract, Rgb, Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    pub microfacet: Microfacet,
    /// Interior index over exterior index.
    pub eta: f32,
    /// Mitsuba's `specular_reflectance` and `specular_transmittance`.
    pub tint_r: Rgb,
    pub tint_t: Rgb,
}

impl RoughDielectric {
    pub fn survival(&self) -> f32 {
        self.tint_r
            .max_element()
            .max(self.tint_t.max_element())
            .min(1.0)
    }

    /// `eta`: far side over near side, for this vertex.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, eta: f32) -> Option<BsdfSample> {
        let md = &self.microfacet;
        let m = md.sample(wo, u);
        let visible = md.d(m) * md.smith_g1(wo, m) * wo.dot(m) / wo.z;
        let f = fresnel_dielectric(wo.dot(m), eta);
        if u_lobe <= f {
            let wi = reflect(wo, m);
            if wi.z <= 0.0 {
                return None;
            }
            let pdf = visible * f / (4.0 * wi.dot(m));
            return (pdf > 0.0).then(|| BsdfSample {
                wi,
                weight: self.tint_r * md.smith_g1(wi, m),
                pdf,
                delta: false,
            });
        }
        let wi = refract(wo, m, eta)?;
        if wi.z >= 0.0 {
            return None;
        }
        let denom = wo.dot(m) + eta * wi.dot(m);
        let pdf = visible * (1.0 - f) * (eta * eta * wi.dot(m)).abs() / (denom * denom);
        // Radiance is compressed by η² into the denser side.
        let weight = self.tint_t * (md.smith_g1(wi, m) / (eta * eta));
        (pdf > 0.0 && pdf.is_finite()).then_some(BsdfSample {
            wi,
            weight,
            pdf,
            delta: false,
        })
    }

    /// The microfacet normal joining `wo` and `wi`, on the +z side, and
    /// whether `wi` is a reflection.
    fn half_vector(wo: Vec3, wi: Vec3, eta: f32) -> Option<(Vec3, bool)> {
        let reflection = wi.z > 0.0;
        let h = if reflection { wo + wi } else { wo + eta * wi };
        let h = h.normalize_or_zero();
        let h = if h.z < 0.0 { -h } else { h };
        // Both directions must see the facet from their own side.
        let valid = h != Vec3::ZERO && wo.dot(h) > 0.0 && wi.dot(h) * wi.z > 0.0;
        valid.then_some((h, reflection))
    }

    /// f·|cos θi|.
    pub fn eval(&self, wo: Vec3, wi: Vec3, eta: f32) -> Rgb {
        let md = &self.microfacet;
        let Some((h, reflection)) = Self::half_vector(wo, wi, eta) else {
            return Rgb::ZERO;
        };
        let f = fresnel_dielectric(wo.dot(h), eta);
        let dg = md.d(h) * md.g(wo, wi, h);
        if reflection {
            return self.tint_r * (f * dg / (4.0 * wo.z));
        }
        let denom = wo.dot(h) + eta * wi.dot(h);
        let value = (1.0 - f) * dg * (wo.dot(h) * wi.dot(h)).abs() / (wo.z * denom * denom);
        self.tint_t * value
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3, eta: f32) -> f32 {
        let md = &self.microfacet;
        let Some((h, reflection)) = Self::half_vector(wo, wi, eta) else {
            return 0.0;
        };
        let f = fresnel_dielectric(wo.dot(h), eta);
        let visible = md.d(h) * md.smith_g1(wo, h) * wo.dot(h) / wo.z;
        if reflection {
            visible * f / (4.0 * wi.dot(h))
        } else {
            let denom = wo.dot(h) + eta * wi.dot(h);
            visible * (1.0 - f) * (eta * eta * wi.dot(h)).abs() / (denom * denom)
        }
    }
}

/// A sheet thin enough that light leaves where it entered, in its own
/// direction: every internal reflection is summed into one reflectance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    pub eta: f32,
    pub tint_r: Rgb,
    pub tint_t: Rgb,
}

impl ThinDielectric {
    pub fn survival(&self) -> f32 {
        self.tint_r
            .max_element()
            .max(self.tint_t.max_element())
            .min(1.0)
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32) -> BsdfSample {
        let r = fresnel_dielectric(wo.z, self.eta);
        // R + T²R/(1 − R²) with T = 1 − R.
        let r = 2.0 * r / (1.0 + r);
        let (wi, weight) = if u_lobe <= r {
            (Vec3::new(-wo.x, -wo.y, wo.z), self.tint_r)
        } else {
            (-wo, self.tint_t)
        };
        BsdfSample {
            wi,
            weight,
            pdf: 1.0,
            delta: true,
        }
    }
}
