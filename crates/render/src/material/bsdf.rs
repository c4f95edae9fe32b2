//! The BSDF at a surface point: a material's model with its textures resolved, in the shading
//! frame. `eval` includes the cosine, `sample` takes uniform numbers, `pdf` is per unit solid
//! angle (0 for Dirac deltas); two-sided BSDFs mirror the back side onto the front.

use super::cook_torrance::CookTorrance;
use super::microfacet::Microfacet;
use super::phong::PhongBrdf;
use super::plastic::{Plastic, RoughPlastic};
use super::sample::{BsdfSample, LocalSample};
use super::{conductor, dielectric, lambert, specular};
use crate::math::{Frame, Vec3};
use crate::spectrum::SampledSpectrum;

/// A material's scattering at one point, textures resolved.
#[derive(Clone, Copy, Debug)]
pub enum BsdfModel<'a> {
    /// Lambert.
    Lambert(SampledSpectrum),
    /// Perfect mirror or smooth conductor.
    Mirror {
        /// Reflectance.
        r: SampledSpectrum,
        /// Conductor index, or `None` for F = 1.
        eta_k: Option<(SampledSpectrum, SampledSpectrum)>,
    },
    /// Rough conductor.
    RoughConductor {
        /// Distribution.
        mf: Microfacet,
        /// Conductor index.
        eta_k: Option<(SampledSpectrum, SampledSpectrum)>,
        /// Reflectance.
        r: SampledSpectrum,
    },
    /// Smooth dielectric.
    Dielectric {
        /// Relative index.
        eta: f32,
        /// Reflection scale.
        r: SampledSpectrum,
        /// Transmission scale.
        t: SampledSpectrum,
    },
    /// Rough dielectric.
    RoughDielectric {
        /// Distribution.
        mf: Microfacet,
        /// Relative index.
        eta: f32,
        /// Reflection scale.
        r: SampledSpectrum,
        /// Transmission scale.
        t: SampledSpectrum,
    },
    /// Smooth plastic.
    Plastic(Plastic),
    /// Rough plastic.
    RoughPlastic(RoughPlastic<'a>),
    /// Phong or Blinn–Phong.
    Phong(PhongBrdf),
    /// Cook–Torrance.
    CookTorrance(CookTorrance),
}

/// A BSDF at a surface point: the model in its shading frame.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf<'a> {
    /// The resolved model.
    pub model: BsdfModel<'a>,
    /// Local frame (z = shading normal as the shape orients it).
    pub frame: Frame,
    /// Mirror the back side onto the front.
    pub two_sided: bool,
}

impl Bsdf<'_> {
    /// Local directions, mirrored to the front when two-sided and seen from the back.
    #[inline]
    fn local(&self, wo: Vec3, wi: Vec3) -> (Vec3, Vec3, bool) {
        let (o, flip) = self.local_wo(wo);
        (o, self.local_wi(wi, flip), flip)
    }

    /// The outgoing direction `wo` (world, unit) in the local frame, mirrored to the front when
    /// the BSDF is two-sided and seen from the back, and whether it was mirrored: computed once
    /// per vertex for [`Bsdf::local_wi`], [`Bsdf::eval_local`], [`Bsdf::pdf_local`] and
    /// [`Bsdf::sample_local`].
    #[inline]
    pub fn local_wo(&self, wo: Vec3) -> (Vec3, bool) {
        local_wo(&self.frame, self.two_sided, wo)
    }

    /// The incident direction `wi` (world, unit) in the local frame, mirrored like `wo`.
    #[inline]
    pub fn local_wi(&self, wi: Vec3, flip: bool) -> Vec3 {
        let mut i = self.frame.to_local(wi);
        if flip {
            i.z = -i.z;
        }
        i
    }

    /// f(wo, wi)·|cos θi| (world directions, unit).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let (o, i, _) = self.local(wo, wi);
        self.eval_local(o, i)
    }

    /// [`Bsdf::eval`] for directions from [`Bsdf::local_wo`] and [`Bsdf::local_wi`].
    #[inline(always)]
    pub fn eval_local(&self, o: Vec3, i: Vec3) -> SampledSpectrum {
        // Lambert, the common case, without a call.
        if let BsdfModel::Lambert(r) = &self.model {
            return lambert::eval(*r, o, i);
        }
        self.eval_general(o, i)
    }

    /// [`Bsdf::eval_local`] for every model.
    #[inline(never)]
    fn eval_general(&self, o: Vec3, i: Vec3) -> SampledSpectrum {
        match &self.model {
            BsdfModel::Lambert(r) => lambert::eval(*r, o, i),
            BsdfModel::Mirror { .. } | BsdfModel::Dielectric { .. } => SampledSpectrum::ZERO,
            BsdfModel::RoughConductor { mf, eta_k, r } => conductor::eval(mf, *eta_k, *r, o, i),
            BsdfModel::RoughDielectric { mf, eta, r, t } => {
                dielectric::eval_rough(mf, *eta, *r, *t, o, i)
            }
            BsdfModel::Plastic(p) => p.eval(o, i),
            BsdfModel::RoughPlastic(p) => p.eval(o, i),
            BsdfModel::Phong(p) => p.eval(o, i),
            BsdfModel::CookTorrance(c) => c.eval(o, i),
        }
    }

    /// [`Bsdf::eval_local`] and [`Bsdf::pdf_local`] of one pair at once (the microfacet
    /// models share their terms): the same numbers, bit for bit.
    #[inline(always)]
    pub fn eval_pdf_local(&self, o: Vec3, i: Vec3) -> (SampledSpectrum, f32) {
        // Lambert, the common case, without a call.
        if let BsdfModel::Lambert(r) = &self.model {
            return (lambert::eval(*r, o, i), lambert::pdf(o, i));
        }
        self.eval_pdf_general(o, i)
    }

    /// [`Bsdf::eval_pdf_local`] for every model.
    #[inline(never)]
    fn eval_pdf_general(&self, o: Vec3, i: Vec3) -> (SampledSpectrum, f32) {
        match &self.model {
            BsdfModel::RoughConductor { mf, eta_k, r } => conductor::eval_pdf(mf, *eta_k, *r, o, i),
            BsdfModel::RoughPlastic(p) => p.eval_pdf(o, i),
            _ => (self.eval_general(o, i), self.pdf_general(o, i)),
        }
    }

    /// The density with which [`Bsdf::sample`] returns `wi` (0 for delta components).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (o, i, _) = self.local(wo, wi);
        self.pdf_local(o, i)
    }

    /// [`Bsdf::pdf`] for directions from [`Bsdf::local_wo`] and [`Bsdf::local_wi`].
    #[inline(always)]
    pub fn pdf_local(&self, o: Vec3, i: Vec3) -> f32 {
        // Lambert, the common case, without a call.
        if let BsdfModel::Lambert(_) = &self.model {
            return lambert::pdf(o, i);
        }
        self.pdf_general(o, i)
    }

    /// [`Bsdf::pdf_local`] for every model.
    #[inline(never)]
    fn pdf_general(&self, o: Vec3, i: Vec3) -> f32 {
        match &self.model {
            BsdfModel::Lambert(_) => lambert::pdf(o, i),
            BsdfModel::Mirror { .. } | BsdfModel::Dielectric { .. } => 0.0,
            BsdfModel::RoughConductor { mf, .. } => conductor::microfacet_pdf(mf, o, i),
            BsdfModel::RoughDielectric { mf, eta, .. } => dielectric::pdf_rough(mf, *eta, o, i),
            BsdfModel::Plastic(p) => p.pdf(o, i),
            BsdfModel::RoughPlastic(p) => p.pdf(o, i),
            BsdfModel::Phong(p) => p.pdf(o, i),
            BsdfModel::CookTorrance(c) => c.pdf(o, i),
        }
    }

    /// Samples an incident direction for the outgoing direction `wo`, from the uniform numbers
    /// `u1` (lobe choice) and `u2`.
    pub fn sample(&self, wo: Vec3, u1: f32, u2: [f32; 2]) -> Option<BsdfSample> {
        let (o, flip) = self.local_wo(wo);
        self.sample_local(o, flip, u1, u2)
    }

    /// [`Bsdf::sample`] for `wo` from [`Bsdf::local_wo`] (`o` and `flip`).
    #[inline(always)]
    pub fn sample_local(&self, o: Vec3, flip: bool, u1: f32, u2: [f32; 2]) -> Option<BsdfSample> {
        // Lambert, the common case, without a call.
        let s = if let BsdfModel::Lambert(r) = &self.model {
            lambert::sample(*r, o, u2)
        } else {
            self.sample_general(o, u1, u2)
        }?;
        self.world_sample(s, flip)
    }

    /// The local sample `s` in world space (mirrored back when `wo` was), or `None` when not
    /// finite.
    #[inline(always)]
    fn world_sample(&self, s: LocalSample, flip: bool) -> Option<BsdfSample> {
        let wi = world_wi(&self.frame, &s, flip)?;
        Some(BsdfSample {
            wi,
            weight: s.weight,
            pdf: s.pdf,
            delta: s.delta,
            eta: s.eta,
        })
    }

    /// The local sample of every model.
    #[inline(never)]
    fn sample_general(&self, o: Vec3, u1: f32, u2: [f32; 2]) -> Option<LocalSample> {
        match &self.model {
            BsdfModel::Lambert(r) => lambert::sample(*r, o, u2),
            BsdfModel::Mirror { r, eta_k } => specular::sample(*r, *eta_k, o),
            BsdfModel::RoughConductor { mf, eta_k, r } => conductor::sample(mf, *eta_k, *r, o, u2),
            BsdfModel::Dielectric { eta, r, t } => dielectric::sample_smooth(*eta, *r, *t, o, u1),
            BsdfModel::RoughDielectric { mf, eta, r, t } => {
                dielectric::sample_rough(mf, *eta, *r, *t, o, u1, u2)
            }
            BsdfModel::Plastic(p) => p.sample(o, u1, u2),
            BsdfModel::RoughPlastic(p) => p.sample(o, u1, u2),
            BsdfModel::Phong(p) => p.sample(o, u1, u2),
            BsdfModel::CookTorrance(c) => c.sample(o, u1, u2),
        }
    }

    /// True when the BSDF only reflects: it is zero unless `wo` and `wi` lie on the same side
    /// of the shading normal (every model but the dielectrics).
    #[inline]
    pub fn reflects_only(&self) -> bool {
        !matches!(
            self.model,
            BsdfModel::Dielectric { .. } | BsdfModel::RoughDielectric { .. }
        )
    }

    /// True when every component is a Dirac delta (light sampling cannot help).
    pub fn is_delta(&self) -> bool {
        matches!(
            self.model,
            BsdfModel::Mirror { .. } | BsdfModel::Dielectric { .. }
        )
    }
}

/// The outgoing direction in its plane of incidence, for the delta BSDFs (mirrors and smooth
/// interfaces) without a shading frame: a reflection or a refraction keeps the direction's
/// part in the tangent plane, only scaled (by −1, or −η′), so a model may sample the local
/// direction (1, 0, cos θo) ([`IncidencePlane::local_wo`]; the models read only its z and
/// scale its x and y), and the world direction is the sample's z times the normal plus its
/// x times wo's tangent part ([`IncidencePlane::world_wi`]). The cosines, hence the weights
/// and densities, are those [`local_wo`] gives, bit for bit; the directions are those of
/// [`world_wi`] up to rounding.
#[derive(Clone, Copy, Debug)]
pub struct IncidencePlane {
    n: Vec3,
    cos_o: f32,
    tangent: Vec3,
}

impl IncidencePlane {
    /// `wo` (world, unit) at the unit shading normal `n`.
    #[inline(always)]
    pub fn new(n: Vec3, wo: Vec3) -> Self {
        let cos_o = wo.dot(n);
        Self {
            n,
            cos_o,
            tangent: wo - n * cos_o,
        }
    }

    /// [`local_wo`]: wo in the plane's local coordinates, mirrored to the upper side when the
    /// surface is `two_sided` and seen from the back; and whether it was mirrored.
    #[inline(always)]
    pub fn local_wo(&self, two_sided: bool) -> (Vec3, bool) {
        let flip = two_sided && self.cos_o < 0.0;
        let z = if flip { -self.cos_o } else { self.cos_o };
        (Vec3::new(1.0, 0.0, z), flip)
    }

    /// [`world_wi`]: the world direction of a sample of a delta model taken at
    /// [`IncidencePlane::local_wo`], when it and the sample's weight are finite.
    #[inline(always)]
    pub fn world_wi(&self, s: &LocalSample, flip: bool) -> Option<Vec3> {
        let z = if flip { -s.wi.z } else { s.wi.z };
        let wi = self.n * z + self.tangent * s.wi.x;
        (s.weight.is_finite() && wi.is_finite()).then_some(wi)
    }
}

/// `wo` (world, unit) in the local space of `frame`, mirrored to the upper side when the
/// surface is `two_sided` and seen from the back; and whether it was mirrored.
#[inline(always)]
pub fn local_wo(frame: &Frame, two_sided: bool, wo: Vec3) -> (Vec3, bool) {
    let mut o = frame.to_local(wo);
    let flip = two_sided && o.z < 0.0;
    if flip {
        o.z = -o.z;
    }
    (o, flip)
}

/// The direction of the local sample `s` in the world (mirrored back when `flip`), when it and
/// the sample's weight are finite.
#[inline(always)]
pub fn world_wi(frame: &Frame, s: &LocalSample, flip: bool) -> Option<Vec3> {
    let mut wi = s.wi;
    if flip {
        wi.z = -wi.z;
    }
    let wi = frame.to_world(wi);
    (s.weight.is_finite() && wi.is_finite()).then_some(wi)
}

#[cfg(test)]
mod tests {
    use super::super::dielectric::sample_smooth;
    use super::super::specular;
    use super::*;
    use crate::math::Normal3;
    use crate::sampling::pcg::Pcg32;
    use crate::spectrum::SampledSpectrum;

    /// A delta model's sample at a local wo, number and reflectance and transmittance.
    type Model = fn(Vec3, f32, SampledSpectrum, SampledSpectrum) -> Option<LocalSample>;

    fn unit(rng: &mut Pcg32) -> Vec3 {
        loop {
            let v = Vec3::new(
                rng.next_f32() * 2.0 - 1.0,
                rng.next_f32() * 2.0 - 1.0,
                rng.next_f32() * 2.0 - 1.0,
            );
            let n2 = v.squared_norm();
            if n2 > 1e-4 && n2 <= 1.0 {
                return v / n2.sqrt();
            }
        }
    }

    /// Mirrors (one- and two-sided) and smooth glass (from either side, total internal
    /// reflection included) sampled in the plane of incidence give what they give through a
    /// shading frame: the same weights, densities and indices, bit for bit, and the same world
    /// directions within rounding; and those directions are reflections and refractions
    /// (unit, in the plane of wo and n, at the angle Snell's law gives).
    #[test]
    fn the_plane_of_incidence_samples_as_a_frame_does() {
        let mut rng = Pcg32::new(3, 5);
        let (r, t) = (SampledSpectrum::splat(0.9), SampledSpectrum::splat(0.8));
        let mut refracted = 0;
        for i in 0..4000 {
            let n = unit(&mut rng);
            let frame = Frame::from_normal_tangent(Normal3::new(n.x, n.y, n.z), unit(&mut rng));
            let n = frame.n;
            let wo = unit(&mut rng);
            let plane = IncidencePlane::new(n, wo);
            let two_sided = i % 2 == 0;
            let u = rng.next_f32();
            const ETA: f32 = 1.5;
            let cases: [(bool, Model); 2] = [
                (two_sided, |o, _, r, _| specular::sample(r, None, o)),
                (false, |o, u, r, t| sample_smooth(ETA, r, t, o, u)),
            ];
            for (sided, sample) in cases {
                let (fo, fflip) = local_wo(&frame, sided, wo);
                let (po, pflip) = plane.local_wo(sided);
                assert_eq!((fo.z, fflip), (po.z, pflip));
                let (Some(fs), Some(ps)) = (sample(fo, u, r, t), sample(po, u, r, t)) else {
                    assert!(sample(fo, u, r, t).is_none() && sample(po, u, r, t).is_none());
                    continue;
                };
                assert_eq!((fs.weight, fs.pdf, fs.eta), (ps.weight, ps.pdf, ps.eta));
                let fw = world_wi(&frame, &fs, fflip).unwrap();
                let pw = plane.world_wi(&ps, pflip).unwrap();
                // Within rounding: f32 directions through a Gram–Schmidt frame differ by a
                // few units in the sixth decimal.
                assert!(fw.approx_eq(pw, 1e-5), "{fw:?} {pw:?}");
                assert!((pw.norm() - 1.0).abs() < 1e-5);
                // In the plane of wo and n, on the side and at the angle of the law.
                assert!(n.cross(wo).dot(pw).abs() < 1e-5);
                let (ci, co) = (wo.dot(n), pw.dot(n));
                if ci * co > 0.0 {
                    assert!((ci - co).abs() < 1e-5);
                } else {
                    refracted += 1;
                    let eta_p = if ci > 0.0 { ETA } else { 1.0 / ETA };
                    let (si, so) = ((1.0 - ci * ci).sqrt(), (1.0 - co * co).max(0.0).sqrt());
                    assert!((si - eta_p * so).abs() < 1e-5, "{si} {so} {eta_p}");
                }
            }
        }
        assert!(refracted > 1000, "{refracted}");
    }
}
