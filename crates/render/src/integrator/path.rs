//! Path tracing of the rendering equation
//! L(x→Θ) = L_e(x→Θ) + ∫ f_r(x, Ψ→Θ) L(x←Ψ) cos(N_x, Ψ) dω_Ψ.
//!
//! [`Path`]: at every vertex one light is sampled (next-event estimation) and one BSDF direction
//! is sampled; both estimates are combined by multiple importance sampling with the power
//! heuristic (Veach 1997). Russian roulette starts at `rr_depth` (default 5). `max_depth` follows
//! Mitsuba: 1 shows only emitters seen directly, 2 adds direct lighting, -1 is unlimited.
//!
//! [`CoursePath`]: the course's estimator, which at every vertex spawns `num_of_rays` BSDF-sampled
//! rays (no light sampling) and applies Russian roulette from a depth limit with survival
//! probability max(0.05, 1 − max(ρ)).

use super::Integrator;
use crate::color::Rgb;
use crate::math::Ray;
use crate::sampling::warp::power_heuristic;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::stats::RayStats;

/// The unidirectional path tracer with next-event estimation and MIS.
#[derive(Clone, Copy, Debug)]
pub struct Path {
    /// Longest path in vertices (Mitsuba's convention); `None` for unlimited.
    pub max_depth: Option<u32>,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: u32,
    /// Do not show emitters seen directly by the camera.
    pub hide_emitters: bool,
}

impl Default for Path {
    fn default() -> Self {
        Self {
            max_depth: None,
            rr_depth: 5,
            hide_emitters: false,
        }
    }
}

impl Integrator for Path {
    fn radiance(
        &self,
        scene: &Scene,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let max_depth = self.max_depth.unwrap_or(u32::MAX);
        let light_pick = if scene.lights.is_empty() {
            0.0
        } else {
            1.0 / scene.lights.len() as f32
        };
        let mut l = Rgb::BLACK;
        let mut beta = Rgb::WHITE;
        let mut ray = *camera_ray;
        // The previous vertex's BSDF density and whether it was a Dirac delta, for MIS.
        let mut prev_pdf = 0.0f32;
        let mut prev_delta = true;
        let mut prev_p = ray.o;
        let mut eta_scale = 1.0f32;
        let mut depth = 0u32;
        loop {
            let Some(si) = scene.interact(&ray, stats) else {
                // Lights at infinity, weighted against their own sampling.
                if depth > 0 || !self.hide_emitters {
                    let d = ray.d.normalize();
                    l += beta * scene.background;
                    for &i in &scene.infinite_lights {
                        let light = &scene.lights[i as usize];
                        let le = light.escaped(d);
                        if le.is_black() {
                            continue;
                        }
                        let w = if prev_delta {
                            1.0
                        } else {
                            power_heuristic(1.0, prev_pdf, 1.0, light_pick * light.pdf_escape(d))
                        };
                        l += beta * le * w;
                    }
                }
                break;
            };

            // Emission found by BSDF sampling (or by the camera).
            if depth > 0 || !self.hide_emitters {
                let le = scene.emitted(&si);
                if !le.is_black() {
                    let w = match si.props.light {
                        Some(li) if !prev_delta => {
                            let pdf_light =
                                light_pick * scene.lights[li as usize].pdf_hit(prev_p, si.p, si.n);
                            power_heuristic(1.0, prev_pdf, 1.0, pdf_light)
                        }
                        _ => 1.0,
                    };
                    l += beta * le * w;
                }
            }
            if depth + 1 >= max_depth {
                break;
            }

            let bsdf = scene.material(&si).bsdf(si.shading_frame(), si.uv);
            // The outgoing direction in the shading frame, shared by every BSDF query below.
            let (wo, flip) = bsdf.local_wo(si.wo);

            // Next-event estimation: one light, chosen uniformly.
            if !bsdf.is_delta() && light_pick > 0.0 {
                let n = scene.lights.len() as u32;
                let pick = if n == 1 { 0 } else { sampler.next_index(n) };
                let u = sampler.next_2d();
                let light = &scene.lights[pick as usize];
                if let Some(ls) = light.sample(&scene.geometry, &scene.emissions, si.p, u) {
                    let wi = bsdf.local_wi(ls.wi, flip);
                    let f = bsdf.eval_local(wo, wi);
                    if !f.is_black() && !super::local::shadowed(scene, &si, ls.wi, ls.target, stats)
                    {
                        let pdf_light = light_pick * ls.pdf;
                        let w = if ls.delta {
                            1.0
                        } else {
                            power_heuristic(1.0, pdf_light, 1.0, bsdf.pdf_local(wo, wi))
                        };
                        l += beta * f * ls.li * (w / pdf_light);
                    }
                }
            } else if !bsdf.is_delta() {
                // Keep the sample stream aligned whether or not lights exist.
                sampler.next_1d();
                sampler.next_2d();
            }

            // BSDF sampling continues the path.
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            let Some(bs) = bsdf.sample_local(wo, flip, u1, u2) else {
                break;
            };
            beta *= bs.weight;
            if beta.is_black() {
                break;
            }
            prev_pdf = bs.pdf;
            prev_delta = bs.delta;
            prev_p = si.p;
            eta_scale *= bs.eta * bs.eta;
            ray = si.spawn_ray(bs.wi);
            depth += 1;

            // Russian roulette from `rr_depth` on: the path survives with probability
            // q = min(max(β)·Πη², 0.95), where Πη² is the product of the squared relative
            // indices of the refractions taken so far (`eta_scale`), and survivors are divided
            // by q. Refraction into a denser medium scales radiance (and so β) by 1/η²;
            // multiplying it back out keeps paths inside glass from being terminated for
            // that compression alone, which would make their survivors fireflies (as pbrt-v4
            // and Mitsuba 3 do).
            if depth >= self.rr_depth {
                let q = (beta.max_component() * eta_scale).min(0.95);
                if !(sampler.next_1d() < q) {
                    break;
                }
                beta /= q;
            }
        }
        l
    }
}

/// The course's branching path tracer.
#[derive(Clone, Copy, Debug)]
pub struct CoursePath {
    /// Rays spawned at every vertex.
    pub num_of_rays: u32,
    /// Longest path (bounces); `None` for unlimited (roulette still ends paths).
    pub max_depth: Option<u32>,
    /// Depth from which Russian roulette starts.
    pub rr_depth: u32,
}

impl Integrator for CoursePath {
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        self.trace(scene, ray, 0, sampler, stats)
    }
}

impl CoursePath {
    fn trace(
        &self,
        scene: &Scene,
        ray: &Ray,
        depth: u32,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        if self.max_depth.is_some_and(|m| depth > m) {
            return Rgb::BLACK;
        }
        let Some(si) = scene.interact(ray, stats) else {
            return scene.escaped(ray.d.normalize());
        };
        let emitted = scene.emitted(&si);
        let m = scene.material(&si);
        let bsdf = m.bsdf(si.shading_frame(), si.uv);
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
        let mut sum = Rgb::BLACK;
        for _ in 0..self.num_of_rays {
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            if let Some(bs) = bsdf.sample(si.wo, u1, u2) {
                sum +=
                    bs.weight * self.trace(scene, &si.spawn_ray(bs.wi), depth + 1, sampler, stats);
            }
        }
        emitted + sum * (scale / self.num_of_rays as f32)
    }
}
