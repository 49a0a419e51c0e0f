//! Mitsuba BSDFs mapped onto luz's material (Lambertian kd, mirror ks,
//! refraction kt, Fresnel dielectric). What does not map exactly is
//! substituted, with a warning that says by what.

use super::conductors::CONDUCTORS;
use super::props::{Props, Value};
use super::spectrum::Use;
use super::xml::Elem;
use super::Builder;
use crate::bsdf::{Conductor, Distribution, Microfacet, RoughPlastic};
use crate::echo::echo;
use crate::math::{luminance, Rgb};
use crate::scene::{Material, Opacity, SceneError, UvTransform};

/// A material and the uv transform its texture asks of the shapes using it.
#[derive(Clone, Debug)]
pub(super) struct Bsdf {
    pub material: Material,
    pub uv: Option<UvTransform>,
}

impl Bsdf {
    fn of(material: Material) -> Self {
        Self { material, uv: None }
    }
}

/// Mitsuba's named indices of refraction (include/mitsuba/render/ior.h).
const IORS: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// Nested BSDFs (twosided, mask, ...) go at most this deep.
const MAX_NESTING: usize = 16;

pub(super) fn bsdf(b: &mut Builder, e: &Elem) -> Result<Bsdf, SceneError> {
    if b.bsdf_depth >= MAX_NESTING {
        return Err(e.loc.error(format!(
            "BSDFs nest deeper than {MAX_NESTING} (a <ref> to a BSDF that contains it?)"
        )));
    }
    b.bsdf_depth += 1;
    let out = build(b, e);
    b.bsdf_depth -= 1;
    out
}

fn build(b: &mut Builder, e: &Elem) -> Result<Bsdf, SceneError> {
    let props = Props::new(e, b.ids);
    let name = e.attr("id").unwrap_or("").to_string();
    let mut out = match e.kind() {
        "diffuse" => diffuse(b, &props)?,
        "mask" => mask(b, &props)?,
        "twosided" | "bumpmap" | "normalmap" | "blendbsdf" => wrapper(b, &props)?,
        "conductor" | "roughconductor" => conductor(b, &props)?,
        "dielectric" | "roughdielectric" => dielectric(b, &props)?,
        "thindielectric" => thin_dielectric(b, &props)?,
        "plastic" | "roughplastic" => plastic(b, &props)?,
        // Light passes straight through: refraction with index 1.
        "null" => Bsdf::of(Material {
            kd: Rgb::ZERO,
            kt: Rgb::ONE,
            ior: 1.0,
            ..Material::default()
        }),
        other => {
            b.problems.warn(
                &e.loc,
                format!("<bsdf type=\"{other}\"> is not supported; substituted a 0.5 grey diffuse"),
            )?;
            // Its properties are part of what was substituted.
            for c in &e.children {
                if let Some(n) = c.attr("name") {
                    props.accept(n);
                }
            }
            Bsdf::of(Material::default())
        }
    };
    out.material.name = name;
    match e.kind() {
        // Mitsuba's reflecting models are black from behind, unless
        // wrapped in `twosided`; its dielectrics transmit both ways.
        "diffuse" | "conductor" | "roughconductor" | "plastic" | "roughplastic" => {
            out.material.one_sided = true
        }
        "twosided" => out.material.one_sided = false,
        _ => {}
    }
    props.finish(&mut b.problems)?;
    Ok(out)
}

/// A colour or texture property as kd: (albedo, texture, uv transform).
fn albedo(
    b: &mut Builder,
    props: &Props,
    name: &str,
    default: f32,
) -> Result<(Rgb, Option<u32>, Option<UvTransform>), SceneError> {
    match props.color(name, Use::Reflectance, &mut b.problems)? {
        None => Ok((Rgb::splat(default), None, None)),
        Some(Value::Rgb(c)) => Ok((clamp_albedo(b, props, name, c)?, None, None)),
        Some(Value::Texture(t)) => {
            let (texture, uv) = b.texture(t)?;
            Ok((Rgb::ONE, Some(texture), uv))
        }
    }
}

/// An albedo above 1 would create energy in luz; it is clamped.
fn clamp_albedo(b: &mut Builder, props: &Props, name: &str, c: Rgb) -> Result<Rgb, SceneError> {
    if c.max_element() > 1.0 {
        b.problems.warn(
            &props.elem.loc,
            format!(
                "`{name}` {c} exceeds 1 (the surface would create energy in luz); clamped to 1"
            ),
        )?;
    }
    Ok(c.min(Rgb::ONE))
}

fn diffuse(b: &mut Builder, props: &Props) -> Result<Bsdf, SceneError> {
    let (kd, texture, uv) = albedo(b, props, "reflectance", 0.5)?;
    Ok(Bsdf {
        material: Material {
            kd,
            texture,
            ..Material::default()
        },
        uv,
    })
}

/// twosided (luz reflects on both sides anyway) and the wrappers luz
/// cannot do, which keep their nested BSDF.
fn wrapper(b: &mut Builder, props: &Props) -> Result<Bsdf, SceneError> {
    let e = props.elem;
    let nested = props.objects("bsdf")?;
    let Some(first) = nested.first() else {
        return Err(e
            .loc
            .error(format!("{} needs a nested <bsdf>", e.describe())));
    };
    let what = match e.kind() {
        "twosided" if nested.len() > 1 => Some("a different back side is not supported"),
        "twosided" => None,
        "bumpmap" | "normalmap" => Some("the shading-normal perturbation is left out"),
        _ => Some("luz does not blend BSDFs"),
    };
    if let Some(what) = what {
        b.problems.warn(
            &e.loc,
            format!(
                "{}: {what}; substituted its first nested BSDF",
                e.describe()
            ),
        )?;
        for n in ["opacity", "weight", "texture", "scale", "normalmap"] {
            props.accept(n);
        }
    }
    bsdf(b, first)
}

/// `mask`: its nested BSDF with an `opacity` (Mitsuba's default 0.5), a
/// number or a texture's luminance.
fn mask(b: &mut Builder, props: &Props) -> Result<Bsdf, SceneError> {
    let e = props.elem;
    let nested = props.objects("bsdf")?;
    let [inner] = nested.as_slice() else {
        return Err(e.loc.error(format!(
            "{} needs exactly one nested <bsdf>, found {}",
            e.describe(),
            nested.len()
        )));
    };
    let (opacity, opacity_uv) = match props.color("opacity", Use::Reflectance, &mut b.problems)? {
        None => (Opacity::Constant(0.5), None),
        Some(Value::Rgb(c)) => (Opacity::Constant(luminance(c).clamp(0.0, 1.0)), None),
        Some(Value::Texture(t)) => {
            let (texture, uv) = b.texture(t)?;
            (Opacity::Texture(texture), uv)
        }
    };
    let mut out = bsdf(b, inner)?;
    out.material.opacity = Some(opacity);
    match (out.uv, opacity_uv) {
        (None, uv) => out.uv = uv,
        (Some(a), Some(o)) if a != o => b.problems.warn(
            &e.loc,
            "the opacity's `to_uv` differs from the nested BSDF's; luz maps both with the BSDF's",
        )?,
        _ => {}
    }
    Ok(out)
}

/// A rough model's microfacet distribution: Mitsuba's `distribution`
/// (default Beckmann) and `alpha` (default 0.1). luz's roughness is
/// isotropic and its normals are always sampled as seen from the viewer.
fn microfacet(b: &mut Builder, props: &Props) -> Result<Microfacet, SceneError> {
    let e = props.elem;
    let distribution = match props.string("distribution")? {
        None | Some("beckmann") => Distribution::Beckmann,
        Some("ggx") => Distribution::Ggx,
        Some(other) => {
            let at = props.get("distribution").map_or(&e.loc, |d| &d.loc);
            return Err(at.error(format!(
                "`distribution` {}: expected beckmann or ggx",
                echo(other)
            )));
        }
    };
    let alpha = match (
        props.float("alpha")?,
        props.float("alpha_u")?,
        props.float("alpha_v")?,
    ) {
        (Some(a), _, _) => a,
        (None, Some(u), Some(v)) => {
            b.problems.warn(
                &e.loc,
                format!("{}: luz's roughness is isotropic; substituted alpha = √(alpha_u·alpha_v) = {:.4}", e.describe(), (u * v).sqrt()),
            )?;
            (u * v).sqrt()
        }
        (None, None, None) => 0.1,
        _ => {
            return Err(e.loc.error(format!(
                "{}: give `alpha`, or both `alpha_u` and `alpha_v`",
                e.describe()
            )))
        }
    };
    if !(alpha >= 0.0 && alpha.is_finite()) {
        return Err(e.loc.error(format!(
            "`alpha` must be finite and not negative, got {alpha}"
        )));
    }
    if props.boolean("sample_visible")? == Some(false) {
        b.problems.warn(
            &e.loc,
            format!("{}: luz always samples the visible normals; `sample_visible` = false changes only the noise", e.describe()),
        )?;
    }
    Ok(Microfacet::new(distribution, alpha as f32))
}

fn conductor(b: &mut Builder, props: &Props) -> Result<Bsdf, SceneError> {
    let (eta, k) = conductor_index(props, &mut b.problems)?;
    let roughness = if props.elem.kind() == "roughconductor" {
        Some(microfacet(b, props)?)
    } else {
        None
    };
    let tint = tint(b, props, "specular_reflectance")?;
    Ok(Bsdf::of(Material {
        kd: Rgb::ZERO,
        bsdf: Some(crate::bsdf::Bsdf::Conductor(Conductor {
            eta,
            k,
            tint,
            roughness,
        })),
        ..Material::default()
    }))
}

/// The conductor's complex index relative to the outside, from `eta`/`k`
/// or a named `material` (`none`, the default, is a perfect mirror: η = 0,
/// k = 1), divided by `ext_eta` as in Mitsuba.
fn conductor_index(
    props: &Props,
    problems: &mut super::Problems,
) -> Result<(Rgb, Rgb), SceneError> {
    let e = props.elem;
    let ext = props.float("ext_eta")?.unwrap_or(1.0);
    if !(ext > 0.0 && ext.is_finite()) {
        return Err(e
            .loc
            .error(format!("`ext_eta` must be positive and finite, got {ext}")));
    }
    let eta = props.color("eta", Use::Index, problems)?;
    let k = props.color("k", Use::Index, problems)?;
    let material = props.string("material")?.unwrap_or("none");
    let constant = |v: Option<Value>, default: f32, name: &str| match v {
        None => Ok(Rgb::splat(default)),
        Some(Value::Rgb(c)) => Ok(c),
        Some(Value::Texture(_)) => Err(e
            .loc
            .error(format!("`{name}`: a texture is not supported here"))),
    };
    let (eta, k) = if eta.is_some() || material == "none" {
        (constant(eta, 0.0, "eta")?, constant(k, 1.0, "k")?)
    } else {
        let Some((_, eta, k)) = CONDUCTORS.iter().find(|(m, _, _)| *m == material) else {
            let at = props.get("material").map_or(&e.loc, |m| &m.loc);
            return Err(at.error(format!(
                "`material` {}: not one of Mitsuba's conductors ({})",
                echo(material),
                CONDUCTORS
                    .iter()
                    .map(|(n, _, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        (Rgb::from(*eta), Rgb::from(*k))
    };
    Ok((eta / ext as f32, k / ext as f32))
}

/// `int_ior` / `ext_ior`: a number or one of Mitsuba's names.
fn ior(props: &Props, name: &str, default: f64) -> Result<f64, SceneError> {
    let Some(e) = props.get(name) else {
        return Ok(default);
    };
    let v = e.need("value")?;
    if let Ok(x) = v.trim().parse::<f64>() {
        if x > 0.0 && x.is_finite() {
            return Ok(x);
        }
    }
    IORS.iter()
        .find(|(n, _)| *n == v.trim())
        .map(|(_, x)| *x)
        .ok_or_else(|| {
            e.loc.error(format!(
                "`{name}`: expected a positive number or a named index ({}), found {}",
                IORS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
                echo(v)
            ))
        })
}

fn relative_ior(props: &Props, int_default: f64) -> Result<f64, SceneError> {
    Ok(ior(props, "int_ior", int_default)? / ior(props, "ext_ior", 1.000277)?)
}

fn dielectric(b: &mut Builder, props: &Props) -> Result<Bsdf, SceneError> {
    let e = props.elem;
    let ior = relative_ior(props, 1.5046)?;
    let kt = tint(b, props, "specular_transmittance")?;
    let kr = tint(b, props, "specular_reflectance")?;
    if e.kind() == "roughdielectric" {
        let model = crate::bsdf::RoughDielectric {
            microfacet: microfacet(b, props)?,
            eta: ior as f32,
            tint_r: kr,
            tint_t: kt,
        };
        return Ok(Bsdf::of(Material {
            kd: Rgb::ZERO,
            bsdf: Some(crate::bsdf::Bsdf::RoughDielectric(model)),
            ..Material::default()
        }));
    }
    if kr != Rgb::ONE {
        b.problems.warn(
            &e.loc,
            format!("{}: luz's dielectric reflects by the Fresnel term alone; `specular_reflectance` is substituted by 1", e.describe()),
        )?;
    }
    Ok(Bsdf::of(Material {
        kd: Rgb::ZERO,
        kt,
        ior: ior as f32,
        dielectric: true,
        ..Material::default()
    }))
}

/// A constant tint in [0, 1], 1 when absent.
fn tint(b: &mut Builder, props: &Props, name: &str) -> Result<Rgb, SceneError> {
    match props.color(name, Use::Reflectance, &mut b.problems)? {
        Some(Value::Rgb(c)) => clamp_albedo(b, props, name, c),
        Some(Value::Texture(_)) => {
            b.problems.warn(
                &props.elem.loc,
                format!("`{name}`: a texture here is not supported; substituted 1"),
            )?;
            Ok(Rgb::ONE)
        }
        None => Ok(Rgb::ONE),
    }
}

/// A thin sheet: luz's `ThinDielectric`, as Mitsuba's.
fn thin_dielectric(b: &mut Builder, props: &Props) -> Result<Bsdf, SceneError> {
    let model = crate::bsdf::ThinDielectric {
        eta: relative_ior(props, 1.5046)? as f32,
        tint_r: tint(b, props, "specular_reflectance")?,
        tint_t: tint(b, props, "specular_transmittance")?,
    };
    Ok(Bsdf::of(Material {
        kd: Rgb::ZERO,
        bsdf: Some(crate::bsdf::Bsdf::ThinDielectric(model)),
        ..Material::default()
    }))
}

/// `roughplastic` and `plastic` as luz's rough and smooth plastics.
fn plastic(b: &mut Builder, props: &Props) -> Result<Bsdf, SceneError> {
    let e = props.elem;
    let ior = relative_ior(props, 1.49)?;
    let (kd, texture, uv) = albedo(b, props, "diffuse_reflectance", 0.5)?;
    let tint = tint(b, props, "specular_reflectance")?;
    if e.kind() == "roughplastic" {
        let coating = microfacet(b, props)?;
        let nonlinear = props.boolean("nonlinear")?.unwrap_or(false);
        // Mitsuba steers samples by the mean of the base's texture; luz by
        // its colour factor, which is 1 under a texture.
        let mean = (kd.x + kd.y + kd.z) / 3.0;
        let model = RoughPlastic::new(coating, ior as f32, tint, mean, nonlinear);
        return Ok(Bsdf {
            material: Material {
                kd,
                texture,
                bsdf: Some(crate::bsdf::Bsdf::RoughPlastic(model)),
                ..Material::default()
            },
            uv,
        });
    }
    let nonlinear = props.boolean("nonlinear")?.unwrap_or(false);
    let mean = (kd.x + kd.y + kd.z) / 3.0;
    let model = crate::bsdf::Plastic::new(ior as f32, tint, mean, nonlinear);
    Ok(Bsdf {
        material: Material {
            kd,
            texture,
            bsdf: Some(crate::bsdf::Bsdf::Plastic(model)),
            ..Material::default()
        },
        uv,
    })
}
