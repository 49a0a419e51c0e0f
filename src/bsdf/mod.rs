//! Reflection models beyond the course's kd/ks/kt mix, behind one
//! interface in the shading frame (normal +z, `wo` towards the viewer, `wi`
//! towards the light): `sample`, `eval` (f·cos θi) and `pdf`, with the
//! Fresnel terms inside the models. They follow Mitsuba 3's plugins of the
//! same names, so that imported scenes render as Mitsuba renders them.
//!
//! The frame's +z is on the viewer's side (luz's surfaces are two-sided), so
//! every model sees `wo.z` > 0; `Context` says which side that is.

pub mod conductor;
pub mod dielectric;
pub mod microfacet;
mod numeric;
pub mod plastic;

#[cfg(test)]
mod tests;

pub use conductor::Conductor;
pub use dielectric::{RoughDielectric, ThinDielectric};
pub use microfacet::{Distribution, Microfacet};
pub use plastic::{Plastic, RoughPlastic};

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

/// What a model needs of the vertex beyond the two directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Context {
    /// The base colour at the point (textured), for the models that have one.
    pub diffuse: Rgb,
    /// Whether the viewer is on the front (outer) side of the surface.
    pub front: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    Conductor(Conductor),
    Plastic(Plastic),
    RoughPlastic(RoughPlastic),
    RoughDielectric(RoughDielectric),
    ThinDielectric(ThinDielectric),
}

impl Bsdf {
    /// Whether every lobe is a delta, so that next-event estimation has
    /// nothing to evaluate.
    pub fn is_delta(&self) -> bool {
        matches!(self, Bsdf::Conductor(c) if c.roughness.is_none())
            || matches!(self, Bsdf::ThinDielectric(_))
    }

    /// Whether light can leave on the side away from the viewer, so that
    /// lights behind the surface are sampled too.
    pub fn transmits(&self) -> bool {
        matches!(self, Bsdf::RoughDielectric(_) | Bsdf::ThinDielectric(_))
    }

    /// The survival probability of Russian roulette at a vertex seen from
    /// `wo`: about the fraction of light the surface reflects, in (0, 1].
    /// Any positive value keeps the estimate unbiased; this one keeps the
    /// path's weight from growing.
    pub fn survival(&self, wo: Vec3, ctx: &Context) -> f32 {
        match self {
            Bsdf::Conductor(c) => c.survival(),
            Bsdf::Plastic(p) => p.survival(wo, ctx.diffuse),
            Bsdf::RoughPlastic(p) => p.survival(wo, ctx.diffuse),
            Bsdf::RoughDielectric(d) => d.survival(),
            Bsdf::ThinDielectric(t) => t.survival(),
        }
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, ctx: &Context) -> Option<BsdfSample> {
        match self {
            Bsdf::Conductor(c) => c.sample(wo, u),
            Bsdf::Plastic(p) => p.sample(wo, u_lobe, u, ctx.diffuse),
            Bsdf::RoughPlastic(p) => p.sample(wo, u_lobe, u, ctx.diffuse),
            Bsdf::RoughDielectric(d) => d.sample(wo, u_lobe, u, relative(d.eta, ctx)),
            Bsdf::ThinDielectric(t) => Some(t.sample(wo, u_lobe)),
        }
    }

    /// f·|cos θi|.
    pub fn eval(&self, wo: Vec3, wi: Vec3, ctx: &Context) -> Rgb {
        match self {
            Bsdf::Conductor(c) => c.eval(wo, wi),
            Bsdf::Plastic(p) => p.eval(wo, wi, ctx.diffuse),
            Bsdf::RoughPlastic(p) => p.eval(wo, wi, ctx.diffuse),
            Bsdf::RoughDielectric(d) => d.eval(wo, wi, relative(d.eta, ctx)),
            Bsdf::ThinDielectric(_) => Rgb::ZERO,
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3, ctx: &Context) -> f32 {
        match self {
            Bsdf::Conductor(c) => c.pdf(wo, wi),
            Bsdf::Plastic(p) => p.pdf(wo, wi),
            Bsdf::RoughPlastic(p) => p.pdf(wo, wi),
            Bsdf::RoughDielectric(d) => d.pdf(wo, wi, relative(d.eta, ctx)),
            Bsdf::ThinDielectric(_) => 0.0,
        }
    }
}

/// The index of the far side over the viewer's.
fn relative(eta: f32, ctx: &Context) -> f32 {
    if ctx.front {
        eta
    } else {
        1.0 / eta
    }
}
