//! Unidirectional path tracing with next-event estimation, multiple
//! importance sampling and Russian roulette over the material's lobes
//! (DESIGN.md, "Light transport").
//!
//! At each vertex one lobe is chosen at random, with probabilities from the
//! material's coefficients: diffuse (kd), mirror (ks), refraction (kt), or,
//! with Russian roulette on, absorption (the rest). The throughput is divided
//! by the chosen probability, so the estimator stays unbiased. With Russian
//! roulette off the probabilities are normalised (no absorption) and only
//! `max_depth` ends a path.
//!
//! On the diffuse lobe and on the non-delta lobes of the `crate::bsdf`
//! models, point lights, `nee = true` emitters and the environment are
//! sampled explicitly; a BSDF-sampled ray that then hits such an emitter, or
//! escapes to the environment, is weighted by the power heuristic against
//! the light-sampling pdf, so nothing is counted twice. Emitters that are
//! not sampled are found only by hitting them and count fully.

mod lobes;

use super::normals::Normals;
use crate::accel::Backend;
use crate::bsdf::{Bsdf, Context};
use crate::geometry::{PreliminaryHit, SurfacePoint};
use crate::math::{near_unit, spawn_ray, spawn_ray_to, Frame, Ray, Rgb, Vec2, Vec3};
use crate::sampling::{power_heuristic, Dimension, Sampler};

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;
use crate::scene::{Lobes, Material, Opacity, Scene};
use std::f32::consts::FRAC_1_PI;

/// Settings of one integration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorSettings {
    /// Maximum path segments, camera segment included (Mitsuba semantics).
    pub max_depth: u32,
    pub russian_roulette: bool,
}

/// Rays traced, by kind; summed across threads for the summary line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub camera: u64,
    pub bounce: u64,
    pub shadow: u64,
}

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }

    pub fn add(&mut self, o: &RayCounts) {
        self.camera += o.camera;
        self.bounce += o.bounce;
        self.shadow += o.shadow;
    }
}

pub struct Integrator<'a, B: Backend + ?Sized> {
    scene: &'a Scene,
    backend: &'a B,
    settings: IntegratorSettings,
    /// The probability that light sampling picks the environment rather
    /// than an emitter: 0 without an environment, 1 with no emitter to
    /// sample, else ½.
    env_share: f32,
    /// Whether a vertex samples an emitter or the environment (next-event
    /// estimation beyond point lights).
    samples_lights: bool,
}

impl<'a, B: Backend + ?Sized> Integrator<'a, B> {
    pub fn new(scene: &'a Scene, backend: &'a B, settings: IntegratorSettings) -> Self {
        let env_share = match (&scene.environment, scene.lights.is_empty()) {
            (None, _) => 0.0,
            (Some(_), true) => 1.0,
            (Some(_), false) => 0.5,
        };
        Self {
            scene,
            backend,
            settings,
            env_share,
            samples_lights: env_share > 0.0 || !scene.lights.is_empty(),
        }
    }

    /// Radiance arriving along the camera ray `ray` (unit direction).
    pub fn li(&self, mut ray: Ray, sampler: &mut Sampler, counts: &mut RayCounts) -> Rgb {
        let scene = self.scene;
        let mut radiance = Rgb::ZERO;
        let mut beta = Rgb::ONE;
        // The previous vertex, for MIS on emitter hits: position and the
        // solid-angle pdf of the direction sampled there (None: delta lobe
        // or camera, whose emitter hits count fully).
        let mut prev: Option<(Vec3, f32)> = None;
        counts.camera += 1;
        let mut depth = 1;
        while depth <= self.settings.max_depth {
            if depth < self.settings.max_depth {
                // This vertex's Sobol' points, computed while its ray is
                // traced rather than when they are asked for.
                sampler.draw_ahead(depth - 1, self.samples_lights);
            }
            let Some(hit) = self.backend.intersect(&ray) else {
                if let Some(env) = &scene.environment {
                    let weight = match prev {
                        Some((_, pdf_bsdf)) => {
                            power_heuristic(pdf_bsdf, self.env_share * env.pdf(ray.dir))
                        }
                        None => 1.0,
                    };
                    radiance += beta * env.eval(ray.dir) * weight;
                }
                break;
            };
            let sp = scene.surface(&ray, &hit);
            let shape = &scene.shapes[hit.geom as usize];
            if scene.shading(shape.material).emissive && sp.n.dot(ray.dir) < 0.0 {
                let weight = match prev {
                    Some((from, pdf_bsdf)) if shape.nee => {
                        let pdf_light = (1.0 - self.env_share)
                            * scene
                                .lights
                                .pdf(&scene.shapes, hit.geom, hit.prim, from, &sp);
                        power_heuristic(pdf_bsdf, pdf_light)
                    }
                    _ => 1.0,
                };
                radiance += beta * scene.materials[shape.material as usize].emission * weight;
            }
            if depth == self.settings.max_depth {
                break;
            }
            let path = Path {
                beta: &mut beta,
                radiance: &mut radiance,
                sampler: &mut *sampler,
                counts: &mut *counts,
            };
            let Some(next) = self.scatter(&ray, &hit, &sp, shape.material, depth, path) else {
                break;
            };
            if beta.is_nan() || beta.max_element() <= 0.0 {
                break;
            }
            prev = next.pdf.map(|pdf| (sp.p, pdf));
            ray = spawn_ray(sp.p, sp.p_err, sp.n, near_unit(next.wi));
            counts.bounce += 1;
            depth += 1;
        }
        radiance
    }

    /// The vertex at `sp`, met by `ray` at path depth `depth`: the light
    /// sampled there (added to the path's radiance), the direction the path
    /// goes on in and its weight (into the path's throughput). `None` ends
    /// the path.
    #[inline(always)]
    fn scatter(
        &self,
        ray: &Ray,
        hit: &PreliminaryHit,
        sp: &SurfacePoint,
        material_id: u32,
        depth: u32,
        path: Path,
    ) -> Option<Continuation> {
        let material = &self.scene.materials[material_id as usize];
        let wo = -ray.dir;
        let cos_o = sp.n.dot(wo);
        // The vertex's numbers come in dimension order (`Dimension`).
        let vertex = depth - 1;
        // A mask is met with probability α; else the path goes on
        // straight through the surface (`meets_mask`).
        let lobe_number = match material.opacity {
            None => None,
            Some(o) => match self.meets_mask(o, hit, sp, path.sampler, vertex) {
                Some(u) => Some(u),
                // A null interaction: straight on, as through a delta lobe.
                None => {
                    return Some(Continuation {
                        wi: ray.dir,
                        pdf: None,
                    })
                }
            },
        };
        // Mitsuba's one-sided BSDFs are black from behind; luz's own
        // materials reflect on both sides.
        if material.one_sided && cos_o <= 0.0 {
            return None;
        }
        // The geometric side decides entering or leaving; the shading
        // normal, on that side, orients the lobes.
        let normals = Normals::facing(sp, cos_o > 0.0);
        // Seen from below its shading hemisphere a surface scatters
        // nothing, as Mitsuba 3's BSDFs (zero for cos θi ≤ 0 in the shading
        // frame). Never so without vertex normals.
        if sp.smooth && normals.shading.dot(wo) < 0.0 {
            return None;
        }
        let next = match (self.scene.shading(material_id).lobes, &material.bsdf) {
            (Lobes::Bsdf, Some(bsdf)) => {
                let model = (material, bsdf);
                self.bsdf_vertex(model, hit, sp, normals, wo, depth, lobe_number, path)?
            }
            _ => {
                let vertex = (material_id, depth, lobe_number);
                self.lobe_vertex(hit, sp, normals, wo, vertex, path)?
            }
        };
        // A direction the shading normal sends to the other side of the
        // surface than the geometric normal does would leak light through
        // it: the path ends there (Mitsuba 0.6's strict normals; light
        // sampling drops such directions too, in `direct`, so both
        // strategies of MIS agree).
        normals.agree(next.wi).then_some(next)
    }

    /// Mitsuba's mask: whether the path meets the surface (probability α)
    /// and, if it does, the number left for the lobe choice; `None` is a
    /// null interaction, which goes on straight through the surface as
    /// through a delta lobe and takes a segment of `max_depth`, as in
    /// Mitsuba. Light sampling from the vertex before sees the masked
    /// surface as opaque, so an emitter reached through it counts fully,
    /// as it does after any delta lobe. Out of line: the vertices of
    /// opaque materials do not pay for it.
    #[cold]
    #[inline(never)]
    fn meets_mask(
        &self,
        opacity: Opacity,
        hit: &PreliminaryHit,
        sp: &SurfacePoint,
        sampler: &mut Sampler,
        vertex: u32,
    ) -> Option<f32> {
        let u = sampler.get_1d(vertex, Dimension::Lobe);
        let alpha = self.scene.opacity(opacity, hit, sp);
        // What is left of the number below α is again uniform.
        (u < alpha).then(|| (u / alpha).min(ONE_MINUS_EPSILON))
    }

    /// A vertex on `material`'s model of `crate::bsdf`: Russian roulette, light
    /// sampling unless every lobe is a delta, then the model's own sample.
    /// `None` ends the path; otherwise the direction and, for a non-delta
    /// sample, its pdf for MIS at the emitter it may hit. `lobe_number` is
    /// the number a mask has already drawn, if any.
    #[allow(clippy::too_many_arguments)]
    fn bsdf_vertex(
        &self,
        (material, bsdf): (&Material, &Bsdf),
        hit: &PreliminaryHit,
        sp: &SurfacePoint,
        normals: Normals,
        wo: Vec3,
        depth: u32,
        lobe_number: Option<f32>,
        path: Path,
    ) -> Option<Continuation> {
        let Path {
            beta,
            radiance,
            sampler,
            counts,
        } = path;
        let vertex = depth - 1;
        let diffuse = if material.texture.is_some() {
            self.scene.albedo(hit, sp)
        } else {
            material.kd
        };
        let ctx = Context {
            diffuse,
            front: sp.n.dot(wo) > 0.0,
        };
        let frame = Frame::from_normal(normals.shading);
        let wo_local = frame.to_local(wo);
        let mut u_lobe = lobe_number.unwrap_or_else(|| sampler.get_1d(vertex, Dimension::Lobe));
        if self.settings.russian_roulette {
            let q = bsdf.survival(wo_local, &ctx);
            if u_lobe >= q {
                return None;
            }
            // What is left of the number below q is again uniform.
            u_lobe = (u_lobe / q).min(ONE_MINUS_EPSILON);
            *beta /= q;
        }
        if !bsdf.is_delta() {
            let glossy = Glossy {
                bsdf,
                frame,
                wo: wo_local,
                ctx,
            };
            *radiance += *beta * self.direct(sp, normals, &glossy, depth, sampler, counts);
        }
        let u = sampler.get_2d(vertex, Dimension::Direction);
        let s = bsdf.sample(wo_local, u_lobe, u, &ctx)?;
        *beta *= s.weight;
        Some(Continuation {
            wi: frame.to_world(s.wi),
            pdf: (!s.delta).then_some(s.pdf),
        })
    }

    /// Light reaching `sp` from point lights and sampled emitters, times
    /// `surface`'s f·cos; area lights MIS-weighted against its pdf.
    /// Directions on which the two normals disagree get no light.
    fn direct(
        &self,
        sp: &SurfacePoint,
        normals: Normals,
        surface: &impl Reflector,
        depth: u32,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
    ) -> Rgb {
        // Light sampling adds one segment to the path.
        if depth + 1 > self.settings.max_depth {
            return Rgb::ZERO;
        }
        let scene = self.scene;
        let mut sum = Rgb::ZERO;
        for light in &scene.point_lights {
            let to_light = light.position - sp.p;
            let d2 = to_light.length_squared();
            let cos = normals.shading.dot(to_light);
            if !surface.reaches(cos) || !normals.agree(to_light) || d2 == 0.0 {
                continue;
            }
            let mut falloff = 1.0;
            if let Some(cone) = &light.spot {
                // Outside its cone a spot sends nothing: no shadow ray.
                falloff = cone.falloff(-to_light / d2.sqrt());
                if falloff == 0.0 {
                    continue;
                }
            }
            // The light's end has no error: its normal does not matter.
            let ray = spawn_ray_to(sp.p, sp.p_err, sp.n, light.position, Vec3::ZERO, sp.n);
            counts.shadow += 1;
            if !self.backend.occluded(&ray) {
                let d = d2.sqrt();
                let (f_cos, _) = surface.eval(to_light / d, cos / d);
                sum += f_cos * light.intensity * (falloff / d2);
            }
        }
        if self.samples_lights {
            let vertex = depth - 1;
            let both = self.env_share > 0.0 && self.env_share < 1.0;
            let mut u_pick = if scene.lights.picks() || both {
                sampler.get_1d(vertex, Dimension::LightPick)
            } else {
                sampler.skip_1d();
                0.0
            };
            let u = sampler.get_2d(vertex, Dimension::LightPoint);
            if u_pick < self.env_share {
                sum += self.direct_environment(sp, normals, surface, u, counts);
                return sum;
            }
            let area_share = 1.0 - self.env_share;
            if both {
                u_pick = ((u_pick - self.env_share) / area_share).min(ONE_MINUS_EPSILON);
            }
            if let Some(ls) = scene.lights.sample(&scene.shapes, sp.p, u_pick, u) {
                let w = ls.point.p - sp.p;
                let d = w.length();
                let wi = w / d;
                let cos = normals.shading.dot(wi);
                let pdf_light = ls.pdf * area_share;
                if surface.reaches(cos)
                    && normals.agree(wi)
                    && ls.point.n.dot(-wi) > 0.0
                    && pdf_light > 0.0
                {
                    let ray =
                        spawn_ray_to(sp.p, sp.p_err, sp.n, ls.point.p, ls.point.p_err, ls.point.n);
                    counts.shadow += 1;
                    if !self.backend.occluded(&ray) {
                        let (f_cos, pdf) = surface.eval(wi, cos);
                        let weight = power_heuristic(pdf_light, pdf);
                        sum += f_cos * ls.emission * (weight / pdf_light);
                    }
                }
            }
        }
        sum
    }
}

impl<B: Backend + ?Sized> Integrator<'_, B> {
    /// Light from the environment along one sampled direction, MIS-weighted
    /// against `surface`'s pdf.
    fn direct_environment(
        &self,
        sp: &SurfacePoint,
        normals: Normals,
        surface: &impl Reflector,
        u: Vec2,
        counts: &mut RayCounts,
    ) -> Rgb {
        let Some(env) = &self.scene.environment else {
            return Rgb::ZERO;
        };
        let Some(es) = env.sample(u) else {
            return Rgb::ZERO;
        };
        let cos = normals.shading.dot(es.wi);
        let pdf_light = es.pdf * self.env_share;
        if !surface.reaches(cos) || !normals.agree(es.wi) || pdf_light <= 0.0 {
            return Rgb::ZERO;
        }
        counts.shadow += 1;
        if self
            .backend
            .occluded(&spawn_ray(sp.p, sp.p_err, sp.n, es.wi))
        {
            return Rgb::ZERO;
        }
        let (f_cos, pdf) = surface.eval(es.wi, cos);
        f_cos * es.radiance * (power_heuristic(pdf_light, pdf) / pdf_light)
    }
}

/// Where a path goes from a vertex on a model of `crate::bsdf`.
/// What a vertex changes of its path: the throughput, the radiance
/// gathered, and the sampler and ray counts it draws from and adds to.
struct Path<'p> {
    beta: &'p mut Rgb,
    radiance: &'p mut Rgb,
    sampler: &'p mut Sampler,
    counts: &'p mut RayCounts,
}

struct Continuation {
    wi: Vec3,
    /// The solid-angle pdf of `wi`; `None` for a delta lobe.
    pdf: Option<f32>,
}

/// What light sampling needs of a surface: f·|cos θ| for a direction `wi`
/// (world, unit, with `cos` = n_s·wi) and the pdf with which the surface
/// would have sampled it.
trait Reflector {
    fn eval(&self, wi: Vec3, cos: f32) -> (Rgb, f32);

    /// Whether lights behind the surface (`cos` < 0) count too; `eval`
    /// then sees their negative cosine.
    fn transmits(&self) -> bool {
        false
    }

    /// Whether light arriving with cosine `cos` can leave towards the viewer.
    #[inline]
    fn reaches(&self, cos: f32) -> bool {
        cos > 0.0 || (cos < 0.0 && self.transmits())
    }
}

/// The diffuse lobe of the kd/ks/kt mix: kd/π.
struct Lambert(Rgb);

impl Reflector for Lambert {
    #[inline]
    fn eval(&self, _wi: Vec3, cos: f32) -> (Rgb, f32) {
        let pdf = cos * FRAC_1_PI;
        (self.0 * pdf, pdf)
    }
}

/// A model of `crate::bsdf` at a vertex.
struct Glossy<'a> {
    bsdf: &'a Bsdf,
    frame: Frame,
    wo: Vec3,
    ctx: Context,
}

impl Reflector for Glossy<'_> {
    fn eval(&self, wi: Vec3, _cos: f32) -> (Rgb, f32) {
        let wi = self.frame.to_local(wi);
        (
            self.bsdf.eval(self.wo, wi, &self.ctx),
            self.bsdf.pdf(self.wo, wi, &self.ctx),
        )
    }

    fn transmits(&self) -> bool {
        self.bsdf.transmits()
    }
}
