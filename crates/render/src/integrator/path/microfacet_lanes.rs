//! The rough conductor (GGX) of [`super::surface_lanes`]' lanes: its value and density for a
//! light sample's direction, and the sample of the next direction by the distribution of
//! visible normals, sixteen lanes at once.
//!
//! Each function repeats, operation for operation, what the scalar vertex computes for one
//! path ([`crate::material::microfacet::Microfacet`]'s `d`, `g1`, `sample` and `pdf_with`,
//! `conductor::microfacet_lobe_pdf`, `conductor::sample`, `fresnel_conductor`,
//! [`crate::sampling::warp::sin_cos_turn`]), so that a lane gets the bits a path gets alone
//! (the NaN cases of `max` aside, which finite directions never meet). Change both together.

use crate::math::{INV_PI, PI};
use crate::simd::Wide;

/// What a rough conductor's lanes share: the lanes, the outgoing direction in the shading
/// frame (mirrored like the BSDF's), GGX's α, the lanes with a complex index and the index
/// (η, k) per spectral lane; its reflectance is the vertex's.
#[derive(Clone, Copy)]
pub(super) struct Conductor<W: Wide> {
    pub on: W::M,
    pub wo: [W::V; 3],
    pub alpha: W::V,
    pub fresnel: W::M,
    pub eta: [W::V; 4],
    pub k: [W::V; 4],
}

/// What a rough plastic's lanes share (GGX coating): the lanes, the outgoing direction in the
/// shading frame, the coating's α and relative index, its transmittance towards wo, the
/// coating lobe's probability there, the coating's reflectance and the base's effective
/// reflectance ([`crate::material::RoughPlastic::lane_terms`]).
#[derive(Clone, Copy)]
pub(super) struct Plastic<W: Wide> {
    pub on: W::M,
    pub wo: [W::V; 3],
    pub alpha: W::V,
    pub eta: W::V,
    pub t_o: W::V,
    pub ps: W::V,
    pub ks: [W::V; 4],
    pub kb: [W::V; 4],
}

/// `a·b` as `Vec3::dot` sums it.
#[inline(always)]
pub(super) fn dot<W: Wide>(w: W, a: [W::V; 3], b: [W::V; 3]) -> W::V {
    w.add(
        w.add(w.mul(a[0], b[0]), w.mul(a[1], b[1])),
        w.mul(a[2], b[2]),
    )
}

/// Neither NaN nor infinite.
#[inline(always)]
pub(super) fn finite<W: Wide>(w: W, a: W::V) -> W::M {
    w.eq(w.sub(a, a), w.splat(0.0))
}

/// `Vec3::normalize`: `v` times 1/|v|.
#[inline(always)]
fn normalize<W: Wide>(w: W, v: [W::V; 3]) -> [W::V; 3] {
    let inv = w.div(w.splat(1.0), w.sqrt(dot(w, v, v)));
    [w.mul(v[0], inv), w.mul(v[1], inv), w.mul(v[2], inv)]
}

/// `max(a, 0)` for an `a` that is not NaN.
#[inline(always)]
fn max0<W: Wide>(w: W, a: W::V) -> W::V {
    let zero = w.splat(0.0);
    w.select(w.lt(a, zero), zero, a)
}

/// `Microfacet::d` for GGX at the unit half vector's local z `ct`.
#[inline(always)]
fn ggx_d<W: Wide>(w: W, alpha: W::V, ct: W::V) -> W::V {
    let (zero, one) = (w.splat(0.0), w.splat(1.0));
    let ct2 = w.mul(ct, ct);
    let a2 = w.mul(alpha, alpha);
    let k = w.add(w.mul(ct2, w.sub(a2, one)), one);
    let r = w.div(a2, w.mul(w.mul(w.splat(PI), k), k));
    let keep = w.and(w.gt(ct, zero), w.gt(w.mul(r, ct), w.splat(1e-20)));
    w.select(keep, r, zero)
}

/// `Microfacet::g1_visible` for GGX at the local z `z` of a direction.
#[inline(always)]
fn ggx_g1_visible<W: Wide>(w: W, alpha: W::V, z: W::V) -> W::V {
    let one = w.splat(1.0);
    let ct = w.copysign(z, one);
    let a2 = w.mul(alpha, alpha);
    let root = w.sqrt(w.add(a2, w.mul(w.sub(one, a2), w.mul(ct, ct))));
    w.div(w.mul(w.splat(2.0), ct), w.add(ct, root))
}

/// `Microfacet::g1`: the visible term where `w·m` (`cos_m`) and `w.z` agree in sign, else 0.
#[inline(always)]
fn ggx_g1<W: Wide>(w: W, alpha: W::V, cos_m: W::V, z: W::V) -> W::V {
    let zero = w.splat(0.0);
    let g = ggx_g1_visible(w, alpha, z);
    w.select(w.le(w.mul(cos_m, z), zero), zero, g)
}

/// `fresnel_conductor` of one spectral lane: cosine `cos_i`, index `eta` + i·`k`.
#[inline(always)]
fn fresnel<W: Wide>(w: W, cos_i: W::V, eta: W::V, k: W::V) -> W::V {
    let (one, half, two) = (w.splat(1.0), w.splat(0.5), w.splat(2.0));
    let c2 = w.mul(cos_i, cos_i);
    let s2 = w.sub(one, c2);
    let s4 = w.mul(s2, s2);
    let t1 = w.sub(w.sub(w.mul(eta, eta), w.mul(k, k)), s2);
    let kkee = w.mul(w.mul(w.mul(w.mul(w.splat(4.0), k), k), eta), eta);
    let a2b2 = w.sqrt(max0(w, w.add(w.mul(t1, t1), kkee)));
    let a = w.sqrt(max0(w, w.mul(half, w.add(a2b2, t1))));
    let term1 = w.add(a2b2, c2);
    let term2 = w.mul(w.mul(two, cos_i), a);
    let term3 = w.add(w.mul(a2b2, c2), s4);
    let term4 = w.mul(term2, s2);
    w.div(
        w.mul(w.sub(term1, term2), term3),
        w.mul(w.add(term1, term2), w.add(term3, term4)),
    )
}

/// `fresnel_dielectric(cos_i, eta).0`: the dielectric Fresnel reflectance.
#[inline(always)]
fn fresnel_dielectric<W: Wide>(w: W, cos_i: W::V, eta: W::V) -> W::V {
    let (zero, one) = (w.splat(0.0), w.splat(1.0));
    let outside = w.ge(cos_i, zero);
    let inv = w.div(one, eta);
    let eta_it = w.select(outside, eta, inv);
    let eta_ti = w.select(outside, inv, eta);
    let cos_t2 = w.sub(
        one,
        w.mul(w.mul(w.sub(one, w.mul(cos_i, cos_i)), eta_ti), eta_ti),
    );
    let ci = w.copysign(cos_i, one);
    let ct = w.sqrt(cos_t2);
    let (a, b) = (w.mul(eta_it, ct), w.mul(eta_it, ci));
    let a_s = w.div(w.sub(ci, a), w.add(ci, a));
    let a_p = w.div(w.sub(ct, b), w.add(ct, b));
    let f = w.mul(w.splat(0.5), w.add(w.mul(a_s, a_s), w.mul(a_p, a_p)));
    let total = w.or(w.le(cos_t2, zero), w.eq(ci, zero));
    w.select(w.eq(eta, one), zero, w.select(total, one, f))
}

/// `RoughPlastic::eval_pdf` for the local direction `wi`, given the coating's transmittance
/// `t_i` towards it: f·cos θi per spectral lane and the density of the plastic's sample
/// (both 0 unless wo and wi are above the surface).
#[inline(always)]
pub(super) fn plastic_eval_pdf<W: Wide>(
    w: W,
    p: &Plastic<W>,
    wi: [W::V; 3],
    t_i: W::V,
) -> ([W::V; 4], W::V) {
    let (zero, one) = (w.splat(0.0), w.splat(1.0));
    let both_up = w.and_not(p.on, w.or(w.le(p.wo[2], zero), w.le(wi[2], zero)));
    let Lobe {
        v,
        lobe,
        cos_oh,
        pdf: mpdf,
    } = lobe_pdf(w, p.on, p.alpha, p.wo, wi);
    let inv_pi = w.splat(INV_PI);
    let cos_pdf = w.select(w.gt(wi[2], zero), w.mul(wi[2], inv_pi), zero);
    let pdf = w.add(w.mul(p.ps, mpdf), w.mul(w.sub(one, p.ps), cos_pdf));
    let fr = fresnel_dielectric(w, cos_oh, p.eta);
    let scale = w.div(
        w.mul(w.mul(w.mul(inv_pi, wi[2]), p.t_o), t_i),
        w.mul(p.eta, p.eta),
    );
    let mut f = [zero; 4];
    for k in 0..4 {
        let spec = w.select(lobe, w.mul(p.ks[k], w.mul(fr, v)), zero);
        f[k] = w.select(both_up, w.add(spec, w.mul(p.kb[k], scale)), zero);
    }
    (f, w.select(both_up, pdf, zero))
}

/// `conductor::eval_pdf` for the local direction `wi`: f·cos θi per spectral lane (0 where the
/// lobe is not positive and finite) and the density of sampling `wi`, with `r` the
/// reflectance. Meaningful in the lanes of `c.on`.
#[inline(always)]
pub(super) fn eval_pdf<W: Wide>(
    w: W,
    c: &Conductor<W>,
    r: &[W::V; 4],
    wi: [W::V; 3],
) -> ([W::V; 4], W::V) {
    let zero = w.splat(0.0);
    let Lobe {
        v,
        lobe,
        cos_oh,
        pdf,
    } = lobe_pdf(w, c.on, c.alpha, c.wo, wi);
    let mut f = [zero; 4];
    for k in 0..4 {
        let fr = w.select(
            c.fresnel,
            fresnel(w, cos_oh, c.eta[k], c.k[k]),
            w.splat(1.0),
        );
        f[k] = w.select(lobe, w.mul(w.mul(r[k], fr), v), zero);
    }
    (f, pdf)
}

/// `conductor::microfacet_lobe_pdf` for GGX in the lanes `on`: the lobe D·G/(4 cos θo) (valid
/// in the lanes `lobe`), wo·h and the density of sampling `wi` (0 outside `on`).
pub(super) struct Lobe<W: Wide> {
    pub v: W::V,
    pub lobe: W::M,
    pub cos_oh: W::V,
    pub pdf: W::V,
}

/// [`Lobe`] of the local directions `wo` and `wi`.
#[inline(always)]
pub(super) fn lobe_pdf<W: Wide>(
    w: W,
    on: W::M,
    alpha: W::V,
    wo: [W::V; 3],
    wi: [W::V; 3],
) -> Lobe<W> {
    let zero = w.splat(0.0);
    let both_up = w.and_not(on, w.or(w.le(wo[2], zero), w.le(wi[2], zero)));
    let h = normalize(
        w,
        [
            w.add(wo[0], wi[0]),
            w.add(wo[1], wi[1]),
            w.add(wo[2], wi[2]),
        ],
    );
    let d = ggx_d(w, alpha, h[2]);
    let cos_oh = dot(w, wo, h);
    let g1o = ggx_g1(w, alpha, cos_oh, wo[2]);
    let g1i = ggx_g1(w, alpha, dot(w, wi, h), wi[2]);
    let p = w.div(w.mul(d, g1o), w.mul(w.splat(4.0), wo[2]));
    let v = w.mul(p, g1i);
    Lobe {
        v,
        lobe: w.and(both_up, w.and(w.gt(v, zero), finite(w, v))),
        cos_oh,
        pdf: w.select(w.and_not(both_up, w.le(cos_oh, zero)), p, zero),
    }
}

/// `conductor::sample` with the numbers `u`: the lanes where the sample exists have wo and wi
/// above the surface, a positive density and G1(wi, m).
#[inline(always)]
pub(super) fn sample<W: Wide>(w: W, c: &Conductor<W>, r: &[W::V; 4], u: [W::V; 2]) -> Sample<W> {
    let (zero, one) = (w.splat(0.0), w.splat(1.0));
    let (wo, alpha) = (c.wo, c.alpha);
    let (m, wi) = reflected(w, wo, alpha, u);
    // The density D(m)·G1(wo, m) / (4 cos θo) and the weight r·F(wo·m)·G1(wi, m).
    let cos_om = dot(w, wo, m);
    let g1i = ggx_g1(w, alpha, dot(w, wi, m), wi[2]);
    let d = ggx_d(w, alpha, m[2]);
    let pdf = w.div(
        w.mul(d, ggx_g1(w, alpha, cos_om, wo[2])),
        w.mul(w.splat(4.0), wo[2]),
    );
    let ok = w.and_not(c.on, w.or(w.le(wo[2], zero), w.le(wi[2], zero)));
    let ok = w.and(ok, w.and(w.gt(pdf, zero), w.gt(g1i, zero)));
    let mut weight = [zero; 4];
    for k in 0..4 {
        let fr = w.select(c.fresnel, fresnel(w, cos_om, c.eta[k], c.k[k]), one);
        weight[k] = w.mul(w.mul(r[k], fr), g1i);
    }
    Sample {
        wi,
        pdf,
        weight,
        ok,
    }
}

/// `Microfacet::sample` (GGX) and `reflect`: the visible normal m drawn with the numbers `u`
/// from `wo`, and `wo` reflected about it.
#[inline(always)]
pub(super) fn reflected<W: Wide>(
    w: W,
    wo: [W::V; 3],
    alpha: W::V,
    u: [W::V; 2],
) -> ([W::V; 3], [W::V; 3]) {
    let (zero, one, half) = (w.splat(0.0), w.splat(1.0), w.splat(0.5));
    // `Microfacet::sampler`: the view direction stretched to the hemisphere configuration,
    // and a frame about it.
    let vh = normalize(w, [w.mul(alpha, wo[0]), w.mul(alpha, wo[1]), wo[2]]);
    let lensq = w.add(w.mul(vh[0], vh[0]), w.mul(vh[1], vh[1]));
    let inv = w.div(one, w.sqrt(lensq));
    let tilted = w.gt(lensq, zero);
    let t1 = [
        w.select(tilted, w.mul(w.neg(vh[1]), inv), one),
        w.select(tilted, w.mul(vh[0], inv), zero),
        w.select(tilted, w.mul(zero, inv), zero),
    ];
    let t2 = [
        w.sub(w.mul(vh[1], t1[2]), w.mul(vh[2], t1[1])),
        w.sub(w.mul(vh[2], t1[0]), w.mul(vh[0], t1[2])),
        w.sub(w.mul(vh[0], t1[1]), w.mul(vh[1], t1[0])),
    ];
    let s = w.mul(half, w.add(one, vh[2]));
    // `Microfacet::radial`, `NormalSampler::angular` (`sin_cos_turn`) and `normal`.
    let rad = w.sqrt(u[0]);
    let (sin, cos) = sin_cos_turn(w, u[1]);
    let p1 = w.mul(rad, cos);
    let p2 = w.mul(rad, sin);
    let p2 = w.add(
        w.mul(w.sub(one, s), w.sqrt(max0(w, w.sub(one, w.mul(p1, p1))))),
        w.mul(s, p2),
    );
    let up = w.sqrt(max0(w, w.sub(w.sub(one, w.mul(p1, p1)), w.mul(p2, p2))));
    let mut nh = [zero; 3];
    for k in 0..3 {
        nh[k] = w.add(w.add(w.mul(t1[k], p1), w.mul(t2[k], p2)), w.mul(vh[k], up));
    }
    let floor = w.splat(1e-6);
    let m = normalize(
        w,
        [
            w.mul(alpha, nh[0]),
            w.mul(alpha, nh[1]),
            w.select(w.lt(nh[2], floor), floor, nh[2]),
        ],
    );
    // `reflect`: m·(2 wo·m) − wo.
    let two_cos = w.mul(w.splat(2.0), dot(w, wo, m));
    let wi = [
        w.sub(w.mul(m[0], two_cos), wo[0]),
        w.sub(w.mul(m[1], two_cos), wo[1]),
        w.sub(w.mul(m[2], two_cos), wo[2]),
    ];
    (m, wi)
}

/// A rough conductor's sample in the lanes: the local direction, its density, f·cos/pdf per
/// spectral lane, and the lanes where it exists.
pub(super) struct Sample<W: Wide> {
    pub wi: [W::V; 3],
    pub pdf: W::V,
    pub weight: [W::V; 4],
    pub ok: W::M,
}

/// [`crate::sampling::warp::sin_cos_turn`] in the lanes: (sin, cos) of 2π·`u`.
#[inline(always)]
pub(super) fn sin_cos_turn<W: Wide>(w: W, u: W::V) -> (W::V, W::V) {
    let (zero, one) = (w.splat(0.0), w.splat(1.0));
    let q = w.mul(w.splat(4.0), u);
    // (Selects, not a closure: closures do not inherit the kernel's instruction set.)
    let (a, b, c, d) = (w.splat(0.5), w.splat(1.5), w.splat(2.5), w.splat(3.5));
    let m = w.add(
        w.add(
            w.add(
                w.select(w.ge(q, a), one, zero),
                w.select(w.ge(q, b), one, zero),
            ),
            w.select(w.ge(q, c), one, zero),
        ),
        w.select(w.ge(q, d), one, zero),
    );
    let (s, c) = sin_cos_quarter(w, w.mul(w.sub(q, m), w.splat(PI / 2.0)));
    // The quarter turns m mod 4: 1 and 3 swap sine and cosine; 1 and 2 negate the sine's
    // result, 2 and 3 the cosine's.
    let odd = w.or(
        w.and(w.ge(q, w.splat(0.5)), w.lt(q, w.splat(1.5))),
        w.and(w.ge(q, w.splat(2.5)), w.lt(q, w.splat(3.5))),
    );
    let (a, b) = (w.select(odd, c, s), w.select(odd, s, c));
    let neg_sin = w.and(w.ge(q, w.splat(1.5)), w.lt(q, w.splat(3.5)));
    let neg_cos = w.and(w.ge(q, w.splat(0.5)), w.lt(q, w.splat(2.5)));
    // (m = 1: (c, −s); m = 2: (−s, −c); m = 3: (−c, s).)
    let sin = w.select(neg_sin, w.neg(a), a);
    let cos = w.select(neg_cos, w.neg(b), b);
    (sin, cos)
}

/// `warp::sin_cos_quarter` in the lanes: Cephes' polynomials for x ∈ [−π/4, π/4].
#[inline(always)]
pub(super) fn sin_cos_quarter<W: Wide>(w: W, t: W::V) -> (W::V, W::V) {
    let one = w.splat(1.0);
    let z = w.mul(t, t);
    let sin = w.add(
        w.mul(
            w.mul(
                w.sub(
                    w.mul(
                        w.add(w.mul(w.splat(-1.951_529_6e-4), z), w.splat(8.332_161e-3)),
                        z,
                    ),
                    w.splat(1.666_665_5e-1),
                ),
                z,
            ),
            t,
        ),
        t,
    );
    let cos = w.add(
        w.sub(
            w.mul(
                w.mul(
                    w.add(
                        w.mul(
                            w.sub(w.mul(w.splat(2.443_315_7e-5), z), w.splat(1.388_731_6e-3)),
                            z,
                        ),
                        w.splat(4.166_664_6e-2),
                    ),
                    z,
                ),
                z,
            ),
            w.mul(w.splat(0.5), z),
        ),
        one,
    );
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Bsdf, BsdfModel, Distribution, Microfacet};
    use crate::math::{Frame, Vec3, BATCH};
    use crate::sampling::Pcg32;
    use crate::simd::{SimdLevel, WideKernel};
    use crate::spectrum::SampledSpectrum;

    type L = [f32; BATCH];

    /// Sixteen rough conductors and their inputs.
    #[derive(Clone, Default)]
    struct Case {
        wo: [L; 3],
        wi: [L; 3],
        alpha: L,
        fresnel: u32,
        eta: [L; 4],
        k: [L; 4],
        r: [L; 4],
        u: [L; 2],
    }

    /// The lanes' results: f and pdf for `wi`, the sample's direction, density, weight and
    /// lanes.
    type Out = ([L; 4], L, [L; 3], L, [L; 4], u32);

    impl WideKernel for &Case {
        type Output = Out;
        fn run<W: Wide>(self, w: W) -> Out {
            let load3 = |a: &[L; 3]| [w.load(&a[0]), w.load(&a[1]), w.load(&a[2])];
            let load4 = |a: &[L; 4]| [w.load(&a[0]), w.load(&a[1]), w.load(&a[2]), w.load(&a[3])];
            let c = Conductor {
                on: w.mask(u32::MAX),
                wo: load3(&self.wo),
                alpha: w.load(&self.alpha),
                fresnel: w.mask(self.fresnel),
                eta: load4(&self.eta),
                k: load4(&self.k),
            };
            let r = load4(&self.r);
            let (f, pdf) = eval_pdf(w, &c, &r, load3(&self.wi));
            let Sample {
                wi: swi,
                pdf: spdf,
                weight: sweight,
                ok,
            } = sample(w, &c, &r, [w.load(&self.u[0]), w.load(&self.u[1])]);
            let mut out: Out = Default::default();
            for k in 0..4 {
                w.store(f[k], &mut out.0[k]);
                w.store(sweight[k], &mut out.4[k]);
            }
            w.store(pdf, &mut out.1);
            for k in 0..3 {
                w.store(swi[k], &mut out.2[k]);
            }
            w.store(spdf, &mut out.3);
            out.5 = w.bits(ok);
            out
        }
    }

    fn random_case(rng: &mut Pcg32) -> Case {
        let mut c = Case::default();
        for i in 0..BATCH {
            let dir = |rng: &mut Pcg32, below: bool| {
                Vec3::new(
                    rng.next_f32() - 0.5,
                    rng.next_f32() - 0.5,
                    rng.next_f32() - if below { 0.7 } else { 0.02 },
                )
                .normalize()
            };
            let wo = dir(rng, i % 7 == 0);
            let wi = dir(rng, i % 5 == 0);
            for k in 0..3 {
                c.wo[k][i] = [wo.x, wo.y, wo.z][k];
                c.wi[k][i] = [wi.x, wi.y, wi.z][k];
            }
            c.alpha[i] = Microfacet::new(Distribution::Ggx, rng.next_f32().powi(2)).alpha;
            if i % 3 != 0 {
                c.fresnel |= 1 << i;
            }
            for k in 0..4 {
                c.eta[k][i] = 0.1 + 2.0 * rng.next_f32();
                c.k[k][i] = 4.0 * rng.next_f32();
                c.r[k][i] = if i % 11 == 0 { 0.0 } else { rng.next_f32() };
            }
            c.u[0][i] = rng.next_f32();
            c.u[1][i] = if i == 3 { 0.875 } else { rng.next_f32() };
        }
        c
    }

    /// Every lane gets the bits `Bsdf` gives for the same rough conductor, with every
    /// instruction set: its value and density for a direction, and its sample.
    #[test]
    fn lanes_agree_with_the_scalar_rough_conductor_bit_for_bit() {
        let mut rng = Pcg32::new(9, 2);
        let mut seen = [0; 3];
        for _ in 0..400 {
            let c = random_case(&mut rng);
            let levels = [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512];
            let outs: Vec<Out> = levels
                .iter()
                .filter(|&&l| l <= SimdLevel::supported())
                .map(|&l| crate::simd::run_wide_at(l, &c))
                .collect();
            for (f, pdf, swi, spdf, sweight, ok) in outs {
                for i in 0..BATCH {
                    let s4 = |a: &[L; 4]| SampledSpectrum([a[0][i], a[1][i], a[2][i], a[3][i]]);
                    let v3 = |a: &[L; 3]| Vec3::new(a[0][i], a[1][i], a[2][i]);
                    let bsdf = Bsdf {
                        model: BsdfModel::RoughConductor {
                            mf: Microfacet::new(Distribution::Ggx, c.alpha[i]),
                            eta_k: (c.fresnel >> i & 1 != 0).then(|| (s4(&c.eta), s4(&c.k))),
                            r: s4(&c.r),
                        },
                        frame: Frame::new(Vec3::X, Vec3::Y, Vec3::Z),
                        two_sided: false,
                    };
                    let (wo, wi) = (v3(&c.wo), v3(&c.wi));
                    let (f_s, pdf_s) = bsdf.eval_pdf_local(wo, wi);
                    assert_eq!(s4(&f).0.map(f32::to_bits), f_s.0.map(f32::to_bits), "f {i}");
                    assert_eq!(pdf[i].to_bits(), pdf_s.to_bits(), "pdf {i}");
                    let sample = bsdf.sample_local(wo, false, 0.5, [c.u[0][i], c.u[1][i]]);
                    // The lanes' direction through the same identity frame.
                    let o = v3(&swi);
                    let o = Vec3::X * o.x + Vec3::Y * o.y + Vec3::Z * o.z;
                    let lane_ok = ok >> i & 1 != 0 && s4(&sweight).is_finite() && o.is_finite();
                    match sample {
                        Some(s) => {
                            assert!(lane_ok, "sample {i}");
                            assert_eq!(o, s.wi, "wi {i}");
                            assert_eq!(spdf[i].to_bits(), s.pdf.to_bits(), "spdf {i}");
                            let b = s4(&sweight).0.map(f32::to_bits);
                            assert_eq!(b, s.weight.0.map(f32::to_bits), "weight {i}");
                            seen[0] += 1;
                        }
                        None => {
                            assert!(!lane_ok, "no sample {i}");
                            seen[1] += 1;
                        }
                    }
                    seen[2] += (!f_s.is_black()) as u32;
                }
            }
        }
        assert!(seen.iter().all(|&k| k > 200), "{seen:?}");
    }

    /// The lanes' turn sine and cosine are `sin_cos_turn`'s, at every quarter and between.
    #[test]
    fn turn_sine_and_cosine_agree_with_the_scalar_ones() {
        struct Turn(L);
        impl WideKernel for &Turn {
            type Output = (L, L);
            fn run<W: Wide>(self, w: W) -> (L, L) {
                let (s, c) = sin_cos_turn(w, w.load(&self.0));
                let mut out = ([0.0; BATCH], [0.0; BATCH]);
                w.store(s, &mut out.0);
                w.store(c, &mut out.1);
                out
            }
        }
        for j in 0..4096u32 {
            let mut u = [0.0; BATCH];
            for (i, u) in u.iter_mut().enumerate() {
                // Near and at the quarter boundaries, and everywhere.
                let x = (j * BATCH as u32 + i as u32) as f32 / (4096.0 * BATCH as f32);
                *u = if i % 4 == 0 {
                    (x * 8.0).round() / 8.0
                } else {
                    x
                };
            }
            let (s, c) = crate::simd::run_wide_at(SimdLevel::supported(), &Turn(u));
            for i in 0..BATCH {
                let (ss, cs) = crate::sampling::warp::sin_cos_turn(u[i]);
                assert_eq!(
                    (s[i].to_bits(), c[i].to_bits()),
                    (ss.to_bits(), cs.to_bits())
                );
            }
        }
    }
}
