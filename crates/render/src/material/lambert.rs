//! Lambertian diffuse reflection: f = ρ/π, sampled cosine-weighted. The path tracer shades
//! Lambert vertices of a batch on sixteen lanes with the same operations
//! (`integrator/path/surface_lanes.rs`): a change here goes there too.
//!
//! Scene syntax: `diffuse(pigment)` (candela), `<bsdf type="diffuse">` with `reflectance`
//! (Mitsuba, default 0.5).

use super::sample::LocalSample;
use crate::math::{Vec3, INV_PI};
use crate::sampling::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::spectrum::SampledSpectrum;

/// f·cos θi for reflectance `r`.
#[inline]
pub fn eval(r: SampledSpectrum, wo: Vec3, wi: Vec3) -> SampledSpectrum {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return SampledSpectrum::ZERO;
    }
    r * (INV_PI * wi.z)
}

/// The density of [`sample`].
#[inline]
pub fn pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    cosine_hemisphere_pdf(wi.z)
}

/// Cosine-weighted sampling: the weight f·cos/pdf is ρ.
#[inline]
pub fn sample(r: SampledSpectrum, wo: Vec3, u: [f32; 2]) -> Option<LocalSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let wi = square_to_cosine_hemisphere(u);
    let pdf = cosine_hemisphere_pdf(wi.z);
    (pdf > 0.0).then_some(LocalSample {
        wi,
        weight: r,
        pdf,
        delta: false,
        eta: 1.0,
    })
}
