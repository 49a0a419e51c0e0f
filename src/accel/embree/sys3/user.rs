//! Embree 3's user-geometry callbacks: SOA ray packets of `N` rays with a
//! `valid` mask, hits written into the packet, and `tfar = -inf` for
//! "occluded".

use super::bindings::*;
use crate::geometry::PrimHit;
use crate::math::{Aabb, Ray, Vec3};
use std::ffi::c_uint;

/// Primitives Embree does not know, intersected by luz's own routines.
pub trait UserPrimitives: Sync {
    /// Finite bounds of primitive `prim`.
    fn bounds(&self, prim: u32) -> Aabb;
    /// Closest hit in `(ray.t_min, ray.t_max)`.
    fn intersect(&self, prim: u32, ray: &Ray) -> Option<PrimHit>;
    /// Whether `prim` is hit in `(ray.t_min, ray.t_max)`.
    fn occluded(&self, prim: u32, ray: &Ray) -> bool;
}

pub(super) unsafe extern "C" fn bounds_fn<T: UserPrimitives>(
    args: *const RTCBoundsFunctionArguments,
) {
    // SAFETY: Embree passes valid arguments; the user pointer is a `T`.
    let args = unsafe { &*args };
    let prims = unsafe { &*(args.geometryUserPtr as *const T) };
    let b = prims.bounds(args.primID);
    unsafe {
        *args.bounds_o = RTCBounds {
            lower_x: b.min.x,
            lower_y: b.min.y,
            lower_z: b.min.z,
            align0: 0.0,
            upper_x: b.max.x,
            upper_y: b.max.y,
            upper_z: b.max.z,
            align1: 0.0,
        };
    }
}

/// Ray `i` of an SOA packet of `n` (`RTCRayN_*` of `rtcore_ray.h`).
#[inline]
unsafe fn read_ray_n(ray: *const f32, n: usize, i: usize) -> Ray {
    let f = |k: usize| unsafe { *ray.add(k * n + i) };
    Ray {
        origin: Vec3::new(f(0), f(1), f(2)),
        t_min: f(3),
        dir: Vec3::new(f(4), f(5), f(6)),
        t_max: f(8),
    }
}

pub(super) unsafe extern "C" fn intersect_fn<T: UserPrimitives>(
    args: *const RTCIntersectFunctionNArguments,
) {
    // SAFETY: Embree passes a valid packet of `N` rays, a `valid` mask of
    // `N` ints, and the user pointer given at creation (a `T`).
    let args = unsafe { &*args };
    let prims = unsafe { &*(args.geometryUserPtr as *const T) };
    let n = args.N as usize;
    let ray = args.rayhit as *mut f32;
    // RTCRayHitN_HitN: the hit follows the 12 ray fields.
    let hit = unsafe { ray.add(12 * n) };
    for i in 0..n {
        if unsafe { *args.valid.add(i) } == 0 {
            continue;
        }
        let r = unsafe { read_ray_n(ray, n, i) };
        if let Some(h) = prims.intersect(args.primID, &r) {
            unsafe {
                *ray.add(8 * n + i) = h.t;
                // Ng is left zero: nothing reads it (`Scene::intersect`
                // returns no normal; luz rebuilds the surface from the hit),
                // so computing one per candidate hit would be wasted work.
                *hit.add(i) = 0.0;
                *hit.add(n + i) = 0.0;
                *hit.add(2 * n + i) = 0.0;
                *hit.add(3 * n + i) = h.u;
                *hit.add(4 * n + i) = h.v;
                let ids = hit as *mut c_uint;
                *ids.add(5 * n + i) = args.primID;
                *ids.add(6 * n + i) = args.geomID;
                let ctx = &*args.context;
                for (l, &inst) in ctx.instID.iter().enumerate() {
                    *ids.add(7 * n + i + n * l) = inst;
                }
            }
        }
    }
}

pub(super) unsafe extern "C" fn occluded_fn<T: UserPrimitives>(
    args: *const RTCOccludedFunctionNArguments,
) {
    // SAFETY: as in `intersect_fn`.
    let args = unsafe { &*args };
    let prims = unsafe { &*(args.geometryUserPtr as *const T) };
    let n = args.N as usize;
    let ray = args.ray as *mut f32;
    for i in 0..n {
        if unsafe { *args.valid.add(i) } == 0 {
            continue;
        }
        let r = unsafe { read_ray_n(ray, n, i) };
        if prims.occluded(args.primID, &r) {
            // Embree 3's convention for "occluded".
            unsafe { *ray.add(8 * n + i) = f32::NEG_INFINITY };
        }
    }
}
