//! The parallel renderer: passes of whole samples over tiles.
//!
//! A render adds samples to a [`Film`]: [`render_pass`] takes sample indices `first..last` of
//! every pixel of the film's window, cutting the window into 16×16 tiles rendered in parallel on
//! the current rayon pool. Pixel (x, y) (row 0 at the top) draws sample i from its own
//! deterministic sequence (seeded by the image seed and the pixel index), so a sample's value
//! depends only on the scene, the seed, the pixel and i, never on the thread, the pass or the
//! process that traced it; and the film's fixed-point sums are exact, so any split of the
//! samples (passes, tiles, crops, separate processes merged later) gives the same bits as one
//! uninterrupted render. [`render`] is one pass of every sample.
//!
//! Samples whose radiance is NaN or infinite are rejected (counted in
//! [`RayStats::rejected_samples`]): they count as samples but contribute zero.

use crate::aov::{aov_sample, emission_aa as emission_aa_of, near_light_edge, Aov, AovSet};
use crate::film::{to_fixed, Film, Window};
use crate::filter::{Filter, FilterSampler};
use crate::image::Image;
use crate::integrator::{Integrator, SampleBatch, SAMPLE_QUEUE};
use crate::math::{Point3, Ray, Vec3, BATCH};
use crate::sampling::pcg::{hash2, unit_pair};
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Edge of the square tiles, in pixels.
pub const TILE: usize = 16;

/// What to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Image width in pixels (> 0).
    pub width: usize,
    /// Image height in pixels (> 0).
    pub height: usize,
    /// Samples per pixel of the whole frame (≥ 1); one sample goes through the pixel centre.
    pub spp: u32,
    /// The seed of every random sequence.
    pub seed: u64,
    /// How the samples of a pixel are placed.
    pub sampler: SamplerKind,
    /// Output variables summed after the radiance (film channels 3 and up).
    pub aovs: AovSet,
    /// The reconstruction filter the pixel samples are drawn from.
    pub filter: Filter,
    /// Trace radiance per wavelength (four per path, hero-wavelength sampling) and turn it into
    /// colour through the CIE observer; integrators whose result is a colour by definition
    /// ([`Integrator::spectral`] false) stay RGB. The scene should be prepared with
    /// [`Scene::prepare_spectral`] (only for speed).
    pub spectral: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            spp: 1,
            seed: 0,
            sampler: SamplerKind::Sobol,
            aovs: AovSet::NONE,
            filter: Filter::Box,
            spectral: false,
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

/// Renders every sample of every pixel of `scene` with `integrator`. `progress` is called from
/// worker threads with the number of samples of each finished tile.
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> RenderOutput {
    let window = Window::full(settings.width, settings.height);
    let channels = 3 + settings.aovs.channels();
    let mut film = Film::new(settings.width, settings.height, window, channels);
    let stats = render_pass(
        scene,
        integrator,
        settings,
        &mut film,
        (0, settings.spp),
        progress,
    );
    RenderOutput {
        image: film.rgb(0),
        stats,
    }
}

/// Adds samples `first..last` (of the frame's `settings.spp`) of every pixel of the film's
/// window to `film`. `progress` is called from worker threads with the number of samples of
/// each finished tile.
pub fn render_pass(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    film: &mut Film,
    samples: (u32, u32),
    progress: &(dyn Fn(u64) + Sync),
) -> RayStats {
    let never = AtomicBool::new(false);
    render_pass_or_cancel(scene, integrator, settings, film, samples, progress, &never)
        .unwrap_or_default()
}

/// A finished tile: its pixels, their fixed-point sums and counts, and its counters.
type TileSums = (Window, Vec<i128>, Vec<u32>, RayStats);

/// [`render_pass`] that gives up when `cancel` becomes true: tiles not yet started are skipped
/// and, if any was, the film is left as it was and `None` is returned (a pass is added whole or
/// not at all, so the film always holds the same samples in every pixel).
pub fn render_pass_or_cancel(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    film: &mut Film,
    (first, last): (u32, u32),
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
) -> Option<RayStats> {
    let win = film.window();
    let film_channels = film.channels();
    assert_eq!(
        film_channels,
        3 + settings.aovs.channels(),
        "the film has a channel per radiance component and output variable"
    );
    let tiles_x = win.width().div_ceil(TILE);
    let tiles_y = win.height().div_ceil(TILE);
    let filter = FilterSampler::new(settings.filter);
    let tiles: Option<Vec<TileSums>> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|tile| {
            if cancel.load(Ordering::Relaxed) {
                return None;
            }
            let x0 = win.x0 + (tile % tiles_x) * TILE;
            let y0 = win.y0 + (tile / tiles_x) * TILE;
            let rect = Window {
                x0,
                x1: (x0 + TILE).min(win.x1),
                y0,
                y1: (y0 + TILE).min(win.y1),
            };
            let mut stats = RayStats::default();
            let mut sums = Vec::with_capacity(rect.pixels() * film_channels);
            let mut counts = Vec::with_capacity(rect.pixels());
            // One sampler per tile, reset for every pixel (its tables are large).
            let mut sampler = Sampler::new(0, 0);
            for y in rect.y0..rect.y1 {
                for x in rect.x0..rect.x1 {
                    let (sum, n) = render_pixel(
                        scene,
                        integrator,
                        settings,
                        (x, y),
                        (first, last),
                        (&mut sampler, &filter),
                        &mut stats,
                    );
                    sums.extend_from_slice(&sum);
                    if !settings.aovs.is_empty() {
                        aov_pixel(
                            scene,
                            settings,
                            (x, y),
                            (first, last),
                            (&mut sampler, &filter),
                            &mut stats,
                            &mut sums,
                        );
                    }
                    counts.push(n);
                }
            }
            progress(rect.pixels() as u64 * (last - first) as u64);
            Some((rect, sums, counts, stats))
        })
        .collect();
    let mut stats = RayStats::default();
    for (rect, sums, counts, s) in tiles? {
        stats += s;
        film.add_block(rect, &sums, &counts);
    }
    Some(stats)
}

/// The fixed-point sums of samples `first..last` of pixel (x, y), and how many there are.
fn render_pixel(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    (x, y): (usize, usize),
    (first, last): (u32, u32),
    (sampler, filter): (&mut Sampler, &FilterSampler),
    stats: &mut RayStats,
) -> ([i128; 3], u32) {
    let (w, h) = (settings.width as f32, settings.height as f32);
    sampler.reset_for_pixel(
        settings.sampler,
        settings.seed,
        (y * settings.width + x) as u64,
        settings.spp,
    );
    sampler.draw_range(first, last);
    let mut sum = [0i128; 3];
    // The samples go to the integrator up to `SAMPLE_QUEUE` at a time (never across a multiple
    // of it, where the sampler's tables start over), traced side by side; each keeps its own
    // place in the pixel's sample sequence.
    const QUEUE: u32 = SAMPLE_QUEUE as u32;
    let mut rays = [Ray::new(Point3::ORIGIN, Vec3::X); SAMPLE_QUEUE];
    let mut cursors = [sampler.cursor(); SAMPLE_QUEUE];
    let mut radiance = [SampledSpectrum::ZERO; SAMPLE_QUEUE];
    let mut weights = [1f32; SAMPLE_QUEUE];
    let mut lambdas = [Wavelengths::Rgb; SAMPLE_QUEUE];
    let spectral = settings.spectral && integrator.spectral();
    // A pinhole's rays are made a batch at a time, from their screen points.
    let pinhole = scene.camera.lens.is_none();
    let mut screen = [[0f32; 2]; SAMPLE_QUEUE];
    let mut start = first;
    while start < last {
        let n = (last.min((start / QUEUE + 1) * QUEUE) - start) as usize;
        for k in 0..n {
            if pinhole {
                let offset;
                (offset, weights[k]) = filter.sample(sampler.pixel_sample(start + k as u32));
                screen[k] = screen_point((w, h), (x, y), offset);
            } else {
                (rays[k], weights[k]) =
                    camera_ray(scene, (w, h), (x, y), start + k as u32, (sampler, filter));
            }
            // The sample's wavelengths: the number after the camera's.
            lambdas[k] = if spectral {
                Wavelengths::sample(sampler.next_1d())
            } else {
                Wavelengths::Rgb
            };
            cursors[k] = sampler.cursor();
        }
        if pinhole {
            for c in (0..n).step_by(BATCH) {
                let batch: &[[f32; 2]; BATCH] = screen[c..c + BATCH].try_into().unwrap();
                scene.camera.rays(batch, (n - c).min(BATCH), &mut rays[c..]);
            }
        }
        let batch = SampleBatch {
            rays: &rays[..n],
            lambdas: &mut lambdas[..n],
            cursors: &mut cursors[..n],
        };
        integrator.radiance_batch(scene, batch, sampler, stats, &mut radiance[..n]);
        for ((l, &weight), lambda) in radiance[..n].iter().zip(&weights).zip(&lambdas) {
            let l = lambda.to_rgb(*l);
            let l = if weight == 1.0 { l } else { l * weight };
            stats.samples += 1;
            if l.is_finite() {
                sum[0] += to_fixed(l.r);
                sum[1] += to_fixed(l.g);
                sum[2] += to_fixed(l.b);
            } else {
                stats.rejected_samples += 1;
            }
        }
        start += n as u32;
    }
    (sum, last.saturating_sub(first))
}

/// The camera ray of sample `i` of pixel (x, y) of a `w × h` image and the sample's filter
/// weight: the first numbers of the sample place it in the pixel (through the filter's
/// distribution), the next ones on the lens.
#[inline]
fn camera_ray(
    scene: &Scene,
    size: (f32, f32),
    (x, y): (usize, usize),
    i: u32,
    (sampler, filter): (&mut Sampler, &FilterSampler),
) -> (Ray, f32) {
    let (offset, weight) = filter.sample(sampler.pixel_sample(i));
    let ray = ray_through(scene, size, (x, y), offset, || sampler.next_2d());
    (ray, weight)
}

/// The camera ray through the point of the filter's square `u` of pixel (x, y), with its
/// filter weight (lens cameras: a lens point hashed from `key` and `u`).
fn camera_ray_at(
    scene: &Scene,
    size: (f32, f32),
    (x, y): (usize, usize),
    u: [f32; 2],
    key: u64,
    filter: &FilterSampler,
) -> (Ray, f32) {
    let (offset, weight) = filter.sample(u);
    let lens = || {
        unit_pair(hash2(
            key,
            u[0].to_bits() as u64 | (u[1].to_bits() as u64) << 32,
        ))
    };
    (ray_through(scene, size, (x, y), offset, lens), weight)
}

/// The camera ray through the point `offset` (in pixels from the corner) of pixel (x, y) of a
/// `w × h` image; `lens` gives the lens point of cameras that have one.
#[inline]
fn ray_through(
    scene: &Scene,
    (w, h): (f32, f32),
    (x, y): (usize, usize),
    [sx, sy]: [f32; 2],
    lens: impl FnOnce() -> [f32; 2],
) -> Ray {
    let [u, v] = screen_point((w, h), (x, y), [sx, sy]);
    match scene.camera.lens {
        None => scene.camera.ray(u, v),
        Some(_) => scene.camera.ray_through_lens(u, v, lens()),
    }
}

/// The point (u, v) of the screen square at `offset` (in pixels from the corner) in pixel
/// (x, y) of a `w × h` image (v upwards).
#[inline(always)]
fn screen_point((w, h): (f32, f32), (x, y): (usize, usize), [sx, sy]: [f32; 2]) -> [f32; 2] {
    [(x as f32 + sx) / w, 1.0 - (y as f32 + sy) / h]
}

/// Appends to `sums` the fixed-point sums of the output variables of samples `first..last` of
/// pixel (x, y), seen along the same camera rays as the radiance.
fn aov_pixel(
    scene: &Scene,
    settings: &RenderSettings,
    (x, y): (usize, usize),
    (first, last): (u32, u32),
    (sampler, filter): (&mut Sampler, &FilterSampler),
    stats: &mut RayStats,
    sums: &mut Vec<i128>,
) {
    let size = (settings.width as f32, settings.height as f32);
    sampler.reset_for_pixel(
        settings.sampler,
        settings.seed,
        (y * settings.width + x) as u64,
        settings.spp,
    );
    sampler.draw_until(last);
    let n = settings.aovs.channels();
    let mut acc = [0i128; 32];
    let mut vals = [0f32; 32];
    // Where the emission channels are (they carry the filter weight, as the radiance does, so
    // that the denoiser can take them out of it exactly).
    let offset = |aov: Aov| {
        settings.aovs.contains(aov).then(|| {
            settings
                .aovs
                .iter()
                .take_while(|&a| a != aov)
                .map(|a| a.channels().len())
                .sum::<usize>()
        })
    };
    let (emission, emission_aa) = (offset(Aov::Emission), offset(Aov::EmissionAa));
    let pixel_key = hash2(settings.seed, (y * settings.width + x) as u64);
    let edge = emission_aa.is_some()
        && near_light_edge(
            scene,
            (2.0 * filter.filter().radius()).max(1.0),
            &mut |offset| ray_through(scene, size, (x, y), offset, || [0.5, 0.5]),
            stats,
        );
    for i in first..last {
        // The other variables are plain means over the same rays.
        let (ray, w) = camera_ray(scene, size, (x, y), i, (&mut *sampler, filter));
        aov_sample(scene, &ray, settings.aovs, &mut vals[..n], stats);
        for at in [emission, emission_aa].into_iter().flatten() {
            for v in &mut vals[at..at + 3] {
                *v *= w;
            }
        }
        if let (Some(at), true) = (emission_aa, edge) {
            let key = hash2(pixel_key, i as u64);
            let e = emission_aa_of(
                scene,
                &mut |u| camera_ray_at(scene, size, (x, y), u, key, filter),
                key,
                stats,
            );
            vals[at..at + 3].copy_from_slice(&e);
        }
        for (a, &v) in acc.iter_mut().zip(&vals[..n]) {
            if v.is_finite() {
                *a += to_fixed(v);
            }
        }
    }
    sums.extend_from_slice(&acc[..n]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::color::Rgb;
    use crate::material::Material;
    use crate::math::{Point3, Ray, Transform, Vec3};
    use crate::scene::SceneBuilder;
    use crate::shape::{Shape, Sphere};
    use crate::texture::Texture;

    /// An integrator that returns its random numbers, to expose the seeding.
    struct Noise;
    impl Integrator for Noise {
        fn radiance(
            &self,
            _: &Scene,
            ray: &Ray,
            _: &mut Wavelengths,
            s: &mut Sampler,
            _: &mut RayStats,
        ) -> SampledSpectrum {
            Rgb::new(s.next_1d(), s.next_1d(), ray.d.z).into()
        }
    }

    /// An integrator that returns NaN on the left half of the image.
    struct Poison;
    impl Integrator for Poison {
        fn radiance(
            &self,
            _: &Scene,
            ray: &Ray,
            _: &mut Wavelengths,
            _: &mut Sampler,
            _: &mut RayStats,
        ) -> SampledSpectrum {
            if ray.d.y > 0.0 {
                Rgb::new(f32::NAN, 0.0, f32::INFINITY).into()
            } else {
                SampledSpectrum::ONE
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
                ..Default::default()
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

    /// One uninterrupted render against the same samples split over passes (any boundaries),
    /// over windows rendered apart and merged, and over thread counts: the same film, bit for
    /// bit.
    #[test]
    fn any_split_of_the_samples_gives_the_same_bits() {
        let s = scene();
        let settings = RenderSettings {
            width: 23,
            height: 17,
            spp: 21,
            seed: 5,
            ..Default::default()
        };
        let full = Window::full(23, 17);
        // The noise integrator's values are its sample's random numbers: every sample differs.
        let path = Noise;
        let mut whole = Film::new(23, 17, full, 3);
        render_pass(&s, &path, &settings, &mut whole, (0, 21), &|_| {});
        let mut passes = Film::new(23, 17, full, 3);
        for range in [(0, 1), (1, 4), (4, 5), (5, 17), (17, 21)] {
            render_pass(&s, &path, &settings, &mut passes, range, &|_| {});
        }
        assert_eq!(passes, whole);
        let mut merged = Film::new(23, 17, full, 3);
        for (x0, x1, y0, y1) in [(0, 9, 0, 17), (9, 23, 0, 5), (9, 23, 5, 17)] {
            let w = Window { x0, x1, y0, y1 };
            let mut part = Film::new(23, 17, w, 3);
            render_pass(&s, &path, &settings, &mut part, (0, 10), &|_| {});
            render_pass(&s, &path, &settings, &mut part, (10, 21), &|_| {});
            merged.merge(&part).unwrap();
        }
        assert_eq!(merged, whole);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let mut threaded = Film::new(23, 17, full, 3);
        pool.install(|| render_pass(&s, &path, &settings, &mut threaded, (0, 21), &|_| {}));
        assert_eq!(threaded, whole);
        assert!(whole.samples() == 23 * 17 * 21);
        assert!(whole.sums().iter().filter(|&&v| v != 0).count() > 23 * 17 * 2);
    }

    #[test]
    fn a_cancelled_pass_leaves_the_film_as_it_was() {
        let s = scene();
        let settings = RenderSettings {
            width: 40,
            height: 40,
            spp: 8,
            ..Default::default()
        };
        let mut film = Film::new(40, 40, Window::full(40, 40), 3);
        render_pass(&s, &Noise, &settings, &mut film, (0, 4), &|_| {});
        let before = film.clone();
        // Cancelled before it starts, and in the middle (after the first tile).
        let cancel = AtomicBool::new(true);
        let r = render_pass_or_cancel(&s, &Noise, &settings, &mut film, (4, 8), &|_| {}, &cancel);
        assert!(r.is_none());
        assert_eq!(film, before);
        let cancel = AtomicBool::new(false);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let r = pool.install(|| {
            render_pass_or_cancel(
                &s,
                &Noise,
                &settings,
                &mut film,
                (4, 8),
                &|_| cancel.store(true, Ordering::Relaxed),
                &cancel,
            )
        });
        assert!(r.is_none());
        assert_eq!(film, before);
        let never = AtomicBool::new(false);
        let r = render_pass_or_cancel(&s, &Noise, &settings, &mut film, (4, 8), &|_| {}, &never);
        assert!(r.is_some());
        assert_eq!(film.samples(), 40 * 40 * 8);
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
