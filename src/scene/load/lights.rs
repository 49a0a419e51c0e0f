//! `[[lights]]`: point lights, and spot lights with Mitsuba's cone.

use super::*;
use crate::scene::SpotCone;

impl Ctx<'_> {
    /// A `point` or `spot` light of `[[lights]]`.
    pub(super) fn point_light(&self, l: &Sp<LightDesc>) -> Result<PointLight, SceneError> {
        let span = l.span();
        let ld = l.get_ref();
        let position = self.point3(&span, "position", ld.position)?;
        let intensity = self.color(
            &span,
            "intensity",
            Some(ld.intensity),
            Rgb::ZERO,
            f32::INFINITY,
        )?;
        let spot = match ld.kind.as_str() {
            "point" => {
                let spot_keys = [
                    ("target", ld.target.is_some()),
                    ("cutoff_angle", ld.cutoff_angle.is_some()),
                    ("beam_width", ld.beam_width.is_some()),
                ];
                if let Some((key, _)) = spot_keys.iter().find(|(_, given)| *given) {
                    return Err(self.field_error(
                        &span,
                        key,
                        "only a `spot` light takes it: a point light shines everywhere",
                    ));
                }
                None
            }
            "spot" => Some(self.spot_cone(&span, ld, position)?),
            other => {
                return Err(self.field_error(
                    &span,
                    "type",
                    format!(
                        "unknown light type {}: [[lights]] are `point` or `spot`; area lights are shapes whose material has `emission`",
                        echo(other)
                    ),
                ))
            }
        };
        Ok(PointLight {
            position,
            intensity,
            spot,
        })
    }

    /// A spot light's cone: aimed at `target`, Mitsuba's default angles
    /// (a 20° cutoff, the full beam three quarters of it).
    fn spot_cone(
        &self,
        span: &Range<usize>,
        ld: &LightDesc,
        position: Vec3,
    ) -> Result<SpotCone, SceneError> {
        let Some(target) = ld.target else {
            return Err(self.field_error(
                span,
                "type",
                "a `spot` light needs a `target` to aim at",
            ));
        };
        let axis = self.finite3(span, "target", target)? - position;
        if axis.length_squared() == 0.0 || !axis.length_squared().is_finite() {
            return Err(self.field_error(span, "target", "must differ from `position`"));
        }
        let cutoff = ld.cutoff_angle.unwrap_or(20.0);
        if !(cutoff > 0.0 && cutoff <= 180.0) {
            return Err(self.field_error(
                span,
                "cutoff_angle",
                format!("must be in (0, 180] degrees, got {cutoff}"),
            ));
        }
        let beam = ld.beam_width.unwrap_or(0.75 * cutoff);
        if !(beam >= 0.0 && beam <= cutoff) {
            return Err(self.field_error(
                span,
                "beam_width",
                format!("must be in [0, cutoff_angle = {cutoff}] degrees, got {beam}"),
            ));
        }
        Ok(SpotCone::new(axis, cutoff.to_radians(), beam.to_radians()))
    }
}
