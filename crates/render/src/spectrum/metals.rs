//! Measured optical constants of conductors: the complex index of refraction η(λ) + i k(λ) of
//! every named metal that the Mitsuba import accepts (Mitsuba 3's `data/ior` tables; generated
//! into `metal_tables.rs` by `scripts/gen-metal-tables.py`).
//!
//! The spectra are piecewise linear over the measured samples and, as in Mitsuba's spectral
//! variants, 0 outside them (a few materials, e.g. `AlSb` up to 590 nm, `Se` up to 689 nm, are
//! not measured over the whole visible range). Their RGB values as Mitsuba's RGB variants use
//! them are `to_rgb(RgbRole::OpticalConstant)` (see [`RgbRole`](super::RgbRole)).

use super::data::Spectrum;
use super::metal_tables::METALS;
use super::tabulated::TabulatedSpectrum;

/// The measured (η, k) of the conductor `name` (Mitsuba's material names, case-sensitive:
/// `"Au"`, `"Cu_palik"`, `"a-C"`, …), `None` for an unknown name.
pub fn metal(name: &str) -> Option<(Spectrum, Spectrum)> {
    let (_, eta, k) = METALS.iter().find(|(n, ..)| *n == name)?;
    let spectrum = |s: &'static [(f32, f32)]| {
        Spectrum::Tabulated(TabulatedSpectrum::from_static(s).expect("generated table is valid"))
    };
    Some((spectrum(eta), spectrum(k)))
}

/// The names accepted by [`metal`], sorted.
pub fn metal_names() -> impl Iterator<Item = &'static str> {
    METALS.iter().map(|(n, ..)| *n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookups() {
        assert!(metal("Au").is_some());
        assert!(metal("au").is_none());
        assert!(metal("unobtainium").is_none());
        // Gold: k is larger in the red, η smaller (its yellow).
        let (eta, k) = metal("Au").unwrap();
        assert!(eta.eval(650.0) < eta.eval(450.0));
        assert!(k.eval(650.0) > k.eval(450.0));
        // Every table is valid and covers some of the visible range.
        for n in metal_names() {
            let (e, k) = metal(n).unwrap();
            for s in [e, k] {
                let Spectrum::Tabulated(t) = s else { panic!() };
                let (lo, hi) = t.range();
                assert!(lo <= 360.0 && hi > 560.0, "{n}: {lo}–{hi}");
            }
        }
    }
}
