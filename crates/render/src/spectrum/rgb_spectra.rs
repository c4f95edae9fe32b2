//! Spectra of RGB colours: reflectances, unbounded values and emitters, built on the
//! sigmoid-polynomial upsampling of [`RgbSigmoid`].
//!
//! | type | for | spectrum | its colour |
//! |---|---|---|---|
//! | [`RgbAlbedoSpectrum`] | reflectances, transmittances ∈ [0, 1]³ | S(λ) ∈ [0, 1] | `rgb` as a reflectance under D65 |
//! | [`RgbUnboundedSpectrum`] | any non-negative value (e.g. scaled albedo, IOR as RGB) | m·S(λ) | idem |
//! | [`RgbIlluminantSpectrum`] | emitted radiance | m·S(λ)·D65ₙ(λ) | `rgb` as seen by the film |
//!
//! (m = 2·max(rgb), S the sigmoid of `rgb / m`, whose largest channel is ½: a colour in the
//! middle of the table, which gives smooth spectra; pbrt-v4's `RGBUnboundedSpectrum` and
//! Mitsuba 3's `d65` plugin do the same.)
//!
//! # Emitter normalisation
//!
//! D65ₙ is the CIE D65 illuminant divided by its luminance ([`d65_normalized`]), so that its
//! Y is 1 and, with the sRGB matrix, its colour is white (1, 1, 1) (to 1e-4: the tabulated
//! D65's chromaticity is (0.31273, 0.32902), sRGB's white (0.3127, 0.3290)). Because the
//! sigmoid of `rgb/m` was fitted to have the colour `rgb/m` as a reflectance under exactly this
//! D65ₙ, the film's estimate `xyz_to_linear_srgb(to_xyz(L))` of the emitted
//! `L = m·S·D65ₙ` converges to m·(rgb/m) = `rgb`: an RGB emitter rendered spectrally gives back
//! its RGB, and a white (1, 1, 1) emitter emits exactly D65ₙ (S of grey ½ is the constant ½).
//! This is Mitsuba 3's convention for RGB emitters in its spectral variants
//! (`src/spectra/d65.cpp`: `scale = 2·max(color)`, the sRGB model of `color / scale`, times
//! `d65_table · MI_CIE_D65_NORMALIZATION`).

use super::cie::d65_normalized;
use super::rgb_sigmoid::RgbSigmoid;
use super::sampled::SampledSpectrum;
use super::wavelengths::SampledWavelengths;
use crate::color::Rgb;

/// A reflectance from an RGB colour in [0, 1]³ (channels clamped): S(λ) ∈ [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbAlbedoSpectrum {
    /// The colour (clamped to [0, 1]³).
    pub rgb: Rgb,
    /// The upsampled spectrum.
    pub sigmoid: RgbSigmoid,
}

impl RgbAlbedoSpectrum {
    /// The reflectance of colour `rgb` (clamped to [0, 1]³).
    pub fn new(rgb: Rgb) -> Self {
        Self::with_fit(rgb, RgbSigmoid::from_rgb)
    }

    /// [`new`](Self::new) with the sigmoid coefficients fitted by `fit` (accurate, or the
    /// table alone: [`RgbSigmoid::from_rgb_table`]).
    pub fn with_fit(rgb: Rgb, fit: fn(Rgb) -> RgbSigmoid) -> Self {
        let rgb = rgb.map(|v| if v > 0.0 { v.min(1.0) } else { 0.0 });
        Self {
            rgb,
            sigmoid: fit(rgb),
        }
    }

    /// The value at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.sigmoid.eval(lambda)
    }

    /// The values at four wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        self.sigmoid.eval4(lambda)
    }
}

/// The colour with negative, NaN and infinite channels set to 0; `scale` = 2·max of it; the
/// sigmoid of `rgb / scale` (scale 0 for black).
fn scaled(rgb: Rgb, fit: fn(Rgb) -> RgbSigmoid) -> (Rgb, f32, RgbSigmoid) {
    let rgb = rgb.map(|v| if v > 0.0 && v.is_finite() { v } else { 0.0 });
    let m = rgb.max_component();
    if !(m > 0.0) {
        return (rgb, 0.0, RgbSigmoid::constant(0.0));
    }
    let scale = 2.0 * m;
    (rgb, scale, fit(rgb * (1.0 / scale)))
}

/// A non-negative spectrum from any non-negative RGB: `scale · S(λ)`, scale = 2·max(rgb)
/// (negative channels count as 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbUnboundedSpectrum {
    /// The colour (negative and non-finite channels set to 0).
    pub rgb: Rgb,
    /// 2·max(rgb).
    pub scale: f32,
    /// The upsampled `rgb / scale`.
    pub sigmoid: RgbSigmoid,
}

impl RgbUnboundedSpectrum {
    /// The spectrum of colour `rgb`.
    pub fn new(rgb: Rgb) -> Self {
        Self::with_fit(rgb, RgbSigmoid::from_rgb)
    }

    /// [`new`](Self::new) with the sigmoid coefficients fitted by `fit` (accurate, or the
    /// table alone: [`RgbSigmoid::from_rgb_table`]).
    pub fn with_fit(rgb: Rgb, fit: fn(Rgb) -> RgbSigmoid) -> Self {
        let (rgb, scale, sigmoid) = scaled(rgb, fit);
        Self {
            rgb,
            scale,
            sigmoid,
        }
    }

    /// The value at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.scale * self.sigmoid.eval(lambda)
    }

    /// The values at four wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        self.sigmoid.eval4(lambda) * self.scale
    }
}

/// An emission spectrum from an RGB radiance: `scale · S(λ) · D65ₙ(λ)` (see the module
/// documentation for why its spectral render is `rgb`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbIlluminantSpectrum {
    /// The colour (negative and non-finite channels set to 0).
    pub rgb: Rgb,
    /// 2·max(rgb).
    pub scale: f32,
    /// The upsampled `rgb / scale`.
    pub sigmoid: RgbSigmoid,
}

impl RgbIlluminantSpectrum {
    /// The emission of RGB radiance `rgb` (negative channels count as 0).
    pub fn new(rgb: Rgb) -> Self {
        Self::with_fit(rgb, RgbSigmoid::from_rgb)
    }

    /// [`new`](Self::new) with the sigmoid coefficients fitted by `fit` (accurate, or the
    /// table alone: [`RgbSigmoid::from_rgb_table`]).
    pub fn with_fit(rgb: Rgb, fit: fn(Rgb) -> RgbSigmoid) -> Self {
        let (rgb, scale, sigmoid) = scaled(rgb, fit);
        Self {
            rgb,
            scale,
            sigmoid,
        }
    }

    /// The value at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.scale * self.sigmoid.eval(lambda) * d65_normalized(lambda)
    }

    /// The values at four wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        self.sigmoid.eval4(lambda) * super::cie::d65_normalized4(lambda) * self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales() {
        let u = RgbUnboundedSpectrum::new(Rgb::new(4.0, 2.0, 1.0));
        assert_eq!(u.scale, 8.0);
        assert!(u.eval(700.0) > u.eval(450.0));
        let b = RgbUnboundedSpectrum::new(Rgb::new(-1.0, 0.0, f32::NAN));
        assert_eq!(b.scale, 0.0);
        assert_eq!(b.eval(500.0), 0.0);
        // White light is D65 with Y = 1: S(grey ½) = ½, scale 2.
        let w = RgbIlluminantSpectrum::new(Rgb::WHITE);
        for l in [380.0, 500.0, 560.0, 700.0] {
            assert!((w.eval(l) - d65_normalized(l)).abs() < 1e-6);
        }
        let a = RgbAlbedoSpectrum::new(Rgb::new(2.0, 2.0, 2.0));
        assert_eq!(a.eval(500.0), 1.0);
    }
}
