//! [`F4`]: four f32 lanes, an SSE register on x86-64 and a plain array elsewhere.

// Why unsafe code is allowed in this file: the SSE intrinsics are `unsafe` functions; SSE and
// SSE2 are always present on x86-64, and `_mm_loadu_ps`/`_mm_storeu_ps` read and write through
// references to `[f32; 4]`, valid for 16 bytes.
#![allow(unsafe_code)]

#[cfg(target_arch = "x86_64")]
pub(crate) use sse::F4;

#[cfg(not(target_arch = "x86_64"))]
pub(crate) use portable::F4;

#[cfg(target_arch = "x86_64")]
mod sse {
    use std::arch::x86_64::*;

    /// Four f32 lanes in an SSE register.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct F4(__m128);

    // SAFETY (every block below): SSE and SSE2 are enabled on every x86-64 CPU; loads and
    // stores go through references to `[f32; 4]`.
    impl F4 {
        #[inline(always)]
        pub(crate) fn splat(x: f32) -> F4 {
            F4(unsafe { _mm_set1_ps(x) })
        }

        #[inline(always)]
        pub(crate) fn load(a: &[f32; 4]) -> F4 {
            F4(unsafe { _mm_loadu_ps(a.as_ptr()) })
        }

        #[inline(always)]
        pub(crate) fn to_array(self) -> [f32; 4] {
            let mut a = [0f32; 4];
            unsafe { _mm_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }

        #[inline(always)]
        pub(crate) fn add(self, o: F4) -> F4 {
            F4(unsafe { _mm_add_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub(crate) fn sub(self, o: F4) -> F4 {
            F4(unsafe { _mm_sub_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub(crate) fn mul(self, o: F4) -> F4 {
            F4(unsafe { _mm_mul_ps(self.0, o.0) })
        }

        #[inline(always)]
        pub(crate) fn div(self, o: F4) -> F4 {
            F4(unsafe { _mm_div_ps(self.0, o.0) })
        }

        /// Per lane `if self > o { self } else { o }`: a NaN in either keeps `o`.
        #[inline(always)]
        pub(crate) fn max_keep(self, o: F4) -> F4 {
            F4(unsafe { _mm_max_ps(self.0, o.0) })
        }

        /// Per lane `if self < o { self } else { o }`: a NaN in either keeps `o`.
        #[inline(always)]
        pub(crate) fn min_keep(self, o: F4) -> F4 {
            F4(unsafe { _mm_min_ps(self.0, o.0) })
        }

        /// Bit i set where `self[i] <= o[i]`.
        #[inline(always)]
        pub(crate) fn le(self, o: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmple_ps(self.0, o.0)) as u32 }
        }

        /// Bit i set where `self[i] < o[i]`.
        #[inline(always)]
        pub(crate) fn lt(self, o: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmplt_ps(self.0, o.0)) as u32 }
        }

        /// Bit i set where `self[i] > o[i]`.
        #[inline(always)]
        pub(crate) fn gt(self, o: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmpgt_ps(self.0, o.0)) as u32 }
        }

        /// Bit i set where `self[i] == o[i]`.
        #[inline(always)]
        pub(crate) fn eq(self, o: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmpeq_ps(self.0, o.0)) as u32 }
        }

        /// Bit i set where `self[i] != o[i]` (true for NaN, as `!=` is).
        #[inline(always)]
        pub(crate) fn ne(self, o: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmpneq_ps(self.0, o.0)) as u32 }
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod portable {
    /// Four f32 lanes.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct F4([f32; 4]);

    impl F4 {
        #[inline(always)]
        fn map(self, o: F4, f: impl Fn(f32, f32) -> f32) -> F4 {
            F4(std::array::from_fn(|i| f(self.0[i], o.0[i])))
        }

        #[inline(always)]
        fn bits(self, o: F4, f: impl Fn(f32, f32) -> bool) -> u32 {
            (0..4).fold(0, |m, i| m | (f(self.0[i], o.0[i]) as u32) << i)
        }

        pub(crate) fn splat(x: f32) -> F4 {
            F4([x; 4])
        }
        pub(crate) fn load(a: &[f32; 4]) -> F4 {
            F4(*a)
        }
        pub(crate) fn to_array(self) -> [f32; 4] {
            self.0
        }
        pub(crate) fn add(self, o: F4) -> F4 {
            self.map(o, |a, b| a + b)
        }
        pub(crate) fn sub(self, o: F4) -> F4 {
            self.map(o, |a, b| a - b)
        }
        pub(crate) fn mul(self, o: F4) -> F4 {
            self.map(o, |a, b| a * b)
        }
        pub(crate) fn div(self, o: F4) -> F4 {
            self.map(o, |a, b| a / b)
        }
        pub(crate) fn max_keep(self, o: F4) -> F4 {
            self.map(o, |a, b| if a > b { a } else { b })
        }
        pub(crate) fn min_keep(self, o: F4) -> F4 {
            self.map(o, |a, b| if a < b { a } else { b })
        }
        pub(crate) fn le(self, o: F4) -> u32 {
            self.bits(o, |a, b| a <= b)
        }
        pub(crate) fn lt(self, o: F4) -> u32 {
            self.bits(o, |a, b| a < b)
        }
        pub(crate) fn gt(self, o: F4) -> u32 {
            self.bits(o, |a, b| a > b)
        }
        pub(crate) fn eq(self, o: F4) -> u32 {
            self.bits(o, |a, b| a == b)
        }
        pub(crate) fn ne(self, o: F4) -> u32 {
            self.bits(o, |a, b| a != b)
        }
    }
}
