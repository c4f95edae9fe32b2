//! Sixteen f32 lanes behind one trait, [`Wide`]: one AVX-512 register ([`Avx512`]), two AVX
//! registers ([`Avx2x2`]) or four SSE registers ([`Sse4`]), chosen at run time by
//! [`super::run_wide`]. Kernels written once over `Wide` give bit-identical results with every
//! implementation: each operation is the same IEEE single-precision operation per lane
//! (no fused multiply-add; division and square root correctly rounded), only the register width
//! differs. Lanes hold f32 values or, bit for bit, u32 ids (selection moves bits unchanged).

// Why unsafe code is allowed in this file: the SSE, AVX and AVX-512 intrinsics are unsafe
// functions (`#[target_feature]`); SSE2 is always present on x86-64, an `Avx2x2` exists only
// once the CPU is known to have AVX2 and an `Avx512` only once it is known to have AVX-512F
// (their constructors are unsafe and called by `super::run_wide` after detection). Loads and
// stores go through references to `[f32; 16]`, valid for 64 bytes.
#![allow(unsafe_code)]

/// Sixteen-lane operations.
pub(crate) trait Wide: Copy {
    /// Sixteen f32 lanes.
    type V: Copy;
    /// Sixteen lane flags.
    type M: Copy;
    /// All lanes `x`.
    fn splat(self, x: f32) -> Self::V;
    /// All lanes the bits of `x`.
    #[inline(always)]
    fn splat_bits(self, x: u32) -> Self::V {
        self.splat(f32::from_bits(x))
    }
    /// Loads sixteen lanes.
    fn load(self, a: &[f32; 16]) -> Self::V;
    /// Stores sixteen lanes.
    fn store(self, v: Self::V, a: &mut [f32; 16]);
    /// `a + b`.
    fn add(self, a: Self::V, b: Self::V) -> Self::V;
    /// `a - b`.
    fn sub(self, a: Self::V, b: Self::V) -> Self::V;
    /// `a · b`.
    fn mul(self, a: Self::V, b: Self::V) -> Self::V;
    /// `a / b`.
    fn div(self, a: Self::V, b: Self::V) -> Self::V;
    /// √a.
    fn sqrt(self, a: Self::V) -> Self::V;
    /// −a (the sign bit flipped).
    fn neg(self, a: Self::V) -> Self::V;
    /// `a` with the sign of `b`.
    fn copysign(self, a: Self::V, b: Self::V) -> Self::V;
    /// `a < b` (false for NaN).
    fn lt(self, a: Self::V, b: Self::V) -> Self::M;
    /// `a <= b`.
    fn le(self, a: Self::V, b: Self::V) -> Self::M;
    /// `a == b`.
    fn eq(self, a: Self::V, b: Self::V) -> Self::M;
    /// `a != b` (true for NaN).
    fn ne(self, a: Self::V, b: Self::V) -> Self::M;
    /// `a > b`.
    #[inline(always)]
    fn gt(self, a: Self::V, b: Self::V) -> Self::M {
        self.lt(b, a)
    }
    /// `a >= b`.
    #[inline(always)]
    fn ge(self, a: Self::V, b: Self::V) -> Self::M {
        self.le(b, a)
    }
    /// `a ∧ b`.
    fn and(self, a: Self::M, b: Self::M) -> Self::M;
    /// `a ∨ b`.
    fn or(self, a: Self::M, b: Self::M) -> Self::M;
    /// `a ∧ ¬b`.
    fn and_not(self, a: Self::M, b: Self::M) -> Self::M;
    /// Lanes of `a` where `m`, of `b` elsewhere.
    fn select(self, m: Self::M, a: Self::V, b: Self::V) -> Self::V;
    /// Bit i set where lane i of `m` is.
    fn bits(self, m: Self::M) -> u32;
    /// The mask with lane i set where bit i of `b` is.
    fn mask(self, b: u32) -> Self::M;
    /// Each lane of `x` moved by `k` (truncated to an integer, |k| < 2³¹) units in the last
    /// place, away from zero for k > 0: [`super::F4::move_ulps`] on sixteen lanes.
    fn move_ulps(self, x: Self::V, k: Self::V) -> Self::V;
}

/// An implementation over `K` registers of `L` lanes each (the pattern of the x86 ones).
/// Plain loops, no closures: the operations inline into the caller's target features.
macro_rules! split_impl {
    ($name:ident, $reg:ty, $k:expr, $l:expr,
     splat = $splat:path, load = $load:path, store = $store:path,
     add = $add:path, sub = $sub:path, mul = $mul:path, div = $div:path, sqrt = $sqrt:path,
     and = $and:path, or = $or:path, andnot = $andnot:path, xor = $xor:path,
     movemask = $movemask:path, blend = $blend:path,
     lt = $lt:path, le = $le:path, eq = $eq:path, ne = $ne:path,
     move_ulps = $move_ulps:path) => {
        // SAFETY (every block below): the type exists only where its instructions are present
        // (see the module's header); loads and stores stay within the `[f32; 16]`.
        impl Wide for $name {
            type V = [$reg; $k];
            type M = [$reg; $k];

            #[inline(always)]
            fn splat(self, x: f32) -> Self::V {
                [unsafe { $splat(x) }; $k]
            }
            #[inline(always)]
            fn load(self, a: &[f32; 16]) -> Self::V {
                let mut r = [unsafe { $splat(0.0) }; $k];
                for i in 0..$k {
                    r[i] = unsafe { $load(a.as_ptr().add(i * $l)) };
                }
                r
            }
            #[inline(always)]
            fn store(self, v: Self::V, a: &mut [f32; 16]) {
                for i in 0..$k {
                    unsafe { $store(a.as_mut_ptr().add(i * $l), v[i]) }
                }
            }
            #[inline(always)]
            fn add(self, mut a: Self::V, b: Self::V) -> Self::V {
                for i in 0..$k {
                    a[i] = unsafe { $add(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn sub(self, mut a: Self::V, b: Self::V) -> Self::V {
                for i in 0..$k {
                    a[i] = unsafe { $sub(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn mul(self, mut a: Self::V, b: Self::V) -> Self::V {
                for i in 0..$k {
                    a[i] = unsafe { $mul(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn div(self, mut a: Self::V, b: Self::V) -> Self::V {
                for i in 0..$k {
                    a[i] = unsafe { $div(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn sqrt(self, mut a: Self::V) -> Self::V {
                for i in 0..$k {
                    a[i] = unsafe { $sqrt(a[i]) };
                }
                a
            }
            #[inline(always)]
            fn neg(self, mut a: Self::V) -> Self::V {
                let s = unsafe { $splat(-0.0) };
                for i in 0..$k {
                    a[i] = unsafe { $xor(a[i], s) };
                }
                a
            }
            #[inline(always)]
            fn copysign(self, mut a: Self::V, b: Self::V) -> Self::V {
                let s = unsafe { $splat(-0.0) };
                for i in 0..$k {
                    a[i] = unsafe { $or($andnot(s, a[i]), $and(s, b[i])) };
                }
                a
            }
            #[inline(always)]
            fn lt(self, mut a: Self::V, b: Self::V) -> Self::M {
                for i in 0..$k {
                    a[i] = unsafe { $lt(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn le(self, mut a: Self::V, b: Self::V) -> Self::M {
                for i in 0..$k {
                    a[i] = unsafe { $le(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn eq(self, mut a: Self::V, b: Self::V) -> Self::M {
                for i in 0..$k {
                    a[i] = unsafe { $eq(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn ne(self, mut a: Self::V, b: Self::V) -> Self::M {
                for i in 0..$k {
                    a[i] = unsafe { $ne(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn and(self, mut a: Self::M, b: Self::M) -> Self::M {
                for i in 0..$k {
                    a[i] = unsafe { $and(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn or(self, mut a: Self::M, b: Self::M) -> Self::M {
                for i in 0..$k {
                    a[i] = unsafe { $or(a[i], b[i]) };
                }
                a
            }
            #[inline(always)]
            fn and_not(self, mut a: Self::M, b: Self::M) -> Self::M {
                for i in 0..$k {
                    a[i] = unsafe { $andnot(b[i], a[i]) };
                }
                a
            }
            #[inline(always)]
            fn select(self, m: Self::M, a: Self::V, mut b: Self::V) -> Self::V {
                for i in 0..$k {
                    b[i] = unsafe { $blend(b[i], a[i], m[i]) };
                }
                b
            }
            #[inline(always)]
            fn bits(self, m: Self::M) -> u32 {
                let mut b = 0u32;
                for i in 0..$k {
                    b |= (unsafe { $movemask(m[i]) } as u32) << (i * $l);
                }
                b
            }
            #[inline(always)]
            fn mask(self, b: u32) -> Self::M {
                let mut a = [0f32; 16];
                for (i, x) in a.iter_mut().enumerate() {
                    *x = f32::from_bits(if b >> i & 1 == 1 { u32::MAX } else { 0 });
                }
                self.load(&a)
            }
            #[inline(always)]
            fn move_ulps(self, mut x: Self::V, k: Self::V) -> Self::V {
                for i in 0..$k {
                    x[i] = unsafe { $move_ulps(x[i], k[i]) };
                }
                x
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Wide;
    use std::arch::x86_64::*;

    /// Sixteen lanes as four SSE registers (SSE2 only: blends by and/andnot/or).
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Sse4;

    #[inline(always)]
    unsafe fn sse_move_ulps(x: __m128, k: __m128) -> __m128 {
        unsafe {
            let ki = _mm_cvttps_epi32(k);
            let bits = _mm_castps_si128(x);
            let sign = _mm_srai_epi32::<31>(bits);
            let adj = _mm_sub_epi32(_mm_xor_si128(ki, sign), sign);
            _mm_castsi128_ps(_mm_add_epi32(bits, adj))
        }
    }

    #[inline(always)]
    unsafe fn sse_blend(b: __m128, a: __m128, m: __m128) -> __m128 {
        unsafe { _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)) }
    }

    split_impl!(
        Sse4,
        __m128,
        4,
        4,
        splat = _mm_set1_ps,
        load = _mm_loadu_ps,
        store = _mm_storeu_ps,
        add = _mm_add_ps,
        sub = _mm_sub_ps,
        mul = _mm_mul_ps,
        div = _mm_div_ps,
        sqrt = _mm_sqrt_ps,
        and = _mm_and_ps,
        or = _mm_or_ps,
        andnot = _mm_andnot_ps,
        xor = _mm_xor_ps,
        movemask = _mm_movemask_ps,
        blend = sse_blend,
        lt = _mm_cmplt_ps,
        le = _mm_cmple_ps,
        eq = _mm_cmpeq_ps,
        ne = _mm_cmpneq_ps,
        move_ulps = sse_move_ulps
    );

    /// Sixteen lanes as two AVX registers.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx2x2(());

    impl Avx2x2 {
        /// # Safety
        /// The CPU must support AVX2.
        #[inline(always)]
        pub(in crate::simd) unsafe fn new() -> Self {
            Avx2x2(())
        }
    }

    #[inline(always)]
    unsafe fn move_ulps256(x: __m256, k: __m256) -> __m256 {
        unsafe {
            let ki = _mm256_cvttps_epi32(k);
            let bits = _mm256_castps_si256(x);
            let sign = _mm256_srai_epi32::<31>(bits);
            let adj = _mm256_sub_epi32(_mm256_xor_si256(ki, sign), sign);
            _mm256_castsi256_ps(_mm256_add_epi32(bits, adj))
        }
    }
    #[inline(always)]
    unsafe fn lt256(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(a, b) }
    }
    #[inline(always)]
    unsafe fn le256(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(a, b) }
    }
    #[inline(always)]
    unsafe fn eq256(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b) }
    }
    #[inline(always)]
    unsafe fn ne256(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_NEQ_UQ>(a, b) }
    }

    split_impl!(
        Avx2x2,
        __m256,
        2,
        8,
        splat = _mm256_set1_ps,
        load = _mm256_loadu_ps,
        store = _mm256_storeu_ps,
        add = _mm256_add_ps,
        sub = _mm256_sub_ps,
        mul = _mm256_mul_ps,
        div = _mm256_div_ps,
        sqrt = _mm256_sqrt_ps,
        and = _mm256_and_ps,
        or = _mm256_or_ps,
        andnot = _mm256_andnot_ps,
        xor = _mm256_xor_ps,
        movemask = _mm256_movemask_ps,
        blend = _mm256_blendv_ps,
        lt = lt256,
        le = le256,
        eq = eq256,
        ne = ne256,
        move_ulps = move_ulps256
    );

    /// Sixteen lanes as one AVX-512 register, masks as `__mmask16`.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx512(());

    impl Avx512 {
        /// # Safety
        /// The CPU must support AVX-512F.
        #[inline(always)]
        pub(in crate::simd) unsafe fn new() -> Self {
            Avx512(())
        }
    }

    // SAFETY (every block below): an `Avx512` exists only on a CPU with AVX-512F (see `new`);
    // loads and stores go through references to `[f32; 16]`.
    impl Wide for Avx512 {
        type V = __m512;
        type M = __mmask16;

        #[inline(always)]
        fn splat(self, x: f32) -> __m512 {
            unsafe { _mm512_set1_ps(x) }
        }
        #[inline(always)]
        fn load(self, a: &[f32; 16]) -> __m512 {
            unsafe { _mm512_loadu_ps(a.as_ptr()) }
        }
        #[inline(always)]
        fn store(self, v: __m512, a: &mut [f32; 16]) {
            unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) }
        }
        #[inline(always)]
        fn add(self, a: __m512, b: __m512) -> __m512 {
            unsafe { _mm512_add_ps(a, b) }
        }
        #[inline(always)]
        fn sub(self, a: __m512, b: __m512) -> __m512 {
            unsafe { _mm512_sub_ps(a, b) }
        }
        #[inline(always)]
        fn mul(self, a: __m512, b: __m512) -> __m512 {
            unsafe { _mm512_mul_ps(a, b) }
        }
        #[inline(always)]
        fn div(self, a: __m512, b: __m512) -> __m512 {
            unsafe { _mm512_div_ps(a, b) }
        }
        #[inline(always)]
        fn sqrt(self, a: __m512) -> __m512 {
            unsafe { _mm512_sqrt_ps(a) }
        }
        #[inline(always)]
        fn neg(self, a: __m512) -> __m512 {
            unsafe {
                _mm512_castsi512_ps(_mm512_xor_si512(
                    _mm512_castps_si512(a),
                    _mm512_set1_epi32(i32::MIN),
                ))
            }
        }
        #[inline(always)]
        fn copysign(self, a: __m512, b: __m512) -> __m512 {
            unsafe {
                let s = _mm512_set1_epi32(i32::MIN);
                let (a, b) = (_mm512_castps_si512(a), _mm512_castps_si512(b));
                _mm512_castsi512_ps(_mm512_or_si512(
                    _mm512_andnot_si512(s, a),
                    _mm512_and_si512(s, b),
                ))
            }
        }
        #[inline(always)]
        fn lt(self, a: __m512, b: __m512) -> __mmask16 {
            unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b) }
        }
        #[inline(always)]
        fn le(self, a: __m512, b: __m512) -> __mmask16 {
            unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b) }
        }
        #[inline(always)]
        fn eq(self, a: __m512, b: __m512) -> __mmask16 {
            unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(a, b) }
        }
        #[inline(always)]
        fn ne(self, a: __m512, b: __m512) -> __mmask16 {
            unsafe { _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(a, b) }
        }
        #[inline(always)]
        fn and(self, a: __mmask16, b: __mmask16) -> __mmask16 {
            a & b
        }
        #[inline(always)]
        fn or(self, a: __mmask16, b: __mmask16) -> __mmask16 {
            a | b
        }
        #[inline(always)]
        fn and_not(self, a: __mmask16, b: __mmask16) -> __mmask16 {
            a & !b
        }
        #[inline(always)]
        fn select(self, m: __mmask16, a: __m512, b: __m512) -> __m512 {
            unsafe { _mm512_mask_blend_ps(m, b, a) }
        }
        #[inline(always)]
        fn bits(self, m: __mmask16) -> u32 {
            m as u32
        }
        #[inline(always)]
        fn mask(self, b: u32) -> __mmask16 {
            b as __mmask16
        }
        #[inline(always)]
        fn move_ulps(self, x: __m512, k: __m512) -> __m512 {
            unsafe {
                let ki = _mm512_cvttps_epi32(k);
                let bits = _mm512_castps_si512(x);
                let sign = _mm512_srai_epi32::<31>(bits);
                let adj = _mm512_sub_epi32(_mm512_xor_si512(ki, sign), sign);
                _mm512_castsi512_ps(_mm512_add_epi32(bits, adj))
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use x86::{Avx2x2, Avx512, Sse4};

/// Sixteen lanes as plain arrays (targets other than x86-64).
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable;

#[cfg(not(target_arch = "x86_64"))]
impl Wide for Portable {
    type V = [f32; 16];
    type M = u32;

    fn splat(self, x: f32) -> [f32; 16] {
        [x; 16]
    }
    fn load(self, a: &[f32; 16]) -> [f32; 16] {
        *a
    }
    fn store(self, v: [f32; 16], a: &mut [f32; 16]) {
        *a = v;
    }
    fn add(self, a: [f32; 16], b: [f32; 16]) -> [f32; 16] {
        std::array::from_fn(|i| a[i] + b[i])
    }
    fn sub(self, a: [f32; 16], b: [f32; 16]) -> [f32; 16] {
        std::array::from_fn(|i| a[i] - b[i])
    }
    fn mul(self, a: [f32; 16], b: [f32; 16]) -> [f32; 16] {
        std::array::from_fn(|i| a[i] * b[i])
    }
    fn div(self, a: [f32; 16], b: [f32; 16]) -> [f32; 16] {
        std::array::from_fn(|i| a[i] / b[i])
    }
    fn sqrt(self, a: [f32; 16]) -> [f32; 16] {
        a.map(f32::sqrt)
    }
    fn neg(self, a: [f32; 16]) -> [f32; 16] {
        a.map(|x| -x)
    }
    fn copysign(self, a: [f32; 16], b: [f32; 16]) -> [f32; 16] {
        std::array::from_fn(|i| a[i].copysign(b[i]))
    }
    fn lt(self, a: [f32; 16], b: [f32; 16]) -> u32 {
        (0..16).fold(0, |m, i| m | ((a[i] < b[i]) as u32) << i)
    }
    fn le(self, a: [f32; 16], b: [f32; 16]) -> u32 {
        (0..16).fold(0, |m, i| m | ((a[i] <= b[i]) as u32) << i)
    }
    fn eq(self, a: [f32; 16], b: [f32; 16]) -> u32 {
        (0..16).fold(0, |m, i| m | ((a[i] == b[i]) as u32) << i)
    }
    fn ne(self, a: [f32; 16], b: [f32; 16]) -> u32 {
        (0..16).fold(0, |m, i| m | ((a[i] != b[i]) as u32) << i)
    }
    fn and(self, a: u32, b: u32) -> u32 {
        a & b
    }
    fn or(self, a: u32, b: u32) -> u32 {
        a | b
    }
    fn and_not(self, a: u32, b: u32) -> u32 {
        a & !b
    }
    fn select(self, m: u32, a: [f32; 16], b: [f32; 16]) -> [f32; 16] {
        std::array::from_fn(|i| if m >> i & 1 == 1 { a[i] } else { b[i] })
    }
    fn bits(self, m: u32) -> u32 {
        m
    }
    fn mask(self, b: u32) -> u32 {
        b & 0xffff
    }
    fn move_ulps(self, x: [f32; 16], k: [f32; 16]) -> [f32; 16] {
        std::array::from_fn(|i| {
            let (k, b) = (k[i] as i32, x[i].to_bits() as i32);
            f32::from_bits(b.wrapping_add(if b < 0 { -k } else { k }) as u32)
        })
    }
}
