//! Rough conductors: the microfacet reflection F·D·G / (4 cos θo cos θi) with the conductor
//! Fresnel term (Mitsuba `roughconductor`: `distribution` (beckmann), `alpha` (0.1), `eta`, `k`
//! or `material`, `specular_reflectance`). With a dielectric Fresnel term and a diffuse base, the
//! same lobe gives the Cook–Torrance model (see `cook_torrance.rs`). The path tracer's lanes
//! repeat the GGX lobe, density and sample operation for operation
//! (`integrator/path/microfacet_lanes.rs`): change both.

use super::fresnel::{fresnel_conductor, reflect};
use super::microfacet::Microfacet;
use super::sample::LocalSample;
use crate::math::Vec3;
use crate::spectrum::SampledSpectrum;

/// The Fresnel term of a conductor, or 1 for the ideal (`material="none"`) one.
#[inline]
pub fn conductor_fresnel(
    c: Option<(SampledSpectrum, SampledSpectrum)>,
    cos: f32,
) -> SampledSpectrum {
    match c {
        Some((eta, k)) => fresnel_conductor(cos, eta, k),
        None => SampledSpectrum::ONE,
    }
}

/// D·G / (4 cos θo) for the pair (the specular lobe without Fresnel, cosine of wi included), and
/// the half vector: [`microfacet_lobe_pdf`]'s first half, bit for bit.
#[inline]
pub fn microfacet_lobe(mf: &Microfacet, wo: Vec3, wi: Vec3) -> Option<(f32, Vec3)> {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return None;
    }
    let h = (wo + wi).normalize();
    let d = mf.d(h);
    let g1o = mf.g1(wo, h);
    let v = d * g1o / (4.0 * wo.z) * mf.g1(wi, h);
    (v > 0.0 && v.is_finite()).then_some((v, h))
}

/// The density of reflecting about a sampled microfacet normal: p(m) / (4 |wo·m|):
/// [`microfacet_lobe_pdf`]'s second half, bit for bit.
#[inline]
pub fn microfacet_pdf(mf: &Microfacet, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize();
    let cos_oh = wo.dot(h);
    if cos_oh <= 0.0 {
        return 0.0;
    }
    mf.d(h) * mf.g1(wo, h) / (4.0 * wo.z)
}

/// [`microfacet_lobe`] and [`microfacet_pdf`] of one pair at once, sharing the half vector h,
/// D(h) and G1(wo, h). With visible normals the density is D(h)·G1(wo, h) / (4 cos θo)
/// (wo·h cancels), and the lobe is that times G1(wi, h).
#[inline]
pub fn microfacet_lobe_pdf(mf: &Microfacet, wo: Vec3, wi: Vec3) -> (Option<(f32, Vec3)>, f32) {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return (None, 0.0);
    }
    let h = (wo + wi).normalize();
    let d = mf.d(h);
    let g1o = mf.g1(wo, h);
    let cos_oh = wo.dot(h);
    let pdf = d * g1o / (4.0 * wo.z);
    let v = pdf * mf.g1(wi, h);
    let lobe = (v > 0.0 && v.is_finite()).then_some((v, h));
    (lobe, if cos_oh <= 0.0 { 0.0 } else { pdf })
}

/// f·cos θi.
pub fn eval(
    mf: &Microfacet,
    c: Option<(SampledSpectrum, SampledSpectrum)>,
    r: SampledSpectrum,
    wo: Vec3,
    wi: Vec3,
) -> SampledSpectrum {
    value(c, r, wo, microfacet_lobe(mf, wo, wi))
}

/// [`eval`] and [`microfacet_pdf`] of one pair at once, sharing the microfacet terms
/// ([`microfacet_lobe_pdf`]): the same numbers, bit for bit.
pub fn eval_pdf(
    mf: &Microfacet,
    c: Option<(SampledSpectrum, SampledSpectrum)>,
    r: SampledSpectrum,
    wo: Vec3,
    wi: Vec3,
) -> (SampledSpectrum, f32) {
    let (lobe, pdf) = microfacet_lobe_pdf(mf, wo, wi);
    (value(c, r, wo, lobe), pdf)
}

/// f·cos θi given the lobe at the pair ([`microfacet_lobe`]).
#[inline(always)]
fn value(
    c: Option<(SampledSpectrum, SampledSpectrum)>,
    r: SampledSpectrum,
    wo: Vec3,
    lobe: Option<(f32, Vec3)>,
) -> SampledSpectrum {
    match lobe {
        Some((v, h)) => r * conductor_fresnel(c, wo.dot(h)) * v,
        None => SampledSpectrum::ZERO,
    }
}

/// Samples a microfacet normal and reflects about it.
pub fn sample(
    mf: &Microfacet,
    c: Option<(SampledSpectrum, SampledSpectrum)>,
    r: SampledSpectrum,
    wo: Vec3,
    u: [f32; 2],
) -> Option<LocalSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let m = mf.sample(wo, u);
    let wi = reflect(wo, m);
    // Visible normals: the density D(m)·G1(wo, m) / (4 cos θo) and the weight
    // f·cos θi / pdf = r·F(wo·m)·G1(wi, m), from the sampled normal itself.
    if wi.z <= 0.0 {
        return None;
    }
    let g1i = mf.g1(wi, m);
    let pdf = mf.d(m) * mf.g1(wo, m) / (4.0 * wo.z);
    (pdf > 0.0 && g1i > 0.0).then(|| LocalSample {
        wi,
        weight: r * conductor_fresnel(c, wo.dot(m)) * g1i,
        pdf,
        delta: false,
        eta: 1.0,
    })
}
