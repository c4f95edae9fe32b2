//! Smooth reflectors: the perfect mirror and the smooth conductor (Dirac deltas).
//!
//! Scene syntax: `specular(pigment)` (candela: a mirror scaled by the pigment);
//! `<bsdf type="conductor">` with `eta`, `k` or `material` (a preset; `none`, the default, is a
//! perfect mirror) and `specular_reflectance` (Mitsuba).

use super::fresnel::{fresnel_conductor, reflect_z};
use super::sample::LocalSample;
use crate::math::Vec3;
use crate::spectrum::SampledSpectrum;

/// Samples the mirror direction; the weight is `r` times the conductor's Fresnel reflectance
/// (none for a perfect mirror).
#[inline]
pub fn sample(
    r: SampledSpectrum,
    conductor: Option<(SampledSpectrum, SampledSpectrum)>,
    wo: Vec3,
) -> Option<LocalSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let f = match conductor {
        Some((eta, k)) => fresnel_conductor(wo.z, eta, k),
        None => SampledSpectrum::ONE,
    };
    Some(LocalSample {
        wi: reflect_z(wo),
        weight: r * f,
        pdf: 1.0,
        delta: true,
        eta: 1.0,
    })
}
