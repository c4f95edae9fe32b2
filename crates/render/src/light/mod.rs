//! Lights: point, spot, distant, hemisphere, environment and area lights.
//!
//! Two interfaces serve the two families of integrators:
//! - the local model of the lectures (`local`, `direct`, `whitted`) asks a light for the
//!   direction and the ambient, diffuse and specular intensities it delivers at a point
//!   ([`Light::local`]); each light may carry separate intensities
//!   (`components(<Ia>, <Id>, <Is>)`, default I_a = 0, I_d = I_s = I);
//! - the path tracer chooses a light ([`LightSelector`]), samples it as seen from a shading
//!   point ([`Light::sample_from`]; [`Light::sample`] from a bare point) and asks for the
//!   density of a direction found by BSDF sampling ([`Light::pdf_hit`],
//!   [`Light::pdf_escape_from`]) for multiple importance sampling.

mod area;
mod emission;
mod infinite;
mod point;
mod select;

pub use area::{AreaLight, AreaShape};
pub use emission::Emission;
pub use infinite::{Environment, HemisphereLight};
pub use point::{Falloff, PointLight, SpotLight, SpotPattern, SpotProfile};
pub use select::{LightSelector, ShadingPoint, MAX_IMPORTANCE_LIGHTS};

use crate::color::Rgb;
use crate::geometry::Geometry;
use crate::math::{Normal3, Point3, Vec3};
use crate::sampling::warp;
use crate::spectrum::{SampledSpectrum, Spectrum, Wavelengths};
use std::sync::Arc;

/// The lecture's separate ambient, diffuse and specular intensities of a light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Components {
    /// I_a.
    pub ambient: Rgb,
    /// I_d.
    pub diffuse: Rgb,
    /// I_s.
    pub specular: Rgb,
}

impl Components {
    /// The default split of an intensity: I_a = 0, I_d = I_s = I.
    pub fn from_intensity(i: Rgb) -> Self {
        Self {
            ambient: Rgb::BLACK,
            diffuse: i,
            specular: i,
        }
    }
}

/// Parallel light travelling along `direction`.
#[derive(Clone, Debug, PartialEq)]
pub struct DistantLight {
    /// Unit direction of travel.
    pub direction: Vec3,
    /// Irradiance on a surface facing the light (in RGB mode, and the colour upsampled in
    /// spectral mode when no `spectrum`).
    pub irradiance: Rgb,
    /// The irradiance's spectrum, used in spectral mode (`irradiance` is its RGB conversion).
    pub spectrum: Option<Arc<Spectrum>>,
}

/// An emitted colour `rgb` with its spectrum, if any, in the lanes of `lambda`.
#[inline]
fn emitted(rgb: Rgb, spectrum: &Option<Arc<Spectrum>>, lambda: &Wavelengths) -> SampledSpectrum {
    match spectrum {
        Some(s) => lambda.spectrum(s, rgb),
        None => lambda.illuminant(rgb),
    }
}

/// The closed set of lights.
// An explicit tag: a match reads one byte, where the niche in a field cost seven
// instructions at every light sample.
#[derive(Clone, Debug, PartialEq)]
#[repr(u8)]
pub enum Light {
    /// A point light.
    Point(PointLight, Components),
    /// A spot light.
    Spot(SpotLight, Components),
    /// A distant light.
    Distant(DistantLight, Components),
    /// A hemisphere light.
    Hemisphere(HemisphereLight, Components),
    /// An environment (constant or image).
    Environment(Environment),
    /// An emissive shape.
    Area(AreaLight),
}

/// Where a shadow ray for a light sample must go.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// A point in space (point and spot lights).
    Point(Point3),
    /// A point on a surface with its normal (area lights).
    Surface(Point3, Normal3),
    /// Infinitely far along the sampled direction.
    Infinite,
}

/// A sampled light direction as seen from a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the point to the light.
    pub wi: Vec3,
    /// Radiance arriving along `wi` (for delta lights: intensity × fall-off, or irradiance), in
    /// the lanes of the path's wavelengths.
    pub li: SampledSpectrum,
    /// Density per unit solid angle (1 for delta lights).
    pub pdf: f32,
    /// The light is a Dirac delta (point, spot, distant): no MIS.
    pub delta: bool,
    /// Where the shadow ray goes.
    pub target: Target,
}

impl LightSample {
    /// A positive density, a finite direction and some radiance.
    #[inline(always)]
    fn usable(&self) -> bool {
        self.pdf > 0.0 && self.wi.is_finite() && !self.li.is_black()
    }
}

/// What the local model receives from one light at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalIllumination {
    /// Unit direction to the light.
    pub wi: Vec3,
    /// Where a shadow ray must go.
    pub target: Target,
    /// I_a (fall-off applied).
    pub ambient: SampledSpectrum,
    /// I_d (fall-off applied).
    pub diffuse: SampledSpectrum,
    /// I_s (fall-off applied).
    pub specular: SampledSpectrum,
}

impl Light {
    /// True for lights at infinity, which escaping rays see.
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Environment(_) | Light::Hemisphere(..))
    }

    /// True for lights at infinity whose radiance varies little enough over directions that
    /// BSDF sampling finds them as well as a light sample could: a constant environment and a
    /// hemisphere light (light selection gives them no importance; see `select`).
    pub fn is_smooth_at_infinity(&self) -> bool {
        match self {
            Light::Environment(e) => !e.is_importance_sampled(),
            Light::Hemisphere(..) => true,
            _ => false,
        }
    }

    /// The local model's illumination at `p` from a point, spot or distant light (`None` for
    /// other lights, or outside a spot's cone), in the lanes of `lambda` (the intensities'
    /// colours upsampled as emitters in spectral mode).
    pub fn local(&self, p: Point3, lambda: &Wavelengths) -> Option<LocalIllumination> {
        let (wi, target, scale, c) = match self {
            Light::Point(l, c) => {
                let to = l.position - p;
                let d = to.norm();
                (to / d, Target::Point(l.position), l.falloff.scale(d), c)
            }
            Light::Spot(l, c) => {
                let to = l.position - p;
                let d = to.norm();
                let wi = to / d;
                (
                    wi,
                    Target::Point(l.position),
                    l.falloff.scale(d) * l.profile(-wi),
                    c,
                )
            }
            Light::Distant(l, c) => (-l.direction, Target::Infinite, 1.0, c),
            _ => return None,
        };
        (scale > 0.0 && wi.is_finite()).then_some(LocalIllumination {
            wi,
            target,
            ambient: lambda.illuminant(c.ambient) * scale,
            diffuse: lambda.illuminant(c.diffuse) * scale,
            specular: lambda.illuminant(c.specular) * scale,
        })
    }

    /// Samples the light as seen from `p` (with no surface to favour, and no other sampling
    /// technique to share the work with: an environment map samples its whole distribution),
    /// with the density [`Light::pdf_hit`] or [`Light::pdf_escape`] gives.
    pub fn sample(
        &self,
        geometry: &Geometry,
        emissions: &[Emission],
        p: Point3,
        u: [f32; 2],
        lambda: &Wavelengths,
    ) -> Option<LightSample> {
        self.sample_with(geometry, emissions, &ShadingPoint::at(p), u, lambda, false)
    }

    /// Samples the light as seen from the shading point `sp` for the path tracer, whose samples
    /// MIS weighs against BSDF sampling, with the density [`Light::pdf_hit`] or
    /// [`Light::pdf_escape_from`] gives. A constant environment or a hemisphere light seen from
    /// a point whose BSDF only reflects is sampled cosine-weighted about the shading normal
    /// (the hemisphere where the BSDF is not zero); an environment map samples its compensated
    /// distribution (see [`Environment`]); elsewhere each light samples itself as
    /// [`Light::sample`] does.
    #[inline(always)]
    pub fn sample_from(
        &self,
        geometry: &Geometry,
        emissions: &[Emission],
        sp: &ShadingPoint,
        u: [f32; 2],
        lambda: &Wavelengths,
    ) -> Option<LightSample> {
        self.sample_with(geometry, emissions, sp, u, lambda, true)
    }

    /// [`Light::sample_from`] (`mis`) or [`Light::sample`].
    #[inline(always)]
    fn sample_with(
        &self,
        geometry: &Geometry,
        emissions: &[Emission],
        sp: &ShadingPoint,
        u: [f32; 2],
        lambda: &Wavelengths,
        mis: bool,
    ) -> Option<LightSample> {
        // A parallelogram (the usual area light) is sampled in the caller: the sample stays in
        // registers rather than going through memory, where it was written in pieces other
        // than those the caller read back (store-forwarding stalls), and no call is made.
        if let Light::Area(a) = self {
            if let Some(s) = a.sample_parallelogram(emissions, sp.p, u, lambda) {
                return s.filter(LightSample::usable);
            }
        }
        self.sample_from_general(geometry, emissions, sp, u, lambda, mis)
    }

    /// [`Light::sample_with`] for every light but a parallelogram.
    #[inline(never)]
    fn sample_from_general(
        &self,
        geometry: &Geometry,
        emissions: &[Emission],
        sp: &ShadingPoint,
        u: [f32; 2],
        lambda: &Wavelengths,
        mis: bool,
    ) -> Option<LightSample> {
        let p = sp.p;
        // Area lights first, on a path of their own (no merge with the other lights' samples).
        if let Light::Area(a) = self {
            return a
                .sample(geometry, emissions, p, u, lambda)
                .filter(LightSample::usable);
        }
        if let Some(wi) = self.cosine_sample(sp, u) {
            let s = LightSample {
                wi,
                li: self.escaped(wi, lambda),
                pdf: warp::cosine_hemisphere_pdf(sp.n.dot(wi)),
                delta: false,
                target: Target::Infinite,
            };
            return s.usable().then_some(s);
        }
        let s = match self {
            Light::Point(l, _) => {
                let to = l.position - p;
                let d = to.norm();
                LightSample {
                    wi: to / d,
                    li: emitted(l.intensity, &l.spectrum, lambda) * l.falloff.scale(d),
                    pdf: 1.0,
                    delta: true,
                    target: Target::Point(l.position),
                }
            }
            Light::Spot(l, _) => {
                let to = l.position - p;
                let d = to.norm();
                let wi = to / d;
                LightSample {
                    wi,
                    li: emitted(l.intensity, &l.spectrum, lambda)
                        * l.pattern(-wi, lambda)
                        * (l.falloff.scale(d) * l.profile(-wi)),
                    pdf: 1.0,
                    delta: true,
                    target: Target::Point(l.position),
                }
            }
            Light::Distant(l, _) => LightSample {
                wi: -l.direction,
                li: emitted(l.irradiance, &l.spectrum, lambda),
                pdf: 1.0,
                delta: true,
                target: Target::Infinite,
            },
            Light::Hemisphere(h, _) => {
                let (wi, pdf) = h.sample(u);
                LightSample {
                    wi,
                    li: lambda.illuminant(h.radiance),
                    pdf,
                    delta: false,
                    target: Target::Infinite,
                }
            }
            Light::Environment(e) => {
                let (wi, li, pdf) = e.sample(u, lambda, mis)?;
                LightSample {
                    wi,
                    li,
                    pdf,
                    delta: false,
                    target: Target::Infinite,
                }
            }
            Light::Area(a) => a.sample(geometry, emissions, p, u, lambda)?,
        };
        s.usable().then_some(s)
    }

    /// The solid-angle density of sampling the point `q` (normal `n`) of this area light from
    /// `p` (0 for other lights).
    pub fn pdf_hit(&self, p: Point3, q: Point3, n: Normal3) -> f32 {
        match self {
            Light::Area(a) => a.pdf(p, q, n),
            _ => 0.0,
        }
    }

    /// Radiance reaching the scene from direction `d` (pointing away from the scene) for
    /// lights at infinity, black for the others; in the lanes of `lambda`.
    pub fn escaped(&self, d: Vec3, lambda: &Wavelengths) -> SampledSpectrum {
        match self {
            Light::Environment(e) => e.radiance(d, lambda),
            Light::Hemisphere(h, _) => lambda.illuminant(h.radiance(d)),
            _ => SampledSpectrum::ZERO,
        }
    }

    /// True when [`Light::sample_from`] samples this light cosine-weighted about the normal of
    /// `sp`: a constant environment or a hemisphere light, seen from a BSDF that only reflects.
    #[inline]
    fn cosine_sampled(&self, sp: &ShadingPoint) -> bool {
        sp.reflect_only && self.is_smooth_at_infinity()
    }

    /// The cosine-weighted direction about the normal of `sp`, for lights sampled so there.
    #[inline]
    fn cosine_sample(&self, sp: &ShadingPoint, u: [f32; 2]) -> Option<Vec3> {
        self.cosine_sampled(sp).then(|| {
            crate::math::Frame::from_normal(sp.n.to_normal())
                .to_world(warp::square_to_cosine_hemisphere(u))
        })
    }

    /// The solid-angle density with which [`Light::sample`] samples the direction `d` of a
    /// light at infinity.
    pub fn pdf_escape(&self, d: Vec3) -> f32 {
        match self {
            Light::Environment(e) => e.pdf(d, false),
            Light::Hemisphere(h, _) => h.pdf(d),
            _ => 0.0,
        }
    }

    /// [`Light::escaped`], and [`Light::pdf_escape_from`] at `sp` when it is given (0
    /// otherwise): an environment map turns the direction into its coordinates once for both.
    #[inline]
    pub fn escaped_with_pdf(
        &self,
        d: Vec3,
        lambda: &Wavelengths,
        sp: Option<&ShadingPoint>,
    ) -> (SampledSpectrum, f32) {
        match (self, sp) {
            (Light::Environment(e), Some(sp)) if !self.cosine_sampled(sp) => {
                e.radiance_and_pdf(d, lambda, true)
            }
            _ => (
                self.escaped(d, lambda),
                sp.map_or(0.0, |sp| self.pdf_escape_from(d, sp)),
            ),
        }
    }

    /// The solid-angle density with which [`Light::sample_from`] at `sp` samples the direction
    /// `d` of a light at infinity.
    pub fn pdf_escape_from(&self, d: Vec3, sp: &ShadingPoint) -> f32 {
        if self.cosine_sampled(sp) {
            return warp::cosine_hemisphere_pdf(sp.n.dot(d));
        }
        match self {
            Light::Environment(e) => e.pdf(d, true),
            Light::Hemisphere(h, _) => h.pdf(d),
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Parallelogram;
    use crate::texture::Texture;

    /// The parallelogram's path in the caller gives what the general path gives, bit for bit,
    /// usable or not (one- and two-sided, seen from either side, from the light's plane).
    #[test]
    fn parallelograms_sampled_in_the_caller_match_the_general_path() {
        let q = Parallelogram::new(
            Point3::new(-0.5, -0.25, 1.0),
            Vec3::new(1.0, 0.0, 0.1),
            Vec3::new(0.0, 0.75, 0.0),
        )
        .unwrap();
        let geometry = Geometry::default();
        let emissions = [
            Emission {
                radiance: Texture::Uniform(Rgb::new(18.0, 14.0, 6.75)),
                two_sided: false,
            },
            Emission {
                radiance: Texture::Checkered {
                    c1: Rgb::new(1.0, 2.0, 3.0),
                    c2: Rgb::BLACK,
                    steps: [2.0; 2],
                    offset: [0.0; 2],
                },
                two_sided: true,
            },
        ];
        let lambda = Wavelengths::Rgb;
        let mut compared = [0; 2];
        for e in 0..2 {
            let light = Light::Area(AreaLight::parallelogram(q.clone(), e));
            for p in [
                Point3::new(0.1, 0.2, 0.0),
                Point3::new(-0.3, 0.1, 2.0),
                Point3::new(0.0, 0.0, 1.0),
            ] {
                let sp = ShadingPoint::at(p);
                for u in [[0.1, 0.9], [0.5, 0.5], [0.99, 0.01], [0.3, 0.7]] {
                    let inline = light.sample_from(&geometry, &emissions, &sp, u, &lambda);
                    let general =
                        light.sample_from_general(&geometry, &emissions, &sp, u, &lambda, true);
                    assert_eq!(format!("{inline:?}"), format!("{general:?}"));
                    compared[inline.is_some() as usize] += 1;
                }
            }
        }
        assert!(compared[0] > 0 && compared[1] > 0, "{compared:?}");
    }
}
