//! Materials: how surfaces scatter light.
//!
//! A [`Material`] is a closed set of models ([`Model`]) whose colour parameters are textures,
//! plus whether it scatters on both sides. At a hit, [`Material::bsdf`] resolves the textures
//! and returns a [`Bsdf`] by value (nothing is allocated); the BSDF works in the local shading
//! frame and offers:
//! - `eval(wo, wi)`: f(wo, wi)·|cos θi| (the cosine is included, as in Mitsuba);
//! - `sample(wo, u1, u2)`: a direction wi with its pdf and weight f·|cos θi|/pdf;
//! - `pdf(wo, wi)`: the density of `sample` (per unit solid angle; 0 for Dirac deltas).
//!
//! `wo` points to the viewer and `wi` to the light, both away from the surface.
//!
//! Every material of the candela language is two-sided (scene-language.md §2b): a ray arriving
//! on the back sees the same BSDF mirrored. Mitsuba's BSDFs are one-sided unless wrapped in
//! `twosided`; dielectrics have two sides by nature.
//!
//! The local model of the lectures (`local`, `direct`, `whitted`) has its own normalisation and
//! is evaluated by [`Material::local`].

mod conductor;
mod cook_torrance;
mod dielectric;
pub mod fresnel;
mod lambert;
pub mod microfacet;
mod phong;
mod plastic;
mod specular;

pub use cook_torrance::CookTorrance;
pub use microfacet::{Distribution, Microfacet};
pub use phong::{Lobe, PhongBrdf};
pub use plastic::{Plastic, RoughCoating, RoughPlastic};

use crate::color::Rgb;
use crate::math::{Frame, Normal3, Point2, Vec3, INV_PI};
use crate::texture::Texture;

/// Index of a material in the scene's table.
pub type MaterialId = u32;

/// The closed set of material models.
#[derive(Clone, Debug, PartialEq)]
pub enum Model {
    /// Lambertian ρ/π (`diffuse`).
    Diffuse {
        /// Reflectance ρ.
        reflectance: Texture,
    },
    /// A perfect mirror scaled by a reflectance (`specular`).
    Specular {
        /// Reflectance.
        reflectance: Texture,
    },
    /// Phong or Blinn–Phong (`phong`, `blinn_phong`).
    Phong {
        /// Which specular lobe.
        lobe: Lobe,
        /// Diffuse coefficient.
        kd: Texture,
        /// Specular coefficient.
        ks: Texture,
        /// Exponent.
        n: f32,
    },
    /// Cook–Torrance (`cook_torrance`).
    CookTorrance {
        /// Diffuse coefficient.
        kd: Texture,
        /// Specular coefficient.
        ks: Texture,
        /// Roughness and distribution.
        mf: Microfacet,
        /// Index of refraction of the Fresnel term.
        ior: f32,
    },
    /// A smooth or rough dielectric interface (`glass`, Mitsuba `dielectric`, `roughdielectric`).
    Dielectric {
        /// Relative index interior/exterior.
        eta: f32,
        /// Scales reflection.
        reflectance: Texture,
        /// Scales transmission.
        transmittance: Texture,
        /// `None` for a smooth interface.
        mf: Option<Microfacet>,
    },
    /// A smooth or rough conductor (Mitsuba `conductor`, `roughconductor`).
    Conductor {
        /// Complex index (η, k) per channel; `None` is the ideal mirror (F = 1).
        eta_k: Option<(Rgb, Rgb)>,
        /// Scales the reflection.
        reflectance: Texture,
        /// `None` for a smooth conductor.
        mf: Option<Microfacet>,
    },
    /// A smooth plastic (Mitsuba `plastic`).
    Plastic {
        /// Diffuse reflectance of the base.
        kd: Texture,
        /// Specular reflectance of the coating.
        ks: Texture,
        /// Relative index of the coating.
        eta: f32,
        /// Colour-dependent internal reflections.
        nonlinear: bool,
    },
    /// A rough plastic (Mitsuba `roughplastic`).
    RoughPlastic {
        /// Diffuse reflectance of the base.
        kd: Texture,
        /// Specular reflectance of the coating.
        ks: Texture,
        /// The tabulated coating.
        coating: Box<RoughCoating>,
        /// Colour-dependent internal reflections.
        nonlinear: bool,
    },
}

/// A material: a model and its sidedness.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The scattering model.
    pub model: Model,
    /// Scatters on both sides (the back side mirrors the front).
    pub two_sided: bool,
}

/// A sampled direction in the local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalSample {
    /// The sampled incident direction (local frame).
    pub wi: Vec3,
    /// f·|cos θi| / pdf.
    pub weight: Rgb,
    /// The density (the discrete probability for Dirac deltas).
    pub pdf: f32,
    /// The sample comes from a Dirac delta.
    pub delta: bool,
    /// The relative index of refraction crossed (1 for reflection).
    pub eta: f32,
}

/// The probability of sampling the specular lobe of a two-lobe model: in proportion to the mean
/// specular and diffuse coefficients, each weighted by the share of light that reaches its lobe
/// (`share` for the specular one, e.g. a coating's reflectance; ½ when both see all the light).
pub(crate) fn specular_probability(kd: Rgb, ks: Rgb, share: f32) -> f32 {
    let (d, s) = (kd.average(), ks.average());
    let w = if d + s > 0.0 { s / (d + s) } else { 0.5 };
    let (ps, pd) = (share * w, (1.0 - share) * (1.0 - w));
    if ps + pd > 0.0 {
        ps / (ps + pd)
    } else {
        0.0
    }
}

/// The sample of a reflection model at `wi`, weighted by `f·cos θi` over the density `pdf` of
/// the mixture that drew it; `None` below the surface or where the density vanishes.
#[inline]
pub(crate) fn reflection_sample(wi: Vec3, pdf: f32, f_cos: Rgb) -> Option<LocalSample> {
    (wi.z > 0.0 && pdf > 0.0).then(|| LocalSample {
        wi,
        weight: f_cos / pdf,
        pdf,
        delta: false,
        eta: 1.0,
    })
}

/// A sampled direction in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The incident direction (world, unit).
    pub wi: Vec3,
    /// f·|cos θi| / pdf.
    pub weight: Rgb,
    /// The density (the discrete probability for Dirac deltas).
    pub pdf: f32,
    /// The sample comes from a Dirac delta.
    pub delta: bool,
    /// The relative index of refraction crossed (1 for reflection).
    pub eta: f32,
}

/// A material's scattering at one point, textures resolved.
#[derive(Clone, Copy, Debug)]
pub enum BsdfModel<'a> {
    /// Lambert.
    Lambert(Rgb),
    /// Perfect mirror or smooth conductor.
    Mirror {
        /// Reflectance.
        r: Rgb,
        /// Conductor index, or `None` for F = 1.
        eta_k: Option<(Rgb, Rgb)>,
    },
    /// Rough conductor.
    RoughConductor {
        /// Distribution.
        mf: Microfacet,
        /// Conductor index.
        eta_k: Option<(Rgb, Rgb)>,
        /// Reflectance.
        r: Rgb,
    },
    /// Smooth dielectric.
    Dielectric {
        /// Relative index.
        eta: f32,
        /// Reflection scale.
        r: Rgb,
        /// Transmission scale.
        t: Rgb,
    },
    /// Rough dielectric.
    RoughDielectric {
        /// Distribution.
        mf: Microfacet,
        /// Relative index.
        eta: f32,
        /// Reflection scale.
        r: Rgb,
        /// Transmission scale.
        t: Rgb,
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
        let mut o = self.frame.to_local(wo);
        let flip = self.two_sided && o.z < 0.0;
        if flip {
            o.z = -o.z;
        }
        (o, flip)
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
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let (o, i, _) = self.local(wo, wi);
        self.eval_local(o, i)
    }

    /// [`Bsdf::eval`] for directions from [`Bsdf::local_wo`] and [`Bsdf::local_wi`].
    #[inline(always)]
    pub fn eval_local(&self, o: Vec3, i: Vec3) -> Rgb {
        // Lambert, the common case, without a call.
        if let BsdfModel::Lambert(r) = &self.model {
            return lambert::eval(*r, o, i);
        }
        self.eval_general(o, i)
    }

    /// [`Bsdf::eval_local`] for every model.
    #[inline(never)]
    fn eval_general(&self, o: Vec3, i: Vec3) -> Rgb {
        match &self.model {
            BsdfModel::Lambert(r) => lambert::eval(*r, o, i),
            BsdfModel::Mirror { .. } | BsdfModel::Dielectric { .. } => Rgb::BLACK,
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
        let mut wi = s.wi;
        if flip {
            wi.z = -wi.z;
        }
        let wi = self.frame.to_world(wi);
        (s.weight.is_finite() && wi.is_finite()).then_some(BsdfSample {
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

    /// True when every component is a Dirac delta (light sampling cannot help).
    pub fn is_delta(&self) -> bool {
        matches!(
            self.model,
            BsdfModel::Mirror { .. } | BsdfModel::Dielectric { .. }
        )
    }
}

impl Material {
    /// A two-sided material (the candela language's rule).
    pub fn two_sided(model: Model) -> Self {
        Self {
            model,
            two_sided: true,
        }
    }

    /// A one-sided material (Mitsuba's rule).
    pub fn one_sided(model: Model) -> Self {
        let two_sided = false;
        Self { model, two_sided }
    }

    /// Lambertian ρ/π, two-sided.
    pub fn diffuse(reflectance: Texture) -> Self {
        Self::two_sided(Model::Diffuse { reflectance })
    }

    /// The BSDF at a point with shading frame `frame` and surface coordinates `uv`.
    #[inline(always)]
    pub fn bsdf(&self, frame: Frame, uv: Point2) -> Bsdf<'_> {
        // Diffuse surfaces, the common case, without a call.
        if let Model::Diffuse { reflectance } = &self.model {
            return Bsdf {
                model: BsdfModel::Lambert(reflectance.eval(uv)),
                frame,
                two_sided: self.two_sided,
            };
        }
        self.bsdf_general(frame, uv)
    }

    /// [`Material::bsdf`] for every model.
    #[inline(never)]
    fn bsdf_general(&self, frame: Frame, uv: Point2) -> Bsdf<'_> {
        let model = match &self.model {
            Model::Diffuse { reflectance } => BsdfModel::Lambert(reflectance.eval(uv)),
            Model::Specular { reflectance } => BsdfModel::Mirror {
                r: reflectance.eval(uv),
                eta_k: None,
            },
            Model::Phong { lobe, kd, ks, n } => BsdfModel::Phong(PhongBrdf {
                lobe: *lobe,
                kd: kd.eval(uv),
                ks: ks.eval(uv),
                n: *n,
            }),
            Model::CookTorrance { kd, ks, mf, ior } => BsdfModel::CookTorrance(CookTorrance {
                kd: kd.eval(uv),
                ks: ks.eval(uv),
                mf: *mf,
                ior: *ior,
            }),
            Model::Dielectric {
                eta,
                reflectance,
                transmittance,
                mf,
            } => {
                let (r, t) = (reflectance.eval(uv), transmittance.eval(uv));
                match mf {
                    None => BsdfModel::Dielectric { eta: *eta, r, t },
                    Some(mf) => BsdfModel::RoughDielectric {
                        mf: *mf,
                        eta: *eta,
                        r,
                        t,
                    },
                }
            }
            Model::Conductor {
                eta_k,
                reflectance,
                mf,
            } => match mf {
                None => BsdfModel::Mirror {
                    r: reflectance.eval(uv),
                    eta_k: *eta_k,
                },
                Some(mf) => BsdfModel::RoughConductor {
                    mf: *mf,
                    eta_k: *eta_k,
                    r: reflectance.eval(uv),
                },
            },
            Model::Plastic {
                kd,
                ks,
                eta,
                nonlinear,
            } => BsdfModel::Plastic(Plastic {
                kd: kd.eval(uv),
                ks: ks.eval(uv),
                eta: *eta,
                nonlinear: *nonlinear,
            }),
            Model::RoughPlastic {
                kd,
                ks,
                coating,
                nonlinear,
            } => BsdfModel::RoughPlastic(RoughPlastic {
                kd: kd.eval(uv),
                ks: ks.eval(uv),
                coating,
                nonlinear: *nonlinear,
            }),
        };
        let two_sided = self.two_sided && !matches!(self.model, Model::Dielectric { .. });
        Bsdf {
            model,
            frame,
            two_sided,
        }
    }

    /// The material's main colour at `uv` (what the `flat` renderer shows).
    pub fn base_color(&self, uv: Point2) -> Rgb {
        match &self.model {
            Model::Diffuse { reflectance } | Model::Specular { reflectance } => {
                reflectance.eval(uv)
            }
            Model::Phong { kd, .. }
            | Model::CookTorrance { kd, .. }
            | Model::Plastic { kd, .. }
            | Model::RoughPlastic { kd, .. } => kd.eval(uv),
            Model::Dielectric { transmittance, .. } => transmittance.eval(uv),
            Model::Conductor { reflectance, .. } => reflectance.eval(uv),
        }
    }

    /// The ambient coefficient k_a of the local model (= k_d).
    pub fn ambient(&self, uv: Point2) -> Rgb {
        match &self.model {
            Model::Diffuse { reflectance } => reflectance.eval(uv),
            Model::Phong { kd, .. }
            | Model::CookTorrance { kd, .. }
            | Model::Plastic { kd, .. }
            | Model::RoughPlastic { kd, .. } => kd.eval(uv),
            _ => Rgb::BLACK,
        }
    }

    /// The local model's response to one light (scene-language.md §2b): `n` is the normal
    /// facing the viewer, `wo` the direction to the viewer, `wi` the direction to the light,
    /// `id`/`is` the light's diffuse and specular intensities at the point.
    pub fn local(&self, uv: Point2, n: Normal3, wo: Vec3, wi: Vec3, id: Rgb, is: Rgb) -> Rgb {
        let frame = Frame::from_normal(n);
        let (o, i) = (frame.to_local(wo), frame.to_local(wi));
        if i.z <= 0.0 {
            return Rgb::BLACK;
        }
        match &self.model {
            // The course's BRDFs: BRDF value × I × cos θ.
            Model::Diffuse { reflectance } => reflectance.eval(uv) * id * (INV_PI * i.z),
            Model::Phong { lobe, kd, ks, n } => PhongBrdf {
                lobe: *lobe,
                kd: kd.eval(uv),
                ks: ks.eval(uv),
                n: *n,
            }
            .local(o, i, id, is),
            Model::CookTorrance { kd, ks, mf, ior } => CookTorrance {
                kd: kd.eval(uv),
                ks: ks.eval(uv),
                mf: *mf,
                ior: *ior,
            }
            .local(o, i, id, is),
            // Physically based models: their BSDF times the light, diffuse intensity for the
            // diffuse part, specular intensity for the glossy part.
            Model::Plastic { .. }
            | Model::RoughPlastic { .. }
            | Model::Conductor { mf: Some(_), .. }
            | Model::Dielectric { mf: Some(_), .. } => {
                let b = self.bsdf(frame, uv);
                b.eval(wo, wi) * is
            }
            // Dirac deltas receive nothing from a light direction.
            Model::Specular { .. }
            | Model::Conductor { mf: None, .. }
            | Model::Dielectric { mf: None, .. } => Rgb::BLACK,
        }
    }

    /// What Whitted's ray tracer follows from this material: the weight k_s of the mirror
    /// reflection, and the refraction (relative index, transmission scale) of a dielectric.
    pub fn whitted(&self, uv: Point2, cos_o: f32) -> Whitted {
        match &self.model {
            Model::Specular { reflectance } => Whitted::mirror(reflectance.eval(uv)),
            Model::Phong { ks, .. } | Model::CookTorrance { ks, .. } => {
                Whitted::mirror(ks.eval(uv))
            }
            Model::Conductor {
                eta_k, reflectance, ..
            } => Whitted::mirror(
                reflectance.eval(uv) * conductor::conductor_fresnel(*eta_k, cos_o.abs()),
            ),
            Model::Plastic { ks, eta, .. } => {
                Whitted::mirror(ks.eval(uv) * fresnel::fresnel_dielectric(cos_o.abs(), *eta).0)
            }
            Model::Dielectric {
                eta,
                reflectance,
                transmittance,
                ..
            } => Whitted {
                reflect: reflectance.eval(uv),
                refract: Some((*eta, transmittance.eval(uv))),
            },
            Model::Diffuse { .. } | Model::RoughPlastic { .. } => Whitted::mirror(Rgb::BLACK),
        }
    }
}

/// The recursive lobes of Whitted's model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Whitted {
    /// Weight of the mirror reflection (black for none); for dielectrics the Fresnel weight is
    /// applied on top.
    pub reflect: Rgb,
    /// Relative index and transmission scale of a dielectric.
    pub refract: Option<(f32, Rgb)>,
}

impl Whitted {
    fn mirror(reflect: Rgb) -> Self {
        Self {
            reflect,
            refract: None,
        }
    }
}
