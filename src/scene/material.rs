//! Materials: the Lambertian + perfect mirror + perfect refraction mix of the
//! course path tracer (coefficients chosen by Russian roulette), with the
//! physical conventions of SCENES.md (BRDF kd/π), a Fresnel dielectric for
//! glass, and emission for area lights.

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
            || self.texture.is_some()
            || (self.kd + self.ks + self.kt).max_element() > 0.0
    }
}
