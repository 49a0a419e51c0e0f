//! The upgrade Mitsuba 3 applies to files older than version 2.0
//! (`upgrade_from_v1` in its src/core/parser.cpp): property names from
//! camelCase to snake_case, a diffuse BSDF's `diffuse_reflectance` to
//! `reflectance`, and `uoffset`/`voffset`/`uscale`/`vscale` to a `to_uv`
//! transform. 0.5's `lookAt` tag is read as `lookat`.

use super::xml::Elem;

/// Mitsuba's `camel_to_underscore_case`: an upper-case letter after a
/// lower-case one starts a new word, and the upper-case run that follows
/// is part of it (`intIOR` → `int_ior`, `toWorld` → `to_world`).
pub(super) fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

/// Tag names that changed.
pub(super) fn tag(tag: &str) -> String {
    match tag {
        "lookAt" => "lookat".into(),
        other => other.to_string(),
    }
}

/// The per-plugin rules, applied to the (already renamed) properties of a
/// plugin of type `kind`.
pub(super) fn plugin(kind: Option<&str>, props: &mut Vec<Elem>) {
    if kind == Some("diffuse") {
        for p in props.iter_mut() {
            rename(p, "diffuse_reflectance", "reflectance");
        }
    }
    let uv_names = ["uoffset", "voffset", "uscale", "vscale"];
    let (uv, rest): (Vec<Elem>, Vec<Elem>) = std::mem::take(props)
        .into_iter()
        .partition(|p| p.attr("name").is_some_and(|n| uv_names.contains(&n)));
    *props = rest;
    if let Some(first) = uv.first() {
        props.push(to_uv(&uv, first));
    }
}

fn rename(p: &mut Elem, from: &str, to: &str) {
    for (k, v) in p.attrs.iter_mut() {
        if k == "name" && v == from {
            *v = to.to_string();
        }
    }
}

/// `to_uv = scale(uscale, vscale) · translate(uoffset, voffset)`, written
/// as the `<transform>` Mitsuba 3 would read: the translation first.
fn to_uv(uv: &[Elem], first: &Elem) -> Elem {
    let value = |name: &str, default: &str| {
        uv.iter()
            .find(|p| p.attr("name") == Some(name))
            .and_then(|p| p.attr("value"))
            .unwrap_or(default)
            .to_string()
    };
    let step = |tag: &str, x: String, y: String| Elem {
        tag: tag.into(),
        attrs: vec![("x".into(), x), ("y".into(), y)],
        children: vec![],
        loc: first.loc.clone(),
    };
    Elem {
        tag: "transform".into(),
        attrs: vec![("name".into(), "to_uv".into())],
        children: vec![
            step("translate", value("uoffset", "0"), value("voffset", "0")),
            step("scale", value("uscale", "1"), value("vscale", "1")),
        ],
        loc: first.loc.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_becomes_snake_case_as_mitsuba_does() {
        for (old, new) in [
            ("toWorld", "to_world"),
            ("intIOR", "int_ior"),
            ("extEta", "ext_eta"),
            ("sampleCount", "sample_count"),
            ("diffuseReflectance", "diffuse_reflectance"),
            ("fovAxis", "fov_axis"),
            ("max_depth", "max_depth"),
            ("UV", "UV"),
        ] {
            assert_eq!(snake_case(old), new);
        }
    }
}
