//! Microfacet normal distributions (Beckmann, GGX) with Smith shadowing-masking.
//!
//! Directions are in the local shading frame (+z is the macro normal). `alpha` is the
//! roughness: the RMS slope for Beckmann, the width of the Trowbridge–Reitz lobe for GGX;
//! anisotropic distributions have one along each tangent of the frame (`alpha` along x,
//! `alpha_v` along y: Mitsuba's `alpha_u`, `alpha_v`), and are stretched versions of the
//! isotropic one of roughness 1, whose formulas they take with the roughness along a
//! direction's azimuth.
//! Both sample the distribution of visible normals: GGX by Heitz 2018's projected-disk
//! construction, Beckmann by inverting the visible slopes' distribution (Heitz and d'Eon 2014)
//! by Newton's method on the slope, kept in a bracket by bisection (Jakob 2014 iterates in the
//! error function's range instead), as Mitsuba does by default. Beckmann's masking term is Smith's exact Λ (through the error function), so that
//! the density of its visible normals integrates to 1.
//! GGX's D, G1 and sample are repeated on sixteen lanes by the path tracer
//! (`integrator/path/microfacet_lanes.rs`) and by the rough coating's table (`plastic.rs`):
//! change all three.

use crate::math::special::{beckmann_lambda, erf_inv, erfc_positive, erfc_scaled, FRAC_1_SQRT_PI};
use crate::math::{Vec3, PI};

/// Which normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Beckmann (Gaussian slopes).
    Beckmann,
    /// GGX / Trowbridge–Reitz.
    Ggx,
}

/// A microfacet distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// The distribution.
    pub dist: Distribution,
    /// Roughness α (clamped away from 0); along the frame's x axis when anisotropic.
    pub alpha: f32,
    /// Roughness along the frame's y axis: `alpha` when isotropic.
    pub alpha_v: f32,
}

impl Microfacet {
    /// An isotropic distribution with roughness `alpha` (clamped to ≥ 1e-4).
    pub fn new(dist: Distribution, alpha: f32) -> Self {
        let alpha = alpha.max(1e-4);
        Self {
            dist,
            alpha,
            alpha_v: alpha,
        }
    }

    /// A distribution with roughness `alpha_u` along the shading frame's x axis (the surface's
    /// ∂p/∂u) and `alpha_v` along its y axis (each clamped to ≥ 1e-4).
    pub fn anisotropic(dist: Distribution, alpha_u: f32, alpha_v: f32) -> Self {
        Self {
            dist,
            alpha: alpha_u.max(1e-4),
            alpha_v: alpha_v.max(1e-4),
        }
    }

    /// True when the roughness is the same in every direction.
    #[inline]
    pub fn is_isotropic(&self) -> bool {
        self.alpha == self.alpha_v
    }

    /// The roughness along the azimuth of `w`: √(αu²·cos²φ + αv²·sin²φ).
    #[inline]
    fn alpha_towards(&self, w: Vec3) -> f32 {
        let r2 = w.x * w.x + w.y * w.y;
        if self.is_isotropic() || !(r2 > 0.0) {
            return self.alpha;
        }
        let (ax, ay) = (self.alpha * w.x, self.alpha_v * w.y);
        ((ax * ax + ay * ay) / r2).sqrt()
    }

    /// The density of normals D(m) (per unit solid angle of m, projected: ∫D(m) cos θm dm = 1).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        let ct = m.z;
        if ct <= 0.0 {
            return 0.0;
        }
        let ct2 = ct * ct;
        if !self.is_isotropic() {
            return self.d_anisotropic(m);
        }
        let a2 = self.alpha * self.alpha;
        let r = match self.dist {
            Distribution::Beckmann => {
                let tan2 = (1.0 - ct2) / ct2;
                (-tan2 / a2).exp() / (PI * a2 * ct2 * ct2)
            }
            Distribution::Ggx => {
                // α² / (π (cos²θ (α² − 1) + 1)²): 1 / (π α² cos⁴θ (1 + tan²θ / α²)²) with
                // one division.
                let k = ct2 * (a2 - 1.0) + 1.0;
                a2 / (PI * k * k)
            }
        };
        if r * ct > 1e-20 {
            r
        } else {
            0.0
        }
    }

    /// [`Microfacet::d`] of an anisotropic distribution (`m.z` > 0).
    fn d_anisotropic(&self, m: Vec3) -> f32 {
        let (ax, ay) = (self.alpha, self.alpha_v);
        let (x, y) = (m.x / ax, m.y / ay);
        let ct2 = m.z * m.z;
        let r = match self.dist {
            Distribution::Beckmann => (-(x * x + y * y) / ct2).exp() / (PI * ax * ay * ct2 * ct2),
            Distribution::Ggx => {
                let k = x * x + y * y + ct2;
                1.0 / (PI * ax * ay * k * k)
            }
        };
        if r * m.z > 1e-20 {
            r
        } else {
            0.0
        }
    }

    /// Smith's masking G1(w, m): the fraction of microfacets with normal m visible from w.
    #[inline]
    pub fn g1(&self, w: Vec3, m: Vec3) -> f32 {
        if w.dot(m) * w.z <= 0.0 {
            return 0.0;
        }
        self.g1_visible(w)
    }

    /// [`Microfacet::g1`] for a normal `m` that `w` sees (w·m and w.z of the same sign): a
    /// function of `w` alone.
    #[inline]
    pub(crate) fn g1_visible(&self, w: Vec3) -> f32 {
        let ct = w.z.abs();
        match self.dist {
            Distribution::Beckmann => {
                let tan = (1.0 - ct * ct).max(0.0).sqrt() / ct;
                if tan == 0.0 {
                    return 1.0;
                }
                // Smith's exact term, not Walter et al. 2007's rational approximation of it
                // (within 0.35 %): the visible normals' density must integrate to 1.
                1.0 / (1.0 + beckmann_lambda(1.0 / (self.alpha_towards(w) * tan)))
            }
            Distribution::Ggx => {
                // 2 / (1 + √(1 + α² tan²θ)), times cos θ above and below: one square root
                // and one division (0 at grazing, 1 at normal incidence up to rounding).
                let a = self.alpha_towards(w);
                let a2 = a * a;
                (2.0 * ct) / (ct + (a2 + (1.0 - a2) * (ct * ct)).sqrt())
            }
        }
    }

    /// Separable shadowing-masking G(wi, wo, m) = G1(wi, m)·G1(wo, m).
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.g1(wi, m) * self.g1(wo, m)
    }

    /// Samples a microfacet normal seen from `wi` (z > 0): the distribution of the normals
    /// `wi` sees, G1(wi, m)·max(0, wi·m)·D(m)/cos θi.
    #[inline]
    pub fn sample(&self, wi: Vec3, u: [f32; 2]) -> Vec3 {
        let sampler = self.sampler(wi);
        sampler.normal(sampler.radial(u[0]), self.angular(u[1]))
    }

    /// [`Microfacet::sample`]'s part that depends on the direction alone: to sample many
    /// normals seen from one direction (the same normals, bit for bit).
    #[inline]
    pub(crate) fn sampler(&self, wi: Vec3) -> NormalSampler {
        let (alpha, alpha_v) = (self.alpha, self.alpha_v);
        match self.dist {
            Distribution::Ggx => {
                // Stretch the view direction to the hemisphere configuration.
                let vh = Vec3::new(alpha * wi.x, alpha_v * wi.y, wi.z).normalize();
                let lensq = vh.x * vh.x + vh.y * vh.y;
                let t1 = if lensq > 0.0 {
                    Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
                } else {
                    Vec3::X
                };
                let t2 = vh.cross(t1);
                NormalSampler::Ggx {
                    alpha,
                    alpha_v,
                    vh,
                    t1,
                    t2,
                    s: 0.5 * (1.0 + vh.z),
                }
            }
            Distribution::Beckmann => {
                // The direction stretched to unit roughness: its azimuth and tan θ.
                let (x, y) = (alpha * wi.x, alpha_v * wi.y);
                let r = (x * x + y * y).sqrt();
                let (cos_phi, sin_phi) = if r > 0.0 { (x / r, y / r) } else { (1.0, 0.0) };
                let tan = r / wi.z;
                NormalSampler::Beckmann {
                    alpha,
                    alpha_v,
                    cos_phi,
                    sin_phi,
                    // (Near normal incidence the marginal is erf's own: sampled directly.)
                    tan: if tan < 1e-4 || !tan.is_finite() {
                        0.0
                    } else {
                        tan
                    },
                }
            }
        }
    }

    /// [`Microfacet::sample`]'s part that depends on the second number alone: (cos φ, sin φ)
    /// of the azimuth 2πu₁ on GGX's projected disk, or the unit-roughness slope across the
    /// direction's azimuth for Beckmann, erf⁻¹(2u₁ − 1) (and 0).
    #[inline]
    pub(crate) fn angular(&self, u1: f32) -> (f32, f32) {
        match self.dist {
            Distribution::Ggx => {
                let (sin, cos) = crate::sampling::warp::sin_cos_turn(u1);
                (cos, sin)
            }
            Distribution::Beckmann => (erf_inv(2.0 * u1.max(1e-6) - 1.0), 0.0),
        }
    }

    /// The density of [`Microfacet::sample`] for normal `m` seen from `wi` (z > 0):
    /// G1(wi, m)·max(0, wi·m)·D(m)/cos θi.
    #[inline]
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        self.g1(wi, m) * wi.dot(m).max(0.0) * self.d(m) / wi.z
    }

    /// [`Microfacet::pdf`] given `d` = D(m) and `g1` = G1(wi, m), already computed: the same
    /// number, bit for bit.
    #[inline]
    pub fn pdf_with(&self, wi: Vec3, m: Vec3, d: f32, g1: f32) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        g1 * wi.dot(m).max(0.0) * d / wi.z
    }
}

/// Newton steps at most in the inversion of Beckmann's visible slopes (it converges in a
/// few; the bisection that guards it halves the bracket at every step it rejects).
const SLOPE_STEPS: usize = 32;

/// [`Microfacet::sample`] split by what its parts depend on ([`Microfacet::sampler`]): the
/// direction's frame for GGX (Heitz 2018, "Sampling the GGX Distribution of Visible Normals");
/// for Beckmann, the direction's azimuth and what the inversion of the visible slopes'
/// distribution needs (Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs using
/// the Distribution of Visible Normals"; Jakob 2014, "An Improved Visible Normal Sampling
/// Routine for the Beckmann Distribution").
#[derive(Clone, Copy, Debug)]
pub(crate) enum NormalSampler {
    /// GGX's visible normals seen from a direction.
    Ggx {
        /// Roughness along x.
        alpha: f32,
        /// Roughness along y.
        alpha_v: f32,
        /// The stretched direction.
        vh: Vec3,
        /// A frame around it.
        t1: Vec3,
        /// The frame's third axis.
        t2: Vec3,
        /// The share of the projected disk's half that the direction sees.
        s: f32,
    },
    /// Beckmann's visible normals seen from a direction.
    Beckmann {
        /// Roughness along x.
        alpha: f32,
        /// Roughness along y.
        alpha_v: f32,
        /// The direction's azimuth.
        cos_phi: f32,
        /// The direction's azimuth.
        sin_phi: f32,
        /// tan θ of the direction stretched to unit roughness (0 near normal incidence).
        tan: f32,
    },
}

impl NormalSampler {
    /// The part of a sample that depends on the first number (and the direction): the radius
    /// √u₀ on GGX's projected disk, or the unit-roughness slope along the direction's azimuth
    /// for Beckmann (and 0).
    #[inline]
    pub(crate) fn radial(&self, u0: f32) -> (f32, f32) {
        match *self {
            NormalSampler::Ggx { .. } => (u0.sqrt(), 0.0),
            NormalSampler::Beckmann { tan, .. } => (beckmann_slope(u0, tan), 0.0),
        }
    }

    /// The normal given [`NormalSampler::radial`] and [`Microfacet::angular`].
    #[inline]
    pub(crate) fn normal(&self, radial: (f32, f32), angular: (f32, f32)) -> Vec3 {
        match *self {
            NormalSampler::Ggx {
                alpha,
                alpha_v,
                vh,
                t1,
                t2,
                s,
            } => {
                let (cos_phi, sin_phi) = angular;
                // Sample the projected area.
                let r = radial.0;
                let p1 = r * cos_phi;
                let mut p2 = r * sin_phi;
                p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
                let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                // Unstretch.
                Vec3::new(alpha * nh.x, alpha_v * nh.y, nh.z.max(1e-6)).normalize()
            }
            NormalSampler::Beckmann {
                alpha,
                alpha_v,
                cos_phi,
                sin_phi,
                ..
            } => {
                // The slopes (along, across the azimuth) turned to the direction's azimuth,
                // scaled to the roughness: the normal (−x, −y, 1), normalised.
                let (sx, sy) = (radial.0, angular.0);
                let x = alpha * (cos_phi * sx - sin_phi * sy);
                let y = alpha_v * (sin_phi * sx + cos_phi * sy);
                Vec3::new(-x, -y, 1.0).normalize()
            }
        }
    }
}

/// The unit-roughness Beckmann slope along the azimuth of a direction of `tan` θ (0: normal
/// incidence) that the visible slopes' marginal gives `u`: the density (cot θ − x)·e^(−x²)
/// over x < cot θ, whose distribution function is `norm`·(1 + erf x + tan θ/√π·e^(−x²)) (from 0
/// at −∞ to 1 at cot θ, `norm` normalising it through erf(cot θ)) and whose derivative is
/// `norm`·(2/√π)·e^(−x²)·(1 − x·tan θ). Newton's method from the slope at normal incidence,
/// erf⁻¹(2u − 1), kept inside a bracket by bisection. (Jakob 2014 iterates in erf's range
/// instead, which costs a logarithm more at every step: here a step costs one exponential,
/// shared by erf and the density.)
#[inline]
fn beckmann_slope(u: f32, tan: f32) -> f32 {
    // (u ≥ 10⁻⁶: erf⁻¹(−1) is −∞.)
    let u = u.max(1e-6);
    let x0 = erf_inv(2.0 * u - 1.0);
    if tan == 0.0 {
        return x0;
    }
    let cot = 1.0 / tan;
    let k = tan * FRAC_1_SQRT_PI;
    let norm = 1.0 / (1.0 + (1.0 - erfc_positive(cot)) + k * (-cot * cot).exp());
    // (Below −5 the distribution function is under 10⁻⁶ for any θ: u's floor.)
    let (mut lo, mut hi) = (-5.0f32, cot);
    // The first guess: ln(1 − x·tan θ) − x² to second order in x is the logarithm of a
    // Gaussian of mean −tan θ/(2 + tan²θ) and of 1 + tan²θ/2 times the precision of erf's:
    // its quantile. (One step of Newton's method then suffices at small θ.)
    let mut x = x0 / (1.0 + 0.5 * tan * tan).sqrt() - tan / (2.0 + tan * tan);
    for _ in 0..SLOPE_STEPS {
        if !(x > lo && x < hi) {
            x = 0.5 * (lo + hi);
        }
        let e = (-x * x).exp();
        let c = erfc_scaled(x.abs()) * e;
        // 1 + erf x, without cancellation on the negative side.
        let one_plus_erf = if x < 0.0 { c } else { 2.0 - c };
        let value = norm * (one_plus_erf + k * e) - u;
        if value.abs() < 1e-5 {
            return x;
        }
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let step = value / (norm * (2.0 * FRAC_1_SQRT_PI) * e * (1.0 - x * tan));
        // The step's residual is about |F''|·step²/2, and |F''| is about F'·(2|x| + tan θ):
        // when that is far below the tolerance, the step is the last (unchecked when it stays
        // in the bracket).
        let last = value.abs() * step.abs() * (x.abs() + tan + 1.0) < 1e-6;
        x -= step;
        if last && x > lo && x < hi {
            return x;
        }
    }
    x.clamp(lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::warp::square_to_uniform_hemisphere;
    use std::f64::consts::PI as PI64;

    /// The distributions of the tests: isotropic and anisotropic, both kinds.
    fn distributions() -> Vec<Microfacet> {
        let mut v = Vec::new();
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            for alpha in [0.1f32, 0.3, 0.8] {
                v.push(Microfacet::new(dist, alpha));
            }
            v.push(Microfacet::anisotropic(dist, 0.1, 0.5));
            v.push(Microfacet::anisotropic(dist, 0.7, 0.2));
        }
        v
    }

    /// ∫ f(m) dωm over the hemisphere, by the midpoint rule on 1024² cells of equal area.
    fn over_hemisphere(f: impl Fn(Vec3) -> f32) -> f64 {
        let n = 1024;
        let mut sum = 0f64;
        for i in 0..n {
            for j in 0..n {
                let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                sum += f(square_to_uniform_hemisphere(u)) as f64;
            }
        }
        sum * 2.0 * std::f64::consts::PI / (n * n) as f64
    }

    /// ∫ D(m) cos θm dωm = 1, by quadrature over the hemisphere.
    #[test]
    fn distributions_are_normalised() {
        for mf in distributions() {
            let mean = over_hemisphere(|m| mf.d(m) * m.z);
            assert!((mean - 1.0).abs() < 0.02, "{mf:?}: {mean}");
        }
    }

    /// The projected area of visible normals equals the projected area of the macro surface:
    /// ∫ G1(w, m) max(0, w·m) D(m) dωm = w.z, from directions off the frame's axes.
    #[test]
    fn visible_normals_integrate_to_the_projected_area() {
        for mf in distributions().into_iter().filter(|m| m.alpha_v >= 0.2) {
            for w in [
                Vec3::new(0.6, 0.0, 0.8),
                Vec3::new(0.5, 0.6, 0.39f32.sqrt()),
            ] {
                let v = over_hemisphere(|m| mf.g1(w, m) * w.dot(m).max(0.0) * mf.d(m));
                assert!((v - w.z as f64).abs() < 0.01, "{mf:?} {w:?}: {v}");
            }
        }
    }

    /// Beckmann's slope along the azimuth inverts its marginal distribution: the distribution
    /// function, evaluated in double precision, gives back the number, from normal to grazing
    /// incidence (stretched tan θ from 10⁻³ to 10³), and the slopes grow with it.
    #[test]
    fn beckmann_slopes_invert_their_distribution() {
        let erf = |x: f64| crate::math::special::erf(x as f32) as f64;
        for tan in [1e-3f32, 0.05, 0.1, 0.3, 0.6, 1.0, 3.0, 10.0, 30.0, 1e3] {
            let wi = Vec3::new(tan, 0.0, 1.0).normalize();
            let NormalSampler::Beckmann { tan: t, .. } =
                Microfacet::new(Distribution::Beckmann, 1.0).sampler(wi)
            else {
                unreachable!()
            };
            let (t64, cot) = (tan as f64, 1.0 / tan as f64);
            let norm64 = 1.0 / (1.0 + erf(cot) + t64 / PI64.sqrt() * (-cot * cot).exp());
            let cdf = |x: f64| norm64 * (1.0 + erf(x) + t64 / PI64.sqrt() * (-x * x).exp());
            let mut last = f64::NEG_INFINITY;
            let (low, high) = ([1e-6f32, 1e-5, 1e-4], [0.9999f32, 0.99999, 0.999_999]);
            let middle = (1..1000).map(|i| i as f32 / 1000.0);
            for u in low.into_iter().chain(middle).chain(high) {
                let x = beckmann_slope(u, t) as f64;
                assert!(x.is_finite() && x <= cot + 1e-6, "tan {tan}, u {u}: {x}");
                assert!(x >= last, "tan {tan}, u {u}: not increasing");
                last = x;
                // (Near normal incidence, the marginal at normal incidence.)
                let c = if t == 0.0 {
                    0.5 * (1.0 + erf(x))
                } else {
                    cdf(x)
                };
                assert!((c - u as f64).abs() < 2e-5, "tan {tan}, u {u}: F(x) = {c}");
            }
        }
    }

    /// Beckmann's visible normals from a direction face it, and the normals of a narrow
    /// distribution stay near the macro normal, from any direction.
    #[test]
    fn beckmann_visible_normals_face_the_direction() {
        for alpha in [0.02f32, 0.3, 1.5] {
            let mf = Microfacet::new(Distribution::Beckmann, alpha);
            for th in [0.0f32, 40.0, 80.0, 89.5] {
                let (s, c) = th.to_radians().sin_cos();
                let wi = Vec3::new(s * 0.6, s * 0.8, c);
                for i in 0..64 {
                    for j in 0..64 {
                        let u = [(i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0];
                        let m = mf.sample(wi, u);
                        assert!((m.dot(m) - 1.0).abs() < 1e-5, "{m:?}");
                        assert!(wi.dot(m) >= -1e-6, "α {alpha} θ {th}: {m:?}");
                        assert!(mf.pdf(wi, m) > 0.0 || wi.dot(m) <= 1e-6, "α {alpha} θ {th}");
                        if alpha == 0.02 {
                            assert!(m.z > 0.99, "α {alpha} θ {th}: {m:?}");
                        }
                    }
                }
            }
        }
    }
}
