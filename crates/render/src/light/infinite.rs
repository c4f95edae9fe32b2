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
//!
//! Next-event estimation, which multiple importance sampling weighs against BSDF sampling,
//! samples an image map by its *compensated* distribution (Karlík et al. 2019, "MIS
//! compensation", as pbrt-v4 does): the luminance bound less its mean over the sphere, clamped
//! at 0, times sin θ. Directions no brighter than the mean are left to BSDF sampling, which covers
//! them (MIS then gives its samples their full weight), and the light samples go where the map
//! outshines its average, a sun's disc above all. Sampling without MIS (`Light::sample`, the
//! radiosity's direct light) keeps the full distribution, whose support is the whole map.

use crate::color::Rgb;
use crate::math::{Point2, Transform, Vec3, INV_2PI, INV_PI, PI};
use crate::sampling::warp;
use crate::sampling::Distribution2D;
use crate::spectrum::{RgbRole, SampledSpectrum, Wavelengths};
use crate::texture::Texture;

/// A light from every direction (an environment map, or a constant colour).
///
/// An image map samples directions in proportion to its luminance (a bound of it per texel)
/// times sin θ, or, for next-event estimation that MIS weighs against BSDF sampling, by its
/// *compensated* distribution: the luminance less its mean over the sphere, clamped at 0 (MIS
/// compensation, Karlík et al. 2019, as in pbrt-v4), which leaves the directions no brighter
/// than the mean to BSDF sampling and spends the light samples where the map outshines its
/// average.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Radiance over the lat-long (u, v) square.
    pub radiance: Texture,
    /// Environment → world.
    pub world_from_env: Transform,
    /// Importance-sampling distribution over (u, v) for image maps.
    distribution: Option<Distribution2D>,
    /// The compensated distribution (see the module documentation), for samples weighed by
    /// MIS against BSDF sampling; `None` when no cell is brighter than the mean (a uniform
    /// map), where the full distribution serves.
    compensated: Option<Distribution2D>,
}

impl Environment {
    /// An environment light; image maps get a sampling distribution.
    pub fn new(radiance: Texture, world_from_env: Transform) -> Self {
        let (mut distribution, mut compensated) = (None, None);
        if let Texture::Image(t) = &radiance {
            let (w, h) = (t.image.width(), t.image.height());
            if w > 0 && h > 0 {
                let bound = cell_maxima(t);
                let sin = |i: usize| (PI * ((i / w) as f32 + 0.5) / h as f32).sin();
                let full: Vec<f32> = bound.iter().enumerate().map(|(i, b)| b * sin(i)).collect();
                // The mean over the sphere: each cell weighs by its solid angle (∝ sin θ).
                let (mut sum, mut weight) = (0f64, 0f64);
                for (i, b) in bound.iter().enumerate() {
                    sum += *b as f64 * sin(i) as f64;
                    weight += sin(i) as f64;
                }
                let mean = (sum / weight) as f32;
                let excess: Vec<f32> = bound
                    .iter()
                    .enumerate()
                    .map(|(i, b)| (b - mean).max(0.0) * sin(i))
                    .collect();
                if excess.iter().any(|&e| e > 0.0) {
                    compensated = Some(Distribution2D::new(&excess, w, h));
                }
                distribution = Some(Distribution2D::new(&full, w, h));
            }
        }
        Self {
            radiance,
            world_from_env,
            distribution,
            compensated,
        }
    }

    /// The distribution samples take: the compensated one where MIS weighs them against BSDF
    /// sampling (`mis`) and the map has one, the full one otherwise (`None`: a constant map).
    #[inline]
    fn distribution(&self, mis: bool) -> Option<&Distribution2D> {
        match (&self.compensated, mis) {
            (Some(c), true) => Some(c),
            _ => self.distribution.as_ref(),
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
        self.uv_and_sin_theta(d).0
    }

    /// The lat-long coordinates of a world direction, and sin θ (the sine of `v`·π, from the
    /// direction itself rather than by a library `sin` of the angle).
    #[inline]
    fn uv_and_sin_theta(&self, d: Vec3) -> (Point2, f32) {
        // (Not normalised again when unit to round-off, as the path tracer's directions are
        // and a rotation keeps them: a square root and a division less on the way.)
        let l = self.world_from_env.inv_vector(d);
        let l2 = l.squared_norm();
        let l = if (l2 - 1.0).abs() <= 1.0 / 1_048_576.0 {
            l
        } else {
            l.normalize()
        };
        // (A polynomial arctangent: the library's atan2 and acos took about a tenth of the
        // profile's samples of a frame under an environment map; without them it is about 2 %
        // faster.)
        let mut phi = crate::math::fast_atan2(l.y, l.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let z = l.z.clamp(-1.0, 1.0);
        let sin_theta = ((1.0 - z) * (1.0 + z)).sqrt();
        let uv = Point2::new(
            (phi * INV_2PI).min(crate::sampling::sampler::ONE_MINUS_EPSILON),
            crate::math::fast_atan2(sin_theta, z) * INV_PI,
        );
        (uv, sin_theta)
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

    /// [`Environment::radiance`] and [`Environment::pdf`] of direction `d`, its lat-long
    /// coordinates computed once for both.
    #[inline]
    pub fn radiance_and_pdf(
        &self,
        d: Vec3,
        lambda: &Wavelengths,
        mis: bool,
    ) -> (SampledSpectrum, f32) {
        let Some(dist) = self.distribution(mis) else {
            return (self.radiance(d, lambda), self.pdf(d, mis));
        };
        let (uv, pdf) = self.uv_and_pdf(dist, d);
        (self.radiance.spectral(uv, lambda, RgbRole::Emission), pdf)
    }

    /// The lat-long coordinates of direction `d` and its density under `dist`, the map's
    /// sampling distribution.
    #[inline]
    fn uv_and_pdf(&self, dist: &Distribution2D, d: Vec3) -> (Point2, f32) {
        let (uv, st) = self.uv_and_sin_theta(d);
        (uv, solid_angle_pdf(dist.pdf([uv.x, uv.y]), st))
    }

    /// A direction sampled in proportion to the map (to its compensated distribution with
    /// `mis`: for samples that MIS weighs against BSDF sampling), its radiance and solid-angle
    /// density.
    pub fn sample(
        &self,
        u: [f32; 2],
        lambda: &Wavelengths,
        mis: bool,
    ) -> Option<(Vec3, SampledSpectrum, f32)> {
        match self.distribution(mis) {
            Some(dist) => {
                let (uv, pdf_uv) = dist.sample(u);
                let (d, st) = self.direction(uv);
                if !(st > 0.0 && pdf_uv > 0.0) {
                    return None;
                }
                let pdf = solid_angle_pdf(pdf_uv, st);
                // The Jacobian of the world transform keeps solid angle for rotations. The
                // radiance at the sampled coordinates themselves (their direction's, up to
                // round-off, without its arctangent and arccosine).
                let l =
                    self.radiance
                        .spectral(Point2::new(uv[0], uv[1]), lambda, RgbRole::Emission);
                Some((d, l, pdf))
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

    /// The solid-angle density of [`Environment::sample`] for direction `d` (with the same
    /// `mis`).
    pub fn pdf(&self, d: Vec3, mis: bool) -> f32 {
        match self.distribution(mis) {
            Some(dist) => self.uv_and_pdf(dist, d).1,
            None => warp::uniform_sphere_pdf(),
        }
    }
}

/// The solid-angle density of a direction at sin θ `st` whose lat-long coordinates have the
/// density `pdf_uv` (the square's 2π × π over the sphere's sin θ; 0 at the poles).
#[inline]
fn solid_angle_pdf(pdf_uv: f32, st: f32) -> f32 {
    if st > 0.0 {
        pdf_uv / (2.0 * PI * PI * st)
    } else {
        0.0
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

/// The luminance bound of an environment map's sampling, one cell of the lat-long square per
/// pixel: the largest luminance among the pixels its lookups in the cell read (with bilinear
/// filtering, the pixels around it too: half a pixel around a small sun is still bright; the
/// cells are where the lookups land, with the texture's scale and offset); the distributions
/// multiply it by sin θ at the cell's centre. An upper bound of the radiance over the cell, so
/// that no direction of high radiance has a low density. (A cell's centre alone left a sun's
/// rim, and with Mitsuba's half-texel offset part of the sun itself, to sky-level densities,
/// whose rare samples were fireflies: the ratio of radiance to density reached 430 times its
/// mean with a 3-pixel sun; Mitsuba samples its bilinear interpolation itself.)
fn cell_maxima(t: &crate::texture::ImageTexture) -> Vec<f32> {
    use crate::texture::{Filter, Wrap};
    let (w, h) = (t.image.width(), t.image.height());
    let index = |i: i64, n: usize, wrap: Wrap| match wrap {
        Wrap::Clamp => i.clamp(0, n as i64 - 1) as usize,
        Wrap::Repeat => i.rem_euclid(n as i64) as usize,
    };
    // The pixels (first, last) the lookups of [a, b) along an axis read (pixel units).
    let span = |a: f32, b: f32| -> (i64, i64) {
        let (a, b) = (a.min(b), a.max(b));
        match t.filter {
            Filter::Nearest => (
                a.floor() as i64,
                (b.ceil() as i64 - 1).max(a.floor() as i64),
            ),
            Filter::Bilinear => ((a - 0.5).floor() as i64, (b - 0.5).floor() as i64 + 1),
        }
    };
    // The cell's extent along axis `k` in pixel units, and the pixels its lookups read.
    let axis = |k: usize, n: usize, c: usize| {
        let at = |i: usize| (i as f32 / n as f32 * t.scale[k] + t.offset[k]) * n as f32;
        let (a, b) = (at(c).min(at(c + 1)), at(c).max(at(c + 1)));
        ((a, b), span(a, b))
    };
    // The largest weight pixel `i` has in a lookup of [a, b]: 1 for nearest filtering; for
    // bilinear filtering, 1 less the distance from its centre to the interval.
    let weight = |i: i64, (a, b): (f32, f32)| match t.filter {
        Filter::Nearest => 1.0,
        Filter::Bilinear => {
            let c = i as f32 + 0.5;
            (1.0 - (a - c).max(c - b).max(0.0)).max(0.0)
        }
    };
    let mut lum = vec![0f32; w * h];
    for (p, l) in t.image.pixels().iter().zip(&mut lum) {
        *l = p.luminance().max(0.0);
    }
    let mut f = Vec::with_capacity(w * h);
    for y in 0..h {
        let (ry, (y0, y1)) = axis(1, h, y);
        for x in 0..w {
            let (rx, (x0, x1)) = axis(0, w, x);
            // Two bounds of the radiance over the cell: the brightest pixel read, and the
            // pixels weighted by their largest weights (tighter around a lone bright one).
            let (mut brightest, mut weighted) = (0f32, 0f32);
            for j in y0..=y1.min(y0 + h as i64) {
                let (row, wy) = (index(j, h, t.wrap[1]) * w, weight(j, ry));
                for i in x0..=x1.min(x0 + w as i64) {
                    let l = lum[row + index(i, w, t.wrap[0])];
                    brightest = brightest.max(l);
                    weighted += wy * weight(i, rx) * l;
                }
            }
            f.push(brightest.min(weighted));
        }
    }
    f
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
            integral += e.pdf(d, false) as f64 / warp::uniform_sphere_pdf() as f64;
        }
        assert!(
            (integral / n as f64 - 1.0).abs() < 0.02,
            "{}",
            integral / n as f64
        );
        for _ in 0..100 {
            let (d, _, pdf) = e
                .sample([rng.next_f32(), rng.next_f32()], &Wavelengths::Rgb, false)
                .unwrap();
            assert!((pdf - e.pdf(d, false)).abs() < 1e-3 * pdf);
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

    /// The samples' density follows the radiance the bilinear lookup returns, a small sun's
    /// half-pixel rim included (lookups offset as Mitsuba's maps are): the ratio of radiance
    /// to density stays within a few times its mean, no fireflies. (Densities from the cells'
    /// centres alone let it reach 430 times its mean, a relative deviation of 3.7; the bound
    /// used now over-weights the rim, whose cells' radiance peaks at their edges, which keeps
    /// the deviation near 0.6.)
    #[test]
    fn image_sampling_follows_the_filtered_radiance() {
        use crate::texture::{Filter, ImageTexture, Wrap};
        let (w, h) = (128usize, 64usize);
        let mut img = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let (dy, dx) = (y as i64 - 15, x as i64 - 35);
                let sun = dy * dy + dx * dx < 4;
                let sky = 0.3 + 0.2 * (y as f32 / h as f32);
                img.set(x, y, Rgb::splat(if sun { 300.0 } else { sky }));
            }
        }
        let tex = Texture::Image(ImageTexture {
            filter: Filter::Bilinear,
            wrap: [Wrap::Repeat, Wrap::Clamp],
            scale: [1.0, (h as f32 - 1.0) / h as f32],
            offset: [0.0, 0.5 / h as f32],
            image: Arc::new(img),
        });
        let e = Environment::new(tex, Transform::IDENTITY);
        let mut rng = crate::sampling::Pcg32::new(2, 3);
        let n = 100_000;
        let (mut sum, mut sum2, mut max, mut off) = (0f64, 0f64, 0f64, 0);
        for _ in 0..n {
            let (d, l, pdf) = e
                .sample([rng.next_f32(), rng.next_f32()], &Wavelengths::Rgb, false)
                .unwrap();
            // (The direction's coordinates, recomputed, may fall across a cell's edge.)
            off += ((pdf - e.pdf(d, false)).abs() > 1e-3 * pdf) as usize;
            let r = l.0[0] as f64 / pdf as f64;
            sum += r;
            sum2 += r * r;
            max = max.max(r);
        }
        let mean = sum / n as f64;
        let rel_std = (sum2 / n as f64 - mean * mean).sqrt() / mean;
        assert!(
            off < n / 1000,
            "{off} densities differ from the direction's"
        );
        assert!(
            max / mean < 4.0 && rel_std < 1.0,
            "max/mean {}, relative deviation {rel_std}",
            max / mean
        );
    }
}
