//! Dielectrics: the smooth interface (Fresnel reflection + Snell refraction) and the rough one
//! (Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces").
//!
//! Scene syntax: `glass(ior [, kt])` (candela); `<bsdf type="dielectric">` and
//! `<bsdf type="roughdielectric">` with `int_ior` (1.5046), `ext_ior` (1.000277),
//! `specular_reflectance`, `specular_transmittance`, `distribution`, `alpha` (Mitsuba).
//!
//! `eta` is the relative index interior/exterior; the local +z axis points outside. Radiance
//! crossing the boundary is scaled by (η_i/η_t)², as radiance transport requires.

use super::fresnel::{fresnel_dielectric, reflect, reflect_z, refract, refract_z};
use super::microfacet::Microfacet;
use super::sample::LocalSample;
use crate::math::Vec3;
use crate::spectrum::{Ior, SampledSpectrum, Wavelengths};

/// A dielectric whose index varies with the wavelength (a candela extension of Mitsuba's
/// `int_ior`): the relative index at λ is `interior(λ) / exterior`.
#[derive(Clone, Debug, PartialEq)]
pub struct Dispersion {
    /// The interior's index as a function of the wavelength.
    pub interior: Ior,
    /// The exterior's index.
    pub exterior: f32,
}

/// The wavelength at which a dispersive glass's index stands for the whole spectrum in RGB mode:
/// the sodium D line, where glasses' catalogue indices n_d are given.
pub const REFERENCE_WAVELENGTH: f32 = 587.56;

/// The relative index a path sees: `eta`, or, for a dispersive glass on a spectral path, the
/// index at the hero wavelength — and then the path keeps only its hero wavelength (the others
/// would refract elsewhere; pbrt-v4's `TerminateSecondary`).
#[inline]
pub fn relative_eta(eta: f32, dispersion: Option<&Dispersion>, w: &mut Wavelengths) -> f32 {
    match (dispersion, w.hero()) {
        (Some(d), Some(lambda)) if d.interior.is_dispersive() => {
            w.terminate_secondary();
            d.interior.eval(lambda) / d.exterior
        }
        _ => eta,
    }
}

/// Samples the smooth interface: reflection with probability F, else refraction.
#[inline]
pub fn sample_smooth(
    eta: f32,
    r: SampledSpectrum,
    t: SampledSpectrum,
    wo: Vec3,
    u: f32,
) -> Option<LocalSample> {
    let (f, cos_t, _, eta_ti) = fresnel_dielectric(wo.z, eta);
    if u < f {
        Some(LocalSample {
            wi: reflect_z(wo),
            weight: r,
            pdf: f,
            delta: true,
            eta: 1.0,
        })
    } else {
        Some(LocalSample {
            wi: refract_z(wo, cos_t, eta_ti),
            weight: t * (eta_ti * eta_ti),
            pdf: 1.0 - f,
            delta: true,
            eta: 1.0 / eta_ti,
        })
    }
}

/// The generalised half vector of `wo` and `wi` (pointing to the outside), or `None` when
/// degenerate, with whether the pair is a reflection and the relative index η′ along wo→wi.
#[inline]
fn half_vector(eta: f32, wo: Vec3, wi: Vec3) -> Option<(Vec3, bool, f32)> {
    let (ci, co) = (wo.z, wi.z);
    if ci == 0.0 || co == 0.0 {
        return None;
    }
    let reflection = ci * co > 0.0;
    let eta_p = if ci > 0.0 { eta } else { 1.0 / eta };
    let m = wo + wi * if reflection { 1.0 } else { eta_p };
    let len = m.norm();
    if !(len > 0.0) {
        return None;
    }
    let m = m / len;
    Some((if m.z < 0.0 { -m } else { m }, reflection, eta_p))
}

/// f·|cos θi| of the rough interface.
pub fn eval_rough(
    mf: &Microfacet,
    eta: f32,
    r: SampledSpectrum,
    t: SampledSpectrum,
    wo: Vec3,
    wi: Vec3,
) -> SampledSpectrum {
    let Some((m, reflection, eta_p)) = half_vector(eta, wo, wi) else {
        return SampledSpectrum::ZERO;
    };
    let d = mf.d(m);
    let (f, ..) = fresnel_dielectric(wo.dot(m), eta);
    let g = mf.g(wo, wi, m);
    let (om, im) = (wo.dot(m), wi.dot(m));
    // Both directions must see m from the side their hemisphere says.
    if om * wo.z <= 0.0 || im * wi.z <= 0.0 {
        return SampledSpectrum::ZERO;
    }
    if reflection {
        r * (f * d * g / (4.0 * wo.z.abs()))
    } else {
        let denom = om + eta_p * im;
        // Radiance scaling (η_i/η_t)² cancels the η′² of the Jacobian.
        t * ((1.0 - f) * d * g * (om * im).abs() / (wo.z.abs() * denom * denom))
    }
}

/// The density of [`sample_rough`].
pub fn pdf_rough(mf: &Microfacet, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    let Some((m, reflection, eta_p)) = half_vector(eta, wo, wi) else {
        return 0.0;
    };
    let (om, im) = (wo.dot(m), wi.dot(m));
    if om * wo.z <= 0.0 || im * wi.z <= 0.0 {
        return 0.0;
    }
    let wo_up = if wo.z < 0.0 { -wo } else { wo };
    let pm = mf.pdf(wo_up, m);
    let (f, ..) = fresnel_dielectric(om, eta);
    if reflection {
        f * pm / (4.0 * im.abs())
    } else {
        let denom = om + eta_p * im;
        (1.0 - f) * pm * eta_p * eta_p * im.abs() / (denom * denom)
    }
}

/// Samples a microfacet normal, then reflection (probability F) or refraction through it.
pub fn sample_rough(
    mf: &Microfacet,
    eta: f32,
    r: SampledSpectrum,
    t: SampledSpectrum,
    wo: Vec3,
    u1: f32,
    u2: [f32; 2],
) -> Option<LocalSample> {
    if wo.z == 0.0 {
        return None;
    }
    let wo_up = if wo.z < 0.0 { -wo } else { wo };
    let m = mf.sample(wo_up, u2);
    // Only microfacets facing wo scatter it (the visible normals face it, up to rounding).
    if wo.dot(m) * wo.z <= 0.0 {
        return None;
    }
    let (f, cos_t, _, eta_ti) = fresnel_dielectric(wo.dot(m), eta);
    let reflection = u1 < f;
    if !reflection && cos_t == 0.0 {
        return None;
    }
    let wi = if reflection {
        reflect(wo, m)
    } else {
        refract(wo, m, cos_t, eta_ti)
    };
    // A reflection must stay on wo's side and a refraction must cross the surface (as in
    // Mitsuba): otherwise `pdf_rough` would see the pair as the other event through another
    // microfacet, and the sample would land where the density does not account for it.
    if (wi.z * wo.z > 0.0) != reflection {
        return None;
    }
    let pdf = pdf_rough(mf, eta, wo, wi);
    if !(pdf > 0.0) {
        return None;
    }
    let value = eval_rough(mf, eta, r, t, wo, wi);
    Some(LocalSample {
        wi,
        weight: value / pdf,
        pdf,
        delta: false,
        eta: if wo.z * wi.z < 0.0 { 1.0 / eta_ti } else { 1.0 },
    })
}
