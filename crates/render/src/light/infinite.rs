//! Lights at infinity: distant (directional), hemisphere and environment lights.
//!
//! Scene syntax:
//! - `distant_light([dir], <E>)`: parallel light travelling along `dir` with irradiance E on a
//!   surface facing it (Mitsuba `directional`: `irradiance`, `direction`).
//! - `hemisphere_light(<L> [, [up]])`: radiance L from every direction of the hemisphere around
//!   `up` (default +z).
//! - `environment(pigment [, T])`: radiance from every direction; image pigments are lat-long
//!   maps with u = atan2(y, x)/2π, v = acos(z)/π in the environment's frame (Mitsuba
//!   `constant`, `envmap`). Image maps are importance-sampled by luminance × sin θ.

use crate::color::Rgb;
use crate::math::{Point2, Transform, Vec3, INV_2PI, INV_PI, PI};
use crate::sampling::warp;
use crate::sampling::Distribution2D;
use crate::spectrum::{RgbRole, SampledSpectrum, Wavelengths};
use crate::texture::Texture;

/// A light from every direction (an environment map, or a constant colour).
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Radiance over the lat-long (u, v) square.
    pub radiance: Texture,
    /// Environment → world.
    pub world_from_env: Transform,
    /// Importance-sampling distribution over (u, v) for image maps.
    distribution: Option<Distribution2D>,
}

impl Environment {
    /// An environment light; image maps get a sampling distribution.
    pub fn new(radiance: Texture, world_from_env: Transform) -> Self {
        let distribution = match &radiance {
            Texture::Image(t) if t.image.width() > 0 && t.image.height() > 0 => {
                let (w, h) = (t.image.width(), t.image.height());
                let mut f = Vec::with_capacity(w * h);
                for y in 0..h {
                    let sin = (PI * (y as f32 + 0.5) / h as f32).sin();
                    for x in 0..w {
                        let uv =
                            Point2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                        f.push(radiance.eval(uv).luminance().max(0.0) * sin);
                    }
                }
                Some(Distribution2D::new(&f, w, h))
            }
            _ => None,
        };
        Self {
            radiance,
            world_from_env,
            distribution,
        }
    }

    /// True for image maps, which are sampled by their luminance (constant environments are
    /// sampled uniformly over the sphere, or cosine-weighted about a surface's normal).
    #[inline]
    pub fn is_importance_sampled(&self) -> bool {
        self.distribution.is_some()
    }

    /// The lat-long coordinates of a world direction.
    #[inline]
    fn uv(&self, d: Vec3) -> Point2 {
        let l = self.world_from_env.inv_vector(d).normalize();
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        Point2::new(
            (phi * INV_2PI).min(crate::sampling::sampler::ONE_MINUS_EPSILON),
            crate::math::safe_acos(l.z) * INV_PI,
        )
    }

    /// The world direction of lat-long coordinates.
    #[inline]
    fn direction(&self, uv: [f32; 2]) -> (Vec3, f32) {
        let (phi, theta) = (uv[0] * 2.0 * PI, uv[1] * PI);
        let st = theta.sin();
        let l = Vec3::new(st * phi.cos(), st * phi.sin(), theta.cos());
        (self.world_from_env.vector(l).normalize(), st)
    }

    /// Radiance arriving from direction `d` (pointing away from the scene), in the lanes of
    /// `lambda`.
    #[inline]
    pub fn radiance(&self, d: Vec3, lambda: &Wavelengths) -> SampledSpectrum {
        // A constant sky needs no coordinates (atan2 and acos per escaped ray).
        let uv = match &self.radiance {
            Texture::Uniform(_) | Texture::Spectral { .. } => Point2::new(0.5, 0.5),
            _ => self.uv(d),
        };
        self.radiance.spectral(uv, lambda, RgbRole::Emission)
    }

    /// A direction sampled in proportion to the map, its radiance and solid-angle density.
    pub fn sample(
        &self,
        u: [f32; 2],
        lambda: &Wavelengths,
    ) -> Option<(Vec3, SampledSpectrum, f32)> {
        match &self.distribution {
            Some(dist) => {
                let (uv, pdf_uv) = dist.sample(u);
                let (d, st) = self.direction(uv);
                if !(st > 0.0 && pdf_uv > 0.0) {
                    return None;
                }
                let pdf = pdf_uv / (2.0 * PI * PI * st);
                // The Jacobian of the world transform keeps solid angle for rotations.
                Some((d, self.radiance(d, lambda), pdf))
            }
            None => {
                let d = self
                    .world_from_env
                    .vector(warp::square_to_uniform_sphere(u))
                    .normalize();
                Some((d, self.radiance(d, lambda), warp::uniform_sphere_pdf()))
            }
        }
    }

    /// The solid-angle density of [`Environment::sample`] for direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        match &self.distribution {
            Some(dist) => {
                let uv = self.uv(d);
                let st = (uv.y * PI).sin();
                if st <= 0.0 {
                    return 0.0;
                }
                dist.pdf([uv.x, uv.y]) / (2.0 * PI * PI * st)
            }
            None => warp::uniform_sphere_pdf(),
        }
    }
}

/// Radiance `radiance` from the hemisphere around `up`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HemisphereLight {
    /// Radiance.
    pub radiance: Rgb,
    /// Unit axis of the lit hemisphere.
    pub up: Vec3,
}

impl HemisphereLight {
    /// Radiance arriving from direction `d`.
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Rgb {
        if d.dot(self.up) > 0.0 {
            self.radiance
        } else {
            Rgb::BLACK
        }
    }

    /// A direction uniform over the lit hemisphere, with density 1/(2π).
    pub fn sample(&self, u: [f32; 2]) -> (Vec3, f32) {
        let l = warp::square_to_uniform_hemisphere(u);
        (
            crate::math::Frame::from_normal(self.up.to_normal()).to_world(l),
            warp::uniform_hemisphere_pdf(),
        )
    }

    /// The density of [`HemisphereLight::sample`].
    pub fn pdf(&self, d: Vec3) -> f32 {
        if d.dot(self.up) > 0.0 {
            warp::uniform_hemisphere_pdf()
        } else {
            0.0
        }
    }

    /// The closed-form irradiance on an unoccluded surface with unit normal `n`, divided by π:
    /// ∫ L cos θ dω / π over the lit part of n's hemisphere = L·(1 + n·up)/2.
    pub fn diffuse_irradiance_over_pi(&self, n: Vec3) -> Rgb {
        self.radiance * (0.5 * (1.0 + n.dot(self.up).clamp(-1.0, 1.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use std::sync::Arc;

    #[test]
    fn lat_long_round_trip() {
        let e = Environment::new(Texture::Uniform(Rgb::WHITE), Transform::rotation_x(30.0));
        for uv in [[0.1f32, 0.3f32], [0.7, 0.9], [0.5, 0.5]] {
            let (d, _) = e.direction(uv);
            let back = e.uv(d);
            assert!((back.x - uv[0]).abs() < 1e-5 && (back.y - uv[1]).abs() < 1e-5);
        }
    }

    #[test]
    fn image_sampling_density_matches_pdf() {
        let mut img = Image::new(8, 4);
        img.set(3, 1, Rgb::splat(50.0));
        img.set(6, 2, Rgb::splat(5.0));
        for p in img.pixels_mut() {
            p.r += 0.1;
            p.g += 0.1;
            p.b += 0.1;
        }
        let tex = Texture::Image(crate::texture::ImageTexture::new(Arc::new(img)));
        let e = Environment::new(tex, Transform::IDENTITY);
        let mut rng = crate::sampling::Pcg32::new(2, 3);
        // ∫ pdf dω = 1 by a Monte Carlo estimate over uniform directions.
        let n = 200_000;
        let mut integral = 0f64;
        for _ in 0..n {
            let d = warp::square_to_uniform_sphere([rng.next_f32(), rng.next_f32()]);
            integral += e.pdf(d) as f64 / warp::uniform_sphere_pdf() as f64;
        }
        assert!(
            (integral / n as f64 - 1.0).abs() < 0.02,
            "{}",
            integral / n as f64
        );
        for _ in 0..100 {
            let (d, _, pdf) = e
                .sample([rng.next_f32(), rng.next_f32()], &Wavelengths::Rgb)
                .unwrap();
            assert!((pdf - e.pdf(d)).abs() < 1e-3 * pdf);
        }
    }

    #[test]
    fn hemisphere_closed_form() {
        let h = HemisphereLight {
            radiance: Rgb::splat(2.0),
            up: Vec3::Z,
        };
        assert_eq!(h.diffuse_irradiance_over_pi(Vec3::Z), Rgb::splat(2.0));
        assert_eq!(h.diffuse_irradiance_over_pi(-Vec3::Z), Rgb::BLACK);
        assert_eq!(h.diffuse_irradiance_over_pi(Vec3::X), Rgb::splat(1.0));
    }
}
