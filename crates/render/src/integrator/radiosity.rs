//! The `radiosity` integrator: the scene's radiosity is solved once, when the integrator is
//! built (or a cached solution is loaded), and that view-independent solution is shown along
//! every camera ray. The solver itself is the [`crate::radiosity`] library; this file makes a
//! [`Radiosity`] solution an [`Integrator`].

use super::Integrator;
use crate::math::Ray;
use crate::radiosity::{Radiosity, RadiosityOptions, RadiosityOutcome};
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;

/// Solves `scene` (or loads `opts.cache` when it matches): the integrator, and what the solve
/// reports.
pub(super) fn build(
    scene: &Scene,
    opts: &RadiosityOptions,
) -> Result<(Radiosity, RadiosityOutcome), String> {
    opts.validate()?;
    let solution = Radiosity::try_solve(scene, opts)?;
    let outcome = solution.outcome();
    Ok((solution, outcome))
}

impl Integrator for Radiosity {
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        _: &mut Wavelengths,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> SampledSpectrum {
        SampledSpectrum::from_rgb(Radiosity::radiance(self, scene, ray, sampler, stats))
    }

    /// The solution is a colour per patch.
    fn spectral(&self) -> bool {
        false
    }
}
