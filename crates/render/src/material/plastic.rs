//! Plastic: a diffuse base under a dielectric coating (Mitsuba `plastic` and `roughplastic`).
//!
//! Parameters: `diffuse_reflectance` (0.5), `specular_reflectance` (1), `int_ior` (1.49,
//! polypropylene), `ext_ior` (1.000277, air), `nonlinear` (false); rough: `distribution`
//! (beckmann), `alpha` (0.1).
//!
//! Light is reflected specularly by the coating with probability F, or enters it, scatters
//! diffusely at the base (with the internal reflections summed in closed form) and leaves:
//! f_diffuse = ρ / (1 − Fdr_int) · (1 − F(θi))(1 − F(θo)) / (π η²) (with `nonlinear`,
//! ρ·Fdr_int replaces Fdr_int). The rough version takes the transmittances from a table,
//! computed once per material, of the light that crosses the rough coating as Mitsuba 3 defines
//! it: over the microfacet normals visible from the direction, (1 − F) times the masking of the
//! refracted direction (so light lost to masking is not transmitted), and the internal
//! reflectance from the coating's directional albedo seen from inside.

use super::conductor::{microfacet_lobe, microfacet_lobe_pdf, microfacet_pdf};
use super::fresnel::{
    fresnel_dielectric, fresnel_diffuse_reflectance, reflect, reflect_z, refract,
};
use super::microfacet::{Distribution, Microfacet, NormalSampler};
use super::sample::{reflection_sample, specular_probability, LocalSample};
use crate::math::special::beckmann_lambda;
use crate::math::{Vec3, INV_PI, PI};
use crate::sampling::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::simd::F4;
use crate::spectrum::SampledSpectrum;

/// The diffuse base's effective reflectance after the internal reflections.
#[inline]
fn base(kd: SampledSpectrum, fdr_int: f32, nonlinear: bool) -> SampledSpectrum {
    if nonlinear {
        kd.map(|c| c / (1.0 - c * fdr_int))
    } else {
        kd / (1.0 - fdr_int)
    }
}

/// Parameters of a smooth plastic at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    /// Diffuse reflectance of the base.
    pub kd: SampledSpectrum,
    /// Specular reflectance of the coating.
    pub ks: SampledSpectrum,
    /// Relative index of the coating.
    pub eta: f32,
    /// Use the colour-dependent internal reflection term.
    pub nonlinear: bool,
}

impl Plastic {
    fn specular_probability(&self, f_i: f32) -> f32 {
        specular_probability(self.kd, self.ks, f_i)
    }

    /// f·cos θi of the diffuse part (the specular part is a delta).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        let f_o = fresnel_dielectric(wi.z, self.eta).0;
        let fdr = fresnel_diffuse_reflectance(1.0 / self.eta);
        base(self.kd, fdr, self.nonlinear)
            * (INV_PI * wi.z * (1.0 - f_i) * (1.0 - f_o) / (self.eta * self.eta))
    }

    /// The density of sampling the diffuse part.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability(fresnel_dielectric(wo.z, self.eta).0);
        (1.0 - ps) * cosine_hemisphere_pdf(wi.z)
    }

    /// Picks the coating's mirror reflection or the diffuse base.
    pub fn sample(&self, wo: Vec3, u1: f32, u2: [f32; 2]) -> Option<LocalSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        let ps = self.specular_probability(f_i);
        if u1 < ps {
            return Some(LocalSample {
                wi: reflect_z(wo),
                weight: self.ks * (f_i / ps),
                pdf: ps,
                delta: true,
                eta: 1.0,
            });
        }
        let wi = square_to_cosine_hemisphere(u2);
        reflection_sample(
            wi,
            (1.0 - ps) * cosine_hemisphere_pdf(wi.z),
            self.eval(wo, wi),
        )
    }
}

/// Entries of the rough coating's transmittance table over cos θ ∈ [0, 1].
pub const TABLE: usize = 64;

/// The precomputed part of a rough plastic: the coating's transmittance per cos θ and its
/// internal diffuse reflectance.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughCoating {
    /// The microfacet distribution of the coating.
    pub mf: Microfacet,
    /// Relative index of the coating.
    pub eta: f32,
    transmittance: Vec<f32>,
    internal_reflectance: f32,
}

impl RoughCoating {
    /// Tabulates the coating (numerical integration over its microfacet normals). The table
    /// is over cos θ alone, so the coating is isotropic: an anisotropic `mf` is taken at the
    /// geometric mean of its two roughnesses (Mitsuba's `roughplastic` has one `alpha`).
    pub fn new(mf: Microfacet, eta: f32) -> Self {
        let mf = if mf.is_isotropic() {
            mf
        } else {
            Microfacet::new(mf.dist, (mf.alpha * mf.alpha_v).sqrt())
        };
        use rayon::prelude::*;
        let mu = |i: usize| (i as f32 / (TABLE - 1) as f32).max(1e-6);
        // What the sampled normals share along a row or a column of the strata, computed once
        // for every entry.
        let u = |i: usize| (i as f32 + 0.5) / STRATA as f32;
        let strata: [f32; STRATA] = std::array::from_fn(u);
        let angular: [(f32, f32); STRATA] = std::array::from_fn(|j| mf.angular(u(j)));
        let lanes: [[[f32; 4]; 2]; STRATA / 4] = std::array::from_fn(|k| {
            let a = |j: usize| angular[4 * k + j];
            [
                std::array::from_fn(|j| a(j).0),
                std::array::from_fn(|j| a(j).1),
            ]
        });
        // The entries in parallel (scene loading is on the clock), summed in order.
        let entries: Vec<(f32, f32)> = (0..TABLE)
            .into_par_iter()
            .map(|i| {
                if eta == 1.0 {
                    coating_entry(&mf, eta, mu(i), &strata, &angular)
                } else {
                    coating_entry_lanes(&mf, eta, mu(i), &strata, &lanes)
                }
            })
            .collect();
        let transmittance = entries.iter().map(|e| e.0).collect();
        let internal = (0..TABLE).map(|i| entries[i].1 * mu(i)).sum::<f32>() / TABLE as f32 * 2.0;
        Self {
            mf,
            eta,
            transmittance,
            internal_reflectance: internal,
        }
    }

    /// The coating's transmittance at cos θ (linear interpolation).
    pub fn transmittance(&self, cos: f32) -> f32 {
        let x = cos.clamp(0.0, 1.0) * (TABLE - 1) as f32;
        let i = (x as usize).min(TABLE - 2);
        let w = x - i as f32;
        self.transmittance[i] * (1.0 - w) + self.transmittance[i + 1] * w
    }

    /// The internal diffuse reflectance of the coating.
    pub fn internal_reflectance(&self) -> f32 {
        self.internal_reflectance
    }
}

/// Strata per dimension of the normals the coating's integrals average over.
const STRATA: usize = 48;

/// [`coating_transmittance`] and [`specular_albedo`] (seen from inside, relative index
/// 1/`eta`) at cos θ = `mu` at once, over the same normals, given the strata's numbers and the
/// part of the normals that depends on the second number alone ([`Microfacet::angular`]):
/// the same numbers, bit for bit.
fn coating_entry(
    mf: &Microfacet,
    eta: f32,
    mu: f32,
    strata: &[f32; STRATA],
    angular: &[(f32, f32); STRATA],
) -> (f32, f32) {
    let w = direction(mu);
    let sampler = mf.sampler(w);
    let radial = strata.map(|u| sampler.radial(u));
    let g1w = mf.g1_visible(w);
    let eta_inside = 1.0 / eta;
    let (mut t, mut a) = (0f64, 0f64);
    for r in radial {
        for &phi in angular {
            let m = sampler.normal(r, phi);
            t += transmitted(mf, eta, w, m, g1w) as f64;
            a += reflected(mf, eta_inside, w, m) as f64;
        }
    }
    (mean(t), mean(a))
}

/// [`coating_entry`] four normals at a time (SSE lanes over the second stratum number): the
/// same arithmetic, operation by operation, so the same numbers bit for bit (tested); the
/// lanes' sums are added in the scalar order. Not for an index-matched coating (`eta` = 1,
/// which [`fresnel_dielectric`] treats apart).
fn coating_entry_lanes(
    mf: &Microfacet,
    eta: f32,
    mu: f32,
    strata: &[f32; STRATA],
    angular: &[[[f32; 4]; 2]; STRATA / 4],
) -> (f32, f32) {
    let w = direction(mu);
    let sampler = mf.sampler(w);
    let radial = strata.map(|u| sampler.radial(u));
    let g1w = F4::splat(mf.g1_visible(w));
    let wv = V3::splat(w);
    let eta_inside = 1.0 / eta;
    let (mut t, mut a) = (0f64, 0f64);
    for r in radial {
        for [cos, sin] in angular {
            let m = normal_lanes(&sampler, r, F4::load(cos), F4::load(sin));
            let cos_i = wv.dot(m);
            let tl = transmitted_lanes(mf, eta, wv, m, cos_i, g1w).to_array();
            let al = reflected_lanes(mf, eta_inside, wv, m, cos_i, g1w).to_array();
            for j in 0..4 {
                t += tl[j] as f64;
                a += al[j] as f64;
            }
        }
    }
    (mean(t), mean(a))
}

/// Three coordinates of four vectors.
#[derive(Clone, Copy)]
struct V3 {
    x: F4,
    y: F4,
    z: F4,
}

impl V3 {
    fn splat(v: Vec3) -> V3 {
        V3 {
            x: F4::splat(v.x),
            y: F4::splat(v.y),
            z: F4::splat(v.z),
        }
    }

    /// As `Vec3::dot`.
    #[inline(always)]
    fn dot(self, o: V3) -> F4 {
        self.x.mul(o.x).add(self.y.mul(o.y)).add(self.z.mul(o.z))
    }

    /// As `Vec3::normalize` (a reciprocal, then a product).
    #[inline(always)]
    fn normalize(self) -> V3 {
        let inv = F4::splat(1.0).div(self.dot(self).sqrt());
        V3 {
            x: self.x.mul(inv),
            y: self.y.mul(inv),
            z: self.z.mul(inv),
        }
    }
}

/// Lanes of `a` where `mask`, 0 elsewhere (also `mask` ∧ `a` for masks).
#[inline(always)]
fn and(mask: F4, a: F4) -> F4 {
    F4::select(mask, a, F4::splat(0.0))
}

/// `mask` ∨ `b` for masks.
#[inline(always)]
fn or(mask: F4, b: F4) -> F4 {
    F4::select(mask, mask, b)
}

/// [`NormalSampler::normal`] for four second numbers ([`Microfacet::angular`]'s two parts in
/// lanes).
#[inline(always)]
fn normal_lanes(sampler: &NormalSampler, radial: (f32, f32), cos_phi: F4, sin_phi: F4) -> V3 {
    let (zero, one) = (F4::splat(0.0), F4::splat(1.0));
    match *sampler {
        NormalSampler::Ggx {
            alpha,
            alpha_v,
            vh,
            t1,
            t2,
            s,
        } => {
            let r = F4::splat(radial.0);
            let p1 = r.mul(cos_phi);
            let p2 = r.mul(sin_phi);
            let p2 = F4::splat(1.0 - s)
                .mul(one.sub(p1.mul(p1)).max_keep(zero).sqrt())
                .add(F4::splat(s).mul(p2));
            let sq = one.sub(p1.mul(p1)).sub(p2.mul(p2)).max_keep(zero).sqrt();
            let (t1, t2, vh) = (V3::splat(t1), V3::splat(t2), V3::splat(vh));
            let c = |a: F4, b: F4, v: F4| a.mul(p1).add(b.mul(p2)).add(v.mul(sq));
            let (a, av) = (F4::splat(alpha), F4::splat(alpha_v));
            V3 {
                x: a.mul(c(t1.x, t2.x, vh.x)),
                y: av.mul(c(t1.y, t2.y, vh.y)),
                z: c(t1.z, t2.z, vh.z).max_keep(F4::splat(1e-6)),
            }
            .normalize()
        }
        NormalSampler::Beckmann {
            alpha,
            alpha_v,
            cos_phi: c,
            sin_phi: s,
            ..
        } => {
            // (`cos_phi` holds the slopes across the azimuth.)
            let (sx, sy) = (F4::splat(radial.0), cos_phi);
            let (c, s, a, av) = (
                F4::splat(c),
                F4::splat(s),
                F4::splat(alpha),
                F4::splat(alpha_v),
            );
            let x = a.mul(c.mul(sx).sub(s.mul(sy)));
            let y = av.mul(s.mul(sx).add(c.mul(sy)));
            V3 {
                x: x.neg(),
                y: y.neg(),
                z: one,
            }
            .normalize()
        }
    }
}

/// [`Microfacet::d`] of four normals with these z coordinates.
#[inline(always)]
fn d_lanes(mf: &Microfacet, ct: F4) -> F4 {
    let (zero, one) = (F4::splat(0.0), F4::splat(1.0));
    let ct2 = ct.mul(ct);
    let a2 = mf.alpha * mf.alpha;
    let r = match mf.dist {
        Distribution::Beckmann => {
            let tan2 = one.sub(ct2).div(ct2);
            let pi_a2 = F4::splat(PI * a2);
            let x = tan2.neg().div(F4::splat(a2)).to_array();
            F4::load(&x.map(f32::exp)).div(pi_a2.mul(ct2).mul(ct2))
        }
        Distribution::Ggx => {
            let k = ct2.mul(F4::splat(a2 - 1.0)).add(one);
            F4::splat(a2).div(F4::splat(PI).mul(k).mul(k))
        }
    };
    and(
        and(ct.gt_mask(zero), r.mul(ct).gt_mask(F4::splat(1e-20))),
        r,
    )
}

/// [`Microfacet::g1`] of four pairs.
#[inline(always)]
fn g1_lanes(mf: &Microfacet, w: V3, m: V3) -> F4 {
    let (zero, one) = (F4::splat(0.0), F4::splat(1.0));
    let ct = w.z.abs();
    let alpha = F4::splat(mf.alpha);
    let g = match mf.dist {
        Distribution::Beckmann => {
            let tan = one.sub(ct.mul(ct)).max_keep(zero).sqrt().div(ct);
            let a = one.div(alpha.mul(tan)).to_array();
            let r = one.div(one.add(F4::load(&a.map(beckmann_lambda))));
            F4::select(tan.eq_mask(zero), one, r)
        }
        Distribution::Ggx => {
            let a2 = mf.alpha * mf.alpha;
            let root = F4::splat(a2)
                .add(F4::splat(1.0 - a2).mul(ct.mul(ct)))
                .sqrt();
            F4::splat(2.0).mul(ct).div(ct.add(root))
        }
    };
    let hidden = w.dot(m).mul(w.z).le_mask(zero);
    F4::select(hidden, zero, g)
}

/// [`fresnel_dielectric`]'s reflectance and transmitted cosine for four cosines, from outside
/// (the lanes with a negative cosine are not used), `eta` ≠ 1.
#[inline(always)]
fn fresnel_lanes(cos_i: F4, eta: f32) -> (F4, F4) {
    let (zero, one) = (F4::splat(0.0), F4::splat(1.0));
    let (eta_it, eta_ti) = (F4::splat(eta), F4::splat(1.0 / eta));
    let cos_t2 = one.sub(one.sub(cos_i.mul(cos_i)).mul(eta_ti).mul(eta_ti));
    let ci = cos_i.abs();
    let total = or(cos_t2.le_mask(zero), ci.eq_mask(zero));
    let ct = cos_t2.sqrt();
    let a_s = ci.sub(eta_it.mul(ct)).div(ci.add(eta_it.mul(ct)));
    let a_p = ct.sub(eta_it.mul(ci)).div(ct.add(eta_it.mul(ci)));
    let f = F4::splat(0.5).mul(a_s.mul(a_s).add(a_p.mul(a_p)));
    (F4::select(total, one, f), F4::select(total, zero, ct.neg()))
}

/// [`transmitted`] at four normals (`cos_i` = wi·m).
#[inline(always)]
fn transmitted_lanes(mf: &Microfacet, eta: f32, wi: V3, m: V3, cos_i: F4, g1w: F4) -> F4 {
    let zero = F4::splat(0.0);
    let g1 = F4::select(cos_i.mul(wi.z).le_mask(zero), zero, g1w);
    let d = d_lanes(mf, m.z);
    // (The density of the visible normals: the normals' own.)
    let q = g1.mul(cos_i.max_keep(zero)).mul(d).div(wi.z);
    let visible = q;
    let (f, cos_t) = fresnel_lanes(cos_i, eta);
    let eta_ti = F4::splat(1.0 / eta);
    let k = cos_i.mul(eta_ti).add(cos_t);
    let wt = V3 {
        x: m.x.mul(k).sub(wi.x.mul(eta_ti)),
        y: m.y.mul(k).sub(wi.y.mul(eta_ti)),
        z: m.z.mul(k).sub(wi.z.mul(eta_ti)),
    };
    let ok = and(
        and(q.gt_mask(zero), zero.lt_mask(cos_i)),
        wt.z.mul(wi.z).lt_mask(zero),
    );
    let v = F4::splat(1.0)
        .sub(f)
        .mul(g1_lanes(mf, wt, m))
        .mul(visible)
        .div(q);
    and(ok, v)
}

/// [`reflected`] at four normals (`cos_i` = wo·m), given G1 of `wo` for the normals it sees.
#[inline(always)]
fn reflected_lanes(mf: &Microfacet, eta: f32, wo: V3, m: V3, cos_i: F4, g1w: F4) -> F4 {
    let zero = F4::splat(0.0);
    let two = F4::splat(2.0).mul(cos_i);
    let wi = V3 {
        x: m.x.mul(two).sub(wo.x),
        y: m.y.mul(two).sub(wo.y),
        z: m.z.mul(two).sub(wo.z),
    };
    let h = V3 {
        x: wo.x.add(wi.x),
        y: wo.y.add(wi.y),
        z: wo.z.add(wi.z),
    }
    .normalize();
    let d = d_lanes(mf, h.z);
    let cos_oh = wo.dot(h);
    let g1o = F4::select(cos_oh.mul(wo.z).le_mask(zero), zero, g1w);
    let v = d
        .mul(g1o.mul(g1_lanes(mf, wi, h)))
        .div(F4::splat(4.0).mul(wo.z));
    let pdf = g1o
        .mul(cos_oh.max_keep(zero))
        .mul(d)
        .div(wo.z)
        .div(F4::splat(4.0).mul(cos_oh));
    let ok = and(
        and(zero.lt_mask(wi.z), zero.lt_mask(cos_oh)),
        and(
            and(zero.lt_mask(v), v.lt_mask(F4::splat(f32::INFINITY))),
            zero.lt_mask(pdf),
        ),
    );
    let (f, _) = fresnel_lanes(cos_oh, eta);
    and(ok, f.mul(v).div(pdf))
}

/// The direction at cos θ = `mu` in the xz plane.
fn direction(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// The mean of a sum over the strata, clamped to [0, 1].
fn mean(sum: f64) -> f32 {
    ((sum / (STRATA * STRATA) as f64) as f32).clamp(0.0, 1.0)
}

/// [`coating_transmittance`]'s integrand at the normal `m`, given `g1w` = G1 of `wi` for
/// normals it sees ([`Microfacet::g1_visible`]).
#[inline(always)]
fn transmitted(mf: &Microfacet, eta: f32, wi: Vec3, m: Vec3, g1w: f32) -> f32 {
    let cos_i = wi.dot(m);
    let g1 = if cos_i * wi.z <= 0.0 { 0.0 } else { g1w };
    let d = mf.d(m);
    // The density of the sampled normal, which is that of the visible normals (as
    // `Microfacet::pdf` computes it).
    let q = g1 * cos_i.max(0.0) * d / wi.z;
    let visible = q;
    if !(q > 0.0) || cos_i <= 0.0 {
        return 0.0;
    }
    let (f, cos_t, _, eta_ti) = fresnel_dielectric(cos_i, eta);
    let wt = refract(wi, m, cos_t, eta_ti);
    if wt.z * wi.z >= 0.0 {
        return 0.0;
    }
    (1.0 - f) * mf.g1(wt, m) * visible / q
}

/// [`specular_albedo`]'s integrand at the normal `m`.
#[inline(always)]
fn reflected(mf: &Microfacet, eta: f32, wo: Vec3, m: Vec3) -> f32 {
    let wi = reflect(wo, m);
    match microfacet_lobe_pdf(mf, wo, wi) {
        (Some((v, h)), pdf) if pdf > 0.0 => fresnel_dielectric(wo.dot(h), eta).0 * v / pdf,
        _ => 0.0,
    }
}

/// The fraction of light arriving at cos θ = `mu` that crosses a rough dielectric coating:
/// E[(1 − F(wi·m)) G1(wt, m)] over the normals m visible from wi (density
/// G1(wi, m) max(0, wi·m) D(m) / cos θ), wt the refracted direction; by stratified importance
/// sampling of the normals.
#[cfg(test)]
fn coating_transmittance(mf: &Microfacet, eta: f32, mu: f32) -> f32 {
    over_normals(mf, mu, |wi, m| {
        let q = mf.pdf(wi, m);
        let cos_i = wi.dot(m);
        if !(q > 0.0) || cos_i <= 0.0 {
            return 0.0;
        }
        let visible = mf.g1(wi, m) * cos_i * mf.d(m) / wi.z;
        let (f, cos_t, _, eta_ti) = fresnel_dielectric(cos_i, eta);
        let wt = refract(wi, m, cos_t, eta_ti);
        if wt.z * wi.z >= 0.0 {
            return 0.0;
        }
        (1.0 - f) * mf.g1(wt, m) * visible / q
    })
}

/// The directional albedo of a rough dielectric coating's reflection at cos θ = `mu`, by
/// stratified importance sampling of its microfacet normals.
#[cfg(test)]
fn specular_albedo(mf: &Microfacet, eta: f32, mu: f32) -> f32 {
    over_normals(mf, mu, |wo, m| {
        let wi = reflect(wo, m);
        let pdf = microfacet_pdf(mf, wo, wi);
        match (microfacet_lobe(mf, wo, wi), pdf > 0.0) {
            (Some((v, h)), true) => fresnel_dielectric(wo.dot(h), eta).0 * v / pdf,
            _ => 0.0,
        }
    })
}

/// The mean of `f(w, m)` over 48 × 48 stratified samples m of [`Microfacet::sample`] seen from
/// the direction w at cos θ = `mu`, clamped to [0, 1] (the plain definition the table's
/// entries are tested against).
#[cfg(test)]
fn over_normals(mf: &Microfacet, mu: f32, f: impl Fn(Vec3, Vec3) -> f32) -> f32 {
    let w = direction(mu);
    let n = STRATA;
    let mut sum = 0f64;
    for i in 0..n {
        for j in 0..n {
            let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
            sum += f(w, mf.sample(w, u)) as f64;
        }
    }
    mean(sum)
}

/// Parameters of a rough plastic at one point.
#[derive(Clone, Copy, Debug)]
pub struct RoughPlastic<'a> {
    /// Diffuse reflectance of the base.
    pub kd: SampledSpectrum,
    /// Specular reflectance of the coating.
    pub ks: SampledSpectrum,
    /// The tabulated coating.
    pub coating: &'a RoughCoating,
    /// Use the colour-dependent internal reflection term.
    pub nonlinear: bool,
}

impl RoughPlastic<'_> {
    /// What [`RoughPlastic::sample`] and [`RoughPlastic::eval_pdf`] compute from the outgoing
    /// direction's local z alone: the coating's transmittance towards it, the coating lobe's
    /// probability, and the base's effective reflectance (for the path tracer's lanes).
    pub(crate) fn lane_terms(&self, wo_z: f32) -> (f32, f32, SampledSpectrum) {
        let c = self.coating;
        let t_o = c.transmittance(wo_z);
        let kb = base(self.kd, c.internal_reflectance, self.nonlinear);
        (t_o, self.specular_probability(t_o), kb)
    }

    fn specular_probability(&self, t_i: f32) -> f32 {
        specular_probability(self.kd, self.ks, 1.0 - t_i)
    }

    /// f·cos θi.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let c = self.coating;
        self.value(
            wo,
            wi,
            microfacet_lobe(&c.mf, wo, wi),
            c.transmittance(wo.z),
        )
    }

    /// f·cos θi of a pair above the surface, given the coating's lobe there
    /// ([`microfacet_lobe`]) and its transmittance towards `wo`.
    #[inline(always)]
    fn value(&self, wo: Vec3, wi: Vec3, lobe: Option<(f32, Vec3)>, t_o: f32) -> SampledSpectrum {
        let c = self.coating;
        let spec = match lobe {
            Some((v, h)) => self.ks * (fresnel_dielectric(wo.dot(h), c.eta).0 * v),
            None => SampledSpectrum::ZERO,
        };
        let diff = base(self.kd, c.internal_reflectance, self.nonlinear)
            * (INV_PI * wi.z * t_o * c.transmittance(wi.z) / (c.eta * c.eta));
        spec + diff
    }

    /// The density of [`RoughPlastic::sample`].
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.specular_probability(self.coating.transmittance(wo.z));
        ps * microfacet_pdf(&self.coating.mf, wo, wi) + (1.0 - ps) * cosine_hemisphere_pdf(wi.z)
    }

    /// [`RoughPlastic::eval`] and [`RoughPlastic::pdf`] of one pair at once, sharing the
    /// microfacet terms and the transmittance towards `wo`: the same numbers, bit for bit.
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (SampledSpectrum, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (SampledSpectrum::ZERO, 0.0);
        }
        let t_o = self.coating.transmittance(wo.z);
        self.eval_pdf_with(wo, wi, t_o, self.specular_probability(t_o))
    }

    /// [`RoughPlastic::eval_pdf`] of a pair above the surface, given the transmittance towards
    /// `wo` and the coating lobe's probability there.
    #[inline(always)]
    fn eval_pdf_with(&self, wo: Vec3, wi: Vec3, t_o: f32, ps: f32) -> (SampledSpectrum, f32) {
        let (lobe, mpdf) = microfacet_lobe_pdf(&self.coating.mf, wo, wi);
        let pdf = ps * mpdf + (1.0 - ps) * cosine_hemisphere_pdf(wi.z);
        (self.value(wo, wi, lobe, t_o), pdf)
    }

    /// Picks the coating's lobe or the diffuse base, then weights by the full pdf.
    pub fn sample(&self, wo: Vec3, u1: f32, u2: [f32; 2]) -> Option<LocalSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let t_o = self.coating.transmittance(wo.z);
        let ps = self.specular_probability(t_o);
        let wi = if u1 < ps {
            reflect(wo, self.coating.mf.sample(wo, u2))
        } else {
            square_to_cosine_hemisphere(u2)
        };
        if wi.z <= 0.0 {
            return None;
        }
        // `eval` and `pdf` at once, sharing the microfacet terms and the transmittance towards
        // wo: the same numbers, bit for bit.
        let (f, pdf) = self.eval_pdf_with(wo, wi, t_o, ps);
        reflection_sample(wi, pdf, f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::microfacet::Distribution;

    /// Sampling, and `eval_pdf`, share the microfacet terms of `eval` and `pdf`: their
    /// densities and values are theirs bit for bit (likewise for the rough conductor).
    #[test]
    fn samples_carry_eval_and_pdf_exactly() {
        use crate::material::conductor;
        let kd = SampledSpectrum::from_rgb(crate::color::Rgb::new(0.6, 0.3, 0.1));
        let ks = SampledSpectrum::splat(0.9);
        for (dist, alpha) in [(Distribution::Ggx, 0.2f32), (Distribution::Beckmann, 0.35)] {
            let coating = RoughCoating::new(Microfacet::new(dist, alpha), 1.5);
            let p = RoughPlastic {
                kd,
                ks,
                coating: &coating,
                nonlinear: true,
            };
            for k in 0..400 {
                let f = |x: f32| (k as f32 * x).fract();
                let wo = Vec3::new(f(0.37) - 0.5, f(0.71) - 0.5, f(0.13) + 0.05).normalize();
                let (u1, u2) = (f(0.53), [f(0.29), f(0.83)]);
                let wi = Vec3::new(f(0.61) - 0.5, f(0.17) - 0.5, f(0.43) - 0.1).normalize();
                let (fv, pdf) = p.eval_pdf(wo, wi);
                assert_eq!(fv.0.map(f32::to_bits), p.eval(wo, wi).0.map(f32::to_bits));
                assert_eq!(pdf.to_bits(), p.pdf(wo, wi).to_bits());
                let (fv, pdf) = conductor::eval_pdf(&coating.mf, None, ks, wo, wi);
                let fc = conductor::eval(&coating.mf, None, ks, wo, wi);
                assert_eq!(fv.0.map(f32::to_bits), fc.0.map(f32::to_bits));
                let pc = conductor::microfacet_pdf(&coating.mf, wo, wi);
                assert_eq!(pdf.to_bits(), pc.to_bits());
                if let Some(s) = p.sample(wo, u1, u2) {
                    assert_eq!(s.pdf.to_bits(), p.pdf(wo, s.wi).to_bits());
                    let w = p.eval(wo, s.wi) / s.pdf;
                    assert_eq!(s.weight.0.map(f32::to_bits), w.0.map(f32::to_bits));
                }
                let mf = coating.mf;
                if let Some(s) = conductor::sample(&mf, None, ks, wo, u2) {
                    let pdf = conductor::microfacet_pdf(&mf, wo, s.wi);
                    let w = conductor::eval(&mf, None, ks, wo, s.wi) / pdf;
                    // The sample takes its density and weight from the sampled normal m rather
                    // than from the half vector of wo and wi, the same up to the rounding of
                    // h = (wo + wi)/|wo + wi|.
                    let near = |a: f32, b: f32| (a - b).abs() <= 1e-4 * b.abs();
                    assert!(near(s.pdf, pdf), "{dist:?} {} {pdf}", s.pdf);
                    for (a, b) in s.weight.0.into_iter().zip(w.0) {
                        assert!(near(a, b), "{dist:?} {a} {b}");
                    }
                }
            }
        }
    }

    /// The table's entries (four normals at a time) are the plain definitions' numbers, bit for
    /// bit.
    #[test]
    fn the_table_holds_the_plain_integrals() {
        for (dist, alpha, eta) in [
            (Distribution::Ggx, 0.2f32, 1.5f32),
            (Distribution::Beckmann, 0.3, 1.5),
            (Distribution::Ggx, 0.08, 1.7),
            (Distribution::Beckmann, 0.02, 1.33),
            // A coating less dense than the outside (total internal reflection from outside),
            // and an index-matched one (the scalar path).
            (Distribution::Ggx, 0.3, 0.8),
            (Distribution::Beckmann, 0.5, 0.7),
            (Distribution::Ggx, 0.1, 1.0),
        ] {
            let mf = Microfacet::new(dist, alpha);
            let c = RoughCoating::new(mf, eta);
            let mu = |i: usize| (i as f32 / (TABLE - 1) as f32).max(1e-6);
            let mut albedo = 0f32;
            for i in 0..TABLE {
                let t = coating_transmittance(&mf, eta, mu(i));
                assert_eq!(c.transmittance[i].to_bits(), t.to_bits(), "{dist:?} {i}");
                albedo += specular_albedo(&mf, 1.0 / eta, mu(i)) * mu(i);
            }
            let internal = albedo / TABLE as f32 * 2.0;
            assert_eq!(c.internal_reflectance.to_bits(), internal.to_bits());
        }
    }

    /// The coating transmits at most what it does not reflect (masking loses the rest) and
    /// tends to 1 − F for a nearly smooth coating.
    #[test]
    fn rough_coating_transmittance() {
        let eta = 1.49;
        for dist in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.05f32, 0.2, 0.5] {
                let mf = Microfacet::new(dist, alpha);
                for mu in [0.1f32, 0.3, 0.5, 0.8, 1.0] {
                    let t = coating_transmittance(&mf, eta, mu);
                    let r = specular_albedo(&mf, eta, mu);
                    assert!(
                        t > 0.0 && t + r <= 1.0 + 1e-4,
                        "{dist:?} {alpha} {mu}: {t} + {r}"
                    );
                }
            }
            let smooth = Microfacet::new(dist, 1e-3);
            for mu in [0.2f32, 0.5, 1.0] {
                let t = coating_transmittance(&smooth, eta, mu);
                let f = fresnel_dielectric(mu, eta).0;
                assert!(
                    (t - (1.0 - f)).abs() < 2e-3,
                    "{dist:?} {mu}: {t} vs {}",
                    1.0 - f
                );
            }
        }
    }

    /// Against Mitsuba 3.9.1: renders of a GGX (α 0.2, η 1.49) rough plastic's diffuse part under
    /// a directional light, candela's former transmittance (1 − specular albedo) over Mitsuba's,
    /// factor into g(θi)·g(θo) with g(0°) = 1.0047, g(60°) = 1.031, g(75°) = 1.085. The new
    /// transmittance must explain that factor.
    #[test]
    fn rough_coating_matches_mitsubas_transmittance() {
        let mf = Microfacet::new(Distribution::Ggx, 0.2);
        for (deg, g) in [(0.0f32, 1.0047f32), (60.0, 1.031), (75.0, 1.085)] {
            let mu = deg.to_radians().cos();
            let ratio =
                (1.0 - specular_albedo(&mf, 1.49, mu)) / coating_transmittance(&mf, 1.49, mu);
            assert!((ratio / g - 1.0).abs() < 0.004, "{deg}°: {ratio} vs {g}");
        }
    }
}
