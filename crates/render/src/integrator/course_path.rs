//! The course's path tracer: at every vertex it spawns `num_of_rays` BSDF-sampled rays (no light
//! sampling) and applies Russian roulette from a depth limit with survival probability
//! max(0.05, 1 − max(ρ)).
//!
//! The tree of rays grows as `num_of_rays`^depth, so the depth must be finite (at most
//! [`MAX_BRANCHING_DEPTH`], which also bounds the recursion) and a camera sample traces at most
//! [`BRANCHING_RAY_BUDGET`] rays: branches beyond the budget are cut (they contribute nothing).

use super::{Integrator, Recursion};
use crate::math::Ray;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;

/// Deepest path of the branching tracer (its recursion depth).
pub const MAX_BRANCHING_DEPTH: u32 = 64;
/// Most rays one camera sample of the branching tracer traces.
pub const BRANCHING_RAY_BUDGET: u32 = 1 << 16;

/// The course's branching path tracer.
#[derive(Clone, Copy, Debug)]
pub struct CoursePath {
    /// Rays spawned at every vertex.
    pub num_of_rays: u32,
    /// Longest path (bounces), at most [`MAX_BRANCHING_DEPTH`].
    pub max_depth: u32,
    /// Depth from which Russian roulette starts.
    pub rr_depth: u32,
}

impl Integrator for CoursePath {
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        lambda: &mut Wavelengths,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> SampledSpectrum {
        let mut t = Recursion {
            scene,
            lambda,
            budget: BRANCHING_RAY_BUDGET,
            sampler,
            stats,
        };
        self.trace(&mut t, ray, 0)
    }
}

impl CoursePath {
    fn trace(&self, t: &mut Recursion, ray: &Ray, depth: u32) -> SampledSpectrum {
        if depth > self.max_depth.min(MAX_BRANCHING_DEPTH) || t.budget == 0 {
            return SampledSpectrum::ZERO;
        }
        t.budget -= 1;
        let scene = t.scene;
        let Some(si) = scene.interact(ray, t.stats) else {
            return scene.escaped(ray.d.normalize(), t.lambda);
        };
        let emitted = scene.emitted(&si, t.lambda);
        let m = scene.material(&si);
        let bsdf = m.bsdf(si.shading_frame(), si.uv, t.lambda);
        let sampler = &mut *t.sampler;
        // The course's roulette: survive with q = max(0.05, 1 − max reflectance).
        let mut scale = 1.0;
        if depth >= self.rr_depth {
            let lum = m.base_color(si.uv).max_component();
            let q = (1.0 - lum).max(0.05);
            if sampler.next_1d() > q {
                scale = 1.0 / (1.0 - q);
            } else {
                return emitted;
            }
        }
        let mut sum = SampledSpectrum::ZERO;
        for _ in 0..self.num_of_rays {
            let u1 = t.sampler.next_1d();
            let u2 = t.sampler.next_2d();
            if let Some(bs) = bsdf.sample(si.wo, u1, u2) {
                let ray = si.spawn_ray(bs.wi);
                sum += bs.weight * self.trace(t, &ray, depth + 1);
            }
        }
        emitted + sum * (scale / self.num_of_rays as f32)
    }
}
