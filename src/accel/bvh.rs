//! TEMPORARY brute-force stand-in with the BVH's API, until the BVH lands.
use crate::math::{Aabb, Ray};

pub enum BuildQuality {
    Balanced,
}

pub struct Bvh {
    order: Vec<u32>,
}

impl Bvh {
    pub fn build(boxes: &[Aabb], _q: BuildQuality) -> Bvh {
        Bvh {
            order: (0..boxes.len() as u32).collect(),
        }
    }
    pub fn primitive_indices(&self) -> &[u32] {
        &self.order
    }
    pub fn intersect_with<H, F: FnMut(u32, &Ray) -> Option<(f32, H)>>(
        &self,
        ray: &Ray,
        mut hit: F,
    ) -> Option<(f32, u32, H)> {
        let mut r = *ray;
        let mut best = None;
        for i in 0..self.order.len() as u32 {
            if let Some((t, h)) = hit(i, &r) {
                r.t_max = t;
                best = Some((t, i, h));
            }
        }
        best
    }
    pub fn occluded<F: FnMut(u32, &Ray) -> bool>(&self, ray: &Ray, mut hit: F) -> bool {
        (0..self.order.len() as u32).any(|i| hit(i, ray))
    }
}
