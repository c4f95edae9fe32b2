//! Next-event estimation's samplers against their densities: rectangle lights (in a general
//! orientation, from near and far, in front, behind, at low angles) against
//! `Light::pdf_hit`, constant environments and hemisphere
//! lights sampled cosine-weighted about a shading normal against `Light::pdf_escape_from`
//! (χ² goodness of fit, and the density each sample reports equal to the one MIS uses), and the
//! importance-based choice of a light (`LightSelector`) against its probabilities.

mod support;

use support::chi2;

use candela_render::accel::AccelKind;
use candela_render::light::{
    Components, DistantLight, Emission, Environment, Falloff, HemisphereLight, Light, PointLight,
    ShadingPoint, SpotLight, SpotProfile, Target,
};
use candela_render::material::Material;
use candela_render::math::{Point3, Ray, Transform, Vec3};
use candela_render::sampling::Pcg32;
use candela_render::shape::{Parallelogram, Shape};
use candela_render::spectrum::Wavelengths;
use candela_render::stats::RayStats;
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene, SceneBuilder};
use chi2::{sidak, Chi2, Grid, ALPHA};

const SAMPLES: usize = 200_000;
const ROWS: usize = 24;

/// A rectangle (orthogonal edges) in a general orientation, 1.4 × 0.9.
fn rectangle() -> Parallelogram {
    let v = Vec3::new(1.2, 0.3, 0.5).normalize() * 1.4;
    let w = v.cross(Vec3::new(0.1, 1.0, -0.2)).normalize() * 0.9;
    Parallelogram::new(Point3::new(-0.6, -0.4, 2.0), v, w).unwrap()
}

/// A scene holding the rectangle light alone.
fn rect_scene(two_sided: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
    let em = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::splat(2.0)),
        two_sided,
    });
    b.add_shape(Shape::Parallelogram(rectangle()), m, Some(em));
    b.build(AccelKind::None)
}

/// The points the rectangle is seen from: (name, point, two-sided, grid power).
fn rect_cases() -> Vec<(&'static str, Point3, bool, f64)> {
    let r = rectangle();
    let centre = r.p + r.v * 0.5 + r.w * 0.5;
    let n = r.normal().to_vec();
    vec![
        ("rectangle from the front", centre + n * 1.5, false, 2.0),
        (
            "rectangle from close above a corner",
            r.p + n * 0.05 + r.v * 0.1,
            false,
            1.0,
        ),
        (
            "rectangle at a low angle",
            centre + r.v * 1.2 + n * 0.4,
            true,
            1.0,
        ),
        (
            "rectangle, two-sided, from behind",
            centre - n * 0.7,
            true,
            1.0,
        ),
        (
            "rectangle, one-sided, from behind (no sample)",
            centre - n * 0.7,
            false,
            1.0,
        ),
    ]
}

fn tests_count() -> usize {
    rect_cases().len() + 3
}

fn seed(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// pdf_hit at the first emitting point along `d`, else 0.
fn hit_pdf(s: &Scene, p: Point3, d: Vec3) -> f32 {
    match s.interact(&Ray::new(p, d), &mut RayStats::default()) {
        Some(si) if !s.emitted(&si, &Wavelengths::Rgb).to_rgb().is_black() => {
            s.lights[0].pdf_hit(p, si.p, si.n)
        }
        _ => 0.0,
    }
}

// The directions of rectangle samples follow pdf_hit, from in front, from close above a
// corner, at a low angle and from behind (two-sided); a one-sided rectangle seen from behind
// gives no sample and has density 0.
#[test]
fn chi2_rectangle_light() {
    let level = sidak(ALPHA, tests_count());
    let mut failures = Vec::new();
    for (name, p, two_sided, power) in rect_cases() {
        let s = rect_scene(two_sided);
        let light = &s.lights[0];
        let r = rectangle();
        let axis = r.p + r.v * 0.5 + r.w * 0.5 - p;
        let t = Chi2 {
            name,
            grid: Grid::new(axis, power, ROWS),
            samples: SAMPLES,
            seed: seed(name),
            expected_mass: None,
            level,
        };
        match t.run(
            |u| {
                let ls = light.sample(
                    &s.geometry,
                    &s.emissions,
                    p,
                    [u[0], u[1]],
                    &Wavelengths::Rgb,
                )?;
                (!ls.li.is_black()).then_some((ls.wi, ls.pdf))
            },
            |d| hit_pdf(&s, p, d),
        ) {
            Ok(r) => println!(
                "{name}: p-value {:.3e}, mass {:.4}",
                r.p_value, r.pdf_integral
            ),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// The density every rectangle sample reports is the one MIS uses for the point it hit
// (pdf_hit), from near, far (less than 10⁻⁴ sr), behind and at a grazing angle.
#[test]
fn rectangle_sample_density_is_pdf_hit() {
    let s = rect_scene(true);
    let light = &s.lights[0];
    let r = rectangle();
    let centre = r.p + r.v * 0.5 + r.w * 0.5;
    let n = r.normal().to_vec();
    let mut rng = Pcg32::new(5, 9);
    for p in [
        centre + n * 1.5,
        centre - n * 0.3 + r.w * 0.4,
        centre + n * 300.0,
        centre + r.v * 2.0 + n * 0.1,
    ] {
        for _ in 0..2000 {
            let u = [rng.next_f32(), rng.next_f32()];
            let Some(ls) = light.sample(&s.geometry, &s.emissions, p, u, &Wavelengths::Rgb) else {
                continue;
            };
            let Target::Surface(q, qn) = ls.target else {
                panic!("area light")
            };
            let pdf = light.pdf_hit(p, q, qn);
            assert!(
                (pdf - ls.pdf).abs() <= 2e-3 * ls.pdf,
                "{p:?} {u:?}: sample {} pdf_hit {pdf}",
                ls.pdf
            );
        }
    }
}

fn infinite_lights() -> Vec<(&'static str, Light)> {
    vec![
        (
            "constant environment, cosine about the normal",
            Light::Environment(Environment::new(
                Texture::Uniform(Rgb::splat(1.5)),
                Transform::rotation_x(20.0),
            )),
        ),
        (
            "hemisphere light, cosine about the normal",
            Light::Hemisphere(
                HemisphereLight {
                    radiance: Rgb::splat(2.0),
                    up: Vec3::new(0.3, -0.5, 0.8).normalize(),
                },
                Components::from_intensity(Rgb::splat(2.0)),
            ),
        ),
    ]
}

// Seen from a BSDF that only reflects, a constant environment and a hemisphere light sample
// cosine-weighted about the shading normal: the directions follow pdf_escape_from (cos θ/π on
// the normal's side; the hemisphere light's dark half gives no sample, density 0 there), and
// each sample reports that density.
#[test]
fn chi2_infinite_lights_cosine_about_the_normal() {
    let level = sidak(ALPHA, tests_count());
    let s = SceneBuilder::new().build(AccelKind::None);
    let sp = ShadingPoint {
        p: Point3::ORIGIN,
        n: Vec3::new(-0.4, 0.2, 0.9).normalize(),
        reflect_only: true,
    };
    let mut failures = Vec::new();
    for (name, light) in infinite_lights() {
        let t = Chi2 {
            name,
            grid: Grid::new(sp.n, 1.0, ROWS),
            samples: SAMPLES,
            seed: seed(name),
            expected_mass: matches!(light, Light::Environment(_)).then_some(1.0),
            level,
        };
        match t.run(
            |u| {
                light
                    .sample_from(
                        &s.geometry,
                        &s.emissions,
                        &sp,
                        [u[0], u[1]],
                        &Wavelengths::Rgb,
                    )
                    .map(|ls| (ls.wi, ls.pdf))
            },
            |d| {
                if light.escaped(d, &Wavelengths::Rgb).is_black() {
                    0.0
                } else {
                    light.pdf_escape_from(d, &sp)
                }
            },
        ) {
            Ok(r) => println!("{name}: p-value {:.3e}", r.p_value),
            Err(e) => failures.push(e),
        }
        // A BSDF that also transmits: the light's own (uniform) sampling.
        let both = ShadingPoint {
            reflect_only: false,
            ..sp
        };
        let d = Vec3::new(0.3, -0.2, -0.9).normalize();
        assert_eq!(light.pdf_escape_from(d, &both), light.pdf_escape(d));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A scene with a rectangle light, a point light, a spot light, a distant light and a
/// constant environment.
fn many_lights() -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
    let em = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::splat(4.0)),
        two_sided: false,
    });
    b.add_shape(Shape::Parallelogram(rectangle()), m, Some(em));
    let c = Components::from_intensity(Rgb::splat(1.0));
    b.add_light(Light::Point(
        PointLight {
            position: Point3::new(1.0, 2.0, 0.5),
            intensity: Rgb::splat(5.0),
            spectrum: None,
            falloff: Falloff::INVERSE_SQUARE,
        },
        c,
    ));
    b.add_light(Light::Spot(
        SpotLight {
            position: Point3::new(-1.0, 0.0, 3.0),
            axis: Vec3::new(0.0, 0.0, -1.0),
            intensity: Rgb::splat(20.0),
            spectrum: None,
            cos_cutoff: 0.9,
            profile: SpotProfile::linear(0.95, 0.9),
            falloff: Falloff::INVERSE_SQUARE,
            pattern: None,
        },
        c,
    ));
    b.add_light(Light::Distant(
        DistantLight {
            direction: Vec3::new(0.2, -0.3, -1.0).normalize(),
            irradiance: Rgb::splat(1.5),
            spectrum: None,
        },
        c,
    ));
    b.add_light(Light::Environment(Environment::new(
        Texture::Uniform(Rgb::splat(0.3)),
        Transform::IDENTITY,
    )));
    b.build(AccelKind::None)
}

// The importance-based choice: the probabilities sum to 1, `pick` reports the probability
// `pmf` recomputes (what MIS uses at an emitter hit), a stratified sweep of the number picks
// each light with that frequency, and the rescaled number is uniform within each share.
#[test]
fn light_choice_follows_its_probabilities() {
    let s = many_lights();
    let lights = &s.lights[..];
    assert_eq!(lights.len(), 5);
    assert!(!s.light_selector.is_uniform());
    let mut rng = Pcg32::new(3, 4);
    let n_points = 200;
    let sweep = 20_000;
    for k in 0..n_points {
        let p = Point3::new(
            4.0 * rng.next_f32() - 2.0,
            4.0 * rng.next_f32() - 2.0,
            4.0 * rng.next_f32() - 1.0,
        );
        let n = Vec3::new(
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
        )
        .normalize();
        let sp = ShadingPoint {
            p,
            n,
            reflect_only: k % 2 == 0,
        };
        let pmf: Vec<f32> = (0..lights.len())
            .map(|i| s.light_selector.pmf(lights, &sp, i))
            .collect();
        let total: f32 = pmf.iter().sum();
        if total == 0.0 {
            // No light can reach the point: no light sample.
            assert!(s.light_selector.pick(lights, &sp, 0.5).is_none());
            continue;
        }
        assert!((total - 1.0).abs() < 1e-5, "{sp:?}: Σ pmf = {total}");
        let mut count = vec![0usize; lights.len()];
        let mut mean_u = vec![0f64; lights.len()];
        for j in 0..sweep {
            let u = (j as f32 + 0.5) / sweep as f32;
            let (i, prob, v) = s.light_selector.pick(lights, &sp, u).unwrap();
            assert_eq!(prob, pmf[i], "{sp:?}: light {i}");
            assert!((0.0..1.0).contains(&v));
            count[i] += 1;
            mean_u[i] += v as f64;
        }
        for i in 0..lights.len() {
            let f = count[i] as f64 / sweep as f64;
            assert!(
                (f - pmf[i] as f64).abs() <= 2.0 / sweep as f64,
                "{sp:?}: light {i} picked {f}, pmf {}",
                pmf[i]
            );
            if count[i] > 100 {
                let m = mean_u[i] / count[i] as f64;
                assert!((m - 0.5).abs() < 0.01, "light {i}: mean rescaled u {m}");
            }
        }
    }
}

// A light that cannot reach a point gets no share there: a one-sided rectangle seen from
// behind (beyond its bounding sphere), a point light below a reflecting surface's horizon, a
// spot light outside its cone; nor does a constant environment beside other lights (BSDF
// sampling finds it as well as light sampling would).
#[test]
fn lights_that_cannot_reach_a_point_are_not_picked() {
    let s = many_lights();
    let lights = &s.lights[..];
    let r = rectangle();
    let behind = r.p + r.v * 0.5 + r.w * 0.5 - r.normal().to_vec() * 3.0;
    let cases = [
        (0, behind, Vec3::Z, false),
        (
            1,
            Point3::ORIGIN,
            (Point3::ORIGIN - Point3::new(1.0, 2.0, 0.5)).normalize(),
            true,
        ),
        (2, Point3::new(3.0, 3.0, 0.0), Vec3::Z, false),
        // The constant environment: left to BSDF sampling everywhere.
        (4, Point3::ORIGIN, Vec3::Z, true),
        (4, Point3::new(1.0, -1.0, 0.5), Vec3::X, false),
    ];
    for (i, p, n, reflect_only) in cases {
        let sp = ShadingPoint { p, n, reflect_only };
        assert_eq!(s.light_selector.pmf(lights, &sp, i), 0.0, "light {i}");
        for j in 0..100 {
            let u = (j as f32 + 0.5) / 100.0;
            // (No light at all may reach the point.)
            if let Some((k, _, _)) = s.light_selector.pick(lights, &sp, u) {
                assert_ne!(k, i);
            }
        }
    }
}

/// A rectangle light beside a constant sky: the sky is left to BSDF sampling, so the
/// rectangle is picked every time, with probability 1 and the number unchanged, wherever it
/// could contribute; the MIS probabilities agree.
#[test]
fn a_sole_light_beside_a_constant_sky_is_always_picked() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
    let em = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::splat(2.0)),
        two_sided: false,
    });
    b.add_shape(Shape::Parallelogram(rectangle()), m, Some(em));
    b.add_light(Light::Environment(Environment::new(
        Texture::Uniform(Rgb::splat(0.4)),
        Transform::IDENTITY,
    )));
    let s = b.build(AccelKind::None);
    let lights = &s.lights[..];
    let rect = (0..lights.len())
        .find(|&i| matches!(lights[i], Light::Area(_)))
        .unwrap();
    let sky = 1 - rect;
    let r = rectangle();
    let front = r.p + r.v * 0.5 + r.w * 0.5 + r.normal().to_vec() * 2.0;
    for (p, n) in [(front, -r.normal().to_vec()), (Point3::ORIGIN, Vec3::Z)] {
        let sp = ShadingPoint {
            p,
            n,
            reflect_only: true,
        };
        assert_eq!(s.light_selector.pmf(lights, &sp, rect), 1.0);
        assert_eq!(s.light_selector.pmf(lights, &sp, sky), 0.0);
        for j in 0..100 {
            let u = (j as f32 + 0.5) / 100.0;
            assert_eq!(s.light_selector.pick(lights, &sp, u), Some((rect, 1.0, u)));
        }
    }
}

/// A diffuse plane z = 0 of reflectance `rho` lit by the point lights `points` (position,
/// intensity), with the plane's material.
fn plane_under_points(rho: f32, points: &[(Point3, Rgb)]) -> (SceneBuilder, u32) {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(rho))));
    let plane = Parallelogram::new(
        Point3::new(-50.0, -50.0, 0.0),
        Vec3::new(100.0, 0.0, 0.0),
        Vec3::new(0.0, 100.0, 0.0),
    )
    .expect("plane");
    b.add_shape(Shape::Parallelogram(plane), m, None);
    for &(position, intensity) in points {
        b.add_light(Light::Point(
            PointLight {
                position,
                intensity,
                spectrum: None,
                falloff: Falloff::INVERSE_SQUARE,
            },
            Components::from_intensity(intensity),
        ));
    }
    (b, m)
}

/// The irradiance the point lights `points` give the point `p` of the plane z = 0:
/// Σ I·cos θ / d².
fn points_irradiance(p: Point3, points: &[(Point3, Rgb)]) -> [f64; 3] {
    let mut e = [0f64; 3];
    for &(q, i) in points {
        let to = q - p;
        let d2 = to.squared_norm() as f64;
        let cos = to.z as f64 / d2.sqrt();
        for (e, c) in e.iter_mut().zip([i.r, i.g, i.b]) {
            *e += c as f64 * cos / d2;
        }
    }
    e
}

/// A diffuse plane lit by three point lights only: every vertex samples every light (no
/// choice among them), so a camera ray hitting the plane gets the exact direct illumination
/// ρ/π · Σ I·cos θ / d², whatever the sample, and nothing else (a plane sends no light back to
/// itself).
/// The RGB radiance of `path` along `ray` for sample `index` (of `spp`) of pixel `index` of an
/// independent sampler seeded by `seed`: `(seed, index, spp)`.
fn path_sample(
    path: &candela_render::integrator::Path,
    scene: &Scene,
    ray: &Ray,
    sampler: &mut candela_render::sampling::Sampler,
    (seed, index, spp): (u64, u64, u32),
) -> [f32; 3] {
    use candela_render::integrator::Integrator;
    use candela_render::sampling::SamplerKind;
    sampler.reset_for_pixel(SamplerKind::Independent, seed, index, spp);
    sampler.pixel_sample(if spp == 1 { 0 } else { index as u32 });
    let mut lambda = Wavelengths::Rgb;
    path.radiance(scene, ray, &mut lambda, sampler, &mut RayStats::default())
        .to_rgb()
        .to_array()
}

#[test]
fn every_delta_light_gives_the_exact_direct_illumination() {
    use candela_render::integrator::Path;
    use candela_render::sampling::Sampler;
    let rho = 0.6;
    let lights = [
        (Point3::new(0.5, 0.2, 1.0), Rgb::new(2.0, 1.0, 0.5)),
        (Point3::new(-1.5, 0.7, 2.0), Rgb::new(1.0, 3.0, 1.0)),
        (Point3::new(0.1, -2.0, 0.6), Rgb::new(0.5, 0.5, 4.0)),
    ];
    let scene = plane_under_points(rho, &lights).0.build(AccelKind::Bvh);
    let expected =
        points_irradiance(Point3::ORIGIN, &lights).map(|e| rho as f64 / std::f64::consts::PI * e);
    let path = Path {
        max_depth: Some(8),
        rr_depth: 5,
        hide_emitters: false,
    };
    let ray = Ray::new(Point3::new(0.0, 0.0, 3.0), Vec3::new(0.0, 0.0, -1.0));
    let mut sampler = Sampler::new(0, 0);
    for index in 0..16 {
        let l = path_sample(&path, &scene, &ray, &mut sampler, (9, index, 16));
        for (c, e) in l.into_iter().zip(expected) {
            assert!(
                ((c as f64) - e).abs() <= 1e-5 * e,
                "sample {index}: {c} against {e}"
            );
        }
    }
}

/// A diffuse plane lit by two point lights and a rectangle light facing it: every vertex
/// samples every light, the rectangle's samples weighed against BSDF sampling by MIS with a
/// choice probability of 1 on both sides. Direct light only (`max_depth` 2): the mean over
/// many paths of a camera ray's radiance is ρ/π times the irradiance, the points' exact and
/// the rectangle's by quadrature, within four standard errors; with the rectangle's choice
/// probability taken below 1 on either side, it is not.
#[test]
fn every_light_with_a_rectangle_gives_the_direct_illumination() {
    use candela_render::integrator::Path;
    use candela_render::sampling::Sampler;
    let rho = 0.6;
    // Below the light's plane.
    let points = [
        (Point3::new(0.6, 0.2, 0.4), Rgb::new(0.2, 0.1, 0.05)),
        (Point3::new(-0.8, -0.5, 0.3), Rgb::new(0.1, 0.3, 0.1)),
    ];
    let (mut b, _) = plane_under_points(rho, &points);
    let black = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.0))));
    // 2 × 1.6 at z = 0.5, facing down (v × w points to −z): from the point seen below it, a
    // wide light, which BSDF sampling finds as often as light sampling does.
    let (corner, v, w) = (
        Point3::new(-0.9, -0.7, 0.5),
        Vec3::new(0.0, 1.6, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
    );
    let light = Parallelogram::new(corner, v, w).expect("light");
    assert!(light.normal().z < 0.0);
    let radiance = Rgb::new(3.0, 2.0, 1.0);
    let e = b.add_emission(Emission {
        radiance: Texture::Uniform(radiance),
        two_sided: false,
    });
    b.add_shape(Shape::Parallelogram(light), black, Some(e));
    let scene = b.build(AccelKind::Bvh);
    // The point seen, below the light, by a ray passing under it.
    let p = Point3::new(0.1, 0.05, 0.0);
    let mut irradiance = points_irradiance(p, &points);
    // The rectangle: ∫ L cos θp cos θl / r² dA, by the midpoint rule on 400 × 400 cells.
    let n = 400;
    let area = (v.norm() * w.norm()) as f64;
    let mut g = 0.0;
    for a in 0..n {
        for c in 0..n {
            let q = corner + v * ((a as f32 + 0.5) / n as f32) + w * ((c as f32 + 0.5) / n as f32);
            let to = q - p;
            let (x, y, z) = (to.x as f64, to.y as f64, to.z as f64);
            let r2 = x * x + y * y + z * z;
            // Both cosines are z / r (the light faces straight down).
            g += (z * z / r2) / r2;
        }
    }
    g *= area / (n * n) as f64;
    for (e, c) in irradiance
        .iter_mut()
        .zip([radiance.r, radiance.g, radiance.b])
    {
        *e += c as f64 * g;
    }
    let expected = irradiance.map(|e| rho as f64 / std::f64::consts::PI * e);
    let path = Path {
        max_depth: Some(2),
        rr_depth: 5,
        hide_emitters: false,
    };
    let o = Point3::new(3.0, 0.0, 0.25);
    let ray = Ray::new(o, (p - o).normalize());
    let mut sampler = Sampler::new(0, 0);
    let count = 40_000;
    let (mut sum, mut sum2) = ([0f64; 3], [0f64; 3]);
    for index in 0..count {
        let l = path_sample(&path, &scene, &ray, &mut sampler, (11, index, 1));
        for (k, x) in l.into_iter().enumerate() {
            sum[k] += x as f64;
            sum2[k] += x as f64 * x as f64;
        }
    }
    for k in 0..3 {
        let mean = sum[k] / count as f64;
        let var = sum2[k] / count as f64 - mean * mean;
        let se = (var / count as f64).sqrt();
        assert!(
            (mean - expected[k]).abs() <= 4.0 * se + 1e-6 * expected[k],
            "channel {k}: {mean} ± {se} against {}",
            expected[k]
        );
        // Not a trivially wide interval: the light's part is some tenths of the whole.
        assert!(
            se < 0.01 * expected[k],
            "channel {k}: {se} against {}",
            expected[k]
        );
    }
}
