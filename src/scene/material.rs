//! Materials: the Lambertian + perfect mirror + perfect refraction mix of the
//! course path tracer (coefficients chosen by Russian roulette), with the
//! physical conventions of SCENES.md (BRDF kd/π), a Fresnel dielectric for
//! glass, and emission for area lights; or one of the reflection models of
//! `crate::bsdf` (conductors, rough plastic), which replaces the mix.

use crate::bsdf::Bsdf;
use crate::math::Rgb;

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse albedo (Lambertian BRDF kd/π); modulated by `texture`.
    pub kd: Rgb,
    /// Perfect mirror reflectance.
    pub ks: Rgb,
    /// Perfect refraction transmittance.
    pub kt: Rgb,
    /// Index of refraction of the inside (outside is 1).
    pub ior: f32,
    /// Smooth dielectric: reflection and refraction weighted by the exact
    /// unpolarised Fresnel term instead of fixed ks/kt; `kt` tints it.
    pub dielectric: bool,
    /// Emitted radiance from the front side.
    pub emission: Rgb,
    pub texture: Option<u32>,
    /// A reflection model in place of the kd/ks/kt mix; `kd` (textured)
    /// is then the base colour of the models that have one.
    pub bsdf: Option<Bsdf>,
    /// How much of the surface is there (Mitsuba's `mask`); `None` is
    /// opaque.
    pub opacity: Option<Opacity>,
    /// Black from behind, as Mitsuba's reflecting BSDFs are unless wrapped
    /// in `twosided`; luz's own materials reflect on both sides.
    pub one_sided: bool,
}

/// The fraction of a surface that is there: light meets the material with
/// this probability and otherwise passes straight through (a cut-out leaf,
/// a net).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Opacity {
    /// In [0, 1].
    Constant(f32),
    /// A texture's luminance (Mitsuba's `eval_1` of a colour texture).
    Texture(u32),
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: String::new(),
            kd: Rgb::splat(0.5),
            ks: Rgb::ZERO,
            kt: Rgb::ZERO,
            ior: 1.5,
            dielectric: false,
            emission: Rgb::ZERO,
            texture: None,
            bsdf: None,
            opacity: None,
            one_sided: false,
        }
    }
}

impl Material {
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Whether any lobe can scatter: absorbing surfaces end paths at once.
    pub fn scatters(&self) -> bool {
        self.dielectric
            || self.bsdf.is_some()
            || self.texture.is_some()
            || (self.kd + self.ks + self.kt).max_element() > 0.0
    }
}

/// What a vertex on a material has to evaluate, decided once when the scene
/// is assembled (`Scene::new`) so that a vertex pays only for the lobes its
/// material has.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shading {
    pub emissive: bool,
    pub lobes: Lobes,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lobes {
    /// Untextured Lambertian: the only lobe's weight, `max(kd)`, is a
    /// constant of the material.
    Diffuse { weight: f32 },
    /// A texture, a mirror, refraction or a Fresnel dielectric: the weights
    /// of the three lobes are evaluated at each vertex.
    Mixed,
    /// A model of `crate::bsdf`.
    Bsdf,
}

impl Material {
    pub fn shading(&self) -> Shading {
        let diffuse_only = self.texture.is_none()
            && !self.dielectric
            && self.ks == Rgb::ZERO
            && self.kt == Rgb::ZERO;
        Shading {
            emissive: self.is_emissive(),
            lobes: if self.bsdf.is_some() {
                Lobes::Bsdf
            } else if diffuse_only {
                Lobes::Diffuse {
                    weight: self.kd.max_element(),
                }
            } else {
                Lobes::Mixed
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_untextured_lambertian_materials_shade_as_diffuse() {
        let grey = Material::default();
        assert_eq!(grey.shading().lobes, Lobes::Diffuse { weight: 0.5 });
        let mirror = Material {
            ks: Rgb::splat(0.2),
            ..Material::default()
        };
        let glass = Material {
            kd: Rgb::ZERO,
            dielectric: true,
            ..Material::default()
        };
        let textured = Material {
            texture: Some(0),
            ..Material::default()
        };
        for m in [mirror, glass, textured] {
            assert_eq!(m.shading().lobes, Lobes::Mixed, "{m:?}");
        }
        let light = Material {
            kd: Rgb::ZERO,
            emission: Rgb::ONE,
            ..Material::default()
        };
        assert_eq!(
            light.shading(),
            Shading {
                emissive: true,
                lobes: Lobes::Diffuse { weight: 0.0 }
            }
        );
    }
}
