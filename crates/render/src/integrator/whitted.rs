//! Whitted's recursive ray tracing (1980): the local model with shadows at every hit, plus the
//! mirror reflection weighted by k_s and, through dielectrics, Fresnel-weighted reflection and
//! Snell refraction with total internal reflection:
//! I = I_local + k_s·I_r + k_t·I_t. Recursion stops at `--max-depth` (default 10, at most
//! [`MAX_WHITTED_DEPTH`]); a camera ray spawns at most [`WHITTED_RAY_BUDGET`] rays (glass
//! doubles the rays at every depth), branches beyond it are not followed.

/// Deepest recursion of Whitted's tracer (`--max-depth`; -1 means this).
pub const MAX_WHITTED_DEPTH: u32 = 100;
/// Most reflected and refracted rays one camera ray spawns (a full tree of depth 11).
pub const WHITTED_RAY_BUDGET: u32 = 4096;

use super::local::shade;
use super::{Integrator, Recursion};
use crate::material::fresnel::{fresnel_dielectric, reflect, refract};
use crate::math::Ray;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;

/// Recursive ray tracing.
#[derive(Clone, Copy, Debug)]
pub struct Whitted {
    /// Largest number of reflections/refractions followed.
    pub max_depth: u32,
}

impl Integrator for Whitted {
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        lambda: &mut Wavelengths,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> SampledSpectrum {
        let mut t = Recursion {
            scene,
            lambda,
            budget: WHITTED_RAY_BUDGET,
            sampler,
            stats,
        };
        self.trace(&mut t, ray, 0)
    }
}

impl Whitted {
    fn trace(&self, t: &mut Recursion, ray: &Ray, depth: u32) -> SampledSpectrum {
        let scene = t.scene;
        let Some(si) = scene.interact(ray, t.stats) else {
            return scene.escaped(ray.d.normalize(), t.lambda);
        };
        let mut l = shade(scene, &si, true, t.lambda, t.sampler, t.stats);
        if depth >= self.max_depth.min(MAX_WHITTED_DEPTH) || t.budget < 2 {
            return l;
        }
        // Both children are paid for up front, so that a refraction is never cut alone.
        t.budget -= 2;
        let w = scene
            .material(&si)
            .whitted(si.uv, si.ns.dot_vec(si.wo), t.lambda);
        let wo = si.wo;
        match w.refract {
            Some((eta, kt)) => {
                // The shading normal as the shape orients it: outside is where it points.
                let n = si.ns.to_vec();
                let cos_i = n.dot(wo);
                let (f, cos_t, _, eta_ti) = fresnel_dielectric(cos_i, eta);
                let nf = if cos_i >= 0.0 { n } else { -n };
                let r = reflect(wo, nf);
                l += w.reflect * f * self.trace(t, &si.spawn_ray(r), depth + 1);
                if f < 1.0 {
                    let d = refract(wo, n, cos_t, eta_ti);
                    let lt = self.trace(t, &si.spawn_ray(d), depth + 1);
                    l += kt * lt * ((1.0 - f) * eta_ti * eta_ti);
                }
            }
            None if !w.reflect.is_black() => {
                let r = reflect(wo, si.facing_shading_normal().to_vec());
                l += w.reflect * self.trace(t, &si.spawn_ray(r), depth + 1);
            }
            None => {}
        }
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::color::Rgb;
    use crate::light::Emission;
    use crate::material::{Material, Model};
    use crate::math::{Point3, Transform, Vec3};
    use crate::scene::SceneBuilder;
    use crate::shape::{Shape, Sphere};
    use crate::texture::Texture;

    /// A mirror of reflectance 0.5 facing an emitter of radiance 1: I = 0.5·1.
    #[test]
    fn mirror_weights_by_ks() {
        let mut b = SceneBuilder::new();
        let mirror = b.add_material(Material::two_sided(Model::Specular {
            reflectance: Texture::Uniform(Rgb::splat(0.5)),
        }));
        let black = b.add_material(Material::diffuse(Texture::Uniform(Rgb::BLACK)));
        let e = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::WHITE),
            two_sided: true,
        });
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::IDENTITY)),
            mirror,
            None,
        );
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                -10.0, 0.0, 0.0,
            )))),
            black,
            Some(e),
        );
        let scene = b.build(AccelKind::Bvh);
        let w = Whitted { max_depth: 10 };
        let ray = Ray::new(Point3::new(-5.0, 0.0, 0.0), Vec3::X);
        let mut st = RayStats::default();
        let l = crate::integrator::rgb_radiance(&w, &scene, &ray, &mut st);
        assert!(l.approx_eq(Rgb::splat(0.5), 1e-6), "{l:?}");
        assert_eq!(
            crate::integrator::rgb_radiance(&Whitted { max_depth: 0 }, &scene, &ray, &mut st),
            Rgb::BLACK
        );
    }

    /// A glass slab seen head-on in front of an emitter: the transmitted weight is
    /// (1 − F)² = 0.96² for η = 1.5 (the η² factors of entering and leaving cancel), the
    /// reflected one F = 0.04 (of a black background).
    #[test]
    fn glass_energy_bookkeeping() {
        let mut b = SceneBuilder::new();
        let glass = b.add_material(Material::two_sided(Model::Dielectric {
            dispersion: None,
            eta: 1.5,
            reflectance: Texture::Uniform(Rgb::WHITE),
            transmittance: Texture::Uniform(Rgb::WHITE),
            mf: None,
        }));
        let black = b.add_material(Material::diffuse(Texture::Uniform(Rgb::BLACK)));
        let e = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::WHITE),
            two_sided: true,
        });
        b.add_shape(
            Shape::Cube(crate::shape::Cube::new(Transform::scaling(Vec3::new(
                0.1, 5.0, 5.0,
            )))),
            glass,
            None,
        );
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                10.0, 0.0, 0.0,
            )))),
            black,
            Some(e),
        );
        let scene = b.build(AccelKind::Bvh);
        let ray = Ray::new(Point3::new(-5.0, 0.0, 0.0), Vec3::X);
        let mut st = RayStats::default();
        // Depth 2: in and out, no internal bounces followed beyond the limit.
        let l = crate::integrator::rgb_radiance(&Whitted { max_depth: 2 }, &scene, &ray, &mut st);
        assert!((l.r - 0.96 * 0.96).abs() < 1e-4, "{l:?}");
        // With many bounces the internal reflections add Σ (1−F)² F^(2k).
        let l = crate::integrator::rgb_radiance(&Whitted { max_depth: 30 }, &scene, &ray, &mut st);
        let expected = 0.96f32 * 0.96 / (1.0 - 0.04 * 0.04);
        assert!((l.r - expected).abs() < 1e-4, "{l:?} vs {expected}");
    }
}
