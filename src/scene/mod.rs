//! The scene model: immutable plain data built by `load` from a TOML file
//! or a Mitsuba XML file (or directly, in tests) and shared by every backend and the integrator.

pub mod camera;
pub mod environment;
pub mod light;
pub mod load;
pub mod material;
pub mod mesh_io;
pub mod mitsuba;
mod obj_materials;
pub mod texture;

pub use camera::{Camera, FovAxis};
pub use environment::{EnvMap, EnvSample, Environment};
pub use light::{LightSampler, PointLight, SpotCone};
pub use load::{load, load_bytes, load_bytes_with, load_str, load_with, LoadOptions, SceneError};
pub use material::{Lobes, Material, Opacity, Shading};
pub use texture::{Texture, UvTransform};

use crate::geometry::{Geometry, PreliminaryHit, PrimHit, SurfacePoint};
use crate::math::{luminance, Ray, Rgb, Vec3};
use crate::sampling::SamplerKind;
use std::path::PathBuf;

/// One shape of the scene; its index in `Scene::shapes` is its `geom` id.
#[derive(Clone, Debug)]
pub struct Shape {
    pub geometry: Geometry,
    pub material: u32,
    /// Also sample this emitter by next-event estimation.
    pub nee: bool,
    pub uv_transform: UvTransform,
}

impl Shape {
    pub fn new(geometry: Geometry, material: u32) -> Self {
        Self {
            geometry,
            material,
            nee: false,
            uv_transform: UvTransform::default(),
        }
    }
}

/// Integrator settings a scene file may set and the command line override.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub spp: u32,
    /// Maximum number of path segments, camera segment included (Mitsuba's
    /// `max_depth`): 1 = emitters seen directly, 2 = direct lighting, ...
    pub max_depth: u32,
    pub seed: u64,
    pub russian_roulette: bool,
    pub sampler: SamplerKind,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            spp: 16,
            max_depth: 64,
            seed: 0,
            russian_roulette: true,
            sampler: SamplerKind::default(),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub camera: Camera,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub shapes: Vec<Shape>,
    pub point_lights: Vec<PointLight>,
    /// Radiance arriving from infinitely far away.
    pub environment: Option<Environment>,
    pub lights: LightSampler,
    pub render: RenderSettings,
    /// The files the scene was read from: the scene file, then every mesh
    /// and texture it names. Empty for a scene built in code. Outputs are
    /// checked against them, so a render never overwrites its own input.
    pub files: Vec<PathBuf>,
    /// What the loader noticed but did not refuse (mesh data luz does not
    /// use, triangles it dropped), one line per mesh; `load` prints them.
    pub warnings: Vec<String>,
    /// Per material, what its vertices evaluate; derived from `materials`.
    shading: Vec<Shading>,
}

/// The warning of a scene without light ([`Scene::has_light`]).
pub(crate) const UNLIT_WARNING: &str =
    "the scene has no light (no emissive shape, point light or environment): it renders black";

/// The one warning of a scene on the mesh files it left out, each with no
/// triangle of any area (all degenerate), named by `files`.
pub(crate) fn no_area_warning(files: &[String]) -> String {
    let n = files.len();
    let plural = if n == 1 { "" } else { "es" };
    let shown = files.iter().take(8).cloned().collect::<Vec<_>>().join(", ");
    let more = match n.saturating_sub(8) {
        0 => String::new(),
        k => format!(" and {k} more"),
    };
    format!(
        "left out {n} mesh{plural} with no triangle of any area (all degenerate): {shown}{more}"
    )
}

/// Samples the emitters of the shapes that ask for NEE.
fn light_sampler(shapes: &[Shape], materials: &[Material]) -> LightSampler {
    LightSampler::new(shapes, |s| materials[s.material as usize].emission)
}

impl Scene {
    /// Assembles a scene and builds its light sampler.
    pub fn new(
        camera: Camera,
        materials: Vec<Material>,
        textures: Vec<Texture>,
        shapes: Vec<Shape>,
        point_lights: Vec<PointLight>,
        environment: Option<Environment>,
        render: RenderSettings,
    ) -> Self {
        let lights = light_sampler(&shapes, &materials);
        let shading = materials.iter().map(Material::shading).collect();
        Self {
            camera,
            materials,
            textures,
            shapes,
            point_lights,
            environment,
            lights,
            render,
            files: Vec::new(),
            warnings: Vec::new(),
            shading,
        }
    }

    /// Rebuilds the light sampler after shapes' `nee` flags changed.
    pub fn rebuild_lights(&mut self) {
        self.lights = light_sampler(&self.shapes, &self.materials);
    }

    /// Bare geometry for intersection work (tests, benchmarks, tools): one
    /// default material, no lights, a 1×1 camera on +z looking at the origin.
    pub fn of_geometry(geometry: impl IntoIterator<Item = Geometry>) -> Self {
        let camera = Camera {
            eye: Vec3::Z,
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 40.0,
            fov_axis: FovAxis::Y,
            width: 1,
            height: 1,
        };
        Self::new(
            camera,
            vec![Material::default()],
            vec![],
            geometry.into_iter().map(|g| Shape::new(g, 0)).collect(),
            vec![],
            None,
            RenderSettings::default(),
        )
    }

    /// Whether anything emits light: an emissive shape, a point light of
    /// some intensity, or an environment. Without, every pixel is black.
    pub fn has_light(&self) -> bool {
        let emits = |s: &Shape| self.materials[s.material as usize].is_emissive();
        self.shapes.iter().any(emits)
            || self
                .point_lights
                .iter()
                .any(|l| l.intensity.max_element() > 0.0)
            || match &self.environment {
                Some(Environment::Constant(c)) => c.max_element() > 0.0,
                Some(Environment::Map(m)) => {
                    m.scale > 0.0 && m.texels.iter().any(|t| t.max_element() > 0.0)
                }
                None => false,
            }
    }

    /// The full surface point of a backend's preliminary hit.
    #[inline]
    pub fn surface(&self, ray: &Ray, hit: &PreliminaryHit) -> SurfacePoint {
        self.shapes[hit.geom as usize]
            .geometry
            .surface(hit.prim, ray, &prim_hit(hit))
    }

    #[inline]
    pub fn shading(&self, material: u32) -> Shading {
        self.shading[material as usize]
    }

    #[inline]
    pub fn material_of(&self, geom: u32) -> &Material {
        &self.materials[self.shapes[geom as usize].material as usize]
    }

    /// The opacity of a masked material at a surface point, in [0, 1].
    #[inline]
    pub fn opacity(&self, opacity: Opacity, hit: &PreliminaryHit, sp: &SurfacePoint) -> f32 {
        match opacity {
            Opacity::Constant(alpha) => alpha,
            Opacity::Texture(t) => {
                let shape = &self.shapes[hit.geom as usize];
                let uv = shape.geometry.uv(hit.prim, &prim_hit(hit), sp);
                let texel = self.textures[t as usize].eval(shape.uv_transform.apply(uv));
                luminance(texel).clamp(0.0, 1.0)
            }
        }
    }

    /// Diffuse albedo at a surface point (texture applied).
    #[inline]
    pub fn albedo(&self, hit: &PreliminaryHit, sp: &SurfacePoint) -> Rgb {
        let shape = &self.shapes[hit.geom as usize];
        let m = &self.materials[shape.material as usize];
        match m.texture {
            Some(t) => {
                let uv = shape.geometry.uv(hit.prim, &prim_hit(hit), sp);
                m.kd * self.textures[t as usize].eval(shape.uv_transform.apply(uv))
            }
            None => m.kd,
        }
    }
}

/// The shape-level part of a backend's hit.
#[inline]
fn prim_hit(hit: &PreliminaryHit) -> PrimHit {
    PrimHit {
        t: hit.t,
        u: hit.u,
        v: hit.v,
    }
}
