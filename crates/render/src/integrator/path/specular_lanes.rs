//! The mirror and smooth-glass vertices of a batch, shaded sixteen at once.
//!
//! [`super::Path::radiance_batch`] runs the start of every vertex lane by lane (the hit's
//! interaction, the emission it finds, the material's colours and relative index, the numbers
//! the vertex draws). At a Dirac-delta surface — a perfect mirror (`Model::Specular`, or a
//! smooth `Model::Conductor` without an index) or a smooth dielectric — nothing samples a light,
//! and the rest of the vertex is left here: the outgoing direction in the shading frame, the
//! dielectric's Fresnel reflectance and its choice between reflection and refraction, the new
//! direction in the world, the throughput (with the (η_i/η_t)² of radiance refracted across the
//! boundary), the product of squared indices that Russian roulette uses, the roulette itself,
//! and the next ray with its origin moved off the surface. [`SpecularLanes::shade`] does these
//! for all such lanes with the sixteen-lane operations of [`crate::simd::Wide`], puts the rays
//! straight into the batch, and [`SpecularLanes::finish`] gives each lane the rest.
//!
//! Every operation is the one the scalar vertex makes ([`crate::material::Bsdf::local_wo`],
//! the mirror's and the smooth dielectric's samples with
//! [`fresnel_dielectric`](crate::material::fresnel::fresnel_dielectric), the BSDF's world
//! sample, [`crate::interaction::SurfaceInteraction::spawn_ray`] and the roulette of
//! [`super::Path`]), on the same operands in the same order, so each path gets the same bits
//! as [`super::Path::radiance`] gives it alone (IEEE single precision, correctly rounded
//! division and square root, no fused multiply-add; the NaN cases of `max`/`min` aside, which
//! a finite throughput never meets).
//!
//! A dispersive glass on a spectral path keeps only its hero wavelength: the scalar part does
//! that (it resolves the index at the hero wavelength before the lane is set), so such lanes
//! are shaded here like any other glass.

use super::lambert_lanes::{dot, finite, max, offset, positive, put};
use crate::math::{Frame, Normal3, Point3, RayBatch, Vec3, BATCH};
use crate::simd::SimdLevel;
use crate::simd::{Wide, WideKernel};
use crate::spectrum::SampledSpectrum;

/// Sixteen f32 lanes.
type L = [f32; BATCH];

/// The deferred delta vertices of a batch step, structure of arrays: lane i is the path in
/// lane i of the batch (`Default`: no lanes).
#[derive(Default)]
pub(super) struct SpecularLanes {
    /// The lanes in use.
    pub(super) lanes: u32,
    /// The hit point and its unit geometric normal.
    p: [L; 3],
    ng: [L; 3],
    /// The shading frame and the (world, unit) outgoing direction.
    s: [L; 3],
    t: [L; 3],
    n: [L; 3],
    wo: [L; 3],
    /// Mirror lanes whose BSDF is two-sided (mirrored to the front when seen from the back).
    two_sided: u32,
    /// Dielectric lanes (the others are mirrors), with their relative index η, 1/η and
    /// 1/(1/η) (the scalar part divides: one lane's division is cheaper than sixteen, and off
    /// the kernel's chain of dependent operations).
    glass: u32,
    eta: L,
    inv_eta: L,
    inv_inv_eta: L,
    /// The reflectance (of a mirror or of a glass's reflection) and a glass's transmittance.
    r: [L; 4],
    tr: [L; 4],
    /// The throughput before the vertex and the product of squared indices (updated here).
    beta: [L; 4],
    eta_scale: L,
    /// The number that chooses between reflection and refraction, the roulette's number and
    /// the lanes that play the roulette here.
    u: L,
    u_rr: L,
    roulette: u32,
    // Outputs.
    /// Lanes whose path goes on, with the sample's probability `pdf` and the throughput
    /// `beta_out`, still to be divided by `q` in the lanes that played the roulette (four lanes
    /// of one path in one division: `finish` does it, for the few lanes that need it).
    alive: u32,
    pdf: L,
    beta_out: [L; 4],
    q: L,
}

/// What the scalar part of a vertex hands over for one delta lane.
pub(super) struct SpecularVertex {
    /// The hit point and its (unit) geometric normal.
    pub p: Point3,
    pub ng: Normal3,
    /// The shading frame and the outgoing direction (world, unit).
    pub frame: Frame,
    pub wo: Vec3,
    /// The surface, its colours in the path's lanes.
    pub bsdf: DeltaBsdf,
    /// The throughput.
    pub beta: SampledSpectrum,
    /// The number of the reflection/refraction choice and that of the roulette (`None`: no
    /// roulette here).
    pub u: f32,
    pub u_rr: Option<f32>,
    pub eta_scale: f32,
}

/// A Dirac-delta BSDF the lanes shade (`BsdfModel::Mirror` without a conductor's index, and
/// `BsdfModel::Dielectric`).
pub(super) enum DeltaBsdf {
    /// A perfect mirror (F = 1) scaled by a reflectance `r`, mirrored onto its front when
    /// `two_sided`.
    Mirror {
        /// The reflectance.
        r: SampledSpectrum,
        /// Scatters on both sides.
        two_sided: bool,
    },
    /// A smooth dielectric of relative index `eta` (interior over exterior).
    Glass {
        /// The relative index the path sees.
        eta: f32,
        /// Scales reflection.
        r: SampledSpectrum,
        /// Scales transmission.
        t: SampledSpectrum,
    },
}

/// What [`SpecularLanes::finish`] gives for a lane: the path's next throughput, the sample's
/// probability and the product of squared indices (`None`: the path ends here).
pub(super) struct SpecularOutcome {
    pub next: Option<(SampledSpectrum, f32, f32)>,
}

impl SpecularLanes {
    /// Puts lane `i`'s vertex in.
    #[inline(always)]
    pub(super) fn set(&mut self, i: usize, v: &SpecularVertex) {
        let bit = 1u32 << i;
        self.lanes |= bit;
        for (a, b) in [v.frame.s, v.frame.t, v.frame.n, v.wo].into_iter().zip([
            &mut self.s,
            &mut self.t,
            &mut self.n,
            &mut self.wo,
        ]) {
            b[0][i] = a.x;
            b[1][i] = a.y;
            b[2][i] = a.z;
        }
        self.p[0][i] = v.p.x;
        self.p[1][i] = v.p.y;
        self.p[2][i] = v.p.z;
        self.ng[0][i] = v.ng.x;
        self.ng[1][i] = v.ng.y;
        self.ng[2][i] = v.ng.z;
        self.two_sided &= !bit;
        self.glass &= !bit;
        match v.bsdf {
            DeltaBsdf::Mirror { r, two_sided } => {
                if two_sided {
                    self.two_sided |= bit;
                }
                put4(&mut self.r, i, r);
            }
            DeltaBsdf::Glass { eta, r, t } => {
                self.glass |= bit;
                let inv = 1.0 / eta;
                self.eta[i] = eta;
                self.inv_eta[i] = inv;
                self.inv_inv_eta[i] = 1.0 / inv;
                put4(&mut self.r, i, r);
                put4(&mut self.tr, i, t);
            }
        }
        put4(&mut self.beta, i, v.beta);
        self.eta_scale[i] = v.eta_scale;
        self.u[i] = v.u;
        self.roulette &= !bit;
        if let Some(u) = v.u_rr {
            self.roulette |= bit;
            self.u_rr[i] = u;
        }
    }

    /// Shades every lane in use (sixteen lanes at once, at the widest instruction set the CPU
    /// has). The rays of the lanes whose path goes on go straight into `next`;
    /// [`SpecularLanes::finish`] gives the rest.
    pub(super) fn shade(&mut self, next: &mut RayBatch) {
        self.shade_at(SimdLevel::detected(), next);
    }

    /// [`SpecularLanes::shade`] with the instructions of `level` (or the widest below it that
    /// the CPU has).
    pub(super) fn shade_at(&mut self, level: SimdLevel, next: &mut RayBatch) {
        // Only the lanes in use count (the other lanes hold an earlier step's values).
        let m = self.lanes;
        for mask in [&mut self.two_sided, &mut self.glass, &mut self.roulette] {
            *mask &= m;
        }
        crate::simd::run_wide_at(level, Shade(self, next));
    }

    /// What is left of lane `i` once [`SpecularLanes::shade`] has run: the path's next
    /// throughput, the sample's probability and the product of squared indices (its ray is in
    /// the batch already).
    #[inline(always)]
    pub(super) fn finish(&self, i: usize) -> SpecularOutcome {
        let bit = 1u32 << i;
        let next = (self.alive & bit != 0).then(|| {
            let beta = SampledSpectrum([
                self.beta_out[0][i],
                self.beta_out[1][i],
                self.beta_out[2][i],
                self.beta_out[3][i],
            ]);
            let beta = if self.roulette & bit != 0 {
                beta / self.q[i]
            } else {
                beta
            };
            (beta, self.pdf[i], self.eta_scale[i])
        });
        SpecularOutcome { next }
    }
}

/// `s` into lane `i` of `a`.
#[inline(always)]
fn put4(a: &mut [L; 4], i: usize, s: SampledSpectrum) {
    for k in 0..4 {
        a[k][i] = s.0[k];
    }
}

/// [`SpecularLanes::shade`] as a kernel.
struct Shade<'a>(&'a mut SpecularLanes, &'a mut RayBatch);

impl WideKernel for Shade<'_> {
    type Output = ();

    #[inline(always)]
    fn run<W: Wide>(self, w: W) -> Self::Output {
        let Shade(x, next) = self;
        let zero = w.splat(0.0);
        let one = w.splat(1.0);
        let all = w.mask(x.lanes);

        // `Bsdf::local_wo`: the outgoing direction in the shading frame, mirrored to the front
        // when a two-sided mirror is seen from the back (a dielectric is never two-sided).
        let s = [w.load(&x.s[0]), w.load(&x.s[1]), w.load(&x.s[2])];
        let t = [w.load(&x.t[0]), w.load(&x.t[1]), w.load(&x.t[2])];
        let n = [w.load(&x.n[0]), w.load(&x.n[1]), w.load(&x.n[2])];
        let wo = [w.load(&x.wo[0]), w.load(&x.wo[1]), w.load(&x.wo[2])];
        let (ox, oy, oz) = (dot(w, wo, s), dot(w, wo, t), dot(w, wo, n));
        let flip = w.and(w.mask(x.two_sided), w.lt(oz, zero));
        let oz = w.select(flip, w.neg(oz), oz);

        // `fresnel_dielectric(oz, η)`: the relative indices along the direction of travel,
        // Snell's law for the squared cosine of the refracted direction, the reflectance; then
        // `dielectric::sample_smooth`: reflection with probability F, else refraction. A mirror
        // always reflects (F = 1, its reflectance the weight), and only from its front.
        let mut ok = positive(w, all, oz);
        let (mut refract, mut lx, mut ly, mut lz) = (w.mask(0), w.neg(ox), w.neg(oy), oz);
        let (mut pdf, mut eta_s, mut t2) = (one, one, one);
        if x.glass != 0 {
            let glass = w.mask(x.glass);
            let eta = w.load(&x.eta);
            let outside = w.ge(oz, zero);
            let inv_eta = w.load(&x.inv_eta);
            let eta_it = w.select(outside, eta, inv_eta);
            let eta_ti = w.select(outside, inv_eta, eta);
            let cos_t2 = w.sub(one, w.mul(w.mul(w.sub(one, w.mul(oz, oz)), eta_ti), eta_ti));
            let ci = w.copysign(oz, one);
            let ct = w.sqrt(cos_t2);
            let e_ct = w.mul(eta_it, ct);
            let e_ci = w.mul(eta_it, ci);
            let a_s = w.div(w.sub(ci, e_ct), w.add(ci, e_ct));
            let a_p = w.div(w.sub(ct, e_ci), w.add(ct, e_ci));
            let f = w.mul(w.splat(0.5), w.add(w.mul(a_s, a_s), w.mul(a_p, a_p)));
            let cos_t = w.select(outside, w.neg(ct), ct);
            // Total internal reflection (or grazing incidence), then an index-matched
            // interface.
            let total = w.or(w.le(cos_t2, zero), w.eq(ci, zero));
            let f = w.select(total, one, f);
            let cos_t = w.select(total, zero, cos_t);
            let matched = w.eq(eta, one);
            let f = w.select(matched, zero, f);
            let cos_t = w.select(matched, w.neg(oz), cos_t);
            // `!(u < F)`: a NaN F refracts, as in the scalar code.
            refract = w.and_not(glass, w.lt(w.load(&x.u), f));
            ok = w.or(ok, glass);
            let neg_eta_ti = w.neg(eta_ti);
            lx = w.select(refract, w.mul(neg_eta_ti, ox), lx);
            ly = w.select(refract, w.mul(neg_eta_ti, oy), ly);
            lz = w.select(refract, cos_t, lz);
            pdf = w.select(glass, w.select(refract, w.sub(one, f), f), one);
            // 1/η_ti.
            eta_s = w.select(
                refract,
                w.select(outside, w.load(&x.inv_inv_eta), inv_eta),
                one,
            );
            t2 = w.mul(eta_ti, eta_ti);
        }
        let r = [
            w.load(&x.r[0]),
            w.load(&x.r[1]),
            w.load(&x.r[2]),
            w.load(&x.r[3]),
        ];
        let mut weight = r;
        for k in 0..4 {
            let tr = w.mul(w.load(&x.tr[k]), t2);
            weight[k] = w.select(refract, tr, r[k]);
            ok = w.and(ok, finite(w, weight[k]));
        }

        // `Bsdf::world_sample`: mirrored back, then into the world.
        let lz = w.select(flip, w.neg(lz), lz);
        let mut wi = [zero; 3];
        for k in 0..3 {
            wi[k] = w.add(w.add(w.mul(s[k], lx), w.mul(t[k], ly)), w.mul(n[k], lz));
            ok = w.and(ok, finite(w, wi[k]));
        }

        // The throughput, the product of squared indices, and Russian roulette:
        // q = min(max(β)·Πη², 0.95).
        let mut b = [zero; 4];
        let mut b_nonzero = w.mask(0);
        for k in 0..4 {
            b[k] = w.mul(w.load(&x.beta[k]), weight[k]);
            b_nonzero = w.or(b_nonzero, w.ne(b[k], zero));
        }
        ok = w.and(ok, b_nonzero);
        let eta_scale = w.mul(w.load(&x.eta_scale), w.mul(eta_s, eta_s));
        let m = max(w, max(w, b[0], b[1]), max(w, b[2], b[3]));
        let q = w.mul(m, eta_scale);
        let q = w.select(w.lt(w.splat(0.95), q), w.splat(0.95), q);
        let roulette = w.mask(x.roulette);
        let survive = w.lt(w.load(&x.u_rr), q);
        ok = w.and(ok, w.or(w.and_not(all, roulette), survive));
        for k in 0..4 {
            w.store(b[k], &mut x.beta_out[k]);
        }
        w.store(q, &mut x.q);
        w.store(pdf, &mut x.pdf);
        w.store(eta_scale, &mut x.eta_scale);
        x.alive = w.bits(ok);

        // The rays, their origins moved off the surface as `Ray::spawn_unit` moves them.
        let p = [w.load(&x.p[0]), w.load(&x.p[1]), w.load(&x.p[2])];
        let ng = [w.load(&x.ng[0]), w.load(&x.ng[1]), w.load(&x.ng[2])];
        let o = offset(w, p, ng, wi);
        for k in 0..3 {
            put(w, ok, o[k], &mut next.o[k]);
            put(w, ok, wi[k], &mut next.d[k]);
        }
        put(w, ok, zero, &mut next.tmin);
        put(w, ok, w.splat(f32::INFINITY), &mut next.tmax);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// Lanes of every kind, from random numbers: mirrors one- and two-sided, seen from both
    /// sides; glass seen from outside and inside (total internal reflection), index-matched
    /// glass; black colours; roulette on some lanes.
    fn random_lanes(rng: &mut Pcg32) -> SpecularLanes {
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
        let mut lanes = SpecularLanes::default();
        for i in 0..BATCH {
            let n = v(rng).normalize();
            let frame = Frame::from_normal(n.to_normal());
            let colour = |rng: &mut Pcg32| {
                if i % 7 == 3 {
                    SampledSpectrum::ZERO
                } else {
                    s(rng, 1.0)
                }
            };
            let bsdf = if i % 3 == 0 {
                DeltaBsdf::Mirror {
                    r: colour(rng),
                    two_sided: i % 2 == 0,
                }
            } else {
                DeltaBsdf::Glass {
                    eta: match i % 5 {
                        0 => 1.0,
                        1 => 1.0 / 1.33,
                        _ => 1.0 + rng.next_f32(),
                    },
                    r: colour(rng),
                    t: colour(rng),
                }
            };
            let p = Point3::ORIGIN + v(rng) * if i % 4 == 0 { 0.01 } else { 5.0 };
            let vertex = SpecularVertex {
                p,
                ng: v(rng).normalize().to_normal(),
                frame,
                wo: v(rng).normalize(),
                bsdf,
                beta: s(rng, 1.0),
                u: rng.next_f32(),
                u_rr: (i % 3 != 1).then(|| rng.next_f32()),
                eta_scale: 0.5 + rng.next_f32(),
            };
            lanes.set(i, &vertex);
        }
        lanes.lanes = 0xefff;
        lanes
    }

    #[test]
    fn every_instruction_set_shades_the_same_bits() {
        let levels = [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512];
        let supported = SimdLevel::supported();
        let mut rng = Pcg32::new(5, 11);
        let mut seen = [0u32; 3];
        for _ in 0..50 {
            let mut results = Vec::new();
            for &level in levels.iter().filter(|&&l| l <= supported) {
                let mut lanes = random_lanes(&mut rng.clone());
                let mut next = RayBatch::default();
                lanes.shade_at(level, &mut next);
                let outcomes: Vec<Option<(Vec<u32>, u32, u32)>> = (0..BATCH)
                    .map(|i| {
                        lanes.finish(i).next.map(|(beta, pdf, eta_scale)| {
                            (
                                beta.0.map(f32::to_bits).to_vec(),
                                pdf.to_bits(),
                                eta_scale.to_bits(),
                            )
                        })
                    })
                    .collect();
                let bits =
                    |a: &[L]| -> Vec<u32> { a.iter().flat_map(|l| l.map(f32::to_bits)).collect() };
                results.push((
                    lanes.alive,
                    outcomes,
                    bits(&next.o),
                    bits(&next.d),
                    bits(&[next.tmin, next.tmax]),
                ));
            }
            assert!(results.windows(2).all(|w| w[0] == w[1]));
            assert_eq!(
                results.len(),
                levels.iter().filter(|&&l| l <= supported).count()
            );
            let alive = results[0].0;
            assert!(alive & !0xefff == 0);
            let lanes = random_lanes(&mut rng.clone());
            seen[0] += (alive & lanes.glass).count_ones();
            seen[1] += (alive & !lanes.glass).count_ones();
            seen[2] += (0xefff & !alive).count_ones();
            let _ = rng.next_u32();
        }
        // Glass and mirror lanes went on, and lanes ended.
        assert!(seen.iter().all(|&k| k > 20), "{seen:?}");
    }

    /// The lanes give what the scalar BSDF gives: `Bsdf::sample` of the same mirror or glass,
    /// bit for bit, and the same rays.
    #[test]
    fn lanes_agree_with_the_scalar_bsdf() {
        use crate::material::{Bsdf, BsdfModel};
        let mut rng = Pcg32::new(9, 2);
        let mut compared = 0;
        for _ in 0..50 {
            let mut lanes = random_lanes(&mut rng.clone());
            let before = random_lanes(&mut rng);
            let mut next = RayBatch::default();
            lanes.shade_at(SimdLevel::detected(), &mut next);
            for i in crate::math::lanes(0xefff) {
                let get3 = |a: &[L; 3]| Vec3::new(a[0][i], a[1][i], a[2][i]);
                let get4 = |a: &[L; 4]| SampledSpectrum([a[0][i], a[1][i], a[2][i], a[3][i]]);
                let frame = Frame::new(get3(&before.s), get3(&before.t), get3(&before.n));
                let glass = before.glass >> i & 1 != 0;
                let bsdf = Bsdf {
                    model: if glass {
                        BsdfModel::Dielectric {
                            eta: before.eta[i],
                            r: get4(&before.r),
                            t: get4(&before.tr),
                        }
                    } else {
                        BsdfModel::Mirror {
                            r: get4(&before.r),
                            eta_k: None,
                        }
                    },
                    frame,
                    two_sided: before.two_sided >> i & 1 != 0,
                };
                let wo = get3(&before.wo);
                let expected = bsdf.sample(wo, before.u[i], [0.5, 0.5]).and_then(|bs| {
                    let beta = get4(&before.beta) * bs.weight;
                    let eta_scale = before.eta_scale[i] * (bs.eta * bs.eta);
                    if beta.is_black() {
                        return None;
                    }
                    let mut beta = beta;
                    if before.roulette >> i & 1 != 0 {
                        let q = (beta.max_component() * eta_scale).min(0.95);
                        if !(before.u_rr[i] < q) {
                            return None;
                        }
                        beta /= q;
                    }
                    let p = Point3::new(before.p[0][i], before.p[1][i], before.p[2][i]);
                    let ng = get3(&before.ng).to_normal();
                    let ray = crate::math::Ray::spawn_unit(p, ng, bs.wi);
                    Some((beta, bs.pdf, eta_scale, ray))
                });
                let got = lanes
                    .finish(i)
                    .next
                    .map(|(beta, pdf, eta_scale)| (beta, pdf, eta_scale, next.ray(i)));
                let bits = |o: Option<(SampledSpectrum, f32, f32, crate::math::Ray)>| {
                    o.map(|(b, pdf, e, r)| {
                        let v = |a: [f32; 3]| a.map(f32::to_bits);
                        (
                            b.0.map(f32::to_bits),
                            pdf.to_bits(),
                            e.to_bits(),
                            v([r.o.x, r.o.y, r.o.z]),
                            v([r.d.x, r.d.y, r.d.z]),
                            r.tmin.to_bits(),
                            r.tmax.to_bits(),
                        )
                    })
                };
                assert_eq!(bits(got), bits(expected), "lane {i}");
                compared += got.is_some() as u32;
            }
            let _ = rng.next_u32();
        }
        assert!(compared > 100, "{compared}");
    }
}
