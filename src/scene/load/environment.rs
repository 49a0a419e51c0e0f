//! The `[environment]` table: a constant `radiance`, or a latitude-longitude
//! `map` with `scale` and `rotate`.

use super::*;
use crate::scene::{EnvMap, Environment};

impl Ctx<'_> {
    pub(super) fn environment(&self, e: &Sp<EnvironmentDesc>) -> Result<Environment, SceneError> {
        let span = e.span();
        let ed = e.get_ref();
        let Some(file) = &ed.map else {
            if let Some(field) = [
                ("scale", ed.scale.is_some()),
                ("rotate", ed.rotate.is_some()),
            ]
            .into_iter()
            .find_map(|(f, set)| set.then_some(f))
            {
                return Err(self.field_error(
                    &span,
                    field,
                    "only an environment `map` has this field",
                ));
            }
            let Some(radiance) = ed.radiance else {
                return Err(self.error_at(span.start, "the environment needs `radiance` or `map`"));
            };
            let c = self.color(&span, "radiance", Some(radiance), Rgb::ZERO, f32::INFINITY)?;
            return Ok(Environment::Constant(c));
        };
        if ed.radiance.is_some() {
            return Err(self.field_error(&span, "radiance", "give `radiance` or `map`, not both"));
        }
        let path = self.resolve_file(&span, file)?;
        let img = crate::image::io::read(&path)
            .map_err(|err| self.field_error(&span, "map", format!("{}: {err}", echo(file))))?;
        if img.width < 2 || img.height < 2 {
            return Err(self.field_error(&span, "map", "must be at least 2×2 texels"));
        }
        if img
            .pixels
            .iter()
            .any(|p| !p.is_finite() || p.min_element() < 0.0)
        {
            return Err(self.field_error(
                &span,
                "map",
                format!("{}: has negative or non-finite texels", echo(file)),
            ));
        }
        let scale = ed.scale.unwrap_or(1.0);
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(self.field_error(
                &span,
                "scale",
                format!("must be finite and not negative, got {scale}"),
            ));
        }
        let r = self.finite3(&span, "rotate", ed.rotate.unwrap_or([0.0; 3]))?;
        let rotation = Mat3::from_rotation_z(r.z.to_radians())
            * Mat3::from_rotation_y(r.y.to_radians())
            * Mat3::from_rotation_x(r.x.to_radians());
        let map = EnvMap::new(img.width, img.height, img.pixels, scale, rotation);
        Ok(Environment::Map(map))
    }
}
