//! Which light next-event estimation samples at a shading point.
//!
//! In scenes with up to [`MAX_IMPORTANCE_LIGHTS`] lights, not all of them emissive shapes,
//! every light's *importance* at the shading point is evaluated and one light is picked in proportion to it, by inverting the
//! cumulative sum with the light sample's first number (which is then rescaled, so that each
//! light keeps a stratified share of the pixel's samples). The importance estimates the
//! unshadowed irradiance the light delivers:
//! - point, spot and distant lights: exactly that, I·fall-off·profile·cos θ (or E·cos θ), from
//!   the light's colour averaged over its channels (a spot's projected texture is left out);
//! - an environment map: π times its mean radiance;
//! - a constant environment or a hemisphere light: 0. Their radiance does not vary (within the
//!   lit hemisphere), so BSDF sampling already samples f·cos·L in proportion to f·cos, as well
//!   as any light sample could; with a choice probability of 0, MIS gives those BSDF samples
//!   their full weight, and no shadow ray is spent on them. (Measured on the bench's meshes
//!   under a rectangle light and a constant sky: RMSE 0.0081 with the sky's share at π L,
//!   0.0069 at a quarter of that, 0.0064 at 0, for fewer rays.) Alone in a scene they are
//!   still sampled, as every single light is (by the path tracer at the first vertex only:
//!   see `integrator::path`);
//! - an emissive shape: its power per side over π (L·A, comparable with the irradiances above)
//!   over the squared distance to its centre (at least its bounding sphere's squared radius),
//!   and 0 where it cannot reach the point: a one-sided planar light seen from behind, a light
//!   whose bounding sphere lies below a reflecting surface's tangent plane. No square root: the
//!   cosine bounds of pbrt-v4's `LightBounds::Importance` (tried first) cost about 20 ns per
//!   light and vertex, which on a Cornell box with three rectangle lights made the frame 56 %
//!   slower for 12 % less variance.
//!
//! The importances are evaluated four lights at a time (SSE lanes, every kind of light by one
//! formula: see `Lanes`), and [`LightSelector::pick`] and [`LightSelector::pmf`] read the same
//! numbers, so that the probability MIS recomputes is the one the choice had, bit for bit.
//!
//! The cosine at the point is taken on the side of the outgoing direction when the BSDF only
//! reflects, and on either side otherwise. A light of importance 0 is never sampled; that costs
//! no bias because multiple importance sampling then gives BSDF sampling its full weight. With
//! more lights or one light, the choice is uniform. Emissive shapes alone are chosen in
//! proportion to their power (L·A, doubled when two-sided), uniformly when their powers are
//! equal (see [`LightSelector::new`] for why not by importance). When a single light
//! has any importance (the others being constant skies), it is picked without evaluating it:
//! where its importance is 0 it cannot contribute either. [`LightSelector::pmf`] recomputes the
//! probability with which the vertex a path left picked a light, for the MIS weights of emitters
//! that BSDF sampling finds.

use super::{AreaShape, Emission, Light, SpotProfile};
use crate::geometry::Geometry;
use crate::math::{Bounds3, Point3, Vec3, PI};
use crate::sampling::sampler::ONE_MINUS_EPSILON;
use crate::simd::F4;

/// Most lights whose importance is evaluated one by one at every shading point; scenes with
/// more lights choose uniformly.
pub const MAX_IMPORTANCE_LIGHTS: usize = 8;

/// A shading point as light selection and light sampling see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingPoint {
    /// The position.
    pub p: Point3,
    /// The unit shading normal, on the side of the outgoing direction.
    pub n: Vec3,
    /// The BSDF reflects only (into the hemisphere of `n`): lights may restrict their samples
    /// to that hemisphere.
    pub reflect_only: bool,
}

impl ShadingPoint {
    /// A point with no surface (no normal to favour, no hemisphere to restrict to).
    pub fn at(p: Point3) -> Self {
        Self {
            p,
            n: Vec3::Z,
            reflect_only: false,
        }
    }
}

/// What the importance of one light needs, computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Bound {
    /// Point, spot, distant and hemisphere lights: computed exactly from the light.
    Exact,
    /// A light at infinity of the given irradiance (π × mean radiance).
    Infinite(f32),
    /// An emissive shape.
    Shape {
        /// Centre of its bounding box.
        centre: Point3,
        /// Squared radius of the bounding sphere around `centre`.
        radius2: f32,
        /// Axis of the cone bounding its normals.
        axis: Vec3,
        /// The shape is planar (every normal is `axis`); otherwise its normals may point
        /// anywhere.
        planar: bool,
        /// Emits on both sides.
        two_sided: bool,
        /// Power per side over π: L·A.
        phi: f32,
    },
}

/// The light selection of a scene: importance at the shading point for few lights, power for
/// emissive shapes alone, uniform for many.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightSelector {
    /// One bound per light; empty for the uniform choice.
    bounds: Vec<Bound>,
    /// The bounds as four lanes at a time, for evaluating the importances together.
    lanes: Vec<Lanes>,
    /// Some point or spot light has the lecture's attenuation.
    attenuated: bool,
    /// The one light with any importance when every other one has none anywhere (constant
    /// skies beside it): it is chosen without evaluating the importances. Where its own
    /// importance is 0 it can contribute nothing either (seen from behind, or below a
    /// reflecting surface's horizon), neither by a light sample nor by BSDF sampling.
    sole: Option<usize>,
    /// Emissive shapes alone, of unequal powers: each light's power (L·A, doubled when
    /// two-sided) and their running sums, to choose in proportion to power. Empty for the
    /// uniform choice and for the choice by importance.
    power: Vec<f32>,
    /// The running sums of `power` (the last is the total).
    power_cdf: Vec<f32>,
}

impl LightSelector {
    /// The selector for `lights` (with the emissions and geometry of their shapes).
    pub fn new(lights: &[Light], emissions: &[Emission], geometry: &Geometry) -> Self {
        // Emissive shapes alone are chosen by power, not by importance: their importance does
        // not pay for its cost. Measured again with the four-lane evaluation below (Intel
        // Xeon, bench/extra, variance over 12 seeds): the specular box with two rectangle
        // lights, 1 % less variance for 27 % more time; the box with three, 22 % less
        // variance for 31 % more time. Evaluating the importances alone (and choosing
        // uniformly still) costs 25 % of that frame; the rest is the shadow rays of vertices
        // that no longer pick a light facing away. Choosing by power (free per vertex) gives
        // 8.6 % less variance with three lights (RMSE 0.02991 -> 0.02859 at 256², 64 spp, 12
        // seeds) and the same with two (0.06885 -> 0.06894), for the same time.
        let shapes_only = lights.iter().all(|l| matches!(l, Light::Area(_)));
        if shapes_only && lights.len() > 1 {
            return Self::by_power(lights, emissions);
        }
        if lights.len() <= 1 || lights.len() > MAX_IMPORTANCE_LIGHTS {
            return Self::default();
        }
        let bounds = lights
            .iter()
            .map(|l| match l {
                Light::Point(..) | Light::Spot(..) | Light::Distant(..) => Bound::Exact,
                // Radiance constant over directions: BSDF sampling already samples it in
                // proportion to f·cos, so next-event estimation leaves it to BSDF sampling.
                Light::Hemisphere(..) => Bound::Infinite(0.0),
                Light::Environment(e) if !e.is_importance_sampled() => Bound::Infinite(0.0),
                Light::Environment(e) => Bound::Infinite(PI * e.radiance.average().average()),
                Light::Area(a) => {
                    let e = &emissions[a.emission as usize];
                    let phi = e.radiance.average().average() * a.area;
                    let (b, axis, planar) = match &a.shape {
                        AreaShape::Parallelogram(q) => (q.bounds(), q.normal().to_vec(), true),
                        AreaShape::Disk(d) => (
                            d.bounds(),
                            d.world_from_object
                                .normal(Vec3::Z.to_normal())
                                .to_vec()
                                .normalize(),
                            true,
                        ),
                        AreaShape::Sphere { sphere, .. } => (sphere.bounds(), Vec3::Z, false),
                        AreaShape::Cube { cube, .. } => (cube.bounds(), Vec3::Z, false),
                        AreaShape::Mesh { mesh, .. } => {
                            let m = &geometry.meshes()[*mesh as usize];
                            let first = m.positions.first().copied().unwrap_or(Point3::ORIGIN);
                            let b = m
                                .positions
                                .iter()
                                .fold(Bounds3::point(first), |b, &p| b.union_point(p));
                            (b, Vec3::Z, false)
                        }
                    };
                    let d = b.diagonal();
                    let ok = phi.is_finite() && d.is_finite() && axis.is_finite();
                    Bound::Shape {
                        centre: b.centroid(),
                        radius2: 0.25 * d.squared_norm(),
                        axis,
                        planar,
                        two_sided: e.two_sided,
                        phi: if ok { phi.max(0.0) } else { 0.0 },
                    }
                }
            })
            .collect::<Vec<_>>();
        let mut lit =
            (0..bounds.len()).filter(|&i| !matches!(bounds[i], Bound::Infinite(e) if e == 0.0));
        let sole = match (lit.next(), lit.next()) {
            (Some(k), None) => match bounds[k] {
                Bound::Exact => Some(k),
                Bound::Shape { phi, .. } if phi > 0.0 => Some(k),
                _ => None,
            },
            _ => None,
        };
        let lanes = (0..bounds.len().div_ceil(4))
            .map(|g| Lanes::new(lights, &bounds, g))
            .collect();
        let attenuated = lights.iter().any(|l| match l {
            Light::Point(l, _) => l.falloff.attenuation.is_some(),
            Light::Spot(l, _) => l.falloff.attenuation.is_some(),
            _ => false,
        });
        Self {
            bounds,
            lanes,
            attenuated,
            sole,
            power: Vec::new(),
            power_cdf: Vec::new(),
        }
    }

    /// The selector of several emissive shapes (and no other light): in proportion to their
    /// powers where those differ, uniform where they are equal (the same choice, and the same
    /// numbers as before). Power is free per vertex, where the importance at the point is
    /// not (see [`LightSelector::new`]); pbrt-v4's `PowerLightSampler` does the same.
    fn by_power(lights: &[Light], emissions: &[Emission]) -> Self {
        let power: Vec<f32> = lights
            .iter()
            .map(|l| match l {
                Light::Area(a) => {
                    let e = &emissions[a.emission as usize];
                    let sides = if e.two_sided { 2.0 } else { 1.0 };
                    let phi = e.radiance.average().average() * a.area * sides;
                    if phi.is_finite() {
                        phi.max(0.0)
                    } else {
                        0.0
                    }
                }
                _ => 0.0,
            })
            .collect();
        let power_cdf: Vec<f32> = power
            .iter()
            .scan(0.0f32, |acc, &p| {
                *acc += p;
                Some(*acc)
            })
            .collect();
        let total = power_cdf.last().copied().unwrap_or(0.0);
        let equal = power.iter().all(|&p| p == power[0]);
        if equal || !(total > 0.0 && total.is_finite()) {
            return Self::default();
        }
        Self {
            power,
            power_cdf,
            ..Self::default()
        }
    }

    /// True when lights are chosen uniformly.
    pub fn is_uniform(&self) -> bool {
        self.bounds.is_empty() && self.power.is_empty()
    }

    /// True when lights are chosen in proportion to their power (emissive shapes alone).
    pub fn is_by_power(&self) -> bool {
        !self.power.is_empty()
    }

    /// The total power of the lights chosen by power.
    #[inline(always)]
    fn power_total(&self) -> f32 {
        self.power_cdf[self.power_cdf.len() - 1]
    }

    /// Picks a light in proportion to its power with `u`: its index, probability and `u`
    /// rescaled within its share.
    #[inline(always)]
    fn pick_by_power(&self, u: f32) -> (usize, f32, f32) {
        let total = self.power_total();
        let x = u * total;
        // The first running sum above x (a light of power 0 has no share), within range
        // when round-off puts x at the total.
        let mut i = self.power_cdf.partition_point(|&c| c <= x);
        if i >= self.power.len() {
            i = self.power.iter().rposition(|&p| p > 0.0).unwrap_or(0);
        }
        let start = if i == 0 { 0.0 } else { self.power_cdf[i - 1] };
        let v = ((x - start) / self.power[i]).clamp(0.0, ONE_MINUS_EPSILON);
        (i, self.power[i] / total, v)
    }

    /// The importances of every light at `sp` (see the module's documentation), four lights
    /// at a time, and their sum in the lights' order: what [`LightSelector::pick`] and
    /// [`LightSelector::pmf`] both read, so that the probability MIS recomputes is the one the
    /// choice had, bit for bit.
    #[inline(always)]
    fn importances(
        &self,
        lights: &[Light],
        sp: &ShadingPoint,
    ) -> ([f32; MAX_IMPORTANCE_LIGHTS], f32) {
        let mut w = [0f32; MAX_IMPORTANCE_LIGHTS];
        for (g, lanes) in self.lanes.iter().enumerate() {
            let v = lanes.importance(lights, sp, self.attenuated, g);
            w[4 * g..4 * g + 4].copy_from_slice(&v);
        }
        // Over whole groups, pairwise within each (a shorter chain of additions): the lanes
        // past the last light hold +0, which adds nothing (importances are never negative).
        let mut sum = 0.0;
        for g in w[..4 * self.lanes.len()].chunks_exact(4) {
            sum += (g[0] + g[1]) + (g[2] + g[3]);
        }
        (w, sum)
    }

    /// Picks one of `lights` at `sp` with the uniform number `u`: its index, the probability
    /// of that choice and `u` rescaled to [0, 1) within the light's share. `None` when no
    /// light has any importance there.
    #[inline(always)]
    pub fn pick(&self, lights: &[Light], sp: &ShadingPoint, u: f32) -> Option<(usize, f32, f32)> {
        let n = lights.len();
        match n {
            0 => return None,
            1 => return Some((0, 1.0, u)),
            _ => {}
        }
        if !self.power.is_empty() {
            return Some(self.pick_by_power(u));
        }
        if self.bounds.len() != n {
            let pick = ((u * n as f32) as usize).min(n - 1);
            let v = if n > 1 {
                (u * n as f32 - pick as f32).min(ONE_MINUS_EPSILON)
            } else {
                u
            };
            return Some((pick, 1.0 / n as f32, v));
        }
        if let Some(k) = self.sole {
            return Some((k, 1.0, u));
        }
        self.pick_by_importance(lights, sp.p, sp.n, sp.reflect_only, u)
    }

    /// [`LightSelector::pick`] by importance (kept out of line: the uniform choice of the
    /// common one-light scene stays small where it is inlined).
    #[inline(never)]
    fn pick_by_importance(
        &self,
        lights: &[Light],
        p: Point3,
        n: Vec3,
        reflect_only: bool,
        u: f32,
    ) -> Option<(usize, f32, f32)> {
        let n_lights = lights.len();
        let sp = ShadingPoint { p, n, reflect_only };
        let (w, sum) = self.importances(lights, &sp);
        if !(sum > 0.0 && sum < f32::INFINITY) {
            return None;
        }
        let x = u * sum;
        let mut acc = 0.0;
        let mut last = 0;
        for (i, &wi) in w.iter().enumerate().take(n_lights) {
            if wi <= 0.0 {
                continue;
            }
            last = i;
            if x < acc + wi {
                let v = ((x - acc) / wi).clamp(0.0, ONE_MINUS_EPSILON);
                return Some((i, wi / sum, v));
            }
            acc += wi;
        }
        // Round-off past the last share: the last light with some importance.
        let wl = w[last];
        Some((last, wl / sum, ONE_MINUS_EPSILON))
    }

    /// True when [`LightSelector::pick`] never chooses light `i`, wherever it is asked (a
    /// constant sky beside the one light with any importance): its density of being picked
    /// is 0 everywhere, and MIS gives BSDF samples that find it their full weight.
    #[inline(always)]
    pub fn never_picks(&self, i: usize) -> bool {
        matches!(self.sole, Some(k) if k != i)
    }

    /// The probability with which [`LightSelector::pick`] chooses light `i` at `sp`.
    #[inline(always)]
    pub fn pmf(&self, lights: &[Light], sp: &ShadingPoint, i: usize) -> f32 {
        let n = lights.len();
        if !self.power.is_empty() {
            return self.power.get(i).map_or(0.0, |&p| p / self.power_total());
        }
        if self.bounds.len() != n {
            return if n == 0 { 0.0 } else { 1.0 / n as f32 };
        }
        if let Some(k) = self.sole {
            return if i == k { 1.0 } else { 0.0 };
        }
        self.pmf_by_importance(lights, sp.p, sp.n, sp.reflect_only, i)
    }

    /// [`LightSelector::pmf`] by importance (out of line, as [`LightSelector::pick`]'s).
    #[inline(never)]
    fn pmf_by_importance(
        &self,
        lights: &[Light],
        p: Point3,
        n: Vec3,
        reflect_only: bool,
        i: usize,
    ) -> f32 {
        let sp = ShadingPoint { p, n, reflect_only };
        let (w, sum) = self.importances(lights, &sp);
        if sum > 0.0 && sum < f32::INFINITY && i < lights.len() {
            w[i] / sum
        } else {
            0.0
        }
    }
}

/// The importance bounds of four lights (a group of [`LightSelector`]'s lights) in structure of
/// arrays form: every kind of light evaluated by one formula, lane by lane. With `to` the
/// vector `origin + k·p` from the shading point `p` to the light (`k` = −1 for lights at a
/// position, 0 for directions), d² its squared length and h = n·to:
///
/// importance = `scale` · cosine · profile / (max(d²·`s`, `c`) · attenuation)
///
/// where the cosine is h/d for point, spot and distant lights and 1 otherwise; the profile is
/// a spot light's (1 off spots, 0 outside the cone); the attenuation max(c1 + c2·d + c3·d², 1)
/// the lecture's (1 without one); and it is 0 where a one-sided planar light is seen from
/// behind (`back`·to ≥ `back_at`) or a shape lies below a reflecting surface's tangent plane
/// (h < 0 and h² > `horizon`).
#[derive(Clone, Debug, Default, PartialEq)]
struct Lanes {
    origin: [[f32; 4]; 3],
    k: [f32; 4],
    scale: [f32; 4],
    s: [f32; 4],
    c: [f32; 4],
    /// 1 for lights whose importance has the cosine at the point, 0 otherwise.
    cosine: [f32; 4],
    /// A spot light's axis (0 elsewhere).
    axis: [[f32; 4]; 3],
    /// cos of a spot's cut-off (−∞ elsewhere).
    cos_cutoff: [f32; 4],
    /// cos of a spot's beam width, inside which its profile is 1 (+∞ for the lecture's
    /// profile, −∞ off spots).
    cos_beam: [f32; 4],
    /// Attenuation (c1, c2, c3) (0 without one).
    att: [[f32; 4]; 3],
    /// The normal of a one-sided planar light (0 elsewhere).
    back: [[f32; 4]; 3],
    /// 0 for one-sided planar lights, +∞ elsewhere.
    back_at: [f32; 4],
    /// A shape's squared bounding radius (+∞ for lights that are not shapes).
    horizon: [f32; 4],
    /// Bit i: lane i is a spot light.
    spots: u32,
}

impl Lanes {
    /// Lanes `4g..4g + 4` of `bounds` (lanes past the last light have importance 0).
    fn new(lights: &[Light], bounds: &[Bound], g: usize) -> Self {
        let inf = f32::INFINITY;
        let mut l = Lanes {
            origin: [[0.0; 4], [0.0; 4], [1.0; 4]],
            k: [0.0; 4],
            scale: [0.0; 4],
            s: [0.0; 4],
            c: [1.0; 4],
            cosine: [0.0; 4],
            axis: [[0.0; 4]; 3],
            cos_cutoff: [-inf; 4],
            cos_beam: [-inf; 4],
            att: [[0.0; 4]; 3],
            back: [[0.0; 4]; 3],
            back_at: [inf; 4],
            horizon: [inf; 4],
            spots: 0,
        };
        for j in 0..4 {
            let i = 4 * g + j;
            let Some(bound) = bounds.get(i) else {
                break;
            };
            let mut at = |o: [f32; 3], k: f32| {
                for (a, o) in l.origin.iter_mut().zip(o) {
                    a[j] = o;
                }
                l.k[j] = k;
            };
            // A point or spot light's fall-off: (r/d)² when r > 0, and the attenuation.
            let falloff = |l: &mut Lanes, f: &super::Falloff, intensity: f32| {
                if f.radius > 0.0 {
                    l.scale[j] = intensity * (f.radius * f.radius);
                    (l.s[j], l.c[j]) = (1.0, 0.0);
                } else {
                    l.scale[j] = intensity;
                }
                if let Some(a) = f.attenuation {
                    for (x, a) in l.att.iter_mut().zip(a) {
                        x[j] = a;
                    }
                }
                l.cosine[j] = 1.0;
            };
            match (bound, &lights[i]) {
                (Bound::Exact, Light::Point(p, _)) => {
                    at([p.position.x, p.position.y, p.position.z], -1.0);
                    falloff(&mut l, &p.falloff, p.intensity.average());
                }
                (Bound::Exact, Light::Spot(p, _)) => {
                    at([p.position.x, p.position.y, p.position.z], -1.0);
                    falloff(&mut l, &p.falloff, p.intensity.average());
                    for (a, x) in l.axis.iter_mut().zip([p.axis.x, p.axis.y, p.axis.z]) {
                        a[j] = x;
                    }
                    l.cos_cutoff[j] = p.cos_cutoff;
                    l.cos_beam[j] = match p.profile {
                        SpotProfile::Power(_) => inf,
                        SpotProfile::Linear { cos_beam, .. } => cos_beam,
                    };
                    l.spots |= 1 << j;
                }
                (Bound::Exact, Light::Distant(d, _)) => {
                    let w = -d.direction;
                    at([w.x, w.y, w.z], 0.0);
                    l.scale[j] = d.irradiance.average();
                    l.cosine[j] = 1.0;
                }
                (Bound::Exact, _) => {}
                (Bound::Infinite(e), _) => l.scale[j] = *e,
                (
                    Bound::Shape {
                        centre,
                        radius2,
                        axis,
                        planar,
                        two_sided,
                        phi,
                    },
                    _,
                ) => {
                    at([centre.x, centre.y, centre.z], -1.0);
                    l.scale[j] = *phi;
                    (l.s[j], l.c[j]) = (1.0, *radius2);
                    l.horizon[j] = *radius2;
                    if *planar && !*two_sided {
                        for (b, x) in l.back.iter_mut().zip([axis.x, axis.y, axis.z]) {
                            b[j] = x;
                        }
                        l.back_at[j] = 0.0;
                    }
                }
            }
        }
        l
    }

    /// The importances of the four lights at `sp` (`attenuated`: some light of the scene has
    /// the lecture's attenuation; `g`: the group's number, for the spot profiles).
    #[inline(always)]
    fn importance(
        &self,
        lights: &[Light],
        sp: &ShadingPoint,
        attenuated: bool,
        g: usize,
    ) -> [f32; 4] {
        let ld = |a: &[f32; 4]| F4::load(a);
        let k = ld(&self.k);
        let to = [
            ld(&self.origin[0]).add(k.mul(F4::splat(sp.p.x))),
            ld(&self.origin[1]).add(k.mul(F4::splat(sp.p.y))),
            ld(&self.origin[2]).add(k.mul(F4::splat(sp.p.z))),
        ];
        let dot = |a: &[[f32; 4]; 3]| {
            ld(&a[0])
                .mul(to[0])
                .add(ld(&a[1]).mul(to[1]))
                .add(ld(&a[2]).mul(to[2]))
        };
        let d2 = to[0].mul(to[0]).add(to[1].mul(to[1])).add(to[2].mul(to[2]));
        let d = d2.sqrt();
        let h = F4::splat(sp.n.x)
            .mul(to[0])
            .add(F4::splat(sp.n.y).mul(to[1]))
            .add(F4::splat(sp.n.z).mul(to[2]));
        // importance = scale · (h / d) / den, as scale · h / (d · den): one division on the
        // path from the square root to the sum.
        let h = if sp.reflect_only { h } else { h.abs() };
        let zero = F4::splat(0.0);
        let one = F4::splat(1.0);
        let cosine = ld(&self.cosine).gt_mask(zero);
        let mut den = d2.mul(ld(&self.s)).max_keep(ld(&self.c));
        if attenuated {
            let a = ld(&self.att[0])
                .add(ld(&self.att[1]).mul(d))
                .add(ld(&self.att[2]).mul(d2));
            den = den.mul(a.max_keep(one));
        }
        let mut v = ld(&self.scale)
            .mul(F4::select(cosine, h, one))
            .div(F4::select(cosine, d, one).mul(den));
        // Spot lights: the cosine of the direction leaving the light with the axis.
        let c = dot(&self.axis).neg().div(d);
        let penumbra = self.spots & c.ge(ld(&self.cos_cutoff)) & !c.ge(ld(&self.cos_beam));
        if penumbra != 0 {
            let (ca, mut va) = (c.to_array(), v.to_array());
            for j in 0..4 {
                if penumbra >> j & 1 != 0 {
                    if let Light::Spot(l, _) = &lights[4 * g + j] {
                        va[j] *= spot_profile(l.profile, ca[j]);
                    }
                }
            }
            v = F4::load(&va);
        }
        // 0 outside a spot's cone, behind a one-sided planar light, for a shape below a
        // reflecting surface's horizon, and where the importance is not positive and finite
        // (masks combined by `select(m1, m2, 0)` = m1 ∧ m2).
        v = F4::select(c.lt_mask(ld(&self.cos_cutoff)), zero, v);
        v = F4::select(ld(&self.back_at).le_mask(dot(&self.back)), zero, v);
        if sp.reflect_only {
            let below = F4::select(h.lt_mask(zero), ld(&self.horizon).lt_mask(h.mul(h)), zero);
            v = F4::select(below, zero, v);
        }
        let ok = F4::select(v.gt_mask(zero), F4::splat(f32::INFINITY).gt_mask(v), zero);
        F4::select(ok, v, zero).to_array()
    }
}

/// A spot light's profile at `c` = cos of the angle from its axis, inside its cone and (for
/// Mitsuba's profile) outside its beam width.
#[inline(never)]
fn spot_profile(profile: SpotProfile, c: f32) -> f32 {
    match profile {
        SpotProfile::Power(k) => c.max(0.0).powf(k),
        SpotProfile::Linear { beam, cutoff, .. } => {
            let x = c.clamp(-1.0, 1.0).acos();
            ((cutoff - x) / (cutoff - beam)).clamp(0.0, 1.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::color::Rgb;
    use crate::light::{Components, DistantLight, Environment, Falloff, PointLight, SpotLight};
    use crate::material::Material;
    use crate::math::Transform;
    use crate::sampling::Pcg32;
    use crate::scene::{Scene, SceneBuilder};
    use crate::shape::{Parallelogram, Shape};
    use crate::texture::Texture;

    /// Seven lights of every kind the importance formula covers (two groups of lanes).
    fn scene() -> Scene {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
        let em = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::splat(4.0)),
            two_sided: false,
        });
        let v = Vec3::new(1.2, 0.3, 0.5).normalize() * 1.4;
        let w = v.cross(Vec3::new(0.1, 1.0, -0.2)).normalize() * 0.9;
        let q = Parallelogram::new(Point3::new(-0.6, -0.4, 2.0), v, w).unwrap();
        b.add_shape(Shape::Parallelogram(q), m, Some(em));
        let c = Components::from_intensity(Rgb::splat(1.0));
        let point = |position, falloff| PointLight {
            position,
            intensity: Rgb::new(5.0, 4.0, 3.0),
            spectrum: None,
            falloff,
        };
        b.add_light(Light::Point(
            point(Point3::new(1.0, 2.0, 0.5), Falloff::INVERSE_SQUARE),
            c,
        ));
        b.add_light(Light::Point(
            point(
                Point3::new(-1.5, 0.5, 1.0),
                Falloff {
                    radius: 0.0,
                    attenuation: Some([0.5, 0.3, 0.2]),
                },
            ),
            c,
        ));
        let spot = |position, axis: Vec3, profile, falloff| SpotLight {
            position,
            axis: axis.normalize(),
            intensity: Rgb::splat(20.0),
            spectrum: None,
            cos_cutoff: 0.8,
            profile,
            falloff,
            pattern: None,
        };
        b.add_light(Light::Spot(
            spot(
                Point3::new(-1.0, 0.0, 3.0),
                Vec3::new(0.1, 0.0, -1.0),
                SpotProfile::linear(0.95, 0.8),
                Falloff::INVERSE_SQUARE,
            ),
            c,
        ));
        b.add_light(Light::Spot(
            spot(
                Point3::new(1.0, -1.0, 2.5),
                Vec3::new(-0.3, 0.2, -1.0),
                SpotProfile::Power(3.0),
                Falloff {
                    radius: 2.0,
                    attenuation: None,
                },
            ),
            c,
        ));
        b.add_light(Light::Distant(
            DistantLight {
                direction: Vec3::new(0.2, -0.3, -1.0).normalize(),
                irradiance: Rgb::splat(1.5),
                spectrum: None,
            },
            c,
        ));
        b.add_light(Light::Environment(Environment::new(
            Texture::Uniform(Rgb::splat(0.3)),
            Transform::IDENTITY,
        )));
        b.build(AccelKind::None)
    }

    /// The importance as it was computed light by light before the lanes (the module's
    /// definition, written plainly).
    fn reference(s: &LightSelector, lights: &[Light], i: usize, sp: &ShadingPoint) -> f32 {
        let cos = |w: Vec3| {
            let c = sp.n.dot(w);
            if sp.reflect_only {
                c
            } else {
                c.abs()
            }
        };
        let v = match s.bounds[i] {
            Bound::Exact => match &lights[i] {
                Light::Point(l, _) => {
                    let to = l.position - sp.p;
                    let d = to.norm();
                    l.intensity.average() * l.falloff.scale(d) * cos(to / d)
                }
                Light::Spot(l, _) => {
                    let to = l.position - sp.p;
                    let d = to.norm();
                    let wi = to / d;
                    l.intensity.average() * l.falloff.scale(d) * l.profile(-wi) * cos(wi)
                }
                Light::Distant(l, _) => l.irradiance.average() * cos(-l.direction),
                _ => 0.0,
            },
            Bound::Infinite(e) => e,
            Bound::Shape {
                centre,
                radius2,
                axis,
                planar,
                two_sided,
                phi,
            } => {
                let to = centre - sp.p;
                let d2 = to.squared_norm();
                let h = sp.n.dot(to);
                if (planar && !two_sided && axis.dot(to) >= 0.0)
                    || (sp.reflect_only && h < 0.0 && h * h > radius2)
                {
                    0.0
                } else {
                    phi / d2.max(radius2)
                }
            }
        };
        if v > 0.0 && v.is_finite() {
            v
        } else {
            0.0
        }
    }

    /// Four lights at a time give each light's importance as the plain definition does, up to
    /// rounding, at random points (both sides of every light, inside and outside the spots'
    /// cones and beams).
    #[test]
    fn lanes_compute_the_importance_of_every_light() {
        let scene = scene();
        let (s, lights) = (&scene.light_selector, &scene.lights[..]);
        assert_eq!(lights.len(), 7);
        assert_eq!(s.lanes.len(), 2);
        let mut rng = Pcg32::new(7, 11);
        let (mut positive, mut penumbra) = (0, 0);
        for k in 0..20_000 {
            let mut r = || rng.next_f32();
            let p = Point3::new(6.0 * r() - 3.0, 6.0 * r() - 3.0, 5.0 * r() - 2.0);
            let n = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
            let sp = ShadingPoint {
                p,
                n,
                reflect_only: k % 3 != 0,
            };
            let (w, sum) = s.importances(lights, &sp);
            let mut total = 0.0;
            for (i, &wi) in w.iter().enumerate() {
                if i >= lights.len() {
                    assert_eq!(wi, 0.0);
                    continue;
                }
                total += wi;
                let want = reference(s, lights, i, &sp);
                // (The cosines cancel differently in the two forms when small, and a spot's
                // profile magnifies the rounding of its cosine near the cut-off.)
                let profile_ulps = match &lights[i] {
                    Light::Spot(l, _) => {
                        let to = l.position - p;
                        l.intensity.average() * l.falloff.scale(to.norm()) * 1e-5
                    }
                    _ => 0.0,
                };
                assert!(
                    (wi - want).abs() <= 1e-5 * want.max(wi) + 1e-6 + profile_ulps,
                    "light {i} at {sp:?}: {wi} vs {want}"
                );
                positive += usize::from(wi > 0.0);
                if let Light::Spot(l, _) = &lights[i] {
                    let c = -(l.position - p).normalize().dot(l.axis);
                    penumbra += usize::from(c > l.cos_cutoff && c < 0.95);
                }
            }
            assert!((sum - total).abs() <= 1e-6 * total, "{sum} vs {total}");
            // `pmf` reads the same numbers `pick` does.
            if sum > 0.0 {
                for i in 0..lights.len() {
                    assert_eq!(s.pmf(lights, &sp, i), w[i] / sum);
                }
            }
        }
        assert!(positive > 20_000 && penumbra > 100, "{positive} {penumbra}");
    }

    /// Emissive shapes alone: chosen in proportion to their powers (L·A, doubled when
    /// two-sided) where those differ, never where the power is 0, with the probability `pmf`
    /// recomputes and the number rescaled uniformly within each share; uniformly (the same
    /// numbers as before) where the powers are equal.
    #[test]
    fn emissive_shapes_are_chosen_by_power() {
        let build = |emitters: &[(f32, f32, bool)]| {
            let mut b = SceneBuilder::new();
            let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
            for (k, &(l, side, two_sided)) in emitters.iter().enumerate() {
                let em = b.add_emission(Emission {
                    radiance: Texture::Uniform(Rgb::new(l, 0.5 * l, 1.5 * l)),
                    two_sided,
                });
                let q = Parallelogram::new(
                    Point3::new(k as f32 * 3.0, 0.0, 2.0),
                    Vec3::X * side,
                    Vec3::Y * side,
                )
                .unwrap();
                b.add_shape(Shape::Parallelogram(q), m, Some(em));
            }
            b.build(AccelKind::None)
        };
        // Powers 1·4, 3·1, 0 and 2·1·2 (two-sided): shares 4/11, 3/11, 0, 4/11.
        let scene = build(&[
            (1.0, 2.0, false),
            (3.0, 1.0, false),
            (0.0, 1.0, false),
            (2.0, 1.0, true),
        ]);
        let (s, lights) = (&scene.light_selector, &scene.lights[..]);
        assert!(s.is_by_power() && !s.is_uniform());
        let want = [4.0 / 11.0, 3.0 / 11.0, 0.0, 4.0 / 11.0];
        let sp = ShadingPoint::at(Point3::ORIGIN);
        let sweep = 110_000;
        let mut count = [0usize; 4];
        let mut rescaled = [[0usize; 10]; 4];
        for k in 0..sweep {
            let u = (k as f32 + 0.5) / sweep as f32;
            let (i, pdf, v) = s.pick(lights, &sp, u).expect("a light");
            assert_eq!(pdf, s.pmf(lights, &sp, i));
            assert!((pdf - want[i]).abs() < 1e-6, "light {i}: {pdf}");
            assert!((0.0..1.0).contains(&v));
            count[i] += 1;
            rescaled[i][(v * 10.0) as usize] += 1;
        }
        for i in 0..4 {
            let n = count[i] as f32;
            assert!((n / sweep as f32 - want[i]).abs() < 1e-4, "light {i}: {n}");
            for bin in rescaled[i] {
                assert!(
                    (bin as f32 - n / 10.0).abs() <= 1.0,
                    "light {i}: {:?}",
                    rescaled[i]
                );
            }
        }
        assert_eq!(s.pmf(lights, &sp, 2), 0.0);
        // Equal powers: the uniform choice.
        let equal = build(&[(2.0, 1.0, false), (0.5, 2.0, false)]);
        let s = &equal.light_selector;
        assert!(s.is_uniform());
        assert_eq!(s.pick(&equal.lights, &sp, 0.75), Some((1, 0.5, 0.5)));
    }
}
