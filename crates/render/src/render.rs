//! The parallel tile renderer.
//!
//! The image is cut into 16×16 tiles rendered in parallel on the current rayon pool. Pixel
//! (x, y) (row 0 at the top) takes `spp` samples from its own deterministic sampler, so the
//! result depends only on the scene and the seed, never on the number of threads. Sample sums
//! are accumulated in f64; samples whose radiance is NaN or infinite are rejected (counted in
//! [`RayStats::rejected_samples`]) and contribute zero.

use crate::color::Rgb;
use crate::image::Image;
use crate::integrator::Integrator;
use crate::math::{Point3, Ray, Vec3, BATCH};
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::Scene;
use crate::stats::RayStats;
use rayon::prelude::*;

/// Edge of the square tiles, in pixels.
pub const TILE: usize = 16;

/// What to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Image width in pixels (> 0).
    pub width: usize,
    /// Image height in pixels (> 0).
    pub height: usize,
    /// Samples per pixel (≥ 1); one sample goes through the pixel centre.
    pub spp: u32,
    /// The seed of every random sequence.
    pub seed: u64,
    /// How the samples of a pixel are placed.
    pub sampler: SamplerKind,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            spp: 1,
            seed: 0,
            sampler: SamplerKind::Sobol,
        }
    }
}

/// A rendered image and the counters gathered on the way.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Linear radiance per pixel.
    pub image: Image,
    /// Counters summed over all threads.
    pub stats: RayStats,
}

/// Renders `scene` with `integrator`. `progress` is called with the number of pixels of each
/// finished tile (from worker threads).
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> RenderOutput {
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let tiles: Vec<(Vec<Rgb>, RayStats)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|tile| {
            let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let mut stats = RayStats::default();
            let mut pixels = Vec::with_capacity((x1 - x0) * (y1 - y0));
            // One sampler per tile, reset for every pixel (its tables are large).
            let mut sampler = Sampler::new(0, 0);
            for y in y0..y1 {
                for x in x0..x1 {
                    pixels.push(render_pixel(
                        scene,
                        integrator,
                        settings,
                        x,
                        y,
                        &mut sampler,
                        &mut stats,
                    ));
                }
            }
            progress(pixels.len() as u64);
            (pixels, stats)
        })
        .collect();

    let mut image = Image::new(w, h);
    let mut stats = RayStats::default();
    for (tile, (pixels, s)) in tiles.into_iter().enumerate() {
        stats += s;
        let (x0, y0) = ((tile % tiles_x) * TILE, (tile / tiles_x) * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        for (i, p) in pixels.into_iter().enumerate() {
            image.set(x0 + i % tw, y0 + i / tw, p);
        }
    }
    RenderOutput { image, stats }
}

/// The mean radiance of the samples of pixel (x, y).
fn render_pixel(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    x: usize,
    y: usize,
    sampler: &mut Sampler,
    stats: &mut RayStats,
) -> Rgb {
    let (w, h) = (settings.width as f32, settings.height as f32);
    sampler.reset_for_pixel(
        settings.sampler,
        settings.seed,
        (y * settings.width + x) as u64,
        settings.spp,
    );
    let mut sum = [0f64; 3];
    // The samples go to the integrator in groups of `BATCH`, traced side by side; each keeps
    // its own place in the pixel's sample sequence.
    let mut rays = [Ray::new(Point3::ORIGIN, Vec3::X); BATCH];
    let mut cursors = [sampler.cursor(); BATCH];
    let mut radiance = [Rgb::BLACK; BATCH];
    for first in (0..settings.spp).step_by(BATCH) {
        let n = (settings.spp - first).min(BATCH as u32) as usize;
        for k in 0..n {
            let [sx, sy] = sampler.pixel_sample(first + k as u32);
            let u = (x as f32 + sx) / w;
            let v = 1.0 - (y as f32 + sy) / h;
            rays[k] = match scene.camera.lens {
                None => scene.camera.ray(u, v),
                Some(_) => scene.camera.ray_through_lens(u, v, sampler.next_2d()),
            };
            cursors[k] = sampler.cursor();
        }
        integrator.radiance_batch(
            scene,
            &rays[..n],
            &mut cursors[..n],
            sampler,
            stats,
            &mut radiance[..n],
        );
        for l in &radiance[..n] {
            stats.samples += 1;
            if l.is_finite() {
                sum[0] += l.r as f64;
                sum[1] += l.g as f64;
                sum[2] += l.b as f64;
            } else {
                stats.rejected_samples += 1;
            }
        }
    }
    let n = settings.spp as f64;
    Rgb::new(
        (sum[0] / n) as f32,
        (sum[1] / n) as f32,
        (sum[2] / n) as f32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::material::Material;
    use crate::math::{Point3, Ray, Transform, Vec3};
    use crate::scene::SceneBuilder;
    use crate::shape::{Shape, Sphere};
    use crate::texture::Texture;

    /// An integrator that returns its random numbers, to expose the seeding.
    struct Noise;
    impl Integrator for Noise {
        fn radiance(&self, _: &Scene, ray: &Ray, s: &mut Sampler, _: &mut RayStats) -> Rgb {
            Rgb::new(s.next_1d(), s.next_1d(), ray.d.z)
        }
    }

    /// An integrator that returns NaN on the left half of the image.
    struct Poison;
    impl Integrator for Poison {
        fn radiance(&self, _: &Scene, ray: &Ray, _: &mut Sampler, _: &mut RayStats) -> Rgb {
            if ray.d.y > 0.0 {
                Rgb::new(f32::NAN, 0.0, f32::INFINITY)
            } else {
                Rgb::WHITE
            }
        }
    }

    fn scene() -> Scene {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                4.0, 0.0, 0.0,
            )))),
            m,
            None,
        );
        b.build(AccelKind::None)
    }

    #[test]
    fn the_image_does_not_depend_on_the_thread_count() {
        let s = scene();
        for sampler in [
            SamplerKind::Sobol,
            SamplerKind::Stratified,
            SamplerKind::Independent,
        ] {
            let settings = RenderSettings {
                width: 37,
                height: 21,
                spp: 3,
                seed: 9,
                sampler,
            };
            let run = |threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| render(&s, &Noise, &settings, &|_| {}))
            };
            let a = run(1);
            let b = run(4);
            assert_eq!(a.image, b.image);
            assert_eq!(a.stats, b.stats);
            let other = render(
                &s,
                &Noise,
                &RenderSettings {
                    seed: 10,
                    ..settings
                },
                &|_| {},
            );
            assert_ne!(a.image, other.image);
        }
    }

    #[test]
    fn one_sample_per_pixel_goes_through_the_centre() {
        let s = scene();
        let settings = RenderSettings {
            width: 4,
            height: 2,
            spp: 1,
            ..Default::default()
        };
        let out = render(&s, &Noise, &settings, &|_| {});
        // Row 0 is the top: v = 1 − 0.5/2 = 0.75, so the ray points up (z > 0).
        let expected = s.camera.ray(0.125, 0.75).d.z;
        assert_eq!(out.image.get(0, 0).b, expected);
        assert!(out.image.get(0, 1).b < 0.0);
        assert_eq!(out.stats.samples, 8);
    }

    #[test]
    fn nan_and_infinite_samples_never_reach_the_image() {
        let s = scene();
        let settings = RenderSettings {
            width: 8,
            height: 4,
            spp: 2,
            ..Default::default()
        };
        let out = render(&s, &Poison, &settings, &|_| {});
        assert!(out.image.pixels().iter().all(|p| p.is_finite()));
        assert_eq!(out.image.get(0, 0), Rgb::BLACK);
        assert_eq!(out.image.get(7, 0), Rgb::WHITE);
        assert_eq!(out.stats.rejected_samples, 32);
        let _ = Point3::ORIGIN;
    }

    #[test]
    fn progress_reports_every_pixel() {
        use std::sync::atomic::{AtomicU64, Ordering};
        let s = scene();
        let done = AtomicU64::new(0);
        let settings = RenderSettings {
            width: 50,
            height: 33,
            spp: 1,
            ..Default::default()
        };
        render(&s, &Noise, &settings, &|n| {
            done.fetch_add(n, Ordering::Relaxed);
        });
        assert_eq!(done.load(Ordering::Relaxed), 50 * 33);
    }
}
