//! `<transform>`: translate, rotate, scale, matrix and lookat, each applied
//! after the ones before it (Mitsuba left-multiplies), in f64.

use super::props::{number, numbers, vector};
use super::xml::Elem;
use crate::echo::echo;
use crate::scene::SceneError;
use glam::{DMat3, DMat4, DVec3, DVec4};

pub(super) fn parse(e: &Elem) -> Result<DMat4, SceneError> {
    let mut m = DMat4::IDENTITY;
    for step in &e.children {
        m = one(step)? * m;
    }
    if !m.is_finite() {
        return Err(e.loc.error("<transform>: the matrix is not finite"));
    }
    Ok(m)
}

fn one(s: &Elem) -> Result<DMat4, SceneError> {
    Ok(match s.tag.as_str() {
        "translate" => DMat4::from_translation(vector(s, 0.0)?),
        "scale" => {
            let v = vector(s, 1.0)?;
            DMat4::from_scale(v)
        }
        "rotate" => {
            let axis = vector(s, 0.0)?;
            let angle = number(s, s.need("angle")?)?;
            if axis.length_squared() == 0.0 {
                return Err(s.loc.error("<rotate>: the axis is zero"));
            }
            DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
        }
        "matrix" => matrix(s)?,
        "lookat" => lookat(s)?,
        other => {
            return Err(s.loc.error(format!(
            "<transform>: unknown step <{other}> (known: translate, rotate, scale, matrix, lookat)"
        )))
        }
    })
}

/// 16 numbers (4×4) or 9 (3×3), row by row.
fn matrix(s: &Elem) -> Result<DMat4, SceneError> {
    let v = s.need("value")?;
    let n = numbers(s, v)?;
    match n.len() {
        16 => Ok(DMat4::from_cols_array(&n.try_into().expect("16 numbers")).transpose()),
        9 => {
            let m3 = DMat3::from_cols_array(&n.try_into().expect("9 numbers")).transpose();
            Ok(DMat4::from_mat3(m3))
        }
        k => Err(s.loc.error(format!(
            "<matrix>: `value` needs 16 (or 9) numbers, found {k} in {}",
            echo(v)
        ))),
    }
}

/// Mitsuba's look-at: local +z to the target, +y towards `up`, +x to the
/// left (`up × dir`).
fn lookat(s: &Elem) -> Result<DMat4, SceneError> {
    let point = |name: &str| -> Result<Option<DVec3>, SceneError> {
        let Some(v) = s.attr(name) else {
            return Ok(None);
        };
        match numbers(s, v)?[..] {
            [x, y, z] => Ok(Some(DVec3::new(x, y, z))),
            _ => Err(s.loc.error(format!(
                "<lookat>: `{name}` needs 3 numbers, found {}",
                echo(v)
            ))),
        }
    };
    let origin = point("origin")?.ok_or_else(|| s.loc.error("<lookat> needs `origin`"))?;
    let target = point("target")?.ok_or_else(|| s.loc.error("<lookat> needs `target`"))?;
    let dir = (target - origin).normalize_or_zero();
    if dir == DVec3::ZERO {
        return Err(s.loc.error("<lookat>: `target` must differ from `origin`"));
    }
    let up = match point("up")? {
        Some(up) => up,
        None => dir.any_orthonormal_vector(),
    };
    let left = up.cross(dir).normalize_or_zero();
    if left == DVec3::ZERO {
        return Err(s
            .loc
            .error("<lookat>: `up` must not be parallel to the view direction"));
    }
    let new_up = dir.cross(left);
    Ok(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        DVec4::new(origin.x, origin.y, origin.z, 1.0),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mitsuba::xml::Reader;
    use std::path::Path;

    fn transform(steps: &str) -> Result<DMat4, SceneError> {
        let text =
            format!(r#"<scene version="3.0.0"><transform name="t">{steps}</transform></scene>"#);
        let scene = Reader::new(&[], Path::new("t.xml")).scene(&text, Path::new("t.xml"))?;
        parse(&scene.children[0])
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-9
    }

    #[test]
    fn every_step_and_their_order() {
        let m = transform(r#"<scale value="2"/><translate x="1"/>"#).unwrap();
        assert!(close(
            m.transform_point3(DVec3::ONE),
            DVec3::new(3.0, 2.0, 2.0)
        ));
        let m = transform(r#"<rotate y="1" angle="90"/>"#).unwrap();
        assert!(close(m.transform_vector3(DVec3::X), -DVec3::Z));
        let m = transform(r#"<matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/>"#).unwrap();
        assert!(close(
            m.transform_point3(DVec3::ZERO),
            DVec3::new(5.0, 6.0, 7.0)
        ));
        let m = transform(r#"<lookat origin="0,0,5" target="0,0,0" up="0,1,0"/>"#).unwrap();
        assert!(close(
            m.transform_point3(DVec3::ZERO),
            DVec3::new(0.0, 0.0, 5.0)
        ));
        assert!(close(m.transform_vector3(DVec3::Z), -DVec3::Z));
        assert!(close(m.transform_vector3(DVec3::X), -DVec3::X));
    }

    #[test]
    fn bad_steps_are_located() {
        let e = transform("\n<matrix value=\"1 2 3\"/>").unwrap_err();
        assert_eq!(e.location, Some((2, 1)));
        assert!(transform(r#"<lookat origin="1,1,1" target="1,1,1"/>"#).is_err());
        assert!(transform(r#"<shear/>"#).is_err());
    }
}
