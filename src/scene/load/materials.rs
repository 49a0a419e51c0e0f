//! The `[textures]` and `[materials]` tables.

use super::*;
use crate::scene::Opacity;

impl Ctx<'_> {
    pub(super) fn texture(&self, name: &str, t: &Sp<TextureDesc>) -> Result<Texture, SceneError> {
        let span = t.span();
        let td = t.get_ref();
        match (&td.file, &td.checker) {
            (Some(file), None) => {
                if td.squares.is_some() {
                    return Err(self.field_error(
                        &span,
                        "squares",
                        "only a checker texture has squares",
                    ));
                }
                let path = self.resolve_file(&span, file)?;
                let img = crate::image::io::read_texture(&path).map_err(|e| {
                    self.field_error(&span, "file", format!("texture {}: {e}", echo(name)))
                })?;
                Ok(Texture::Image {
                    width: img.width,
                    height: img.height,
                    texels: img.pixels,
                })
            }
            (None, Some([a, b])) => {
                let squares = td.squares.unwrap_or(8.0);
                if !(squares > 0.0 && squares.is_finite()) {
                    return Err(self.field_error(&span, "squares", "must be positive and finite"));
                }
                Ok(Texture::Checker {
                    a: self.color(&span, "checker", Some(*a), Rgb::ZERO, 1.0)?,
                    b: self.color(&span, "checker", Some(*b), Rgb::ZERO, 1.0)?,
                    squares,
                })
            }
            _ => Err(self.error_at(
                span.start,
                format!(
                    "texture {} needs exactly one of `file` or `checker`",
                    echo(name)
                ),
            )),
        }
    }

    pub(super) fn material(
        &self,
        name: &str,
        m: &Sp<MaterialDesc>,
        textures: &BTreeMap<String, u32>,
    ) -> Result<Material, SceneError> {
        let opacity = self.opacity(m, textures)?;
        Ok(Material {
            opacity,
            ..self.surface(name, m, textures)?
        })
    }

    /// `opacity`: a number in [0, 1] or the name of a texture whose
    /// luminance it is.
    fn opacity(
        &self,
        m: &Sp<MaterialDesc>,
        textures: &BTreeMap<String, u32>,
    ) -> Result<Option<Opacity>, SceneError> {
        let span = m.span();
        match &m.get_ref().opacity {
            None => Ok(None),
            Some(OpacityDesc::Constant(alpha)) if (0.0..=1.0).contains(alpha) => {
                Ok(Some(Opacity::Constant(*alpha)))
            }
            Some(OpacityDesc::Constant(alpha)) => Err(self.field_error(
                &span,
                "opacity",
                format!("must be in [0, 1] or a texture's name, got {alpha}"),
            )),
            Some(OpacityDesc::Texture(t)) => match textures.get(t) {
                Some(&id) => Ok(Some(Opacity::Texture(id))),
                None => {
                    Err(self.field_error(&span, "opacity", format!("no texture named {}", echo(t))))
                }
            },
        }
    }

    fn surface(
        &self,
        name: &str,
        m: &Sp<MaterialDesc>,
        textures: &BTreeMap<String, u32>,
    ) -> Result<Material, SceneError> {
        let span = m.span();
        let md = m.get_ref();
        let dielectric = match md.kind.as_deref() {
            None | Some("diffuse") | Some("standard") => false,
            Some("dielectric") | Some("glass") if md.roughness.is_some() => {
                return self.model(name, m, textures)
            }
            Some("dielectric") | Some("glass") => true,
            Some("conductor") | Some("plastic") | Some("roughplastic") => {
                return self.model(name, m, textures)
            }
            Some(other) => {
                return Err(self.field_error(
                    &span,
                    "type",
                    format!(
                        "unknown material type {} (known: standard, dielectric, conductor, plastic, roughplastic)",
                        echo(other)
                    ),
                ))
            }
        };
        if let Some(field) = [
            ("eta", md.eta.is_some()),
            ("k", md.k.is_some()),
            ("roughness", md.roughness.is_some()),
            ("distribution", md.distribution.is_some()),
        ]
        .into_iter()
        .find_map(|(f, set)| set.then_some(f))
        {
            return Err(self.field_error(
                &span,
                field,
                "only a conductor, plastic, roughplastic or rough dielectric material has this field",
            ));
        }
        let texture = self.texture_of(&span, md, textures)?;
        let (kd_default, kt_default) = if dielectric {
            (Rgb::ZERO, Rgb::ONE)
        } else if md.ks.is_some() || md.kt.is_some() || md.emission.is_some() {
            (Rgb::ZERO, Rgb::ZERO)
        } else {
            (Rgb::splat(0.5), Rgb::ZERO)
        };
        let kd = self.color(&span, "kd", md.kd, kd_default, 1.0)?;
        let ks = self.color(&span, "ks", md.ks, Rgb::ZERO, 1.0)?;
        let kt = self.color(&span, "kt", md.kt, kt_default, 1.0)?;
        if dielectric && (md.kd.is_some() || md.ks.is_some()) {
            let field = if md.kd.is_some() { "kd" } else { "ks" };
            return Err(self.field_error(
                &span,
                field,
                "a dielectric reflects and refracts by the Fresnel term; only `kt` (a tint) and `ior` apply",
            ));
        }
        let total = kd + ks + kt;
        if total.max_element() > 1.0 + 1e-6 {
            let field = ["kd", "ks", "kt"]
                .into_iter()
                .zip([md.kd, md.ks, md.kt])
                .rfind(|(_, v)| v.is_some())
                .map_or("kd", |(f, _)| f);
            return Err(self.field_error(
                &span,
                field,
                format!("material {}: kd + ks + kt = {total} exceeds 1 in some channel (the surface would create energy)", echo(name)),
            ));
        }
        let ior = md.ior.unwrap_or(1.5);
        if !(ior > 0.0 && ior.is_finite()) {
            return Err(self.field_error(
                &span,
                "ior",
                format!("must be positive and finite, got {ior}"),
            ));
        }
        let emission = self.color(&span, "emission", md.emission, Rgb::ZERO, f32::INFINITY)?;
        Ok(Material {
            name: name.to_string(),
            kd,
            ks,
            kt,
            ior,
            dielectric,
            emission,
            texture,
            bsdf: None,
            opacity: None,
            one_sided: false,
        })
    }

    pub(super) fn texture_of(
        &self,
        span: &std::ops::Range<usize>,
        md: &MaterialDesc,
        textures: &BTreeMap<String, u32>,
    ) -> Result<Option<u32>, SceneError> {
        match &md.texture {
            Some(t) => Ok(Some(*textures.get(t).ok_or_else(|| {
                self.field_error(span, "texture", format!("no texture named {}", echo(t)))
            })?)),
            None => Ok(None),
        }
    }
}
