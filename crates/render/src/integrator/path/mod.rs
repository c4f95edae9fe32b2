//! Path tracing of the rendering equation
//! L(x→Θ) = L_e(x→Θ) + ∫ f_r(x, Ψ→Θ) L(x←Ψ) cos(N_x, Ψ) dω_Ψ.
//!
//! [`Path`]: at every vertex one light is sampled (next-event estimation: the light chosen by
//! its importance at the shading point, see [`crate::light::LightSelector`], and sampled by
//! [`crate::light::Light::sample_from`]) and one BSDF direction is sampled; both estimates are
//! combined by multiple importance sampling with the power heuristic (Veach 1997). In scenes
//! of two to eight lights, delta lights and emissive shapes with at least one delta light,
//! every vertex samples every light instead, each with its shadow ray (see `every_light`).
//! Russian roulette starts at `rr_depth` (default 5). `max_depth` follows
//! Mitsuba: 1 shows only emitters seen directly, 2 adds direct lighting, -1 is unlimited.
//! (The course's branching estimator is [`super::CoursePath`].)

mod microfacet_lanes;
mod surface_lanes;

use super::{Integrator, SampleBatch, BATCH_SAMPLES};
use crate::interaction::Hit;
use crate::light::ShadingPoint;
use crate::light::{AreaShape, Light};
use crate::material::{
    conductor_index, relative_eta, sample_smooth, sample_specular, Bsdf, BsdfSample, Distribution,
    IncidencePlane, Model, RoughCoating, RoughPlastic,
};
use crate::math::{lanes, Ray, RayBatch, Vec3, BATCH};
use crate::sampling::guide::GuideCones;
use crate::sampling::warp::power_heuristic;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;
use surface_lanes::{ConductorVertex, LaneLight, LaneVertex, PlasticVertex, SurfaceLanes};

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

/// A path between two vertices: what it has gathered, its throughput, the ray it continues
/// along and what multiple importance sampling needs of the vertex it left.
#[derive(Clone, Copy, Debug)]
struct PathState {
    l: SampledSpectrum,
    beta: SampledSpectrum,
    /// What the lanes of `l` and `beta` mean.
    lambda: Wavelengths,
    ray: Ray,
    /// The previous vertex's BSDF density and whether it was a Dirac delta, for MIS.
    prev_pdf: f32,
    prev_delta: bool,
    /// The previous vertex as light selection and sampling saw it (MIS recomputes the
    /// density with which it would have sampled the emitter the path finds).
    prev: ShadingPoint,
    eta_scale: f32,
    depth: u32,
}

impl PathState {
    fn new(camera_ray: &Ray, lambda: Wavelengths) -> Self {
        Self {
            l: SampledSpectrum::ZERO,
            beta: SampledSpectrum::ONE,
            lambda,
            ray: *camera_ray,
            prev_pdf: 0.0,
            prev_delta: true,
            prev: ShadingPoint::at(camera_ray.o),
            eta_scale: 1.0,
            depth: 0,
        }
    }

    /// Starts this state over on a new camera ray: [`PathState::new`] in place, field by field
    /// (built whole and copied, the state goes through the stack in pieces that a later whole
    /// load cannot be forwarded from). `prev` keeps its value: a path that starts from the
    /// camera reads it only once a vertex has set it (`prev_delta` is true until then).
    #[inline(always)]
    fn start(&mut self, camera_ray: &Ray, lambda: Wavelengths) {
        self.l = SampledSpectrum::ZERO;
        self.beta = SampledSpectrum::ONE;
        self.lambda = lambda;
        self.ray = *camera_ray;
        self.prev_pdf = 0.0;
        self.prev_delta = true;
        self.eta_scale = 1.0;
        self.depth = 0;
    }
}

/// True when a material of the scene is one [`Path::delta_vertex`] shades (a perfect mirror
/// or a smooth dielectric), looked for among its first 256 materials: that path only saves
/// time (the general vertex gives the same bits), and this is asked once per batch.
#[inline]
fn has_delta_surfaces(scene: &Scene) -> bool {
    scene.materials.iter().take(256).any(|m| {
        matches!(
            m.model,
            Model::Specular { .. }
                | Model::Conductor {
                    eta_k: None,
                    mf: None,
                    ..
                }
                | Model::Dielectric { mf: None, .. }
        )
    })
}

/// The highest survival probability of Russian roulette (see `Path::roulette`): 1 when
/// `max_depth` bounds the path, 0.95 when its length is unlimited, so that every path ends.
#[inline(always)]
fn roulette_cap(unbounded: bool) -> f32 {
    if unbounded {
        0.95
    } else {
        1.0
    }
}

/// True when the vertex at `depth` (0 for the camera's hit) samples a light. A scene lit by a
/// single light at infinity that BSDF sampling finds as well as a light sample could (a
/// constant sky, a hemisphere light: [`Light::is_smooth_at_infinity`]) samples it at the
/// first vertex only: deeper, the shadow ray costs more than the variance it saves, and MIS
/// gives the BSDF samples that escape their full weight there (the previous vertex's choice
/// probability is 0). On the bench's meshes under the sky alone (4 seeds): 0.83× the time for
/// 1.13× the variance, so 1.07× the efficiency; without light samples at any vertex the time
/// was 0.67× but the variance 1.53×. Where the sky is not alone, light selection already gives
/// it no share (see `light::select`).
#[inline(always)]
fn samples_lights(scene: &Scene, depth: u32) -> bool {
    // (The scene's lights first: the same every time, where the depth changes from one path
    // to the next.)
    !matches!(&scene.lights[..], [l] if l.is_smooth_at_infinity()) || depth == 0
}

/// The most lights a vertex samples all of (see [`every_light`]).
const MAX_SHADOWS: usize = 8;

/// The shadow rays of a vertex that samples every light, with what each adds.
type Shadows = [Option<(Ray, SampledSpectrum)>; MAX_SHADOWS];

/// True when every vertex samples every light, each with its own shadow ray, rather than
/// one chosen by its importance: a scene of two to [`MAX_SHADOWS`] lights, delta lights
/// (point, spot, distant) and emissive shapes, at least one a delta light. Their light samples
/// cost little and the choice of one would add its own variance (and the importances cost as
/// much as the samples). BSDF sampling never finds a delta light; a shape's light sample and
/// BSDF sampling are weighed by MIS, the light's choice probability being 1. (Emissive shapes
/// alone keep the uniform choice of one, cheaper there: see `light::select`.)
#[inline]
fn every_light(scene: &Scene) -> bool {
    let lights = &scene.lights;
    let delta = |l: &Light| matches!(l, Light::Point(..) | Light::Spot(..) | Light::Distant(..));
    (2..=MAX_SHADOWS).contains(&lights.len())
        && lights.iter().any(delta)
        && lights
            .iter()
            .all(|l| delta(l) || matches!(l, Light::Area(..)))
}

/// The BSDF's value for a light sample's direction `wi` (local, as `wo`) and, where MIS
/// weighs the sample (not a delta light), its density there: both at once.
#[inline(always)]
fn eval_for(
    bsdf: &crate::material::Bsdf,
    ls: &crate::light::LightSample,
    wo: crate::math::Vec3,
    wi: crate::math::Vec3,
) -> (SampledSpectrum, f32) {
    if ls.delta {
        (bsdf.eval_local(wo, wi), 0.0)
    } else {
        bsdf.eval_pdf_local(wo, wi)
    }
}

/// The models the batch's lanes shade ([`SurfaceLanes`]), with what each needs besides its
/// first texture: a rough GGX conductor's α and complex index, a rough plastic's specular
/// reflectance, coating and `nonlinear`.
enum LaneModel<'s> {
    Lambert,
    Conductor(
        f32,
        &'s Option<(crate::texture::Texture, crate::texture::Texture)>,
    ),
    Plastic(&'s crate::texture::Texture, &'s RoughCoating, bool),
}

/// The numbers a rough conductor's or rough plastic's lane draws ([`Sampler::lambert_numbers`],
/// or [`Sampler::surface_numbers`] for the plastic's choice of lobe), and what the lanes take
/// of its model: `first` is its first texture, `wo_z` the outgoing direction's local z, `at`
/// the texture coordinates and the path's wavelengths (the direction's local x and y are the
/// lanes' to compute). Out of line, as [`SurfaceLanes::set_surface`] is, so that the Lambert
/// vertex stays as short as it was without these models.
#[inline(never)]
fn surface_lane<'s>(
    model: LaneModel<'s>,
    first: &'s crate::texture::Texture,
    wo_z: f32,
    (uv, lambda): (crate::math::Point2, &Wavelengths),
    sampler: &mut Sampler,
    roulette: bool,
) -> LaneNumbers<'s> {
    let refl =
        |t: &crate::texture::Texture| t.spectral(uv, lambda, crate::spectrum::RgbRole::Reflectance);
    match model {
        LaneModel::Plastic(ks, coating, nonlinear) => {
            let (u, u1, u2, u_rr) = sampler.surface_numbers(roulette);
            let (kd, ks) = (refl(first), refl(ks));
            let p = RoughPlastic {
                kd,
                ks,
                coating,
                nonlinear,
            };
            let (t_o, ps, kb) = p.lane_terms(wo_z);
            let v = PlasticVertex {
                coating,
                t_o,
                ps,
                kb,
                ks,
                u1,
            };
            (u, u2, u_rr, None, Some(v))
        }
        LaneModel::Conductor(alpha, eta_k) => {
            let (u, u2, u_rr) = sampler.lambert_numbers(roulette);
            let c = ConductorVertex {
                alpha,
                eta_k: conductor_index(eta_k.as_ref(), uv, lambda),
            };
            (u, u2, u_rr, Some(c), None)
        }
        LaneModel::Lambert => {
            let (u, u2, u_rr) = sampler.lambert_numbers(roulette);
            (u, u2, u_rr, None, None)
        }
    }
}

/// What [`surface_lane`] gives: the light pair, the direction pair, the roulette's number, and
/// the conductor's or plastic's terms.
type LaneNumbers<'s> = (
    [f32; 2],
    [f32; 2],
    Option<f32>,
    Option<ConductorVertex>,
    Option<PlasticVertex<'s>>,
);

/// A diffuse vertex's next direction with caustic guides (`cones`, see `sampling::guide`):
/// from the cone the first number of `u2` picks, or else the BSDF's cosine-weighted sample
/// (`GuideCones::split`), weighed by f·cos over the mixture's density. (The lanes repeat it:
/// `SurfaceLanes::shade`.)
#[inline(never)]
fn guided_sample(
    bsdf: &Bsdf,
    cones: &GuideCones,
    (wo, flip): (Vec3, bool),
    u1: f32,
    u2: [f32; 2],
) -> Option<BsdfSample> {
    let (j, v) = cones.split(u2[0]);
    let u = [v, u2[1]];
    let wi = match j {
        Some(j) => cones.sample(j, u),
        None => bsdf.sample_local(wo, flip, u1, u)?.wi,
    };
    if !wi.is_finite() {
        return None;
    }
    let (f, pdf_b) = bsdf.eval_pdf_local(wo, bsdf.local_wi(wi, flip));
    let pdf = cones.mix(pdf_b, wi);
    if !(pdf > 0.0) || f.is_black() {
        return None;
    }
    Some(BsdfSample {
        wi,
        weight: SampledSpectrum(f.0.map(|x| x / pdf)),
        pdf,
        delta: false,
        eta: 1.0,
    })
}

/// What a vertex asks of the caller: a shadow ray to test and the radiance it adds when the
/// ray is unblocked (next-event estimation), and whether the path goes on.
struct VertexOutcome {
    shadow: Option<(Ray, SampledSpectrum)>,
    alive: bool,
}

impl Path {
    /// The vertex where `st.ray` ends (`hit`, or nothing when it escapes): adds the emission
    /// found there, samples a light (the shadow ray is the caller's to test), samples the
    /// next direction and plays Russian roulette.
    ///
    /// With `defer` (the batch's lanes and this path's lane), a vertex at a Lambert surface, a
    /// rough GGX conductor or a rough plastic with a GGX coating stops once it has drawn its
    /// numbers and sampled a light, and leaves the rest to [`SurfaceLanes::shade`]: it then returns `None`. With `delta`, a vertex at a perfect
    /// mirror or a smooth dielectric is shaded by [`Path::delta_vertex`].
    #[inline(always)]
    fn vertex<'s>(
        &self,
        scene: &'s Scene,
        st: &mut PathState,
        hit: Option<Hit>,
        sampler: &mut Sampler,
        (defer, delta): (Option<(&mut SurfaceLanes<'s>, usize)>, bool),
        every: Option<&mut Shadows>,
    ) -> Option<VertexOutcome> {
        let done = Some(VertexOutcome {
            shadow: None,
            alive: false,
        });
        let max_depth = self.max_depth.unwrap_or(u32::MAX);
        let lights = &scene.lights[..];
        let Some(hit) = hit else {
            // Lights at infinity, weighted against their own sampling.
            if st.depth > 0 || !self.hide_emitters {
                // (Unit to round-off already, as the path's rays are: not normalised again.
                // The square root and division were about 1 % of a frame under a sky.)
                let d = crate::geometry::unit_direction(st.ray.d);
                st.l += st.beta * scene.background(&st.lambda);
                for &i in &scene.infinite_lights {
                    let light = &scene.lights[i as usize];
                    // (The density only where MIS weighs the light against the BSDF: not
                    // after a delta vertex, nor for a light that light sampling never picks.)
                    let never = scene.light_selector.never_picks(i as usize);
                    let unweighed = st.prev_delta || never;
                    let sp = (!unweighed).then_some(&st.prev);
                    let (le, pdf) = light.escaped_with_pdf(d, &st.lambda, sp);
                    if le.is_black() {
                        continue;
                    }
                    let w = if unweighed || !samples_lights(scene, st.depth - 1) {
                        1.0
                    } else {
                        let pick = scene.light_selector.pmf(lights, &st.prev, i as usize);
                        power_heuristic(1.0, st.prev_pdf, 1.0, pick * pdf)
                    };
                    st.l += st.beta * le * w;
                }
            }
            return done;
        };
        let si = scene.interaction(&st.ray, &hit);

        // Emission found by BSDF sampling (or by the camera).
        if st.depth > 0 || !self.hide_emitters {
            let le = scene.emitted(&si, &st.lambda);
            if !le.is_black() {
                let w = match si.props.light {
                    Some(li) if !st.prev_delta => {
                        // (Every light is sampled at every vertex in the every-light mode.)
                        let pick = match every {
                            Some(_) => 1.0,
                            None => scene.light_selector.pmf(lights, &st.prev, li as usize),
                        };
                        let pdf_light = pick * lights[li as usize].pdf_hit(st.prev.p, si.p, si.n);
                        power_heuristic(1.0, st.prev_pdf, 1.0, pdf_light)
                    }
                    _ => 1.0,
                };
                st.l += st.beta * le * w;
            }
        }
        if st.depth + 1 >= max_depth {
            return done;
        }

        let material = scene.material(&si);
        let (lambert, lane) = match defer {
            Some((lambert, lane)) => (Some(lambert), lane),
            None => (None, 0),
        };
        // The models the lanes shade: Lambert's, a rough isotropic GGX conductor (its α and complex
        // index), a rough plastic with a GGX coating.
        let lane_model = match &material.model {
            Model::Diffuse { reflectance } => Some((reflectance, LaneModel::Lambert)),
            Model::Conductor {
                eta_k,
                reflectance,
                mf: Some(mf),
            } if mf.dist == Distribution::Ggx && mf.is_isotropic() => {
                Some((reflectance, LaneModel::Conductor(mf.alpha, eta_k)))
            }
            Model::RoughPlastic {
                kd,
                ks,
                coating,
                nonlinear,
            } if coating.mf.dist == Distribution::Ggx => {
                Some((kd, LaneModel::Plastic(ks, coating, *nonlinear)))
            }
            _ => None,
        };
        if let (Some(lanes), Some((reflectance, model))) = (lambert, lane_model) {
            // A Lambert, rough-conductor or rough-plastic vertex, left to the batch's lanes
            // once its numbers are drawn (in the order the scalar vertex below draws them, the
            // roulette's even where the path could end before it: it then goes unused). What
            // `Material::bsdf`, `Bsdf::local_wo` and the shading point below give, without
            // building the BSDF.
            let frame = si.shading_frame();
            let cos_o = si.wo.dot(frame.n);
            let flip = material.two_sided && cos_o < 0.0;
            let wo_z = if flip { -cos_o } else { cos_o };
            let roulette = st.depth + 1 >= self.rr_depth;
            let lambert_lane = matches!(model, LaneModel::Lambert);
            let (u, u2, u_rr, surface) = match model {
                LaneModel::Lambert => {
                    let (u, u2, u_rr) = sampler.lambert_numbers(roulette);
                    (u, u2, u_rr, None)
                }
                _ => {
                    let at = (si.uv, &st.lambda);
                    let (u, u2, u_rr, c, p) =
                        surface_lane(model, reflectance, wo_z, at, sampler, roulette);
                    (u, u2, u_rr, Some((c, p)))
                }
            };
            // The shading point, made where the path keeps it if it goes on (unread if it ends
            // here; a copy made on the stack would be reloaded whole from pieces).
            st.prev.p = si.p;
            st.prev.n = if cos_o < 0.0 { -frame.n } else { frame.n };
            st.prev.reflect_only = true;
            let light = if every.is_some() {
                // Every light, each sampled by itself with the same numbers (as below).
                for (k, light) in lights.iter().enumerate() {
                    let ls = light.sample_from(
                        &scene.geometry,
                        &scene.emissions,
                        &st.prev,
                        u,
                        &st.lambda,
                    );
                    lanes.set_sample(lane, k, ls.as_ref(), 1.0);
                }
                LaneLight::Given
            } else {
                self.lane_light(scene, st, &st.prev, u)
            };
            st.prev_delta = false;
            st.depth += 1;
            lanes.set(
                lane,
                &LaneVertex {
                    p: si.p,
                    ng: si.n,
                    frame,
                    wo_z,
                    flip,
                    reflectance,
                    uv: si.uv,
                    lambda: &st.lambda,
                    beta: st.beta,
                    light,
                    u2,
                    u_rr,
                    eta_scale: st.eta_scale,
                },
            );
            if let Some((conductor, plastic)) = surface {
                lanes.set_surface(lane, si.wo, conductor, plastic);
            }
            if lambert_lane && !scene.guides.is_empty() {
                // (Its direction sampled with the caustic guides: `guided_sample` below.)
                lanes.set_guided(lane);
            }
            return None;
        }
        if delta {
            if let Some(alive) = self.delta_vertex(st, &si, material, sampler) {
                return Some(VertexOutcome {
                    shadow: None,
                    alive,
                });
            }
        }
        let bsdf = material.bsdf(si.shading_frame(), si.uv, &mut st.lambda);
        // The outgoing direction in the shading frame, shared by every BSDF query below.
        let (wo, flip) = bsdf.local_wo(si.wo);

        // The shading point as light selection and sampling see it: the shading normal turned
        // to the side of the outgoing direction.
        let ns = bsdf.frame.n;
        let sp = ShadingPoint {
            p: si.p,
            n: if ns.dot(si.wo) < 0.0 { -ns } else { ns },
            reflect_only: bsdf.reflects_only(),
        };

        // Caustic guides (see `sampling::guide`): a diffuse vertex's directions are drawn
        // towards the specular objects too, and weighed by the mixture's density.
        let cones = match material.model {
            Model::Diffuse { .. } if !scene.guides.is_empty() => {
                GuideCones::at(&scene.guides, si.p)
            }
            _ => GuideCones::NONE,
        };

        // Next-event estimation (see `Path::sample_light`).
        let mut shadow = None;
        if let (false, Some(every)) = (bsdf.is_delta(), every) {
            // A few lights: every one of them, each with its shadow ray (see `every_light`),
            // left in `every`; a shape's sample weighed against BSDF sampling by MIS.
            let u = sampler.next_2d();
            for (k, light) in lights.iter().enumerate() {
                let ls = light.sample_from(&scene.geometry, &scene.emissions, &sp, u, &st.lambda);
                if let Some(ls) = ls {
                    let wi = bsdf.local_wi(ls.wi, flip);
                    let (f, pdf) = eval_for(&bsdf, &ls, wo, wi);
                    if !f.is_black() {
                        let w = if ls.delta {
                            1.0
                        } else {
                            power_heuristic(1.0, ls.pdf, 1.0, cones.mix(pdf, ls.wi))
                        };
                        every[k] = Some((
                            super::local::shadow_ray(&si, ls.wi, ls.target),
                            st.beta * f * ls.li * (w / ls.pdf),
                        ));
                    }
                }
            }
        } else if !bsdf.is_delta() {
            if let Some((ls, pick_pdf)) = self.sample_light(scene, st, &sp, sampler) {
                let wi = bsdf.local_wi(ls.wi, flip);
                let (f, pdf) = eval_for(&bsdf, &ls, wo, wi);
                if !f.is_black() {
                    let pdf_light = pick_pdf * ls.pdf;
                    let w = if ls.delta {
                        1.0
                    } else {
                        power_heuristic(1.0, pdf_light, 1.0, cones.mix(pdf, ls.wi))
                    };
                    shadow = Some((
                        super::local::shadow_ray(&si, ls.wi, ls.target),
                        st.beta * f * ls.li * (w / pdf_light),
                    ));
                }
            }
        } else {
            // A delta BSDF samples no light, but passes over the light sample's pair: every
            // vertex draws the same dimensions (light pair, lobe, direction pair, roulette),
            // so the samples of a pixel at a depth read the same tables of the sampler
            // instead of starting new ones three dimensions apart after a mirror.
            sampler.skip_1d();
            sampler.skip_1d();
        }

        // BSDF sampling continues the path.
        let u1 = sampler.next_1d();
        let u2 = sampler.next_2d();
        let sampled = if cones.g == 0 {
            bsdf.sample_local(wo, flip, u1, u2)
        } else {
            guided_sample(&bsdf, &cones, (wo, flip), u1, u2)
        };
        let Some(bs) = sampled else {
            return Some(VertexOutcome {
                shadow,
                alive: false,
            });
        };
        st.beta *= bs.weight;
        if st.beta.is_black() {
            return Some(VertexOutcome {
                shadow,
                alive: false,
            });
        }
        st.prev_pdf = bs.pdf;
        st.prev_delta = bs.delta;
        st.prev = sp;
        st.eta_scale *= bs.eta * bs.eta;
        st.ray = si.spawn_ray(bs.wi);
        st.depth += 1;

        // Russian roulette (see `Path::roulette`).
        let alive = self.roulette(st, sampler);
        Some(VertexOutcome { shadow, alive })
    }

    /// The rest of a vertex at a perfect mirror (`specular`, or a conductor without an index)
    /// or a smooth dielectric, the emission found there added (`None`: the material is neither):
    /// what the general vertex below does for it — `Material::bsdf`, `Bsdf::local_wo`, the
    /// model's sample with the numbers drawn as there, `Bsdf::world_sample`, the throughput,
    /// Πη², the next ray and Russian roulette — without building the BSDF (an out-of-line call
    /// returning a large value, another for the sample), without the light sampling a delta
    /// BSDF skips, and without the shading point, unread after a delta vertex (`prev_delta`:
    /// the next vertex makes its own before reading it). Gives whether the path goes on.
    ///
    /// Nor is the shading frame built: the models sample in the plane of incidence
    /// ([`IncidencePlane`]), which gives the direction a frame gives up to rounding. Single
    /// paths ([`Integrator::radiance`]) take this vertex too, so that a batch's lanes and a
    /// path alone agree bit for bit.
    #[inline(always)]
    fn delta_vertex(
        &self,
        st: &mut PathState,
        si: &crate::interaction::SurfaceInteraction,
        material: &crate::material::Material,
        sampler: &mut Sampler,
    ) -> Option<bool> {
        let refl = |t: &crate::texture::Texture, w: &Wavelengths| {
            t.spectral(si.uv, w, crate::spectrum::RgbRole::Reflectance)
        };
        let plane = IncidencePlane::new(si.ns.to_vec(), si.wo);
        // The light sample's pair, unread by a delta BSDF: passed over, so that every vertex
        // at a depth draws from the same dimensions (see `Path::vertex`).
        let light_pair = |sampler: &mut Sampler| {
            sampler.skip_1d();
            sampler.skip_1d();
        };
        let (s, flip) = match &material.model {
            Model::Specular { reflectance }
            | Model::Conductor {
                eta_k: None,
                reflectance,
                mf: None,
            } => {
                let r = refl(reflectance, &st.lambda);
                let (o, flip) = plane.local_wo(material.two_sided);
                light_pair(sampler);
                // The BSDF's numbers, unread by a mirror.
                sampler.skip_1d();
                sampler.skip_1d();
                sampler.skip_1d();
                (sample_specular(r, None, o), flip)
            }
            Model::Dielectric {
                eta,
                dispersion,
                reflectance,
                transmittance,
                mf: None,
            } => {
                let (r, t) = (
                    refl(reflectance, &st.lambda),
                    refl(transmittance, &st.lambda),
                );
                // A dispersive glass on a spectral path keeps only its hero wavelength.
                let eta = relative_eta(*eta, dispersion.as_deref(), &mut st.lambda);
                // A dielectric is never two-sided.
                let (o, _) = plane.local_wo(false);
                light_pair(sampler);
                let u = sampler.next_1d();
                sampler.skip_1d();
                sampler.skip_1d();
                (sample_smooth(eta, r, t, o, u), false)
            }
            _ => return None,
        };
        let Some(s) = s else {
            return Some(false);
        };
        let Some(wi) = plane.world_wi(&s, flip) else {
            return Some(false);
        };
        st.beta *= s.weight;
        if st.beta.is_black() {
            return Some(false);
        }
        st.prev_pdf = s.pdf;
        st.prev_delta = true;
        st.eta_scale *= s.eta * s.eta;
        st.ray = si.spawn_ray(wi);
        st.depth += 1;
        Some(self.roulette(st, sampler))
    }

    /// Russian roulette from `rr_depth` on: the path survives with probability
    /// q = min(max(β)·Πη², 1), where Πη² is the product of the squared relative indices of
    /// the refractions taken so far (`eta_scale`), and survivors are divided by q. Refraction
    /// into a denser medium scales radiance (and so β) by 1/η²; multiplying it back out keeps
    /// paths inside glass from being terminated for that compression alone, which would make
    /// their survivors fireflies (as pbrt-v4 and Mitsuba 3 do). A path whose throughput has
    /// not fallen below 1 goes on (as in pbrt-v4; Mitsuba caps q at 0.95) up to `max_depth`:
    /// on the bench's specular box, whose caustic paths keep β near 1 through mirror and
    /// glass, the cap at 0.95 gave 1.1–1.3% more RMSE (5 seeds) for the same time. Without a
    /// `max_depth` the cap stays at 0.95, which ends every path (a lossless one between
    /// mirrors, in a white furnace) with probability 1. False when the path ends.
    /// (The Lambert lanes play it in SIMD: `surface_lanes.rs`.)
    #[inline(always)]
    fn roulette(&self, st: &mut PathState, sampler: &mut Sampler) -> bool {
        if st.depth >= self.rr_depth {
            let cap = roulette_cap(self.max_depth.is_none());
            let q = (st.beta.max_component() * st.eta_scale).min(cap);
            if !(sampler.next_1d() < q) {
                return false;
            }
            st.beta /= q;
        }
        true
    }

    /// [`Path::sample_light`] for a Lambert lane: a parallelogram or a sphere light of uniform
    /// radiance is left to [`SurfaceLanes::shade`] to sample; other lights are sampled here.
    #[inline(always)]
    fn lane_light<'s>(
        &self,
        scene: &'s Scene,
        st: &PathState,
        sp: &ShadingPoint,
        mut u: [f32; 2],
    ) -> LaneLight<'s> {
        if !samples_lights(scene, st.depth) {
            return LaneLight::None;
        }
        let lights = &scene.lights[..];
        let Some((pick, pick_pdf, u0)) = scene.light_selector.pick(lights, sp, u[0]) else {
            return LaneLight::None;
        };
        u[0] = u0;
        let light = &lights[pick];
        if let Light::Area(a) = light {
            let e = &scene.emissions[a.emission as usize];
            if e.radiance.is_constant() {
                match &a.shape {
                    AreaShape::Parallelogram(q) => {
                        return LaneLight::Rect {
                            q,
                            inv_area: a.inv_area(),
                            radiance: &e.radiance,
                            two_sided: e.two_sided,
                            u,
                            pick_pdf,
                        };
                    }
                    // A sphere seen from outside: its cone sample left to the lanes
                    // (`AreaLight::sample` samples it so from beyond 1.0001 times its radius).
                    AreaShape::Sphere {
                        cone: Some((c, r)), ..
                    } if sp.p.squared_distance(*c) > r * r * 1.0001 => {
                        return LaneLight::Sphere {
                            c: *c,
                            r: *r,
                            radiance: &e.radiance,
                            two_sided: e.two_sided,
                            u,
                            pick_pdf,
                        };
                    }
                    // A mesh whose triangles keep their faces: the triangle chosen as
                    // `AreaLight::sample` chooses it, the point left to the lanes.
                    AreaShape::Mesh { mesh, triangles } => {
                        let (tri, u0) = triangles.sample_discrete(u[0]);
                        if let Some((corners, face)) = scene.geometry.face(*mesh, tri as u32) {
                            return LaneLight::Tri {
                                corners,
                                n: face.n,
                                inv_area: a.inv_area(),
                                radiance: &e.radiance,
                                two_sided: e.two_sided,
                                u: [u0, u[1]],
                                pick_pdf,
                            };
                        }
                    }
                    _ => {}
                }
            }
        }
        match light.sample_from(&scene.geometry, &scene.emissions, sp, u, &st.lambda) {
            Some(ls) => LaneLight::Sample(ls, pick_pdf),
            None => LaneLight::None,
        }
    }

    /// Next-event estimation's light sample: one light, chosen by its importance at the
    /// shading point (see `LightSelector`) with the first number of the light's own pair,
    /// which is then rescaled within the light's share, so that each light keeps a stratified
    /// share of the pixel's samples (a separate number for the choice would give each light a
    /// random, unstratified subset of them). Gives the sample and the pick's probability.
    #[inline(always)]
    fn sample_light(
        &self,
        scene: &Scene,
        st: &PathState,
        sp: &ShadingPoint,
        sampler: &mut Sampler,
    ) -> Option<(crate::light::LightSample, f32)> {
        let lights = &scene.lights[..];
        let mut u = sampler.next_2d();
        if !samples_lights(scene, st.depth) {
            return None;
        }
        let (pick, pick_pdf, u0) = scene.light_selector.pick(lights, sp, u[0])?;
        u[0] = u0;
        lights[pick]
            .sample_from(&scene.geometry, &scene.emissions, sp, u, &st.lambda)
            .map(|ls| (ls, pick_pdf))
    }
}

impl Integrator for Path {
    fn radiance(
        &self,
        scene: &Scene,
        camera_ray: &Ray,
        lambda: &mut Wavelengths,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> SampledSpectrum {
        self.radiance_alone(scene, camera_ray, lambda, sampler, stats, true)
    }

    fn radiance_batch(
        &self,
        scene: &Scene,
        batch: SampleBatch<'_>,
        samplers: &mut [Sampler],
        stats: &mut RayStats,
        out: &mut [SampledSpectrum],
    ) {
        // See `Path::trace_batch`.
        if has_delta_surfaces(scene) {
            self.trace_batch::<true>(scene, batch, samplers, stats, out);
        } else {
            self.trace_batch::<false>(scene, batch, samplers, stats, out);
        }
    }
}

impl Path {
    /// One path alone ([`Integrator::radiance`]). `delta`: mirrors and smooth glass are shaded
    /// by [`Path::delta_vertex`], as in the renderer; without, through their BSDFs and shading
    /// frames as every other surface is, for tests, which check that the two agree (within
    /// rounding: the directions differ in their last bits).
    #[doc(hidden)]
    pub fn radiance_alone(
        &self,
        scene: &Scene,
        camera_ray: &Ray,
        lambda: &mut Wavelengths,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        delta: bool,
    ) -> SampledSpectrum {
        let mut st = PathState::new(camera_ray, *lambda);
        let every = every_light(scene);
        let mut extra = [None; MAX_SHADOWS];
        loop {
            let hit = scene.intersect(&st.ray, stats);
            let o = self.vertex(
                scene,
                &mut st,
                hit,
                sampler,
                (None, delta),
                every.then_some(&mut extra),
            );
            let Some(out) = o else {
                unreachable!("only a batch's lanes defer vertices");
            };
            for (ray, c) in out
                .shadow
                .into_iter()
                .chain(extra.iter_mut().filter_map(Option::take))
            {
                if !scene.occluded(&ray, stats) {
                    st.l += c;
                }
            }
            if !out.alive {
                *lambda = st.lambda;
                return st.l;
            }
        }
    }

    /// [`BATCH`] paths side by side: their rays are traced together (small scenes test each
    /// primitive against all of them at once), their vertices shaded one by one, each drawing
    /// from its own sample's cursor. Where a batch costs the same however few of its lanes are
    /// active ([`crate::accel::Accel::refills_lanes`]), a lane whose path ends takes the next
    /// sample at once; otherwise the samples go sixteen at a time, so that camera rays start
    /// together (and large scenes trace them as packets). Every path gets the radiance
    /// [`Integrator::radiance`] gives it alone, bit for bit, whatever lane it runs in.
    ///
    /// With `DELTA`, the perfect-mirror and smooth-glass vertices are shaded by
    /// [`Path::delta_vertex`]; without, the loop is compiled without it (for scenes that have
    /// no such surface: carried along, it lengthened the loop's code).
    #[inline(never)]
    fn trace_batch<const DELTA: bool>(
        &self,
        scene: &Scene,
        batch: SampleBatch<'_>,
        samplers: &mut [Sampler],
        stats: &mut RayStats,
        out: &mut [SampledSpectrum],
    ) {
        let SampleBatch {
            rays,
            lambdas,
            cursors,
            samplers_of,
        } = batch;
        let n = rays.len();
        debug_assert!(
            n <= BATCH_SAMPLES && cursors.len() == n && samplers_of.len() == n && out.len() >= n
        );
        let refill = scene.accel.refills_lanes();
        let unused = Ray::new(crate::math::Point3::ORIGIN, crate::math::Vec3::X);
        let mut st = [PathState::new(&unused, Wavelengths::Rgb); BATCH];
        // The sample each lane traces, and the next sample to start.
        let mut slot = [0usize; BATCH];
        let mut next = 0;
        let mut alive: u32 = 0;
        let mut hits = [None; BATCH];
        // Only the active lanes are read: the batches are filled, not cleared, at each step.
        // `batch` holds each path's next ray from one step to the next (the Lambert lanes put
        // theirs there; the path's own copy is read back at once, so that the stores have
        // long retired when the next vertex loads it).
        let mut batch = RayBatch::default();
        let mut shadows = [RayBatch::default(); MAX_SHADOWS];
        let mut pending = [[SampledSpectrum::ZERO; BATCH]; MAX_SHADOWS];
        let every = every_light(scene);
        let mut extra: Shadows = [None; MAX_SHADOWS];
        let mut lambert = SurfaceLanes::default();
        lambert.unbounded = self.max_depth.is_none();
        lambert.guides = &scene.guides;
        if every {
            lambert.extra = scene.lights.len() - 1;
        }
        loop {
            if alive == 0 {
                if next == n {
                    break;
                }
                // A fresh batch: the next samples, in order, from lane 0.
                let m = (n - next).min(BATCH);
                for i in 0..m {
                    st[i].start(&rays[next + i], lambdas[next + i]);
                    batch.set(i, &rays[next + i]);
                    slot[i] = next + i;
                }
                next += m;
                alive = (1u32 << m) - 1;
                // Camera rays: a pixel's, coherent.
                batch.coherent = u32::MAX;
            }
            batch.active = alive;
            scene.intersect_batch(&batch, &mut hits, stats);
            scene.geometry.prefetch_interactions(&hits, alive);
            for s in &mut shadows {
                s.active = 0;
            }
            let mut ended = 0u32;
            lambert.lanes = 0;
            // The lanes shading their first hit: their shadow rays (a pixel's, towards one
            // light) go down a deep tree as packets; a deeper vertex's rays are incoherent
            // (see `RayBatch::coherent`).
            let mut first = 0u32;
            for i in lanes(alive) {
                first |= ((st[i].depth == 0) as u32) << i;
                let s = slot[i];
                let sampler = &mut samplers[samplers_of[s] as usize];
                sampler.resume(cursors[s]);
                let lanes = (Some((&mut lambert, i)), DELTA);
                let o = if every {
                    let o =
                        self.vertex(scene, &mut st[i], hits[i], sampler, lanes, Some(&mut extra));
                    if o.is_some() {
                        // (Taken, so that `extra` holds nothing for the next lane.)
                        for (k, shadow) in extra[..scene.lights.len()].iter_mut().enumerate() {
                            if let Some((ray, c)) = shadow.take() {
                                shadows[k].set(i, &ray);
                                pending[k][i] = c;
                            }
                        }
                    }
                    o
                } else {
                    self.vertex(scene, &mut st[i], hits[i], sampler, lanes, None)
                };
                cursors[s] = sampler.cursor();
                let Some(o) = o else { continue };
                if let Some((ray, c)) = o.shadow {
                    shadows[0].set(i, &ray);
                    pending[0][i] = c;
                }
                if o.alive {
                    batch.set(i, &st[i].ray);
                } else {
                    ended |= 1 << i;
                }
            }
            for s in &mut shadows {
                s.coherent = first;
            }
            batch.coherent = 0;
            if lambert.lanes != 0 {
                lambert.shade(&mut batch, &mut shadows, &mut pending);
                for i in lanes(lambert.lanes) {
                    let o = lambert.finish(i);
                    let st = &mut st[i];
                    match o.next {
                        Some((beta, pdf)) => {
                            st.beta = beta;
                            st.prev_pdf = pdf;
                            st.ray = batch.ray(i);
                        }
                        None => ended |= 1 << i,
                    }
                }
            }
            for (shadows, pending) in shadows.iter().zip(&pending) {
                if shadows.active != 0 {
                    let blocked = scene.occluded_batch(shadows, stats);
                    for i in lanes(shadows.active & !blocked) {
                        st[i].l += pending[i];
                    }
                }
            }
            alive &= !ended;
            for i in lanes(ended) {
                out[slot[i]] = st[i].l;
                lambdas[slot[i]] = st[i].lambda;
                if refill && next < n {
                    st[i].start(&rays[next], lambdas[next]);
                    batch.set(i, &rays[next]);
                    slot[i] = next;
                    next += 1;
                    alive |= 1 << i;
                }
            }
        }
    }
}
