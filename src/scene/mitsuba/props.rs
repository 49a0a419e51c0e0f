//! The properties of one plugin element (`<float name=...>`, `<rgb>`,
//! nested objects, `<ref>`s), read by name and ticked off as they are used,
//! so that whatever luz did not use is reported, never dropped silently.

use super::spectrum::{self, Use};
use super::transform;
use super::xml::Elem;
use super::Problems;
use crate::echo::echo;
use crate::math::Rgb;
use crate::scene::SceneError;
use glam::{DMat4, DVec3};
use std::cell::Cell;
use std::collections::HashMap;

/// Elements that carry an `id`, by id.
pub(super) type Ids<'e> = HashMap<String, &'e Elem>;

/// A colour property: a constant or a texture element.
pub(super) enum Value<'e> {
    Rgb(Rgb),
    Texture(&'e Elem),
}

pub(super) struct Props<'e, 'i> {
    pub elem: &'e Elem,
    ids: &'i Ids<'e>,
    used: Vec<Cell<bool>>,
}

impl<'e, 'i> Props<'e, 'i> {
    pub fn new(elem: &'e Elem, ids: &'i Ids<'e>) -> Self {
        Self {
            elem,
            ids,
            used: elem.children.iter().map(|_| Cell::new(false)).collect(),
        }
    }

    /// The property named `name`, marked used.
    pub fn get(&self, name: &str) -> Option<&'e Elem> {
        let i = self
            .elem
            .children
            .iter()
            .position(|c| c.attr("name") == Some(name))?;
        self.used[i].set(true);
        Some(&self.elem.children[i])
    }

    /// Marks a property used without reading it: luz does what it asks
    /// anyway (or it changes nothing luz computes).
    pub fn accept(&self, name: &str) {
        self.get(name);
    }

    /// The nested objects of tag `tag` (inline, or `<ref id>`s to one),
    /// marked used: unnamed, or named as their tag (`<ref name="bsdf"
    /// id="..."/>`, as Mitsuba's own scenes write); other names are
    /// properties.
    pub fn objects(&self, tag: &str) -> Result<Vec<&'e Elem>, SceneError> {
        let mut out = Vec::new();
        for (i, c) in self.elem.children.iter().enumerate() {
            if c.attr("name").is_some_and(|n| n != tag) {
                continue;
            }
            let target = if c.tag == "ref" { self.resolve(c)? } else { c };
            if target.tag == tag {
                self.used[i].set(true);
                out.push(target);
            }
        }
        Ok(out)
    }

    /// The element a `<ref id>` names.
    pub fn resolve(&self, r: &Elem) -> Result<&'e Elem, SceneError> {
        let id = r.need("id")?;
        self.ids.get(id).copied().ok_or_else(|| {
            r.loc
                .error(format!("<ref>: no element has the id {}", echo(id)))
        })
    }

    pub fn float(&self, name: &str) -> Result<Option<f64>, SceneError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        expect_tag(e, &["float", "integer"])?;
        number(e, e.need("value")?).map(Some)
    }

    pub fn integer(&self, name: &str) -> Result<Option<i64>, SceneError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        expect_tag(e, &["integer"])?;
        let v = e.need("value")?;
        v.trim().parse().map(Some).map_err(|_| {
            e.loc
                .error(format!("`{name}`: expected an integer, found {}", echo(v)))
        })
    }

    pub fn boolean(&self, name: &str) -> Result<Option<bool>, SceneError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        expect_tag(e, &["boolean"])?;
        match e.need("value")?.trim() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            v => Err(e.loc.error(format!(
                "`{name}`: expected true or false, found {}",
                echo(v)
            ))),
        }
    }

    pub fn string(&self, name: &str) -> Result<Option<&'e str>, SceneError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        expect_tag(e, &["string"])?;
        e.need("value").map(Some)
    }

    pub fn point(&self, name: &str) -> Result<Option<DVec3>, SceneError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        expect_tag(e, &["point", "vector"])?;
        vector(e, 0.0).map(Some)
    }

    pub fn transform(&self, name: &str) -> Result<Option<DMat4>, SceneError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        expect_tag(e, &["transform"])?;
        transform::parse(e).map(Some)
    }

    /// A colour or texture property (`<rgb>`, `<spectrum>`, `<float>`,
    /// `<texture>` or a `<ref>` to one).
    pub fn color(
        &self,
        name: &str,
        use_: Use,
        problems: &mut Problems,
    ) -> Result<Option<Value<'e>>, SceneError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        let e = if e.tag == "ref" { self.resolve(e)? } else { e };
        let rgb = match e.tag.as_str() {
            "texture" => return Ok(Some(Value::Texture(e))),
            "rgb" => rgb(e)?,
            "float" => Rgb::splat(number(e, e.need("value")?)? as f32),
            "spectrum" => spectrum(e, use_)?,
            "blackbody" | "srgb" => {
                problems.warn(
                    &e.loc,
                    format!(
                        "`{name}`: <{}> is not supported; substituted 0.5 grey",
                        e.tag
                    ),
                )?;
                Rgb::splat(0.5)
            }
            _ => {
                return Err(e
                    .loc
                    .error(format!("`{name}`: expected a colour, found <{}>", e.tag)))
            }
        };
        if !rgb.is_finite() || rgb.min_element() < 0.0 {
            return Err(e.loc.error(format!(
                "`{name}`: every channel must be finite and non-negative, got {rgb}"
            )));
        }
        Ok(Some(Value::Rgb(rgb)))
    }

    /// Warns, in one line, about every property and object luz did not use.
    pub fn finish(self, problems: &mut Problems) -> Result<(), SceneError> {
        let unused: Vec<String> = self
            .elem
            .children
            .iter()
            .zip(&self.used)
            .filter(|(_, u)| !u.get())
            .map(|(c, _)| match c.attr("name") {
                Some(n) => format!("`{n}`"),
                None => c.describe(),
            })
            .collect();
        if unused.is_empty() {
            return Ok(());
        }
        problems.warn(
            &self.elem.loc,
            format!(
                "{}: luz does not use {}; ignored",
                self.elem.describe(),
                unused.join(", ")
            ),
        )
    }
}

fn expect_tag(e: &Elem, tags: &[&str]) -> Result<(), SceneError> {
    if tags.contains(&e.tag.as_str()) {
        return Ok(());
    }
    Err(e.loc.error(format!(
        "`{}`: expected <{}>, found <{}>",
        e.attr("name").unwrap_or(""),
        tags.join("> or <"),
        e.tag
    )))
}

/// A finite number.
pub(super) fn number(e: &Elem, s: &str) -> Result<f64, SceneError> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(e.loc.error(format!(
            "{}: expected a finite number, found {}",
            e.describe(),
            echo(s)
        ))),
    }
}

/// Numbers separated by commas and/or spaces.
pub(super) fn numbers(e: &Elem, s: &str) -> Result<Vec<f64>, SceneError> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| number(e, t))
        .collect()
}

/// `x`, `y`, `z` attributes (each defaulting to `default`), or `value`
/// with three numbers (or one for all three).
pub(super) fn vector(e: &Elem, default: f64) -> Result<DVec3, SceneError> {
    if let Some(v) = e.attr("value") {
        return match numbers(e, v)?[..] {
            [x] => Ok(DVec3::splat(x)),
            [x, y, z] => Ok(DVec3::new(x, y, z)),
            _ => Err(e.loc.error(format!(
                "{}: `value` needs 1 or 3 numbers, found {}",
                e.describe(),
                echo(v)
            ))),
        };
    }
    let axis = |name: &str| e.attr(name).map_or(Ok(default), |v| number(e, v));
    Ok(DVec3::new(axis("x")?, axis("y")?, axis("z")?))
}

fn rgb(e: &Elem) -> Result<Rgb, SceneError> {
    let v = e.need("value")?;
    if v.trim_start().starts_with('#') {
        return hex(e, v.trim());
    }
    match numbers(e, v)?[..] {
        [g] => Ok(Rgb::splat(g as f32)),
        [r, g, b] => Ok(Rgb::new(r as f32, g as f32, b as f32)),
        _ => Err(e.loc.error(format!(
            "<rgb>: `value` needs 1 or 3 numbers, found {}",
            echo(v)
        ))),
    }
}

/// `#rrggbb`, sRGB-encoded as Mitsuba reads it.
fn hex(e: &Elem, v: &str) -> Result<Rgb, SceneError> {
    let bad = || {
        e.loc
            .error(format!("<rgb>: expected #rrggbb, found {}", echo(v)))
    };
    if v.len() != 7 {
        return Err(bad());
    }
    let c = |i: usize| u8::from_str_radix(&v[i..i + 2], 16).map_err(|_| bad());
    let lin = |b: u8| crate::image::io::srgb_to_linear(b as f32 / 255.0);
    Ok(Rgb::new(lin(c(1)?), lin(c(3)?), lin(c(5)?)))
}

fn spectrum(e: &Elem, use_: Use) -> Result<Rgb, SceneError> {
    if e.attr("filename").is_some() {
        return Err(e.loc.error(
            "<spectrum filename>: spectra from files are not supported; write the wavelength:value pairs",
        ));
    }
    let v = e.need("value")?;
    if !v.contains(':') {
        return Ok(spectrum::uniform(number(e, v)?, use_));
    }
    let mut w = Vec::new();
    let mut values = Vec::new();
    for pair in v.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = pair.split_once(':').ok_or_else(|| {
            e.loc.error(format!(
                "<spectrum>: expected wavelength:value, found {}",
                echo(pair)
            ))
        })?;
        w.push(number(e, a)?);
        values.push(number(e, b)?);
    }
    spectrum::to_rgb(&w, &values, use_)
        .ok_or_else(|| e.loc.error("<spectrum>: the wavelengths must ascend"))
}
