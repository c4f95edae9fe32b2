//! Preview renderers (scene-language.md §2b): `onoff`, `flat`, `normals`, `depth`.

use super::Integrator;
use crate::color::Rgb;
use crate::math::Ray;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, Wavelengths};
use crate::stats::RayStats;

/// White where a ray hits anything, black elsewhere.
#[derive(Clone, Copy, Debug, Default)]
pub struct OnOff;

/// The material's colour plus the emitted radiance at the hit; the background elsewhere.
#[derive(Clone, Copy, Debug, Default)]
pub struct Flat;

/// The shading normal `n` (facing the ray) as the colour `(n + 1)/2`; black where nothing is hit.
#[derive(Clone, Copy, Debug, Default)]
pub struct Normals;

/// The hit distance t in every channel; 0 where nothing is hit.
#[derive(Clone, Copy, Debug, Default)]
pub struct Depth;

/// A preview view: a colour per camera ray, computed in RGB (no wavelengths, no samples).
trait View: Sync {
    fn colour(&self, scene: &Scene, ray: &Ray, stats: &mut RayStats) -> Rgb;
}

impl<V: View> Integrator for V {
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        _: &mut Wavelengths,
        _: &mut Sampler,
        stats: &mut RayStats,
    ) -> SampledSpectrum {
        SampledSpectrum::from_rgb(self.colour(scene, ray, stats))
    }

    /// A view is a colour, not radiance per wavelength.
    fn spectral(&self) -> bool {
        false
    }
}

impl View for OnOff {
    fn colour(&self, scene: &Scene, ray: &Ray, stats: &mut RayStats) -> Rgb {
        match scene.intersect(ray, stats) {
            Some(_) => Rgb::WHITE,
            None => Rgb::BLACK,
        }
    }
}

impl View for Flat {
    fn colour(&self, scene: &Scene, ray: &Ray, stats: &mut RayStats) -> Rgb {
        match scene.interact(ray, stats) {
            Some(si) => {
                scene.material(&si).base_color(si.uv)
                    + scene.emitted(&si, &Wavelengths::Rgb).to_rgb()
            }
            None => scene.background,
        }
    }
}

impl View for Normals {
    fn colour(&self, scene: &Scene, ray: &Ray, stats: &mut RayStats) -> Rgb {
        match scene.interact(ray, stats) {
            Some(si) => {
                let n = si.facing_shading_normal();
                Rgb::new((n.x + 1.0) * 0.5, (n.y + 1.0) * 0.5, (n.z + 1.0) * 0.5)
            }
            None => Rgb::BLACK,
        }
    }
}

impl View for Depth {
    fn colour(&self, scene: &Scene, ray: &Ray, stats: &mut RayStats) -> Rgb {
        match scene.intersect(ray, stats) {
            Some(h) => Rgb::splat(h.t * ray.d.norm()),
            None => Rgb::BLACK,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::light::Emission;
    use crate::material::Material;
    use crate::math::{Point3, Transform, Vec3};
    use crate::scene::SceneBuilder;
    use crate::shape::{Shape, Sphere};
    use crate::texture::Texture;

    fn one_sphere() -> Scene {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::new(
            0.5, 0.25, 0.0,
        ))));
        let e = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::new(0.0, 0.0, 1.0)),
            two_sided: true,
        });
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                3.0, 0.0, 0.0,
            )))),
            m,
            Some(e),
        );
        b.build(AccelKind::None)
    }

    #[test]
    fn preview_values_by_hand() {
        let s = one_sphere();
        let mut st = RayStats::default();
        let hit = Ray::new(Point3::ORIGIN, Vec3::X);
        let miss = Ray::new(Point3::ORIGIN, Vec3::Y);
        assert_eq!(OnOff.colour(&s, &hit, &mut st), Rgb::WHITE);
        assert_eq!(OnOff.colour(&s, &miss, &mut st), Rgb::BLACK);
        assert_eq!(Flat.colour(&s, &hit, &mut st), Rgb::new(0.5, 0.25, 1.0));
        assert_eq!(Normals.colour(&s, &hit, &mut st), Rgb::new(0.0, 0.5, 0.5));
        assert_eq!(Normals.colour(&s, &miss, &mut st), Rgb::BLACK);
        assert_eq!(Depth.colour(&s, &hit, &mut st), Rgb::splat(2.0));
        assert_eq!(Depth.colour(&s, &miss, &mut st), Rgb::BLACK);
        // From inside the sphere the normal still faces the ray.
        let inside = Ray::new(Point3::new(3.0, 0.0, 0.0), Vec3::Z);
        assert_eq!(
            Normals.colour(&s, &inside, &mut st),
            Rgb::new(0.5, 0.5, 0.0)
        );
    }
}
