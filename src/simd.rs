//! Float vectors. `F4`, four lanes: SSE on x86_64 (always available there),
//! plain arrays elsewhere. `F8`, eight lanes of AVX, for kernels compiled
//! for AVX and chosen at run time (`has_avx`); `Lanes` lets one packed test
//! serve both widths.
//!
//! `F4`: `min`/`max` return the *second* operand when either is NaN,
//! exactly like `minps`/`maxps`; traversal relies on that to drop NaN.
//! Comparisons give lane masks (`M4`); `bits` packs them into an integer.
//! Every operation is one IEEE single-precision operation per lane, so code
//! written with `F4` gives bit for bit what the same scalar code gives.

#[cfg(target_arch = "x86_64")]
#[allow(unused_unsafe)]
mod imp {
    use std::arch::x86_64::*;

    #[derive(Clone, Copy)]
    pub struct F4(__m128);

    #[derive(Clone, Copy)]
    pub struct M4(__m128);

    /// The vector's register as it is: its fourth lane is unspecified.
    impl From<crate::math::Vec3> for F4 {
        #[inline(always)]
        fn from(v: crate::math::Vec3) -> F4 {
            F4(v.into())
        }
    }

    /// The first three lanes.
    impl From<F4> for crate::math::Vec3 {
        #[inline(always)]
        fn from(v: F4) -> crate::math::Vec3 {
            v.0.into()
        }
    }

    macro_rules! binop {
        ($name:ident, $intr:ident) => {
            #[inline(always)]
            pub fn $name(self, o: F4) -> F4 {
                unsafe { F4($intr(self.0, o.0)) }
            }
        };
    }
    macro_rules! cmpop {
        ($name:ident, $intr:ident) => {
            #[inline(always)]
            pub fn $name(self, o: F4) -> M4 {
                unsafe { M4($intr(self.0, o.0)) }
            }
        };
    }

    impl F4 {
        #[inline(always)]
        pub fn splat(v: f32) -> F4 {
            unsafe { F4(_mm_set1_ps(v)) }
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            // SAFETY: reads exactly the four floats of `a`.
            unsafe { F4(_mm_loadu_ps(a.as_ptr())) }
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            let mut out = [0.0; 4];
            // SAFETY: writes exactly the four floats of `out`.
            unsafe { _mm_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }
        binop!(add, _mm_add_ps);
        binop!(sub, _mm_sub_ps);
        binop!(mul, _mm_mul_ps);
        binop!(div, _mm_div_ps);
        // `self < o ? self : o`
        binop!(min, _mm_min_ps);
        // `self > o ? self : o`
        binop!(max, _mm_max_ps);
        cmpop!(lt, _mm_cmplt_ps);
        cmpop!(le, _mm_cmple_ps);
        cmpop!(gt, _mm_cmpgt_ps);
        cmpop!(ge, _mm_cmpge_ps);
        cmpop!(ne, _mm_cmpneq_ps);
        cmpop!(eq, _mm_cmpeq_ps);
        #[inline(always)]
        pub fn abs(self) -> F4 {
            unsafe { F4(_mm_andnot_ps(_mm_set1_ps(-0.0), self.0)) }
        }
        /// Bit `k` set where `self[k] <= o[k]`.
        #[inline(always)]
        pub fn le_mask(self, o: F4) -> u32 {
            self.le(o).bits()
        }
        /// Each lane truncated towards zero, for lanes already within
        /// `0..=i32::MAX` (others are `i32::MIN`, as `cvttps2dq` gives).
        #[inline(always)]
        pub fn truncate_in_range(self) -> [i32; 4] {
            let mut out = [0i32; 4];
            // SAFETY: writes exactly the four integers of `out`.
            unsafe { _mm_storeu_si128(out.as_mut_ptr().cast(), _mm_cvttps_epi32(self.0)) };
            out
        }
    }

    impl M4 {
        #[inline(always)]
        pub fn and(self, o: M4) -> M4 {
            unsafe { M4(_mm_and_ps(self.0, o.0)) }
        }
        #[inline(always)]
        pub fn bits(self) -> u32 {
            unsafe { _mm_movemask_ps(self.0) as u32 }
        }
        /// `a` in the lanes set, `b` in the others.
        #[inline(always)]
        pub fn select(self, a: F4, b: F4) -> F4 {
            unsafe {
                F4(_mm_or_ps(
                    _mm_and_ps(self.0, a.0),
                    _mm_andnot_ps(self.0, b.0),
                ))
            }
        }
    }

    impl F4 {
        /// Each lane moved one float in the direction of `off`'s sign:
        /// pbrt-v4's `NextFloatUp` for `off > 0`, `NextFloatDown` for
        /// `off < 0`, the lane itself for a zero or NaN `off`. Branch-free,
        /// on the bits: a step away from zero adds one to them, a step
        /// towards zero takes one away, zero first takes `off`'s sign, and
        /// an infinity does not grow. Tested in `math`.
        #[inline(always)]
        pub fn step_towards(self, off: F4) -> F4 {
            unsafe {
                let zero_ps = _mm_setzero_ps();
                let moves = _mm_castps_si128(_mm_or_ps(
                    _mm_cmpgt_ps(off.0, zero_ps),
                    _mm_cmplt_ps(off.0, zero_ps),
                ));
                let sign = _mm_set1_epi32(i32::MIN);
                let bits = _mm_castps_si128(self.0);
                let off_sign = _mm_and_si128(_mm_castps_si128(off.0), sign);
                let magnitude = _mm_andnot_si128(sign, bits);
                let zero = _mm_and_si128(moves, _mm_cmpeq_epi32(magnitude, _mm_setzero_si128()));
                let bits =
                    _mm_or_si128(_mm_and_si128(zero, off_sign), _mm_andnot_si128(zero, bits));
                let away = _mm_cmpeq_epi32(_mm_and_si128(bits, sign), off_sign);
                let infinite =
                    _mm_cmpeq_epi32(magnitude, _mm_set1_epi32(f32::INFINITY.to_bits() as i32));
                // -1 (all ones) towards zero, +1 away from it, 0 for an
                // infinity away from zero.
                let grow = _mm_and_si128(_mm_andnot_si128(infinite, away), _mm_set1_epi32(1));
                let step = _mm_or_si128(_mm_andnot_si128(away, _mm_set1_epi32(-1)), grow);
                let step = _mm_and_si128(moves, step);
                F4(_mm_castsi128_ps(_mm_add_epi32(bits, step)))
            }
        }
        /// The largest lane, for lanes without NaN.
        #[inline(always)]
        pub fn max_lane(self) -> f32 {
            unsafe {
                let pairs = _mm_max_ps(self.0, _mm_movehl_ps(self.0, self.0));
                _mm_cvtss_f32(_mm_max_ss(pairs, _mm_shuffle_ps(pairs, pairs, 1)))
            }
        }
        /// The smallest lane, for lanes without NaN.
        #[inline(always)]
        pub fn min_lane(self) -> f32 {
            unsafe {
                let pairs = _mm_min_ps(self.0, _mm_movehl_ps(self.0, self.0));
                _mm_cvtss_f32(_mm_min_ss(pairs, _mm_shuffle_ps(pairs, pairs, 1)))
            }
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    #[derive(Clone, Copy)]
    pub struct F4([f32; 4]);

    #[derive(Clone, Copy)]
    pub struct M4([bool; 4]);

    /// The fourth lane is unspecified (zero here).
    impl From<crate::math::Vec3> for F4 {
        #[inline(always)]
        fn from(v: crate::math::Vec3) -> F4 {
            F4([v.x, v.y, v.z, 0.0])
        }
    }

    /// The first three lanes.
    impl From<F4> for crate::math::Vec3 {
        #[inline(always)]
        fn from(v: F4) -> crate::math::Vec3 {
            crate::math::Vec3::new(v.0[0], v.0[1], v.0[2])
        }
    }

    macro_rules! binop {
        ($name:ident, $f:expr) => {
            #[inline(always)]
            pub fn $name(self, o: F4) -> F4 {
                F4(std::array::from_fn(|k| $f(self.0[k], o.0[k])))
            }
        };
    }
    macro_rules! cmpop {
        ($name:ident, $f:expr) => {
            #[inline(always)]
            pub fn $name(self, o: F4) -> M4 {
                M4(std::array::from_fn(|k| $f(self.0[k], o.0[k])))
            }
        };
    }

    impl F4 {
        #[inline(always)]
        pub fn splat(v: f32) -> F4 {
            F4([v; 4])
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            F4(*a)
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }
        binop!(add, |a: f32, b: f32| a + b);
        binop!(sub, |a: f32, b: f32| a - b);
        binop!(mul, |a: f32, b: f32| a * b);
        /// Each lane truncated towards zero, for lanes already within
        /// `0..=i32::MAX`.
        #[inline(always)]
        pub fn truncate_in_range(self) -> [i32; 4] {
            self.0.map(|v| v as i32)
        }
        binop!(div, |a: f32, b: f32| a / b);
        binop!(min, |a: f32, b: f32| if a < b { a } else { b });
        binop!(max, |a: f32, b: f32| if a > b { a } else { b });
        cmpop!(lt, |a: f32, b: f32| a < b);
        cmpop!(le, |a: f32, b: f32| a <= b);
        cmpop!(gt, |a: f32, b: f32| a > b);
        cmpop!(ge, |a: f32, b: f32| a >= b);
        cmpop!(ne, |a: f32, b: f32| a != b);
        cmpop!(eq, |a: f32, b: f32| a == b);
        #[inline(always)]
        pub fn abs(self) -> F4 {
            F4(self.0.map(f32::abs))
        }
        #[inline(always)]
        pub fn le_mask(self, o: F4) -> u32 {
            self.le(o).bits()
        }
    }

    impl M4 {
        #[inline(always)]
        pub fn and(self, o: M4) -> M4 {
            M4(std::array::from_fn(|k| self.0[k] && o.0[k]))
        }
        #[inline(always)]
        pub fn bits(self) -> u32 {
            (0..4).fold(0, |m, k| m | ((self.0[k] as u32) << k))
        }
        /// `a` in the lanes set, `b` in the others.
        #[inline(always)]
        pub fn select(self, a: F4, b: F4) -> F4 {
            F4(std::array::from_fn(
                |k| if self.0[k] { a.0[k] } else { b.0[k] },
            ))
        }
    }

    impl F4 {
        /// Each lane moved one float in the direction of `off`'s sign, as
        /// the x86_64 `step_towards` (its doc).
        #[inline(always)]
        pub fn step_towards(self, off: F4) -> F4 {
            F4(std::array::from_fn(|k| step_towards(self.0[k], off.0[k])))
        }
        /// The largest lane, for lanes without NaN.
        #[inline(always)]
        pub fn max_lane(self) -> f32 {
            self.0.into_iter().fold(f32::NEG_INFINITY, f32::max)
        }
        /// The smallest lane, for lanes without NaN.
        #[inline(always)]
        pub fn min_lane(self) -> f32 {
            self.0.into_iter().fold(f32::INFINITY, f32::min)
        }
    }

    /// One lane of `F4::step_towards`.
    #[inline(always)]
    fn step_towards(v: f32, off: f32) -> f32 {
        const SIGN: u32 = 0x8000_0000;
        let off_sign = off.to_bits() & SIGN;
        let bits = v.to_bits();
        let bits = if bits & !SIGN == 0 { off_sign } else { bits };
        let away = bits & SIGN == off_sign;
        let step: u32 = if !away {
            u32::MAX
        } else if bits & !SIGN == f32::INFINITY.to_bits() {
            0
        } else {
            1
        };
        let moves = (off > 0.0) | (off < 0.0);
        if moves {
            f32::from_bits(bits.wrapping_add(step))
        } else {
            v
        }
    }
}

pub use imp::{F4, M4};

/// What packed shape tests need of a vector of lanes, so that one test
/// serves SSE's four lanes and AVX's eight. Every operation is one IEEE
/// single-precision operation per lane, so both widths compute the very
/// values of the same scalar code.
pub trait Lanes: Copy {
    const N: usize;
    type Mask: Copy;
    fn splat(v: f32) -> Self;
    /// The first `N` floats of `a`.
    fn load(a: &[f32]) -> Self;
    /// Into the first `N` floats of `out`.
    fn store(self, out: &mut [f32]);
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn lt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// Bit `k` set where lane `k` of `m` is.
    fn bits(m: Self::Mask) -> u32;
}

impl Lanes for F4 {
    const N: usize = 4;
    type Mask = M4;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        F4::splat(v)
    }
    #[inline(always)]
    fn load(a: &[f32]) -> Self {
        F4::load(a[..4].try_into().expect("four floats"))
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        out[..4].copy_from_slice(&self.to_array());
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        F4::add(self, o)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        F4::sub(self, o)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        F4::mul(self, o)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        F4::div(self, o)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> M4 {
        F4::lt(self, o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> M4 {
        F4::le(self, o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> M4 {
        F4::gt(self, o)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> M4 {
        F4::ge(self, o)
    }
    #[inline(always)]
    fn and(a: M4, b: M4) -> M4 {
        a.and(b)
    }
    #[inline(always)]
    fn bits(m: M4) -> u32 {
        m.bits()
    }
}

/// Whether this CPU runs AVX (`F8`). std caches the detection, so a call
/// costs a load and a test.
#[inline(always)]
pub fn has_avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx::F8;

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::Lanes;
    use std::arch::x86_64::*;

    /// Eight lanes of AVX. Its operations are AVX intrinsics inlined into
    /// their caller: an `F8` may exist only inside a function compiled with
    /// `#[target_feature(enable = "avx")]` and called after `has_avx()`,
    /// where they become single instructions (elsewhere they would not be
    /// inlined, and on a CPU without AVX they would fault).
    #[derive(Clone, Copy)]
    pub struct F8(__m256);

    #[derive(Clone, Copy)]
    pub struct M8(__m256);

    macro_rules! binop {
        ($name:ident, $intr:ident) => {
            #[inline(always)]
            fn $name(self, o: F8) -> F8 {
                // SAFETY: see the type's invariant.
                unsafe { F8($intr(self.0, o.0)) }
            }
        };
    }
    macro_rules! cmpop {
        ($name:ident, $pred:ident) => {
            #[inline(always)]
            fn $name(self, o: F8) -> M8 {
                // SAFETY: see the type's invariant.
                unsafe { M8(_mm256_cmp_ps::<$pred>(self.0, o.0)) }
            }
        };
    }

    impl Lanes for F8 {
        const N: usize = 8;
        type Mask = M8;
        #[inline(always)]
        fn splat(v: f32) -> F8 {
            // SAFETY: see the type's invariant.
            unsafe { F8(_mm256_set1_ps(v)) }
        }
        #[inline(always)]
        fn load(a: &[f32]) -> F8 {
            let a = &a[..8];
            // SAFETY: reads the eight floats of `a`; AVX as above.
            unsafe { F8(_mm256_loadu_ps(a.as_ptr())) }
        }
        #[inline(always)]
        fn store(self, out: &mut [f32]) {
            let out = &mut out[..8];
            // SAFETY: writes the eight floats of `out`; AVX as above.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) }
        }
        binop!(add, _mm256_add_ps);
        binop!(sub, _mm256_sub_ps);
        binop!(mul, _mm256_mul_ps);
        binop!(div, _mm256_div_ps);
        // Ordered, non-signalling: false on NaN, as SSE's comparisons.
        cmpop!(lt, _CMP_LT_OQ);
        cmpop!(le, _CMP_LE_OQ);
        cmpop!(gt, _CMP_GT_OQ);
        cmpop!(ge, _CMP_GE_OQ);
        #[inline(always)]
        fn and(a: M8, b: M8) -> M8 {
            // SAFETY: see the type's invariant.
            unsafe { M8(_mm256_and_ps(a.0, b.0)) }
        }
        #[inline(always)]
        fn bits(m: M8) -> u32 {
            // SAFETY: see the type's invariant.
            unsafe { _mm256_movemask_ps(m.0) as u32 }
        }
    }
}
