//! [`Wavelengths`]: what the four lanes of a path's [`SampledSpectrum`]s mean — RGB channels or
//! four sampled wavelengths — and how scene colours become such lanes.
//!
//! One hot path serves both modes. Materials, lights and integrators compute on four-lane
//! values lane by lane; only the places where a *colour of the scene* enters a path ask the
//! path's `Wavelengths` to turn it into lanes:
//!
//! | colour | RGB mode | spectral mode |
//! |---|---|---|
//! | reflectance `rgb` ∈ [0, 1]³ | `(r, g, b, g)` | Jakob–Hanika sigmoid at λ₀…λ₃ |
//! | other non-negative value | `(r, g, b, g)` | 2·max(rgb) × sigmoid of rgb / (2·max) |
//! | emitted `rgb` | `(r, g, b, g)` | the same × D65 (Y = 1) |
//! | a [`Spectrum`] (tabulated, blackbody, measured) | its RGB conversion | its values at λ₀…λ₃ |
//!
//! In RGB mode lane 3 repeats green, so that every lane holds a real channel (no lane-wise
//! operation meets 0/0 in an unused lane) and lane-wise maxima and minima are those of the RGB
//! triple; the film reads lanes 0–2. In spectral mode the film turns the path's radiance into
//! linear sRGB through the CIE 1931 observer ([`Wavelengths::to_rgb`]).

use super::cie::{to_xyz, xyz_to_linear_srgb};
use super::data::{RgbRole, Spectrum};
use super::rgb_sigmoid::RgbSigmoid;
use super::rgb_spectra::{RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum};
use super::sampled::SampledSpectrum;
use super::wavelengths::SampledWavelengths;
use crate::color::Rgb;

/// The meaning of a path's four lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Wavelengths {
    /// Lanes 0–2 are linear sRGB channels (lane 3 repeats green).
    Rgb,
    /// The lanes are the spectral quantity at four sampled wavelengths.
    Sampled(SampledWavelengths),
}

impl Wavelengths {
    /// The wavelengths of a spectral path from the uniform number `u` (hero-wavelength
    /// sampling over the visible range).
    #[inline]
    pub fn sample(u: f32) -> Self {
        Self::Sampled(SampledWavelengths::sample_visible(u))
    }

    /// The colour `c` in the role `role` (see the module documentation): upsampled at the
    /// sampled wavelengths in spectral mode, as is in RGB mode. A reflectance with a channel
    /// above 1 is upsampled as an unbounded value.
    /// (Per call, the upsampling is the table lookup alone, ~0.2 µs; scene constants are
    /// upsampled once, accurately, by [`upsample`] when the scene is prepared.)
    #[inline]
    pub fn colour(&self, c: Rgb, role: RgbRole) -> SampledSpectrum {
        match self {
            // Made whole in a register (see `SampledSpectrum::from_rgb_whole`): the colour
            // meets the other arm's result in memory, where a later whole load reads it.
            Self::Rgb => SampledSpectrum::from_rgb_whole(c),
            Self::Sampled(w) => upsample_fast(c, role, w),
        }
    }

    /// An emitted radiance (or intensity, irradiance) as lanes.
    #[inline]
    pub fn illuminant(&self, c: Rgb) -> SampledSpectrum {
        self.colour(c, RgbRole::Emission)
    }

    /// A spectrum as lanes: its values in spectral mode, `rgb` (its RGB conversion, computed
    /// when the scene was built) in RGB mode.
    #[inline]
    pub fn spectrum(&self, s: &Spectrum, rgb: Rgb) -> SampledSpectrum {
        match self {
            Self::Rgb => SampledSpectrum::from_rgb_whole(rgb),
            Self::Sampled(w) => s.eval4(w),
        }
    }

    /// The hero wavelength (nm) in spectral mode.
    #[inline]
    pub fn hero(&self) -> Option<f32> {
        match self {
            Self::Rgb => None,
            Self::Sampled(w) => Some(w.lambda(0)),
        }
    }

    /// Keeps only the hero wavelength (a dispersive interface); nothing in RGB mode.
    #[inline]
    pub fn terminate_secondary(&mut self) {
        if let Self::Sampled(w) = self {
            w.terminate_secondary();
        }
    }

    /// The film's linear sRGB estimate of the radiance `l` carried in these lanes: lanes 0–2
    /// in RGB mode; XYZ through the CIE 1931 observer, then sRGB (D65 white), in spectral mode.
    #[inline]
    pub fn to_rgb(&self, l: SampledSpectrum) -> Rgb {
        match self {
            Self::Rgb => l.to_rgb(),
            Self::Sampled(w) => xyz_to_linear_srgb(to_xyz(&l, w)),
        }
    }
}

/// [`upsample`] at four wavelengths, the coefficients from the table alone (no refinement).
#[inline(never)]
fn upsample_fast(c: Rgb, role: RgbRole, w: &SampledWavelengths) -> SampledSpectrum {
    upsample_with(c, role, RgbSigmoid::from_rgb_table).eval4(w)
}

/// The spectrum a colour stands for in `role` (accurate upsampling, ~10 µs: for scene
/// constants).
#[inline]
pub fn upsample(c: Rgb, role: RgbRole) -> Spectrum {
    upsample_with(c, role, RgbSigmoid::from_rgb)
}

/// The spectrum of colour `c` in `role`, its sigmoid fitted by `fit`: a reflectance in
/// [0, 1]³ as is, an emitter × D65, anything else scaled.
#[inline]
fn upsample_with(c: Rgb, role: RgbRole, fit: fn(Rgb) -> RgbSigmoid) -> Spectrum {
    match role {
        RgbRole::Reflectance if c.max_component() <= 1.0 => {
            Spectrum::RgbAlbedo(RgbAlbedoSpectrum::with_fit(c, fit))
        }
        RgbRole::Emission => Spectrum::RgbIlluminant(RgbIlluminantSpectrum::with_fit(c, fit)),
        _ => Spectrum::RgbUnbounded(RgbUnboundedSpectrum::with_fit(c, fit)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb_mode_keeps_colours() {
        let c = Rgb::new(0.2, 0.5, 0.9);
        let l = Wavelengths::Rgb.colour(c, RgbRole::Reflectance);
        assert_eq!(l.lanes(), [0.2, 0.5, 0.9, 0.5]);
        assert_eq!(Wavelengths::Rgb.to_rgb(l), c);
        assert_eq!(Wavelengths::Rgb.illuminant(c).to_rgb(), c);
    }

    #[test]
    fn spectral_mode_upsamples_by_role() {
        let w = Wavelengths::sample(0.37);
        let Wavelengths::Sampled(s) = w else {
            unreachable!()
        };
        // Per call the table alone is used: within its interpolation error (~1e-3) of the
        // refined spectra.
        let close = |a: SampledSpectrum, b: SampledSpectrum, scale: f32| {
            (0..4).all(|i| (a[i] - b[i]).abs() <= 5e-3 * scale)
        };
        let c = Rgb::new(0.2, 0.5, 0.9);
        assert!(close(
            w.colour(c, RgbRole::Reflectance),
            RgbAlbedoSpectrum::new(c).eval4(&s),
            1.0
        ));
        assert!(close(
            w.illuminant(c),
            RgbIlluminantSpectrum::new(c).eval4(&s),
            2.0
        ));
        let big = Rgb::new(2.0, 1.0, 0.5);
        assert!(close(
            w.colour(big, RgbRole::Reflectance),
            RgbUnboundedSpectrum::new(big).eval4(&s),
            4.0
        ));
        let mut t = w;
        t.terminate_secondary();
        assert_eq!(t.hero(), w.hero());
        assert!(matches!(t, Wavelengths::Sampled(s) if s.secondary_terminated()));
    }
}
