//! The lectures' local illumination model (Phong-style response to one light, ambient term)
//! and the recursive lobes of Whitted's ray tracer, as seen from a [`Material`].

use super::cook_torrance::CookTorrance;
use super::phong::PhongBrdf;
use super::{conductor, conductor_index, dielectric, fresnel, Material, Model};
use crate::math::{Frame, Normal3, Point2, Vec3, INV_PI};
use crate::spectrum::{RgbRole, SampledSpectrum, Wavelengths};
use crate::texture::Texture;

/// A reflectance texture at `uv` in the lanes of `w`.
#[inline]
fn refl(t: &Texture, uv: Point2, w: &Wavelengths) -> SampledSpectrum {
    t.spectral(uv, w, RgbRole::Reflectance)
}

impl Material {
    /// The ambient coefficient k_a of the local model (= k_d).
    pub fn ambient(&self, uv: Point2, w: &Wavelengths) -> SampledSpectrum {
        match &self.model {
            Model::Diffuse { reflectance } => refl(reflectance, uv, w),
            Model::Phong { kd, .. }
            | Model::CookTorrance { kd, .. }
            | Model::Plastic { kd, .. }
            | Model::RoughPlastic { kd, .. } => refl(kd, uv, w),
            _ => SampledSpectrum::ZERO,
        }
    }

    /// The local model's response to one light (scene-language.md §2b): `n` is the normal
    /// facing the viewer, `wo` the direction to the viewer, `wi` the direction to the light,
    /// `id`/`is` the light's diffuse and specular intensities at the point, all in the lanes
    /// of `w`.
    pub fn local(
        &self,
        uv: Point2,
        n: Normal3,
        wo: Vec3,
        wi: Vec3,
        (id, is): (SampledSpectrum, SampledSpectrum),
        w: &mut Wavelengths,
    ) -> SampledSpectrum {
        let frame = Frame::from_normal(n);
        let (o, i) = (frame.to_local(wo), frame.to_local(wi));
        if i.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        match &self.model {
            // The course's BRDFs: BRDF value × I × cos θ.
            Model::Diffuse { reflectance } => refl(reflectance, uv, w) * id * (INV_PI * i.z),
            Model::Phong { lobe, kd, ks, n } => PhongBrdf {
                lobe: *lobe,
                kd: refl(kd, uv, w),
                ks: refl(ks, uv, w),
                n: *n,
            }
            .local(o, i, id, is),
            Model::CookTorrance { kd, ks, mf, ior } => CookTorrance {
                kd: refl(kd, uv, w),
                ks: refl(ks, uv, w),
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
                let b = self.bsdf(frame, uv, w);
                b.eval(wo, wi) * is
            }
            // Dirac deltas receive nothing from a light direction.
            Model::Specular { .. }
            | Model::Conductor { mf: None, .. }
            | Model::Dielectric { mf: None, .. } => SampledSpectrum::ZERO,
        }
    }

    /// What Whitted's ray tracer follows from this material: the weight k_s of the mirror
    /// reflection, and the refraction (relative index, transmission scale) of a dielectric.
    /// A dispersive dielectric keeps only the hero wavelength of a spectral path.
    pub fn whitted(&self, uv: Point2, cos_o: f32, w: &mut Wavelengths) -> Whitted {
        match &self.model {
            Model::Specular { reflectance } => Whitted::mirror(refl(reflectance, uv, w)),
            Model::Phong { ks, .. } | Model::CookTorrance { ks, .. } => {
                Whitted::mirror(refl(ks, uv, w))
            }
            Model::Conductor {
                eta_k, reflectance, ..
            } => Whitted::mirror(
                refl(reflectance, uv, w)
                    * conductor::conductor_fresnel(
                        conductor_index(eta_k.as_ref(), uv, w),
                        cos_o.abs(),
                    ),
            ),
            Model::Plastic { ks, eta, .. } => {
                Whitted::mirror(refl(ks, uv, w) * fresnel::fresnel_dielectric(cos_o.abs(), *eta).0)
            }
            Model::Dielectric {
                eta,
                dispersion,
                reflectance,
                transmittance,
                ..
            } => Whitted {
                reflect: refl(reflectance, uv, w),
                refract: Some((
                    dielectric::relative_eta(*eta, dispersion.as_deref(), w),
                    refl(transmittance, uv, w),
                )),
            },
            Model::Diffuse { .. } | Model::RoughPlastic { .. } => {
                Whitted::mirror(SampledSpectrum::ZERO)
            }
        }
    }
}

/// The recursive lobes of Whitted's model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Whitted {
    /// Weight of the mirror reflection (black for none); for dielectrics the Fresnel weight is
    /// applied on top.
    pub reflect: SampledSpectrum,
    /// Relative index and transmission scale of a dielectric.
    pub refract: Option<(f32, SampledSpectrum)>,
}

impl Whitted {
    fn mirror(reflect: SampledSpectrum) -> Self {
        Self {
            reflect,
            refract: None,
        }
    }
}
