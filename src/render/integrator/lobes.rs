//! The lobes of luz's own kd/ks/kt materials: which one a vertex follows
//! (diffuse, mirror or refraction, with Russian roulette over them) and the
//! vertex that follows it.

use super::{Continuation, Integrator, Lambert, Path};
use crate::accel::Backend;
use crate::geometry::{PreliminaryHit, SurfacePoint};
use crate::math::{fresnel_dielectric, reflect, refract, Frame, Rgb, Vec3};
use crate::render::normals::Normals;
use crate::sampling::{cosine_hemisphere, Dimension, Sampler};
use crate::scene::{Lobes, Material};
use std::f32::consts::FRAC_1_PI;

/// A lobe of luz's own materials.
enum Lobe {
    Diffuse,
    Mirror,
    Refraction,
}

/// The lobe chosen at a vertex, the probability of that choice and the
/// lobe's coefficient there (kd, ks or kt).
struct Scatter {
    lobe: Lobe,
    p: f32,
    k: Rgb,
}

impl<B: Backend + ?Sized> Integrator<'_, B> {
    /// A vertex on the kd/ks/kt material `material_id` at path depth
    /// `depth`: the lobe chosen, light sampled on the diffuse one, the
    /// direction the path goes on in. `None` ends the path. `lobe_number`
    /// is the number a mask has already drawn, if any.
    #[inline(always)]
    pub(super) fn lobe_vertex(
        &self,
        hit: &PreliminaryHit,
        sp: &SurfacePoint,
        normals: Normals,
        wo: Vec3,
        (material_id, depth, lobe_number): (u32, u32, Option<f32>),
        path: Path,
    ) -> Option<Continuation> {
        let vertex = depth - 1;
        let cos_o = sp.n.dot(wo);
        let Scatter { lobe, p, k } = self.choose_lobe(
            material_id,
            hit,
            sp,
            cos_o,
            lobe_number,
            path.sampler,
            vertex,
        )?;
        let ns = normals.shading;
        Some(match lobe {
            Lobe::Diffuse => {
                *path.beta /= p;
                *path.radiance += *path.beta
                    * self.direct(sp, normals, &Lambert(k), depth, path.sampler, path.counts);
                let u = path.sampler.get_2d(vertex, Dimension::Direction);
                let local = cosine_hemisphere(u);
                *path.beta *= k;
                Continuation {
                    wi: Frame::from_normal(ns).to_world(local),
                    pdf: Some(local.z * FRAC_1_PI),
                }
            }
            Lobe::Mirror => {
                *path.beta *= k / p;
                Continuation {
                    wi: reflect(wo, ns),
                    pdf: None,
                }
            }
            Lobe::Refraction => {
                *path.beta *= k / p;
                let ior = self.scene.materials[material_id as usize].ior;
                let eta = if cos_o > 0.0 { ior } else { 1.0 / ior };
                // Total internal reflection sends the light back.
                Continuation {
                    wi: refract(wo, ns, eta).unwrap_or_else(|| reflect(wo, ns)),
                    pdf: None,
                }
            }
        })
    }

    /// Chooses the lobe followed at a vertex; `None` when the path ends
    /// there (absorption, or nothing left to scatter). A diffuse-only
    /// material takes a number from the sampler as a mixed one does (and
    /// skips it when the diffuse lobe is certain), so the independent stream
    /// does not depend on which of the two evaluated the choice.
    /// `lobe_number` is the number a mask has already drawn, if any.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn choose_lobe(
        &self,
        material_id: u32,
        hit: &PreliminaryHit,
        sp: &SurfacePoint,
        cos_o: f32,
        lobe_number: Option<f32>,
        sampler: &mut Sampler,
        vertex: u32,
    ) -> Option<Scatter> {
        let material = &self.scene.materials[material_id as usize];
        let mut draw = || lobe_number.unwrap_or_else(|| sampler.get_1d(vertex, Dimension::Lobe));
        let Lobes::Diffuse { weight } = self.scene.shading(material_id).lobes else {
            return self.choose_mixed_lobe(material, hit, sp, cos_o, draw());
        };
        let p = weight * self.lobe_scale(weight)?;
        let chosen = match (p >= 1.0, lobe_number) {
            (true, Some(_)) => true,
            (true, None) => {
                sampler.skip_1d();
                true
            }
            (false, _) => draw() < p,
        };
        chosen.then_some(Scatter {
            lobe: Lobe::Diffuse,
            p,
            k: material.kd,
        })
    }

    fn choose_mixed_lobe(
        &self,
        material: &Material,
        hit: &PreliminaryHit,
        sp: &SurfacePoint,
        cos_o: f32,
        xi: f32,
    ) -> Option<Scatter> {
        let kd = if material.texture.is_some() {
            self.scene.albedo(hit, sp)
        } else {
            material.kd
        };
        let (ks, kt) = if material.dielectric {
            let eta = if cos_o > 0.0 {
                material.ior
            } else {
                1.0 / material.ior
            };
            let f = fresnel_dielectric(cos_o.abs(), eta);
            (material.kt * f, material.kt * (1.0 - f))
        } else {
            (material.ks, material.kt)
        };
        let (wd, ws, wt) = (kd.max_element(), ks.max_element(), kt.max_element());
        let sum = wd + ws + wt;
        let scale = self.lobe_scale(sum)?;
        let (lobe, p, k) = if xi < wd * scale {
            (Lobe::Diffuse, wd * scale, kd)
        } else if xi < (wd + ws) * scale {
            (Lobe::Mirror, ws * scale, ks)
        } else if xi < sum * scale {
            (Lobe::Refraction, wt * scale, kt)
        } else {
            return None;
        };
        Some(Scatter { lobe, p, k })
    }

    /// Factor from lobe weights summing to `sum` to probabilities:
    /// normalised when they exceed one or when Russian roulette is off,
    /// otherwise the rest is absorption. `None` when nothing scatters.
    #[inline]
    fn lobe_scale(&self, sum: f32) -> Option<f32> {
        if sum.is_nan() || sum <= 0.0 {
            return None;
        }
        Some(if sum > 1.0 || !self.settings.russian_roulette {
            1.0 / sum
        } else {
            1.0
        })
    }
}
