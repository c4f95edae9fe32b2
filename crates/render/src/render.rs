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
//! With a filter wider than the box (and no output variables), samples are splatted to the
//! pixels around them ([`crate::splat`]): each tile adds the shares of its samples, its own
//! pixels' and its neighbours', to the pass's sums of the window (exact integers, so in any
//! order), which the film takes when the pass ends; and a window is rendered with a border of
//! the pixels whose samples reach it (their own sums stay out of the film), so that a window
//! gets the same bits as the same pixels of the whole frame.
//!
//! Samples whose radiance is NaN or infinite are rejected (counted in
//! [`RayStats::rejected_samples`]): they count as samples but contribute zero.

use crate::aov::{aov_sample, emission_aa as emission_aa_of, near_light_edge, Aov, AovSet};
use crate::color::Rgb;
use crate::film::{to_fixed, Film, Window};
use crate::filter::{Filter, FilterSampler};
use crate::image::Image;
use crate::integrator::{Integrator, SampleBatch, BATCH_RUNS, BATCH_SAMPLES, SAMPLE_QUEUE};
use crate::math::{Point3, Ray, Vec3, BATCH};
use crate::sampling::pcg::{hash2, unit_pair};
use crate::sampling::{SampleCursor, Sampler, SamplerKind};
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::splat::{Splat, SplatSums};
use crate::stats::RayStats;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

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

/// A finished tile: its pixels inside the film's window (none for a tile of the border that
/// splatting renders around a window), their fixed-point sums (the radiance's are 0 when it is
/// splatted) and counts, and its counters.
type TileSums = (Option<Window>, Vec<i128>, Vec<u32>, RayStats);

/// The pixels `w` and `o` share, if any.
fn intersection(w: Window, o: Window) -> Option<Window> {
    w.overlaps(&o).then(|| Window {
        x0: w.x0.max(o.x0),
        x1: w.x1.min(o.x1),
        y0: w.y0.max(o.y0),
        y1: w.y1.min(o.y1),
    })
}

/// `w` grown by `m` pixels on every side, within a `width × height` image.
fn grown(w: Window, m: usize, (width, height): (usize, usize)) -> Window {
    Window {
        x0: w.x0.saturating_sub(m),
        x1: (w.x1 + m).min(width),
        y0: w.y0.saturating_sub(m),
        y1: (w.y1 + m).min(height),
    }
}

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
    let size = (settings.width, settings.height);
    // Splatting (output variables keep the filter's importance sampling: a denoiser reads
    // them with the radiance, and expects pixels whose noise is their own).
    let splat = if settings.aovs.is_empty() {
        Splat::new(
            settings.filter,
            settings.width,
            settings.height,
            settings.spp,
        )
    } else {
        None
    };
    // The pixels rendered: the window, and around it those whose samples reach it.
    let region = match &splat {
        Some(s) => grown(win, s.margin(), size),
        None => win,
    };
    let tiles_x = region.width().div_ceil(TILE);
    let tiles_y = region.height().div_ceil(TILE);
    // Splatted samples are placed uniformly in their pixels (the box's sampling).
    let filter = FilterSampler::new(if splat.is_some() {
        Filter::Box
    } else {
        settings.filter
    });
    // The radiance the pass splats into the window's pixels: each tile adds its sums there
    // as it ends (exact integers, so in any order), and the film takes them if the pass ends.
    let splats = Mutex::new(if splat.is_some() {
        vec![[0i128; 3]; win.pixels()]
    } else {
        Vec::new()
    });
    let tiles: Option<Vec<TileSums>> = (0..tiles_x * tiles_y)
        .into_par_iter()
        // Each worker's runs (their samplers are large) serve tile after tile.
        .map_init(
            || Runs::new(scene, integrator, settings, &filter, splat.as_ref()),
            |runs, tile| {
                if cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let x0 = region.x0 + (tile % tiles_x) * TILE;
                let y0 = region.y0 + (tile / tiles_x) * TILE;
                let rect = Window {
                    x0,
                    x1: (x0 + TILE).min(region.x1),
                    y0,
                    y1: (y0 + TILE).min(region.y1),
                };
                let own = intersection(rect, win);
                let mut stats = RayStats::default();
                let n_own = own.map_or(0, |o| o.pixels());
                let mut sums = Vec::with_capacity(n_own * film_channels);
                let mut counts = Vec::with_capacity(n_own);
                // The radiance sums of the pixels the tile's samples reach, in rows.
                let reach = match &splat {
                    Some(s) => grown(rect, s.margin(), size),
                    None => rect,
                };
                runs.tile = rect;
                runs.reach = reach;
                if splat.is_some() {
                    runs.quick.reset(reach);
                }
                let mut radiance = vec![[0i128; 3]; reach.pixels()];
                for (k, (x, y)) in rect.points().enumerate() {
                    runs.add_pixel((x, y), k, (first, last), &mut radiance, &mut stats);
                }
                runs.trace(&mut radiance, &mut stats);
                if splat.is_some() {
                    runs.quick.flush(&mut radiance);
                    if let Some(part) = intersection(reach, win) {
                        let mut all = splats.lock().unwrap_or_else(|e| e.into_inner());
                        for y in part.y0..part.y1 {
                            for x in part.x0..part.x1 {
                                let s = &radiance[(y - reach.y0) * reach.width() + x - reach.x0];
                                let to = &mut all[(y - win.y0) * win.width() + x - win.x0];
                                for c in 0..3 {
                                    to[c] += s[c];
                                }
                            }
                        }
                    }
                    for _ in 0..n_own {
                        sums.extend_from_slice(&[0; 3]);
                        counts.push(last.saturating_sub(first));
                    }
                    progress(n_own as u64 * (last - first) as u64);
                    return Some((own, sums, counts, stats));
                }
                let sampler = runs.sampler();
                for ((x, y), sum) in rect.points().zip(&radiance) {
                    sums.extend_from_slice(sum);
                    if !settings.aovs.is_empty() {
                        aov_pixel(
                            scene,
                            settings,
                            (x, y),
                            (first, last),
                            (&mut *sampler, &filter),
                            &mut stats,
                            &mut sums,
                        );
                    }
                    counts.push(last.saturating_sub(first));
                }
                progress(rect.pixels() as u64 * (last - first) as u64);
                Some((Some(rect), sums, counts, stats))
            },
        )
        .collect();
    let mut stats = RayStats::default();
    for (own, sums, counts, s) in tiles? {
        stats += s;
        if let Some(own) = own {
            film.add_block(own, &sums, &counts);
        }
    }
    if splat.is_some() {
        film.add_radiance(win, &splats.into_inner().unwrap_or_else(|e| e.into_inner()));
    }
    Some(stats)
}

/// Runs of samples of the tile's pixels (at most [`SAMPLE_QUEUE`] of one pixel each, never
/// across a multiple of it, where a sampler's tables start over), gathered up to
/// [`BATCH_RUNS`] at a time and handed to the integrator together, each with its own sampler:
/// the paths of one pixel's samples fill the lanes that another's leave, rather than each pixel
/// ending its batch with a few lanes left. Every sample keeps its place in its pixel's sample
/// sequence (so its value whatever run, lane or batch it is traced in), and the sums are exact,
/// so the order in which samples are added makes no difference.
struct Runs<'a> {
    scene: &'a Scene,
    integrator: &'a dyn Integrator,
    settings: &'a RenderSettings,
    filter: &'a FilterSampler,
    /// Splatting, with the tile being rendered and the pixels its samples reach (the pixels
    /// of the tile's sums).
    splat: Option<&'a Splat>,
    tile: Window,
    reach: Window,
    /// The 64-bit splat sums of the tile (see [`Splat::add`]).
    quick: SplatSums,
    /// One sampler per run (their tables are large: kept by the worker from tile to tile).
    samplers: Vec<Sampler>,
    /// Runs gathered, samples gathered.
    runs: usize,
    len: usize,
    /// Per sample: camera ray, filter weight, wavelengths, cursor, run, pixel (in the tile).
    rays: Box<[Ray; BATCH_SAMPLES]>,
    weights: [f32; BATCH_SAMPLES],
    /// Per sample: its position in its pixel (from the corner) and its value (splatting
    /// reads them).
    offsets: [[f32; 2]; BATCH_SAMPLES],
    rgb: Box<[Rgb; BATCH_SAMPLES]>,
    lambdas: [Wavelengths; BATCH_SAMPLES],
    cursors: Box<[SampleCursor; BATCH_SAMPLES]>,
    samplers_of: [u8; BATCH_SAMPLES],
    pixels: [u16; BATCH_SAMPLES],
    /// Screen points of a pinhole's rays (made a batch at a time), with room for a whole batch
    /// from any sample on.
    screen: Box<[[f32; 2]; BATCH_SAMPLES + BATCH]>,
    radiance: Box<[SampledSpectrum; BATCH_SAMPLES]>,
}

impl<'a> Runs<'a> {
    fn new(
        scene: &'a Scene,
        integrator: &'a dyn Integrator,
        settings: &'a RenderSettings,
        filter: &'a FilterSampler,
        splat: Option<&'a Splat>,
    ) -> Self {
        let sampler = Sampler::new(0, 0);
        let tile = Window::full(settings.width, settings.height);
        Self {
            scene,
            integrator,
            settings,
            filter,
            splat,
            tile,
            reach: tile,
            quick: SplatSums::default(),
            samplers: vec![sampler.clone(); BATCH_RUNS],
            runs: 0,
            len: 0,
            rays: Box::new([Ray::new(Point3::ORIGIN, Vec3::X); BATCH_SAMPLES]),
            weights: [1.0; BATCH_SAMPLES],
            offsets: [[0.5; 2]; BATCH_SAMPLES],
            rgb: Box::new([Rgb::BLACK; BATCH_SAMPLES]),
            lambdas: [Wavelengths::Rgb; BATCH_SAMPLES],
            cursors: Box::new([sampler.cursor(); BATCH_SAMPLES]),
            samplers_of: [0; BATCH_SAMPLES],
            pixels: [0; BATCH_SAMPLES],
            screen: Box::new([[0.0; 2]; BATCH_SAMPLES + BATCH]),
            radiance: Box::new([SampledSpectrum::ZERO; BATCH_SAMPLES]),
        }
    }

    /// Adds samples `first..last` of pixel (x, y) (pixel `k` of the tile), tracing the runs
    /// gathered whenever there are [`BATCH_RUNS`] of them.
    fn add_pixel(
        &mut self,
        (x, y): (usize, usize),
        k: usize,
        (first, last): (u32, u32),
        radiance: &mut [[i128; 3]],
        stats: &mut RayStats,
    ) {
        const QUEUE: u32 = SAMPLE_QUEUE as u32;
        let settings = self.settings;
        let (w, h) = (settings.width as f32, settings.height as f32);
        let spectral = settings.spectral && self.integrator.spectral();
        // A pinhole's rays are made a batch at a time, from their screen points.
        let pinhole = self.scene.camera.lens.is_none();
        let mut start = first;
        while start < last {
            let n = (last.min((start / QUEUE + 1) * QUEUE) - start) as usize;
            let run = self.runs;
            let sampler = &mut self.samplers[run];
            sampler.reset_for_pixel(
                settings.sampler,
                settings.seed,
                (y * settings.width + x) as u64,
                settings.spp,
            );
            sampler.draw_range(first, last);
            let at = self.len;
            for j in at..at + n {
                let i = start + (j - at) as u32;
                if pinhole {
                    let offset;
                    (offset, self.weights[j]) = self.filter.sample(sampler.pixel_sample(i));
                    self.screen[j] = screen_point((w, h), (x, y), offset);
                    self.offsets[j] = offset;
                } else {
                    (self.rays[j], self.weights[j], self.offsets[j]) =
                        camera_ray(self.scene, (w, h), (x, y), i, (sampler, self.filter));
                }
                // The sample's wavelengths: the number after the camera's.
                self.lambdas[j] = if spectral {
                    Wavelengths::sample(sampler.next_1d())
                } else {
                    Wavelengths::Rgb
                };
                sampler.mark_path_start();
                self.cursors[j] = sampler.cursor();
                self.samplers_of[j] = run as u8;
                self.pixels[j] = k as u16;
            }
            if pinhole {
                for c in (at..at + n).step_by(BATCH) {
                    let batch: &[[f32; 2]; BATCH] = self.screen[c..c + BATCH].try_into().unwrap();
                    let count = (at + n - c).min(BATCH);
                    self.scene.camera.rays(batch, count, &mut self.rays[c..]);
                }
            }
            self.len += n;
            self.runs += 1;
            start += n as u32;
            if self.runs == BATCH_RUNS {
                self.trace(radiance, stats);
            }
        }
    }

    /// Traces the samples gathered and adds them to their pixels' sums.
    fn trace(&mut self, radiance: &mut [[i128; 3]], stats: &mut RayStats) {
        let n = self.len;
        if n == 0 {
            return;
        }
        let batch = SampleBatch {
            rays: &self.rays[..n],
            lambdas: &mut self.lambdas[..n],
            cursors: &mut self.cursors[..n],
            samplers_of: &self.samplers_of[..n],
        };
        self.integrator.radiance_batch(
            self.scene,
            batch,
            &mut self.samplers,
            stats,
            &mut self.radiance[..n],
        );
        for j in 0..n {
            let (l, weight) = (self.lambdas[j].to_rgb(self.radiance[j]), self.weights[j]);
            let l = if weight == 1.0 { l } else { l * weight };
            stats.samples += 1;
            if !l.is_finite() {
                stats.rejected_samples += 1;
                self.rgb[j] = Rgb::BLACK;
            } else if self.splat.is_some() {
                self.rgb[j] = l;
            } else {
                let sum = &mut radiance[self.pixels[j] as usize];
                sum[0] += to_fixed(l.r);
                sum[1] += to_fixed(l.g);
                sum[2] += to_fixed(l.b);
            }
        }
        if let Some(splat) = self.splat {
            let (tile, pixels, offsets, rgb) = (self.tile, &self.pixels, &self.offsets, &self.rgb);
            let tw = tile.width();
            let samples = (0..n).map(|j| {
                let k = pixels[j] as usize;
                ((tile.x0 + k % tw, tile.y0 + k / tw), offsets[j], rgb[j])
            });
            splat.add(&mut self.quick, radiance, samples);
        }
        self.runs = 0;
        self.len = 0;
    }

    /// One of the samplers, for other uses of the tile (between batches).
    fn sampler(&mut self) -> &mut Sampler {
        &mut self.samplers[0]
    }
}

/// The camera ray of sample `i` of pixel (x, y) of a `w × h` image, the sample's filter
/// weight and its position in the pixel (from the corner): the first numbers of the sample
/// place it in the pixel (through the filter's distribution), the next ones on the lens.
#[inline]
fn camera_ray(
    scene: &Scene,
    size: (f32, f32),
    (x, y): (usize, usize),
    i: u32,
    (sampler, filter): (&mut Sampler, &FilterSampler),
) -> (Ray, f32, [f32; 2]) {
    let (offset, weight) = filter.sample(sampler.pixel_sample(i));
    let ray = ray_through(scene, size, (x, y), offset, || sampler.next_2d());
    (ray, weight, offset)
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
        let (ray, w, _) = camera_ray(scene, size, (x, y), i, (&mut *sampler, filter));
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

    /// An integrator that returns one value on the left half of the image and another on the
    /// right half (this camera's y axis is the image's x axis, leftwards).
    struct Halves(Rgb, Rgb);
    impl Integrator for Halves {
        fn radiance(
            &self,
            _: &Scene,
            ray: &Ray,
            _: &mut Wavelengths,
            _: &mut Sampler,
            _: &mut RayStats,
        ) -> SampledSpectrum {
            if ray.d.y > 0.0 { self.0 } else { self.1 }.into()
        }
    }

    /// NaN and infinities on the left half of the image.
    const POISON: Halves = Halves(Rgb::new(f32::NAN, 0.0, f32::INFINITY), Rgb::WHITE);

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
        let out = render(&s, &POISON, &settings, &|_| {});
        assert!(out.image.pixels().iter().all(|p| p.is_finite()));
        assert_eq!(out.image.get(0, 0), Rgb::BLACK);
        assert_eq!(out.image.get(7, 0), Rgb::WHITE);
        assert_eq!(out.stats.rejected_samples, 32);
        let _ = Point3::ORIGIN;
    }

    /// One uninterrupted render against the same samples split over passes (any boundaries),
    /// over windows rendered apart and merged, and over thread counts: the same film, bit for
    /// bit; with each pixel's samples in it (the box), and splatted over their neighbours
    /// (wider filters, negative lobes included), where a window's edge pixels take the samples
    /// of pixels outside it.
    #[test]
    fn any_split_of_the_samples_gives_the_same_bits() {
        let s = scene();
        for filter in [
            Filter::Box,
            Filter::Gaussian { stddev: 0.5 },
            Filter::Tent { radius: 1.0 },
            Filter::Lanczos { lobes: 3 },
        ] {
            let settings = RenderSettings {
                width: 23,
                height: 17,
                spp: 21,
                seed: 5,
                filter,
                ..Default::default()
            };
            let full = Window::full(23, 17);
            // The noise integrator's values are its sample's random numbers: every sample
            // differs.
            let path = Noise;
            let mut whole = Film::new(23, 17, full, 3);
            render_pass(&s, &path, &settings, &mut whole, (0, 21), &|_| {});
            let mut passes = Film::new(23, 17, full, 3);
            for range in [(0, 1), (1, 4), (4, 5), (5, 17), (17, 21)] {
                render_pass(&s, &path, &settings, &mut passes, range, &|_| {});
            }
            assert_eq!(passes, whole, "{filter:?}");
            let mut merged = Film::new(23, 17, full, 3);
            for (x0, x1, y0, y1) in [(0, 9, 0, 17), (9, 23, 0, 5), (9, 23, 5, 17)] {
                let w = Window { x0, x1, y0, y1 };
                let mut part = Film::new(23, 17, w, 3);
                render_pass(&s, &path, &settings, &mut part, (0, 10), &|_| {});
                render_pass(&s, &path, &settings, &mut part, (10, 21), &|_| {});
                merged.merge(&part).unwrap();
            }
            assert_eq!(merged, whole, "{filter:?}");
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(3)
                .build()
                .unwrap();
            let mut threaded = Film::new(23, 17, full, 3);
            pool.install(|| render_pass(&s, &path, &settings, &mut threaded, (0, 21), &|_| {}));
            assert_eq!(threaded, whole, "{filter:?}");
            assert!(whole.samples() == 23 * 17 * 21);
            assert!(whole.sums().iter().filter(|&&v| v != 0).count() > 23 * 17 * 2);
        }
    }

    /// An edge (1 left of the middle of the image, 0 right of it) rendered with splatting
    /// comes out as the filter's normalised convolution of it, the image Mitsuba's film
    /// converges to: `∫ g(c − s) step(s) ds / ∫ g(c − s) ds` over the image's columns, in
    /// every column, the first and last ones (where the filter is clipped) included.
    #[test]
    fn splatted_edges_are_the_filtered_image() {
        let edge = Halves(Rgb::WHITE, Rgb::BLACK);
        let s = scene();
        let (w, h) = (12, 6);
        for filter in [
            Filter::Gaussian { stddev: 0.5 },
            Filter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            Filter::Tent { radius: 1.5 },
        ] {
            let settings = RenderSettings {
                width: w,
                height: h,
                spp: 1024,
                filter,
                ..Default::default()
            };
            let out = render(&s, &edge, &settings, &|_| {});
            let integral = |c: f64, a: f64, b: f64| {
                let n = 20000;
                let dh = (b - a) / n as f64;
                (0..n)
                    .map(|k| filter.eval_1d(c - (a + (k as f64 + 0.5) * dh)) * dh)
                    .sum::<f64>()
            };
            for x in 0..w {
                let c = x as f64 + 0.5;
                let expected = integral(c, 0.0, w as f64 / 2.0) / integral(c, 0.0, w as f64);
                for y in 0..h {
                    let v = out.image.get(x, y).r as f64;
                    assert!(
                        (v - expected).abs() < 2e-3,
                        "{filter:?} ({x}, {y}): {v} vs {expected}"
                    );
                }
            }
        }
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
