//! 4-wide float vector: SSE on x86_64 (always available there), plain arrays
//! elsewhere. `min`/`max` return the *second* operand when either is NaN,
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
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    #[derive(Clone, Copy)]
    pub struct F4([f32; 4]);

    #[derive(Clone, Copy)]
    pub struct M4([bool; 4]);

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
    }
}

pub use imp::F4;
