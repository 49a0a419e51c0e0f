//! Lights: point lights (always sampled by next-event estimation), area
//! lights (emissive shapes; sampled too when they ask for it with
//! `nee = true`) and a constant environment (found by escaping rays).

use super::shape::{Geometry, SurfacePoint};
use super::Shape;
use crate::math::{luminance, Rgb, Vec2, Vec3};
use crate::sampling::Discrete;

#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity in W/sr per channel.
    pub intensity: Rgb,
}

/// The emissive shapes that next-event estimation samples, chosen in
/// proportion to their power.
#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// Shape ids of the sampled emitters.
    pub shapes: Vec<u32>,
    /// Position of each shape in `shapes`, indexed by shape id.
    slot: Vec<Option<u32>>,
    choice: Option<Discrete>,
    /// Per emitter: triangle distribution for meshes.
    triangles: Vec<Option<Discrete>>,
}

/// A point sampled on an emitter, with its solid-angle pdf at the
/// receiving point (selection probability included).
pub struct LightSample {
    pub point: SurfacePoint,
    pub geom: u32,
    pub pdf: f32,
}

impl LightSampler {
    pub fn new(shapes: &[Shape], emission_of: impl Fn(&Shape) -> Rgb) -> Self {
        let mut sampler = LightSampler {
            slot: vec![None; shapes.len()],
            ..Default::default()
        };
        let mut weights = Vec::new();
        for (id, shape) in shapes.iter().enumerate() {
            let emission = emission_of(shape);
            if !shape.nee || emission.max_element() <= 0.0 {
                continue;
            }
            let area = match &shape.geometry {
                Geometry::Sphere(s) => s.area(),
                Geometry::Quad(q) => q.area(),
                Geometry::Cuboid(c) => c.area(),
                Geometry::Mesh(m) => (0..m.triangle_count() as u32)
                    .map(|i| m.triangle_area(i))
                    .sum(),
                Geometry::Plane(_) => continue,
            };
            if area.is_nan() || area <= 0.0 {
                continue;
            }
            sampler.slot[id] = Some(sampler.shapes.len() as u32);
            sampler.shapes.push(id as u32);
            sampler.triangles.push(match &shape.geometry {
                Geometry::Mesh(m) => m.area_distribution(),
                _ => None,
            });
            weights.push(luminance(emission).max(1e-6) * area);
        }
        sampler.choice = Discrete::new(weights);
        sampler
    }

    pub fn is_empty(&self) -> bool {
        self.choice.is_none()
    }

    pub fn is_sampled(&self, geom: u32) -> bool {
        self.slot.get(geom as usize).is_some_and(|s| s.is_some())
    }

    /// Samples an emitter point as seen from `from`.
    pub fn sample(
        &self,
        shapes: &[Shape],
        from: Vec3,
        u_pick: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let choice = self.choice.as_ref()?;
        let (slot, p_pick) = choice.sample(u_pick);
        let geom = self.shapes[slot];
        let shape = &shapes[geom as usize];
        let (point, pdf) = match &shape.geometry {
            Geometry::Sphere(s) => s.sample(from, u)?,
            Geometry::Quad(q) => {
                let sp = q.point_at(u);
                let pdf = area_to_solid_angle(from, &sp, 1.0 / q.area())?;
                (sp, pdf)
            }
            Geometry::Cuboid(c) => {
                let sp = c.sample_area(u);
                let pdf = area_to_solid_angle(from, &sp, 1.0 / c.area())?;
                (sp, pdf)
            }
            Geometry::Mesh(m) => {
                let tris = self.triangles[slot].as_ref()?;
                let (tri, p_tri, ux) = tris.sample_reuse(u.x);
                let sp = m.sample_triangle(tri as u32, Vec2::new(ux, u.y));
                let pdf = area_to_solid_angle(from, &sp, p_tri / m.triangle_area(tri as u32))?;
                (sp, pdf)
            }
            Geometry::Plane(_) => return None,
        };
        Some(LightSample {
            point,
            geom,
            pdf: pdf * p_pick,
        })
    }

    /// Solid-angle pdf with which `sample` would have produced the point
    /// `hit` on shape `geom` (primitive `prim`), seen from `from`.
    pub fn pdf(
        &self,
        shapes: &[Shape],
        geom: u32,
        prim: u32,
        from: Vec3,
        hit: &SurfacePoint,
    ) -> f32 {
        let Some(Some(slot)) = self.slot.get(geom as usize) else {
            return 0.0;
        };
        let choice = self.choice.as_ref().expect("a slot implies a distribution");
        let p_pick = choice.pmf(*slot as usize);
        let shape = &shapes[geom as usize];
        let pdf = match &shape.geometry {
            Geometry::Sphere(s) => s.pdf(from, hit.p, hit.n),
            Geometry::Quad(q) => area_to_solid_angle(from, hit, 1.0 / q.area()).unwrap_or(0.0),
            Geometry::Cuboid(c) => area_to_solid_angle(from, hit, 1.0 / c.area()).unwrap_or(0.0),
            Geometry::Mesh(m) => {
                let tris = self.triangles[*slot as usize].as_ref();
                let p_tri = tris.map_or(0.0, |t| t.pmf(prim as usize));
                area_to_solid_angle(from, hit, p_tri / m.triangle_area(prim)).unwrap_or(0.0)
            }
            Geometry::Plane(_) => 0.0,
        };
        pdf * p_pick
    }
}

/// Converts an area density at `sp` to a solid-angle density at `from`.
fn area_to_solid_angle(from: Vec3, sp: &SurfacePoint, pdf_area: f32) -> Option<f32> {
    let w = sp.p - from;
    let d2 = w.length_squared();
    if d2 == 0.0 {
        return None;
    }
    let cos = sp.n.dot(w).abs() / d2.sqrt();
    if cos == 0.0 {
        return None;
    }
    Some(pdf_area * d2 / cos)
}
