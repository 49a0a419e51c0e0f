//! Ray-intersection backends. A backend answers only *where* a ray hits
//! (`Hit`); the scene turns that into a surface point with code shared by all
//! backends, which is what lets them agree pixel by pixel.

use crate::math::Ray;

/// Preliminary hit: ray parameter, the scene's shape id (`geom`), the
/// primitive within it (`prim`: triangle index, 0 otherwise) and two
/// shape-specific coordinates (barycentrics of vertices 1 and 2 for
/// triangles, quad parameters for quads).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub geom: u32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

pub trait Backend: Send + Sync {
    fn name(&self) -> &'static str;
    /// Closest hit with `t` in `(ray.t_min, ray.t_max)`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything is hit in `(ray.t_min, ray.t_max)`: shadow rays.
    fn occluded(&self, ray: &Ray) -> bool;
}

pub mod bvh;
#[cfg(luz_embree)]
pub mod embree;
pub mod native;
mod planes;

use crate::scene::Scene;
use native::NativeBackend;
use std::sync::Arc;

/// Which backend to build; `Auto` is Embree when compiled in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendKind {
    Auto,
    Rust,
    Embree,
}

impl BackendKind {
    pub const ALL: [BackendKind; 3] = [Self::Auto, Self::Rust, Self::Embree];

    /// The name `FromStr` accepts (which also takes `native` for `rust`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Rust => "rust",
            Self::Embree => "embree",
        }
    }
}

impl std::str::FromStr for BackendKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "native" {
            return Ok(Self::Rust);
        }
        crate::names::parse(s, &Self::ALL, Self::name, "backend")
    }
}

/// Embree's BVH build quality.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EmbreeQuality {
    Low,
    #[default]
    Medium,
    High,
}

impl EmbreeQuality {
    pub const ALL: [EmbreeQuality; 3] = [Self::Low, Self::Medium, Self::High];

    /// The name `FromStr` accepts.
    pub fn name(self) -> &'static str {
        match self {
            Self::Low => "low",
            Self::Medium => "medium",
            Self::High => "high",
        }
    }
}

impl std::str::FromStr for EmbreeQuality {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        crate::names::parse(s, &Self::ALL, Self::name, "Embree quality")
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BuildOptions {
    pub embree_quality: EmbreeQuality,
    pub embree_robust: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("the Embree backend is not compiled into this luz: install Embree 3 (`apt-get install libembree-dev` on Debian 12) and rebuild, or use `--backend rust`")]
    EmbreeMissing,
    #[error("Embree: {0}")]
    Embree(String),
}

/// A built backend. An enum, so the render loop is monomorphised per backend
/// and no virtual call sits in the hot path.
pub enum Accel {
    Native(NativeBackend),
    #[cfg(luz_embree)]
    Embree(embree::EmbreeBackend),
}

impl Accel {
    pub fn build(
        scene: &Arc<Scene>,
        kind: BackendKind,
        options: &BuildOptions,
    ) -> Result<Self, AccelError> {
        match kind {
            BackendKind::Rust => Ok(Accel::Native(NativeBackend::new(scene.clone()))),
            #[cfg(luz_embree)]
            BackendKind::Embree | BackendKind::Auto => Ok(Accel::Embree(
                embree::EmbreeBackend::new(scene.clone(), options)?,
            )),
            #[cfg(not(luz_embree))]
            BackendKind::Auto => {
                let _ = options;
                Ok(Accel::Native(NativeBackend::new(scene.clone())))
            }
            #[cfg(not(luz_embree))]
            BackendKind::Embree => Err(AccelError::EmbreeMissing),
        }
    }
}

/// Per-ray dispatch, for tests and tools; the render loop matches once.
impl Backend for Accel {
    fn name(&self) -> &'static str {
        match self {
            Accel::Native(b) => b.name(),
            #[cfg(luz_embree)]
            Accel::Embree(b) => b.name(),
        }
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match self {
            Accel::Native(b) => b.intersect(ray),
            #[cfg(luz_embree)]
            Accel::Embree(b) => b.intersect(ray),
        }
    }

    fn occluded(&self, ray: &Ray) -> bool {
        match self {
            Accel::Native(b) => b.occluded(ray),
            #[cfg(luz_embree)]
            Accel::Embree(b) => b.occluded(ray),
        }
    }
}

/// Names of the backends compiled into this build.
pub fn compiled_backends() -> Vec<&'static str> {
    let mut v = vec!["rust"];
    if cfg!(luz_embree) {
        v.push("embree");
    }
    v
}

/// Embree's version string, when compiled in.
pub fn embree_version() -> Option<String> {
    #[cfg(luz_embree)]
    {
        static VERSION: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();
        VERSION.get_or_init(embree::library_version).clone()
    }
    #[cfg(not(luz_embree))]
    None
}
