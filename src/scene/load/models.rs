//! `[materials.NAME]` of the reflection models (`crate::bsdf`): conductors,
//! smooth and rough plastic and rough dielectrics.

use super::*;
use crate::bsdf::{
    Bsdf, Conductor, Distribution, Microfacet, Plastic, RoughDielectric, RoughPlastic,
};

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Conductor,
    Plastic,
    RoughPlastic,
    RoughDielectric,
}

impl Kind {
    fn of(md: &MaterialDesc) -> Self {
        match md.kind.as_deref() {
            Some("conductor") => Kind::Conductor,
            Some("plastic") => Kind::Plastic,
            Some("roughplastic") => Kind::RoughPlastic,
            _ => Kind::RoughDielectric,
        }
    }

    /// The fields of the kd/ks/kt mix a model does not take.
    fn refused(self, md: &MaterialDesc) -> Option<&'static str> {
        let set = match self {
            Kind::Conductor => vec![
                ("kd", md.kd.is_some()),
                ("kt", md.kt.is_some()),
                ("ior", md.ior.is_some()),
                ("texture", md.texture.is_some()),
            ],
            Kind::Plastic => vec![
                ("kt", md.kt.is_some()),
                ("eta", md.eta.is_some()),
                ("k", md.k.is_some()),
                ("roughness", md.roughness.is_some()),
                ("distribution", md.distribution.is_some()),
            ],
            Kind::RoughPlastic => vec![
                ("kt", md.kt.is_some()),
                ("eta", md.eta.is_some()),
                ("k", md.k.is_some()),
            ],
            Kind::RoughDielectric => vec![
                ("kd", md.kd.is_some()),
                ("eta", md.eta.is_some()),
                ("k", md.k.is_some()),
                ("texture", md.texture.is_some()),
            ],
        };
        set.into_iter()
            .find_map(|(field, given)| given.then_some(field))
    }
}

impl Ctx<'_> {
    pub(super) fn model(
        &self,
        name: &str,
        m: &Sp<MaterialDesc>,
        textures: &BTreeMap<String, u32>,
    ) -> Result<Material, SceneError> {
        let span = m.span();
        let md = m.get_ref();
        let kind = Kind::of(md);
        if let Some(field) = kind.refused(md) {
            let what = md.kind.as_deref().unwrap_or_default();
            let message = format!("a {what} material has no `{field}`");
            return Err(self.field_error(&span, field, message));
        }
        let (distribution, roughness) = self.roughness(&span, md)?;
        let tint = self.color(&span, "ks", md.ks, Rgb::ONE, 1.0)?;
        let emission = self.color(&span, "emission", md.emission, Rgb::ZERO, f32::INFINITY)?;
        let (kd, texture, bsdf) = match kind {
            Kind::Conductor => {
                let bsdf = Bsdf::Conductor(Conductor {
                    eta: self.color(&span, "eta", md.eta, Rgb::ZERO, f32::INFINITY)?,
                    k: self.color(&span, "k", md.k, Rgb::ONE, f32::INFINITY)?,
                    tint,
                    roughness: roughness.map(|a| Microfacet::new(distribution, a)),
                });
                (Rgb::ZERO, None, bsdf)
            }
            Kind::Plastic => {
                let kd = self.color(&span, "kd", md.kd, Rgb::splat(0.5), 1.0)?;
                let ior = self.interface_ior(&span, md, 1.49)?;
                let mean = (kd.x + kd.y + kd.z) / 3.0;
                let model = Plastic::new(ior, tint, mean, false);
                let texture = self.texture_of(&span, md, textures)?;
                (kd, texture, Bsdf::Plastic(model))
            }
            Kind::RoughPlastic => {
                let kd = self.color(&span, "kd", md.kd, Rgb::splat(0.5), 1.0)?;
                let ior = self.interface_ior(&span, md, 1.49)?;
                let coating = Microfacet::new(distribution, roughness.unwrap_or(0.1));
                let mean = (kd.x + kd.y + kd.z) / 3.0;
                let model = RoughPlastic::new(coating, ior, tint, mean, false);
                let texture = self.texture_of(&span, md, textures)?;
                (kd, texture, Bsdf::RoughPlastic(model))
            }
            Kind::RoughDielectric => {
                let bsdf = Bsdf::RoughDielectric(RoughDielectric {
                    microfacet: Microfacet::new(distribution, roughness.unwrap_or(0.1)),
                    eta: self.interface_ior(&span, md, 1.5)?,
                    tint_r: tint,
                    tint_t: self.color(&span, "kt", md.kt, Rgb::ONE, 1.0)?,
                });
                (Rgb::ZERO, None, bsdf)
            }
        };
        Ok(Material {
            name: name.to_string(),
            kd,
            emission,
            texture,
            bsdf: Some(bsdf),
            ..Material::default()
        })
    }

    /// `distribution` (default GGX) and `roughness` (α > 0, if given).
    fn roughness(
        &self,
        span: &Range<usize>,
        md: &MaterialDesc,
    ) -> Result<(Distribution, Option<f32>), SceneError> {
        let distribution = match md.distribution.as_deref() {
            None | Some("ggx") => Distribution::Ggx,
            Some("beckmann") => Distribution::Beckmann,
            Some(other) => {
                let message = format!(
                    "unknown distribution {} (known: ggx, beckmann)",
                    echo(other)
                );
                return Err(self.field_error(span, "distribution", message));
            }
        };
        match md.roughness {
            Some(a) if !(a > 0.0 && a.is_finite()) => {
                let message = format!("must be positive and finite, got {a}");
                Err(self.field_error(span, "roughness", message))
            }
            a => Ok((distribution, a)),
        }
    }

    /// The `ior` of an interface: positive, finite and not 1 (no interface).
    fn interface_ior(
        &self,
        span: &Range<usize>,
        md: &MaterialDesc,
        default: f32,
    ) -> Result<f32, SceneError> {
        let ior = md.ior.unwrap_or(default);
        if ior > 0.0 && ior.is_finite() && ior != 1.0 {
            Ok(ior)
        } else {
            let message = format!("must be positive, finite and not 1, got {ior}");
            Err(self.field_error(span, "ior", message))
        }
    }
}
