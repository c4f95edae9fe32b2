//! `SampledWavelengths`: the four wavelengths a path carries, with their densities.
//!
//! # Sampling (hero wavelength, Wilkie et al. 2014, as pbrt-v4 and Mitsuba 3 do it)
//!
//! One uniform number `u` picks the hero wavelength λ₀ from the visible density
//! p(λ) ∝ 1/cosh²(0.0072 (λ − 538 nm)) on [360, 830] nm (pbrt-v4's `SampleVisibleWavelengths`,
//! Mitsuba's `sample_rgb_spectrum`; Radziszewski et al. 2009), by inverting its CDF in closed
//! form. The three others are at equal offsets of a quarter of the range from the hero,
//! wrapped around — offsets taken in the *primary sample* `u` (uᵢ = u + i/4 mod 1, each mapped
//! through the same inverse CDF), not in nanometres. That is where pbrt-v4's
//! `SampledWavelengths::SampleVisible` and Mitsuba's `sample_shifted` put them, and it is what
//! makes the per-lane densities below right: every lane is then distributed exactly by p, so
//! `pdf[i] = p(λᵢ)` and the estimator `(1/4) Σᵢ f(λᵢ)/p(λᵢ)` is unbiased, lane by lane.
//! (With a non-uniform p, offsets of 117.5 nm in λ would give lane i the density
//! p(λᵢ − i·117.5 nm wrapped), not p(λᵢ): dividing by p(λᵢ) would be biased, and the unbiased
//! alternative is Wilkie's balance heuristic, a common density (1/4) Σⱼ p(λⱼ) for all four
//! lanes. With the uniform density both coincide: [`SampledWavelengths::sample_uniform`]
//! offsets in nanometres.) The four wavelengths are therefore stratified in the CDF of p:
//! equally spaced where p is flat, closer where the eye is sensitive.
//!
//! # Densities are per lane
//!
//! [`SampledWavelengths::pdf`] holds each lane's own marginal density (per nm). A spectral
//! estimate of a quantity `f` carried in a [`SampledSpectrum`] is `mean over lanes of
//! f[i] / pdf[i]`, with lanes of density 0 contributing 0 (see
//! [`SampledSpectrum::safe_div`]).
//!
//! # Dispersion
//!
//! When a path refracts through an interface whose IOR depends on λ, the four wavelengths
//! would go four ways: [`SampledWavelengths::terminate_secondary`] keeps only the hero, sets
//! the other densities to 0 and divides the hero's by 4 (pbrt-v4's `TerminateSecondary`), so
//! the same estimator `mean(f / pdf)` now reads `f(λ₀)/p(λ₀)`, still unbiased.

use super::sampled::{SampledSpectrum, N_SPECTRUM_SAMPLES};
use super::{LAMBDA_MAX, LAMBDA_MIN};

/// −tanh(0.0072 (360 − 538)).
const VIS_T0: f32 = 0.856_910_6;
/// tanh(0.0072 (830 − 538)) − tanh(0.0072 (360 − 538)).
const VIS_SPAN: f32 = 1.827_502;
/// 0.0072 / VIS_SPAN: the normalisation of the visible density.
const VIS_NORM: f32 = 0.003_939_804;
/// The density's rate (per nm).
const VIS_RATE: f32 = 0.0072;
/// The density's centre (nm).
const VIS_CENTER: f32 = 538.0;

/// The visible-wavelength density (per nm): 0.0039398 / cosh²(0.0072 (λ − 538)) on
/// [360, 830] nm, 0 outside. It integrates to 1 over the range.
#[inline]
pub fn visible_wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (VIS_RATE * (lambda - VIS_CENTER)).cosh();
    VIS_NORM / (c * c)
}

/// The wavelength (nm) at which the CDF of [`visible_wavelength_pdf`] equals `u` ∈ [0, 1]:
/// λ = 538 + atanh(u·span − t₀)/0.0072, clamped to [360, 830] against rounding.
#[inline]
pub fn sample_visible_wavelength(u: f32) -> f32 {
    let l = VIS_CENTER + (u * VIS_SPAN - VIS_T0).atanh() * (1.0 / VIS_RATE);
    l.clamp(LAMBDA_MIN, LAMBDA_MAX)
}

/// The CDF of [`visible_wavelength_pdf`] at `lambda` (0 below 360 nm, 1 above 830 nm).
#[inline]
pub fn visible_wavelength_cdf(lambda: f32) -> f32 {
    let l = lambda.clamp(LAMBDA_MIN, LAMBDA_MAX);
    (((VIS_RATE * (l - VIS_CENTER)).tanh() + VIS_T0) / VIS_SPAN).clamp(0.0, 1.0)
}

/// Four wavelengths (nm) and their per-lane densities (per nm); lane 0 is the hero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    lambda: [f32; N_SPECTRUM_SAMPLES],
    pdf: [f32; N_SPECTRUM_SAMPLES],
}

impl SampledWavelengths {
    /// Hero-wavelength sampling from the visible density, the three others at offsets of ¼
    /// in `u` (see the module documentation). `u` ∈ [0, 1).
    pub fn sample_visible(u: f32) -> Self {
        let mut lambda = [0.0; 4];
        let mut pdf = [0.0; 4];
        for i in 0..N_SPECTRUM_SAMPLES {
            let mut up = u + i as f32 / N_SPECTRUM_SAMPLES as f32;
            if up >= 1.0 {
                up -= 1.0;
            }
            // x = tanh(0.0072 (λ − 538)) is linear in u: λ = 538 + atanh(x)/0.0072, and the
            // density 0.0039398/cosh² is 0.0039398 (1 − x²) (one logarithm per lane, no
            // hyperbolic functions).
            let x = (up * VIS_SPAN - VIS_T0).clamp(-1.0 + f32::EPSILON, 1.0 - f32::EPSILON);
            let l = VIS_CENTER + 0.5 * ((1.0 + x) / (1.0 - x)).ln() * (1.0 / VIS_RATE);
            lambda[i] = l.clamp(LAMBDA_MIN, LAMBDA_MAX);
            pdf[i] = VIS_NORM * (1.0 - x * x);
        }
        Self { lambda, pdf }
    }

    /// Uniform wavelengths on [360, 830] nm: the hero at `360 + u·470`, the others at offsets of
    /// 470/4 nm, wrapped (Wilkie et al.'s original scheme); every density 1/470.
    pub fn sample_uniform(u: f32) -> Self {
        let range = LAMBDA_MAX - LAMBDA_MIN;
        let mut lambda = [0.0; 4];
        lambda[0] = (LAMBDA_MIN + u * range).clamp(LAMBDA_MIN, LAMBDA_MAX);
        for i in 1..N_SPECTRUM_SAMPLES {
            let mut l = lambda[0] + i as f32 * range / N_SPECTRUM_SAMPLES as f32;
            if l > LAMBDA_MAX {
                l -= range;
            }
            lambda[i] = l;
        }
        Self {
            lambda,
            pdf: [1.0 / range; 4],
        }
    }

    /// Given wavelengths and densities (tests, deterministic renders at fixed wavelengths).
    pub fn new(lambda: [f32; N_SPECTRUM_SAMPLES], pdf: [f32; N_SPECTRUM_SAMPLES]) -> Self {
        Self { lambda, pdf }
    }

    /// The wavelength of lane `i` (nm).
    #[inline]
    pub fn lambda(&self, i: usize) -> f32 {
        self.lambda[i]
    }

    /// All four wavelengths (nm).
    #[inline]
    pub fn lambdas(&self) -> [f32; N_SPECTRUM_SAMPLES] {
        self.lambda
    }

    /// `f` at the four wavelengths (a plain loop, which inlines `f` into straight-line code).
    #[inline(always)]
    pub fn eval(&self, f: impl Fn(f32) -> f32) -> SampledSpectrum {
        let mut r = [0.0; N_SPECTRUM_SAMPLES];
        for i in 0..N_SPECTRUM_SAMPLES {
            r[i] = f(self.lambda[i]);
        }
        SampledSpectrum(r)
    }

    /// The wavelengths as a spectrum (e.g. to evaluate λ-dependent formulas lane-wise).
    #[inline]
    pub fn as_spectrum(&self) -> SampledSpectrum {
        SampledSpectrum(self.lambda)
    }

    /// The per-lane densities (per nm); 0 in terminated lanes.
    #[inline]
    pub fn pdf(&self) -> SampledSpectrum {
        SampledSpectrum(self.pdf)
    }

    /// Keeps only the hero wavelength (a dispersive refraction): the other lanes' densities
    /// become 0 and the hero's is divided by 4, so `mean(f / pdf)` stays unbiased. Idempotent.
    pub fn terminate_secondary(&mut self) {
        if self.secondary_terminated() {
            return;
        }
        for i in 1..N_SPECTRUM_SAMPLES {
            self.pdf[i] = 0.0;
        }
        self.pdf[0] /= N_SPECTRUM_SAMPLES as f32;
    }

    /// True once [`terminate_secondary`](Self::terminate_secondary) has run.
    #[inline]
    pub fn secondary_terminated(&self) -> bool {
        self.pdf[1..].iter().all(|&p| p == 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_match_their_definition() {
        let b = 0.0072f64;
        let t0 = -(b * (360.0 - 538.0)).tanh();
        let span = (b * (830.0 - 538.0)).tanh() + t0;
        assert!((VIS_T0 as f64 - t0).abs() < 1e-7);
        assert!((VIS_SPAN as f64 - span).abs() < 1e-7);
        assert!((VIS_NORM as f64 - b / span).abs() < 1e-10);
    }

    #[test]
    fn pdf_integrates_to_one_and_cdf_inverts() {
        // Midpoint rule at 0.01 nm.
        let n = 47_000;
        let h = 470.0 / n as f64;
        let sum: f64 = (0..n)
            .map(|i| visible_wavelength_pdf((360.0 + (i as f64 + 0.5) * h) as f32) as f64 * h)
            .sum();
        assert!((sum - 1.0).abs() < 1e-5, "{sum}");
        assert_eq!(visible_wavelength_pdf(359.0), 0.0);
        assert_eq!(visible_wavelength_pdf(831.0), 0.0);
        assert_eq!(sample_visible_wavelength(0.0), 360.0);
        assert!((sample_visible_wavelength(1.0) - 830.0).abs() < 0.05);
        for i in 0..=100 {
            let u = i as f32 / 100.0;
            let l = sample_visible_wavelength(u);
            assert!((360.0..=830.0).contains(&l));
            assert!((visible_wavelength_cdf(l) - u).abs() < 2e-5, "{u} {l}");
        }
    }

    #[test]
    fn lanes_and_termination() {
        let w = SampledWavelengths::sample_visible(0.3);
        for i in 0..4 {
            let u = (0.3 + i as f32 * 0.25) % 1.0;
            assert!((w.lambda(i) - sample_visible_wavelength(u)).abs() < 1e-3);
            let p = visible_wavelength_pdf(w.lambda(i));
            assert!((w.pdf()[i] - p).abs() <= 1e-5 * p, "{} {p}", w.pdf()[i]);
        }
        assert!(!w.secondary_terminated());
        let mut t = w;
        t.terminate_secondary();
        assert!(t.secondary_terminated());
        assert_eq!(t.pdf().lanes(), [w.pdf()[0] / 4.0, 0.0, 0.0, 0.0]);
        t.terminate_secondary();
        assert_eq!(t.pdf()[0], w.pdf()[0] / 4.0);

        let u = SampledWavelengths::sample_uniform(0.9);
        let l = u.lambdas();
        assert!((l[0] - 783.0).abs() < 1e-3);
        assert!((l[1] - (783.0 + 117.5 - 470.0)).abs() < 1e-3);
        assert!(l.iter().all(|x| (360.0..=830.0).contains(x)));
    }
}
