//! The local illumination model of the lectures: ray casting with ambient, diffuse, specular
//! and emission terms (`local`), and the same with shadow rays (`direct`, the course's
//! point-light renderer).
//!
//! At a hit, with the normal n facing the viewer:
//! L = L_e + I_a·k_a + Σ_lights (I_a,l·k_a + [visible]·local(I_d,l, I_s,l))
//! where `local` is each material's response to one light (scene-language.md §2b). Hemisphere
//! lights are integrated over their directions with stratified samples. Emissive surfaces do
//! not light their neighbours under this model.

use super::Integrator;
use crate::interaction::SurfaceInteraction;
use crate::light::{Light, Target};
use crate::math::{Frame, Normal3, Point3, Ray, Vec3, PI};
use crate::sampling::sampler::cmj;
use crate::sampling::{warp, Sampler};
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;

/// Directions per shading point for hemisphere lights.
const HEMISPHERE_SAMPLES: u32 = 16;

/// Ray casting with the local model: `local` without shadows, `direct` with shadow rays.
#[derive(Clone, Copy, Debug, Default)]
pub struct Local {
    /// Trace shadow rays (the `direct` integrator).
    pub shadows: bool,
}

impl Integrator for Local {
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        lambda: &mut Wavelengths,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> SampledSpectrum {
        match scene.interact(ray, stats) {
            Some(si) => shade(scene, &si, self.shadows, lambda, sampler, stats),
            None => scene.escaped(ray.d.normalize(), lambda),
        }
    }
}

/// True when the light's target is hidden from the surface point.
pub(crate) fn shadowed(
    scene: &Scene,
    si: &SurfaceInteraction,
    wi: Vec3,
    target: Target,
    stats: &mut RayStats,
) -> bool {
    scene.occluded(&shadow_ray(si, wi, target), stats)
}

/// The ray that tests whether the light's target (in direction `wi`) is visible from the
/// surface point.
#[inline(always)]
pub(crate) fn shadow_ray(si: &SurfaceInteraction, wi: Vec3, target: Target) -> Ray {
    shadow_ray_from(si.p, si.n, wi, target)
}

/// [`shadow_ray`] from the point `p` with the unit geometric normal `n`.
#[inline(always)]
pub(crate) fn shadow_ray_from(p: Point3, n: Normal3, wi: Vec3, target: Target) -> Ray {
    match target {
        Target::Point(q) => Ray::spawn_to(p, n, q),
        // Both normals are unit normals (of an interaction and of a light's surface).
        Target::Surface(q, nq) => Ray::spawn_between_unit(p, n, q, nq),
        Target::Infinite => Ray::spawn_unit(p, n, wi),
    }
}

/// The local model at a surface point, with or without shadow rays, in the lanes of `lambda`.
pub fn shade(
    scene: &Scene,
    si: &SurfaceInteraction,
    shadows: bool,
    lambda: &mut Wavelengths,
    sampler: &mut Sampler,
    stats: &mut RayStats,
) -> SampledSpectrum {
    let m = scene.material(si);
    let n = si.facing_shading_normal();
    let ka = m.ambient(si.uv, lambda);
    let mut l = scene.emitted(si, lambda) + lambda.illuminant(scene.ambient) * ka;
    for light in &scene.lights {
        match light {
            Light::Point(..) | Light::Spot(..) | Light::Distant(..) => {
                let Some(li) = light.local(si.p, lambda) else {
                    continue;
                };
                l += li.ambient * ka;
                if n.dot_vec(li.wi) <= 0.0
                    || (shadows && shadowed(scene, si, li.wi, li.target, stats))
                {
                    continue;
                }
                l += m.local(si.uv, n, si.wo, li.wi, (li.diffuse, li.specular), lambda);
            }
            Light::Hemisphere(h, c) => {
                l += lambda.illuminant(c.ambient) * ka;
                let (id, is) = (lambda.illuminant(c.diffuse), lambda.illuminant(c.specular));
                // ∫ over the lit directions of local(I·dω), by stratified cosine-weighted samples.
                let frame = Frame::from_normal(n);
                let pattern = sampler.next_index(u32::MAX);
                let mut sum = SampledSpectrum::ZERO;
                for i in 0..HEMISPHERE_SAMPLES {
                    let wi = frame.to_world(warp::square_to_cosine_hemisphere(cmj(
                        i,
                        HEMISPHERE_SAMPLES,
                        pattern,
                    )));
                    let cos = n.dot_vec(wi);
                    if cos <= 0.0
                        || wi.dot(h.up) <= 0.0
                        || (shadows && shadowed(scene, si, wi, Target::Infinite, stats))
                    {
                        continue;
                    }
                    sum += m.local(si.uv, n, si.wo, wi, (id, is), lambda) * (PI / cos);
                }
                l += sum / HEMISPHERE_SAMPLES as f32;
            }
            Light::Environment(_) | Light::Area(_) => {}
        }
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::color::Rgb;
    use crate::light::Emission;
    use crate::light::{Components, Falloff, PointLight};
    use crate::material::Material;
    use crate::math::{Point3, Transform};
    use crate::scene::SceneBuilder;
    use crate::shape::{Shape, Sphere};
    use crate::texture::Texture;

    /// The course's point-light test, derived for candela's semantics (§2b): a red diffuse
    /// sphere emitting blue, lit by a yellow point light at 45°, with green ambient light.
    /// L = L_e + I_a·k_a + ρ/π·I·cos 45° = (0,0,1) + (0,1,0)·(1,0,0) + (1/π·cos 45°, 0, 0).
    #[test]
    fn red_sphere_under_a_yellow_light_by_hand() {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::new(1.0, 0.0, 0.0))));
        let e = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::new(0.0, 0.0, 1.0)),
            two_sided: true,
        });
        b.add_shape(Shape::Sphere(Sphere::new(Transform::IDENTITY)), m, Some(e));
        // The hit point is (-1, 0, 0), normal (-1, 0, 0); the light at 45° from the normal.
        let yellow = Rgb::new(1.0, 1.0, 0.0);
        b.add_light(Light::Point(
            PointLight {
                position: Point3::new(-1.0 - 1.0, 1.0, 0.0),
                intensity: yellow,
                spectrum: None,
                falloff: Falloff::default(),
            },
            Components::from_intensity(yellow),
        ));
        b.add_ambient(Rgb::new(0.0, 1.0, 0.0));
        let scene = b.build(AccelKind::Bvh);
        let ray = Ray::new(Point3::new(-5.0, 0.0, 0.0), Vec3::X);
        let mut st = RayStats::default();
        let l = crate::integrator::rgb_radiance(&Local { shadows: true }, &scene, &ray, &mut st);
        let expected = Rgb::new(
            std::f32::consts::FRAC_1_PI * std::f32::consts::FRAC_1_SQRT_2,
            0.0,
            1.0,
        );
        assert!(l.approx_eq(expected, 1e-6), "{l:?}");
        assert!((l.r - 0.22507908).abs() < 1e-6);
    }

    #[test]
    fn shadows_only_in_direct() {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
        b.add_shape(Shape::Sphere(Sphere::new(Transform::IDENTITY)), m, None);
        // A blocker between the light and the hit point (-1, 0, 0).
        b.add_shape(
            Shape::Sphere(Sphere::new(
                Transform::translation(Vec3::new(-3.0, 0.0, 0.0))
                    * Transform::scaling(Vec3::new(0.2, 0.2, 0.2)),
            )),
            m,
            None,
        );
        b.add_light(Light::Point(
            PointLight {
                position: Point3::new(-5.0, 0.0, 0.0),
                intensity: Rgb::WHITE,
                spectrum: None,
                falloff: Falloff::default(),
            },
            Components::from_intensity(Rgb::WHITE),
        ));
        let scene = b.build(AccelKind::Bvh);
        let ray = Ray::new(
            Point3::new(-1.5, 0.0, 5.0),
            Point3::new(-1.0, 0.0, 0.0) - Point3::new(-1.5, 0.0, 5.0),
        );
        let mut st = RayStats::default();
        let lit = crate::integrator::rgb_radiance(&Local { shadows: false }, &scene, &ray, &mut st);
        assert!((lit.r - std::f32::consts::FRAC_1_PI).abs() < 1e-5);
        assert_eq!(
            crate::integrator::rgb_radiance(&Local { shadows: true }, &scene, &ray, &mut st),
            Rgb::BLACK
        );
    }
}
