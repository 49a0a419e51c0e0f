//! The native Rust backend: one BVH over every finite primitive of the scene
//! (mesh triangles, spheres, quads, cuboids); infinite planes are tested
//! outside it. Triangles are stored pre-transformed (`p0, e1, e2`) in the
//! BVH's leaf order, so traversal reads them sequentially.

use super::bvh::{BuildQuality, Bvh};
use super::{Backend, Hit};
use crate::math::Vec3;
use crate::math::{Aabb, Ray};
use crate::scene::shape::{intersect_triangle, PrimHit};
use crate::scene::{Geometry, Scene};
use std::sync::Arc;

#[derive(Clone, Copy, Debug)]
enum Prim {
    Triangle {
        p0: Vec3,
        e1: Vec3,
        e2: Vec3,
        geom: u32,
        prim: u32,
    },
    Analytic {
        geom: u32,
    },
}

pub struct NativeBackend {
    scene: Arc<Scene>,
    bvh: Bvh,
    /// Primitives in the BVH's leaf order.
    prims: Vec<Prim>,
    planes: Vec<u32>,
}

impl NativeBackend {
    pub fn new(scene: Arc<Scene>) -> Self {
        Self::with_quality(scene, BuildQuality::Balanced)
    }

    pub fn with_quality(scene: Arc<Scene>, quality: BuildQuality) -> Self {
        let mut boxes = Vec::new();
        let mut refs = Vec::new();
        let mut planes = Vec::new();
        for (geom, shape) in scene.shapes.iter().enumerate() {
            let geom = geom as u32;
            match &shape.geometry {
                Geometry::Plane(_) => planes.push(geom),
                Geometry::Mesh(m) => {
                    for prim in 0..m.triangle_count() as u32 {
                        let [p0, p1, p2] = m.vertices(prim);
                        boxes.push(Aabb::from_points(&[p0, p1, p2]));
                        refs.push(Prim::Triangle {
                            p0,
                            e1: p1 - p0,
                            e2: p2 - p0,
                            geom,
                            prim,
                        });
                    }
                }
                g => {
                    boxes.push(g.primitive_bounds(0).expect("finite shapes have bounds"));
                    refs.push(Prim::Analytic { geom });
                }
            }
        }
        let bvh = Bvh::build(&boxes, quality);
        let prims = bvh
            .primitive_indices()
            .iter()
            .map(|&i| refs[i as usize])
            .collect();
        Self {
            scene,
            bvh,
            prims,
            planes,
        }
    }

    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    #[inline]
    fn intersect_prim(&self, slot: u32, ray: &Ray) -> Option<(PrimHit, u32, u32)> {
        match self.prims[slot as usize] {
            Prim::Triangle {
                p0,
                e1,
                e2,
                geom,
                prim,
            } => intersect_triangle(p0, e1, e2, ray).map(|h| (h, geom, prim)),
            Prim::Analytic { geom } => self.scene.shapes[geom as usize]
                .geometry
                .intersect(0, ray)
                .map(|h| (h, geom, 0)),
        }
    }
}

impl Backend for NativeBackend {
    fn name(&self) -> &'static str {
        "rust"
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best = self
            .bvh
            .intersect_with(ray, |slot, r| {
                self.intersect_prim(slot, r)
                    .map(|(h, geom, prim)| (h.t, (h, geom, prim)))
            })
            .map(|(t, _, (h, geom, prim))| Hit {
                t,
                geom,
                prim,
                u: h.u,
                v: h.v,
            });
        for &geom in &self.planes {
            let mut r = *ray;
            if let Some(b) = &best {
                r.t_max = b.t;
            }
            if let Some(h) = self.scene.shapes[geom as usize].geometry.intersect(0, &r) {
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

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.planes.iter().any(|&g| {
            self.scene.shapes[g as usize]
                .geometry
                .intersect(0, ray)
                .is_some()
        }) || self
            .bvh
            .occluded(ray, |slot, r| self.intersect_prim(slot, r).is_some())
    }
}
