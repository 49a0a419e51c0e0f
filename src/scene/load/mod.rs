//! The TOML scene format (documented key by key in docs/scene-format.md).
//!
//! Parsing is two-staged: serde reads the file into descriptions that keep
//! the byte span of every table, then `build` validates them and builds the
//! `Scene`. Every error names the file, the line and column, and the field.

use super::{
    Camera, FovAxis, Material, PointLight, RenderSettings, Scene, Shape, Texture, UvTransform,
};
use crate::echo::echo;
use crate::geometry::{within_bounds, Cuboid, Geometry, Mesh, Plane, Quad, Sphere, MAX_COORDINATE};
use crate::location::{line_column, read_regular_file};
use crate::math::{Mat3, Mat4, Quat, Rgb, Vec2, Vec3};
use crate::render::film::check_resolution;
use crate::sampling::SamplerKind;
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

mod assign;
mod camera;
mod desc;
mod environment;
mod lights;
mod materials;
mod mesh;
mod messages;
mod models;
mod shapes;
#[cfg(test)]
mod tests;

use assign::Palette;
use desc::*;
use mesh::Built;
use messages::*;
use shapes::uv_extent;

/// A scene error: where it is and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {message}", file.display(), location.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
pub struct SceneError {
    pub file: PathBuf,
    /// 1-based line and column, when the error has a place in the file.
    pub location: Option<(usize, usize)>,
    pub message: String,
}

/// How a scene file is read: the parameters `-D KEY=VALUE` gives Mitsuba
/// XML's `$KEY`, and whether warnings are errors (`--strict`).
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    pub defines: Vec<(String, String)>,
    pub strict: bool,
}

/// Loads and validates the scene file at `path`, which must be a regular
/// file (a FIFO would block the read for ever); the scene's warnings
/// ([`Scene::warnings`]) go to stderr, one line each.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    load_with(path, &LoadOptions::default())
}

/// [`load`] with options.
pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let data = read_regular_file(path).map_err(|e| SceneError {
        file: path.to_path_buf(),
        location: None,
        message: format!("cannot read the scene file: {e}"),
    })?;
    let scene = load_bytes_with(&data, path, options)?;
    for w in &scene.warnings {
        eprintln!("luz: warning: {w}");
    }
    Ok(scene)
}

/// Loads a scene from the bytes of a scene file, which must be UTF-8;
/// `path` names it in errors and anchors relative file names.
pub fn load_bytes(data: &[u8], path: &Path) -> Result<Scene, SceneError> {
    load_bytes_with(data, path, &LoadOptions::default())
}

/// [`load_bytes`] with options; a `.xml` file is read as Mitsuba XML.
pub fn load_bytes_with(
    data: &[u8],
    path: &Path,
    options: &LoadOptions,
) -> Result<Scene, SceneError> {
    let text = std::str::from_utf8(data).map_err(|e| SceneError {
        file: path.to_path_buf(),
        location: Some(line_column(data, e.valid_up_to())),
        message: format!(
            "the file is not UTF-8 text (invalid byte at offset {})",
            e.valid_up_to()
        ),
    })?;
    let error = |message: String| SceneError {
        file: path.to_path_buf(),
        location: None,
        message,
    };
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
    {
        return super::mitsuba::load_str(text, path, options);
    }
    if let Some((key, _)) = options.defines.first() {
        return Err(error(format!(
            "-D {}: parameters are for Mitsuba XML scenes (.xml); this is a TOML scene",
            echo(key)
        )));
    }
    let scene = load_str(text, path)?;
    match scene.warnings.first() {
        Some(w) if options.strict => Err(error(format!("{w} (an error with --strict)"))),
        _ => Ok(scene),
    }
}

/// Loads a scene from `text`; `path` names it in errors and anchors
/// relative file names.
pub fn load_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let ctx = Ctx {
        text,
        path,
        files: RefCell::new(vec![path.to_path_buf()]),
    };
    let desc: SceneDesc = toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        // One line per error: toml puts its expectations on further lines;
        // the values serde repeats (an unknown key, a string of the wrong
        // type) are shortened.
        let mut message =
            shorten_quoted(&e.message().trim().lines().collect::<Vec<_>>().join(": "));
        if let Some(key) = key_before(text, span.start) {
            message = format!("field {}: {message}", echo(key));
        }
        if let Some(hint) = did_you_mean(&message) {
            message.push_str(&format!(" (did you mean `{hint}`?)"));
        }
        // Point at the offending key itself when serde names it.
        let at = unknown_field(&message)
            .and_then(|key| ctx.find_key(&span, key))
            .unwrap_or(span.start);
        ctx.error_at(at, message)
    })?;
    let mut scene = ctx.build(desc)?;
    scene.files = ctx.files.into_inner();
    Ok(scene)
}

const DEFAULT_ASSETS: &str = "../shared/assets";

struct Ctx<'a> {
    text: &'a str,
    path: &'a Path,
    /// The files read so far, the scene file first.
    files: RefCell<Vec<PathBuf>>,
}

impl Ctx<'_> {
    fn error_at(&self, offset: usize, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.path.to_path_buf(),
            location: Some(line_column(self.text.as_bytes(), offset)),
            message: message.into(),
        }
    }

    /// Offset of `key =` inside `span`, if written there.
    fn find_key(&self, span: &Range<usize>, key: &str) -> Option<usize> {
        // An empty key (`"" = 1`, found by fuzzing) would match everywhere
        // without advancing.
        if key.is_empty() {
            return None;
        }
        let end = span.end.min(self.text.len());
        let start = span.start.min(end);
        let region = &self.text[start..end];
        let mut at = 0;
        while let Some(i) = region[at..].find(key) {
            let pos = at + i;
            let prev_ok = pos == 0
                || region[..pos]
                    .chars()
                    .next_back()
                    .is_some_and(|c| !(c.is_alphanumeric() || c == '_'));
            let rest = region[pos + key.len()..].trim_start_matches([' ', '\t']);
            if prev_ok && rest.starts_with('=') {
                return Some(start + pos);
            }
            at = pos + key.len();
        }
        None
    }

    /// Error about `field` of the table at `span`.
    fn field_error(
        &self,
        span: &Range<usize>,
        field: &str,
        message: impl AsRef<str>,
    ) -> SceneError {
        let at = self.find_key(span, field).unwrap_or(span.start);
        self.error_at(at, format!("`{field}`: {}", message.as_ref()))
    }

    fn finite3(&self, span: &Range<usize>, field: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let v = Vec3::from(v);
        if !v.is_finite() {
            return Err(self.field_error(span, field, format!("must be finite, got {v}")));
        }
        Ok(v)
    }

    /// A position in the world: finite and within [`MAX_COORDINATE`].
    fn point3(&self, span: &Range<usize>, field: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let v = self.finite3(span, field, v)?;
        if !within_bounds(v) {
            return Err(self.field_error(span, field, outside(v)));
        }
        Ok(v)
    }

    fn color(
        &self,
        span: &Range<usize>,
        field: &str,
        c: Option<Color>,
        default: Rgb,
        max: f32,
    ) -> Result<Rgb, SceneError> {
        let Some(c) = c else { return Ok(default) };
        let c = c.rgb();
        if !c.is_finite() || c.min_element() < 0.0 || c.max_element() > max {
            let range = if max.is_finite() {
                format!("in [0, {max}]")
            } else {
                "finite and non-negative".into()
            };
            return Err(self.field_error(
                span,
                field,
                format!("every channel must be {range}, got {c}"),
            ));
        }
        Ok(c)
    }

    fn resolve_file(&self, span: &Range<usize>, name: &str) -> Result<PathBuf, SceneError> {
        let base = self.path.parent().unwrap_or(Path::new("."));
        let mut tried = Vec::new();
        let candidates: Vec<PathBuf> = if let Some(rest) = name
            .strip_prefix("$LUZ_ASSETS/")
            .or_else(|| name.strip_prefix("${LUZ_ASSETS}/"))
        {
            match std::env::var_os("LUZ_ASSETS") {
                Some(dir) => vec![PathBuf::from(dir).join(rest)],
                None => vec![
                    Path::new(DEFAULT_ASSETS).join(rest),
                    base.join("..").join(DEFAULT_ASSETS).join(rest),
                ],
            }
        } else {
            vec![base.join(name)]
        };
        for c in candidates {
            match std::fs::metadata(&c) {
                Ok(m) if m.is_file() => {
                    self.files.borrow_mut().push(c.clone());
                    return Ok(c);
                }
                Ok(_) => {
                    return Err(self.field_error(
                        span,
                        "file",
                        format!("{} is not a regular file", echo(&c.display().to_string())),
                    ))
                }
                Err(_) => tried.push(echo(&c.display().to_string())),
            }
        }
        let hint = if name.contains("LUZ_ASSETS") {
            " (set LUZ_ASSETS to the folder holding the test assets; see the README)"
        } else {
            ""
        };
        Err(self.field_error(
            span,
            "file",
            format!(
                "{} not found; looked for {}{hint}",
                echo(name),
                tried.join(", ")
            ),
        ))
    }

    fn build(&self, desc: SceneDesc) -> Result<Scene, SceneError> {
        let camera = self.camera(&desc.camera)?;
        let render = match &desc.render {
            Some(r) => self.render(r)?,
            None => RenderSettings::default(),
        };

        let mut textures = Vec::new();
        let mut texture_ids = BTreeMap::new();
        for (name, t) in &desc.textures {
            texture_ids.insert(name.clone(), textures.len() as u32);
            textures.push(self.texture(name, t)?);
        }

        let mut materials = Vec::new();
        let mut material_ids = BTreeMap::new();
        for (name, m) in &desc.materials {
            material_ids.insert(name.clone(), materials.len() as u32);
            materials.push(self.material(name, m, &texture_ids)?);
        }
        let mut warnings = Vec::new();
        let shapes = self.shapes(
            &desc.shapes,
            Palette {
                materials: &mut materials,
                material_ids: &material_ids,
                textures: &mut textures,
            },
            &mut warnings,
        )?;

        let mut point_lights = Vec::new();
        for l in &desc.lights {
            point_lights.push(self.point_light(l)?);
        }

        let environment = match &desc.environment {
            Some(e) => Some(self.environment(e)?),
            None => None,
        };

        let mut scene = Scene::new(
            camera,
            materials,
            textures,
            shapes,
            point_lights,
            environment,
            render,
        );
        scene.warnings = warnings;
        if !scene.has_light() {
            scene.warnings.push(super::UNLIT_WARNING.into());
        }
        Ok(scene)
    }
}
