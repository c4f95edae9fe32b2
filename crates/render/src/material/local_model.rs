//! The lectures' local illumination model (Phong-style response to one light, ambient term)
//! and the recursive lobes of Whitted's ray tracer, as seen from a [`Material`].

use super::cook_torrance::CookTorrance;
use super::phong::PhongBrdf;
use super::{conductor, fresnel, Material, Model};
use crate::color::Rgb;
use crate::math::{Frame, Normal3, Point2, Vec3, INV_PI};

impl Material {
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
