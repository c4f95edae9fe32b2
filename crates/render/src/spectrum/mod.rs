//! Spectral quantities for rendering with radiance per wavelength (issue 16): the per-ray
//! four-lane [`SampledSpectrum`] and the [`SampledWavelengths`] it is sampled at, the CIE 1931
//! observer and D65 ([`cie`]), RGB → spectrum upsampling ([`RgbSigmoid`] and the
//! [`RgbAlbedoSpectrum`], [`RgbUnboundedSpectrum`], [`RgbIlluminantSpectrum`] built on it),
//! spectrum-valued scene data ([`Spectrum`]: constant, RGB, tabulated, blackbody), measured
//! conductor constants ([`metal`]) and dispersive indices of refraction ([`Ior`]).
//!
//! Everything covers the visible range [`LAMBDA_MIN`]–[`LAMBDA_MAX`] (360–830 nm, the range of
//! the CIE tables; Mitsuba 3 and pbrt-v4 use the same).
//!
//! # How a spectral estimate becomes a pixel
//!
//! A path samples `SampledWavelengths::sample_visible(u)`, carries its throughput and radiance
//! as `SampledSpectrum`s evaluated at those wavelengths (`Spectrum::eval4`, …), and the film
//! turns the radiance `L` into colour with `xyz_to_linear_srgb(to_xyz(&L, &lambda))`. That is
//! an unbiased estimate of the colour of the spectral radiance: XYZ = ∫ L (x̄, ȳ, z̄) dλ / ∫ ȳ dλ,
//! then the sRGB matrix. A unit reflectance lit by an RGB white emitter (D65, Y = 1) gives
//! (1, 1, 1); an RGB emitter gives back its RGB; an RGB reflectance gives back its RGB under
//! white light.
//!
//! Generated data: `cie_tables.rs` (`scripts/gen-cie-tables.py`), `metal_tables.rs`
//! (`scripts/gen-metal-tables.py`), `srgb_sigmoid.bin` (`examples/gen_rgb_to_spectrum.rs`).

mod blackbody;
pub mod cie;
mod cie_tables;
mod data;
mod ior;
mod metal_tables;
mod metals;
mod mode;
mod rgb_sigmoid;
mod rgb_spectra;
mod sampled;
mod tabulated;
mod wavelengths;

pub use blackbody::{planck, planck4, planck_peak, planck_unbounded};
pub use cie::{
    cie_xyz, cie_y, d65, d65_normalized, integrate_xyz, linear_srgb_to_xyz, to_xyz,
    xyz_to_linear_srgb, xyz_to_linear_srgb_f64, CIE_Y_NORMALIZER,
};
pub use cie_tables::D65_LUMINANCE;
pub use data::{RgbRole, Spectrum};
pub use ior::Ior;
pub use metals::{metal, metal_names};
pub use mode::{upsample, Wavelengths};
pub use rgb_sigmoid::{sigmoid, table_resolution, table_z_node, RgbSigmoid, TABLE_MAGIC};
pub use rgb_spectra::{RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum};
pub use sampled::{SampledSpectrum, N_SPECTRUM_SAMPLES};
pub use tabulated::{SpectrumParseError, TabulatedSpectrum};
pub use wavelengths::{
    sample_visible_wavelength, visible_wavelength_cdf, visible_wavelength_pdf, SampledWavelengths,
};

/// The shortest wavelength of the visible range (nm).
pub const LAMBDA_MIN: f32 = 360.0;
/// The longest wavelength of the visible range (nm).
pub const LAMBDA_MAX: f32 = 830.0;
