//! Indices of refraction of dielectrics, constant or varying with wavelength (dispersion).
//!
//! - Cauchy: n(λ) = A + B / λ², λ in µm (B in µm²).
//! - Sellmeier: n²(λ) = 1 + Σᵢ Bᵢ λ² / (λ² − Cᵢ), λ in µm (Cᵢ in µm²), with named glasses from
//!   their manufacturers' data sheets ([`Ior::glass`]).
//! - Tabulated: piecewise linear in λ (nm), holding the end values outside the samples.
//!
//! A path that refracts through a dispersive interface must keep only its hero wavelength
//! ([`SampledWavelengths::terminate_secondary`]).

use super::sampled::SampledSpectrum;
use super::tabulated::TabulatedSpectrum;
use super::wavelengths::SampledWavelengths;

/// Named glasses: (names, Sellmeier B, Sellmeier C in µm²), with the published digits.
#[allow(clippy::excessive_precision)]
const GLASSES: &[(&[&str], [f32; 3], [f32; 3])] = &[
    // SCHOTT N-BK7 (borosilicate crown), data sheet: n_d = 1.51680, V_d = 64.17.
    (
        &["bk7", "n-bk7"],
        [1.039_612_1, 0.231_792_34, 1.010_469_5],
        [0.006_000_698_7, 0.020_017_914, 103.560_65],
    ),
    // Fused silica (fused quartz), Malitson 1965: n_d = 1.4585, V_d = 67.8.
    (
        &["fused silica", "fused quartz"],
        [0.696_166_3, 0.407_942_6, 0.897_479_4],
        [0.004_679_148_3, 0.013_512_063, 97.934_003],
    ),
    // SCHOTT N-SF11 (dense flint), data sheet: n_d = 1.78472, V_d = 25.68.
    (
        &["sf11", "n-sf11"],
        [1.737_597, 0.313_747_35, 1.898_781],
        [0.013_188_707, 0.062_306_814, 155.236_29],
    ),
    // SCHOTT F2 (flint), data sheet: n_d = 1.62004, V_d = 36.37.
    (
        &["f2"],
        [1.345_333_6, 0.209_073_18, 0.937_357_16],
        [0.009_977_438_7, 0.047_045_077, 111.886_76],
    ),
];

/// An index of refraction as a function of wavelength.
#[derive(Clone, Debug, PartialEq)]
pub enum Ior {
    /// The same at every wavelength.
    Constant(f32),
    /// Cauchy's equation n = a + b/λ², λ in µm.
    Cauchy {
        /// A (dimensionless).
        a: f32,
        /// B (µm²).
        b: f32,
    },
    /// Sellmeier's equation n² = 1 + Σ bᵢ λ²/(λ² − cᵢ), λ in µm.
    Sellmeier {
        /// Bᵢ (dimensionless).
        b: [f32; 3],
        /// Cᵢ (µm²).
        c: [f32; 3],
    },
    /// Piecewise linear over (λ in nm, n), the end values held outside.
    Tabulated(TabulatedSpectrum),
}

impl Ior {
    /// The named glass (case-insensitive): `"bk7"`/`"n-bk7"`, `"fused silica"`/`"fused
    /// quartz"`, `"sf11"`/`"n-sf11"`, `"f2"`.
    pub fn glass(name: &str) -> Option<Ior> {
        let lower = name.trim().to_ascii_lowercase();
        GLASSES
            .iter()
            .find(|(names, ..)| names.contains(&lower.as_str()))
            .map(|&(_, b, c)| Ior::Sellmeier { b, c })
    }

    /// The names accepted by [`glass`](Self::glass).
    pub fn glass_names() -> impl Iterator<Item = &'static str> {
        GLASSES.iter().flat_map(|(names, ..)| names.iter().copied())
    }

    /// The index at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        match self {
            Ior::Constant(n) => *n,
            Ior::Cauchy { a, b } => {
                let l = lambda * 1e-3;
                a + b / (l * l)
            }
            Ior::Sellmeier { b, c } => {
                let l2 = (lambda * 1e-3) * (lambda * 1e-3);
                let mut n2 = 1.0;
                for i in 0..3 {
                    n2 += b[i] * l2 / (l2 - c[i]);
                }
                n2.max(0.0).sqrt()
            }
            Ior::Tabulated(t) => t.eval_clamped(lambda),
        }
    }

    /// The indices at four wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        lambda.eval(|l| self.eval(l))
    }

    /// True when the index depends on the wavelength (a refraction must then terminate the
    /// secondary wavelengths).
    pub fn is_dispersive(&self) -> bool {
        match self {
            Ior::Constant(_) => false,
            Ior::Cauchy { b, .. } => *b != 0.0,
            Ior::Sellmeier { b, .. } => b.iter().any(|&v| v != 0.0),
            Ior::Tabulated(t) => !t.is_constant(),
        }
    }

    /// The Abbe number V_d = (n_d − 1) / (n_F − n_C) (d: 587.56 nm, F: 486.13 nm, C: 656.27 nm):
    /// the lower, the more dispersive; infinite for a constant index.
    pub fn abbe_number(&self) -> f32 {
        let (d, f, c) = (self.eval(587.56), self.eval(486.13), self.eval(656.27));
        (d - 1.0) / (f - c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glasses_match_their_catalogue() {
        for (name, nd, vd) in [
            ("BK7", 1.5168, 64.17),
            ("fused silica", 1.4585, 67.8),
            ("Fused Quartz", 1.4585, 67.8),
            ("N-SF11", 1.78472, 25.68),
            ("F2", 1.62004, 36.37),
        ] {
            let g = Ior::glass(name).unwrap();
            assert!(g.is_dispersive());
            assert!(
                (g.eval(587.56) - nd).abs() < 1e-4,
                "{name}: {}",
                g.eval(587.56)
            );
            assert!(
                (g.abbe_number() - vd).abs() < 0.1,
                "{name}: {}",
                g.abbe_number()
            );
            // Normal dispersion: blue bends more.
            assert!(g.eval(450.0) > g.eval(650.0));
        }
        assert!(Ior::glass("unobtainium").is_none());
        assert_eq!(Ior::glass_names().count(), 7);
    }

    #[test]
    fn forms() {
        let c = Ior::Cauchy {
            a: 1.5046,
            b: 0.0042,
        };
        // λ = 0.5 µm: 1.5046 + 0.0042 / 0.25.
        assert!((c.eval(500.0) - 1.5214).abs() < 1e-5);
        assert!(c.is_dispersive());
        assert!(!Ior::Cauchy { a: 1.5, b: 0.0 }.is_dispersive());
        assert!(!Ior::Constant(1.5).is_dispersive());
        assert_eq!(Ior::Constant(1.5).eval(400.0), 1.5);
        assert!(Ior::Constant(1.5).abbe_number().is_infinite());
        let t = Ior::Tabulated(TabulatedSpectrum::parse_list("400:1.6, 700:1.5").unwrap());
        assert!(t.is_dispersive());
        assert_eq!(t.eval(300.0), 1.6);
        assert_eq!(t.eval(800.0), 1.5);
        assert!((t.eval(550.0) - 1.55).abs() < 1e-6);
        let w = SampledWavelengths::new([400.0, 500.0, 600.0, 700.0], [1.0; 4]);
        assert_eq!(t.eval4(&w)[3], 1.5);
    }
}
