//! Ray-intersection backends. A backend answers only *where* a ray hits
//! (`geometry::PreliminaryHit`); shared geometry code turns that into a
//! surface point for both backends, which is what lets them agree pixel by
//! pixel.

use crate::geometry::PreliminaryHit;
use crate::math::Ray;

pub trait Backend: Send + Sync {
    fn name(&self) -> &'static str;
    /// Closest hit with `t` in `(ray.t_min, ray.t_max)`, if any.
    fn intersect(&self, ray: &Ray) -> Option<PreliminaryHit>;
    /// Whether anything is hit in `(ray.t_min, ray.t_max)`: shadow rays.
    fn occluded(&self, ray: &Ray) -> bool;
}

/// What a backend's own tree answers, for rays `Accel` has already checked
/// (finite origin and direction, `t_min` not NaN) and whose `t_max` its
/// root shapes have already shortened.
pub trait Tree: Send + Sync {
    fn name(&self) -> &'static str;
    /// Whether the tree holds nothing (every shape at the root, as in a
    /// Cornell box without a mesh): `Accel` then skips it.
    fn is_empty(&self) -> bool;
    /// Closest hit of the tree's shapes in `(ray.t_min, ray.t_max)`.
    fn closest(&self, ray: &Ray) -> Option<PreliminaryHit>;
    /// Whether any of the tree's shapes is hit in `(ray.t_min, ray.t_max)`.
    fn any_hit(&self, ray: &Ray) -> bool;
}

pub mod bvh;
#[cfg(luz_embree)]
pub mod embree;
mod extent;
pub mod native;
mod quality;
mod root;
mod sphere_pack;

pub use quality::{Quality, Work};

use crate::geometry::Geometry;
use crate::simd::F4;
use extent::Extent;
use native::{Gathered, NativeBackend, Packed};
use root::RootShapes;

/// Whether a ray can be traced: finite origin and direction, `t_min` not
/// NaN, `t_min < t_max`. No box or shape test can handle the others, which
/// hit nothing. Branch-free: `x * 0` is ±0 for finite `x` and NaN
/// otherwise, so one comparison of four lanes covers all seven numbers.
#[inline(always)]
pub(crate) fn traceable(ray: &Ray) -> bool {
    let (o, d) = (ray.origin, ray.dir);
    let zero = F4::splat(0.0);
    let origin = F4::load(&[o.x, o.y, o.z, ray.t_min]).mul(zero);
    let dir = F4::load(&[d.x, d.y, d.z, 0.0]).mul(zero);
    (origin.add(dir).eq(zero).bits() == 0b1111) & (ray.t_min < ray.t_max)
}

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

/// Embree's BVH build quality (`Quality` resolved for Embree).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EmbreeQuality {
    Low,
    #[default]
    Medium,
    High,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BuildOptions {
    pub bvh_quality: Quality,
    pub embree_quality: Quality,
    pub embree_robust: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("the Embree backend is not compiled into this luz: install Embree 3 (`apt-get install libembree-dev` on Debian 12) and rebuild, or use `--backend rust`")]
    EmbreeMissing,
    #[cfg(luz_embree)]
    #[error("Embree: {0}")]
    Embree(#[from] embree::EmbreeError),
}

/// A built backend: the root shapes `Accel` tests itself (`root`), over
/// one backend's tree. The tree is an enum, so the render loop is
/// monomorphised per backend (`Accel::over`) and no virtual call sits in the
/// hot path.
pub struct Accel {
    root: RootShapes,
    tree: AccelTree,
    /// Around all of `tree`'s shapes: a ray that misses it skips the tree.
    extent: Extent,
}

/// The native backend is two variants, one per leaf layout, so that each
/// gets a render loop of its own.
pub enum AccelTree {
    Native(NativeBackend<Packed>),
    NativeGathered(NativeBackend<Gathered>),
    #[cfg(luz_embree)]
    Embree(embree::EmbreeBackend),
}

impl Accel {
    /// The accelerator over `shapes`, its trees built for `work`; a hit's
    /// `geom` is the shape's index in `shapes`.
    pub fn build(
        shapes: &[Geometry],
        work: Work,
        kind: BackendKind,
        options: &BuildOptions,
    ) -> Result<Self, AccelError> {
        let (root, in_root) = RootShapes::of(shapes);
        let extent = Extent::of(shapes, &in_root);
        let native = || native::build(shapes, &in_root, options.bvh_quality.native(work));
        let tree = match kind {
            BackendKind::Rust => native(),
            #[cfg(luz_embree)]
            BackendKind::Embree | BackendKind::Auto => {
                AccelTree::Embree(embree::EmbreeBackend::new(shapes, &in_root, options, work)?)
            }
            #[cfg(not(luz_embree))]
            BackendKind::Auto => native(),
            #[cfg(not(luz_embree))]
            BackendKind::Embree => return Err(AccelError::EmbreeMissing),
        };
        Ok(Self { root, tree, extent })
    }

    /// The backend built: `Rust` or `Embree`, never `Auto`.
    pub fn kind(&self) -> BackendKind {
        match &self.tree {
            AccelTree::Native(_) | AccelTree::NativeGathered(_) => BackendKind::Rust,
            #[cfg(luz_embree)]
            AccelTree::Embree(_) => BackendKind::Embree,
        }
    }

    pub fn tree(&self) -> &AccelTree {
        &self.tree
    }

    /// The whole query, root shapes and `tree`, with `tree` one of this
    /// accel's (`Accel::tree`) as a concrete type.
    pub fn over<'a, T: Tree>(&'a self, tree: &'a T) -> Layered<'a, T> {
        Layered {
            root: &self.root,
            tree,
            extent: &self.extent,
        }
    }
}

/// Root shapes over a tree: the complete `Backend`.
pub struct Layered<'a, T> {
    root: &'a RootShapes,
    tree: &'a T,
    extent: &'a Extent,
}

impl<T: Tree> Backend for Layered<'_, T> {
    fn name(&self) -> &'static str {
        self.tree.name()
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<PreliminaryHit> {
        if !traceable(ray) {
            return None;
        }
        // The root first: its walls bound how far the tree is walked.
        let root = self.root.closest(ray);
        if self.tree.is_empty() {
            return root;
        }
        let mut r = *ray;
        if let Some(h) = &root {
            r.t_max = h.t;
        }
        if !self.extent.touches(&r) {
            return root;
        }
        self.tree.closest(&r).or(root)
    }

    /// Always inlined into the integrator: out of line, its
    /// call cost cornell-area 70 instructions per sample.
    #[inline(always)]
    fn occluded(&self, ray: &Ray) -> bool {
        traceable(ray)
            && (self.root.any_hit(ray)
                || (!self.tree.is_empty() && self.extent.touches(ray) && self.tree.any_hit(ray)))
    }
}

/// Per-ray dispatch, for tests and tools; the render loop matches once.
impl Backend for Accel {
    fn name(&self) -> &'static str {
        match &self.tree {
            AccelTree::Native(b) => b.name(),
            AccelTree::NativeGathered(b) => b.name(),
            #[cfg(luz_embree)]
            AccelTree::Embree(b) => b.name(),
        }
    }

    fn intersect(&self, ray: &Ray) -> Option<PreliminaryHit> {
        match &self.tree {
            AccelTree::Native(b) => self.over(b).intersect(ray),
            AccelTree::NativeGathered(b) => self.over(b).intersect(ray),
            #[cfg(luz_embree)]
            AccelTree::Embree(b) => self.over(b).intersect(ray),
        }
    }

    fn occluded(&self, ray: &Ray) -> bool {
        match &self.tree {
            AccelTree::Native(b) => self.over(b).occluded(ray),
            AccelTree::NativeGathered(b) => self.over(b).occluded(ray),
            #[cfg(luz_embree)]
            AccelTree::Embree(b) => self.over(b).occluded(ray),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Mesh, Plane, Quad, Sphere};
    use crate::math::{PackedVec3, Vec3};

    /// A plane, a quad and a sphere (root shapes) and a triangle (a tree's),
    /// all on the ray below.
    fn shapes() -> [Geometry; 4] {
        let z = |z: f32| Vec3::new(-1.0, -1.0, z);
        [
            Geometry::Plane(Plane::new(Vec3::new(0.0, 0.0, -9.0), Vec3::Z)),
            Geometry::Quad(Quad::new(z(-4.0), 2.0 * Vec3::X, 2.0 * Vec3::Y).unwrap()),
            Geometry::Sphere(Sphere {
                center: Vec3::new(0.0, 0.0, -6.0),
                radius: 0.5,
            }),
            Geometry::from(Mesh {
                positions: vec![
                    z(-2.0).into(),
                    PackedVec3::new(1.0, -1.0, -2.0),
                    PackedVec3::new(0.0, 1.0, -2.0),
                ],
                indices: vec![[0, 1, 2]],
                uvs: None,
                normals: None,
            }),
        ]
    }

    /// One check in `Accel`, for the root shapes and both trees: a ray with
    /// a NaN or infinite origin, direction or `t_min`, a NaN `t_max`, or an
    /// empty interval hits nothing and is occluded by nothing.
    #[test]
    fn untraceable_rays_hit_nothing_in_either_backend() {
        let shapes = shapes();
        let good = Ray::new(Vec3::ZERO, -Vec3::Z);
        let mut bad = Vec::new();
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for axis in 0..3 {
                let mut r = good;
                r.origin[axis] = v;
                bad.push(r);
                let mut r = good;
                r.dir[axis] = v;
                bad.push(r);
            }
            let mut r = good;
            r.t_min = v;
            bad.push(r);
        }
        let mut r = good;
        r.t_max = f32::NAN;
        bad.push(r);
        bad.push(Ray { t_max: 0.0, ..good });
        let kinds: &[BackendKind] = if cfg!(luz_embree) {
            &[BackendKind::Rust, BackendKind::Embree]
        } else {
            &[BackendKind::Rust]
        };
        for &kind in kinds {
            // A 1×1 render at the default 16 spp: `auto`'s medium builds.
            let work = Work::of(16.0, &shapes);
            let accel = Accel::build(&shapes, work, kind, &BuildOptions::default()).unwrap();
            let hit = accel.intersect(&good).expect("the triangle");
            assert_eq!((hit.geom, accel.occluded(&good)), (3, true), "{kind:?}");
            for r in &bad {
                assert_eq!(accel.intersect(r), None, "{kind:?} {r:?}");
                assert!(!accel.occluded(r), "{kind:?} {r:?}");
            }
        }
    }
}
