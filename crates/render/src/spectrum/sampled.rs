//! `SampledSpectrum`: four f32 lanes, the per-ray spectral quantity.
//!
//! In spectral mode the lanes hold a quantity's values at the four wavelengths of a path's
//! [`SampledWavelengths`](super::SampledWavelengths); in RGB mode they hold `(r, g, b, g)`. All
//! operations are lane-wise plain loops over `[f32; 4]` without branches (selects only), the
//! form LLVM turns into four-wide SSE operations (the type is 16-byte aligned; the
//! transcendental `exp` stays four scalar calls).

use std::ops::{
    Add, AddAssign, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub, SubAssign,
};

use crate::color::Rgb;
use crate::simd::F4;

/// Number of lanes of a [`SampledSpectrum`] (and of wavelengths a path carries).
pub const N_SPECTRUM_SAMPLES: usize = 4;

/// Four values of a spectral quantity: one per sampled wavelength, or `(r, g, b, g)`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampledSpectrum(pub [f32; N_SPECTRUM_SAMPLES]);

impl SampledSpectrum {
    /// All lanes zero.
    pub const ZERO: Self = Self([0.0; 4]);
    /// All lanes one.
    pub const ONE: Self = Self([1.0; 4]);

    /// From four lane values.
    #[inline]
    pub const fn new(v: [f32; N_SPECTRUM_SAMPLES]) -> Self {
        Self(v)
    }

    /// Every lane `v`.
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Self([v; 4])
    }

    /// An RGB triple in lanes 0–2, lane 3 repeating green (RGB mode: every lane holds a
    /// real channel, so lane-wise arithmetic never meets an empty lane).
    #[inline]
    pub const fn from_rgb(c: Rgb) -> Self {
        Self([c.r, c.g, c.b, c.g])
    }

    /// [`SampledSpectrum::from_rgb`], the same bits, made in one vector register: stored to
    /// memory, it is written whole, so that a whole-vector load of it is forwarded from the
    /// store (LLVM copies `from_rgb`'s lanes from a colour in memory as two 8-byte halves,
    /// which a 16-byte load cannot be forwarded from). An SSE `max` of the vector with itself
    /// (each lane keeps its bits, NaN included) is what keeps it one vector.
    #[inline(always)]
    pub fn from_rgb_whole(c: Rgb) -> Self {
        let v = F4::load(&[c.r, c.g, c.b, c.g]);
        Self(v.max_keep(v).to_array())
    }

    /// Lanes 0–2 as RGB (RGB mode; lane 3 is ignored).
    #[inline]
    pub const fn to_rgb(self) -> Rgb {
        Rgb::new(self.0[0], self.0[1], self.0[2])
    }

    /// The lanes.
    #[inline]
    pub const fn lanes(self) -> [f32; N_SPECTRUM_SAMPLES] {
        self.0
    }

    /// Applies `f` to every lane.
    #[inline]
    pub fn map(self, f: impl Fn(f32) -> f32) -> Self {
        let mut r = [0.0; 4];
        for i in 0..4 {
            r[i] = f(self.0[i]);
        }
        Self(r)
    }

    /// Combines two spectra lane by lane.
    #[inline]
    pub fn zip(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        let mut r = [0.0; 4];
        for i in 0..4 {
            r[i] = f(self.0[i], o.0[i]);
        }
        Self(r)
    }

    /// The largest lane (all four: RGB contents repeat green in lane 3).
    #[inline]
    pub fn max_component(self) -> f32 {
        self.0[0].max(self.0[1]).max(self.0[2].max(self.0[3]))
    }

    /// The smallest lane (all four).
    #[inline]
    pub fn min_component(self) -> f32 {
        self.0[0].min(self.0[1]).min(self.0[2].min(self.0[3]))
    }

    /// The mean of the four lanes: the spectral meaning. For RGB contents use
    /// [`average_rgb`](Self::average_rgb).
    #[inline]
    pub fn average(self) -> f32 {
        (self.0[0] + self.0[1] + self.0[2] + self.0[3]) * 0.25
    }

    /// The mean of lanes 0–2 (RGB contents).
    #[inline]
    pub fn average_rgb(self) -> f32 {
        (self.0[0] + self.0[1] + self.0[2]) * (1.0 / 3.0)
    }

    /// Lane-wise approximate equality (an RGB triple compares in RGB mode's layout).
    pub fn approx_eq(self, o: impl Into<Self>, eps: f32) -> bool {
        let o = o.into();
        (0..N_SPECTRUM_SAMPLES).all(|i| (self.0[i] - o.0[i]).abs() <= eps)
    }

    /// True when every lane is exactly zero.
    #[inline]
    pub fn is_black(self) -> bool {
        // Bitwise so that it compiles to one compare and mask test (−0 counts as zero).
        let mut nonzero = false;
        for v in self.0 {
            nonzero |= v != 0.0;
        }
        !nonzero
    }

    /// True when every lane is finite (neither NaN nor infinite).
    #[inline]
    pub fn is_finite(self) -> bool {
        let mut ok = true;
        for v in self.0 {
            ok &= v.is_finite();
        }
        ok
    }

    /// Lane-wise eˣ (Beer–Lambert transmittance `(-σ t).exp()`). Note: a lane holding 0
    /// becomes 1, so RGB contents get lane 3 = 1.
    #[inline]
    pub fn exp(self) -> Self {
        self.map(f32::exp)
    }

    /// Lane-wise square root.
    #[inline]
    pub fn sqrt(self) -> Self {
        self.map(f32::sqrt)
    }

    /// Lane-wise `max(v, 0)` (NaN becomes 0).
    #[inline]
    pub fn clamp_zero(self) -> Self {
        self.map(|v| if v > 0.0 { v } else { 0.0 })
    }

    /// Lane-wise `clamp(v, lo, hi)`.
    #[inline]
    pub fn clamp(self, lo: f32, hi: f32) -> Self {
        self.map(|v| v.max(lo).min(hi))
    }

    /// Lane-wise `self / d`, 0 where `d` is 0 (e.g. a value over a terminated lane's pdf).
    #[inline]
    pub fn safe_div(self, d: Self) -> Self {
        self.zip(d, |a, b| if b != 0.0 { a / b } else { 0.0 })
    }

    /// Lane-wise linear interpolation `(1 − t)·self + t·o`.
    #[inline]
    pub fn lerp(self, o: Self, t: f32) -> Self {
        self * (1.0 - t) + o * t
    }
}

impl Index<usize> for SampledSpectrum {
    type Output = f32;
    #[inline]
    fn index(&self, i: usize) -> &f32 {
        &self.0[i]
    }
}

impl IndexMut<usize> for SampledSpectrum {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut self.0[i]
    }
}

impl From<[f32; 4]> for SampledSpectrum {
    #[inline]
    fn from(v: [f32; 4]) -> Self {
        Self(v)
    }
}

impl From<Rgb> for SampledSpectrum {
    #[inline]
    fn from(c: Rgb) -> Self {
        Self::from_rgb(c)
    }
}

macro_rules! lanewise {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl $tr for SampledSpectrum {
            type Output = Self;
            #[inline]
            fn $f(self, o: Self) -> Self {
                let mut r = [0.0; 4];
                for i in 0..4 {
                    r[i] = self.0[i] $op o.0[i];
                }
                Self(r)
            }
        }
        impl $tr<f32> for SampledSpectrum {
            type Output = Self;
            #[inline]
            fn $f(self, s: f32) -> Self {
                let mut r = [0.0; 4];
                for i in 0..4 {
                    r[i] = self.0[i] $op s;
                }
                Self(r)
            }
        }
        impl $tra for SampledSpectrum {
            #[inline]
            fn $fa(&mut self, o: Self) {
                *self = *self $op o;
            }
        }
        impl $tra<f32> for SampledSpectrum {
            #[inline]
            fn $fa(&mut self, s: f32) {
                *self = *self $op s;
            }
        }
    };
}

lanewise!(Add, add, AddAssign, add_assign, +);
lanewise!(Sub, sub, SubAssign, sub_assign, -);
lanewise!(Mul, mul, MulAssign, mul_assign, *);
lanewise!(Div, div, DivAssign, div_assign, /);

impl Mul<SampledSpectrum> for f32 {
    type Output = SampledSpectrum;
    #[inline]
    fn mul(self, s: SampledSpectrum) -> SampledSpectrum {
        s * self
    }
}

impl Neg for SampledSpectrum {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.map(|v| -v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn from_rgb_whole_keeps_every_bit() {
        for c in [
            Rgb::new(0.25, -0.0, 3.0e38),
            Rgb::new(f32::NAN, f32::INFINITY, f32::from_bits(0x0000_0001)),
            Rgb::new(-1.0, f32::NEG_INFINITY, 0.0),
        ] {
            let (a, b) = (
                SampledSpectrum::from_rgb(c),
                SampledSpectrum::from_rgb_whole(c),
            );
            assert_eq!(a.0.map(f32::to_bits), b.0.map(f32::to_bits));
        }
    }

    #[test]
    fn arithmetic_is_lanewise() {
        let a = SampledSpectrum::new([1.0, 2.0, 3.0, 4.0]);
        let b = SampledSpectrum::new([2.0, 4.0, 0.5, -1.0]);
        assert_eq!((a + b).lanes(), [3.0, 6.0, 3.5, 3.0]);
        assert_eq!((a - b).lanes(), [-1.0, -2.0, 2.5, 5.0]);
        assert_eq!((a * b).lanes(), [2.0, 8.0, 1.5, -4.0]);
        assert_eq!((a / b).lanes(), [0.5, 0.5, 6.0, -4.0]);
        assert_eq!((a * 2.0).lanes(), [2.0, 4.0, 6.0, 8.0]);
        assert_eq!((2.0 * a).lanes(), [2.0, 4.0, 6.0, 8.0]);
        assert_eq!((a / 2.0).lanes(), [0.5, 1.0, 1.5, 2.0]);
        assert_eq!((a + 1.0).lanes(), [2.0, 3.0, 4.0, 5.0]);
        assert_eq!((a - 1.0).lanes(), [0.0, 1.0, 2.0, 3.0]);
        assert_eq!((-a).lanes(), [-1.0, -2.0, -3.0, -4.0]);
        let mut c = a;
        c += b;
        c -= b;
        c *= b;
        c /= b;
        c *= 3.0;
        c /= 3.0;
        c += 1.0;
        c -= 1.0;
        assert_eq!(c, a);
        assert_eq!(a[2], 3.0);
        c[3] = 7.0;
        assert_eq!(c.lanes()[3], 7.0);
    }

    #[test]
    fn reductions_and_functions() {
        let a = SampledSpectrum::new([1.0, -2.0, 9.0, 4.0]);
        assert_eq!(a.max_component(), 9.0);
        assert_eq!(a.min_component(), -2.0);
        assert_eq!(a.average(), 3.0);
        assert_eq!(a.average_rgb(), 8.0 / 3.0);
        assert_eq!(a.clamp_zero().lanes(), [1.0, 0.0, 9.0, 4.0]);
        assert_eq!(a.clamp(0.0, 2.0).lanes(), [1.0, 0.0, 2.0, 2.0]);
        assert_eq!(
            SampledSpectrum::new([4.0, 9.0, 0.0, 1.0]).sqrt().lanes(),
            [2.0, 3.0, 0.0, 1.0]
        );
        let e = SampledSpectrum::new([0.0, 1.0, -1.0, 2.0]).exp();
        assert_eq!(e[0], 1.0);
        assert!((e[1] - std::f32::consts::E).abs() < 1e-6);
        let q = a.safe_div(SampledSpectrum::new([2.0, 0.0, 3.0, 0.0]));
        assert_eq!(q.lanes(), [0.5, 0.0, 3.0, 0.0]);
        assert!(SampledSpectrum::ZERO.is_black());
        assert!(SampledSpectrum::new([-0.0, 0.0, 0.0, 0.0]).is_black());
        assert!(!SampledSpectrum::new([0.0, 0.0, 0.0, 1e-30]).is_black());
        assert!(a.is_finite());
        assert!(!SampledSpectrum::new([0.0, f32::NAN, 0.0, 0.0]).is_finite());
        assert_eq!(
            SampledSpectrum::new([f32::NAN, 1.0, 1.0, 1.0]).clamp_zero()[0],
            0.0
        );
        let rgb = Rgb::new(0.1, 0.2, 0.3);
        let s = SampledSpectrum::from_rgb(rgb);
        assert_eq!(s.lanes(), [0.1, 0.2, 0.3, 0.2]);
        assert_eq!(s.to_rgb(), rgb);
        assert_eq!(
            SampledSpectrum::ZERO.lerp(SampledSpectrum::ONE, 0.25),
            SampledSpectrum::splat(0.25)
        );
        assert_eq!(std::mem::align_of::<SampledSpectrum>(), 16);
        assert_eq!(std::mem::size_of::<SampledSpectrum>(), 16);
    }
}
