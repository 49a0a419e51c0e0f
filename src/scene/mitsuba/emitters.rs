//! `<emitter>`: `area` (on a shape: its material's emission, sampled by
//! next-event estimation as Mitsuba samples it), `point`, `spot`,
//! `constant`, and `envmap` (a latitude-longitude map, importance-sampled).

use super::props::{Props, Value};
use super::spectrum::Use;
use super::xml::Elem;
use super::Builder;
use crate::echo::echo;
use crate::geometry::within_bounds;
use crate::math::Rgb;
use crate::scene::{EnvMap, Environment, Material, PointLight, SceneError, Shape, SpotCone};
use glam::{DMat4, DVec3};

impl<'e> Builder<'e, '_> {
    /// A radiance-like property: a constant colour, 1 when absent.
    fn radiance(&mut self, props: &Props, name: &str) -> Result<Rgb, SceneError> {
        match props.color(name, Use::Emission, &mut self.problems)? {
            Some(Value::Rgb(c)) => Ok(c),
            Some(Value::Texture(t)) => {
                self.problems.warn(
                    &t.loc,
                    format!("`{name}`: a textured emitter is not supported; substituted 1"),
                )?;
                Ok(Rgb::ONE)
            }
            None => Ok(Rgb::ONE),
        }
    }

    /// An emitter nested in a shape.
    pub(super) fn area_emitter(
        &mut self,
        e: &'e Elem,
        shape: &mut Shape,
    ) -> Result<(), SceneError> {
        let props = Props::new(e, self.ids);
        if e.kind() != "area" {
            props.finish(&mut self.problems).ok();
            return self.problems.warn(
                &e.loc,
                format!(
                    "{} on a shape: only `area` emitters can sit on shapes in luz; left out",
                    e.describe()
                ),
            );
        }
        let radiance = self.radiance(&props, "radiance")?;
        props.finish(&mut self.problems)?;
        let power = radiance.max_element() * shape.geometry.area().unwrap_or(0.0);
        if !power.is_finite() {
            return Err(e.loc.error(format!(
                "`radiance` {radiance} times the shape's area overflows f32"
            )));
        }
        // Emission belongs to luz's material: each emitter gets its own
        // copy of the shape's.
        let mut material: Material = self.materials[shape.material as usize].clone();
        material.emission = radiance;
        self.materials.push(material);
        shape.material = self.materials.len() as u32 - 1;
        shape.nee = true;
        Ok(())
    }

    /// A top-level emitter.
    pub(super) fn emitter(&mut self, e: &'e Elem) -> Result<(), SceneError> {
        let props = Props::new(e, self.ids);
        match e.kind() {
            "point" | "spot" => {
                let light = self.point_light(e, &props)?;
                self.point_lights.push(light);
            }
            "constant" => {
                let radiance = self.radiance(&props, "radiance")?;
                self.add_environment(e, Environment::Constant(radiance))?;
            }
            "envmap" => {
                let map = self.envmap(&props)?;
                self.add_environment(e, Environment::Map(map))?;
            }
            "area" => {
                return Err(e.loc.error("an `area` emitter must be nested in a <shape>"));
            }
            other => {
                props.finish(&mut self.problems).ok();
                return self.problems.warn(
                    &e.loc,
                    format!("<emitter type=\"{other}\"> is not supported; left out of the scene"),
                );
            }
        }
        props.finish(&mut self.problems)
    }

    /// `point` (at `position` under `to_world`) and `spot` (at the origin
    /// of `to_world`, aimed along its +z, with Mitsuba's `cutoff_angle`,
    /// 20° by default, and `beam_width`, three quarters of it).
    fn point_light(&mut self, e: &Elem, props: &Props) -> Result<PointLight, SceneError> {
        let m = props.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let spot = e.kind() == "spot";
        let at = match spot {
            false => props.point("position")?.unwrap_or(DVec3::ZERO),
            true => DVec3::ZERO,
        };
        let position = m.transform_point3(at).as_vec3a();
        if !within_bounds(position) {
            return Err(e.loc.error("`position` lies beyond ±1e12"));
        }
        let intensity = self.radiance(props, "intensity")?;
        let spot = match spot {
            false => None,
            true => Some(spot_cone(e, props, m)?),
        };
        Ok(PointLight {
            position,
            intensity,
            spot,
        })
    }

    fn add_environment(&mut self, e: &Elem, env: Environment) -> Result<(), SceneError> {
        match (self.environment.take(), env) {
            (None, env) => self.environment = Some(env),
            (Some(Environment::Constant(a)), Environment::Constant(b)) => {
                self.environment = Some(Environment::Constant(a + b));
            }
            (Some(first), _) => {
                self.environment = Some(first);
                self.problems.warn(
                    &e.loc,
                    "a second environment emitter; luz has one environment (two constants add up): kept the first, left this one out",
                )?;
            }
        }
        Ok(())
    }

    /// `<emitter type="envmap">`: `filename`, `scale` and `to_world` (its
    /// rotation; a scale or shear would only distort directions).
    fn envmap(&mut self, props: &Props) -> Result<EnvMap, SceneError> {
        let e = props.elem;
        let scale = props.float("scale")?.unwrap_or(1.0) as f32;
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(e.loc.error(format!(
                "`scale` must be finite and not negative, got {scale}"
            )));
        }
        let m = props.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let linear = glam::DMat3::from_mat4(m);
        let rotation = glam::Mat3::from_cols(
            linear.x_axis.normalize().as_vec3(),
            linear.y_axis.normalize().as_vec3(),
            linear.z_axis.normalize().as_vec3(),
        );
        if !rotation.is_finite() || (rotation.determinant() - 1.0).abs() > 1e-3 {
            return Err(e.loc.error("`to_world` of an envmap must be a rotation"));
        }
        let name = props
            .string("filename")?
            .ok_or_else(|| e.loc.error("<emitter type=\"envmap\"> needs `filename`"))?;
        let path = self.file(e, name)?;
        let img = crate::image::io::read(&path)
            .map_err(|err| e.loc.error(format!("`filename` {}: {err}", echo(name))))?;
        if img.width < 2 || img.height < 2 || img.pixels.iter().any(|p| !p.is_finite()) {
            return Err(e.loc.error(format!(
                "`filename` {}: needs at least 2×2 finite texels",
                echo(name)
            )));
        }
        // Mitsuba clamps negative texels of an emitter to 0.
        let texels = img.pixels.iter().map(|p| p.max(Rgb::ZERO)).collect();
        Ok(EnvMap::new(img.width, img.height, texels, scale, rotation))
    }
}

/// A `spot` emitter's cone, its angles checked as Mitsuba asserts them.
fn spot_cone(e: &Elem, props: &Props, to_world: DMat4) -> Result<SpotCone, SceneError> {
    let axis = to_world.transform_vector3(DVec3::Z).as_vec3a();
    if !axis.is_finite() || axis.length_squared() == 0.0 {
        return Err(e.loc.error("`to_world` collapses the spot light's axis"));
    }
    let cutoff = props.float("cutoff_angle")?.unwrap_or(20.0);
    if !(cutoff > 0.0 && cutoff <= 180.0) {
        return Err(e.loc.error(format!(
            "`cutoff_angle` must be in (0, 180] degrees, got {cutoff}"
        )));
    }
    let beam = props.float("beam_width")?.unwrap_or(0.75 * cutoff);
    if !(0.0..=cutoff).contains(&beam) {
        return Err(e.loc.error(format!(
            "`beam_width` must be in [0, cutoff_angle = {cutoff}] degrees, got {beam}"
        )));
    }
    Ok(SpotCone::new(
        axis,
        cutoff.to_radians() as f32,
        beam.to_radians() as f32,
    ))
}
