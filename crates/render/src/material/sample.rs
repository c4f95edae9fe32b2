//! What sampling a BSDF returns, in the local shading frame ([`LocalSample`]) and in the world
//! ([`BsdfSample`]), and the helpers the two-lobe models share to build local samples.

use crate::math::Vec3;
use crate::spectrum::SampledSpectrum;

/// A sampled direction in the local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalSample {
    /// The sampled incident direction (local frame).
    pub wi: Vec3,
    /// f·|cos θi| / pdf.
    pub weight: SampledSpectrum,
    /// The density (the discrete probability for Dirac deltas).
    pub pdf: f32,
    /// The sample comes from a Dirac delta.
    pub delta: bool,
    /// The relative index of refraction crossed (1 for reflection).
    pub eta: f32,
}

/// The probability of sampling the specular lobe of a two-lobe model: in proportion to the mean
/// specular and diffuse coefficients, each weighted by the share of light that reaches its lobe
/// (`share` for the specular one, e.g. a coating's reflectance; ½ when both see all the light).
pub(crate) fn specular_probability(kd: SampledSpectrum, ks: SampledSpectrum, share: f32) -> f32 {
    let (d, s) = (kd.average(), ks.average());
    let w = if d + s > 0.0 { s / (d + s) } else { 0.5 };
    let (ps, pd) = (share * w, (1.0 - share) * (1.0 - w));
    if ps + pd > 0.0 {
        ps / (ps + pd)
    } else {
        0.0
    }
}

/// The sample of a reflection model at `wi`, weighted by `f·cos θi` over the density `pdf` of
/// the mixture that drew it; `None` below the surface or where the density vanishes.
#[inline]
pub(crate) fn reflection_sample(wi: Vec3, pdf: f32, f_cos: SampledSpectrum) -> Option<LocalSample> {
    (wi.z > 0.0 && pdf > 0.0).then(|| LocalSample {
        wi,
        weight: f_cos / pdf,
        pdf,
        delta: false,
        eta: 1.0,
    })
}

/// A sampled direction in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The incident direction (world, unit).
    pub wi: Vec3,
    /// f·|cos θi| / pdf.
    pub weight: SampledSpectrum,
    /// The density (the discrete probability for Dirac deltas).
    pub pdf: f32,
    /// The sample comes from a Dirac delta.
    pub delta: bool,
    /// The relative index of refraction crossed (1 for reflection).
    pub eta: f32,
}
