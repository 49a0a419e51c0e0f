//! The two normals of a path vertex: the geometric one decides the side of
//! the surface, the shading one orients the lobes (`SurfacePoint`).

use crate::geometry::SurfacePoint;
use crate::math::Vec3;

/// The geometric and shading normals of a vertex, both turned to the side
/// the path arrived from.
#[derive(Clone, Copy)]
pub(super) struct Normals {
    geometric: Vec3,
    pub(super) shading: Vec3,
    /// `SurfacePoint::smooth`: whether the two may differ.
    smooth: bool,
}

impl Normals {
    #[inline]
    pub(super) fn facing(sp: &SurfacePoint, front: bool) -> Self {
        let sign = if front { 1.0 } else { -1.0 };
        Self {
            geometric: sign * sp.n,
            shading: sign * sp.ns,
            smooth: sp.smooth,
        }
    }

    /// Whether both normals put `w` on the same side of the surface:
    /// always so without vertex normals, which the flag answers at the
    /// cost of one branch.
    #[inline]
    pub(super) fn agree(&self, w: Vec3) -> bool {
        !self.smooth || (self.geometric.dot(w) > 0.0) == (self.shading.dot(w) > 0.0)
    }
}
