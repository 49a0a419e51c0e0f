//! Mitsuba 3 XML scenes (and the 0.5/2.x files Mitsuba 3 upgrades), read
//! into the same `Scene` the TOML loader builds. What luz cannot do is
//! substituted and said, in a warning that names the file, line and column
//! (an error with `--strict`); nothing is dropped silently. The mapping is
//! documented in docs/scene-format.md.

mod bsdf;
mod cie;
mod conductors;
mod emitters;
mod props;
mod resolver;
mod sensor;
mod shapes;
mod spectrum;
mod textures;
mod transform;
mod upgrade;
mod xml;

use super::{LoadOptions, Material, PointLight, RenderSettings, Scene, SceneError, Shape};
use super::{Texture, UvTransform};
use crate::echo::echo;
use props::Ids;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use xml::{Elem, Loc};

/// Loads the Mitsuba scene `text` read from `path`.
pub fn load_str(text: &str, path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let mut reader = xml::Reader::new(&options.defines, path);
    let root = reader.scene(text, path)?;
    let mut ids = Ids::new();
    collect_ids(&root, &mut ids)?;
    let resolver = std::mem::take(&mut reader.resolver);
    let mut b = Builder::new(&ids, options.strict, resolver);
    let mut render = RenderSettings {
        max_depth: sensor::UNBOUNDED_DEPTH,
        ..RenderSettings::default()
    };
    let mut camera = None;
    for c in &root.children {
        match c.tag.as_str() {
            "integrator" => sensor::integrator(c, &ids, &mut b.problems, &mut render)?,
            "sensor" if camera.is_some() => b.problems.warn(
                &c.loc,
                "a second <sensor>: luz renders one camera, the first; left out",
            )?,
            "sensor" => {
                let s = sensor::sensor(c, &ids, &mut b.problems)?;
                // Mitsuba's default sampler takes 4 samples per pixel.
                render.spp = s.spp.unwrap_or(4);
                render.seed = s.seed.unwrap_or(render.seed);
                camera = Some(s.camera);
            }
            "shape" => b.shape(c)?,
            // Defined for `<ref>`s; read where they are referenced (an
            // area emitter by the shapes that refer to it).
            "bsdf" | "texture" | "medium" | "spectrum" if c.attr("id").is_some() => {}
            "emitter" if c.kind() == "area" && c.attr("id").is_some() => {}
            "emitter" => b.emitter(c)?,
            _ => b.problems.warn(
                &c.loc,
                format!("{} is not supported here; left out", c.describe()),
            )?,
        }
    }
    let camera = camera.ok_or_else(|| {
        root.loc
            .error("the scene has no <sensor>; luz needs a perspective camera")
    })?;
    if !b.no_area.is_empty() {
        b.problems
            .warn(&root.loc, super::no_area_warning(&b.no_area))?;
    }
    let mut scene = Scene::new(
        camera,
        b.materials,
        b.textures,
        b.shapes,
        b.point_lights,
        b.environment,
        render,
    );
    if !scene.has_light() {
        b.problems.warn(&root.loc, super::UNLIT_WARNING)?;
    }
    scene.files = reader.files;
    scene.files.extend(b.files);
    scene.warnings = b.problems.warnings;
    Ok(scene)
}

/// Every element with an `id`, by id; an id given twice is an error.
fn collect_ids<'e>(e: &'e Elem, ids: &mut Ids<'e>) -> Result<(), SceneError> {
    for c in &e.children {
        if let (Some(id), false) = (c.attr("id"), c.tag == "ref") {
            if let Some(before) = ids.insert(id.to_string(), c) {
                return Err(c.loc.error(format!(
                    "the id {} is given twice (first at {})",
                    echo(id),
                    before.loc
                )));
            }
        }
        collect_ids(c, ids)?;
    }
    Ok(())
}

/// The warnings so far, or with `strict` the first one as an error.
struct Problems {
    strict: bool,
    warnings: Vec<String>,
}

impl Problems {
    pub fn new(strict: bool) -> Self {
        Self {
            strict,
            warnings: Vec::new(),
        }
    }

    pub fn warn(&mut self, loc: &Loc, message: impl Into<String>) -> Result<(), SceneError> {
        let message = message.into();
        if self.strict {
            return Err(loc.error(format!("{message} (an error with --strict)")));
        }
        self.warnings.push(format!("{loc}: {message}"));
        Ok(())
    }
}

/// What the scene's elements have built so far.
struct Builder<'e, 'i> {
    ids: &'i Ids<'e>,
    problems: Problems,
    resolver: resolver::Resolver,
    files: Vec<PathBuf>,
    textures: Vec<Texture>,
    texture_ids: HashMap<*const Elem, (u32, Option<UvTransform>)>,
    materials: Vec<Material>,
    material_ids: HashMap<*const Elem, (u32, Option<UvTransform>)>,
    default_material: Option<u32>,
    /// How many BSDFs are being built inside one another: a `<ref>` cycle
    /// would otherwise recurse for ever.
    bsdf_depth: usize,
    shapes: Vec<Shape>,
    /// The mesh files left out, with no triangle of any area.
    no_area: Vec<String>,
    point_lights: Vec<PointLight>,
    environment: Option<crate::scene::Environment>,
}

impl<'e, 'i> Builder<'e, 'i> {
    fn new(ids: &'i Ids<'e>, strict: bool, resolver: resolver::Resolver) -> Self {
        Self {
            ids,
            problems: Problems::new(strict),
            resolver,
            files: Vec::new(),
            textures: Vec::new(),
            texture_ids: HashMap::new(),
            materials: Vec::new(),
            material_ids: HashMap::new(),
            default_material: None,
            bsdf_depth: 0,
            shapes: Vec::new(),
            no_area: Vec::new(),
            point_lights: Vec::new(),
            environment: None,
        }
    }

    /// The material of a `<bsdf>` element, made once however many shapes
    /// refer to it.
    fn material_of(&mut self, e: &'e Elem) -> Result<(u32, Option<UvTransform>), SceneError> {
        let key = e as *const Elem;
        if let Some(done) = self.material_ids.get(&key) {
            return Ok(*done);
        }
        let b = bsdf::bsdf(self, e)?;
        self.materials.push(b.material);
        let done = (self.materials.len() as u32 - 1, b.uv);
        self.material_ids.insert(key, done);
        Ok(done)
    }

    /// Mitsuba's default BSDF, a one-sided 0.5 grey diffuse.
    fn default_material(&mut self) -> u32 {
        *self.default_material.get_or_insert_with(|| {
            self.materials.push(Material {
                name: "(default)".into(),
                one_sided: true,
                ..Material::default()
            });
            self.materials.len() as u32 - 1
        })
    }

    /// A file named by element `e`, found as Mitsuba finds it (`resolver`);
    /// it must be a regular file.
    fn file(&mut self, e: &Elem, name: &str) -> Result<PathBuf, SceneError> {
        let path = self.resolver.resolve(&e.loc, name);
        match std::fs::metadata(&path) {
            Ok(m) if m.is_file() => {
                self.files.push(path.clone());
                Ok(path)
            }
            Ok(_) => Err(e.loc.error(format!(
                "`filename`: {} is not a regular file",
                echo(&path.display().to_string())
            ))),
            Err(err) => Err(e.loc.error(format!(
                "`filename`: cannot read {} (looked in {}): {err}",
                echo(name),
                self.resolver.places(&e.loc)
            ))),
        }
    }
}
