//! Deterministic random numbers (independent streams, and Owen-scrambled
//! Sobol' points in `sobol`), the sampler that hands them to the integrator
//! by dimension (`sampler`), and the warps from the unit square to the
//! directions and points the integrator samples.

pub mod sampler;
pub mod sobol;

pub use sampler::{Dimension, Sampler, SamplerKind};

use crate::math::{sin_cos_octant, sin_cos_turns, Vec2, Vec3};
use std::f32::consts::{FRAC_PI_4, PI};

/// PCG32 (O'Neill 2014): small state, good statistics, cheap.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

#[inline]
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Rng {
    const MULT: u64 = 0x5851_f42d_4c95_7f2d;

    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The stream of sample `sample` of pixel `(x, y)`: a pure function of
    /// its arguments, so an image does not depend on scheduling.
    pub fn for_sample(seed: u64, x: u32, y: u32, sample: u32) -> Self {
        let pixel = ((y as u64) << 32) | x as u64;
        let key = splitmix64(seed ^ splitmix64(pixel));
        Rng::new(splitmix64(key ^ sample as u64), key)
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

/// Shirley–Chiu concentric map from the square to the unit disk.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // θ = π/4 · y/x, or π/2 − π/4 · x/y, whose cosine and sine are the
    // sine and cosine of π/4 · x/y: both within one octant.
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_octant(FRAC_PI_4 * (o.y / o.x));
        o.x * Vec2::new(cos, sin)
    } else {
        let (sin, cos) = sin_cos_octant(FRAC_PI_4 * (o.x / o.y));
        o.y * Vec2::new(sin, cos)
    }
}

/// Cosine-weighted direction around local +z; pdf = cos θ / π.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Uniform direction on the unit sphere; pdf = 1 / 4π.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction in the cone around local +z with `cos θ ≥ cos_max`;
/// pdf = 1 / (2π (1 − cos_max)).
#[inline]
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = (1.0 - u.x) + u.x * cos_max;
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(u.y);
    Vec3::new(sin_t * cos_phi, sin_t * sin_phi, cos_t)
}

#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentrics `(b1, b2)` on a triangle (Heitz 2019, low distortion).
#[inline]
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    Vec2::new(b1, 1.0 - b0 - b1)
}

/// Power heuristic with β = 2 (Veach 1997).
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a.is_infinite() {
        return 1.0;
    }
    if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

/// A discrete distribution over `n` items with given non-negative weights.
#[derive(Clone, Debug, Default)]
pub struct Discrete {
    cdf: Vec<f32>,
    total: f64,
}

impl Discrete {
    /// `None` when no weight is positive.
    pub fn new(weights: impl IntoIterator<Item = f32>) -> Option<Self> {
        let mut acc = 0.0f64;
        let mut sums = Vec::new();
        for w in weights {
            acc += w.max(0.0) as f64;
            sums.push(acc);
        }
        if !(acc.is_finite() && acc > 0.0) {
            return None;
        }
        let cdf = sums.iter().map(|&s| (s / acc) as f32).collect();
        Some(Self { cdf, total: acc })
    }

    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    pub fn total(&self) -> f64 {
        self.total
    }

    /// Picks an index for `u` in [0,1); returns it with its probability.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        (i, self.pmf(i))
    }

    /// Like `sample`, and also returns `u` rescaled to [0,1) within the
    /// chosen item, so one random number serves two decisions.
    #[inline]
    pub fn sample_reuse(&self, u: f32) -> (usize, f32, f32) {
        let (i, p) = self.sample(u);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let rest = ((u - lo) / p).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        (i, p, rest)
    }

    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - lo
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_their_key() {
        let mut a = Rng::for_sample(7, 3, 4, 5);
        let mut b = Rng::for_sample(7, 3, 4, 5);
        let mut c = Rng::for_sample(7, 3, 4, 6);
        let va: Vec<u32> = (0..8).map(|_| a.next_u32()).collect();
        let vb: Vec<u32> = (0..8).map(|_| b.next_u32()).collect();
        let vc: Vec<u32> = (0..8).map(|_| c.next_u32()).collect();
        assert_eq!(va, vb);
        assert_ne!(va, vc);
    }

    #[test]
    fn uniform_floats_have_the_right_mean_and_range() {
        let mut r = Rng::new(1, 2);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        // Standard error of the mean is 1/sqrt(12 n) ≈ 9e-4; 5 sigma.
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * 9.2e-4);
    }

    #[test]
    fn cosine_hemisphere_has_mean_cosine_two_thirds() {
        let mut r = Rng::new(3, 4);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = cosine_hemisphere(r.next_2d());
            assert!((d.length() - 1.0).abs() < 1e-5 && d.z >= 0.0);
            sum += d.z as f64;
        }
        // E[cos] = 2/3, Var = 1/2 - 4/9 = 1/18; 5 sigma.
        let se = (1.0f64 / 18.0 / n as f64).sqrt();
        assert!((sum / n as f64 - 2.0 / 3.0).abs() < 5.0 * se);
    }

    #[test]
    fn cone_samples_stay_in_the_cone() {
        let mut r = Rng::new(5, 6);
        for _ in 0..10_000 {
            let d = uniform_cone(r.next_2d(), 0.9);
            assert!(d.z >= 0.9 - 1e-6);
        }
    }

    #[test]
    fn triangle_barycentrics_are_inside() {
        let mut r = Rng::new(9, 9);
        for _ in 0..10_000 {
            let b = uniform_triangle(r.next_2d());
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }

    #[test]
    fn discrete_distribution_matches_weights() {
        let d = Discrete::new([1.0, 0.0, 3.0]).unwrap();
        assert_eq!(d.sample(0.0).0, 0);
        assert_eq!(d.sample(0.24).0, 0);
        assert_eq!(d.sample(0.26).0, 2);
        assert_eq!(d.sample(0.9999).0, 2);
        assert!((d.pmf(2) - 0.75).abs() < 1e-6);
        assert_eq!(d.pmf(1), 0.0);
        assert!(Discrete::new([0.0, 0.0]).is_none());
        assert!(Discrete::new([f32::NAN]).is_none());
    }
}
