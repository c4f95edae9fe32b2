//! SIMD for the hot kernels: four-lane f32 vectors ([`F4`]), eight-lane operations behind an
//! instruction-set trait ([`Isa`]), and the choice of instruction set at run time ([`run`]).
//!
//! [`F4`] wraps an SSE register on x86-64 (SSE2 is part of the baseline there) and a plain
//! array elsewhere. Every operation is one IEEE single-precision instruction per lane, the same
//! as the scalar code's, so the kernels give bit-identical results to the scalar routines.
//!
//! [`run`] executes a kernel compiled a second time with AVX2 (and BMI, LZCNT, POPCNT) on a
//! CPU that has them: the same SSE operations in VEX form (three operands, fewer moves) and
//! cheaper bit scans; and a third time with the AVX-512VL encodings too where the CPU has
//! them (the same operations, with thirty-two vector registers). No arithmetic changes:
//! floating-point contraction stays off.
//!
//! [`run_auto_at`] executes a kernel the compiler vectorises by itself (integer loops: the
//! sampler's scrambles) compiled for AVX-512 with GFNI where the CPU has them, else as [`run`].
//!
//! [`run_wide`] executes a kernel over sixteen lanes ([`Wide`]) with the widest registers the
//! CPU has: one AVX-512 register, two AVX registers or four SSE ones. Every width gives the
//! same bits. The environment variable `CANDELA_SIMD` (`sse`, `avx2`, `avx512`) caps the
//! choice, for tests and comparisons.
//!
//! This module sits below everything that uses vectors (the samplers, the accelerators).

// Why unsafe code is allowed in this file:
// - `run_at`, `run_auto_at` and `run_wide_at` call their AVX2 / AVX-512 versions
//   (`#[target_feature]` functions, unsafe to call from code not compiled for the feature)
//   only after `is_x86_feature_detected!` confirmed every feature that version is compiled
//   with;
// - `prefetch` issues `_mm_prefetch`, an SSE instruction (always present on x86-64) that never
//   faults.
#![allow(unsafe_code)]

use std::sync::atomic::{AtomicU8, Ordering};

mod f4;
mod isa;
mod wide;

pub(crate) use f4::F4;
#[cfg(target_arch = "x86_64")]
use isa::Avx2;
pub(crate) use isa::{Isa, Sse};
pub(crate) use wide::Wide;
#[cfg(target_arch = "x86_64")]
use wide::{Avx2x2, Avx512, Sse4};

/// What `ask` gives plus one, asked once and then kept in `cache` (0 until asked): the CPU's
/// features and the environment's caps, read at every kernel call. (Kept plus one, the
/// callers' tests of the answer are those of the cache's value.)
#[inline(always)]
fn cached(cache: &AtomicU8, ask: impl FnOnce() -> u8) -> u8 {
    match cache.load(Ordering::Relaxed) {
        0 => ask_once(cache, ask),
        v => v,
    }
}

/// [`cached`]'s first asking, out of the callers' way.
#[cold]
#[inline(never)]
fn ask_once(cache: &AtomicU8, ask: impl FnOnce() -> u8) -> u8 {
    let v = ask() + 1;
    cache.store(v, Ordering::Relaxed);
    v
}

/// A kernel to run with the best instruction set: its `run` must be `#[inline(always)]` so
/// that it is compiled into each version.
pub(crate) trait Kernel {
    /// What it returns.
    type Output;
    /// Runs it with the operations of `isa`.
    fn run<I: Isa>(self, isa: I) -> Self::Output;
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
    static CACHE: AtomicU8 = AtomicU8::new(0);
    cached(&CACHE, || {
        (std::env::var_os("CANDELA_NO_AVX2").is_none()
            && std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("lzcnt")
            && std::arch::is_x86_feature_detected!("popcnt")) as u8
    }) == 2
}

/// `run_avx2` compiled with the AVX-512VL encodings as well: the same eight-lane operations,
/// with thirty-two vector registers rather than sixteen. The single-ray traversal holds a ray's
/// box-test operands and its triangle-test operands at once; with sixteen registers they were
/// reloaded from the stack around every leaf. (meshes-sky, two series of pairs: 0.967× and
/// 0.969× the time.)
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,bmi1,bmi2,lzcnt,popcnt")]
fn run_avx2_evex<K: Kernel>(k: K) -> K::Output {
    // SAFETY: this function is only called on a CPU with AVX-512F and AVX-512VL (see
    // `run_at`), which includes AVX2.
    k.run(unsafe { Avx2::new() })
}

/// True when the CPU has every feature `run_avx2_evex` is compiled for.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn has_avx512vl() -> bool {
    static CACHE: AtomicU8 = AtomicU8::new(0);
    cached(&CACHE, || {
        (SimdLevel::supported() == SimdLevel::Avx512
            && std::arch::is_x86_feature_detected!("avx512vl")) as u8
    }) == 2
}

/// Runs `k` with the best instruction set the CPU has (capped by `CANDELA_SIMD`): AVX2 with
/// the AVX-512VL registers, AVX2, or SSE.
#[inline(always)]
pub(crate) fn run<K: Kernel>(k: K) -> K::Output {
    run_at(SimdLevel::detected(), k)
}

/// [`run`] at `level` at most (every level gives the same bits; tests compare them).
#[inline(always)]
pub(crate) fn run_at<K: Kernel>(level: SimdLevel, k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if level >= SimdLevel::Avx512 && has_avx512vl() {
        // SAFETY: the CPU supports every feature `run_avx2_evex` is compiled with.
        return unsafe { run_avx2_evex(k) };
    }
    #[cfg(target_arch = "x86_64")]
    if level >= SimdLevel::Avx2 && has_avx2() {
        // SAFETY: the CPU supports every feature `run_avx2` is compiled with.
        return unsafe { run_avx2(k) };
    }
    let _ = level;
    k.run(Sse)
}

/// Runs `k`, a kernel the compiler vectorises by itself (integer loops such as the sampler's
/// scrambles), compiled for AVX-512 with GFNI when the CPU has them and `level` allows it
/// (sixteen lanes per instruction; bit reversal in two instructions), otherwise as [`run`]
/// does. Integer arithmetic is exact, so every version gives the same bits.
#[inline(always)]
pub(crate) fn run_auto_at<K: Kernel>(level: SimdLevel, k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if level >= SimdLevel::Avx512 && has_avx512_gfni() {
        // SAFETY: the CPU supports every feature `run_avx512_gfni` is compiled with.
        return unsafe { run_avx512_gfni(k) };
    }
    #[cfg(target_arch = "x86_64")]
    if level >= SimdLevel::Avx2 && has_avx2() {
        // SAFETY: the CPU supports every feature `run_avx2` is compiled with.
        return unsafe { run_avx2(k) };
    }
    let _ = level;
    k.run(Sse)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,gfni,avx2,bmi1,bmi2,lzcnt,popcnt")]
fn run_avx512_gfni<K: Kernel>(k: K) -> K::Output {
    // SAFETY: this function is only called on a CPU with AVX-512 and GFNI (see
    // `run_auto_at`), which includes AVX2.
    k.run(unsafe { Avx2::new() })
}

/// True when the CPU has every feature `run_avx512_gfni` is compiled for and `CANDELA_SIMD`
/// does not cap the level below AVX-512.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn has_avx512_gfni() -> bool {
    static CACHE: AtomicU8 = AtomicU8::new(0);
    cached(&CACHE, || {
        (SimdLevel::detected() == SimdLevel::Avx512
            && std::arch::is_x86_feature_detected!("avx512bw")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("gfni")) as u8
    }) == 2
}

/// Asks for the cache lines of `x` (up to 256 bytes) to be loaded: a hint, no effect on
/// results.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    prefetch_bytes(
        x as *const T as *const i8,
        std::mem::size_of::<T>().min(256),
    );
}

/// Asks for the cache lines of the values of `xs` to be loaded (a hint, no effect on
/// results): [`prefetch`] for each, in one loop over its bytes (no division by the values'
/// size to count them, as iterating over a slice of 160-byte values compiles to).
#[inline(always)]
pub(crate) fn prefetch_all<T>(xs: &[T]) {
    prefetch_bytes(xs.as_ptr() as *const i8, std::mem::size_of_val(xs));
}

/// Prefetches the `n` bytes from `p`, a cache line (64 bytes) at a time.
#[inline(always)]
fn prefetch_bytes(p: *const i8, n: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let mut off = 0;
        while off < n {
            // SAFETY: SSE is always present on x86-64, and a prefetch never faults (the
            // callers' addresses lie within, or just past, a live object anyway).
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
            off += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, n);
}

/// A kernel over sixteen lanes, for [`run_wide`]: its `run` must be `#[inline(always)]` so
/// that it is compiled into each version.
pub(crate) trait WideKernel {
    /// What it returns.
    type Output;
    /// Runs it with the operations of `w`.
    fn run<W: Wide>(self, w: W) -> Self::Output;
}

/// The instruction sets [`run_wide`] chooses from, narrowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SimdLevel {
    /// Four SSE registers (every x86-64 CPU; plain arrays elsewhere).
    Sse,
    /// Two AVX registers (AVX2).
    Avx2,
    /// One AVX-512 register (AVX-512F).
    Avx512,
}

impl SimdLevel {
    /// The widest level this CPU supports, capped by `CANDELA_SIMD` (asked once, then cached).
    #[inline]
    pub fn detected() -> SimdLevel {
        static CACHE: AtomicU8 = AtomicU8::new(0);
        Self::from_cached(cached(&CACHE, || Self::capped() as u8))
    }

    /// [`SimdLevel::detected`], asked of the CPU and the environment.
    #[cold]
    fn capped() -> SimdLevel {
        Self::supported().min(match std::env::var("CANDELA_SIMD").as_deref() {
            Ok("sse") => SimdLevel::Sse,
            Ok("avx2") => SimdLevel::Avx2,
            _ => SimdLevel::Avx512,
        })
    }

    /// The widest level the CPU supports (asked once, then cached: the sixteen-lane kernels
    /// ask at every call).
    #[inline]
    pub fn supported() -> SimdLevel {
        static CACHE: AtomicU8 = AtomicU8::new(0);
        Self::from_cached(cached(&CACHE, || Self::asked() as u8))
    }

    /// The level numbered `v` − 1 (as [`cached`] keeps `level as u8`).
    #[inline(always)]
    fn from_cached(v: u8) -> SimdLevel {
        match v {
            1 => SimdLevel::Sse,
            2 => SimdLevel::Avx2,
            _ => SimdLevel::Avx512,
        }
    }

    /// [`SimdLevel::supported`], asked of the CPU.
    #[cold]
    fn asked() -> SimdLevel {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") && has_avx2() {
                return SimdLevel::Avx512;
            }
            if has_avx2() {
                return SimdLevel::Avx2;
            }
        }
        SimdLevel::Sse
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,bmi1,bmi2,lzcnt,popcnt")]
fn run_avx512<K: WideKernel>(k: K) -> K::Output {
    // SAFETY: this function is only called on a CPU with AVX-512F (see `run_wide_at`).
    k.run(unsafe { Avx512::new() })
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
fn run_avx2x2<K: WideKernel>(k: K) -> K::Output {
    // SAFETY: this function is only called on a CPU with AVX2 (see `run_wide_at`).
    k.run(unsafe { Avx2x2::new() })
}

/// The SSE kernel of `k`, out of line as the others are (they must be, for their instruction
/// sets). Inlined, every kernel's SSE version went into its caller: the lanes' shading
/// function held all ten of its kernels, and its loop passes took minutes to compile.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
fn run_sse<K: WideKernel>(k: K) -> K::Output {
    k.run(Sse4)
}

/// Runs `k` at `level`, or at the widest level below it that the CPU supports.
#[inline(always)]
pub(crate) fn run_wide_at<K: WideKernel>(level: SimdLevel, k: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    {
        let level = level.min(SimdLevel::supported());
        if level == SimdLevel::Avx512 {
            // SAFETY: the CPU supports every feature `run_avx512` is compiled with.
            return unsafe { run_avx512(k) };
        }
        if level == SimdLevel::Avx2 {
            // SAFETY: the CPU supports every feature `run_avx2x2` is compiled with.
            return unsafe { run_avx2x2(k) };
        }
        run_sse(k)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = level;
        k.run(wide::Portable)
    }
}
