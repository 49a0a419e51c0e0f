//! Vector types, rays, bounding boxes, orthonormal frames and the
//! floating-point error bounds that keep secondary rays off the surface they
//! leave (pbrt-v4, "Managing Rounding Error").

pub use glam::{Mat3, Mat4, Quat, Vec2};

use crate::simd::F4;

/// Three floats held in one 16-byte SIMD register (`glam::Vec3A`): what
/// the render loop computes with, one instruction per operation on x86_64
/// where a 12-byte vector takes three and the shuffles to gather them.
/// Arrays of many points (meshes) store [`PackedVec3`] instead.
pub type Vec3 = glam::Vec3A;

/// Three floats in 12 bytes (`glam::Vec3`): the storage of large arrays
/// (mesh vertices and normals, the layout Embree shares), converted to
/// [`Vec3`] where read.
pub type PackedVec3 = glam::Vec3;

/// Linear RGB colour (Rec.709 primaries).
pub type Rgb = Vec3;

/// A ray `origin + t * dir` valid for `t` in the open interval `(t_min, t_max)`.
///
/// `dir` need not be normalised; every backend reports `t` in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    pub fn segment(origin: Vec3, dir: Vec3, t_max: f32) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max,
        }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// Axis-aligned bounding box. The empty box has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    pub fn from_points<P: Copy + Into<Vec3>>(points: &[P]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p.into()))
    }

    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    #[inline]
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// Half the surface area (the SAH only needs ratios).
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Orthonormal frame with `n` as local +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Branchless construction of Duff et al., "Building an Orthonormal
    /// Basis, Revisited" (JCGT 2017). `n` must be normalised.
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.s + v.y * self.t + v.z * self.n
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

/// Higham's bound `n·u / (1 − n·u)` on the relative error of `n` chained
/// f32 operations (pbrt-v4 `gamma`).
#[inline]
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// Origin for a ray leaving a surface point `p` (with absolute error bound
/// `p_err` per axis) in direction `w`: pushed along the geometric normal `n`
/// just past the error box, on the side `w` points to, then rounded away
/// from `p` (pbrt-v4 `OffsetRayOrigin`). Every shape, on every backend,
/// spawns its secondary rays through this one function. Always inlined:
/// rustc outlined it once the integrator grew, at 1.2% of the instructions
/// per sample on cornell-area.
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_err);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    F4::from(po).step_towards(F4::from(offset)).into()
}

/// How far from 1 a squared length may be for `near_unit` to leave the
/// vector as it is: 2^-20, eight roundings of a unit vector's length.
const NEAR_UNIT: f32 = 1.0 / (1 << 20) as f32;

/// `v` at unit length: as it is when its length is within a few roundings
/// of 1, as sampled directions are, else normalised. Skipping a square
/// root and a division per bounce saved about 4% of cornell-area's time
/// (docs/performance.md, 2026-12-08).
#[inline]
pub fn near_unit(v: Vec3) -> Vec3 {
    let length_squared = v.length_squared();
    if (length_squared - 1.0).abs() <= NEAR_UNIT {
        v
    } else {
        v / length_squared.sqrt()
    }
}

/// Ray from a surface point towards direction `w`.
#[inline]
pub fn spawn_ray(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, p_err, n, w), w)
}

/// Shadow ray from a surface point to a point `to` (itself on a surface with
/// error `to_err` and normal `to_n`), stopping just short of it.
#[inline]
pub fn spawn_ray_to(p: Vec3, p_err: Vec3, n: Vec3, to: Vec3, to_err: Vec3, to_n: Vec3) -> Ray {
    let from = offset_ray_origin(p, p_err, n, to - p);
    let to = offset_ray_origin(to, to_err, to_n, from - to);
    const SHADOW_EPSILON: f32 = 1.0 - 1e-4;
    Ray::segment(from, to - from, SHADOW_EPSILON)
}

/// Reflection of `wo` (pointing away from the surface) about `n`.
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Refraction of `wo` (pointing away from the surface, on the side `n`
/// points to) into the medium below, with `eta` = η_below / η_above.
/// `None` on total internal reflection.
#[inline]
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(n);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / eta + (cos_i / eta - cos_t) * n)
}

/// Unpolarised Fresnel reflectance of a dielectric interface for light
/// arriving with cosine `cos_i` (> 0, on the side of the normal) and
/// `eta` = η_transmitted / η_incident.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// `(sin x, cos x)` for |x| ≤ π/4, by the minimax polynomials of Cephes'
/// `sinf` and `cosf`: a few multiplies instead of libm's `sincosf` with its
/// general range reduction. Largest absolute error over the range, against
/// f64: 4.6e-8 for sin, 6.0e-8 (half an ulp of 1) for cos, asserted by a
/// dense sweep in the tests.
#[inline]
pub fn sin_cos_octant(x: f32) -> (f32, f32) {
    let z = x * x;
    let sin = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x;
    let cos = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    (sin, cos)
}

/// `(sin 2πt, cos 2πt)` for `t` in [0, 1): reduced to an octant exactly
/// (whole quarter turns are subtracted in turns, not radians); the rounding
/// of the octant's angle in radians brings the largest absolute error to
/// 9.0e-8, asserted by a dense sweep in the tests.
#[inline]
pub fn sin_cos_turns(t: f32) -> (f32, f32) {
    let quarter = (4.0 * t + 0.5) as u32;
    let (sin, cos) = sin_cos_octant((t - 0.25 * quarter as f32) * std::f32::consts::TAU);
    match quarter & 3 {
        0 => (sin, cos),
        1 => (cos, -sin),
        2 => (-sin, -cos),
        _ => (-cos, sin),
    }
}

/// Rec.709 luminance.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the integrator relies on: a cosine-sampled direction turned to
    /// the world by a shading frame is left as it is (it is unit to within
    /// `NEAR_UNIT`), and whatever `near_unit` returns is unit to within it.
    #[test]
    fn sampled_directions_are_near_unit_and_others_are_normalised() {
        use crate::sampling::{cosine_hemisphere, uniform_sphere, Rng};
        let mut rng = Rng::new(7, 0);
        let mut kept = 0;
        const N: usize = 100_000;
        for _ in 0..N {
            let frame = Frame::from_normal(uniform_sphere(rng.next_2d()));
            let w = frame.to_world(cosine_hemisphere(rng.next_2d()));
            let unit = near_unit(w);
            kept += usize::from(unit == w);
            assert!(
                (unit.length_squared() - 1.0).abs() <= NEAR_UNIT,
                "{w} -> {unit}"
            );
        }
        // 0 of 184,226 directions needed normalising in a bunny render.
        assert!(kept >= N - N / 1000, "{kept} of {N} left as they were");
        let long = Vec3::new(3.0, -4.0, 12.0);
        assert_eq!(near_unit(long), long / 13.0);
        let tiny = Vec3::new(1e-10, 0.0, 0.0);
        assert_eq!(near_unit(tiny), Vec3::X);
        assert!(near_unit(Vec3::ZERO).is_nan());
    }

    #[test]
    fn frame_is_orthonormal_for_every_octant_and_poles() {
        let normals = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(1.0, -2.0, 3.0).normalize(),
            Vec3::new(-1e-7, 1e-7, -1.0).normalize(),
        ];
        for n in normals {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5, "{n}");
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5);
            assert!(f.s.dot(n).abs() < 1e-5);
            let v = Vec3::new(0.3, -0.4, 0.5);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn offset_origin_leaves_the_error_box_on_the_side_of_w() {
        for scale in [1e-4f32, 1.0, 1e4, 1e6] {
            let p = Vec3::new(scale, -scale, 0.5 * scale);
            let err = p.abs() * gamma(7);
            let n = Vec3::new(0.0, 1.0, 0.0);
            let up = offset_ray_origin(p, err, n, Vec3::new(0.1, 1.0, 0.0));
            let down = offset_ray_origin(p, err, n, Vec3::new(0.1, -1.0, 0.0));
            assert!(up.y > p.y + err.y * 0.999, "scale {scale}");
            assert!(down.y < p.y - err.y * 0.999, "scale {scale}");
        }
    }

    /// Dense sweeps of both ranges against f64, asserting the bounds stated
    /// in the doc comments.
    #[test]
    fn polynomial_sin_cos_stay_within_their_stated_error() {
        let steps = 1 << 20;
        let (mut sin_err, mut cos_err) = (0.0f64, 0.0f64);
        for i in 0..=steps {
            let x = std::f32::consts::FRAC_PI_4 * (2.0 * i as f32 / steps as f32 - 1.0);
            let (s, c) = sin_cos_octant(x);
            sin_err = sin_err.max((s as f64 - (x as f64).sin()).abs());
            cos_err = cos_err.max((c as f64 - (x as f64).cos()).abs());
        }
        assert!(
            sin_err <= 4.6e-8 && cos_err <= 6.0e-8,
            "{sin_err:e} {cos_err:e}"
        );
        let mut turn_err = 0.0f64;
        for i in 0..steps {
            let t = i as f32 / steps as f32;
            let (s, c) = sin_cos_turns(t);
            let a = std::f64::consts::TAU * t as f64;
            turn_err = turn_err.max((s as f64 - a.sin()).abs().max((c as f64 - a.cos()).abs()));
        }
        let t = 1.0 - f32::EPSILON / 2.0;
        let (s, c) = sin_cos_turns(t);
        let a = std::f64::consts::TAU * t as f64;
        turn_err = turn_err.max((s as f64 - a.sin()).abs().max((c as f64 - a.cos()).abs()));
        assert!(turn_err <= 9.0e-8, "{turn_err:e}");
    }

    #[test]
    fn fresnel_limits() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-4);
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
        // Inside glass beyond the critical angle: total internal reflection.
        assert_eq!(fresnel_dielectric(0.3, 1.0 / 1.5), 1.0);
        assert_eq!(fresnel_dielectric(1.0, 1.0), 0.0);
    }

    #[test]
    fn refraction_obeys_snell() {
        let wo = Vec3::new(0.6, 0.8, 0.0);
        let wt = refract(wo, Vec3::Y, 1.5).unwrap();
        let sin_i = 0.6;
        let sin_t = wt.x.abs() / wt.length();
        assert!((sin_i - 1.5 * sin_t).abs() < 1e-5);
        assert!(wt.y < 0.0);
        assert!(refract(Vec3::new(0.9, 0.2, 0.0).normalize(), Vec3::Y, 1.0 / 1.5).is_none());
    }

    /// pbrt-v4's `NextFloatUp` and `NextFloatDown`, the reference
    /// `F4::step_towards` is checked against.
    fn next_float_up(v: f32) -> f32 {
        if v.is_infinite() && v > 0.0 {
            return v;
        }
        let v = if v == -0.0 { 0.0 } else { v };
        let bits = v.to_bits();
        let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
        f32::from_bits(bits)
    }

    fn next_float_down(v: f32) -> f32 {
        if v.is_infinite() && v < 0.0 {
            return v;
        }
        let v = if v == 0.0 { -0.0 } else { v };
        let bits = v.to_bits();
        let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
        f32::from_bits(bits)
    }

    #[test]
    fn next_float_steps_across_zero() {
        assert!(next_float_up(0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
        assert!(next_float_up(-0.0) > 0.0);
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
    }

    #[test]
    fn the_branch_free_step_is_pbrts_next_float() {
        // Each number in every lane, as `offset_ray_origin` steps them.
        let step = |v: f32, off: f32| {
            let [a, b, c, d] = F4::splat(v).step_towards(F4::splat(off)).to_array();
            assert!([b, c, d].iter().all(|x| x.to_bits() == a.to_bits()));
            a
        };
        let mut values = vec![
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            -f32::from_bits(1),
            1.0,
            -1.0,
        ];
        let mut bits = 0x1234_5678u32;
        for _ in 0..100_000 {
            bits = bits.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
            let v = f32::from_bits(bits);
            if !v.is_nan() {
                values.push(v);
            }
        }
        for v in values {
            for off in [1e-3, -1e-3, f32::from_bits(1), -f32::INFINITY] {
                let want = if off > 0.0 {
                    next_float_up(v)
                } else {
                    next_float_down(v)
                };
                assert_eq!(
                    step(v, off).to_bits(),
                    want.to_bits(),
                    "{v:e} towards {off:e}"
                );
            }
            for off in [0.0, -0.0, f32::NAN] {
                assert_eq!(step(v, off).to_bits(), v.to_bits(), "{v:e} towards {off:e}");
            }
        }
        assert!(step(f32::NAN, 1.0).is_nan());
        assert!(step(-f32::NAN, -1.0).is_nan());
    }
}
