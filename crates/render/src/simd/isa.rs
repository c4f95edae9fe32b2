//! Eight-lane f32 operations behind one trait, [`Isa`]: two SSE registers ([`Sse`]) or one
//! AVX register ([`Avx2`], only constructed once the CPU is known to have AVX2).

// Why unsafe code is allowed in this file: the AVX intrinsics are `#[target_feature]`
// functions, unsafe to call from code not compiled for the feature; `Avx2` values exist only
// where `super::run` has checked the CPU (its constructor is unsafe), and `_mm256_loadu_ps` /
// `_mm256_storeu_ps` read and write through references to `[f32; 8]`, valid for 32 bytes.
#![allow(unsafe_code)]

use super::F4;

/// Eight-lane operations, as one register or two.
pub(crate) trait Isa: Copy {
    /// Eight f32 lanes.
    type F8: Copy;
    /// All lanes `x`.
    fn splat8(self, x: f32) -> Self::F8;
    /// Loads eight lanes.
    fn load8(self, a: &[f32; 8]) -> Self::F8;
    /// The lanes as an array.
    fn store8(self, a: Self::F8) -> [f32; 8];
    /// `a - b`.
    fn sub8(self, a: Self::F8, b: Self::F8) -> Self::F8;
    /// `a · b`.
    fn mul8(self, a: Self::F8, b: Self::F8) -> Self::F8;
    /// Per lane `if a > b { a } else { b }` (a NaN keeps `b`).
    fn max_keep8(self, a: Self::F8, b: Self::F8) -> Self::F8;
    /// Per lane `if a < b { a } else { b }` (a NaN keeps `b`).
    fn min_keep8(self, a: Self::F8, b: Self::F8) -> Self::F8;
    /// Bit i set where `a[i] <= b[i]`.
    fn le8(self, a: Self::F8, b: Self::F8) -> u32;
}

/// Eight lanes as two [`F4`] (SSE).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sse;

impl Isa for Sse {
    type F8 = [F4; 2];

    #[inline(always)]
    fn splat8(self, x: f32) -> [F4; 2] {
        [F4::splat(x); 2]
    }

    #[inline(always)]
    fn load8(self, a: &[f32; 8]) -> [F4; 2] {
        let (l, h) = a.split_at(4);
        [
            F4::load(l.try_into().expect("4")),
            F4::load(h.try_into().expect("4")),
        ]
    }

    #[inline(always)]
    fn store8(self, a: [F4; 2]) -> [f32; 8] {
        let (l, h) = (a[0].to_array(), a[1].to_array());
        [l[0], l[1], l[2], l[3], h[0], h[1], h[2], h[3]]
    }

    #[inline(always)]
    fn sub8(self, a: [F4; 2], b: [F4; 2]) -> [F4; 2] {
        [a[0].sub(b[0]), a[1].sub(b[1])]
    }

    #[inline(always)]
    fn mul8(self, a: [F4; 2], b: [F4; 2]) -> [F4; 2] {
        [a[0].mul(b[0]), a[1].mul(b[1])]
    }

    #[inline(always)]
    fn max_keep8(self, a: [F4; 2], b: [F4; 2]) -> [F4; 2] {
        [a[0].max_keep(b[0]), a[1].max_keep(b[1])]
    }

    #[inline(always)]
    fn min_keep8(self, a: [F4; 2], b: [F4; 2]) -> [F4; 2] {
        [a[0].min_keep(b[0]), a[1].min_keep(b[1])]
    }

    #[inline(always)]
    fn le8(self, a: [F4; 2], b: [F4; 2]) -> u32 {
        a[0].le(b[0]) | a[1].le(b[1]) << 4
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::Avx2;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::Isa;
    use std::arch::x86_64::*;

    /// Eight lanes in one AVX register. Only [`super::run`] makes one, after checking that
    /// the CPU has AVX2: holding one proves it.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx2(());

    impl Avx2 {
        /// # Safety
        /// The CPU must support AVX2.
        #[inline(always)]
        pub(in crate::simd) unsafe fn new() -> Self {
            Avx2(())
        }
    }

    // SAFETY (every block below): an `Avx2` exists only on a CPU with AVX2 (see `new`);
    // loads and stores go through references to `[f32; 8]`.
    impl Isa for Avx2 {
        type F8 = __m256;

        #[inline(always)]
        fn splat8(self, x: f32) -> __m256 {
            unsafe { _mm256_set1_ps(x) }
        }

        #[inline(always)]
        fn load8(self, a: &[f32; 8]) -> __m256 {
            unsafe { _mm256_loadu_ps(a.as_ptr()) }
        }

        #[inline(always)]
        fn store8(self, a: __m256) -> [f32; 8] {
            let mut r = [0f32; 8];
            unsafe { _mm256_storeu_ps(r.as_mut_ptr(), a) };
            r
        }

        #[inline(always)]
        fn sub8(self, a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_sub_ps(a, b) }
        }

        #[inline(always)]
        fn mul8(self, a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_mul_ps(a, b) }
        }

        #[inline(always)]
        fn max_keep8(self, a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_max_ps(a, b) }
        }

        #[inline(always)]
        fn min_keep8(self, a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_min_ps(a, b) }
        }

        #[inline(always)]
        fn le8(self, a: __m256, b: __m256) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(a, b)) as u32 }
        }
    }
}
