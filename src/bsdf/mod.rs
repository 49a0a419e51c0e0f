//! Reflection models beyond the course's kd/ks/kt mix, behind one
//! interface in the shading frame (normal +z, `wo` towards the viewer, `wi`
//! towards the light): `sample`, `eval` (f·cos θi) and `pdf`, with the
//! Fresnel terms inside the models. They follow Mitsuba 3's plugins of the
//! same names, so that imported scenes render as Mitsuba renders them.
//!
//! Surfaces reflect on the side the viewer is on (luz's surfaces are
//! two-sided), so every model sees `wo.z` > 0 for a front-facing view.

pub mod conductor;
pub mod microfacet;
mod numeric;
pub mod plastic;

#[cfg(test)]
mod tests;

pub use conductor::Conductor;
pub use microfacet::{Distribution, Microfacet};
pub use plastic::RoughPlastic;

use crate::math::{Rgb, Vec2, Vec3};

/// A sampled incident direction and what it carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Towards the light, in the shading frame.
    pub wi: Vec3,
    /// f·cos θi / pdf.
    pub weight: Rgb,
    /// Solid-angle density of `wi` (meaningless for a delta lobe).
    pub pdf: f32,
    /// A delta lobe: never light-sampled, its emitter hits count fully.
    pub delta: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    Conductor(Conductor),
    RoughPlastic(RoughPlastic),
}

impl Bsdf {
    /// Whether every lobe is a delta, so that next-event estimation has
    /// nothing to evaluate.
    pub fn is_delta(&self) -> bool {
        matches!(self, Bsdf::Conductor(c) if c.roughness.is_none())
    }

    /// The survival probability of Russian roulette at a vertex seen from
    /// `wo`: about the fraction of light the surface reflects, in (0, 1].
    /// Any positive value keeps the estimate unbiased; this one keeps the
    /// path's weight from growing.
    pub fn survival(&self, wo: Vec3, diffuse: Rgb) -> f32 {
        match self {
            Bsdf::Conductor(c) => c.survival(),
            Bsdf::RoughPlastic(p) => p.survival(wo, diffuse),
        }
    }

    /// `diffuse` is the base colour at the point (textured), for the
    /// models that have one.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, diffuse: Rgb) -> Option<BsdfSample> {
        match self {
            Bsdf::Conductor(c) => c.sample(wo, u),
            Bsdf::RoughPlastic(p) => p.sample(wo, u_lobe, u, diffuse),
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, diffuse: Rgb) -> Rgb {
        match self {
            Bsdf::Conductor(c) => c.eval(wo, wi),
            Bsdf::RoughPlastic(p) => p.eval(wo, wi, diffuse),
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Conductor(c) => c.pdf(wo, wi),
            Bsdf::RoughPlastic(p) => p.pdf(wo, wi),
        }
    }
}
