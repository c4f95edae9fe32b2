//! Point and spot lights (Dirac deltas in position); a spot may project a texture
//! ([`SpotPattern`], Mitsuba's `spot` with a `texture`).
//!
//! Scene syntax:
//! - `point_light([pos], <I>, r [, attenuation(c1, c2, c3)] [, components(…)])`: the intensity
//!   `I` scaled by (r/d)² when r > 0 (the course) and by f_att = min(1/(c1 + c2·d + c3·d²), 1)
//!   when an attenuation is given (the lecture). Mitsuba `point` (`intensity`, `position`) is
//!   the physical inverse-square law, i.e. r = 1.
//! - `spot_light([pos], [dir], <I>, cutoff_deg, k [, attenuation(…)] [, components(…)])`:
//!   I·(ω·s)^k inside the cut-off cone around the axis s, 0 outside. Mitsuba `spot`
//!   (`intensity`, `cutoff_angle` 20°, `beam_width` 3/4 of it) falls off linearly in the angle
//!   between beam width and cut-off, and follows the inverse-square law.

use crate::color::Rgb;
use crate::math::{Point2, Point3, Vec3};
use crate::spectrum::{RgbRole, SampledSpectrum, Spectrum, Wavelengths};
use crate::texture::Texture;
use std::sync::Arc;

/// How a light's contribution decreases with distance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Falloff {
    /// The course's linear radius r: scale by (r/d)² when r > 0.
    pub radius: f32,
    /// The lecture's attenuation (c1, c2, c3): scale by min(1/(c1 + c2·d + c3·d²), 1).
    pub attenuation: Option<[f32; 3]>,
}

impl Falloff {
    /// The physical inverse-square law 1/d².
    pub const INVERSE_SQUARE: Falloff = Falloff {
        radius: 1.0,
        attenuation: None,
    };

    /// The scale at distance `d`.
    #[inline]
    pub fn scale(&self, d: f32) -> f32 {
        let mut s = if self.radius > 0.0 {
            (self.radius / d) * (self.radius / d)
        } else {
            1.0
        };
        if let Some([c1, c2, c3]) = self.attenuation {
            let den = c1 + c2 * d + c3 * d * d;
            s *= if den > 1.0 { 1.0 / den } else { 1.0 };
        }
        s
    }
}

/// How a spot light's intensity varies inside its cone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpotProfile {
    /// The lecture's (ω·s)^k.
    Power(f32),
    /// Mitsuba's fall-off, linear in the angle from the beam width (full intensity) to the
    /// cut-off (zero): see [`SpotProfile::linear`].
    Linear {
        /// cos of the beam width.
        cos_beam: f32,
        /// The beam width (radians).
        beam: f32,
        /// The cut-off angle (radians).
        cutoff: f32,
    },
}

impl SpotProfile {
    /// Mitsuba's linear fall-off between the beam width and the cut-off angle, given by their
    /// cosines (`cos_cutoff` is the light's [`SpotLight::cos_cutoff`]): both angles are
    /// computed here once rather than at every evaluation.
    pub fn linear(cos_beam: f32, cos_cutoff: f32) -> Self {
        SpotProfile::Linear {
            cos_beam,
            beam: cos_beam.acos(),
            cutoff: cos_cutoff.acos(),
        }
    }
}

/// A point light.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    /// Position.
    pub position: Point3,
    /// Intensity (in RGB mode, and the colour upsampled in spectral mode when no `spectrum`).
    pub intensity: Rgb,
    /// The intensity's spectrum, used in spectral mode (`intensity` is its RGB conversion).
    pub spectrum: Option<Arc<Spectrum>>,
    /// Distance fall-off.
    pub falloff: Falloff,
}

/// A texture projected by a spot light (Mitsuba's `spot` with a `texture`): the direction `w`
/// leaving the light, in the light's frame (x, y, axis), looks the texture up at
/// uv = ½ + ½·(w·x, w·y) / ((w·axis)·tan(cut-off)).
#[derive(Clone, Debug, PartialEq)]
pub struct SpotPattern {
    /// The light's local x axis (unit, orthogonal to the axis).
    pub x: Vec3,
    /// The light's local y axis.
    pub y: Vec3,
    /// tan of the cut-off angle.
    pub uv_factor: f32,
    /// The texture (multiplies the intensity).
    pub texture: Texture,
}

/// A spot light.
#[derive(Clone, Debug, PartialEq)]
pub struct SpotLight {
    /// Position.
    pub position: Point3,
    /// Unit axis of the cone (the direction the light shines to).
    pub axis: Vec3,
    /// Intensity on the axis (in RGB mode, and the colour upsampled in spectral mode when no
    /// `spectrum`).
    pub intensity: Rgb,
    /// The intensity's spectrum, used in spectral mode (`intensity` is its RGB conversion).
    pub spectrum: Option<Arc<Spectrum>>,
    /// cos of the cut-off angle.
    pub cos_cutoff: f32,
    /// The profile inside the cone.
    pub profile: SpotProfile,
    /// Distance fall-off.
    pub falloff: Falloff,
    /// A projected texture, if any.
    pub pattern: Option<Box<SpotPattern>>,
}

impl SpotLight {
    /// The projected texture's colour along the unit direction `w` leaving the light (white
    /// without a texture).
    #[inline]
    pub fn pattern(&self, w: Vec3, lambda: &Wavelengths) -> SampledSpectrum {
        let Some(p) = &self.pattern else {
            return SampledSpectrum::ONE;
        };
        let z = w.dot(self.axis) * p.uv_factor;
        if !(z > 0.0) {
            return SampledSpectrum::ZERO;
        }
        let uv = Point2::new(0.5 + 0.5 * w.dot(p.x) / z, 0.5 + 0.5 * w.dot(p.y) / z);
        p.texture.spectral(uv, lambda, RgbRole::Reflectance)
    }

    /// The angular factor for the unit direction `w` leaving the light.
    #[inline]
    pub fn profile(&self, w: Vec3) -> f32 {
        let c = w.dot(self.axis);
        if c < self.cos_cutoff {
            return 0.0;
        }
        match self.profile {
            SpotProfile::Power(k) => c.max(0.0).powf(k),
            SpotProfile::Linear {
                cos_beam,
                beam,
                cutoff,
            } => {
                if c >= cos_beam {
                    1.0
                } else {
                    let x = c.clamp(-1.0, 1.0).acos();
                    ((cutoff - x) / (cutoff - beam)).clamp(0.0, 1.0)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn falloff_by_hand() {
        let f = Falloff {
            radius: 2.0,
            attenuation: None,
        };
        assert_eq!(f.scale(4.0), 0.25);
        assert_eq!(Falloff::default().scale(10.0), 1.0);
        let a = Falloff {
            radius: 0.0,
            attenuation: Some([1.0, 0.5, 0.25]),
        };
        // 1/(1 + 1 + 1) at d = 2; clamped to 1 when the denominator is below 1.
        assert!((a.scale(2.0) - 1.0 / 3.0).abs() < 1e-6);
        let near = Falloff {
            radius: 0.0,
            attenuation: Some([0.1, 0.0, 0.0]),
        };
        assert_eq!(near.scale(1.0), 1.0);
        assert!((Falloff::INVERSE_SQUARE.scale(2.0) - 0.25).abs() < 1e-7);
    }

    #[test]
    fn spot_cutoff_and_falloff_by_hand() {
        let s = SpotLight {
            position: Point3::ORIGIN,
            axis: Vec3::Z,
            intensity: Rgb::WHITE,
            spectrum: None,
            cos_cutoff: 30f32.to_radians().cos(),
            profile: SpotProfile::Power(2.0),
            pattern: None,
            falloff: Falloff::default(),
        };
        assert_eq!(s.profile(Vec3::Z), 1.0);
        let w = Vec3::new(20f32.to_radians().sin(), 0.0, 20f32.to_radians().cos());
        assert!((s.profile(w) - 20f32.to_radians().cos().powi(2)).abs() < 1e-6);
        let outside = Vec3::new(31f32.to_radians().sin(), 0.0, 31f32.to_radians().cos());
        assert_eq!(s.profile(outside), 0.0);
        let m = SpotLight {
            profile: SpotProfile::linear(20f32.to_radians().cos(), s.cos_cutoff),
            ..s
        };
        assert_eq!(m.profile(Vec3::Z), 1.0);
        let mid = Vec3::new(25f32.to_radians().sin(), 0.0, 25f32.to_radians().cos());
        assert!((m.profile(mid) - 0.5).abs() < 1e-4);
        let quarter = Vec3::new(27.5f32.to_radians().sin(), 0.0, 27.5f32.to_radians().cos());
        assert!((m.profile(quarter) - 0.25).abs() < 1e-4);
    }
}
