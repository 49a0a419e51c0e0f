//! The `[camera]` and `[render]` tables.

use super::*;

impl Ctx<'_> {
    pub(super) fn camera(&self, c: &Sp<CameraDesc>) -> Result<Camera, SceneError> {
        let span = c.span();
        let cd = c.get_ref();
        let eye = self.point3(&span, "eye", cd.eye)?;
        let target = self.point3(&span, "target", cd.target)?;
        let up = self.finite3(&span, "up", cd.up.unwrap_or([0.0, 1.0, 0.0]))?;
        // Both within MAX_COORDINATE: the difference is finite.
        if target == eye {
            return Err(self.field_error(&span, "target", "must differ from `eye`"));
        }
        if up == Vec3::ZERO {
            return Err(self.field_error(&span, "up", "must not be zero"));
        }
        // In f64, of unit vectors: neither a huge nor a tiny `up` (or view
        // direction) over- or underflows. An angle under 1e-6 rad leaves
        // the image's orientation to rounding.
        let (d, u) = ((target - eye).as_dvec3(), up.as_dvec3());
        let (d, u) = (d / d.abs().max_element(), u / u.abs().max_element());
        let sin = d.normalize().cross(u.normalize()).length();
        // (Both unit vectors are finite: `sin` is a number.)
        if sin < 1e-6 {
            return Err(self.field_error(
                &span,
                "up",
                "must not be parallel to the view direction",
            ));
        }
        // A tiny or huge `up` is scaled to unit length, so the basis's
        // cross products neither under- nor overflow.
        let up = if (1e-12..1e12).contains(&up.length_squared()) {
            up
        } else {
            u.normalize().as_vec3a()
        };
        let fov = cd.fov.unwrap_or(40.0);
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.field_error(
                &span,
                "fov",
                format!("must be in (0, 180) degrees, got {fov}"),
            ));
        }
        let [width, height] = cd.resolution.unwrap_or([512, 512]);
        check_resolution(width, height)
            .map_err(|message| self.field_error(&span, "resolution", message))?;
        let camera = Camera {
            eye,
            target,
            up,
            fov_y: fov,
            fov_axis: FovAxis::Y,
            width,
            height,
        };
        // What the renderer derives: every axis finite and non-zero.
        let b = camera.basis();
        let axes = [b.forward, b.right, b.up];
        if axes.iter().any(|a| !a.is_finite() || *a == Vec3::ZERO) {
            return Err(self.field_error(
                &span,
                "eye",
                format!(
                    "the camera's basis is not finite (forward {}, right {}, up {})",
                    vec3(b.forward),
                    vec3(b.right),
                    vec3(b.up)
                ),
            ));
        }
        Ok(camera)
    }

    pub(super) fn render(&self, r: &Sp<RenderDesc>) -> Result<RenderSettings, SceneError> {
        let rd = r.get_ref();
        let d = RenderSettings::default();
        let spp = rd.spp.unwrap_or(d.spp);
        if spp == 0 {
            return Err(self.field_error(&r.span(), "spp", "must be at least 1"));
        }
        Ok(RenderSettings {
            spp,
            max_depth: rd.max_depth.unwrap_or(d.max_depth),
            seed: rd.seed.unwrap_or(d.seed),
            russian_roulette: rd.russian_roulette.unwrap_or(d.russian_roulette),
            sampler: match &rd.sampler {
                Some(name) => name
                    .parse::<SamplerKind>()
                    .map_err(|e| self.field_error(&r.span(), "sampler", e))?,
                None => d.sampler,
            },
        })
    }
}
