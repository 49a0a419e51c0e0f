//! `<texture>`: `bitmap` (PNG, JPEG, PPM) and `checkerboard`, with their
//! `to_uv` as luz's per-shape uv scale and offset.

use super::props::{Props, Value};
use super::spectrum::Use;
use super::xml::Elem;
use super::Builder;
use crate::echo::echo;
use crate::math::{Rgb, Vec2};
use crate::scene::{SceneError, Texture, UvTransform};
use glam::DMat4;

impl Builder<'_, '_> {
    /// The texture of element `t` (made once per element) and the uv
    /// transform it asks for.
    pub(super) fn texture(&mut self, t: &Elem) -> Result<(u32, Option<UvTransform>), SceneError> {
        let key = t as *const Elem;
        if let Some(done) = self.texture_ids.get(&key) {
            return Ok(*done);
        }
        let props = Props::new(t, self.ids);
        let texture = match t.kind() {
            "bitmap" => self.bitmap(&props)?,
            "checkerboard" => {
                let mut color = |name: &str, default: f32| -> Result<Rgb, SceneError> {
                    match props.color(name, Use::Reflectance, &mut self.problems)? {
                        Some(Value::Rgb(c)) => Ok(c.min(Rgb::ONE)),
                        Some(Value::Texture(_)) => Err(t.loc.error(format!(
                            "`{name}`: a checkerboard of textures is not supported"
                        ))),
                        None => Ok(Rgb::splat(default)),
                    }
                };
                // Mitsuba's squares: color0 where u and v fall in the same
                // half of the unit square.
                Texture::Checker {
                    a: color("color0", 0.4)?,
                    b: color("color1", 0.2)?,
                    squares: 2.0,
                }
            }
            other => {
                self.problems.warn(
                    &t.loc,
                    format!("<texture type=\"{other}\"> is not supported; substituted 0.5 grey"),
                )?;
                Texture::Checker {
                    a: Rgb::splat(0.5),
                    b: Rgb::splat(0.5),
                    squares: 1.0,
                }
            }
        };
        let uv = match props.transform("to_uv")? {
            Some(m) => Some(self.uv_transform(t, &m)?),
            None => None,
        };
        props.finish(&mut self.problems)?;
        self.textures.push(texture);
        let done = (self.textures.len() as u32 - 1, uv);
        self.texture_ids.insert(key, done);
        Ok(done)
    }

    fn bitmap(&mut self, props: &Props) -> Result<Texture, SceneError> {
        let t = props.elem;
        let name = props
            .string("filename")?
            .ok_or_else(|| t.loc.error("<texture type=\"bitmap\"> needs `filename`"))?;
        let path = self.file(t, name)?;
        // luz looks up the nearest texel and always repeats.
        for n in ["filter_type", "wrap_mode"] {
            props.accept(n);
        }
        if props.boolean("raw")? == Some(true) {
            self.problems.warn(
                &t.loc,
                "`raw`: luz decodes 8-bit textures as sRGB; the raw values are substituted",
            )?;
        }
        match crate::image::io::read_texture(&path) {
            // Mitsuba reads row 0 at v = 0, luz at v = 1: the rows are
            // stored upside down so that luz's lookup reads Mitsuba's.
            Ok(img) => Ok(Texture::Image {
                width: img.width,
                height: img.height,
                texels: img.pixels,
            }
            .upside_down()),
            Err(e) => {
                self.problems.warn(
                    &t.loc,
                    format!("texture {}: {e}; substituted 0.5 grey", echo(name)),
                )?;
                Ok(Texture::Checker {
                    a: Rgb::splat(0.5),
                    b: Rgb::splat(0.5),
                    squares: 1.0,
                })
            }
        }
    }

    /// luz's `uv * scale + offset` from a 2D affine `to_uv`; a rotation or
    /// shear is left out, with a warning.
    fn uv_transform(&mut self, t: &Elem, m: &DMat4) -> Result<UvTransform, SceneError> {
        if m.x_axis.y != 0.0 || m.y_axis.x != 0.0 {
            self.problems.warn(
                &t.loc,
                "`to_uv`: luz scales and offsets texture coordinates; the rotation or shear is left out",
            )?;
        }
        let scale = Vec2::new(m.x_axis.x as f32, m.y_axis.y as f32);
        let offset = Vec2::new(m.w_axis.x as f32, m.w_axis.y as f32);
        if !scale.is_finite() || !offset.is_finite() {
            return Err(t.loc.error("`to_uv`: must be finite"));
        }
        Ok(UvTransform { scale, offset })
    }
}
