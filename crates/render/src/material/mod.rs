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

mod bsdf;
mod conductor;
mod cook_torrance;
mod dielectric;
pub mod fresnel;
mod lambert;
mod local_model;
pub mod microfacet;
mod phong;
mod plastic;
mod sample;
mod specular;

pub use bsdf::{local_wo, world_wi, Bsdf, BsdfModel, IncidencePlane};
pub use cook_torrance::CookTorrance;
pub use dielectric::{relative_eta, sample_smooth, Dispersion, REFERENCE_WAVELENGTH};
pub use local_model::Whitted;
pub use microfacet::{Distribution, Microfacet};
pub use phong::{Lobe, PhongBrdf};
pub use plastic::{Plastic, RoughCoating, RoughPlastic};
pub use sample::{BsdfSample, LocalSample};
pub use specular::sample as sample_specular;

use crate::color::Rgb;
use crate::math::{Frame, Point2};
use crate::spectrum::{RgbRole, SampledSpectrum, Wavelengths};
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
        /// Relative index interior/exterior (in spectral mode, of non-dispersive glass).
        eta: f32,
        /// An index that varies with the wavelength: used in spectral mode instead of `eta`.
        dispersion: Option<Box<Dispersion>>,
        /// Scales reflection.
        reflectance: Texture,
        /// Scales transmission.
        transmittance: Texture,
        /// `None` for a smooth interface.
        mf: Option<Microfacet>,
    },
    /// A smooth or rough conductor (Mitsuba `conductor`, `roughconductor`).
    Conductor {
        /// Complex index (η, k): colours or measured spectra; `None` is the ideal mirror
        /// (F = 1).
        eta_k: Option<(Texture, Texture)>,
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

impl Model {
    /// True for the models that scatter only into discrete directions: a perfect mirror, a
    /// smooth conductor, a smooth dielectric (their BSDFs are Dirac deltas).
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Model::Specular { .. }
                | Model::Conductor { mf: None, .. }
                | Model::Dielectric { mf: None, .. }
        )
    }
}

/// A material: a model and its sidedness.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The scattering model.
    pub model: Model,
    /// Scatters on both sides (the back side mirrors the front).
    pub two_sided: bool,
    /// Stochastic opacity (Mitsuba's `mask`): a ray meets the surface with the probability
    /// given by the texture's luminance at the hit and passes straight through otherwise,
    /// shadow rays included (see [`crate::scene::Scene::intersect`]). `None`: opaque.
    pub opacity: Option<Texture>,
}

impl Material {
    /// A two-sided material (the candela language's rule).
    pub fn two_sided(model: Model) -> Self {
        Self {
            model,
            two_sided: true,
            opacity: None,
        }
    }

    /// A one-sided material (Mitsuba's rule).
    pub fn one_sided(model: Model) -> Self {
        let two_sided = false;
        Self {
            model,
            two_sided,
            opacity: None,
        }
    }

    /// Lambertian ρ/π, two-sided.
    pub fn diffuse(reflectance: Texture) -> Self {
        Self::two_sided(Model::Diffuse { reflectance })
    }

    /// The BSDF at a point with shading frame `frame` and surface coordinates `uv`, its colours
    /// in the lanes of `w` (a dispersive dielectric keeps only the hero wavelength of a
    /// spectral path).
    #[inline(always)]
    pub fn bsdf(&self, frame: Frame, uv: Point2, w: &mut Wavelengths) -> Bsdf<'_> {
        // Diffuse surfaces, the common case, without a call.
        if let Model::Diffuse { reflectance } = &self.model {
            return Bsdf {
                model: BsdfModel::Lambert(reflectance.spectral(uv, w, RgbRole::Reflectance)),
                frame,
                two_sided: self.two_sided,
            };
        }
        self.bsdf_general(frame, uv, w)
    }

    /// [`Material::bsdf`] for every model.
    #[inline(never)]
    fn bsdf_general(&self, frame: Frame, uv: Point2, w: &mut Wavelengths) -> Bsdf<'_> {
        let refl = |t: &Texture, w: &Wavelengths| t.spectral(uv, w, RgbRole::Reflectance);
        let model = match &self.model {
            Model::Diffuse { reflectance } => BsdfModel::Lambert(refl(reflectance, w)),
            Model::Specular { reflectance } => BsdfModel::Mirror {
                r: refl(reflectance, w),
                eta_k: None,
            },
            Model::Phong { lobe, kd, ks, n } => BsdfModel::Phong(PhongBrdf {
                lobe: *lobe,
                kd: refl(kd, w),
                ks: refl(ks, w),
                n: *n,
            }),
            Model::CookTorrance { kd, ks, mf, ior } => BsdfModel::CookTorrance(CookTorrance {
                kd: refl(kd, w),
                ks: refl(ks, w),
                mf: *mf,
                ior: *ior,
            }),
            Model::Dielectric {
                eta,
                dispersion,
                reflectance,
                transmittance,
                mf,
            } => {
                let (r, t) = (refl(reflectance, w), refl(transmittance, w));
                let eta = dielectric::relative_eta(*eta, dispersion.as_deref(), w);
                match mf {
                    None => BsdfModel::Dielectric { eta, r, t },
                    Some(mf) => BsdfModel::RoughDielectric { mf: *mf, eta, r, t },
                }
            }
            Model::Conductor {
                eta_k,
                reflectance,
                mf,
            } => {
                let eta_k = conductor_index(eta_k.as_ref(), uv, w);
                match mf {
                    None => BsdfModel::Mirror {
                        r: refl(reflectance, w),
                        eta_k,
                    },
                    Some(mf) => BsdfModel::RoughConductor {
                        mf: *mf,
                        eta_k,
                        r: refl(reflectance, w),
                    },
                }
            }
            Model::Plastic {
                kd,
                ks,
                eta,
                nonlinear,
            } => BsdfModel::Plastic(Plastic {
                kd: refl(kd, w),
                ks: refl(ks, w),
                eta: *eta,
                nonlinear: *nonlinear,
            }),
            Model::RoughPlastic {
                kd,
                ks,
                coating,
                nonlinear,
            } => BsdfModel::RoughPlastic(RoughPlastic {
                kd: refl(kd, w),
                ks: refl(ks, w),
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

    /// True when a texture of the material (its opacity included) varies over the surface,
    /// so that its hits need texture coordinates.
    pub fn reads_uv(&self) -> bool {
        let varies = |t: &Texture| !t.is_constant();
        let model = match &self.model {
            Model::Diffuse { reflectance } | Model::Specular { reflectance } => varies(reflectance),
            Model::Phong { kd, ks, .. }
            | Model::CookTorrance { kd, ks, .. }
            | Model::Plastic { kd, ks, .. }
            | Model::RoughPlastic { kd, ks, .. } => varies(kd) || varies(ks),
            Model::Dielectric {
                reflectance,
                transmittance,
                ..
            } => varies(reflectance) || varies(transmittance),
            Model::Conductor {
                eta_k, reflectance, ..
            } => {
                varies(reflectance)
                    || eta_k
                        .as_ref()
                        .is_some_and(|(eta, k)| varies(eta) || varies(k))
            }
        };
        model || self.opacity.as_ref().is_some_and(varies)
    }

    /// True when the material's response turns with the surface's tangent (∂p/∂u), not only
    /// with its normal: an anisotropic microfacet distribution. Such a surface keeps the
    /// tangent its shape defines (a mesh stays a mesh: see `SceneBuilder::add_mesh_or_parallelograms`).
    pub fn reads_tangent(&self) -> bool {
        match &self.model {
            Model::Conductor { mf: Some(mf), .. } | Model::Dielectric { mf: Some(mf), .. } => {
                !mf.is_isotropic()
            }
            _ => false,
        }
    }

    /// Readies the material for spectral rendering: uniform colours are upsampled once, here,
    /// rather than at every hit (see [`Texture::prepare_spectral`]).
    pub fn prepare_spectral(&mut self) {
        let refl = RgbRole::Reflectance;
        match &mut self.model {
            Model::Diffuse { reflectance } | Model::Specular { reflectance } => {
                reflectance.prepare_spectral(refl)
            }
            Model::Phong { kd, ks, .. }
            | Model::CookTorrance { kd, ks, .. }
            | Model::Plastic { kd, ks, .. }
            | Model::RoughPlastic { kd, ks, .. } => {
                kd.prepare_spectral(refl);
                ks.prepare_spectral(refl);
            }
            Model::Dielectric {
                reflectance,
                transmittance,
                ..
            } => {
                reflectance.prepare_spectral(refl);
                transmittance.prepare_spectral(refl);
            }
            Model::Conductor {
                eta_k, reflectance, ..
            } => {
                reflectance.prepare_spectral(refl);
                if let Some((eta, k)) = eta_k {
                    eta.prepare_spectral(RgbRole::OpticalConstant);
                    k.prepare_spectral(RgbRole::OpticalConstant);
                }
            }
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
}

/// A conductor's complex index at `uv` in the lanes of `w`.
#[inline]
pub(crate) fn conductor_index(
    eta_k: Option<&(Texture, Texture)>,
    uv: Point2,
    w: &Wavelengths,
) -> Option<(SampledSpectrum, SampledSpectrum)> {
    eta_k.map(|(eta, k)| {
        (
            eta.spectral(uv, w, RgbRole::OpticalConstant),
            k.spectral(uv, w, RgbRole::OpticalConstant),
        )
    })
}
