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
