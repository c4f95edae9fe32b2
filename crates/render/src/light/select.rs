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
//!   still sampled, as every single light is;
//! - an emissive shape: its power per side over π (L·A, comparable with the irradiances above)
//!   over the squared distance to its centre (at least its bounding sphere's squared radius),
//!   and 0 where it cannot reach the point: a one-sided planar light seen from behind, a light
//!   whose bounding sphere lies below a reflecting surface's tangent plane. No square root: the
//!   cosine bounds of pbrt-v4's `LightBounds::Importance` (tried first) cost about 20 ns per
//!   light and vertex, which on a Cornell box with three rectangle lights made the frame 56 %
//!   slower for 12 % less variance.
//!
//! The cosine at the point is taken on the side of the outgoing direction when the BSDF only
//! reflects, and on either side otherwise. A light of importance 0 is never sampled; that costs
//! no bias because multiple importance sampling then gives BSDF sampling its full weight. With
//! more lights, one light, or emissive shapes alone, the choice is uniform. When a single light
//! has any importance (the others being constant skies), it is picked without evaluating it:
//! where its importance is 0 it cannot contribute either. [`LightSelector::pmf`] recomputes the
//! probability with which the vertex a path left picked a light, for the MIS weights of emitters
//! that BSDF sampling finds.

use super::{AreaShape, Emission, Light};
use crate::geometry::Geometry;
use crate::math::{Bounds3, Point3, Vec3, PI};
use crate::sampling::sampler::ONE_MINUS_EPSILON;

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

    /// The cosine the importance uses for the unit direction `w` to a light: signed on the side
    /// of `n` when the BSDF only reflects, its absolute value otherwise.
    #[inline(always)]
    fn cos(&self, w: Vec3) -> f32 {
        let c = self.n.dot(w);
        if self.reflect_only {
            c
        } else {
            c.abs()
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

/// The light selection of a scene: importance at the shading point for few lights, uniform for
/// many.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightSelector {
    /// One bound per light; empty for the uniform choice.
    bounds: Vec<Bound>,
    /// The one light with any importance when every other one has none anywhere (constant
    /// skies beside it): it is chosen without evaluating the importances. Where its own
    /// importance is 0 it can contribute nothing either (seen from behind, or below a
    /// reflecting surface's horizon), neither by a light sample nor by BSDF sampling.
    sole: Option<usize>,
}

impl LightSelector {
    /// The selector for `lights` (with the emissions and geometry of their shapes).
    pub fn new(lights: &[Light], emissions: &[Emission], geometry: &Geometry) -> Self {
        // Emissive shapes alone are chosen uniformly: their importance did not pay for its
        // cost (Cornell boxes with two and three rectangle lights: 1 % and 25 % less variance
        // for 25 % and 37 % more time).
        let shapes_only = lights.iter().all(|l| matches!(l, Light::Area(_)));
        if lights.len() <= 1 || lights.len() > MAX_IMPORTANCE_LIGHTS || shapes_only {
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
        Self { bounds, sole }
    }

    /// True when lights are chosen uniformly.
    pub fn is_uniform(&self) -> bool {
        self.bounds.is_empty()
    }

    /// The importance of light `i` at `sp` (see the module's documentation).
    #[inline(always)]
    fn importance(&self, lights: &[Light], i: usize, sp: &ShadingPoint) -> f32 {
        let v = match self.bounds[i] {
            Bound::Exact => match &lights[i] {
                Light::Point(l, _) => {
                    let to = l.position - sp.p;
                    let d = to.norm();
                    l.intensity.average() * l.falloff.scale(d) * sp.cos(to / d)
                }
                Light::Spot(l, _) => {
                    let to = l.position - sp.p;
                    let d = to.norm();
                    let wi = to / d;
                    l.intensity.average() * l.falloff.scale(d) * l.profile(-wi) * sp.cos(wi)
                }
                Light::Distant(l, _) => l.irradiance.average() * sp.cos(-l.direction),
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
                // A one-sided planar light seen from behind sends nothing; nor does a light
                // whose bounding sphere lies below a reflecting surface's tangent plane.
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
        self.pick_by_importance(lights, sp, u)
    }

    /// [`LightSelector::pick`] by importance (kept out of line: the uniform choice of the
    /// common one-light scene stays small where it is inlined).
    #[inline(never)]
    fn pick_by_importance(
        &self,
        lights: &[Light],
        sp: &ShadingPoint,
        u: f32,
    ) -> Option<(usize, f32, f32)> {
        let n = lights.len();
        let mut w = [0f32; MAX_IMPORTANCE_LIGHTS];
        let mut sum = 0.0;
        for (i, wi) in w.iter_mut().enumerate().take(n) {
            *wi = self.importance(lights, i, sp);
            sum += *wi;
        }
        if !(sum > 0.0 && sum.is_finite()) {
            return None;
        }
        let x = u * sum;
        let mut acc = 0.0;
        let mut last = 0;
        for (i, &wi) in w.iter().enumerate().take(n) {
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

    /// The probability with which [`LightSelector::pick`] chooses light `i` at `sp`.
    #[inline(always)]
    pub fn pmf(&self, lights: &[Light], sp: &ShadingPoint, i: usize) -> f32 {
        let n = lights.len();
        if self.bounds.len() != n {
            return if n == 0 { 0.0 } else { 1.0 / n as f32 };
        }
        if let Some(k) = self.sole {
            return if i == k { 1.0 } else { 0.0 };
        }
        self.pmf_by_importance(lights, sp, i)
    }

    /// [`LightSelector::pmf`] by importance (out of line, as [`LightSelector::pick`]'s).
    #[inline(never)]
    fn pmf_by_importance(&self, lights: &[Light], sp: &ShadingPoint, i: usize) -> f32 {
        let n = lights.len();
        let mut sum = 0.0;
        let mut wi = 0.0;
        for j in 0..n {
            let w = self.importance(lights, j, sp);
            sum += w;
            if j == i {
                wi = w;
            }
        }
        if sum > 0.0 && sum.is_finite() {
            wi / sum
        } else {
            0.0
        }
    }
}
