//! `<emitter>`: `area` (on a shape: its material's emission, sampled by
//! next-event estimation as Mitsuba samples it), `point`, `constant`, and
//! `envmap` (substituted by its mean radiance).

use super::props::{Props, Value};
use super::spectrum::Use;
use super::xml::Elem;
use super::Builder;
use crate::echo::echo;
use crate::geometry::within_bounds;
use crate::math::Rgb;
use crate::scene::{Material, PointLight, SceneError, Shape};
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
            "point" => {
                let m = props.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
                let at = props.point("position")?.unwrap_or(DVec3::ZERO);
                let position = m.transform_point3(at).as_vec3();
                if !within_bounds(position) {
                    return Err(e.loc.error("`position` lies beyond ±1e12"));
                }
                let intensity = self.radiance(&props, "intensity")?;
                self.point_lights.push(PointLight {
                    position,
                    intensity,
                });
            }
            "constant" => {
                let radiance = self.radiance(&props, "radiance")?;
                self.add_environment(e, radiance)?;
            }
            "envmap" => {
                let radiance = self.envmap_mean(&props)?;
                self.add_environment(e, radiance)?;
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

    fn add_environment(&mut self, e: &Elem, radiance: Rgb) -> Result<(), SceneError> {
        if let Some(before) = self.environment {
            self.problems.warn(
                &e.loc,
                "a second environment emitter; luz has one environment: substituted their sum",
            )?;
            self.environment = Some(before + radiance);
        } else {
            self.environment = Some(radiance);
        }
        Ok(())
    }

    /// The solid-angle mean of an equirectangular map times `scale`.
    fn envmap_mean(&mut self, props: &Props) -> Result<Rgb, SceneError> {
        let e = props.elem;
        props.accept("to_world");
        let scale = props.float("scale")?.unwrap_or(1.0) as f32;
        let name = props
            .string("filename")?
            .ok_or_else(|| e.loc.error("<emitter type=\"envmap\"> needs `filename`"))?;
        let path = self.file(e, name)?;
        let img = crate::image::io::read(&path)
            .map_err(|err| e.loc.error(format!("`filename` {}: {err}", echo(name))))?;
        let mut sum = glam::DVec3::ZERO;
        let mut weight = 0.0;
        for y in 0..img.height {
            let theta = std::f64::consts::PI * (y as f64 + 0.5) / img.height as f64;
            let w = theta.sin();
            for x in 0..img.width {
                sum += img.pixels[(y * img.width + x) as usize].as_dvec3() * w;
                weight += w;
            }
        }
        let mean = (sum / weight.max(f64::MIN_POSITIVE)).as_vec3() * scale;
        self.problems.warn(
            &e.loc,
            format!("<emitter type=\"envmap\">: luz's environment is constant; substituted the map's mean radiance {mean}"),
        )?;
        Ok(mean)
    }
}
