//! Cook–Torrance (1982): a Lambertian base plus a microfacet specular lobe with a dielectric
//! Fresnel term.
//!
//! Scene syntax: `cook_torrance(kd, ks, roughness [, ior [, "beckmann"|"ggx"]])`, defaults
//! ior 1.5 and GGX; `roughness` is the microfacet α.
//!
//! f = k_d/π + k_s·D·G·F / (4 cos θo cos θi). Under the local model the specular term is the
//! same D·G·F/(4 cos θo cos θi) times (n·l), with no 1/π on the diffuse term
//! (scene-language.md §2b). Sampling picks the cosine lobe or the microfacet lobe in proportion
//! to k_d and k_s.

use super::conductor::{microfacet_lobe, microfacet_pdf};
use super::fresnel::{fresnel_dielectric, reflect};
use super::microfacet::Microfacet;
use super::sample::{reflection_sample, specular_probability, LocalSample};
use crate::math::{Vec3, INV_PI};
use crate::sampling::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::spectrum::SampledSpectrum;

/// A Cook–Torrance BRDF at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CookTorrance {
    /// Diffuse coefficient.
    pub kd: SampledSpectrum,
    /// Specular coefficient.
    pub ks: SampledSpectrum,
    /// The microfacet distribution.
    pub mf: Microfacet,
    /// Index of refraction of the Fresnel term.
    pub ior: f32,
}

impl CookTorrance {
    fn specular_probability(&self) -> f32 {
        specular_probability(self.kd, self.ks, 0.5)
    }

    /// D·G·F/(4 cos θo), the specular lobe times cos θi.
    fn specular(&self, wo: Vec3, wi: Vec3) -> f32 {
        match microfacet_lobe(&self.mf, wo, wi) {
            Some((v, h)) => v * fresnel_dielectric(wo.dot(h), self.ior).0,
            None => 0.0,
        }
    }

    /// f·cos θi.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.kd * (INV_PI * wi.z) + self.ks * self.specular(wo, wi)
    }

    /// The density of [`CookTorrance::sample`].
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability();
        ps * microfacet_pdf(&self.mf, wo, wi) + (1.0 - ps) * cosine_hemisphere_pdf(wi.z)
    }

    /// Picks a lobe, samples it, weights by the mixture density.
    pub fn sample(&self, wo: Vec3, u1: f32, u2: [f32; 2]) -> Option<LocalSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u1 < self.specular_probability() {
            reflect(wo, self.mf.sample(wo, u2))
        } else {
            square_to_cosine_hemisphere(u2)
        };
        reflection_sample(wi, self.pdf(wo, wi), self.eval(wo, wi))
    }

    /// The local model for one light: I_d·k_d·(n·l) + I_s·k_s·D·G·F/(4 cos θo cos θi)·(n·l).
    pub fn local(
        &self,
        wo: Vec3,
        wi: Vec3,
        id: SampledSpectrum,
        is: SampledSpectrum,
    ) -> SampledSpectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        id * self.kd * wi.z + is * self.ks * self.specular(wo, wi)
    }
}
