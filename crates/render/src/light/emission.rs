//! What emissive surfaces emit.

use crate::interaction::SurfaceInteraction;
use crate::math::{Normal3, Point2, Vec3};
use crate::spectrum::{RgbRole, SampledSpectrum, Wavelengths};
use crate::texture::Texture;

/// Emitted radiance of a surface.
#[derive(Clone, Debug, PartialEq)]
pub struct Emission {
    /// Radiance over the surface's uv.
    pub radiance: Texture,
    /// Emits on both sides (candela language) or only on the side of the normal (Mitsuba).
    pub two_sided: bool,
}

impl Emission {
    /// The radiance leaving the surface point of `si` towards `w` (pointing away from it), in
    /// the lanes of `lambda`.
    #[inline]
    pub fn radiance(
        &self,
        si: &SurfaceInteraction,
        w: Vec3,
        lambda: &Wavelengths,
    ) -> SampledSpectrum {
        self.radiance_at(si.uv, si.n, w, lambda)
    }

    /// The radiance leaving the point with surface coordinates `uv` and geometric normal `n`
    /// towards `w`.
    #[inline]
    pub fn radiance_at(
        &self,
        uv: Point2,
        n: Normal3,
        w: Vec3,
        lambda: &Wavelengths,
    ) -> SampledSpectrum {
        if !self.two_sided && n.dot_vec(w) <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.radiance.spectral(uv, lambda, RgbRole::Emission)
    }
}
