//! Lights: point lights (always sampled by next-event estimation), area
//! lights (emissive shapes; sampled too when they ask for it with
//! `nee = true`); the environment is `super::environment`.

use super::Shape;
use crate::geometry::{Geometry, Quad, SurfacePoint};
use crate::math::{luminance, Rgb, Vec2, Vec3};
use crate::sampling::Discrete;
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity in W/sr per channel (on a spot light's axis).
    pub intensity: Rgb,
    /// A spot light's cone; `None` emits the same intensity everywhere.
    pub spot: Option<SpotCone>,
}

/// Mitsuba's `spot` profile: full intensity within `beam_width` of the
/// axis, falling linearly in angle to zero at `cutoff_angle`.
#[derive(Clone, Debug, PartialEq)]
pub struct SpotCone {
    /// Unit direction of the beam's centre.
    axis: Vec3,
    cutoff: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    inv_transition: f32,
}

impl SpotCone {
    /// A cone around `axis` (any length but zero); angles in radians with
    /// `0 <= beam_width <= cutoff <= π`, as the loaders check.
    pub fn new(axis: Vec3, cutoff: f32, beam_width: f32) -> Self {
        debug_assert!(0.0 <= beam_width && beam_width <= cutoff && cutoff <= PI);
        Self {
            axis: axis.normalize(),
            cutoff,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam_width.cos(),
            // A hard-edged cone (beam = cutoff) never reads it: any
            // direction inside the cutoff is inside the beam.
            inv_transition: 1.0 / (cutoff - beam_width).max(f32::MIN_POSITIVE),
        }
    }

    /// The fraction of the intensity sent along the unit direction `d`
    /// away from the light.
    #[inline]
    pub fn falloff(&self, d: Vec3) -> f32 {
        let cos = self.axis.dot(d);
        if cos <= self.cos_cutoff {
            0.0
        } else if cos >= self.cos_beam {
            1.0
        } else {
            ((self.cutoff - cos.min(1.0).acos()) * self.inv_transition).clamp(0.0, 1.0)
        }
    }
}

/// The emissive shapes that next-event estimation samples, chosen in
/// proportion to their power.
#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// Shape ids of the sampled emitters.
    pub shapes: Vec<u32>,
    /// Position of each shape in `shapes`, indexed by shape id.
    slot: Vec<Option<u32>>,
    choice: Option<Choice>,
    /// Per emitter: triangle distribution for meshes.
    triangles: Vec<Option<Discrete>>,
    /// Per emitter: its emitted radiance.
    emission: Vec<Rgb>,
}

/// How an emitter is picked. One emitter, the common case, is picked with
/// probability exactly one, which is what the distribution over it would
/// return too: the fast paths do not change a single sample.
#[derive(Clone, Debug)]
enum Choice {
    /// The one emitter is a quad (a ceiling light), kept here so that
    /// sampling it reads neither a distribution nor the shape list.
    OneQuad(Quad),
    One,
    ByPower(Discrete),
}

/// A point sampled on an emitter, its emitted radiance, and its solid-angle
/// pdf at the receiving point (selection probability included).
pub struct LightSample {
    pub point: SurfacePoint,
    pub emission: Rgb,
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
            let Some(area) = shape.geometry.area() else {
                continue;
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
            sampler.emission.push(emission);
            weights.push(luminance(emission).max(1e-6) * area);
        }
        let distribution = Discrete::new(weights);
        sampler.choice = match sampler.shapes[..] {
            [geom] if distribution.is_some() => match &shapes[geom as usize].geometry {
                Geometry::Quad(q) => Some(Choice::OneQuad(q.clone())),
                _ => Some(Choice::One),
            },
            _ => distribution.map(Choice::ByPower),
        };
        sampler
    }

    pub fn is_empty(&self) -> bool {
        self.choice.is_none()
    }

    /// Whether `sample` reads its `u_pick`: only a choice among several
    /// emitters does.
    pub fn picks(&self) -> bool {
        matches!(self.choice, Some(Choice::ByPower(_)))
    }

    /// Picks an emitter for `u_pick` in [0,1): its slot and probability.
    #[inline]
    fn pick(&self, u_pick: f32) -> Option<(usize, f32)> {
        match self.choice.as_ref()? {
            Choice::OneQuad(_) | Choice::One => Some((0, 1.0)),
            Choice::ByPower(d) => Some(d.sample(u_pick)),
        }
    }

    pub fn is_sampled(&self, geom: u32) -> bool {
        self.slot.get(geom as usize).is_some_and(|s| s.is_some())
    }

    /// Samples an emitter point as seen from `from`. Always inlined: rustc
    /// kept it out of line, which cost the bunny and cornell-area about 120
    /// instructions per sample.
    #[inline(always)]
    pub fn sample(
        &self,
        shapes: &[Shape],
        from: Vec3,
        u_pick: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        if let Some(Choice::OneQuad(q)) = &self.choice {
            let point = q.point_at(u);
            return Some(LightSample {
                pdf: quad_pdf(q, from, &point)?,
                point,
                emission: self.emission[0],
            });
        }
        let (slot, p_pick) = self.pick(u_pick)?;
        let shape = &shapes[self.shapes[slot] as usize];
        let (point, pdf) = match &shape.geometry {
            Geometry::Sphere(s) => s.sample(from, u)?,
            Geometry::Quad(q) => {
                let sp = q.point_at(u);
                (sp, quad_pdf(q, from, &sp)?)
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
            emission: self.emission[slot],
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
        let p_pick = match self.choice.as_ref().expect("a slot implies a choice") {
            Choice::OneQuad(_) | Choice::One => 1.0,
            Choice::ByPower(d) => d.pmf(*slot as usize),
        };
        let shape = &shapes[geom as usize];
        let pdf = match &shape.geometry {
            Geometry::Sphere(s) => s.pdf(from, hit.p, hit.n),
            Geometry::Quad(q) => quad_pdf(q, from, hit).unwrap_or(0.0),
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

/// Solid-angle density at `from` of the point `sp` sampled uniformly on `q`.
#[inline]
fn quad_pdf(q: &Quad, from: Vec3, sp: &SurfacePoint) -> Option<f32> {
    area_to_solid_angle(from, sp, 1.0 / q.area())
}

/// Converts an area density at `sp` to a solid-angle density at `from`.
#[inline]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sphere;
    use crate::sampling::Rng;

    fn emitter(geometry: Geometry) -> Shape {
        let mut shape = Shape::new(geometry, 0);
        shape.nee = true;
        shape
    }

    fn quad() -> Shape {
        let q = Quad::new(Vec3::new(-1.0, 2.0, -1.0), 2.0 * Vec3::X, 2.0 * Vec3::Z);
        emitter(Geometry::Quad(q.expect("a quad with area")))
    }

    fn sphere() -> Shape {
        emitter(Geometry::Sphere(Sphere {
            center: Vec3::new(2.0, 1.0, 0.0),
            radius: 0.5,
        }))
    }

    /// Mitsuba's spot profile: 1 inside the beam, 0 past the cutoff, and
    /// linear in the angle between them.
    #[test]
    fn spot_falloff_is_flat_then_linear_in_angle_then_zero() {
        let (cutoff, beam) = (40f32.to_radians(), 20f32.to_radians());
        let cone = SpotCone::new(Vec3::new(0.0, -2.0, 0.0), cutoff, beam);
        let at = |degrees: f32| {
            let a = degrees.to_radians();
            cone.falloff(Vec3::new(a.sin(), -a.cos(), 0.0))
        };
        for (degrees, want) in [
            (0.0, 1.0),
            (19.9, 1.0),
            (25.0, 0.75),
            (30.0, 0.5),
            (35.0, 0.25),
        ] {
            assert!(
                (at(degrees) - want).abs() < 1e-5,
                "{degrees}°: {}",
                at(degrees)
            );
        }
        for degrees in [40.01, 90.0, 180.0] {
            assert_eq!(at(degrees), 0.0, "{degrees}°");
        }
        // A hard-edged cone: no transition, no division by zero.
        let hard = SpotCone::new(Vec3::Z, cutoff, cutoff);
        assert_eq!(hard.falloff(Vec3::Z), 1.0);
        assert_eq!(hard.falloff(Vec3::new(0.0, 1.0, 1.0).normalize()), 0.0);
        assert_eq!(hard.falloff(Vec3::new(0.0, 0.8, 1.0).normalize()), 1.0);
    }

    /// Every sample's pdf is the one `pdf` reports for the point, whichever
    /// path (one quad, one shape, several) the sampler took.
    #[test]
    fn sampled_pdfs_match_the_reported_ones() {
        for shapes in [vec![quad()], vec![sphere()], vec![quad(), sphere()]] {
            let lights = LightSampler::new(&shapes, |_| Rgb::ONE);
            let from = Vec3::new(0.3, 0.0, 0.2);
            let mut rng = Rng::new(1, 2);
            let mut sampled = 0;
            for _ in 0..1000 {
                let (u_pick, u) = (rng.next_f32(), rng.next_2d());
                let Some(ls) = lights.sample(&shapes, from, u_pick, u) else {
                    continue;
                };
                sampled += 1;
                // The quad, when there is one, is shape 0 at y = 2.
                let geom = if ls.point.p.y > 1.75 {
                    0
                } else {
                    shapes.len() - 1
                };
                let geom = geom as u32;
                let pdf = lights.pdf(&shapes, geom, 0, from, &ls.point);
                assert!((ls.pdf - pdf).abs() <= 1e-4 * pdf, "{} vs {pdf}", ls.pdf);
                assert_eq!(ls.emission, Rgb::ONE);
            }
            // Every emitter is in view of `from`: nearly every sample counts.
            assert!(sampled > 900, "{sampled} samples");
        }
    }

    #[test]
    fn a_single_emitter_is_picked_with_probability_one() {
        for shapes in [vec![quad()], vec![sphere()]] {
            let lights = LightSampler::new(&shapes, |_| Rgb::splat(3.0));
            assert_eq!(lights.pick(0.999), Some((0, 1.0)));
        }
        assert!(LightSampler::new(&[quad()], |_| Rgb::ZERO).is_empty());
    }
}
