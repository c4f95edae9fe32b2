//! `Spectrum`: spectrum-valued scene data (a material's reflectance, an emitter's radiance, a
//! conductor's η and k), as one closed enum evaluated at sampled wavelengths.
//!
//! # Conversion to RGB ([`Spectrum::to_rgb`]), as Mitsuba 3's RGB variants do
//!
//! Mitsuba 3 (3.9.1) turns a spectrum into an RGB value when it loads a scene in an RGB
//! variant: `Properties::get_texture_impl` (`src/core/properties.cpp`) calls
//! `spectrum_list_to_srgb(wavelengths, values, bounded = !(emitter || unbounded), d65 =
//! !emitter)` (`src/core/spectrum.cpp`), and named conductors' measured η and k are read by
//! `ior_from_file` (`include/mitsuba/render/ior.h`) with `bounded = false, d65 = false`.
//! `spectrum_list_to_srgb` integrates the piecewise-linear spectrum (0 outside its samples)
//! times the CIE 1931 CMFs — times the Y-normalised D65 when `d65` — normalised by ∫ȳ, converts
//! XYZ to linear sRGB, and clamps to [0, 1] when `bounded`, else to ≥ 0. A uniform spectrum
//! stays a plain number, except on an emitter, where it becomes `value` times Mitsuba's colour of illuminant E
//! (the colour of the equal-energy spectrum, as Mitsuba's spectral variants render it). The
//! blackbody is not available in Mitsuba's RGB variants at all.
//!
//! [`RgbRole`] names these cases; every spectrum is integrated the same way (trapezoid rule on
//! the 1 nm CIE tables, in f64), so the colours agree with Mitsuba's to the accuracy of the two
//! quadratures (Mitsuba: its 5 nm CMF table, 1000 steps; ~1e-3 relative). RGB-defined spectra
//! return their RGB unchanged in every role (Mitsuba's `srgb` plugin in an RGB variant), and a
//! blackbody is integrated like any spectrum (the emission role then gives the colour its
//! spectral render has).

use super::blackbody::{planck, planck4};
use super::cie::{d65_normalized, integrate_xyz, xyz_to_linear_srgb_f64};
use super::rgb_spectra::{RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum};
use super::sampled::SampledSpectrum;
use super::tabulated::{SpectrumParseError, TabulatedSpectrum};
use super::wavelengths::SampledWavelengths;
use crate::color::Rgb;

/// What a spectrum stands for when it is converted to RGB (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RgbRole {
    /// A reflectance or transmittance (a bounded texture): its colour lit by D65 (Y = 1),
    /// clamped to [0, 1]. Mitsuba: `bounded = true, d65 = true`.
    Reflectance,
    /// Any other non-emitter texture value that may exceed 1 (e.g. a conductor's `eta`/`k`
    /// given as a `<spectrum>` list): lit by D65, clamped to ≥ 0. Mitsuba: `bounded = false,
    /// d65 = true`.
    Unbounded,
    /// Emitted radiance: the spectrum's own colour, clamped to ≥ 0; a constant `c` gives
    /// `c` times Mitsuba's colour of illuminant E. Mitsuba: `bounded = false, d65 = false`.
    Emission,
    /// A measured optical constant (named conductors' η, k from Mitsuba's `data/ior`): the
    /// spectrum's own colour, clamped to ≥ 0; a constant stays itself. Mitsuba's
    /// `ior_from_file`: `bounded = false, d65 = false`.
    OpticalConstant,
}

/// Spectrum-valued scene data.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength (Mitsuba's `uniform`).
    Constant(f32),
    /// An RGB reflectance in [0, 1]³, upsampled.
    RgbAlbedo(RgbAlbedoSpectrum),
    /// A non-negative RGB value, upsampled and scaled.
    RgbUnbounded(RgbUnboundedSpectrum),
    /// An RGB emitted radiance: upsampled, scaled, times D65 (Y = 1).
    RgbIlluminant(RgbIlluminantSpectrum),
    /// Piecewise linear over samples, 0 outside them.
    Tabulated(TabulatedSpectrum),
    /// `scale ×` Planck's law in W·m⁻²·sr⁻¹·nm⁻¹ (see [`planck`]; Mitsuba's `blackbody` has
    /// scale 1).
    Blackbody {
        /// Temperature (K).
        temperature: f32,
        /// Factor on Planck's law.
        scale: f32,
    },
}

impl Spectrum {
    /// A reflectance from RGB (clamped to [0, 1]³).
    pub fn rgb_albedo(rgb: Rgb) -> Self {
        Self::RgbAlbedo(RgbAlbedoSpectrum::new(rgb))
    }

    /// A non-negative value from RGB.
    pub fn rgb_unbounded(rgb: Rgb) -> Self {
        Self::RgbUnbounded(RgbUnboundedSpectrum::new(rgb))
    }

    /// An emitted radiance from RGB.
    pub fn rgb_illuminant(rgb: Rgb) -> Self {
        Self::RgbIlluminant(RgbIlluminantSpectrum::new(rgb))
    }

    /// A black body at `temperature` K, Planck's law times `scale`.
    pub fn blackbody(temperature: f32, scale: f32) -> Self {
        Self::Blackbody { temperature, scale }
    }

    /// Parses Mitsuba's `<spectrum value="…">`: one number (a constant) or a
    /// `"λ:value, …"` list.
    pub fn parse(text: &str) -> Result<Self, SpectrumParseError> {
        if !text.contains(':') {
            if let Ok(v) = text.trim().parse::<f32>() {
                if v.is_finite() {
                    return Ok(Self::Constant(v));
                }
            }
        }
        TabulatedSpectrum::parse_list(text).map(Self::Tabulated)
    }

    /// Parses the text of a spectrum file (`λ value` lines, `#` comments).
    pub fn parse_spd(text: &str) -> Result<Self, SpectrumParseError> {
        TabulatedSpectrum::parse_spd(text).map(Self::Tabulated)
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        match self {
            Self::Constant(c) => *c,
            Self::RgbAlbedo(s) => s.eval(lambda),
            Self::RgbUnbounded(s) => s.eval(lambda),
            Self::RgbIlluminant(s) => s.eval(lambda),
            Self::Tabulated(s) => s.eval(lambda),
            Self::Blackbody { temperature, scale } => scale * planck(lambda, *temperature),
        }
    }

    /// The values at four sampled wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Self::Constant(c) => SampledSpectrum::splat(*c),
            Self::RgbAlbedo(s) => s.eval4(lambda),
            Self::RgbUnbounded(s) => s.eval4(lambda),
            Self::RgbIlluminant(s) => s.eval4(lambda),
            Self::Tabulated(s) => s.eval4(lambda),
            Self::Blackbody { temperature, scale } => planck4(lambda, *temperature) * *scale,
        }
    }

    /// The linear sRGB colour that Mitsuba 3's RGB variants give this spectrum in `role`
    /// (see the module documentation).
    pub fn to_rgb(&self, role: RgbRole) -> Rgb {
        match self {
            Self::RgbAlbedo(s) => return s.rgb,
            Self::RgbUnbounded(s) => return s.rgb,
            Self::RgbIlluminant(s) => return s.rgb,
            Self::Constant(c) => {
                if role != RgbRole::Emission {
                    return Rgb::splat(*c);
                }
                return clamp(role, FLAT_EMISSION_RGB.map(|w| *c as f64 * w));
            }
            Self::Tabulated(_) | Self::Blackbody { .. } => {}
        }
        let lit = matches!(role, RgbRole::Reflectance | RgbRole::Unbounded);
        let xyz = integrate_xyz(|l| {
            let v = self.eval(l) as f64;
            if lit {
                v * d65_normalized(l) as f64
            } else {
                v
            }
        });
        clamp(role, xyz_to_linear_srgb_f64(xyz))
    }

    /// True when the value does not depend on the wavelength.
    pub fn is_constant(&self) -> bool {
        match self {
            Self::Constant(_) => true,
            Self::Tabulated(t) => t.is_constant(),
            _ => false,
        }
    }
}

/// The linear sRGB colour Mitsuba 3.9.1's RGB variants give an emitted flat (equal-energy)
/// spectrum of value 1 (illuminant E, not white: white is D65), as they compute it with their
/// own colour-matching tables; candela's integration of the same spectrum differs by ~3e-4.
const FLAT_EMISSION_RGB: [f64; 3] = [1.20479, 0.948291, 0.908916];

fn clamp(role: RgbRole, c: [f64; 3]) -> Rgb {
    let c = c.map(|v| {
        let v = v.max(0.0);
        if role == RgbRole::Reflectance {
            v.min(1.0)
        } else {
            v
        }
    });
    Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_forms() {
        assert_eq!(Spectrum::parse(" 0.5 ").unwrap(), Spectrum::Constant(0.5));
        let t = Spectrum::parse("400:0.2, 700:0.8").unwrap();
        assert!((t.eval(550.0) - 0.5).abs() < 1e-6);
        assert!(Spectrum::parse("inf").is_err());
        assert!(Spectrum::parse("red").is_err());
        assert!(Spectrum::parse_spd("400 1\n700 1\n").unwrap().is_constant());
    }

    #[test]
    fn constant_roles() {
        let c = Spectrum::Constant(0.5);
        assert_eq!(c.to_rgb(RgbRole::Reflectance), Rgb::splat(0.5));
        assert_eq!(c.to_rgb(RgbRole::OpticalConstant), Rgb::splat(0.5));
        // The equal-energy spectrum is purplish in sRGB.
        let e = c.to_rgb(RgbRole::Emission);
        assert!(e.r > 0.5 && e.g < 0.5 && e.b < 0.5, "{e:?}");
        // The same spectrum tabulated gives (nearly) the same colour by integration.
        let t = Spectrum::parse("360:0.5, 830:0.5").unwrap();
        let f = t.to_rgb(RgbRole::Emission);
        assert!(
            (f.r - e.r).abs() < 1e-3 && (f.b - e.b).abs() < 1e-3,
            "{f:?} {e:?}"
        );
        // A unit reflectance under D65 is white.
        let w = Spectrum::parse("360:1, 830:1")
            .unwrap()
            .to_rgb(RgbRole::Reflectance);
        assert!((w.r - 1.0).abs() < 1e-3 && (w.g - 1.0).abs() < 1e-3 && (w.b - 1.0).abs() < 1e-3);
    }

    #[test]
    fn rgb_variants_keep_their_rgb() {
        let c = Rgb::new(0.2, 0.4, 0.6);
        assert_eq!(Spectrum::rgb_albedo(c).to_rgb(RgbRole::Reflectance), c);
        assert_eq!(
            Spectrum::rgb_illuminant(c * 3.0).to_rgb(RgbRole::Emission),
            c * 3.0
        );
        assert_eq!(
            Spectrum::rgb_unbounded(c * 2.0).to_rgb(RgbRole::Unbounded),
            c * 2.0
        );
    }
}
