//! Planck's law: the spectral radiance of a black body.
//!
//! # Normalisation (as Mitsuba 3)
//!
//! Mitsuba 3's `blackbody` spectrum (`src/spectra/blackbody.cpp`, 3.9.1) is *not* normalised:
//! it is Planck's spectral radiance in absolute units, W·m⁻²·sr⁻¹·nm⁻¹
//! (`1e-9 · 2hc² / (λ⁵ (exp(hc / (λ k T)) − 1))` with λ in metres), zero outside its
//! wavelength range (360–830 nm by default), with CODATA 2014 constants
//! (h = 6.62607004e-34 J·s, c = 2.99792458e8 m/s, k = 1.38064852e-23 J/K). Its documentation
//! says that this puts physical units into the scene (model it in metres); it is only
//! available in spectral variants. [`planck`] is that function, with the same constants; the
//! scene-level [`Spectrum::Blackbody`](super::Spectrum::Blackbody) multiplies it by a `scale`
//! (1 to match Mitsuba). (pbrt-v4 instead divides by the peak value, Wien's λ_max = b/T:
//! [`planck_peak`] gives that factor.)
//!
//! For reference, a 6500 K black body has luminance Y ≈ 4.2e4 in these units (∫B ȳ dλ / ∫ȳ dλ;
//! its peak ≈ 4.7e4 W·m⁻²·sr⁻¹·nm⁻¹ at 446 nm).

use super::sampled::SampledSpectrum;
use super::wavelengths::SampledWavelengths;
use super::{LAMBDA_MAX, LAMBDA_MIN};

/// Planck's constant (J·s), CODATA 2014 as Mitsuba 3.
pub const PLANCK_H: f64 = 6.626_070_04e-34;
/// The speed of light (m/s).
pub const LIGHT_SPEED: f64 = 2.997_924_58e8;
/// Boltzmann's constant (J/K), CODATA 2014 as Mitsuba 3.
pub const BOLTZMANN_K: f64 = 1.380_648_52e-23;
/// Wien's displacement constant (m·K).
pub const WIEN_B: f64 = 2.897_771_96e-3;

/// 2hc² scaled for λ in nm and radiance per nm: 2hc² · 1e45 · 1e-9.
const C0_NM: f64 = 2.0 * PLANCK_H * LIGHT_SPEED * LIGHT_SPEED * 1e36;
/// hc/k in nm·K.
const C1_NM: f64 = PLANCK_H * LIGHT_SPEED / BOLTZMANN_K * 1e9;

/// Planck's spectral radiance of a black body at `temperature` K and `lambda` nm, in
/// W·m⁻²·sr⁻¹·nm⁻¹ (Mitsuba 3's `blackbody`); 0 outside 360–830 nm and for T ≤ 0.
#[inline]
pub fn planck(lambda: f32, temperature: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    planck_unbounded(lambda as f64, temperature as f64) as f32
}

/// Planck's law at any wavelength (nm), in f64 (W·m⁻²·sr⁻¹·nm⁻¹).
pub fn planck_unbounded(lambda: f64, temperature: f64) -> f64 {
    if !(temperature > 0.0) || !(lambda > 0.0) {
        return 0.0;
    }
    let l5 = lambda.powi(5);
    C0_NM / (l5 * (C1_NM / (lambda * temperature)).exp_m1())
}

/// Planck's law at four wavelengths (0 outside 360–830 nm).
#[inline]
pub fn planck4(lambda: &SampledWavelengths, temperature: f32) -> SampledSpectrum {
    lambda.eval(|l| planck(l, temperature))
}

/// The peak value of Planck's law over all wavelengths, at Wien's λ_max = b/T (pbrt-v4
/// normalises its blackbody by it).
pub fn planck_peak(temperature: f32) -> f32 {
    let t = temperature as f64;
    if !(t > 0.0) {
        return 0.0;
    }
    planck_unbounded(WIEN_B / t * 1e9, t) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values() {
        // Hand value: 6500 K at 500 nm. x = hc/(λkT) = 1.438777e7 / (500·6500) = 4.42700;
        // B = 1.1910429e20 / (500⁵ (e^x − 1)) = 1.1910429e20 / (3.125e13 · 82.684) = 4.6094e4.
        let b = planck(500.0, 6500.0);
        assert!((b / 4.6094e4 - 1.0).abs() < 1e-3, "{b}");
        assert_eq!(planck(300.0, 6500.0), 0.0);
        assert_eq!(planck(500.0, 0.0), 0.0);
        assert_eq!(planck(500.0, 100.0), 0.0); // underflows to 0, not NaN
                                               // The peak is at Wien's wavelength and is a maximum.
        let t = 5000.0;
        let lp = (WIEN_B / t as f64 * 1e9) as f32;
        let p = planck_peak(t);
        assert!(planck_unbounded(lp as f64 * 1.01, t as f64) < p as f64);
        assert!(planck_unbounded(lp as f64 * 0.99, t as f64) < p as f64);
    }
}
