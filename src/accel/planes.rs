//! Infinite planes, tested outside both backends' BVHs by this one piece of
//! code: they have no finite bounds (Embree drops user geometry bounds beyond
//! ~1.8e18, and a huge box would be entered by every ray), a scene has a
//! handful at most, and sharing the loop makes plane hits bit-identical
//! across backends.

use super::Hit;
use crate::math::Ray;
use crate::scene::{Geometry, Shape};

/// The scene ids of the infinite planes.
#[derive(Clone, Debug, Default)]
pub struct InfinitePlanes(Vec<u32>);

impl InfinitePlanes {
    pub fn of(shapes: &[Shape]) -> Self {
        Self(
            shapes
                .iter()
                .enumerate()
                .filter(|(_, s)| matches!(s.geometry, Geometry::Plane(_)))
                .map(|(geom, _)| geom as u32)
                .collect(),
        )
    }

    /// The closest of `best` and the plane hits in front of it.
    #[inline]
    pub fn closest(&self, shapes: &[Shape], ray: &Ray, mut best: Option<Hit>) -> Option<Hit> {
        let mut r = *ray;
        for &geom in &self.0 {
            if let Some(b) = &best {
                r.t_max = b.t;
            }
            if let Some(h) = shapes[geom as usize].geometry.intersect(0, &r) {
                best = Some(Hit {
                    t: h.t,
                    geom,
                    prim: 0,
                    u: h.u,
                    v: h.v,
                });
            }
        }
        best
    }

    /// Whether any plane is hit in `(ray.t_min, ray.t_max)`.
    #[inline]
    pub fn any_hit(&self, shapes: &[Shape], ray: &Ray) -> bool {
        self.0
            .iter()
            .any(|&g| shapes[g as usize].geometry.intersect(0, ray).is_some())
    }
}
