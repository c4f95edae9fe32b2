//! Fresnel equations for dielectric and conductor interfaces.

use crate::math::{safe_sqrt, Vec3};
use crate::spectrum::SampledSpectrum;

/// Fresnel reflectance at a dielectric interface for unpolarised light.
///
/// `cos_i` is the cosine between the incident direction and the normal (negative when the light
/// arrives from the inside); `eta` is the relative index inside/outside (> 1 for glass in air).
/// Returns `(F, cos_t, eta_it, eta_ti)`: the reflectance, the signed cosine of the transmitted
/// direction (0 under total internal reflection), and the relative indices along the direction
/// of travel (transmitted over incident, and its inverse).
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    // Snell's law for the squared cosine of the transmitted direction.
    let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
    let ci = cos_i.abs();
    if eta == 1.0 {
        return (0.0, -cos_i, 1.0, 1.0);
    }
    if cos_t2 <= 0.0 {
        return (1.0, 0.0, eta_it, eta_ti);
    }
    if ci == 0.0 {
        return (1.0, 0.0, eta_it, eta_ti);
    }
    let ct = cos_t2.sqrt();
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    let f = 0.5 * (a_s * a_s + a_p * a_p);
    (f, if outside { -ct } else { ct }, eta_it, eta_ti)
}

/// Fresnel reflectance of a conductor with complex relative index `eta + i·k` for light arriving
/// from outside at cosine `cos_i` ≥ 0 (per channel). This and [`fresnel_dielectric`]'s
/// reflectance are repeated on sixteen lanes by the path tracer
/// (`integrator/path/microfacet_lanes.rs`): change both.
pub fn fresnel_conductor(cos_i: f32, eta: SampledSpectrum, k: SampledSpectrum) -> SampledSpectrum {
    let one = |eta: f32, k: f32| -> f32 {
        let c2 = cos_i * cos_i;
        let s2 = 1.0 - c2;
        let s4 = s2 * s2;
        let t1 = eta * eta - k * k - s2;
        let a2b2 = safe_sqrt(t1 * t1 + 4.0 * k * k * eta * eta);
        let a = safe_sqrt(0.5 * (a2b2 + t1));
        let term1 = a2b2 + c2;
        let term2 = 2.0 * cos_i * a;
        let term3 = a2b2 * c2 + s4;
        let term4 = term2 * s2;
        // ½(Rs + Rp) with Rs = (t1 − t2)/(t1 + t2) and Rp = Rs·(t3 − t4)/(t3 + t4) is
        // Rs·t3/(t3 + t4): one division.
        (term1 - term2) * term3 / ((term1 + term2) * (term3 + term4))
    };
    eta.zip(k, one)
}

/// The hemispherical average of the dielectric Fresnel reflectance ("Fdr"): the fraction of
/// diffuse light reflected by the interface, for relative index `eta` (polynomial fits of Egan
/// and Hilgeman 1973 for η < 1 and of d'Eon and Irving 2011 for η ≥ 1).
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let i = 1.0 / eta;
        let (i2, i3, i4, i5) = (i * i, i * i * i, i * i * i * i, i * i * i * i * i);
        0.919317 - 3.4793 * i + 6.75335 * i2 - 7.80989 * i3 + 4.98554 * i4 - 1.36881 * i5
    }
}

/// Mirror reflection of `w` about the local normal +z.
#[inline]
pub fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Mirror reflection of `w` about the unit vector `m`.
#[inline]
pub fn reflect(w: Vec3, m: Vec3) -> Vec3 {
    m * (2.0 * w.dot(m)) - w
}

/// Refraction of `w` through the surface with local normal +z, given `cos_t` and `eta_ti` from
/// [`fresnel_dielectric`].
#[inline]
pub fn refract_z(w: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    Vec3::new(-eta_ti * w.x, -eta_ti * w.y, cos_t)
}

/// Refraction of `w` through a microfacet with unit normal `m`.
#[inline]
pub fn refract(w: Vec3, m: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    m * (w.dot(m) * eta_ti + cos_t) - w * eta_ti
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_and_critical_angle() {
        // F(0) = ((η − 1)/(η + 1))² = 0.04 for η = 1.5, from either side.
        let (f, ct, eta_it, _) = fresnel_dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-6);
        assert!((ct + 1.0).abs() < 1e-6 && eta_it == 1.5);
        assert!((fresnel_dielectric(-1.0, 1.5).0 - 0.04).abs() < 1e-6);
        // From inside, beyond the critical angle asin(1/1.5): total internal reflection.
        let crit = (1.0f32 / 1.5).asin();
        let (f, ct, _, _) = fresnel_dielectric(-(crit + 0.01).cos(), 1.5);
        assert_eq!((f, ct), (1.0, 0.0));
        let (f, _, _, _) = fresnel_dielectric(-(crit - 0.01).cos(), 1.5);
        assert!(f < 1.0 && f > 0.3);
        // Grazing incidence reflects everything.
        assert!((fresnel_dielectric(1e-4, 1.5).0 - 1.0).abs() < 1e-2);
        // Index-matched: nothing is reflected.
        assert_eq!(fresnel_dielectric(0.3, 1.0).0, 0.0);
    }

    #[test]
    fn snell_law_holds() {
        let eta = 1.33;
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let (_, ct, _, eta_ti) = fresnel_dielectric(wi.z, eta);
        let wt = refract_z(wi, ct, eta_ti);
        assert!((wt.norm() - 1.0).abs() < 1e-5);
        // sin θi = η sin θt.
        assert!((0.6 - eta * wt.x.abs()).abs() < 1e-5);
        assert!(wt.z < 0.0);
        let wm = refract(wi, Vec3::Z, ct, eta_ti);
        assert!(wm.approx_eq(wt, 1e-6));
    }

    #[test]
    fn conductors_match_known_values() {
        // A conductor with k = 0 is a dielectric seen from outside.
        let f = fresnel_conductor(
            0.7,
            SampledSpectrum::splat(1.5),
            SampledSpectrum::splat(0.0),
        );
        assert!((f[0] - fresnel_dielectric(0.7, 1.5).0).abs() < 1e-5);
        // Normal incidence: ((η−1)² + k²)/((η+1)² + k²).
        let f = fresnel_conductor(
            1.0,
            SampledSpectrum::splat(0.2),
            SampledSpectrum::splat(3.0),
        );
        assert!((f[1] - (0.64 + 9.0) / (1.44 + 9.0)).abs() < 1e-5);
    }

    #[test]
    fn diffuse_fresnel_reflectance_matches_numeric_integration() {
        for eta in [1.33f32, 1.5, 1.0 / 1.5, 2.0] {
            // Fdr = ∫ F(cos) 2 cos dcos.
            let n = 20000;
            let num: f64 = (0..n)
                .map(|i| {
                    let c = (i as f64 + 0.5) / n as f64;
                    fresnel_dielectric(c as f32, eta).0 as f64 * 2.0 * c / n as f64
                })
                .sum();
            assert!(
                (num - fresnel_diffuse_reflectance(eta) as f64).abs() < 0.01,
                "η = {eta}: {num}"
            );
        }
    }
}
