//! The TOML scene format (documented key by key in docs/scene-format.md).
//!
//! Parsing is two-staged: serde reads the file into descriptions that keep
//! the byte span of every table, then `build` validates them and builds the
//! `Scene`. Every error names the file, the line and column, and the field.

use super::{Camera, Material, PointLight, RenderSettings, Scene, Shape, Texture, UvTransform};
use crate::echo::echo;
use crate::geometry::{within_bounds, Cuboid, Geometry, Mesh, Plane, Quad, Sphere, MAX_COORDINATE};
use crate::location::{line_column, read_regular_file};
use crate::math::{Mat4, Quat, Rgb, Vec2, Vec3};
use crate::render::film::check_resolution;
use crate::sampling::SamplerKind;
use serde::Deserialize;
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

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

/// A TOML table, read only as a table. serde's derived structs also accept
/// a sequence, their fields by position, and drop what is left over:
/// `environment = [0.25, 99, "junk"]` was read as `radiance = 0.25`. Every
/// table of the format is read through this wrapper, which asks the
/// deserializer for a map and refuses anything else.
struct Table<T>(T);

impl<T> std::ops::Deref for Table<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Table<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct MapOnly<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for MapOnly<T> {
            type Value = T;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table (`[name]` or `{ key = value, ... }`)")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<T, A::Error> {
                T::deserialize(serde::de::value::MapAccessDeserializer::new(map))
            }
        }
        d.deserialize_map(MapOnly(PhantomData)).map(Table)
    }
}

/// A table with the byte span it was written at.
type Sp<T> = Spanned<Table<T>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDesc {
    camera: Sp<CameraDesc>,
    render: Option<Sp<RenderDesc>>,
    #[serde(default)]
    materials: BTreeMap<String, Sp<MaterialDesc>>,
    #[serde(default)]
    textures: BTreeMap<String, Sp<TextureDesc>>,
    #[serde(default)]
    shapes: Vec<Sp<ShapeDesc>>,
    #[serde(default)]
    lights: Vec<Sp<LightDesc>>,
    environment: Option<Sp<EnvironmentDesc>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    eye: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    resolution: Option<[u32; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderDesc {
    spp: Option<u32>,
    max_depth: Option<u32>,
    seed: Option<u64>,
    russian_roulette: Option<bool>,
    sampler: Option<String>,
}

/// A colour: `[r, g, b]`, or one number for grey.
#[derive(Deserialize, Clone, Copy)]
#[serde(untagged)]
enum Color {
    Grey(f32),
    Rgb([f32; 3]),
}

impl Color {
    fn rgb(self) -> Rgb {
        match self {
            Color::Grey(g) => Rgb::splat(g),
            Color::Rgb(c) => Rgb::from(c),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDesc {
    #[serde(rename = "type")]
    kind: Option<String>,
    kd: Option<Color>,
    ks: Option<Color>,
    kt: Option<Color>,
    ior: Option<f32>,
    emission: Option<Color>,
    texture: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TextureDesc {
    file: Option<String>,
    checker: Option<[Color; 2]>,
    squares: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeDesc {
    #[serde(rename = "type")]
    kind: String,
    material: Option<String>,
    nee: Option<bool>,
    // sphere
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    // plane
    point: Option<[f32; 3]>,
    normal: Option<[f32; 3]>,
    // quad
    corners: Option<Vec<[f32; 3]>>,
    // cuboid
    min: Option<[f32; 3]>,
    max: Option<[f32; 3]>,
    // triangle
    vertices: Option<Vec<[f32; 3]>>,
    uvs: Option<Vec<[f32; 2]>>,
    // mesh
    file: Option<String>,
    scale: Option<Scale>,
    rotate: Option<[f32; 3]>,
    translate: Option<[f32; 3]>,
    // texture mapping
    texture_scale: Option<[f32; 2]>,
    texture_offset: Option<[f32; 2]>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(untagged)]
enum Scale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDesc {
    #[serde(rename = "type")]
    kind: String,
    position: [f32; 3],
    intensity: Color,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EnvironmentDesc {
    radiance: Color,
}

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
        let mut default_material = None;

        let mut shapes = Vec::new();
        let mut warnings = Vec::new();
        for s in &desc.shapes {
            let span = s.span();
            let sd = s.get_ref();
            let geometry = self.geometry(&span, sd, &mut warnings)?;
            let material = match &sd.material {
                Some(name) => *material_ids.get(name).ok_or_else(|| {
                    let known: Vec<&str> = material_ids.keys().map(|k| k.as_str()).collect();
                    self.field_error(
                        &span,
                        "material",
                        format!(
                            "no material named {} (defined: {})",
                            echo(name),
                            known.join(", ")
                        ),
                    )
                })?,
                None => *default_material.get_or_insert_with(|| {
                    materials.push(Material {
                        name: "(default)".into(),
                        ..Material::default()
                    });
                    materials.len() as u32 - 1
                }),
            };
            let mut shape = Shape::new(geometry, material);
            shape.nee = sd.nee.unwrap_or(false);
            if shape.nee && !materials[material as usize].is_emissive() {
                return Err(self.field_error(
                    &span,
                    "nee",
                    "only emissive shapes can be sampled as lights",
                ));
            }
            if shape.nee && matches!(shape.geometry, Geometry::Plane(_)) {
                return Err(self.field_error(
                    &span,
                    "nee",
                    "an infinite plane has no area to sample",
                ));
            }
            if shape.nee {
                let power = materials[material as usize].emission.max_element()
                    * shape.geometry.area().unwrap_or(0.0);
                if !power.is_finite() {
                    return Err(self.field_error(
                        &span,
                        "nee",
                        format!(
                            "the emitted power (`emission` {} of material {} times the area) overflows f32",
                            vec3(materials[material as usize].emission),
                            echo(&materials[material as usize].name)
                        ),
                    ));
                }
            }
            for (field, v) in [
                ("texture_scale", sd.texture_scale),
                ("texture_offset", sd.texture_offset),
            ] {
                if let Some(v) = v {
                    if !Vec2::from(v).is_finite() {
                        return Err(self.field_error(&span, field, "must be finite"));
                    }
                }
            }
            shape.uv_transform = UvTransform {
                scale: sd.texture_scale.map_or(Vec2::ONE, Vec2::from),
                offset: sd.texture_offset.map_or(Vec2::ZERO, Vec2::from),
            };
            // The texture coordinates the transform makes of the shape's
            // own (at most `uv_extent` in magnitude) must stay finite.
            let extent = uv_extent(&shape.geometry);
            let t = shape.uv_transform;
            if !(t.scale.abs() * extent).is_finite() {
                return Err(self.field_error(
                    &span,
                    "texture_scale",
                    format!("scales this shape's texture coordinates (up to {extent:e}) past f32's range"),
                ));
            }
            if !(t.scale.abs() * extent + t.offset.abs()).is_finite() {
                let field = if sd.texture_offset.is_some() {
                    "texture_offset"
                } else {
                    "texture_scale"
                };
                return Err(self.field_error(
                    &span,
                    field,
                    "moves this shape's texture coordinates past f32's range",
                ));
            }
            shapes.push(shape);
        }

        let mut point_lights = Vec::new();
        for l in &desc.lights {
            let span = l.span();
            let ld = l.get_ref();
            if ld.kind != "point" {
                return Err(self.field_error(
                    &span,
                    "type",
                    format!(
                        "unknown light type {}: `point` is the only light of [[lights]]; area lights are shapes whose material has `emission`",
                        echo(&ld.kind)
                    ),
                ));
            }
            point_lights.push(PointLight {
                position: self.point3(&span, "position", ld.position)?,
                intensity: self.color(
                    &span,
                    "intensity",
                    Some(ld.intensity),
                    Rgb::ZERO,
                    f32::INFINITY,
                )?,
            });
        }

        let environment = match &desc.environment {
            Some(e) => Some(self.color(
                &e.span(),
                "radiance",
                Some(e.get_ref().radiance),
                Rgb::ZERO,
                f32::INFINITY,
            )?),
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
        Ok(scene)
    }

    fn camera(&self, c: &Sp<CameraDesc>) -> Result<Camera, SceneError> {
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
            u.normalize().as_vec3()
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

    fn render(&self, r: &Sp<RenderDesc>) -> Result<RenderSettings, SceneError> {
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

    fn texture(&self, name: &str, t: &Sp<TextureDesc>) -> Result<Texture, SceneError> {
        let span = t.span();
        let td = t.get_ref();
        match (&td.file, &td.checker) {
            (Some(file), None) => {
                if td.squares.is_some() {
                    return Err(self.field_error(
                        &span,
                        "squares",
                        "only a checker texture has squares",
                    ));
                }
                let path = self.resolve_file(&span, file)?;
                let img = crate::image::io::read_texture(&path).map_err(|e| {
                    self.field_error(&span, "file", format!("texture {}: {e}", echo(name)))
                })?;
                Ok(Texture::Image {
                    width: img.width,
                    height: img.height,
                    texels: img.pixels,
                })
            }
            (None, Some([a, b])) => {
                let squares = td.squares.unwrap_or(8.0);
                if !(squares > 0.0 && squares.is_finite()) {
                    return Err(self.field_error(&span, "squares", "must be positive and finite"));
                }
                Ok(Texture::Checker {
                    a: self.color(&span, "checker", Some(*a), Rgb::ZERO, 1.0)?,
                    b: self.color(&span, "checker", Some(*b), Rgb::ZERO, 1.0)?,
                    squares,
                })
            }
            _ => Err(self.error_at(
                span.start,
                format!(
                    "texture {} needs exactly one of `file` or `checker`",
                    echo(name)
                ),
            )),
        }
    }

    fn material(
        &self,
        name: &str,
        m: &Sp<MaterialDesc>,
        textures: &BTreeMap<String, u32>,
    ) -> Result<Material, SceneError> {
        let span = m.span();
        let md = m.get_ref();
        let dielectric = match md.kind.as_deref() {
            None | Some("diffuse") | Some("standard") => false,
            Some("dielectric") | Some("glass") => true,
            Some(other) => {
                return Err(self.field_error(
                    &span,
                    "type",
                    format!(
                        "unknown material type {} (known: standard, dielectric)",
                        echo(other)
                    ),
                ))
            }
        };
        let (kd_default, kt_default) = if dielectric {
            (Rgb::ZERO, Rgb::ONE)
        } else if md.ks.is_some() || md.kt.is_some() || md.emission.is_some() {
            (Rgb::ZERO, Rgb::ZERO)
        } else {
            (Rgb::splat(0.5), Rgb::ZERO)
        };
        let kd = self.color(&span, "kd", md.kd, kd_default, 1.0)?;
        let ks = self.color(&span, "ks", md.ks, Rgb::ZERO, 1.0)?;
        let kt = self.color(&span, "kt", md.kt, kt_default, 1.0)?;
        if dielectric && (md.kd.is_some() || md.ks.is_some()) {
            let field = if md.kd.is_some() { "kd" } else { "ks" };
            return Err(self.field_error(
                &span,
                field,
                "a dielectric reflects and refracts by the Fresnel term; only `kt` (a tint) and `ior` apply",
            ));
        }
        let total = kd + ks + kt;
        if total.max_element() > 1.0 + 1e-6 {
            let field = ["kd", "ks", "kt"]
                .into_iter()
                .zip([md.kd, md.ks, md.kt])
                .rfind(|(_, v)| v.is_some())
                .map_or("kd", |(f, _)| f);
            return Err(self.field_error(
                &span,
                field,
                format!("material {}: kd + ks + kt = {total} exceeds 1 in some channel (the surface would create energy)", echo(name)),
            ));
        }
        let ior = md.ior.unwrap_or(1.5);
        if !(ior > 0.0 && ior.is_finite()) {
            return Err(self.field_error(
                &span,
                "ior",
                format!("must be positive and finite, got {ior}"),
            ));
        }
        let emission = self.color(&span, "emission", md.emission, Rgb::ZERO, f32::INFINITY)?;
        let texture = match &md.texture {
            Some(t) => Some(*textures.get(t).ok_or_else(|| {
                self.field_error(&span, "texture", format!("no texture named {}", echo(t)))
            })?),
            None => None,
        };
        Ok(Material {
            name: name.to_string(),
            kd,
            ks,
            kt,
            ior,
            dielectric,
            emission,
            texture,
        })
    }

    fn geometry(
        &self,
        span: &Range<usize>,
        sd: &ShapeDesc,
        warnings: &mut Vec<String>,
    ) -> Result<Geometry, SceneError> {
        let used: &[&str] = match sd.kind.as_str() {
            "sphere" => &["center", "radius"],
            "plane" => &["point", "normal"],
            "quad" => &["corners"],
            "cuboid" => &["min", "max"],
            "triangle" => &["vertices", "uvs"],
            "mesh" => &["file", "scale", "rotate", "translate"],
            other => {
                return Err(self.field_error(
                    span,
                    "type",
                    format!(
                    "unknown shape type {} (known: sphere, plane, quad, cuboid, triangle, mesh)",
                    echo(other)
                ),
                ))
            }
        };
        let present = [
            ("center", sd.center.is_some()),
            ("radius", sd.radius.is_some()),
            ("point", sd.point.is_some()),
            ("normal", sd.normal.is_some()),
            ("corners", sd.corners.is_some()),
            ("min", sd.min.is_some()),
            ("max", sd.max.is_some()),
            ("vertices", sd.vertices.is_some()),
            ("uvs", sd.uvs.is_some()),
            ("file", sd.file.is_some()),
            ("scale", sd.scale.is_some()),
            ("rotate", sd.rotate.is_some()),
            ("translate", sd.translate.is_some()),
        ];
        for (field, is_set) in present {
            if is_set && !used.contains(&field) {
                return Err(self.field_error(
                    span,
                    field,
                    format!(
                        "a {} has no `{field}` (it takes: {})",
                        sd.kind,
                        used.join(", ")
                    ),
                ));
            }
        }
        let need =
            |field: &str| self.error_at(span.start, format!("a {} needs `{field}`", sd.kind));
        Ok(match sd.kind.as_str() {
            "sphere" => {
                let center =
                    self.point3(span, "center", sd.center.ok_or_else(|| need("center"))?)?;
                let radius = sd.radius.ok_or_else(|| need("radius"))?;
                if !(radius > 0.0 && radius.is_finite()) {
                    return Err(self.field_error(
                        span,
                        "radius",
                        format!("must be positive and finite, got {radius}"),
                    ));
                }
                let sphere = Sphere { center, radius };
                let b = sphere.bounds();
                for corner in [b.min, b.max] {
                    if !within_bounds(corner) {
                        return Err(self.field_error(
                            span,
                            "radius",
                            format!(
                                "the sphere's bounds reach past the coordinates luz can use: {}",
                                outside(corner)
                            ),
                        ));
                    }
                }
                Geometry::Sphere(sphere)
            }
            "plane" => {
                let point = self.point3(span, "point", sd.point.ok_or_else(|| need("point"))?)?;
                let normal =
                    self.finite3(span, "normal", sd.normal.ok_or_else(|| need("normal"))?)?;
                // Compared, not squared: a normal of 1e-40 is a direction.
                if normal == Vec3::ZERO {
                    return Err(self.field_error(span, "normal", "must not be zero"));
                }
                Geometry::Plane(Plane::new(point, normal))
            }
            "quad" => {
                let corners = sd.corners.as_ref().ok_or_else(|| need("corners"))?;
                if corners.len() != 4 {
                    return Err(self.field_error(
                        span,
                        "corners",
                        format!("needs 4 points, got {}", corners.len()),
                    ));
                }
                let mut p = [Vec3::ZERO; 4];
                for (i, c) in corners.iter().enumerate() {
                    p[i] = self.point3(span, "corners", *c)?;
                }
                let (e1, e2) = (p[1] - p[0], p[3] - p[0]);
                let off = (p[2] - (p[0] + e1 + e2)).length();
                let size = e1.length().max(e2.length());
                if off > 1e-4 * size.max(f32::MIN_POSITIVE) {
                    return Err(self.field_error(
                        span,
                        "corners",
                        format!("not a parallelogram: p2 is {off} away from p1 + p3 - p0"),
                    ));
                }
                Geometry::Quad(
                    Quad::new(p[0], e1, e2)
                        .ok_or_else(|| self.field_error(span, "corners", "the quad has no area"))?,
                )
            }
            "cuboid" => {
                let min = self.point3(span, "min", sd.min.ok_or_else(|| need("min"))?)?;
                let max = self.point3(span, "max", sd.max.ok_or_else(|| need("max"))?)?;
                if !min.cmplt(max).all() {
                    return Err(self.field_error(span, "max", "must exceed `min` on every axis"));
                }
                Geometry::Cuboid(Cuboid { min, max })
            }
            "triangle" => {
                let vertices = sd.vertices.as_ref().ok_or_else(|| need("vertices"))?;
                if vertices.len() != 3 {
                    return Err(self.field_error(
                        span,
                        "vertices",
                        format!("needs 3 points, got {}", vertices.len()),
                    ));
                }
                let mut positions = Vec::with_capacity(3);
                for v in vertices {
                    positions.push(self.point3(span, "vertices", *v)?);
                }
                if super::mesh_io::is_degenerate([positions[0], positions[1], positions[2]]) {
                    return Err(self.field_error(
                        span,
                        "vertices",
                        "the triangle has no area (collinear vertices)",
                    ));
                }
                let uvs = match &sd.uvs {
                    Some(uvs) if uvs.len() == 3 => {
                        let uvs: Vec<Vec2> = uvs.iter().map(|&u| Vec2::from(u)).collect();
                        if let Some(uv) = uvs.iter().find(|uv| !uv.is_finite()) {
                            return Err(self.field_error(
                                span,
                                "uvs",
                                format!("must be finite, got {uv}"),
                            ));
                        }
                        Some(uvs)
                    }
                    Some(uvs) => {
                        return Err(self.field_error(
                            span,
                            "uvs",
                            format!("needs 3 pairs, got {}", uvs.len()),
                        ))
                    }
                    None => None,
                };
                Geometry::Mesh(Mesh {
                    positions,
                    indices: vec![[0, 1, 2]],
                    uvs,
                })
            }
            "mesh" => {
                let file = sd.file.as_ref().ok_or_else(|| need("file"))?;
                let path = self.resolve_file(span, file)?;
                let (mut mesh, mut notes) = super::mesh_io::read_mesh(&path)
                    .map_err(|e| self.field_error(span, "file", e.to_string()))?;
                let scale = match sd.scale {
                    None => Vec3::ONE,
                    Some(Scale::Uniform(s)) => Vec3::splat(s),
                    Some(Scale::PerAxis(s)) => Vec3::from(s),
                };
                if !scale.is_finite() || scale.cmpeq(Vec3::ZERO).any() {
                    return Err(self.field_error(span, "scale", "must be finite and non-zero"));
                }
                let r = self.finite3(span, "rotate", sd.rotate.unwrap_or([0.0; 3]))?;
                let t = self.point3(span, "translate", sd.translate.unwrap_or([0.0; 3]))?;
                let rotation = Quat::from_rotation_z(r.z.to_radians())
                    * Quat::from_rotation_y(r.y.to_radians())
                    * Quat::from_rotation_x(r.x.to_radians());
                let transformed =
                    sd.scale.is_some() || sd.rotate.is_some() || sd.translate.is_some();
                if transformed {
                    mesh.transform(&Mat4::from_scale_rotation_translation(scale, rotation, t));
                }
                // Every vertex where it lands in the world, the file's own
                // or transformed, within the coordinates luz can intersect.
                {
                    use rayon::prelude::*;
                    if let Some((i, p)) = mesh
                        .positions
                        .par_iter()
                        .enumerate()
                        .find_first(|(_, p)| !within_bounds(**p))
                    {
                        let field = ["scale", "translate", "rotate"]
                            .into_iter()
                            .zip([
                                sd.scale.is_some(),
                                sd.translate.is_some(),
                                sd.rotate.is_some(),
                            ])
                            .find_map(|(f, given)| given.then_some(f))
                            .unwrap_or("file");
                        let how = if transformed { " once transformed" } else { "" };
                        return Err(self.field_error(
                            span,
                            field,
                            format!("vertex {i} of the mesh{how}: {}", outside(*p)),
                        ));
                    }
                }
                if transformed {
                    // A very uneven scale can flatten triangles to lines.
                    let before = mesh.indices.len();
                    let dropped =
                        super::mesh_io::drop_degenerate(&mesh.positions, &mut mesh.indices);
                    if mesh.indices.is_empty() {
                        return Err(self.field_error(
                            span,
                            "scale",
                            "every triangle of the mesh is degenerate once transformed",
                        ));
                    }
                    if dropped > 0 {
                        notes.push(format!(
                            "dropped {dropped} of {before} triangles, degenerate once transformed"
                        ));
                    }
                }
                if !notes.is_empty() {
                    warnings.push(format!("{}: {}", path.display(), notes.join("; ")));
                }
                // Spare room after the last vertex lets Embree read luz's
                // own array instead of copying it (its loads are 16 bytes).
                mesh.positions.reserve_exact(1);
                Geometry::Mesh(mesh)
            }
            _ => unreachable!("shape kinds are checked above"),
        })
    }
}

/// Why a position is refused: where it lies and the bound.
fn outside(p: Vec3) -> String {
    format!(
        "{} lies beyond ±{MAX_COORDINATE:e}, the most luz places anything at on an axis (its f32 intersection tests cube coordinate differences)",
        vec3(p)
    )
}

/// A vector for a message, each component in the shorter of plain and
/// exponent notation: `(3e38, 0, 0)`.
fn vec3(v: Vec3) -> String {
    let c = |x: f32| {
        let (plain, exp) = (format!("{x}"), format!("{x:e}"));
        if plain.len() <= exp.len() {
            plain
        } else {
            exp
        }
    };
    format!("({}, {}, {})", c(v.x), c(v.y), c(v.z))
}

/// The largest magnitude of a shape's own texture coordinates: 1 for the
/// bounded shapes and for meshes without uvs (barycentrics), the largest uv
/// of a mesh that has them, and for a plane, whose coordinates are positions
/// on it, the farthest a point can lie.
fn uv_extent(g: &Geometry) -> f32 {
    match g {
        Geometry::Plane(_) => 2.0 * MAX_COORDINATE,
        Geometry::Mesh(Mesh { uvs: Some(uvs), .. }) => uvs
            .iter()
            .fold(1.0f32, |m, uv| m.max(uv.abs().max_element())),
        _ => 1.0,
    }
}

/// `message` with every backquoted or double-quoted value longer than
/// [`echo`] repeats cut short: serde's messages quote the offending key or
/// string whole, which may be megabytes.
fn shorten_quoted(message: &str) -> String {
    let mut out = String::new();
    let mut rest = message;
    while let Some(open) = rest.find(['`', '"']) {
        let quote = rest[open..].chars().next().unwrap_or('`');
        out.push_str(&rest[..open]);
        let inner = &rest[open + 1..];
        match inner.find(quote) {
            Some(close) => {
                let value = &inner[..close];
                if value.len() > 60 {
                    out.push_str(&echo(value));
                } else {
                    out.push(quote);
                    out.push_str(value);
                    out.push(quote);
                }
                rest = &inner[close + 1..];
            }
            None => {
                out.push(quote);
                rest = inner;
                break;
            }
        }
    }
    out.push_str(rest);
    // Whatever else it holds, one line of a bounded length.
    match out.char_indices().nth(400) {
        Some((cut, _)) => format!("{}…", &out[..cut]),
        None => out,
    }
}

/// The key of a `key = value` line whose value starts at `offset`: serde's
/// type errors point at the value and do not name the field.
fn key_before(text: &str, offset: usize) -> Option<&str> {
    let line_start = text.get(..offset)?.rfind('\n').map_or(0, |i| i + 1);
    let (key, rest) = text[line_start..offset].split_once('=')?;
    let key = key.trim().trim_matches('"');
    let is_key = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
    (is_key && rest.trim().is_empty()).then_some(key)
}

/// The unknown key named by a serde "unknown field" message.
fn unknown_field(message: &str) -> Option<&str> {
    let rest = message.strip_prefix("unknown field `")?;
    rest.split('`').next()
}

/// The closest expected key to an unknown one, if it is a likely typo.
fn did_you_mean(message: &str) -> Option<String> {
    let unknown = unknown_field(message)?;
    if unknown.len() > 64 {
        return None;
    }
    let expected = message.split("expected").nth(1)?;
    expected
        .split('`')
        .skip(1)
        .step_by(2)
        .map(|cand| (edit_distance(unknown, cand), cand))
        .filter(|&(d, cand)| d <= 2.max(cand.len() / 3))
        .min()
        .map(|(_, c)| c.to_string())
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\n";

    fn err(text: &str) -> SceneError {
        load_str(text, Path::new("test.toml")).expect_err("must fail")
    }

    #[test]
    fn minimal_scene_gets_defaults() {
        let s = load_str(MINIMAL, Path::new("m.toml")).unwrap();
        assert_eq!((s.camera.width, s.camera.height), (512, 512));
        assert_eq!(s.camera.fov_y, 40.0);
        assert_eq!(s.render, RenderSettings::default());
        assert!(s.shapes.is_empty() && s.lights.is_empty());
    }

    #[test]
    fn unknown_key_names_line_column_and_suggests() {
        let e = err(&format!(
            "{MINIMAL}[[shapes]]\ntype = \"sphere\"\ncenter = [0,0,0]\nradus = 1\n"
        ));
        assert_eq!(e.location.map(|l| l.0), Some(7), "{e}");
        assert!(
            e.message.contains("radus") && e.message.contains("did you mean `radius`"),
            "{e}"
        );
    }

    #[test]
    fn empty_keys_are_unknown_fields() {
        for text in ["\"\" = 1\n", "[camera]\n\"\" = \"\"\n"] {
            let e = err(text);
            assert!(e.message.contains("unknown field ``"), "{e}");
        }
    }

    #[test]
    fn wrong_type_is_located() {
        let e = err("[camera]\neye = [0, 1, 3]\ntarget = \"up\"\n");
        assert_eq!(e.location.map(|l| l.0), Some(3), "{e}");
    }

    #[test]
    fn semantic_errors_name_the_field_line() {
        let cases = [
            ("[[shapes]]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = -1\n", 7, "radius"),
            ("[[shapes]]\ntype = \"sphere\"\ncenter = [0,nan,0]\nradius = 1\n", 6, "center"),
            ("[materials.m]\nkd = 0.6\nks = 0.5\n", 6, "ks"),
            ("[[shapes]]\ntype = \"cuboid\"\nmin = [0,0,0]\nmax = [1,1,1]\nmaterial = \"nope\"\n", 8, "material"),
            ("[[lights]]\ntype = \"point\"\nposition = [0,0,0]\nintensity = inf\n", 7, "intensity"),
        ];
        for (body, line, field) in cases {
            let e = err(&format!("{MINIMAL}{body}"));
            assert_eq!(e.location.map(|l| l.0), Some(line), "{e}");
            assert!(e.message.contains(field), "{e}");
        }
    }

    #[test]
    fn the_render_table_names_the_sampler() {
        for kind in SamplerKind::ALL {
            let text = format!("{MINIMAL}[render]\nsampler = \"{}\"\n", kind.name());
            let s = load_str(&text, Path::new("s.toml")).unwrap();
            assert_eq!(s.render.sampler, kind);
        }
        let e = err(&format!(
            "{MINIMAL}[render]\nspp = 4\nsampler = \"halton\"\n"
        ));
        assert_eq!(e.location.map(|l| l.0), Some(6), "{e}");
        assert!(
            e.message
                .contains("unknown sampler `halton` (known: independent, sobol)"),
            "{e}"
        );
    }

    #[test]
    fn missing_mesh_file_says_where_it_looked() {
        let e = err(&format!(
            "{MINIMAL}[[shapes]]\ntype = \"mesh\"\nfile = \"nothing-here.ply\"\n"
        ));
        assert!(
            e.message.contains("nothing-here.ply") && e.message.contains("looked for"),
            "{e}"
        );
        assert_eq!(e.location.map(|l| l.0), Some(6));
    }

    #[test]
    fn collinear_triangle_is_rejected() {
        let e = err(&format!(
            "{MINIMAL}[[shapes]]\ntype = \"triangle\"\nvertices = [[0,0,0],[1,1,1],[2,2,2]]\n"
        ));
        assert_eq!(e.location.map(|l| l.0), Some(6), "{e}");
        assert!(
            e.message.contains("`vertices`: the triangle has no area"),
            "{e}"
        );
    }

    #[test]
    fn quad_must_be_a_parallelogram() {
        let e = err(&format!(
            "{MINIMAL}[[shapes]]\ntype = \"quad\"\ncorners = [[0,0,0],[1,0,0],[1,1,0.5],[0,1,0]]\n"
        ));
        assert!(e.message.contains("parallelogram"), "{e}");
    }

    #[test]
    fn huge_and_tiny_directions_are_directions() {
        let s = load_str(
            "[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\nup = [0, 1e-30, 0]\n\
             [[shapes]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 3e38, 3e38]\n\
             [[shapes]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [1e-40, 0, 0]\n",
            Path::new("d.toml"),
        )
        .unwrap();
        let b = s.camera.basis();
        assert!(b.up.is_finite() && b.right.is_finite() && b.up.y > 0.0);
        for (shape, n) in s
            .shapes
            .iter()
            .zip([Vec3::new(0.0, 1.0, 1.0).normalize(), Vec3::X])
        {
            let Geometry::Plane(p) = &shape.geometry else {
                panic!("a plane")
            };
            assert!((p.normal - n).length() < 1e-6, "{}", p.normal);
        }
    }

    #[test]
    fn tables_are_never_read_by_position() {
        let e = err(
            "environment = [0.25, 99, \"junk\"]\n[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\n",
        );
        assert!(
            e.message.contains("`environment`") && e.message.contains("a table"),
            "{e}"
        );
        assert_eq!(e.location.map(|l| l.0), Some(1), "{e}");
        let e = err("camera = [[0, 1, 3], [0, 1, 0]]\n");
        assert!(
            e.message.contains("`camera`") && e.message.contains("a table"),
            "{e}"
        );
        // Inline tables are tables.
        load_str(
            "camera = { eye = [0, 1, 3], target = [0, 1, 0] }\nenvironment = { radiance = 0.5 }\n",
            Path::new("t.toml"),
        )
        .unwrap();
    }

    #[test]
    fn long_values_are_echoed_short() {
        let long = "y".repeat(1 << 20);
        for text in [
            format!("{MINIMAL}{long} = 1\n"),
            format!("{MINIMAL}fov = \"{long}\"\n"),
            format!("{MINIMAL}[[shapes]]\ntype = \"{long}\"\n"),
        ] {
            let e = err(&text).to_string();
            assert!(e.len() < 1024, "{} bytes: {}", e.len(), &e[..1024]);
        }
    }

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("radus", "radius"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
