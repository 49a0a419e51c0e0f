//! The Embree backend: one Embree device and one scene per backend.
//!
//! - Meshes are Embree's native triangle geometry (its own intersector,
//!   watertight only with `embree_robust`, so `t`, `u`, `v` differ from the
//!   native watertight test in the last bits; agreement between backends is
//!   statistical).
//! - Infinite planes, and spheres, quads and cuboids when a scene has few
//!   of them, are tested outside Embree by `Accel` (`accel::root`), for both
//!   backends alike. Embree needs finite bounds for every primitive; "huge"
//!   finite bounds (say ±1e30) would put a box around the whole scene into
//!   its BVH that every ray enters, would lose any ray or plane beyond it,
//!   and with the compressed node formats risks overflow in the quantised
//!   bounds.
//! - The analytic shapes of scenes with many of them are Embree user
//!   geometry whose callbacks call the very routines the native backend uses
//!   (`Geometry::intersect`).
//!
//! Every geometry is attached with `rtcAttachGeometryByID` under its index
//! in the shapes the backend is built from (a scene's shape index, through
//! `render::build_accel`), so Embree's `geomID` is `PreliminaryHit::geom`
//! without remapping.
//!
//! All Embree-3 specifics (layouts, constants, callback conventions) live in
//! `sys3`; this file uses only its small safe API, whose failures are
//! [`EmbreeError`]s (`error`, shared by every Embree version's module).

mod error;
mod sys3;

pub use error::{EmbreeError, ErrorCode, Report};

use self::sys3 as sys;
use super::{AccelError, BuildOptions, EmbreeQuality, Tree, Work};
use crate::geometry::{Geometry, PreliminaryHit, PrimHit};
use crate::math::{Aabb, Ray};
use crate::meter::{Step, StepKind};

pub struct EmbreeBackend {
    // Field order is drop order: the Embree scene (which holds pointers into
    // `shapes`) goes first, the shapes last.
    rtc: sys::Scene,
    device: sys::Device,
    /// No geometry was attached.
    empty: bool,
    /// A copy of the shapes (the meshes shared, not copied): owns the
    /// vertex and index buffers Embree reads and the user geometry it calls
    /// back into, at addresses that stay put while the backend moves.
    _shapes: Box<[Geometry]>,
}

/// Spheres, quads and cuboids as Embree user primitives (one per shape).
impl sys::UserPrimitives for Geometry {
    fn bounds(&self, prim: u32) -> Aabb {
        self.primitive_bounds(prim)
            .expect("only bounded shapes become user geometry")
    }

    #[inline]
    fn intersect(&self, prim: u32, ray: &Ray) -> Option<PrimHit> {
        Geometry::intersect(self, prim, ray)
    }

    #[inline]
    fn occluded(&self, prim: u32, ray: &Ray) -> bool {
        Geometry::intersect(self, prim, ray).is_some()
    }
}

impl EmbreeBackend {
    /// Embree's scene of `shapes`, less those `in_root` (which `Accel`
    /// tests); a hit's `geom` is the shape's index in `shapes`.
    pub fn new(
        shapes: &[Geometry],
        in_root: &[bool],
        options: &BuildOptions,
        work: Work,
    ) -> Result<Self, AccelError> {
        Self::with_device_config(shapes, in_root, options, work, None)
    }

    /// `new` with an Embree device configuration string (`rtcNewDevice`'s
    /// argument, e.g. "threads=4,verbose=1"); `None` is Embree's default.
    pub fn with_device_config(
        shapes: &[Geometry],
        in_root: &[bool],
        options: &BuildOptions,
        work: Work,
        config: Option<&str>,
    ) -> Result<Self, AccelError> {
        let device = sys::Device::new(config)?;
        let (quality, compact) = options.embree_quality.embree(work);
        let rtc = device.new_scene(quality, options.embree_robust, compact)?;
        let shapes: Box<[Geometry]> = shapes.into();
        let mut empty = true;
        for (id, shape) in shapes.iter().enumerate() {
            if in_root[id] {
                continue;
            }
            let id = u32::try_from(id).ok().filter(|&i| i != u32::MAX).ok_or(
                EmbreeError::TooManyShapes {
                    shapes: shapes.len(),
                },
            )?;
            // SAFETY: the shapes live in `shapes`, which this backend holds
            // and drops after the Embree scene.
            let Some(geom) = (unsafe { geometry_of(&device, id, shape, quality)? }) else {
                continue;
            };
            device.attach(&rtc, &geom, id)?;
            empty = false;
        }
        let in_tree = shapes.iter().zip(in_root).filter(|(_, &r)| !r);
        let primitives = in_tree.map(|(g, _)| g.primitive_count()).sum::<usize>() as u64;
        let _step = Step::begin(StepKind::BuildTree { backend: "embree" }, primitives);
        device.commit(&rtc, Step::current(), primitives)?;
        Ok(Self {
            rtc,
            device,
            empty,
            _shapes: shapes,
        })
    }

    /// Version of the Embree library this backend runs on.
    pub fn version(&self) -> String {
        self.device.version()
    }
}

/// Embree's committed geometry of shape `id`, `geometry`; `None` for a mesh
/// without triangles.
///
/// # Safety
///
/// `geometry` outlives the geometry returned and every scene it is attached
/// to.
unsafe fn geometry_of(
    device: &sys::Device,
    id: u32,
    geometry: &Geometry,
    quality: EmbreeQuality,
) -> Result<Option<sys::Geometry>, EmbreeError> {
    let geom = match geometry {
        Geometry::Mesh(m) => {
            if m.indices.is_empty() {
                return Ok(None);
            }
            let n = m.positions.len();
            let out_of_range = m
                .indices
                .iter()
                .enumerate()
                .find_map(|(t, tri)| tri.iter().find(|&&i| i as usize >= n).map(|&i| (t, i)));
            if let Some((triangle, vertex)) = out_of_range {
                return Err(EmbreeError::VertexOutOfRange {
                    shape: id,
                    triangle,
                    vertex,
                    vertices: n,
                });
            }
            let spare = m.positions.capacity() > n;
            // SAFETY: with spare capacity, the 4 bytes after the last vertex
            // are allocated; the caller vouches for the arrays' lifetime.
            unsafe { device.new_triangles(&m.positions, spare, &m.indices, quality) }
        }
        g => {
            if !matches!(g.primitive_bounds(0), Some(b) if b.is_finite()) {
                return Err(EmbreeError::Unbounded {
                    shape: id,
                    kind: g.name(),
                });
            }
            // SAFETY: the caller vouches for `g`'s lifetime.
            unsafe { device.new_user(g as *const Geometry, 1) }
        }
    }?;
    Ok(Some(geom))
}

/// Version of the linked Embree library, e.g. "3.13.5".
pub fn library_version() -> Option<String> {
    sys::Device::new(None).ok().map(|d| d.version())
}

/// Rays reach it checked by `Accel` (`accel::traceable`): Embree leaves
/// the behaviour on NaN or infinite origins and directions undefined, while
/// luz's routines miss them.
impl Tree for EmbreeBackend {
    fn name(&self) -> &'static str {
        "embree"
    }

    fn is_empty(&self) -> bool {
        self.empty
    }

    #[inline]
    fn closest(&self, ray: &Ray) -> Option<PreliminaryHit> {
        self.rtc.intersect(ray)
    }

    #[inline]
    fn any_hit(&self, ray: &Ray) -> bool {
        self.rtc.occluded(ray)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Mesh, Sphere};
    use crate::math::{PackedVec3, Vec3};

    fn build(shapes: &[Geometry], in_root: &[bool]) -> Result<EmbreeBackend, AccelError> {
        // A 1×1 render at the default 16 spp: `auto`'s medium build.
        let work = Work::of(16.0, shapes);
        EmbreeBackend::new(shapes, in_root, &BuildOptions::default(), work)
    }

    /// Both ways of handing Embree a mesh: its own copy, and luz's array
    /// when there is room after the last vertex.
    #[test]
    fn hits_report_the_scenes_own_ids() {
        for spare in [false, true] {
            let mut positions = vec![
                PackedVec3::new(-1.0, -1.0, -2.0),
                PackedVec3::new(1.0, -1.0, -2.0),
                PackedVec3::new(0.0, 1.0, -2.0),
            ];
            positions.shrink_to_fit();
            if spare {
                positions.reserve_exact(1);
            }
            let shapes = sphere_behind(positions, vec![[0, 1, 2]]);
            // Nothing at the root: the sphere is user geometry.
            let b = build(&shapes, &[false, false]).unwrap();
            let down = |x: f32| Ray::new(Vec3::new(x, 0.0, 0.0), -Vec3::Z);
            let h = b.closest(&down(0.0)).unwrap();
            assert_eq!((h.geom, h.prim), (1, 0));
            assert!((h.t - 2.0).abs() < 1e-6);
            // Beyond the triangle's tip at x = 0.9, only the sphere.
            let h = b.closest(&down(0.9)).unwrap();
            assert_eq!((h.geom, h.prim), (0, 0));
            assert!(b.any_hit(&down(0.9)));
            assert!(!b.any_hit(&Ray::segment(Vec3::new(0.9, 0.0, 0.0), -Vec3::Z, 3.0)));
            assert!(b.closest(&down(3.0)).is_none());
            assert_eq!(b.version().split('.').next(), Some("3"));
        }
    }

    /// A unit sphere at z = -5 (shape 0) and the mesh `positions`,
    /// `indices` (shape 1).
    fn sphere_behind(positions: Vec<PackedVec3>, indices: Vec<[u32; 3]>) -> Vec<Geometry> {
        vec![
            Geometry::Sphere(Sphere {
                center: Vec3::new(0.0, 0.0, -5.0),
                radius: 1.0,
            }),
            Geometry::from(Mesh {
                positions,
                indices,
                uvs: None,
                normals: None,
            }),
        ]
    }

    /// The build is one step counting the tree's primitives (the sphere's
    /// one and the grid's triangles), never more than all of them.
    #[test]
    fn builds_are_one_metered_step() {
        use crate::meter::test_support::{steps, Recorder};
        let side = 300u32;
        let positions = (0..=side)
            .flat_map(|y| (0..=side).map(move |x| PackedVec3::new(x as f32, y as f32, -3.0)))
            .collect();
        let at = |x: u32, y: u32| y * (side + 1) + x;
        let indices = (0..side)
            .flat_map(|y| {
                (0..side).flat_map(move |x| {
                    [
                        [at(x, y), at(x + 1, y), at(x, y + 1)],
                        [at(x + 1, y), at(x + 1, y + 1), at(x, y + 1)],
                    ]
                })
            })
            .collect();
        let shapes = sphere_behind(positions, indices);
        let (built, events) = Recorder::record(|| build(&shapes, &[false, false]));
        assert!(built.is_ok());
        let steps = steps(&events);
        let primitives = 1 + 2 * (side * side) as u64;
        assert_eq!(steps.len(), 1, "{events:?}");
        assert_eq!(
            (steps[0].0.as_str(), steps[0].1),
            ("build embree", primitives)
        );
        assert!(steps[0].2 <= primitives, "{steps:?}");
    }

    #[test]
    fn embree_failures_become_accel_errors() {
        match EmbreeBackend::with_device_config(
            &[],
            &[],
            &BuildOptions::default(),
            Work::of(1.0, &[]),
            Some("threads=x"),
        ) {
            Err(AccelError::Embree(e @ EmbreeError::Device { .. })) => {
                assert!(e.to_string().starts_with("rtcNewDevice failed: "), "{e}")
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("built"),
        }
    }

    #[test]
    fn out_of_range_indices_are_a_build_error_not_a_crash() {
        let shapes = [Geometry::from(Mesh {
            positions: vec![PackedVec3::ZERO, PackedVec3::X, PackedVec3::Y],
            indices: vec![[0, 1, 7]],
            uvs: None,
            normals: None,
        })];
        match build(&shapes, &[false]) {
            Err(AccelError::Embree(
                e @ EmbreeError::VertexOutOfRange {
                    shape: 0,
                    triangle: 0,
                    vertex: 7,
                    vertices: 3,
                },
            )) => assert!(e.to_string().contains("refers to vertex 7"), "{e}"),
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("built"),
        }
    }
}
