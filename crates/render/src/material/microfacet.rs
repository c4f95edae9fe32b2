//! Microfacet normal distributions (Beckmann, GGX) with Smith shadowing-masking.
//!
//! Directions are in the local shading frame (+z is the macro normal). `alpha` is the
//! roughness: the RMS slope for Beckmann, the width of the Trowbridge–Reitz lobe for GGX.
//! GGX samples the distribution of visible normals (Heitz 2018); Beckmann samples D(m)·cos θm.
//! GGX's D, G1 and sample are repeated on sixteen lanes by the path tracer
//! (`integrator/path/microfacet_lanes.rs`) and by the rough coating's table (`plastic.rs`):
//! change all three.

use crate::math::{Vec3, PI};

/// Which normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Beckmann (Gaussian slopes).
    Beckmann,
    /// GGX / Trowbridge–Reitz.
    Ggx,
}

/// An isotropic microfacet distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// The distribution.
    pub dist: Distribution,
    /// Roughness α (clamped away from 0).
    pub alpha: f32,
}

impl Microfacet {
    /// A distribution with roughness `alpha` (clamped to ≥ 1e-4).
    pub fn new(dist: Distribution, alpha: f32) -> Self {
        Self {
            dist,
            alpha: alpha.max(1e-4),
        }
    }

    /// The density of normals D(m) (per unit solid angle of m, projected: ∫D(m) cos θm dm = 1).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        let ct = m.z;
        if ct <= 0.0 {
            return 0.0;
        }
        let ct2 = ct * ct;
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
                // Walter et al. 2007's rational approximation of the exact Beckmann term.
                let a = 1.0 / (self.alpha * tan);
                if a >= 1.6 {
                    1.0
                } else {
                    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
                }
            }
            Distribution::Ggx => {
                // 2 / (1 + √(1 + α² tan²θ)), times cos θ above and below: one square root
                // and one division (0 at grazing, 1 at normal incidence up to rounding).
                let a2 = self.alpha * self.alpha;
                (2.0 * ct) / (ct + (a2 + (1.0 - a2) * (ct * ct)).sqrt())
            }
        }
    }

    /// Separable shadowing-masking G(wi, wo, m) = G1(wi, m)·G1(wo, m).
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.g1(wi, m) * self.g1(wo, m)
    }

    /// Samples a microfacet normal seen from `wi` (z > 0).
    #[inline]
    pub fn sample(&self, wi: Vec3, u: [f32; 2]) -> Vec3 {
        self.sampler(wi)
            .normal(self.radial(u[0]), NormalSampler::angular(u[1]))
    }

    /// [`Microfacet::sample`]'s part that depends on the direction alone: to sample many
    /// normals seen from one direction (the same normals, bit for bit).
    #[inline]
    pub(crate) fn sampler(&self, wi: Vec3) -> NormalSampler {
        match self.dist {
            Distribution::Ggx => {
                let alpha = self.alpha;
                // Stretch the view direction to the hemisphere configuration.
                let vh = Vec3::new(alpha * wi.x, alpha * wi.y, wi.z).normalize();
                let lensq = vh.x * vh.x + vh.y * vh.y;
                let t1 = if lensq > 0.0 {
                    Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
                } else {
                    Vec3::X
                };
                let t2 = vh.cross(t1);
                NormalSampler::Ggx {
                    alpha,
                    vh,
                    t1,
                    t2,
                    s: 0.5 * (1.0 + vh.z),
                }
            }
            Distribution::Beckmann => NormalSampler::Beckmann,
        }
    }

    /// [`Microfacet::sample`]'s part that depends on the first number alone: the radius
    /// √u₀ on the projected disk (GGX), or (cos θm, sin θm) (Beckmann).
    #[inline]
    pub(crate) fn radial(&self, u0: f32) -> (f32, f32) {
        match self.dist {
            Distribution::Ggx => (u0.sqrt(), 0.0),
            Distribution::Beckmann => {
                let tan2 = -self.alpha * self.alpha * (1.0 - u0).ln();
                let ct = 1.0 / (1.0 + tan2).sqrt();
                (ct, (1.0 - ct * ct).max(0.0).sqrt())
            }
        }
    }

    /// The density of [`Microfacet::sample`] for normal `m` seen from `wi` (z > 0).
    #[inline]
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        match self.dist {
            Distribution::Ggx => {
                if wi.z <= 0.0 {
                    return 0.0;
                }
                self.g1(wi, m) * wi.dot(m).max(0.0) * self.d(m) / wi.z
            }
            Distribution::Beckmann => self.d(m) * m.z.max(0.0),
        }
    }

    /// [`Microfacet::pdf`] given `d` = D(m) and `g1` = G1(wi, m), already computed: the same
    /// number, bit for bit.
    #[inline]
    pub fn pdf_with(&self, wi: Vec3, m: Vec3, d: f32, g1: f32) -> f32 {
        match self.dist {
            Distribution::Ggx => {
                if wi.z <= 0.0 {
                    return 0.0;
                }
                g1 * wi.dot(m).max(0.0) * d / wi.z
            }
            Distribution::Beckmann => d * m.z.max(0.0),
        }
    }
}

/// [`Microfacet::sample`] split by what its parts depend on ([`Microfacet::sampler`]): the
/// direction's frame for GGX (Heitz 2018, "Sampling the GGX Distribution of Visible Normals");
/// nothing for Beckmann, whose normals do not depend on the direction.
#[derive(Clone, Copy, Debug)]
pub(crate) enum NormalSampler {
    /// GGX's visible normals seen from a direction.
    Ggx {
        /// Roughness.
        alpha: f32,
        /// The stretched direction.
        vh: Vec3,
        /// A frame around it.
        t1: Vec3,
        /// The frame's third axis.
        t2: Vec3,
        /// The share of the projected disk's half that the direction sees.
        s: f32,
    },
    /// Beckmann: D(m)·cos θm.
    Beckmann,
}

impl NormalSampler {
    /// The part of a sample that depends on the second number alone: (cos φ, sin φ).
    #[inline]
    pub(crate) fn angular(u1: f32) -> (f32, f32) {
        let (sin, cos) = crate::sampling::warp::sin_cos_turn(u1);
        (cos, sin)
    }

    /// The normal given [`Microfacet::radial`] and [`NormalSampler::angular`].
    #[inline]
    pub(crate) fn normal(&self, radial: (f32, f32), (cos_phi, sin_phi): (f32, f32)) -> Vec3 {
        match *self {
            NormalSampler::Ggx {
                alpha,
                vh,
                t1,
                t2,
                s,
            } => {
                // Sample the projected area.
                let r = radial.0;
                let p1 = r * cos_phi;
                let mut p2 = r * sin_phi;
                p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
                let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                // Unstretch.
                Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-6)).normalize()
            }
            NormalSampler::Beckmann => {
                let (ct, st) = radial;
                Vec3::new(st * cos_phi, st * sin_phi, ct)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::warp::square_to_uniform_hemisphere;

    /// ∫ D(m) cos θm dωm = 1, by quadrature over the hemisphere.
    #[test]
    fn distributions_are_normalised() {
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            for alpha in [0.1f32, 0.3, 0.8] {
                let n = 1024;
                let mut sum = 0f64;
                for i in 0..n {
                    for j in 0..n {
                        let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                        let m = square_to_uniform_hemisphere(u);
                        sum += (Microfacet::new(dist, alpha).d(m) * m.z) as f64
                            * 2.0
                            * std::f64::consts::PI;
                    }
                }
                let mean = sum / (n * n) as f64;
                assert!((mean - 1.0).abs() < 0.02, "{dist:?} α = {alpha}: {mean}");
            }
        }
    }

    /// The projected area of visible normals equals the projected area of the macro surface:
    /// ∫ G1(w, m) max(0, w·m) D(m) dωm = w.z.
    #[test]
    fn visible_normals_integrate_to_the_projected_area() {
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            let mf = Microfacet::new(dist, 0.4);
            let w = Vec3::new(0.6, 0.0, 0.8);
            let n = 1024;
            let mut sum = 0f64;
            for i in 0..n {
                for j in 0..n {
                    let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                    let m = square_to_uniform_hemisphere(u);
                    sum += (mf.g1(w, m) * w.dot(m).max(0.0) * mf.d(m)) as f64
                        * 2.0
                        * std::f64::consts::PI;
                }
            }
            let v = sum / (n * n) as f64;
            assert!((v - 0.8).abs() < 0.02, "{dist:?}: {v}");
        }
    }
}
