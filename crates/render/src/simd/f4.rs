//! [`F4`]: four f32 lanes, an SSE register on x86-64 and a plain array elsewhere.

// Why unsafe code is allowed in this file: the SSE intrinsics are `unsafe` functions; SSE and
// SSE2 are always present on x86-64, and `_mm_loadu_ps`/`_mm_storeu_ps` read and write through
// references to `[f32; 4]`, `_mm_storeu_si128` through a reference to `[i32; 4]`, each valid
// for 16 bytes (unaligned accesses).
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
    // stores go through references to `[f32; 4]` (and `[i32; 4]`), 16 bytes each.
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

        /// Per lane square root (correctly rounded, as `f32::sqrt`).
        #[inline(always)]
        pub(crate) fn sqrt(self) -> F4 {
            F4(unsafe { _mm_sqrt_ps(self.0) })
        }

        /// Lanes of `a` where `mask` (a comparison result) is set, of `b` elsewhere.
        #[inline(always)]
        pub(crate) fn select(mask: F4, a: F4, b: F4) -> F4 {
            F4(unsafe { _mm_or_ps(_mm_and_ps(mask.0, a.0), _mm_andnot_ps(mask.0, b.0)) })
        }

        /// All bits set where `self[i] > o[i]`.
        #[inline(always)]
        pub(crate) fn gt_mask(self, o: F4) -> F4 {
            F4(unsafe { _mm_cmpgt_ps(self.0, o.0) })
        }

        /// All bits set where `self[i] < o[i]`.
        #[inline(always)]
        pub(crate) fn lt_mask(self, o: F4) -> F4 {
            F4(unsafe { _mm_cmplt_ps(self.0, o.0) })
        }

        /// `self` with the sign bit of `o` (as `f32::copysign`).
        #[inline(always)]
        pub(crate) fn copysign(self, o: F4) -> F4 {
            unsafe {
                let sign = _mm_set1_ps(-0.0);
                F4(_mm_or_ps(
                    _mm_andnot_ps(sign, self.0),
                    _mm_and_ps(sign, o.0),
                ))
            }
        }

        /// Bit i set where `self[i] >= o[i]`.
        #[inline(always)]
        pub(crate) fn ge(self, o: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmpge_ps(self.0, o.0)) as u32 }
        }

        /// `-self` (the sign bit flipped, as `f32`'s negation).
        #[inline(always)]
        pub(crate) fn neg(self) -> F4 {
            F4(unsafe { _mm_xor_ps(self.0, _mm_set1_ps(-0.0)) })
        }

        /// All bits set where `self[i] <= o[i]`.
        #[inline(always)]
        pub(crate) fn le_mask(self, o: F4) -> F4 {
            F4(unsafe { _mm_cmple_ps(self.0, o.0) })
        }

        /// All bits set where `self[i] == o[i]`.
        #[inline(always)]
        pub(crate) fn eq_mask(self, o: F4) -> F4 {
            F4(unsafe { _mm_cmpeq_ps(self.0, o.0) })
        }

        /// The bits of `self` not set in `o` (for masks).
        #[inline(always)]
        pub(crate) fn and_not(self, o: F4) -> F4 {
            F4(unsafe { _mm_andnot_ps(o.0, self.0) })
        }

        /// Bit i set where lane i of a mask is set.
        #[inline(always)]
        pub(crate) fn bits(self) -> u32 {
            unsafe { _mm_movemask_ps(self.0) as u32 }
        }

        /// `|self|` (the sign bit cleared).
        #[inline(always)]
        pub(crate) fn abs(self) -> F4 {
            F4(unsafe { _mm_andnot_ps(_mm_set1_ps(-0.0), self.0) })
        }

        /// Each lane moved by `k` (truncated to an integer, |k| < 2³¹) units in the last place:
        /// `f32::from_bits(x.to_bits() + k)` for x ≥ +0, `f32::from_bits(x.to_bits() − k)` for
        /// x with its sign bit set (away from zero for k > 0).
        #[inline(always)]
        pub(crate) fn move_ulps(self, k: F4) -> F4 {
            unsafe {
                let ki = _mm_cvttps_epi32(k.0);
                let bits = _mm_castps_si128(self.0);
                let sign = _mm_srai_epi32::<31>(bits);
                let adj = _mm_sub_epi32(_mm_xor_si128(ki, sign), sign);
                F4(_mm_castsi128_ps(_mm_add_epi32(bits, adj)))
            }
        }

        /// Each lane truncated towards zero to an integer: `x as i32` for |x| < 2³¹ (one
        /// `cvttps2dq`; other lanes give `i32::MIN` where `as` would saturate).
        #[inline(always)]
        pub(crate) fn trunc_i32(self) -> [i32; 4] {
            let mut a = [0i32; 4];
            unsafe { _mm_storeu_si128(a.as_mut_ptr().cast(), _mm_cvttps_epi32(self.0)) };
            a
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
        fn cmp_bits(self, o: F4, f: impl Fn(f32, f32) -> bool) -> u32 {
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
            self.cmp_bits(o, |a, b| a <= b)
        }
        pub(crate) fn lt(self, o: F4) -> u32 {
            self.cmp_bits(o, |a, b| a < b)
        }
        pub(crate) fn gt(self, o: F4) -> u32 {
            self.cmp_bits(o, |a, b| a > b)
        }
        pub(crate) fn eq(self, o: F4) -> u32 {
            self.cmp_bits(o, |a, b| a == b)
        }
        pub(crate) fn ne(self, o: F4) -> u32 {
            self.cmp_bits(o, |a, b| a != b)
        }
        pub(crate) fn sqrt(self) -> F4 {
            F4(self.0.map(f32::sqrt))
        }
        pub(crate) fn select(mask: F4, a: F4, b: F4) -> F4 {
            F4(std::array::from_fn(|i| {
                if mask.0[i].to_bits() != 0 {
                    a.0[i]
                } else {
                    b.0[i]
                }
            }))
        }
        pub(crate) fn gt_mask(self, o: F4) -> F4 {
            self.map(o, |a, b| f32::from_bits(if a > b { u32::MAX } else { 0 }))
        }
        pub(crate) fn lt_mask(self, o: F4) -> F4 {
            self.map(o, |a, b| f32::from_bits(if a < b { u32::MAX } else { 0 }))
        }
        pub(crate) fn copysign(self, o: F4) -> F4 {
            self.map(o, f32::copysign)
        }
        pub(crate) fn ge(self, o: F4) -> u32 {
            self.cmp_bits(o, |a, b| a >= b)
        }
        pub(crate) fn neg(self) -> F4 {
            F4(self.0.map(|x| -x))
        }
        pub(crate) fn le_mask(self, o: F4) -> F4 {
            self.map(o, |a, b| f32::from_bits(if a <= b { u32::MAX } else { 0 }))
        }
        pub(crate) fn eq_mask(self, o: F4) -> F4 {
            self.map(o, |a, b| f32::from_bits(if a == b { u32::MAX } else { 0 }))
        }
        pub(crate) fn and_not(self, o: F4) -> F4 {
            self.map(o, |a, b| f32::from_bits(a.to_bits() & !b.to_bits()))
        }
        pub(crate) fn bits(self) -> u32 {
            (0..4).fold(0, |m, i| m | (self.0[i].to_bits() >> 31) << i)
        }
        pub(crate) fn abs(self) -> F4 {
            F4(self.0.map(f32::abs))
        }
        pub(crate) fn move_ulps(self, k: F4) -> F4 {
            F4(std::array::from_fn(|i| {
                let (x, k) = (self.0[i], k.0[i] as i32);
                let b = x.to_bits() as i32;
                f32::from_bits(b.wrapping_add(if b < 0 { -k } else { k }) as u32)
            }))
        }
        pub(crate) fn trunc_i32(self) -> [i32; 4] {
            self.0.map(|x| x as i32)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::F4;

    /// `trunc_i32` is `as i32` (towards zero) in every lane, for the values a BVH's bins
    /// take and for negative ones, fractions and the edges of whole numbers.
    #[test]
    fn truncation_is_as_i32() {
        let mut x = -70.0f32;
        while x < 70.0 {
            let v = [x, x.next_up(), x.next_down(), -x];
            let want = v.map(|x| x as i32);
            assert_eq!(F4::load(&v).trunc_i32(), want, "{v:?}");
            x += 0.37;
        }
        let v = [15.999_999, -0.999_999_9, 1.0e9, -2.0e9];
        assert_eq!(F4::load(&v).trunc_i32(), v.map(|x| x as i32));
    }
}
