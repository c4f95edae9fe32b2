//! Integrators: the algorithms that turn a camera ray into radiance.
//!
//! An integrator is chosen once per render (cold path), so it is a trait object; everything it
//! calls per ray (shapes, materials, lights) is a closed enum.

mod course_path;
mod debug;
mod local;
mod path;
mod radiosity;
mod whitted;

pub use course_path::{CoursePath, BRANCHING_RAY_BUDGET, MAX_BRANCHING_DEPTH};
pub use debug::{Depth, Flat, Normals, OnOff};
pub use local::{shade, Local};
pub use path::Path;
pub use whitted::{Whitted, MAX_WHITTED_DEPTH, WHITTED_RAY_BUDGET};

use crate::math::Ray;
use crate::sampling::{SampleCursor, Sampler};
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;

/// Computes the radiance arriving along a camera ray.
pub trait Integrator: Sync {
    /// The radiance arriving at the ray's origin from direction `-ray.d`, in the lanes of
    /// `lambda` (RGB channels or sampled wavelengths; a dispersive interface may leave only the
    /// hero wavelength). Implementations draw every random number from `sampler` and count the
    /// rays they trace in `stats`.
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        lambda: &mut Wavelengths,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> SampledSpectrum;

    /// True when the integrator follows radiance per wavelength (spectral mode); false for
    /// those whose result is a colour by definition (debug views, radiosity).
    fn spectral(&self) -> bool {
        true
    }

    /// The radiance along each of `rays` (at most [`BATCH_SAMPLES`]): ray i, in the lanes of
    /// `lambdas[i]`, continues the sample at `cursors[i]` (left at its end) of the pixel of
    /// `samplers[samplers_of[i]]`, and its radiance goes to `out[i]`. Each result equals what
    /// [`Integrator::radiance`] gives for that ray and sample alone; integrators that can trace
    /// paths side by side do so.
    fn radiance_batch(
        &self,
        scene: &Scene,
        batch: SampleBatch<'_>,
        samplers: &mut [Sampler],
        stats: &mut RayStats,
        out: &mut [SampledSpectrum],
    ) {
        for (i, ray) in batch.rays.iter().enumerate() {
            let sampler = &mut samplers[batch.samplers_of[i] as usize];
            sampler.resume(batch.cursors[i]);
            out[i] = self.radiance(scene, ray, &mut batch.lambdas[i], sampler, stats);
            batch.cursors[i] = sampler.cursor();
        }
    }
}

/// The most samples of one run (of one pixel, with one sampler) handed to
/// [`Integrator::radiance_batch`]: the samples whose numbers a pixel sampler tabulates
/// together (four batches).
pub const SAMPLE_QUEUE: usize = crate::sampling::sampler::TABLE_SAMPLES;
const _: () = assert!(SAMPLE_QUEUE.is_multiple_of(crate::math::BATCH));

/// The most runs of at most [`SAMPLE_QUEUE`] samples (of one pixel each, each with its own
/// sampler) handed to [`Integrator::radiance_batch`] at once: paths traced side by side then
/// end in one drain where only a few are left, for several pixels, rather than one per pixel.
pub const BATCH_RUNS: usize = 16;

/// The most samples handed to [`Integrator::radiance_batch`] at once.
pub const BATCH_SAMPLES: usize = BATCH_RUNS * SAMPLE_QUEUE;

/// Samples traced side by side: sample i has the camera ray `rays[i]`, the wavelengths
/// `lambdas[i]` (left as the path ends them) and its place in its pixel's sample sequence
/// `cursors[i]` (left at the sample's end), drawn from the sampler `samplers_of[i]`.
pub struct SampleBatch<'a> {
    /// The camera rays (at most [`BATCH_SAMPLES`]).
    pub rays: &'a [Ray],
    /// What each path's lanes mean.
    pub lambdas: &'a mut [Wavelengths],
    /// Where each sample's numbers continue.
    pub cursors: &'a mut [SampleCursor],
    /// The sampler of each sample's pixel (an index into the samplers handed over with the
    /// batch).
    pub samplers_of: &'a [u8],
}

/// The RGB radiance `integrator` gives along `ray` (unit tests of single rays).
#[cfg(test)]
pub(crate) fn rgb_radiance(
    integrator: &dyn Integrator,
    scene: &Scene,
    ray: &Ray,
    stats: &mut RayStats,
) -> crate::color::Rgb {
    integrator
        .radiance(
            scene,
            ray,
            &mut Wavelengths::Rgb,
            &mut Sampler::new(0, 0),
            stats,
        )
        .to_rgb()
}

/// What a recursive integrator's calls share (Whitted's tree, the course's branching tracer):
/// the scene, the sample's wavelengths (a dispersive interface anywhere in the tree keeps only
/// the hero), the budget of rays left, the sampler and the counters.
pub(crate) struct Recursion<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) lambda: &'a mut Wavelengths,
    pub(crate) budget: u32,
    pub(crate) sampler: &'a mut Sampler,
    pub(crate) stats: &'a mut RayStats,
}

/// Settings that integrators read (each ignores what it does not use).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IntegratorSettings {
    /// Path length limit; `None` or -1: the integrator's default (unlimited for `path`).
    pub max_depth: Option<i32>,
    /// The course's branching factor for `path`.
    pub num_of_rays: u32,
    /// Depth from which Russian roulette starts (Mitsuba's `rr_depth`).
    pub rr_depth: Option<u32>,
    /// Hide directly visible emitters (Mitsuba's `hide_emitters`).
    pub hide_emitters: bool,
    /// Options of the `radiosity` integrator.
    pub radiosity: crate::radiosity::RadiosityOptions,
}

/// The integrators selectable by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntegratorKind {
    /// White on hit, black on miss.
    OnOff,
    /// Colour + emission.
    Flat,
    /// Normals as colours.
    Normals,
    /// Hit distance.
    Depth,
    /// Ray casting with the local Phong model, no shadows.
    Local,
    /// The local model with shadow rays.
    Direct,
    /// Whitted's recursive ray tracing.
    Whitted,
    /// Path tracing of the rendering equation.
    Path,
    /// Radiosity.
    Radiosity,
}

impl IntegratorKind {
    /// The command-line names, in order.
    pub const NAMES: &'static [&'static str] = &[
        "onoff",
        "flat",
        "normals",
        "depth",
        "local",
        "direct",
        "whitted",
        "path",
        "radiosity",
    ];

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        use IntegratorKind::*;
        let all = [
            OnOff, Flat, Normals, Depth, Local, Direct, Whitted, Path, Radiosity,
        ];
        Self::NAMES.iter().position(|&n| n == name).map(|i| all[i])
    }

    /// True when the integrator follows radiance per wavelength in spectral renders (see
    /// [`Integrator::spectral`]): `path`, `direct`, `local`, `whitted`.
    pub fn spectral(self) -> bool {
        matches!(
            self,
            IntegratorKind::Path
                | IntegratorKind::Direct
                | IntegratorKind::Local
                | IntegratorKind::Whitted
        )
    }

    /// The integrator for `scene`, with what building it reported (a radiosity solve), or why
    /// it cannot be built.
    pub fn build(
        self,
        scene: &Scene,
        settings: &IntegratorSettings,
    ) -> Result<BuiltIntegrator, String> {
        let integrator: Box<dyn Integrator> = match self {
            IntegratorKind::OnOff => Box::new(OnOff),
            IntegratorKind::Flat => Box::new(Flat),
            IntegratorKind::Normals => Box::new(Normals),
            IntegratorKind::Depth => Box::new(Depth),
            IntegratorKind::Local => Box::new(Local { shadows: false }),
            IntegratorKind::Direct => Box::new(Local { shadows: true }),
            IntegratorKind::Whitted => Box::new(Whitted {
                max_depth: whitted_depth(settings.max_depth)?,
            }),
            IntegratorKind::Path => {
                let max_depth = settings.max_depth.filter(|&d| d >= 0).map(|d| d as u32);
                let rr_depth = settings.rr_depth.unwrap_or(5);
                if settings.num_of_rays > 1 {
                    Box::new(CoursePath {
                        num_of_rays: settings.num_of_rays,
                        max_depth: branching_depth(settings.num_of_rays, settings.max_depth)?,
                        rr_depth,
                    })
                } else {
                    Box::new(Path {
                        max_depth,
                        rr_depth,
                        hide_emitters: settings.hide_emitters,
                    })
                }
            }
            IntegratorKind::Radiosity => {
                let (integrator, outcome) = radiosity::build(scene, &settings.radiosity)?;
                return Ok(BuiltIntegrator {
                    integrator: Box::new(integrator),
                    radiosity: Some(outcome),
                });
            }
        };
        Ok(BuiltIntegrator {
            integrator,
            radiosity: None,
        })
    }
}

/// Whitted's recursion depth for `--max-depth` (`None`: 10; -1: the most,
/// [`MAX_WHITTED_DEPTH`]), or why it is out of range.
pub fn whitted_depth(max_depth: Option<i32>) -> Result<u32, String> {
    match max_depth {
        None => Ok(10),
        Some(d) if d < 0 => Ok(MAX_WHITTED_DEPTH),
        Some(d) if d as u32 > MAX_WHITTED_DEPTH => Err(format!(
            "--max-depth {d}: whitted follows at most {MAX_WHITTED_DEPTH} reflections and refractions (docs/limits.md)"
        )),
        Some(d) => Ok(d as u32),
    }
}

/// The depth of the course's branching tracer (`--num-of-rays` N > 1) for `--max-depth`,
/// which must be given and at most [`MAX_BRANCHING_DEPTH`], or why not.
pub fn branching_depth(num_of_rays: u32, max_depth: Option<i32>) -> Result<u32, String> {
    match max_depth {
        Some(d) if d >= 0 && d as u32 <= MAX_BRANCHING_DEPTH => Ok(d as u32),
        Some(d) if d >= 0 => Err(format!(
            "--max-depth {d}: with --num-of-rays {num_of_rays} the depth is at most {MAX_BRANCHING_DEPTH} (docs/limits.md)"
        )),
        _ => Err(format!(
            "--num-of-rays {num_of_rays} needs a finite --max-depth (0 to {MAX_BRANCHING_DEPTH}): the branching tracer traces up to {num_of_rays}^depth rays per sample"
        )),
    }
}

/// An integrator ready to render, with what building it reported.
pub struct BuiltIntegrator {
    /// The integrator.
    pub integrator: Box<dyn Integrator>,
    /// The report (and the solution's bytes, when computed) of a radiosity solve.
    pub radiosity: Option<crate::radiosity::RadiosityOutcome>,
}
