//! Phong (1975) and Blinn–Phong (1977) reflection.
//!
//! Scene syntax: `phong(kd, ks, n)`, `blinn_phong(kd, ks, n)`.
//!
//! Under the local model (`local`, `direct`, `whitted`) they are the lecture's formulas,
//! I·(k_d (n·l) + k_s (r·v)^n) and I·(k_d (n·l) + k_s (n·h)^n), with no 1/π
//! (scene-language.md §2b). Under the path tracer they are energy-conserving BRDFs:
//! f = k_d/π + k_s·(n+2)/(2π)·cos^n α (α between wi and the mirror direction of wo) for Phong,
//! f = k_d/π + k_s·(n+2)(n+4)/(8π(2^(−n/2)+n))·cos^n θh for Blinn–Phong (the exact
//! normalisation: albedo 1 at normal incidence, less elsewhere), sampled by picking the diffuse
//! lobe or the specular lobe (θ = acos(X^(1/(n+1))) around its axis) in proportion to k_d and
//! k_s.

use super::fresnel::{reflect, reflect_z};
use super::sample::{reflection_sample, specular_probability, LocalSample};
use crate::math::{Frame, Vec3, INV_PI, PI};
use crate::sampling::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::spectrum::SampledSpectrum;

/// Which specular lobe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// (r·v)^n.
    Phong,
    /// (n·h)^n.
    BlinnPhong,
}

/// A Phong-type BRDF at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongBrdf {
    /// The lobe.
    pub lobe: Lobe,
    /// Diffuse coefficient.
    pub kd: SampledSpectrum,
    /// Specular coefficient.
    pub ks: SampledSpectrum,
    /// Exponent.
    pub n: f32,
}

/// A direction around `axis` with cos α = X^(1/(n+1)): pdf (n+1)/(2π) cos^n α.
fn sample_lobe(axis: Vec3, n: f32, u: [f32; 2]) -> Vec3 {
    let c = u[0].powf(1.0 / (n + 1.0));
    let s = (1.0 - c * c).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Frame::from_normal(axis.to_normal()).to_world(Vec3::new(s * phi.cos(), s * phi.sin(), c))
}

/// The normalisation of the Blinn–Phong lobe cos^n θh: (n+2)(n+4) / (8π(2^(−n/2) + n)), which
/// makes the directional albedo exactly 1 at normal incidence, its maximum. (The common
/// approximation (n+8)/(8π) exceeds it, by up to 7.5 % near n = 10, so that the BRDF reflected
/// more than it received.)
fn blinn_phong_norm(n: f32) -> f32 {
    (n + 2.0) * (n + 4.0) / (8.0 * PI * ((-0.5 * n).exp2() + n))
}

fn lobe_pdf(n: f32, cos: f32) -> f32 {
    if cos <= 0.0 {
        0.0
    } else {
        (n + 1.0) * 0.5 * INV_PI * cos.powf(n)
    }
}

impl PhongBrdf {
    fn specular_probability(&self) -> f32 {
        specular_probability(self.kd, self.ks, 0.5)
    }

    /// The specular lobe's value (without k_s) and its sampling density for the pair.
    fn specular(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        match self.lobe {
            Lobe::Phong => {
                let c = reflect_z(wo).dot(wi);
                if c <= 0.0 {
                    return (0.0, 0.0);
                }
                (
                    (self.n + 2.0) * 0.5 * INV_PI * c.powf(self.n),
                    lobe_pdf(self.n, c),
                )
            }
            Lobe::BlinnPhong => {
                let h = (wo + wi).normalize();
                let (ch, oh) = (h.z, wo.dot(h));
                if ch <= 0.0 || oh <= 0.0 {
                    return (0.0, 0.0);
                }
                (
                    blinn_phong_norm(self.n) * ch.powf(self.n),
                    lobe_pdf(self.n, ch) / (4.0 * oh),
                )
            }
        }
    }

    /// f·cos θi of the normalised BRDF.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let (s, _) = self.specular(wo, wi);
        (self.kd * INV_PI + self.ks * s) * wi.z
    }

    /// The density of [`PhongBrdf::sample`].
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability();
        ps * self.specular(wo, wi).1 + (1.0 - ps) * cosine_hemisphere_pdf(wi.z)
    }

    /// Picks a lobe, samples it, weights by the mixture density.
    pub fn sample(&self, wo: Vec3, u1: f32, u2: [f32; 2]) -> Option<LocalSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u1 < self.specular_probability() {
            match self.lobe {
                Lobe::Phong => sample_lobe(reflect_z(wo), self.n, u2),
                Lobe::BlinnPhong => reflect(wo, sample_lobe(Vec3::Z, self.n, u2)),
            }
        } else {
            square_to_cosine_hemisphere(u2)
        };
        reflection_sample(wi, self.pdf(wo, wi), self.eval(wo, wi))
    }

    /// The lecture's local model for one light: I_d·k_d·(n·l) + I_s·k_s·(r·v)^n (or (n·h)^n).
    pub fn local(
        &self,
        wo: Vec3,
        wi: Vec3,
        id: SampledSpectrum,
        is: SampledSpectrum,
    ) -> SampledSpectrum {
        if wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let spec = match self.lobe {
            Lobe::Phong => reflect_z(wi).dot(wo).max(0.0).powf(self.n),
            Lobe::BlinnPhong => (wo + wi).normalize().z.max(0.0).powf(self.n),
        };
        id * self.kd * wi.z + is * self.ks * spec
    }
}
