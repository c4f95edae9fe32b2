//! The Lambert, rough-conductor and rough-plastic vertices of a batch, shaded sixteen at once.
//!
//! [`super::Path::radiance_batch`] runs the start of every vertex lane by lane (the hit's
//! interaction, the emission it finds, the numbers the vertex draws and the light sample). At
//! a Lambert surface, the common case, and at a rough conductor or a rough plastic with a GGX
//! distribution, it then leaves the rest of the vertex here: the BSDF's value and density for
//! the light sample with the MIS weight of next-event estimation, the sample of the next
//! direction, the throughput and Russian roulette. [`SurfaceLanes::shade`] does these for all
//! such lanes with the sixteen-lane operations of [`crate::simd::Wide`] (the microfacet terms
//! in `microfacet_lanes.rs`), and [`SurfaceLanes::finish`] makes each lane's rays. Lights of
//! uniform radiance that are parallelograms, faced mesh triangles or spheres seen from outside
//! are sampled here too (a sphere by the cone it subtends, in a kernel of its own before the
//! shading one: `AreaLight::sample`'s operations, which it repeats). A scene
//! that samples every light at each vertex (`super::every_light`) hands over one light sample
//! per light, each with its own batch of shadow rays.
//!
//! The kernel is compiled four times, with and without each of the other two models, and a
//! step's lanes choose the variant: with the other models' code in, the compiler computed
//! parts of their terms ahead of the tests that skip them, and a step of Lambert lanes alone
//! took several times longer. The kernel holds no closures: they do not inherit the
//! instruction set it is compiled for, and every operation in them became a call.
//!
//! Every operation is the one the scalar vertex makes ([`crate::material::Bsdf`] with a Lambert
//! model, [`crate::sampling::warp`], [`power_heuristic`](crate::sampling::warp::power_heuristic)),
//! on the same operands in the same order, so each path gets the same bits as
//! [`super::Path::radiance`] gives it alone (IEEE single precision, correctly rounded division
//! and square root, no fused multiply-add; the NaN cases of `max`/`min` aside, which a finite
//! throughput never meets).

use super::microfacet_lanes::{self, dot, finite, Conductor, Plastic};
use super::MAX_SHADOWS;
use crate::light::{LightSample, Target};
use crate::material::RoughCoating;
use crate::math::{
    Frame, Normal3, Point2, Point3, RayBatch, Vec3, BATCH, INV_PI, PI, SHADOW_EPSILON,
};
use crate::sampling::guide::{Guide, GUIDE_SHARE, MAX_GUIDES, ONE_MINUS_EPSILON};
use crate::shape::Parallelogram;
use crate::simd::SimdLevel;
use crate::simd::{Wide, WideKernel};
use crate::spectrum::{RgbRole, SampledSpectrum, Wavelengths};
use crate::texture::Texture;

/// Sixteen f32 lanes.
type L = [f32; BATCH];

/// The shadow rays of each light sample of a batch step.
pub(super) type Shadows = [RayBatch; MAX_SHADOWS];

/// What each light sample's shadow ray adds when unoccluded, lane by lane.
pub(super) type Pending = [[SampledSpectrum; BATCH]; MAX_SHADOWS];

/// The deferred Lambert vertices of a batch step, structure of arrays: lane i is the path in
/// lane i of the batch (`Default`: no lanes).
#[derive(Default)]
pub(super) struct SurfaceLanes<'s> {
    /// The lanes in use.
    pub(super) lanes: u32,
    /// The shading point and its unit geometric normal.
    p_x: [L; 3],
    ng_x: [L; 3],
    // Inputs: the shading frame, the outgoing direction's local z (mirrored when `flip`).
    s: [L; 3],
    t: [L; 3],
    n: [L; 3],
    wo_z: L,
    flip: u32,
    /// Reflectance and the throughput before the vertex.
    r: [L; 4],
    beta: [L; 4],
    /// Lanes whose surface is a rough GGX conductor rather than Lambert's: the outgoing
    /// direction in the world, α, the lanes with a complex index and the
    /// index (η, k); the reflectance above scales the reflection.
    ggx: u32,
    wo_w: [L; 3],
    alpha: L,
    fresnel: u32,
    eta: [L; 4],
    k: [L; 4],
    /// Lanes whose surface is a rough plastic with a GGX coating (`wo_w` and `alpha` as for
    /// a conductor): the coating's relative index, its transmittance towards wo, the coating
    /// lobe's probability, the coating's and the base's reflectances
    /// (`RoughPlastic::lane_terms`), the number choosing the lobe and each lane's coating
    /// (its transmittance table).
    plastic: u32,
    eta_c: L,
    t_o: L,
    ps: L,
    ks: [L; 4],
    kb: [L; 4],
    u1: L,
    coatings: [Option<&'s RoughCoating>; BATCH],
    /// The scene's caustic guides (`sampling::guide`; at most `MAX_GUIDES`), and the Lambert
    /// lanes that sample with them. Made by `GuideConeLanes` before the shading: the cones
    /// seen from each lane (`GuideCones`: how many are seen from outside, and each one's unit
    /// axis, 1 − cos θ_max and density), the lanes whose direction pair picked a cone
    /// (`GuideCones::split`, its first number made uniform again in `u2`), and that cone's
    /// axis and 1 − cos θ_max.
    pub(super) guides: &'s [Guide],
    guided: u32,
    cone: u32,
    c_axis: [L; 3],
    c_omc: L,
    g_n: L,
    g_axis: [[L; 3]; MAX_GUIDES],
    g_omc: [L; MAX_GUIDES],
    g_pdf: [L; MAX_GUIDES],
    /// The light samples of the lanes: one per lane, or in the every-light mode (see
    /// `super::every_light`) one per light of the scene, each with its own shadow ray.
    lights: [LightLanes; MAX_SHADOWS],
    /// How many of `lights` are in use beyond the first: none, or in the every-light mode the
    /// number of lights less one.
    pub(super) extra: usize,
    /// Lanes whose first light is a parallelogram of uniform radiance, sampled here: its
    /// corner, edges and unit normal (in the first light's `n`), 1/area, which of them emit on
    /// both sides, the light's numbers and the pick's probability (the radiance is in the
    /// first light's `li`, the sampled point goes to its `at`). Of those, the lanes of
    /// `tri` sample a triangle of a mesh light instead: its corners are in `q_p`, `q_v` and
    /// `q_w`, and 1/area is the mesh's.
    rect: u32,
    /// The parallelogram light whose shape, normal, 1/area and radiance (on RGB paths) each
    /// lane holds from an earlier step (its address; 0: none), so that a lane sampling the
    /// same light again does not write them again.
    held: [usize; BATCH],
    tri: u32,
    /// Lanes whose first light is a sphere of uniform radiance seen from outside, sampled
    /// here by the cone it subtends (`AreaLight::sample`): its centre is in `q_p`, its radius
    /// in `sphere_r` (and its radiance, numbers, pick probability and sidedness where a
    /// parallelogram's are). [`SurfaceLanes::shade`] turns them into light samples before
    /// the kernel.
    sphere: u32,
    sphere_r: L,
    q_p: [L; 3],
    q_v: [L; 3],
    q_w: [L; 3],
    inv_area: L,
    two_sided: u32,
    u_light: [L; 2],
    pick_pdf: L,
    /// The direction sample's numbers, the roulette number and where it is played.
    u2: [L; 2],
    u_rr: L,
    roulette: u32,
    eta_scale: L,
    /// The path length is unlimited: the roulette's survival probability is capped at 0.95
    /// (see `Path::roulette`).
    pub(super) unbounded: bool,
    // Outputs.
    /// Lanes whose path goes on, with the direction's density `pdf` and throughput
    /// `beta_out`.
    alive: u32,
    pdf: L,
    beta_out: [L; 4],
}

/// One light sample per lane, structure of arrays (`Default`: none).
#[derive(Default)]
struct LightLanes {
    /// Lanes with a light sample; of those, the delta lights.
    light: u32,
    delta: u32,
    /// The light sample: world direction, radiance, density including the pick.
    wi: [L; 3],
    li: [L; 4],
    pdf: L,
    /// Where the shadow rays go: a point on a surface (its normal in `n`), a point in space
    /// (both in `at`), or infinitely far.
    to_surface: u32,
    to_point: u32,
    at: [L; 3],
    n: [L; 3],
    /// Output: the lanes whose light sample adds `c` when unoccluded.
    shadow: u32,
    c: [L; 4],
}

impl LightLanes {
    /// Lane `bit` without a light sample (until one is put in).
    #[inline(always)]
    fn clear(&mut self, bit: u32) {
        self.light &= !bit;
        self.delta &= !bit;
        self.to_surface &= !bit;
        self.to_point &= !bit;
    }
}

/// The shape of a light sampled in the lanes ([`SurfaceLanes::set`]): three points (a
/// parallelogram's corner and edges, or a triangle's corners, then `true`) with the unit
/// normal and 1/area, or a sphere's centre and radius.
enum Here {
    Points([Vec3; 3], Normal3, bool, f32),
    Sphere(Point3, f32),
}

/// What the scalar part of a vertex hands over for one Lambert lane.
pub(super) struct LaneVertex<'a> {
    /// The hit point and its (unit) geometric normal.
    pub p: Point3,
    pub ng: Normal3,
    /// The shading frame and the outgoing direction's local z, after mirroring.
    pub frame: Frame,
    pub wo_z: f32,
    pub flip: bool,
    /// The reflectance, at `uv`, in the lanes of `lambda`; the throughput.
    pub reflectance: &'a Texture,
    pub uv: Point2,
    pub lambda: &'a Wavelengths,
    pub beta: SampledSpectrum,
    /// The light sample, or the light to sample here.
    pub light: LaneLight<'a>,
    /// The numbers of the direction sample and of the roulette (`None`: no roulette here).
    pub u2: [f32; 2],
    pub u_rr: Option<f32>,
    pub eta_scale: f32,
}

/// What a rough plastic with a GGX coating adds to a lane's vertex.
pub(super) struct PlasticVertex<'a> {
    /// The coating.
    pub coating: &'a RoughCoating,
    /// `RoughPlastic::lane_terms`: the transmittance towards wo, the coating lobe's
    /// probability and the base's effective reflectance; the coating's reflectance.
    pub t_o: f32,
    pub ps: f32,
    pub kb: SampledSpectrum,
    pub ks: SampledSpectrum,
    /// The number choosing between the coating's lobe and the base.
    pub u1: f32,
}

/// What a rough GGX conductor adds to a lane's vertex.
pub(super) struct ConductorVertex {
    /// GGX's α (`Microfacet::alpha`).
    pub alpha: f32,
    /// The complex index (η, k) in the path's lanes, or `None` for F = 1.
    pub eta_k: Option<(SampledSpectrum, SampledSpectrum)>,
}

/// Next-event estimation's light at a Lambert vertex.
pub(super) enum LaneLight<'a> {
    /// No light to sample.
    None,
    /// The light samples are in already ([`SurfaceLanes::set_sample`]).
    Given,
    /// A light sample made by [`crate::light::Light::sample_from`], and the pick's probability.
    Sample(LightSample, f32),
    /// A parallelogram light of uniform radiance, to sample here with the numbers `u` (the
    /// pick's probability `pick_pdf`).
    Rect {
        /// The light's shape.
        q: &'a Parallelogram,
        /// 1 / its area.
        inv_area: f32,
        /// Its radiance (a texture that is the same everywhere).
        radiance: &'a Texture,
        /// Emits on both sides.
        two_sided: bool,
        /// The light's pair of numbers.
        u: [f32; 2],
        /// The pick's probability.
        pick_pdf: f32,
    },
    /// A sphere light of uniform radiance whose placement is a similarity, seen from outside
    /// (beyond 1.0001 times its radius), to sample here by its cone of directions (the other
    /// fields as for `Rect`).
    Sphere {
        /// Its centre and radius.
        c: Point3,
        r: f32,
        radiance: &'a Texture,
        two_sided: bool,
        u: [f32; 2],
        pick_pdf: f32,
    },
    /// A triangle of a mesh light of uniform radiance (chosen by area with the light's first
    /// number, which `u` holds rescaled), to sample here (the other fields as for `Rect`).
    Tri {
        /// The triangle's corners and its geometric normal ([`crate::shape::Face::n`]).
        corners: [Point3; 3],
        n: Normal3,
        /// 1 / the mesh's area.
        inv_area: f32,
        radiance: &'a Texture,
        two_sided: bool,
        u: [f32; 2],
        pick_pdf: f32,
    },
}

/// What [`SurfaceLanes::finish`] gives for a lane: the path's next throughput and direction
/// density (`None`: the path ends here).
pub(super) struct LaneOutcome {
    pub next: Option<(SampledSpectrum, f32)>,
}

impl<'s> SurfaceLanes<'s> {
    /// Puts lane `i`'s vertex in.
    #[inline(always)]
    pub(super) fn set(&mut self, i: usize, v: &LaneVertex) {
        let bit = 1u32 << i;
        self.lanes |= bit;
        for (a, b) in [v.frame.s, v.frame.t, v.frame.n].into_iter().zip([
            &mut self.s,
            &mut self.t,
            &mut self.n,
        ]) {
            b[0][i] = a.x;
            b[1][i] = a.y;
            b[2][i] = a.z;
        }
        self.p_x[0][i] = v.p.x;
        self.p_x[1][i] = v.p.y;
        self.p_x[2][i] = v.p.z;
        self.ng_x[0][i] = v.ng.x;
        self.ng_x[1][i] = v.ng.y;
        self.ng_x[2][i] = v.ng.z;
        self.wo_z[i] = v.wo_z;
        self.flip = (self.flip & !bit) | if v.flip { bit } else { 0 };
        put_texture(
            &mut self.r,
            i,
            v.reflectance,
            v.uv,
            v.lambda,
            RgbRole::Reflectance,
        );
        for k in 0..4 {
            self.beta[k][i] = v.beta.0[k];
        }
        self.rect &= !bit;
        self.tri &= !bit;
        self.sphere &= !bit;
        self.two_sided &= !bit;
        // A parallelogram light this lane holds already (the same light, on an RGB path):
        // only its numbers and pick's probability are new. (A scene's one light is sampled
        // at every vertex; writing its shape, normal and radiance each time was about a tenth
        // of the instructions of a Cornell box's Lambert vertex.)
        if let LaneLight::Rect {
            q,
            two_sided,
            u,
            pick_pdf,
            ..
        } = v.light
        {
            if self.held[i] == held_key(q) && matches!(v.lambda, Wavelengths::Rgb) {
                self.lights[0].clear(bit);
                self.rect |= bit;
                self.set_light_numbers(i, two_sided, u, pick_pdf);
                self.set_path(i, v);
                return;
            }
        }
        self.held[i] = 0;
        // A light sampled here: its shape (a parallelogram's corner and edges or a triangle's
        // corners, with the unit normal; a sphere's centre and radius) and what all share.
        let here = match v.light {
            LaneLight::Rect {
                q,
                inv_area,
                radiance,
                two_sided,
                u,
                pick_pdf,
            } => Some((
                Here::Points([q.p.to_vec(), q.v, q.w], q.normal(), false, inv_area),
                (radiance, two_sided, u, pick_pdf),
            )),
            LaneLight::Tri {
                corners,
                n,
                inv_area,
                radiance,
                two_sided,
                u,
                pick_pdf,
            } => Some((
                Here::Points(corners.map(|c| c.to_vec()), n, true, inv_area),
                (radiance, two_sided, u, pick_pdf),
            )),
            LaneLight::Sphere {
                c,
                r,
                radiance,
                two_sided,
                u,
                pick_pdf,
            } => Some((Here::Sphere(c, r), (radiance, two_sided, u, pick_pdf))),
            _ => None,
        };
        if let Some((shape, (radiance, two_sided, u, pick_pdf))) = here {
            let l = &mut self.lights[0];
            l.clear(bit);
            match shape {
                Here::Points(points, n, tri, inv_area) => {
                    self.rect |= bit;
                    if tri {
                        self.tri |= bit;
                    }
                    set3(&mut self.q_p, i, points[0]);
                    set3(&mut self.q_v, i, points[1]);
                    set3(&mut self.q_w, i, points[2]);
                    set3(&mut l.n, i, n.to_vec());
                    self.inv_area[i] = inv_area;
                }
                Here::Sphere(c, r) => {
                    self.sphere |= bit;
                    set3(&mut self.q_p, i, c.to_vec());
                    self.sphere_r[i] = r;
                }
            }
            let uv = Point2::new(0.0, 0.0);
            put_texture(&mut l.li, i, radiance, uv, v.lambda, RgbRole::Emission);
            self.set_light_numbers(i, two_sided, u, pick_pdf);
            if let (LaneLight::Rect { q, .. }, Wavelengths::Rgb) = (&v.light, v.lambda) {
                self.held[i] = held_key(q);
            }
        } else if !matches!(v.light, LaneLight::Given) {
            self.set_light(i, 0, &v.light);
        }
        self.set_path(i, v);
    }

    /// What changes at every vertex of a light sampled in lane `i`: its sidedness, its pair of
    /// numbers and the pick's probability.
    #[inline(always)]
    fn set_light_numbers(&mut self, i: usize, two_sided: bool, u: [f32; 2], pick_pdf: f32) {
        if two_sided {
            self.two_sided |= 1 << i;
        }
        self.u_light[0][i] = u[0];
        self.u_light[1][i] = u[1];
        self.pick_pdf[i] = pick_pdf;
    }

    /// The end of [`SurfaceLanes::set`]: lane `i`'s numbers and path state.
    #[inline(always)]
    fn set_path(&mut self, i: usize, v: &LaneVertex) {
        let bit = 1u32 << i;
        self.u2[0][i] = v.u2[0];
        self.u2[1][i] = v.u2[1];
        self.roulette &= !bit;
        if let Some(u) = v.u_rr {
            self.roulette |= bit;
            self.u_rr[i] = u;
        }
        self.eta_scale[i] = v.eta_scale;
    }

    /// Makes lane `i` (put in by [`SurfaceLanes::set`]) a rough conductor's or a rough
    /// plastic's, with the outgoing direction `wo` (world; its local x and y are the kernel's
    /// to compute: here, the frame's tangents read again would be loaded in pieces the stores
    /// cannot be forwarded to). Out of line, so that the Lambert vertex stays as short as it
    /// was without these models (inlined, the Cornell box's frame took 4 % longer).
    #[inline(never)]
    pub(super) fn set_surface(
        &mut self,
        i: usize,
        wo: Vec3,
        conductor: Option<ConductorVertex>,
        plastic: Option<PlasticVertex<'s>>,
    ) {
        let bit = 1u32 << i;
        set3(&mut self.wo_w, i, wo);
        if let Some(c) = conductor {
            self.ggx |= bit;
            self.alpha[i] = c.alpha;
            if let Some((eta, k)) = c.eta_k {
                self.fresnel |= bit;
                for j in 0..4 {
                    self.eta[j][i] = eta.0[j];
                    self.k[j][i] = k.0[j];
                }
            }
        }
        if let Some(p) = plastic {
            self.plastic |= bit;
            self.alpha[i] = p.coating.mf.alpha;
            self.eta_c[i] = p.coating.eta;
            self.t_o[i] = p.t_o;
            self.ps[i] = p.ps;
            self.u1[i] = p.u1;
            for j in 0..4 {
                self.ks[j][i] = p.ks.0[j];
                self.kb[j][i] = p.kb.0[j];
            }
            self.coatings[i] = Some(p.coating);
        }
    }

    /// Makes lane `i`, a Lambert vertex, sample its direction with the scene's caustic guides
    /// (`guided_sample` in `path/mod.rs`).
    #[inline(always)]
    pub(super) fn set_guided(&mut self, i: usize) {
        self.guided |= 1 << i;
    }

    /// Puts light sample `k` of lane `i` in (a light sample made by the light, or none; not a
    /// parallelogram to sample here).
    #[inline(always)]
    pub(super) fn set_light(&mut self, i: usize, k: usize, light: &LaneLight) {
        match light {
            LaneLight::Sample(ls, pick_pdf) => self.set_sample(i, k, Some(ls), *pick_pdf),
            _ => self.set_sample(i, k, None, 1.0),
        }
    }

    /// Puts light sample `k` of lane `i` in: `ls`, a sample made by the light (its density
    /// times `pick_pdf`), or none. (Read field by field where the light left it: a copy into
    /// another value would be reloaded whole from pieces.)
    #[inline(always)]
    pub(super) fn set_sample(
        &mut self,
        i: usize,
        k: usize,
        ls: Option<&LightSample>,
        pick_pdf: f32,
    ) {
        let bit = 1u32 << i;
        if k == 0 {
            self.held[i] = 0;
        }
        let l = &mut self.lights[k];
        l.clear(bit);
        if let Some(ls) = ls {
            l.light |= bit;
            if ls.delta {
                l.delta |= bit;
            }
            set3(&mut l.wi, i, ls.wi);
            for k in 0..4 {
                l.li[k][i] = ls.li.0[k];
            }
            l.pdf[i] = pick_pdf * ls.pdf;
            match ls.target {
                Target::Surface(q, n) => {
                    l.to_surface |= bit;
                    set3(&mut l.at, i, q.to_vec());
                    set3(&mut l.n, i, n.to_vec());
                }
                Target::Point(q) => {
                    l.to_point |= bit;
                    set3(&mut l.at, i, q.to_vec());
                }
                Target::Infinite => {}
            }
        }
    }

    /// Shades every lane in use (sixteen lanes at once, at the widest instruction set the CPU
    /// has).
    ///
    /// The rays of the lanes whose path goes on go straight into `next`, and the shadow rays
    /// of light sample `k` into `shadows[k]` (marked active there, with what they add in
    /// `pending[k]`); [`SurfaceLanes::finish`] gives the rest.
    pub(super) fn shade(
        &mut self,
        next: &mut RayBatch,
        shadows: &mut Shadows,
        pending: &mut Pending,
    ) {
        self.shade_at(SimdLevel::detected(), next, shadows, pending);
    }

    /// [`SurfaceLanes::shade`] with the instructions of `level` (or the widest below it that
    /// the CPU has).
    pub(super) fn shade_at(
        &mut self,
        level: SimdLevel,
        next: &mut RayBatch,
        shadows: &mut Shadows,
        pending: &mut Pending,
    ) {
        // Only the lanes in use count (the other lanes hold an earlier step's values).
        let m = self.lanes;
        for mask in [
            &mut self.flip,
            &mut self.rect,
            &mut self.tri,
            &mut self.sphere,
            &mut self.two_sided,
            &mut self.roulette,
            &mut self.ggx,
            &mut self.fresnel,
            &mut self.plastic,
            &mut self.guided,
        ] {
            *mask &= m;
        }
        for l in &mut self.lights[..=self.extra] {
            for mask in [
                &mut l.light,
                &mut l.delta,
                &mut l.to_surface,
                &mut l.to_point,
            ] {
                *mask &= m;
            }
        }
        // Sphere lights' samples first, in a kernel of their own (their code kept out of the
        // shading kernel, whose variants it would slow: see `Shade`): then they are light
        // samples like any other.
        if self.sphere != 0 {
            let usable = crate::simd::run_wide_at(level, SphereSamples(self));
            let l = &mut self.lights[0];
            l.to_surface |= usable;
            l.light |= usable;
            self.sphere = 0;
        }
        // The guided lanes' cones, likewise.
        if self.guided != 0 {
            crate::simd::run_wide_at(level, GuideConeLanes(self));
        }
        // Lambert lanes alone take a kernel compiled without the other models: with them in,
        // the compiler computes parts of their terms ahead of the tests that skip them, and
        // the Lambert kernel ran several times slower (see `Shade`).
        // (Guided Lambert lanes likewise take kernels of their own.)
        match (self.ggx != 0, self.plastic != 0, self.guided != 0) {
            (false, false, false) => {
                crate::simd::run_wide_at(level, Shade::<false, false, false>(self, next, shadows))
            }
            (true, false, false) => {
                crate::simd::run_wide_at(level, Shade::<true, false, false>(self, next, shadows))
            }
            (false, true, false) => {
                crate::simd::run_wide_at(level, Shade::<false, true, false>(self, next, shadows))
            }
            (true, true, false) => {
                crate::simd::run_wide_at(level, Shade::<true, true, false>(self, next, shadows))
            }
            (false, false, true) => {
                crate::simd::run_wide_at(level, Shade::<false, false, true>(self, next, shadows))
            }
            (true, false, true) => {
                crate::simd::run_wide_at(level, Shade::<true, false, true>(self, next, shadows))
            }
            (false, true, true) => {
                crate::simd::run_wide_at(level, Shade::<false, true, true>(self, next, shadows))
            }
            (true, true, true) => {
                crate::simd::run_wide_at(level, Shade::<true, true, true>(self, next, shadows))
            }
        }
        for (l, pending) in self.lights[..=self.extra].iter().zip(pending) {
            for i in crate::math::lanes(l.shadow) {
                pending[i] = SampledSpectrum([l.c[0][i], l.c[1][i], l.c[2][i], l.c[3][i]]);
            }
        }
        // The other models' lanes are put in afresh at each step (`set_surface`), and so are
        // the guided ones (`set_guides`).
        self.ggx = 0;
        self.fresnel = 0;
        self.plastic = 0;
        self.guided = 0;
    }

    /// What is left of lane `i` once [`SurfaceLanes::shade`] has run: the shadow ray of a light
    /// sampled by [`crate::light::Light::sample_from`], and the path's next throughput and
    /// direction density (its ray is in the batch already).
    #[inline(always)]
    pub(super) fn finish(&self, i: usize) -> LaneOutcome {
        let bit = 1u32 << i;
        let next = (self.alive & bit != 0).then(|| {
            let beta = SampledSpectrum([
                self.beta_out[0][i],
                self.beta_out[1][i],
                self.beta_out[2][i],
                self.beta_out[3][i],
            ]);
            (beta, self.pdf[i])
        });
        LaneOutcome { next }
    }
}

/// What [`SurfaceLanes::held`] records of a parallelogram light: its address.
#[inline(always)]
fn held_key(q: &Parallelogram) -> usize {
    q as *const Parallelogram as usize
}

/// Lane `i` of `a`: the vector `v`.
#[inline(always)]
fn set3(a: &mut [L; 3], i: usize, v: Vec3) {
    a[0][i] = v.x;
    a[1][i] = v.y;
    a[2][i] = v.z;
}

/// Lane `i` of `a`: the texture `t` at `uv` in the lanes of `w` (`Texture::spectral`).
#[inline(always)]
fn put_texture(a: &mut [L; 4], i: usize, t: &Texture, uv: Point2, w: &Wavelengths, role: RgbRole) {
    let s = t.spectral(uv, w, role);
    for k in 0..4 {
        a[k][i] = s.0[k];
    }
}

/// The samples of the sphere lights of a step's lanes (`SurfaceLanes::sphere`), into their
/// first light's direction, radiance, density (with the pick's probability), point and
/// normal: `AreaLight::sample`'s cone sample, operation for operation (with
/// `warp::one_minus_cos_from_sin2`, `Frame::from_normal`, `warp::square_to_uniform_cone_narrow`
/// and `Emission::radiance_at`). Returns the lanes whose sample is usable
/// (`LightSample::usable`).
struct SphereSamples<'a, 's>(&'a mut SurfaceLanes<'s>);

impl WideKernel for SphereSamples<'_, '_> {
    type Output = u32;

    #[inline(always)]
    fn run<W: Wide>(self, w: W) -> u32 {
        let x = self.0;
        let on = w.mask(x.sphere);
        let (zero, one, two) = (w.splat(0.0), w.splat(1.0), w.splat(2.0));
        let p = load3(w, &x.p_x);
        let c = load3(w, &x.q_p);
        let r = w.load(&x.sphere_r);
        let (u0, u1) = (w.load(&x.u_light[0]), w.load(&x.u_light[1]));
        let pc = [w.sub(p[0], c[0]), w.sub(p[1], c[1]), w.sub(p[2], c[2])];
        let d2 = dot(w, pc, pc);
        let rr = w.mul(r, r);
        // 1 − cos θ_max from sin²θ_max = r²/d², clamped to [0, 1].
        let s = w.div(rr, d2);
        let s = w.select(w.lt(s, zero), zero, s);
        let s = w.select(w.gt(s, one), one, s);
        let one_minus_cos = w.div(s, w.add(one, w.sqrt(w.sub(one, s))));
        let d = w.sqrt(d2);
        let inv_d = w.div(one, d);
        let axis = [
            w.mul(w.sub(c[0], p[0]), inv_d),
            w.mul(w.sub(c[1], p[1]), inv_d),
            w.mul(w.sub(c[2], p[2]), inv_d),
        ];
        // The frame about the axis.
        let (fs, ft) = frame_about(w, axis);
        // The direction, uniform in the cone (a = 1 − cos θ).
        let a = w.mul(u0, one_minus_cos);
        let a2 = w.mul(a, w.sub(two, a));
        let rad = w.sqrt(w.select(w.lt(a2, zero), zero, a2));
        let (sin_phi, cos_phi) = microfacet_lanes::sin_cos_turn(w, u1);
        let local = [w.mul(rad, cos_phi), w.mul(rad, sin_phi), w.sub(one, a)];
        let mut wi = [zero; 3];
        for k in 0..3 {
            wi[k] = w.add(
                w.add(w.mul(fs[k], local[0]), w.mul(ft[k], local[1])),
                w.mul(axis[k], local[2]),
            );
        }
        // Where it meets the sphere, and the normal there.
        let h2 = w.mul(d2, a2);
        let under = w.sub(rr, h2);
        let t = w.sub(
            w.mul(d, w.sub(one, a)),
            w.sqrt(w.select(w.lt(under, zero), zero, under)),
        );
        let inv_r = w.div(one, r);
        let l = &mut x.lights[0];
        let mut n = [zero; 3];
        let mut wi_finite = on;
        for k in 0..3 {
            n[k] = w.mul(w.sub(w.add(p[k], w.mul(wi[k], t)), c[k]), inv_r);
            let q = w.add(c[k], w.mul(n[k], r));
            put(w, on, q, &mut l.at[k]);
            put(w, on, n[k], &mut l.n[k]);
            put(w, on, wi[k], &mut l.wi[k]);
            wi_finite = w.and(wi_finite, finite(w, wi[k]));
        }
        // The radiance towards the point (none from behind a one-sided light).
        let back = w.le(dot(w, n, [w.neg(wi[0]), w.neg(wi[1]), w.neg(wi[2])]), zero);
        let dark = w.and_not(back, w.mask(x.two_sided));
        let mut lit = w.mask(0);
        for k in 0..4 {
            let v = w.select(dark, zero, w.load(&l.li[k]));
            lit = w.or(lit, w.ne(v, zero));
            put(w, on, v, &mut l.li[k]);
        }
        let pdf = w.div(one, w.mul(w.splat(2.0 * PI), one_minus_cos));
        put(w, on, w.mul(w.load(&x.pick_pdf), pdf), &mut l.pdf);
        w.bits(w.and(w.and(wi_finite, lit), w.gt(pdf, zero)))
    }
}

/// [`SurfaceLanes::shade`] as a kernel, with rough conductors (`C`) and rough plastics (`P`)
/// among the lanes or not (without, their code is left out).
struct Shade<'a, 's, const C: bool, const P: bool, const G: bool>(
    &'a mut SurfaceLanes<'s>,
    &'a mut RayBatch,
    &'a mut Shadows,
);

impl<const C: bool, const P: bool, const G: bool> WideKernel for Shade<'_, '_, C, P, G> {
    type Output = ();

    #[inline(always)]
    fn run<W: Wide>(self, w: W) -> Self::Output {
        let Shade(x, next, shadows) = self;
        let zero = w.splat(0.0);
        let one = w.splat(1.0);
        let inv_pi = w.splat(INV_PI);
        let all = w.mask(x.lanes);
        // `!(a <= 0)`: the scalar code's tests, NaN included.

        let wo_z = w.load(&x.wo_z);
        let wo_up = positive(w, all, wo_z);
        let flip = w.mask(x.flip);
        let n = [w.load(&x.n[0]), w.load(&x.n[1]), w.load(&x.n[2])];
        let r = [
            w.load(&x.r[0]),
            w.load(&x.r[1]),
            w.load(&x.r[2]),
            w.load(&x.r[3]),
        ];
        let beta = [
            w.load(&x.beta[0]),
            w.load(&x.beta[1]),
            w.load(&x.beta[2]),
            w.load(&x.beta[3]),
        ];

        // Parallelogram lights sampled uniformly by area (`AreaLight::sample`): the point
        // p + v·s + w·t, the direction to it, and the density per solid angle. A triangle of
        // a mesh light: the point of barycentrics (1 − √s, t·√s) (`square_to_uniform_triangle`)
        // as `Mesh::geometry` interpolates it, α·a + β·b + γ·c.
        let rect = w.mask(x.rect);
        let tri = w.mask(x.tri);
        let pos = [w.load(&x.p_x[0]), w.load(&x.p_x[1]), w.load(&x.p_x[2])];
        let ng = [w.load(&x.ng_x[0]), w.load(&x.ng_x[1]), w.load(&x.ng_x[2])];
        let (us, ut) = (w.load(&x.u_light[0]), w.load(&x.u_light[1]));
        let su = w.sqrt(us);
        let (b1, b2) = (w.sub(one, su), w.mul(ut, su));
        let b0 = w.sub(w.sub(one, b1), b2);
        let l0 = &mut x.lights[0];
        let mut to = [zero; 3];
        for k in 0..3 {
            let (qp, qv, qw) = (w.load(&x.q_p[k]), w.load(&x.q_v[k]), w.load(&x.q_w[k]));
            let in_rect = w.add(w.add(qp, w.mul(qv, us)), w.mul(qw, ut));
            let in_tri = w.add(w.add(w.mul(b0, qp), w.mul(b1, qv)), w.mul(b2, qw));
            let q = w.select(tri, in_tri, in_rect);
            put(w, rect, q, &mut l0.at[k]);
            to[k] = w.sub(q, pos[k]);
        }
        let d2 = w.add(
            w.add(w.mul(to[0], to[0]), w.mul(to[1], to[1])),
            w.mul(to[2], to[2]),
        );
        let inv_d = w.div(one, w.sqrt(d2));
        let qn = [w.load(&l0.n[0]), w.load(&l0.n[1]), w.load(&l0.n[2])];
        let mut lw = [zero; 3];
        let mut lw_finite = all;
        for k in 0..3 {
            let d = w.mul(to[k], inv_d);
            lw_finite = w.and(lw_finite, finite(w, d));
            lw[k] = w.select(rect, d, w.load(&l0.wi[k]));
        }
        let cos = w.copysign(dot(w, qn, lw), one);
        let facing = w.or(
            w.mask(x.two_sided),
            w.and_not(
                all,
                w.le(dot(w, qn, [w.neg(lw[0]), w.neg(lw[1]), w.neg(lw[2])]), zero),
            ),
        );
        let pdf_rect = w.div(w.mul(w.load(&x.inv_area), d2), cos);
        let mut li = [zero; 4];
        let mut li_nonzero = w.mask(0);
        for k in 0..4 {
            let v = w.load(&l0.li[k]);
            li[k] = w.select(w.and(rect, w.and_not(all, facing)), zero, v);
            li_nonzero = w.or(li_nonzero, w.ne(li[k], zero));
        }
        let rect_ok = w.and(
            w.and(rect, w.and(w.gt(d2, zero), w.gt(cos, zero))),
            w.and(w.and(w.gt(pdf_rect, zero), lw_finite), li_nonzero),
        );
        let light = w.or(w.and_not(w.mask(l0.light), rect), rect_ok);
        let pdf_light = w.select(rect, w.mul(w.load(&x.pick_pdf), pdf_rect), w.load(&l0.pdf));
        // The outgoing direction in the shading frame (`Bsdf::local_wo`, mirrored in z), for
        // the rough conductors' and plastics' lanes. (No closures here: they would not inherit
        // the kernel's instruction set.)
        let wo = if C || P {
            let o = load3(w, &x.wo_w);
            [dot(w, o, load3(w, &x.s)), dot(w, o, load3(w, &x.t)), wo_z]
        } else {
            [zero; 3]
        };
        let conductor = if C {
            Some(Conductor {
                on: w.mask(x.ggx),
                wo,
                alpha: w.load(&x.alpha),
                fresnel: w.mask(x.fresnel),
                eta: load4(w, &x.eta),
                k: load4(w, &x.k),
            })
        } else {
            None
        };
        let plastic = if P {
            Some(Plastic {
                on: w.mask(x.plastic),
                wo,
                alpha: w.load(&x.alpha),
                eta: w.load(&x.eta_c),
                t_o: w.load(&x.t_o),
                ps: w.load(&x.ps),
                ks: load4(w, &x.ks),
                kb: load4(w, &x.kb),
            })
        } else {
            None
        };
        let at = Shading {
            all,
            pos,
            ng,
            tangents: (&x.s, &x.t),
            n,
            flip,
            wo_up,
            r,
            beta,
            conductor,
            plastic,
            coatings: (&x.coatings, x.plastic),
            guides: if G {
                Some(GuideLanes {
                    count: x.guides.len().min(MAX_GUIDES),
                    on: w.and(all, w.mask(x.guided)),
                    n: w.load(&x.g_n),
                    k: w.div(
                        w.splat(GUIDE_SHARE),
                        w.splat(x.guides.len().min(MAX_GUIDES) as f32),
                    ),
                    axis: &x.g_axis,
                    omc: &x.g_omc,
                    pdf: &x.g_pdf,
                })
            } else {
                None
            },
        };
        let mut shadows = shadows.iter_mut();
        let Some(first) = shadows.next() else {
            return;
        };
        let ls = LaneSample {
            wi: lw,
            li,
            on: light,
            pdf: pdf_light,
            rect,
        };
        nee(w, &at, l0, ls, first);
        // The every-light mode's other lights, sampled by the lights themselves.
        for (l, shadows) in x.lights[1..=x.extra].iter_mut().zip(shadows) {
            let lw = [w.load(&l.wi[0]), w.load(&l.wi[1]), w.load(&l.wi[2])];
            let li = [
                w.load(&l.li[0]),
                w.load(&l.li[1]),
                w.load(&l.li[2]),
                w.load(&l.li[3]),
            ];
            let (light, pdf) = (w.mask(l.light), w.load(&l.pdf));
            let ls = LaneSample {
                wi: lw,
                li,
                on: light,
                pdf,
                rect: w.mask(0),
            };
            nee(w, &at, l, ls, shadows);
        }

        // The next direction: Malley's method on Shirley and Chiu's concentric disk, with the
        // sine and cosine polynomials of `warp`.
        let two = w.splat(2.0);
        let ox = w.sub(w.mul(two, w.load(&x.u2[0])), one);
        let oy = w.sub(w.mul(two, w.load(&x.u2[1])), one);
        let centre = w.and(w.eq(ox, zero), w.eq(oy, zero));
        let wide_x = w.gt(w.copysign(ox, one), w.copysign(oy, one));
        let a = w.select(wide_x, w.div(oy, ox), w.div(ox, oy));
        let t = w.mul(w.splat(PI / 4.0), a);
        let (sin, cos) = microfacet_lanes::sin_cos_quarter(w, t);
        let dx = w.select(wide_x, w.mul(ox, cos), w.mul(oy, sin));
        let dy = w.select(wide_x, w.mul(ox, sin), w.mul(oy, cos));
        let dx = w.select(centre, zero, dx);
        let dy = w.select(centre, zero, dy);
        let rad = w.sub(w.sub(one, w.mul(dx, dx)), w.mul(dy, dy));
        let dz = w.sqrt(w.select(w.lt(rad, zero), zero, rad));
        let pdf = w.select(w.gt(dz, zero), w.mul(dz, inv_pi), zero);
        let up = w.gt(pdf, zero);
        let mut pdf = pdf;
        let lz = w.select(flip, w.neg(dz), dz);
        let s = [w.load(&x.s[0]), w.load(&x.s[1]), w.load(&x.s[2])];
        let tt = [w.load(&x.t[0]), w.load(&x.t[1]), w.load(&x.t[2])];
        let mut ok = w.and(wo_up, up);
        let mut wi = [zero; 3];
        for k in 0..3 {
            wi[k] = to_world(w, [s[k], tt[k], n[k]], dx, dy, lz);
            ok = w.and(ok, finite(w, wi[k]));
        }
        // Lambert's sample weighs the throughput by the reflectance; a conductor's by f·cos/pdf
        // of its sample of the visible normals (`conductor::sample`, `world_wi`).
        let mut weight = r;
        // Guided Lambert lanes (`guided_sample` in `path/mod.rs`): a direction in the cone the
        // lobe number picks, or the cosine-weighted one above, weighed by f·cos over the
        // mixture's density.
        if let Some(g) = &at.guides {
            let cone = w.and(g.on, w.mask(x.cone));
            let axis = load3(w, &x.c_axis);
            let omc = w.load(&x.c_omc);
            let (fs, ft) = frame_about(w, axis);
            let (u0, u1) = (w.load(&x.u2[0]), w.load(&x.u2[1]));
            let a = w.mul(u0, omc);
            let a2 = w.mul(a, w.sub(two, a));
            let rad = w.sqrt(w.select(w.lt(a2, zero), zero, a2));
            let (sin_phi, cos_phi) = microfacet_lanes::sin_cos_turn(w, u1);
            let local = [w.mul(rad, cos_phi), w.mul(rad, sin_phi), w.sub(one, a)];
            let mut wi_g = wi;
            let mut ok_g = w.or(cone, up);
            for k in 0..3 {
                let c = w.add(
                    w.add(w.mul(fs[k], local[0]), w.mul(ft[k], local[1])),
                    w.mul(axis[k], local[2]),
                );
                wi_g[k] = w.select(cone, c, wi[k]);
                ok_g = w.and(ok_g, finite(w, wi_g[k]));
            }
            // f·cos and the cosine's density of the direction (`lambert::eval`, `pdf`).
            let iz = dot(w, wi_g, n);
            let iz = w.select(flip, w.neg(iz), iz);
            let f_on = w.and(wo_up, positive(w, all, iz));
            let cos_pi = w.mul(inv_pi, iz);
            let pdf_b = w.select(w.and(wo_up, w.gt(iz, zero)), w.mul(iz, inv_pi), zero);
            let mix = guide_mix(w, g, pdf_b, wi_g);
            let mut f_nonzero = w.mask(0);
            for k in 0..4 {
                let f = w.select(f_on, w.mul(r[k], cos_pi), zero);
                f_nonzero = w.or(f_nonzero, w.ne(f, zero));
                weight[k] = w.select(g.on, w.div(f, mix), weight[k]);
            }
            ok_g = w.and(ok_g, w.and(w.and(wo_up, f_nonzero), w.gt(mix, zero)));
            for k in 0..3 {
                wi[k] = w.select(g.on, wi_g[k], wi[k]);
            }
            ok = w.or(w.and(g.on, ok_g), w.and_not(ok, g.on));
            pdf = w.select(g.on, mix, pdf);
        }
        if let Some(c) = &at.conductor {
            let u2 = [w.load(&x.u2[0]), w.load(&x.u2[1])];
            let microfacet_lanes::Sample {
                wi: o,
                pdf: pdf_c,
                weight: weight_c,
                ok: ok_c,
            } = microfacet_lanes::sample(w, c, &r, u2);
            let z = w.select(flip, w.neg(o[2]), o[2]);
            let mut ok_c = ok_c;
            for k in 0..3 {
                let d = to_world(w, [s[k], tt[k], n[k]], o[0], o[1], z);
                ok_c = w.and(ok_c, finite(w, d));
                wi[k] = w.select(c.on, d, wi[k]);
            }
            for k in 0..4 {
                weight[k] = w.select(c.on, weight_c[k], weight[k]);
            }
            ok = w.or(w.and(c.on, ok_c), w.and_not(ok, c.on));
            pdf = w.select(c.on, pdf_c, pdf);
        }
        // A rough plastic's (`RoughPlastic::sample`): the coating's lobe with probability
        // `ps`, else the cosine-weighted direction above, weighed by f·cos over the mixture's
        // density.
        if let Some(p) = &at.plastic {
            let u2 = [w.load(&x.u2[0]), w.load(&x.u2[1])];
            let (_, spec) = microfacet_lanes::reflected(w, p.wo, p.alpha, u2);
            let coat = w.lt(w.load(&x.u1), p.ps);
            let o = [
                w.select(coat, spec[0], dx),
                w.select(coat, spec[1], dy),
                w.select(coat, spec[2], dz),
            ];
            let t_i = transmittances(w, at.coatings, o[2]);
            let (f, pdf_p) = microfacet_lanes::plastic_eval_pdf(w, p, o, t_i);
            let mut ok_p = w.and_not(p.on, w.or(w.le(p.wo[2], zero), w.le(o[2], zero)));
            ok_p = w.and(ok_p, w.and(w.gt(o[2], zero), w.gt(pdf_p, zero)));
            let z = w.select(flip, w.neg(o[2]), o[2]);
            for k in 0..3 {
                let d = to_world(w, [s[k], tt[k], n[k]], o[0], o[1], z);
                ok_p = w.and(ok_p, finite(w, d));
                wi[k] = w.select(p.on, d, wi[k]);
            }
            for k in 0..4 {
                weight[k] = w.select(p.on, w.div(f[k], pdf_p), weight[k]);
            }
            ok = w.or(w.and(p.on, ok_p), w.and_not(ok, p.on));
            pdf = w.select(p.on, pdf_p, pdf);
        }
        w.store(pdf, &mut x.pdf);
        // The throughput, and Russian roulette: q = min(max(w, β)·Πη², 1), or 0.95 when the
        // path length is unlimited.
        let mut b = [zero; 4];
        let mut b_nonzero = w.mask(0);
        for k in 0..4 {
            ok = w.and(ok, finite(w, weight[k]));
            b[k] = w.mul(beta[k], weight[k]);
            b_nonzero = w.or(b_nonzero, w.ne(b[k], zero));
        }
        ok = w.and(ok, b_nonzero);
        let m = max(w, max(w, b[0], b[1]), max(w, b[2], b[3]));
        let q = w.mul(m, w.load(&x.eta_scale));
        let cap = w.splat(super::roulette_cap(x.unbounded));
        let q = w.select(w.lt(cap, q), cap, q);
        let roulette = w.mask(x.roulette);
        let survive = w.lt(w.load(&x.u_rr), q);
        ok = w.and(ok, w.or(w.and_not(all, roulette), survive));
        for k in 0..4 {
            w.store(w.select(roulette, w.div(b[k], q), b[k]), &mut x.beta_out[k]);
        }
        x.alive = w.bits(ok);

        // The rays, their origins moved off the surface as `Ray::spawn_unit` and
        // `Ray::spawn_between_unit` move them.
        let o = offset(w, pos, ng, wi);
        for k in 0..3 {
            put(w, ok, o[k], &mut next.o[k]);
            put(w, ok, wi[k], &mut next.d[k]);
        }
        put(w, ok, zero, &mut next.tmin);
        put(w, ok, w.splat(f32::INFINITY), &mut next.tmax);
    }
}

/// What the light samples of a vertex's lanes share: the lanes in use, the shading point and
/// its unit geometric normal, the shading frame (s, t, n), the mirrored lanes, the lanes seen
/// from above, the reflectance, the throughput, the rough conductors' and rough plastics'
/// lanes, and the plastics' coatings (with the plastics' lanes).
struct Shading<'a, 's, W: Wide> {
    all: W::M,
    pos: [W::V; 3],
    ng: [W::V; 3],
    tangents: (&'a [L; 3], &'a [L; 3]),
    n: [W::V; 3],
    flip: W::M,
    wo_up: W::M,
    r: [W::V; 4],
    beta: [W::V; 4],
    conductor: Option<Conductor<W>>,
    plastic: Option<Plastic<W>>,
    coatings: Coatings<'a, 's>,
    guides: Option<GuideLanes<'a, W>>,
}

/// The guided lanes' cones (`SurfaceLanes::guided`), read where they are needed: the lanes,
/// the share over the number of cones, and each cone's axis, 1 − cos θ_max and density.
struct GuideLanes<'a, W: Wide> {
    count: usize,
    on: W::M,
    n: W::V,
    k: W::V,
    axis: &'a [[L; 3]; MAX_GUIDES],
    omc: &'a [L; MAX_GUIDES],
    pdf: &'a [L; MAX_GUIDES],
}

/// `GuideCones::mix` in the lanes of `g` (`pdf` in the others), for the unit direction `wi`.
#[inline(always)]
fn guide_mix<W: Wide>(w: W, g: &GuideLanes<'_, W>, pdf: W::V, wi: [W::V; 3]) -> W::V {
    let (zero, one) = (w.splat(0.0), w.splat(1.0));
    let mut m = w.mul(w.sub(one, w.mul(g.k, g.n)), pdf);
    // (The slots beyond the scene's guides would add zeros.)
    for j in 0..g.count {
        let d = dot(w, wi, load3(w, &g.axis[j]));
        let inside = w.le(w.sub(one, d), w.load(&g.omc[j]));
        m = w.add(m, w.select(inside, w.mul(g.k, w.load(&g.pdf[j])), zero));
    }
    w.select(g.on, m, pdf)
}

/// The cones of the scene's guides seen from the guided lanes' points (`GuideCones::at`,
/// operation for operation), into `g_axis`, `g_omc`, `g_pdf` and `g_n`.
struct GuideConeLanes<'a, 's>(&'a mut SurfaceLanes<'s>);

impl WideKernel for GuideConeLanes<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn run<W: Wide>(self, w: W) {
        let x = self.0;
        let on = w.mask(x.guided);
        let (zero, one) = (w.splat(0.0), w.splat(1.0));
        let p = load3(w, &x.p_x);
        let mut n = zero;
        for j in 0..MAX_GUIDES {
            let Some(g) = x.guides.get(j) else {
                put(w, on, w.splat(-1.0), &mut x.g_omc[j]);
                put(w, on, zero, &mut x.g_pdf[j]);
                continue;
            };
            let to = [
                w.sub(w.splat(g.c.x), p[0]),
                w.sub(w.splat(g.c.y), p[1]),
                w.sub(w.splat(g.c.z), p[2]),
            ];
            let d2 = dot(w, to, to);
            let rr = w.splat(g.r * g.r);
            // `warp::one_minus_cos_from_sin2` and `uniform_cone_pdf_narrow`.
            let s = w.div(rr, d2);
            let s = w.select(w.lt(s, zero), zero, s);
            let s = w.select(w.gt(s, one), one, s);
            let omc = w.div(s, w.add(one, w.sqrt(w.sub(one, s))));
            let pdf = w.div(one, w.mul(w.splat(2.0 * PI), omc));
            let seen = w.and(
                w.and(on, w.gt(d2, w.mul(rr, w.splat(1.0001)))),
                w.and(w.gt(omc, zero), finite(w, pdf)),
            );
            let inv = w.div(one, w.sqrt(d2));
            for k in 0..3 {
                put(
                    w,
                    on,
                    w.select(seen, w.mul(to[k], inv), zero),
                    &mut x.g_axis[j][k],
                );
            }
            put(w, on, w.select(seen, omc, w.splat(-1.0)), &mut x.g_omc[j]);
            put(w, on, w.select(seen, pdf, zero), &mut x.g_pdf[j]);
            n = w.add(n, w.select(seen, one, zero));
        }
        put(w, on, n, &mut x.g_n);
        // The strategy the direction pair's first number picks (`GuideCones::split`).
        let share = w.splat(GUIDE_SHARE);
        let g = w.splat(x.guides.len().min(MAX_GUIDES) as f32);
        let u = w.load(&x.u2[0]);
        let t = w.mul(w.div(u, share), g);
        let mut j = zero;
        let mut axis = load3(w, &x.g_axis[0]);
        let mut omc = w.load(&x.g_omc[0]);
        for k in 1..x.guides.len().min(MAX_GUIDES) {
            let kf = w.splat(k as f32);
            let take = w.and(w.le(kf, t), w.gt(g, kf));
            j = w.select(take, kf, j);
            let a = load3(w, &x.g_axis[k]);
            for c in 0..3 {
                axis[c] = w.select(take, a[c], axis[c]);
            }
            omc = w.select(take, w.load(&x.g_omc[k]), omc);
        }
        let in_share = w.lt(u, share);
        let v_cos = w.div(w.sub(u, share), w.splat(1.0 - GUIDE_SHARE));
        let v = w.select(in_share, w.sub(t, j), v_cos);
        let top = w.splat(ONE_MINUS_EPSILON);
        put(w, on, w.select(w.lt(top, v), top, v), &mut x.u2[0]);
        let cone = w.and(w.and(on, in_share), w.gt(omc, zero));
        for c in 0..3 {
            put(w, cone, axis[c], &mut x.c_axis[c]);
        }
        put(w, cone, omc, &mut x.c_omc);
        x.cone = w.bits(cone);
    }
}

/// The tangents of `Frame::from_normal` about the unit vector `a`, operation for operation.
#[inline(always)]
fn frame_about<W: Wide>(w: W, a: [W::V; 3]) -> ([W::V; 3], [W::V; 3]) {
    let one = w.splat(1.0);
    let sign = w.copysign(one, a[2]);
    let k = w.div(w.splat(-1.0), w.add(sign, a[2]));
    let b = w.mul(w.mul(a[0], a[1]), k);
    let s = [
        w.add(one, w.mul(w.mul(w.mul(sign, a[0]), a[0]), k)),
        w.mul(sign, b),
        w.mul(w.neg(sign), a[0]),
    ];
    let t = [b, w.add(sign, w.mul(w.mul(a[1], a[1]), k)), w.neg(a[1])];
    (s, t)
}

/// Each lane's rough-plastic coating, and the lanes that have one.
type Coatings<'a, 's> = (&'a [Option<&'s RoughCoating>; BATCH], u32);

/// The coatings' transmittances ([`RoughCoating::transmittance`]) at the cosines `cos`, in
/// the lanes that have a coating (a table each: looked up lane by lane).
#[inline(always)]
fn transmittances<W: Wide>(w: W, (coatings, lanes): Coatings, cos: W::V) -> W::V {
    let mut a = [0.0; BATCH];
    w.store(cos, &mut a);
    for i in crate::math::lanes(lanes) {
        if let Some(c) = coatings[i] {
            a[i] = c.transmittance(a[i]);
        }
    }
    w.load(&a)
}

/// A light sample in the lanes: direction, radiance, the lanes that have one, its density
/// (the pick's included), and the lanes where it is a parallelogram sampled here.
struct LaneSample<W: Wide> {
    wi: [W::V; 3],
    li: [W::V; 4],
    on: W::M,
    pdf: W::V,
    rect: W::M,
}

/// Next-event estimation for the light samples `ls` of the lanes of `l`:
/// f·cos and the BSDF's density for the light's direction (only its local z matters to
/// Lambert), the power heuristic against the light's density, what each adds (`l.c`) and
/// its shadow ray (`shadow_ray_from`) in `shadows`: between two surface points, each moved
/// off its surface; to a point in space, stopping short of it; or along the direction to a
/// light at infinity.
#[inline(always)]
fn nee<W: Wide>(
    w: W,
    at: &Shading<'_, '_, W>,
    l: &mut LightLanes,
    ls: LaneSample<W>,
    shadows: &mut RayBatch,
) {
    let (zero, one) = (w.splat(0.0), w.splat(1.0));
    let LaneSample {
        wi: lw,
        li,
        on: light,
        pdf: pdf_light,
        rect,
    } = ls;
    let Shading {
        all,
        pos,
        ng,
        tangents,
        n,
        flip,
        wo_up,
        r,
        beta,
        ref conductor,
        ref plastic,
        coatings,
        ref guides,
    } = *at;
    let iz = w.add(
        w.add(w.mul(lw[0], n[0]), w.mul(lw[1], n[1])),
        w.mul(lw[2], n[2]),
    );
    let iz = w.select(flip, w.neg(iz), iz);
    let f_on = w.and(wo_up, positive(w, all, iz));
    let cos_pi = w.mul(w.splat(INV_PI), iz);
    let mut f = [zero; 4];
    for k in 0..4 {
        f[k] = w.select(f_on, w.mul(r[k], cos_pi), zero);
    }
    let mut pdf_bsdf = w.select(
        w.and(wo_up, w.gt(iz, zero)),
        w.mul(iz, w.splat(INV_PI)),
        zero,
    );
    if let Some(g) = guides {
        pdf_bsdf = guide_mix(w, g, pdf_bsdf, lw);
    }
    // The direction in the shading frame (`Bsdf::local_wi`), for the models that need more
    // than its z (loaded here: kept from the start, the tangents crowded out the registers).
    // (Not a closure: closures do not inherit the kernel's instruction set, and the
    // operations in them would be calls.)
    let local = conductor.is_some() || plastic.is_some();
    let wi = if local {
        let (s, t) = (load3(w, tangents.0), load3(w, tangents.1));
        [dot(w, lw, s), dot(w, lw, t), iz]
    } else {
        [zero, zero, iz]
    };
    if let Some(c) = conductor {
        let (f_c, pdf_c) = microfacet_lanes::eval_pdf(w, c, &r, wi);
        for k in 0..4 {
            f[k] = w.select(c.on, f_c[k], f[k]);
        }
        pdf_bsdf = w.select(c.on, pdf_c, pdf_bsdf);
    }
    if let Some(p) = plastic {
        let t_i = transmittances(w, coatings, iz);
        let (f_p, pdf_p) = microfacet_lanes::plastic_eval_pdf(w, p, wi, t_i);
        for k in 0..4 {
            f[k] = w.select(p.on, f_p[k], f[k]);
        }
        pdf_bsdf = w.select(p.on, pdf_p, pdf_bsdf);
    }
    let mut f_nonzero = w.mask(0);
    for fk in f {
        f_nonzero = w.or(f_nonzero, w.ne(fk, zero));
    }
    let ratio = w.div(pdf_bsdf, pdf_light);
    let mis = w.select(
        w.eq(pdf_light, w.splat(f32::INFINITY)),
        one,
        w.select(
            w.gt(pdf_light, zero),
            w.div(one, w.add(one, w.mul(ratio, ratio))),
            zero,
        ),
    );
    let mis = w.select(w.mask(l.delta), one, mis);
    let scale = w.div(mis, pdf_light);
    for k in 0..4 {
        w.store(
            w.mul(w.mul(w.mul(beta[k], f[k]), li[k]), scale),
            &mut l.c[k],
        );
    }
    let rays = w.and(light, f_nonzero);
    l.shadow = w.bits(rays);
    if l.shadow == 0 {
        return;
    }
    let between = w.and(rays, w.or(rect, w.mask(l.to_surface)));
    let towards = w.and(rays, w.mask(l.to_point));
    let away = w.and_not(rays, w.or(between, towards));
    let q = [w.load(&l.at[0]), w.load(&l.at[1]), w.load(&l.at[2])];
    let qn = [w.load(&l.n[0]), w.load(&l.n[1]), w.load(&l.n[2])];
    let to_q = [
        w.sub(q[0], pos[0]),
        w.sub(q[1], pos[1]),
        w.sub(q[2], pos[2]),
    ];
    // `Ray::spawn_to` normalises the normal again.
    let len = w.sqrt(dot(w, ng, ng));
    let inv = w.div(one, len);
    let unit = w.gt(len, zero);
    let mut ng_unit = ng;
    for k in 0..3 {
        ng_unit[k] = w.select(unit, w.mul(ng[k], inv), ng[k]);
    }
    let o_between = offset(w, pos, ng, to_q);
    let o_towards = offset(w, pos, ng_unit, to_q);
    let o_away = offset(w, pos, ng, lw);
    let mut o = o_away;
    let mut back = o_away;
    for k in 0..3 {
        o[k] = w.select(
            between,
            o_between[k],
            w.select(towards, o_towards[k], o_away[k]),
        );
        back[k] = w.sub(o[k], q[k]);
    }
    let t = offset(w, q, qn, back);
    for k in 0..3 {
        let d = w.select(
            between,
            w.sub(t[k], o[k]),
            w.select(towards, w.sub(q[k], o[k]), lw[k]),
        );
        put(w, rays, o[k], &mut shadows.o[k]);
        put(w, rays, d, &mut shadows.d[k]);
    }
    put(w, rays, zero, &mut shadows.tmin);
    let short = w.splat(1.0 - SHADOW_EPSILON);
    let tmax = w.select(away, w.splat(f32::INFINITY), short);
    put(w, rays, tmax, &mut shadows.tmax);
    shadows.active |= l.shadow;
}

/// Four vectors of lanes.
#[inline(always)]
fn load4<W: Wide>(w: W, a: &[L; 4]) -> [W::V; 4] {
    [w.load(&a[0]), w.load(&a[1]), w.load(&a[2]), w.load(&a[3])]
}

/// Three vectors of lanes.
#[inline(always)]
fn load3<W: Wide>(w: W, a: &[L; 3]) -> [W::V; 3] {
    [w.load(&a[0]), w.load(&a[1]), w.load(&a[2])]
}

/// Component k of the local direction (x, y, z) in the world (`Frame::to_world`), given
/// component k of the frame's axes `[s, t, n]`.
#[inline(always)]
fn to_world<W: Wide>(w: W, [s, t, n]: [W::V; 3], x: W::V, y: W::V, z: W::V) -> W::V {
    w.add(w.add(w.mul(s, x), w.mul(t, y)), w.mul(n, z))
}

/// `!(a <= 0)` in the lanes of `all`: the scalar code's tests, NaN included.
#[inline(always)]
fn positive<W: Wide>(w: W, all: W::M, a: W::V) -> W::M {
    w.and_not(all, w.le(a, w.splat(0.0)))
}

/// `f32::max` for operands that are not NaN.
#[inline(always)]
fn max<W: Wide>(w: W, a: W::V, b: W::V) -> W::V {
    w.select(w.lt(a, b), b, a)
}

/// `v` into the lanes `m` of `a`.
#[inline(always)]
fn put<W: Wide>(w: W, m: W::M, v: W::V, a: &mut L) {
    w.store(w.select(m, v, w.load(a)), a);
}

/// The origin `p` (unit geometric normal `n`) moved off its surface towards the side `d`
/// points to, as `Ray::spawn_unit` moves it.
#[inline(always)]
fn offset<W: Wide>(w: W, p: [W::V; 3], n: [W::V; 3], d: [W::V; 3]) -> [W::V; 3] {
    let away = w.lt(dot(w, n, d), w.splat(0.0));
    let mut o = p;
    for k in 0..3 {
        let n = w.select(away, w.neg(n[k]), n[k]);
        let moved = w.move_ulps(p[k], w.mul(w.splat(256.0), n));
        let near = w.add(p[k], w.mul(w.splat(1.0 / 65536.0), n));
        let small = w.lt(w.copysign(p[k], w.splat(1.0)), w.splat(1.0 / 32.0));
        o[k] = w.select(small, near, moved);
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// Lanes of every kind, from random numbers: directions on both sides, lights facing both
    /// ways, delta lights, zero reflectances, roulette on some lanes.
    fn random_lanes<'s>(
        rng: &mut Pcg32,
        coatings: &'s [RoughCoating],
    ) -> (SurfaceLanes<'s>, Vec<Parallelogram>) {
        fn v(rng: &mut Pcg32) -> Vec3 {
            Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            )
        }
        fn s(rng: &mut Pcg32, k: f32) -> SampledSpectrum {
            SampledSpectrum([0; 4].map(|_| rng.next_f32() * k))
        }
        fn tex(rng: &mut Pcg32, k: f32) -> Texture {
            let mut c = || rng.next_f32() * k;
            Texture::Uniform(crate::color::Rgb::new(c(), c(), c()))
        }
        let textures: Vec<(Texture, Texture)> = (0..BATCH)
            .map(|i| {
                let r = if i % 5 == 0 {
                    Texture::Uniform(crate::color::Rgb::BLACK)
                } else {
                    tex(rng, 1.0)
                };
                (r, tex(rng, 9.0))
            })
            .collect();
        let quads: Vec<Parallelogram> = (0..BATCH)
            .map(|_| {
                let p = Point3::ORIGIN + v(rng) * 4.0;
                Parallelogram::new(p, v(rng), v(rng)).expect("quad")
            })
            .collect();
        let mut lanes = SurfaceLanes::default();
        for (i, q) in quads.iter().enumerate() {
            let n = v(rng).normalize();
            let frame = Frame::from_normal(n.to_normal());
            let wo = v(rng);
            let flip = rng.next_f32() < 0.3;
            let light = match i % 4 {
                0 => LaneLight::None,
                1 | 3 if i < 8 => LaneLight::Sample(
                    LightSample {
                        wi: v(rng).normalize(),
                        li: s(rng, 1.0),
                        pdf: rng.next_f32() * 3.0,
                        delta: rng.next_f32() < 0.5,
                        target: match i % 3 {
                            0 => Target::Point(Point3::ORIGIN + v(rng) * 3.0),
                            1 => Target::Surface(
                                Point3::ORIGIN + v(rng) * 3.0,
                                v(rng).normalize().to_normal(),
                            ),
                            _ => Target::Infinite,
                        },
                    },
                    rng.next_f32(),
                ),
                2 if i % 8 == 6 => LaneLight::Tri {
                    corners: [q.p, q.p + q.v, q.p + q.w],
                    n: q.normal(),
                    inv_area: 2.0 / q.area(),
                    radiance: &textures[i].1,
                    two_sided: i % 3 == 0,
                    u: [rng.next_f32(), rng.next_f32()],
                    pick_pdf: rng.next_f32(),
                },
                _ => LaneLight::Rect {
                    q,
                    inv_area: 1.0 / q.area(),
                    radiance: &textures[i].1,
                    two_sided: i % 3 == 0,
                    u: [rng.next_f32(), rng.next_f32()],
                    pick_pdf: rng.next_f32(),
                },
            };
            let p = Point3::ORIGIN + v(rng) * if i % 7 == 0 { 0.01 } else { 5.0 };
            let vertex = LaneVertex {
                p,
                ng: v(rng).normalize().to_normal(),
                frame,
                wo_z: wo.dot(n),
                flip,
                reflectance: &textures[i].0,
                uv: crate::math::Point2::new(0.0, 0.0),
                lambda: &Wavelengths::Rgb,
                beta: s(rng, 1.0),
                light,
                u2: [rng.next_f32(), rng.next_f32()],
                u_rr: (i % 3 != 1).then(|| rng.next_f32()),
                eta_scale: 1.0 + rng.next_f32(),
            };
            lanes.set(i, &vertex);
            // Some rough conductors, with and without a complex index, and rough plastics.
            let conductor = (i % 3 == 2).then(|| ConductorVertex {
                alpha: 0.01 + rng.next_f32(),
                eta_k: (i % 2 == 0).then(|| (s(rng, 2.0), s(rng, 4.0))),
            });
            let plastic = (i % 3 == 1).then(|| PlasticVertex {
                coating: &coatings[i % coatings.len()],
                t_o: rng.next_f32(),
                ps: rng.next_f32(),
                kb: s(rng, 1.0),
                ks: s(rng, 1.0),
                u1: rng.next_f32(),
            });
            if i % 3 != 0 {
                lanes.set_surface(i, wo, conductor, plastic);
            }
            // Two more lights, as in the every-light mode (some lanes without a sample).
            for k in 1..3 {
                let ls = ((i + k) % 5 != 0).then(|| LightSample {
                    wi: v(rng).normalize(),
                    li: s(rng, 1.0),
                    pdf: rng.next_f32() * 3.0,
                    delta: true,
                    target: if k == 1 {
                        Target::Point(Point3::ORIGIN + v(rng) * 3.0)
                    } else {
                        Target::Infinite
                    },
                });
                lanes.set_sample(i, k, ls.as_ref(), 1.0);
            }
        }
        lanes.extra = 2;
        lanes.lanes = 0xbfff;
        (lanes, quads)
    }

    #[test]
    fn every_instruction_set_shades_the_same_bits() {
        use crate::material::{Distribution, Microfacet};
        let coatings =
            [0.1, 0.4].map(|a| RoughCoating::new(Microfacet::new(Distribution::Ggx, a), 1.5));
        let levels = [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512];
        let supported = SimdLevel::supported();
        let mut rng = Pcg32::new(4, 7);
        let mut seen = [0u32; 3];
        for _ in 0..50 {
            let mut results = Vec::new();
            for &level in levels.iter().filter(|&&l| l <= supported) {
                let (mut lanes, _quads) = random_lanes(&mut rng.clone(), &coatings);
                let mut next = RayBatch::default();
                let mut shadows = [RayBatch::default(); MAX_SHADOWS];
                let mut pending = [[SampledSpectrum::ZERO; BATCH]; MAX_SHADOWS];
                lanes.shade_at(level, &mut next, &mut shadows, &mut pending);
                let bits =
                    |a: &[L]| -> Vec<u32> { a.iter().flat_map(|l| l.map(f32::to_bits)).collect() };
                let lights: Vec<_> = (0..3)
                    .map(|k| {
                        let (l, sh) = (&lanes.lights[k], &shadows[k]);
                        let shown = |a: &[L]| -> Vec<u32> {
                            // Only the lanes with a shadow ray are outputs.
                            a.iter()
                                .flat_map(|x| {
                                    crate::math::lanes(l.shadow).map(move |i| x[i].to_bits())
                                })
                                .collect()
                        };
                        (
                            (l.shadow, sh.active),
                            shown(&l.c),
                            shown(&sh.o),
                            shown(&sh.d),
                            shown(&[sh.tmax]),
                        )
                    })
                    .collect();
                results.push((
                    (lanes.alive, lights),
                    bits(&lanes.beta_out),
                    bits(&[lanes.pdf]),
                    bits(&next.o),
                    bits(&next.d),
                ));
            }
            assert!(results.windows(2).all(|w| w[0] == w[1]));
            assert_eq!(
                results.len(),
                levels.iter().filter(|&&l| l <= supported).count()
            );
            let ((alive, lights), ..) = &results[0];
            let (shadow, rays) = lights[0].0;
            assert!(shadow & !0xbfff == 0 && alive & !0xbfff == 0 && rays & !0xbfff == 0);
            assert!(lights.iter().all(|l| l.0 .0 == l.0 .1));
            seen[0] += shadow.count_ones();
            seen[1] += alive.count_ones();
            seen[2] += lights[1].0 .0.count_ones() + lights[2].0 .0.count_ones();
            let _ = rng.next_u32();
        }
        // Every kind of outcome was compared.
        assert!(seen.iter().all(|&k| k > 20), "{seen:?}");
    }

    /// A lane that keeps its parallelogram light from an earlier step (`SurfaceLanes::held`)
    /// shades as lanes put in afresh do, bit for bit: over steps where each lane samples one
    /// of two parallelograms again, another one, a sphere (whose kernel writes the light's
    /// normal and radiance), a light's own sample or none, on RGB and spectral paths.
    #[test]
    fn lanes_holding_a_light_shade_as_fresh_ones() {
        let radiance = [
            Texture::Uniform(crate::color::Rgb::new(6.0, 4.0, 2.5)),
            Texture::Uniform(crate::color::Rgb::new(1.0, 3.0, 9.0)),
        ];
        let white = Texture::Uniform(crate::color::Rgb::new(0.7, 0.6, 0.5));
        let quads = [
            Parallelogram::new(
                Point3::new(-1.0, 3.0, -1.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 2.0),
            ),
            Parallelogram::new(
                Point3::new(2.0, 1.0, -1.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 1.5),
            ),
        ]
        .map(|q| q.expect("quad"));
        let spectral = Wavelengths::sample(0.37);
        let mut rng = Pcg32::new(9, 3);
        let mut held = SurfaceLanes::default();
        let mut kept = 0;
        for step in 0..40 {
            let mut fresh = SurfaceLanes::default();
            for i in 0..BATCH {
                let u = [rng.next_f32(), rng.next_f32()];
                let pick_pdf = 0.25 + rng.next_f32();
                let k = (rng.next_u32() % 8) as usize;
                let light = match k {
                    0..=3 => LaneLight::Rect {
                        q: &quads[k % 2],
                        inv_area: 1.0 / quads[k % 2].area(),
                        radiance: &radiance[k % 2],
                        two_sided: k % 2 == 1,
                        u,
                        pick_pdf,
                    },
                    4 => LaneLight::Sphere {
                        c: Point3::new(0.0, 4.0, 0.0),
                        r: 0.5,
                        radiance: &radiance[0],
                        two_sided: false,
                        u,
                        pick_pdf,
                    },
                    5 => LaneLight::Sample(
                        LightSample {
                            wi: Vec3::new(0.3, 0.9, 0.1).normalize(),
                            li: SampledSpectrum([2.0, 1.0, 0.5, 1.0]),
                            pdf: 0.8,
                            delta: false,
                            target: Target::Surface(
                                Point3::new(0.6, 3.0, 0.2),
                                Vec3::new(0.0, -1.0, 0.0).to_normal(),
                            ),
                        },
                        pick_pdf,
                    ),
                    _ => LaneLight::None,
                };
                if k < 4 && held.held[i] == held_key(&quads[k % 2]) {
                    kept += 1;
                }
                let n = Vec3::new(rng.next_f32() - 0.5, 1.0, rng.next_f32() - 0.5).normalize();
                let vertex = LaneVertex {
                    p: Point3::new(rng.next_f32() * 2.0 - 1.0, 0.0, rng.next_f32() * 2.0 - 1.0),
                    ng: n.to_normal(),
                    frame: Frame::from_normal(n.to_normal()),
                    wo_z: 0.2 + rng.next_f32() * 0.8,
                    flip: false,
                    reflectance: &white,
                    uv: Point2::new(0.0, 0.0),
                    lambda: if step % 10 == 9 {
                        &spectral
                    } else {
                        &Wavelengths::Rgb
                    },
                    beta: SampledSpectrum([1.0; 4]),
                    light,
                    u2: [rng.next_f32(), rng.next_f32()],
                    u_rr: None,
                    eta_scale: 1.0,
                };
                held.set(i, &vertex);
                fresh.set(i, &vertex);
            }
            let mut out = Vec::new();
            for lanes in [&mut held, &mut fresh] {
                let mut next = RayBatch::default();
                let mut shadows = [RayBatch::default(); MAX_SHADOWS];
                let mut pending = [[SampledSpectrum::ZERO; BATCH]; MAX_SHADOWS];
                lanes.shade(&mut next, &mut shadows, &mut pending);
                let l = &lanes.lights[0];
                let shown = |a: &[L]| -> Vec<u32> {
                    a.iter()
                        .flat_map(|x| crate::math::lanes(l.shadow).map(move |i| x[i].to_bits()))
                        .collect()
                };
                let bits = |a: &[L]| -> Vec<u32> {
                    a.iter()
                        .flat_map(|x| crate::math::lanes(lanes.alive).map(move |i| x[i].to_bits()))
                        .collect()
                };
                out.push((
                    (l.shadow, lanes.alive),
                    shown(&l.c),
                    shown(&shadows[0].d),
                    shown(&[shadows[0].tmax]),
                    bits(&lanes.beta_out),
                    bits(&[lanes.pdf]),
                    bits(&next.d),
                ));
                lanes.lanes = 0;
            }
            assert_eq!(out[0], out[1], "step {step}");
        }
        // Many lanes kept their light from the step before (about 80 are expected: a
        // parallelogram lane finds the same one there one time in four).
        assert!(kept > 40, "{kept}");
    }

    /// The lanes' sphere-light samples are `AreaLight::sample`'s, bit for bit, at every
    /// instruction set: one-sided and two-sided spheres seen from near and far, the light's
    /// usable samples (and only those) kept, with the pick's probability in the density.
    #[test]
    fn sphere_light_samples_are_the_lights_own() {
        use crate::light::{AreaLight, AreaShape, Emission};
        use crate::math::Transform;
        use crate::shape::Sphere;
        let radiance = Texture::Uniform(crate::color::Rgb::new(6.0, 4.0, 2.5));
        let geometry = crate::geometry::Geometry::default();
        let supported = SimdLevel::supported();
        let mut rng = Pcg32::new(5, 7);
        let mut seen = [0usize; 2];
        for round in 0..200u64 {
            let two_sided = round % 2 == 1;
            let emissions = [Emission {
                radiance: radiance.clone(),
                two_sided,
            }];
            let r = 0.01 + rng.next_f32() * 0.3;
            let c = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            );
            let place = Transform::translation(c) * Transform::scaling(Vec3::new(r, r, r));
            let light = AreaLight::sphere(Sphere::new(place), 0);
            let AreaShape::Sphere {
                cone: Some((c, r)), ..
            } = light.shape
            else {
                panic!("a round sphere samples its cone");
            };
            for level in [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512] {
                if level > supported {
                    continue;
                }
                let mut lanes = SurfaceLanes::default();
                let mut want = Vec::new();
                let mut rng = Pcg32::new(round, 11);
                for i in 0..BATCH {
                    // Points from just outside the sphere to far away.
                    let dir = Vec3::new(
                        rng.next_f32() - 0.5,
                        rng.next_f32() - 0.5,
                        rng.next_f32() - 0.5,
                    );
                    let p = c + dir.normalize() * (r * 1.001 + rng.next_f32().powi(3) * 50.0);
                    let u = [rng.next_f32(), rng.next_f32()];
                    let pick_pdf = rng.next_f32();
                    let ls = light
                        .sample(&geometry, &emissions, p, u, &Wavelengths::Rgb)
                        .filter(|s| s.pdf > 0.0 && s.wi.is_finite() && !s.li.is_black());
                    want.push(ls.map(|s| (s, pick_pdf)));
                    let vertex = LaneVertex {
                        p,
                        ng: Vec3::Z.to_normal(),
                        frame: Frame::from_normal(Vec3::Z.to_normal()),
                        wo_z: 0.5,
                        flip: false,
                        reflectance: &radiance,
                        uv: Point2::new(0.0, 0.0),
                        lambda: &Wavelengths::Rgb,
                        beta: SampledSpectrum([1.0; 4]),
                        light: LaneLight::Sphere {
                            c,
                            r,
                            radiance: &radiance,
                            two_sided,
                            u,
                            pick_pdf,
                        },
                        u2: [0.5, 0.5],
                        u_rr: None,
                        eta_scale: 1.0,
                    };
                    lanes.set(i, &vertex);
                }
                let usable = crate::simd::run_wide_at(level, SphereSamples(&mut lanes));
                let l = &lanes.lights[0];
                for (i, want) in want.iter().enumerate() {
                    assert_eq!(usable >> i & 1 == 1, want.is_some(), "{level:?} lane {i}");
                    let Some((s, pick_pdf)) = want else { continue };
                    seen[two_sided as usize] += 1;
                    let Target::Surface(q, n) = s.target else {
                        panic!("a point on the sphere");
                    };
                    let bits = |v: [f32; 3]| v.map(f32::to_bits);
                    let lane = |a: &[L; 3]| bits([a[0][i], a[1][i], a[2][i]]);
                    assert_eq!(lane(&l.wi), bits([s.wi.x, s.wi.y, s.wi.z]), "{level:?}");
                    assert_eq!(lane(&l.at), bits([q.x, q.y, q.z]), "{level:?}");
                    assert_eq!(lane(&l.n), bits([n.x, n.y, n.z]), "{level:?}");
                    assert_eq!(l.pdf[i].to_bits(), (pick_pdf * s.pdf).to_bits());
                    for k in 0..4 {
                        assert_eq!(l.li[k][i].to_bits(), s.li.0[k].to_bits());
                    }
                }
            }
        }
        assert!(seen.iter().all(|&k| k > 1000), "{seen:?}");
    }
}
