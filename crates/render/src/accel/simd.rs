//! Four-lane f32 vectors for the BVH kernels, and the choice of instruction set at run time.
//!
//! [`F4`] wraps an SSE register on x86-64 (SSE2 is part of the baseline there) and a plain
//! array elsewhere. Every operation is one IEEE single-precision instruction per lane, the same
//! as the scalar code's, so the kernels give bit-identical results to the scalar routines.
//!
//! [`run`] executes a kernel compiled a second time with AVX2 (and BMI, LZCNT, POPCNT) on a
//! CPU that has them: the same SSE operations in VEX form (three operands, fewer moves) and
//! cheaper bit scans. No arithmetic changes: floating-point contraction stays off.

// Why unsafe code is allowed here (and only here in the accelerators):
// - the `std::arch` intrinsics are `#[target_feature]` functions, which are unsafe to call
//   from code not itself compiled for the feature; SSE and SSE2 are always present on
//   x86-64, and `_mm_loadu_ps`/`_mm_storeu_ps` read and write through references to
//   `[f32; 4]`, which are valid for 16 bytes;
// - `run` calls its AVX2 version only after `is_x86_feature_detected!` confirmed every
//   feature that version is compiled with.
#![allow(unsafe_code)]

/// A kernel to run with the best instruction set: its `run` must be `#[inline(always)]` so
/// that it is compiled into each version.
pub(crate) trait Kernel {
    /// What it returns.
    type Output;
    /// Runs it with the operations of `isa`.
    fn run<I: Isa>(self, isa: I) -> Self::Output;
}

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
        pub(super) unsafe fn new() -> Self {
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

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
fn run_avx2<K: Kernel>(k: K) -> K::Output {
    // SAFETY: this function is only called on a CPU with AVX2 (see `run`).
    k.run(unsafe { Avx2::new() })
}

/// True when the CPU has every feature `run_avx2` is compiled for (asked once, then cached).
/// The environment variable `CANDELA_NO_AVX2` (any value) forces the SSE version, for tests
/// and comparisons.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn has_avx2() -> bool {
    use std::sync::atomic::{AtomicU8, Ordering};
    static CACHE: AtomicU8 = AtomicU8::new(0);
    match CACHE.load(Ordering::Relaxed) {
        1 => false,
        2 => true,
        _ => {
            let yes = std::env::var_os("CANDELA_NO_AVX2").is_none()
                && std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("bmi1")
                && std::arch::is_x86_feature_detected!("bmi2")
                && std::arch::is_x86_feature_detected!("lzcnt")
                && std::arch::is_x86_feature_detected!("popcnt");
            CACHE.store(1 + yes as u8, Ordering::Relaxed);
            yes
        }
    }
}

/// Runs `k`, compiled for AVX2 when the CPU has it.
#[inline(always)]
pub(crate) fn run<K: Kernel>(k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: the CPU supports every feature `run_avx2` is compiled with.
        return unsafe { run_avx2(k) };
    }
    k.run(Sse)
}

/// Asks for the cache lines of `x` (up to 256 bytes) to be loaded: a hint, no effect on
/// results.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = x as *const T as *const i8;
        let n = std::mem::size_of::<T>().min(256);
        let mut off = 0;
        while off < n {
            // SAFETY: SSE is always present on x86-64, and a prefetch never faults: the
            // addresses lie within (or just past) a live object anyway.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
            off += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

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
