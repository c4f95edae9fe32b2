//! Integrators against analytic scenes: the furnace tests of the rendering equation.

use candela_render::accel::AccelKind;
use candela_render::camera::Camera;
use candela_render::integrator::{Integrator, Path, Whitted};
use candela_render::light::Emission;
use candela_render::light::{Environment, Light};
use candela_render::material::{Material, Model};
use candela_render::math::{Point3, Transform, Vec3};
use candela_render::render::{render, RenderSettings};
use candela_render::shape::{Shape, Sphere};
use candela_render::texture::Texture;
use candela_render::{Image, Rgb, Scene, SceneBuilder};

fn settings(spp: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 12,
        spp,
        seed: 7,
        ..Default::default()
    }
}

/// A uniform environment of radiance 1, the furnaces' only light.
fn add_white_sky(b: &mut SceneBuilder) {
    b.add_light(Light::Environment(Environment::new(
        Texture::Uniform(Rgb::WHITE),
        Transform::IDENTITY,
    )));
}

fn image(scene: &Scene, integrator: &dyn Integrator, spp: u32) -> Image {
    render(scene, integrator, &settings(spp), &|_| {}).image
}

/// The course's furnace: the camera inside a closed sphere of emission L_e and albedo ρ sees
/// L = L_e + ρL everywhere, i.e. L_e/(1 − ρ). Roulette off (a depth limit where ρ^depth is
/// negligible). Inside a sphere, light sampling and BSDF sampling have the same density, so MIS
/// gives both weight ½ and every sample is exact: the test is tight (1e-3).
#[test]
fn closed_sphere_furnace_gives_le_over_one_minus_rho() {
    for (le, rho) in [(1.0f32, 0.5f32), (0.3, 0.8), (2.0, 0.0)] {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(rho))));
        let e = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::splat(le)),
            two_sided: true,
        });
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::scaling(Vec3::new(3.0, 3.0, 3.0)))),
            m,
            Some(e),
        );
        b.camera(Camera::perspective(1.0, 4.0 / 3.0, Transform::IDENTITY));
        let scene = b.build(AccelKind::Bvh);
        let path = Path {
            max_depth: Some(200),
            rr_depth: u32::MAX,
            hide_emitters: false,
        };
        let img = image(&scene, &path, 4);
        let expected = le / (1.0 - rho);
        for p in img.pixels() {
            assert!(
                (p.r - expected).abs() <= 1e-3 * expected.max(1.0),
                "Le {le}, ρ {rho}: {p:?} vs {expected}"
            );
        }
    }
}

/// The same furnace with Russian roulette on: unbiased, so the image mean stays L_e/(1 − ρ).
#[test]
fn furnace_with_roulette_is_unbiased() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.8))));
    let e = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::splat(1.0)),
        two_sided: true,
    });
    b.add_shape(Shape::Sphere(Sphere::new(Transform::IDENTITY)), m, Some(e));
    let scene = b.build(AccelKind::Bvh);
    let img = image(&scene, &Path::default(), 256);
    let mean = img.mean()[0];
    assert!((mean - 5.0).abs() < 0.05, "{mean}");
}

/// White furnaces under a uniform environment of radiance 1: a lossless object (white Lambert,
/// white mirror, clear glass) is invisible, every pixel is 1.
#[test]
fn lossless_materials_vanish_in_a_white_furnace() {
    let models = [
        (
            "white diffuse",
            Model::Diffuse {
                reflectance: Texture::Uniform(Rgb::WHITE),
            },
        ),
        (
            "white mirror",
            Model::Specular {
                reflectance: Texture::Uniform(Rgb::WHITE),
            },
        ),
        (
            "clear glass",
            Model::Dielectric {
                dispersion: None,
                eta: 1.5,
                reflectance: Texture::Uniform(Rgb::WHITE),
                transmittance: Texture::Uniform(Rgb::WHITE),
                mf: None,
            },
        ),
        (
            "ideal conductor",
            Model::Conductor {
                eta_k: None,
                reflectance: Texture::Uniform(Rgb::WHITE),
                mf: None,
            },
        ),
    ];
    for (name, model) in models {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::two_sided(model));
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                4.0, 0.0, 0.0,
            )))),
            m,
            None,
        );
        add_white_sky(&mut b);
        b.camera(Camera::perspective(2.0, 4.0 / 3.0, Transform::IDENTITY));
        let scene = b.build(AccelKind::Bvh);
        let path = Path {
            max_depth: Some(64),
            rr_depth: 64,
            hide_emitters: false,
        };
        let img = image(&scene, &path, 64);
        let mean = img.mean()[0];
        assert!((mean - 1.0).abs() < 0.01, "{name}: mean {mean}");
        for p in img.pixels() {
            assert!((p.r - 1.0).abs() < 0.15, "{name}: pixel {p:?}");
        }
        // Whitted sees the mirror and the glass the same way (no light sampling needed).
        if name != "white diffuse" {
            let w = image(&scene, &Whitted { max_depth: 64 }, 1);
            for p in w.pixels() {
                assert!((p.r - 1.0).abs() < 1e-3, "{name} under Whitted: {p:?}");
            }
        }
    }
}

/// A white furnace whose paths bounce between objects: two white Lambert spheres almost
/// touching, under a uniform environment of radiance 1 and no other light, are invisible too.
/// The path tracer samples such a sky at the first vertex only (deeper, BSDF sampling alone
/// finds it, with the full MIS weight), so this checks that the deeper vertices' escapes are
/// weighed as their vertex sampled (with a weight of ½ there the mean was 0.986).
#[test]
fn interreflecting_white_spheres_vanish_under_the_sky_alone() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
    // Two spheres of radius 2 side by side, a larger one behind them.
    for (x, y, r) in [(3.0, -2.03, 2.0), (3.0, 2.03, 2.0), (9.0, 0.0, 4.0)] {
        let to_world =
            Transform::translation(Vec3::new(x, y, 0.0)) * Transform::scaling(Vec3::new(r, r, r));
        b.add_shape(Shape::Sphere(Sphere::new(to_world)), m, None);
    }
    add_white_sky(&mut b);
    b.camera(Camera::perspective(1.0, 4.0 / 3.0, Transform::IDENTITY));
    let scene = b.build(AccelKind::Bvh);
    let img = image(&scene, &Path::default(), 256);
    let mean = img.mean()[0];
    assert!((mean - 1.0).abs() < 0.005, "mean {mean}");
    for p in img.pixels() {
        assert!((p.r - 1.0).abs() < 0.1, "pixel {p:?}");
    }
}

/// Without a depth limit the roulette still ends every path, even where nothing is absorbed:
/// the camera inside a closed sphere of albedo 1 keeps β = 1 at every bounce, which a survival
/// probability min(β·Πη², 1) would never stop. Capped at 0.95 when the length is unlimited,
/// a path makes 1/0.05 = 20 bounces past `rr_depth` on average. With a depth limit the cap is 1,
/// and the limit ends the paths. No emission: the image is black either way.
#[test]
fn unlimited_paths_end_where_nothing_is_absorbed() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
    b.add_shape(
        Shape::Sphere(Sphere::new(Transform::scaling(Vec3::new(3.0, 3.0, 3.0)))),
        m,
        None,
    );
    b.camera(Camera::perspective(1.0, 4.0 / 3.0, Transform::IDENTITY));
    let scene = b.build(AccelKind::Bvh);
    for (max_depth, rr_depth, most) in [(None, 2, 2.0 + 20.0), (Some(40), 2, 40.0)] {
        let path = Path {
            max_depth,
            rr_depth,
            hide_emitters: false,
        };
        let out = render(&scene, &path, &settings(4), &|_| {});
        assert!(out.image.pixels().iter().all(|p| p.r == 0.0));
        // Camera and bounce rays per sample (no light: no shadow rays).
        let samples = (out.image.width() * out.image.height() * 4) as f64;
        let per_sample = out.stats.rays as f64 / samples;
        assert!(
            per_sample > 0.8 * most && per_sample < 1.2 * most,
            "max_depth {max_depth:?}: {per_sample} rays per path, expected {most}"
        );
    }
}

/// Russian roulette inside glass: clear glass in a white furnace, roulette from the first
/// bounce. Radiance entering the glass is compressed by 1/η² and expanded again on the way out,
/// so the roulette must look at β·Πη² (≈ 1 all along a lossless path: survival 1), not at β
/// alone (≈ 0.44 inside) nor β/Πη² (≈ 0.2, whose survivors count five times: fireflies). Every
/// pixel is 1 in expectation; at 64 spp the pixels must also stay close to it (the image is
/// deterministic: same seed, same pixels).
#[test]
fn roulette_inside_glass_keeps_the_variance_low() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::two_sided(Model::Dielectric {
        dispersion: None,
        eta: 1.5,
        reflectance: Texture::Uniform(Rgb::WHITE),
        transmittance: Texture::Uniform(Rgb::WHITE),
        mf: None,
    }));
    b.add_shape(
        Shape::Sphere(Sphere::new(
            Transform::translation(Vec3::new(2.5, 0.0, 0.0))
                * Transform::scaling(Vec3::new(1.3, 1.3, 1.3)),
        )),
        m,
        None,
    );
    add_white_sky(&mut b);
    b.camera(Camera::perspective(2.0, 4.0 / 3.0, Transform::IDENTITY));
    let scene = b.build(AccelKind::Bvh);
    let path = Path {
        max_depth: Some(64),
        rr_depth: 1,
        hide_emitters: false,
    };
    let img = image(&scene, &path, 64);
    let n = img.pixels().len() as f32;
    let mean = img.pixels().iter().map(|p| p.r).sum::<f32>() / n;
    let rms = (img
        .pixels()
        .iter()
        .map(|p| (p.r - 1.0).powi(2))
        .sum::<f32>()
        / n)
        .sqrt();
    assert!((mean - 1.0).abs() < 0.03, "mean {mean}");
    // 5e-8 with survival min(β·Πη², 1) (0.008 with the cap at 0.95); the old rule,
    // min(β/Πη², 0.95), gave 0.05.
    assert!(rms < 0.02, "pixels scatter around 1 by {rms}");
}

/// Phong, Blinn–Phong and Cook–Torrance under the path tracer conserve energy: with
/// k_d + k_s ≤ 1 an object in a white furnace is never brighter than the furnace.
#[test]
fn glossy_models_conserve_energy_in_a_white_furnace() {
    use candela_render::material::{Distribution, Lobe, Microfacet};
    let kd = Texture::Uniform(Rgb::splat(0.5));
    let ks = Texture::Uniform(Rgb::splat(0.5));
    let models = [
        Model::Phong {
            lobe: Lobe::Phong,
            kd: kd.clone(),
            ks: ks.clone(),
            n: 20.0,
        },
        Model::Phong {
            lobe: Lobe::BlinnPhong,
            kd: kd.clone(),
            ks: ks.clone(),
            n: 20.0,
        },
        Model::CookTorrance {
            kd: kd.clone(),
            ks: ks.clone(),
            mf: Microfacet::new(Distribution::Ggx, 0.3),
            ior: 1.5,
        },
    ];
    for model in models {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::two_sided(model.clone()));
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                4.0, 0.0, 0.0,
            )))),
            m,
            None,
        );
        add_white_sky(&mut b);
        b.camera(Camera::perspective(2.0, 4.0 / 3.0, Transform::IDENTITY));
        let scene = b.build(AccelKind::Bvh);
        let img = image(&scene, &Path::default(), 64);
        let mean = img.mean()[0];
        assert!(mean <= 1.0 + 0.01 && mean > 0.5, "{model:?}: mean {mean}");
        let _ = Point3::ORIGIN;
    }
}

/// The furnace rendered spectrally, with an emission spectrum L_e(λ) and a reflectance
/// spectrum ρ(λ) that vary strongly: every wavelength sees L_e(λ)/(1 − ρ(λ)), so the image is
/// the colour of that spectrum, ∫ L_e/(1 − ρ)·(x̄, ȳ, z̄) dλ / ∫ȳ through the sRGB matrix
/// (integrated here on the 1 nm tables). Each sample is exact at its wavelengths (see the RGB
/// furnace above), so the only noise is the wavelength sampling's: a pixel mean of 64 samples
/// is checked against the expected colour with its standard error, and the image mean within
/// 1 %. A white D65 emitter (an RGB white light) over a white reflectance (an RGB white
/// surface) gives (1, 1, 1)/(1 − ρ) exactly.
#[test]
fn spectral_furnace_gives_the_colour_of_le_over_one_minus_rho() {
    use candela_render::spectrum::{integrate_xyz, xyz_to_linear_srgb_f64, Spectrum};
    let le = Spectrum::parse("360:0.2, 450:1.5, 550:0.5, 650:2.0, 830:0.3").unwrap();
    let rho = Spectrum::parse("360:0.1, 480:0.8, 560:0.2, 620:0.7, 830:0.4").unwrap();
    let expected =
        xyz_to_linear_srgb_f64(integrate_xyz(|l| (le.eval(l) / (1.0 - rho.eval(l))) as f64));
    let cases = [
        (
            Texture::spectrum(le.clone(), Rgb::WHITE),
            Texture::spectrum(rho.clone(), Rgb::WHITE),
            expected,
        ),
        // RGB white light on an RGB white-ish surface: D65 × (1/(1 − 0.5)) is white × 2.
        (
            Texture::Uniform(Rgb::WHITE),
            Texture::Uniform(Rgb::splat(0.5)),
            [2.0; 3],
        ),
    ];
    for (emission, reflectance, expected) in cases {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(reflectance));
        let e = b.add_emission(Emission {
            radiance: emission,
            two_sided: true,
        });
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::scaling(Vec3::new(3.0, 3.0, 3.0)))),
            m,
            Some(e),
        );
        b.camera(Camera::perspective(1.0, 4.0 / 3.0, Transform::IDENTITY));
        let mut scene = b.build(AccelKind::Bvh);
        scene.prepare_spectral();
        let path = Path {
            max_depth: Some(200),
            rr_depth: u32::MAX,
            hide_emitters: false,
        };
        let rs = RenderSettings {
            spectral: true,
            ..settings(64)
        };
        let img = render(&scene, &path, &rs, &|_| {}).image;
        let n = img.pixels().len() as f64;
        for c in 0..3 {
            let v: Vec<f64> = img
                .pixels()
                .iter()
                .map(|p| p.to_array()[c] as f64)
                .collect();
            let mean = v.iter().sum::<f64>() / n;
            // The pixels' spread estimates one pixel's standard error.
            let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            assert!(
                (mean - expected[c]).abs() <= 0.01 * expected[c].abs().max(0.1),
                "channel {c}: image mean {mean} vs {}",
                expected[c]
            );
            let bad = v
                .iter()
                .filter(|&&x| (x - expected[c]).abs() > 4.5 * sd.max(1e-4))
                .count();
            assert!(bad <= 1, "channel {c}: {bad} pixels beyond 4.5 σ ({sd})");
        }
    }
}

/// The lectures' integrators render spectrally too. Under a white light (D65 in spectral
/// renders) an RGB reflectance reflects its own colour (its upsampled spectrum was fitted to
/// do so), so for light that bounces once — `local`, `direct`, and `whitted` with a mirror that
/// shows the lit sphere — the spectral image mean equals the RGB one within the wavelength
/// sampling's noise.
#[test]
fn local_direct_and_whitted_render_spectrally() {
    use candela_render::integrator::Local;
    use candela_render::light::{Components, DistantLight};
    let mut b = SceneBuilder::new();
    let red = b.add_material(Material::diffuse(Texture::Uniform(Rgb::new(0.7, 0.2, 0.1))));
    let mirror = b.add_material(Material::two_sided(Model::Specular {
        reflectance: Texture::Uniform(Rgb::new(0.3, 0.6, 0.9)),
    }));
    b.add_shape(
        Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
            2.5, 0.0, 0.0,
        )))),
        red,
        None,
    );
    b.add_shape(
        Shape::Sphere(Sphere::new(
            Transform::translation(Vec3::new(3.0, -1.3, 0.0))
                * Transform::scaling(Vec3::new(0.6, 0.6, 0.6)),
        )),
        mirror,
        None,
    );
    let irradiance = Rgb::splat(2.0);
    b.add_light(Light::Distant(
        DistantLight {
            direction: Vec3::new(1.0, 0.3, -0.4).normalize(),
            irradiance,
            spectrum: None,
        },
        Components::from_intensity(irradiance),
    ));
    b.camera(Camera::perspective(1.0, 4.0 / 3.0, Transform::IDENTITY));
    let mut scene = b.build(AccelKind::Bvh);
    scene.prepare_spectral();
    let integrators: [(&str, Box<dyn Integrator>); 3] = [
        ("local", Box::new(Local { shadows: false })),
        ("direct", Box::new(Local { shadows: true })),
        ("whitted", Box::new(Whitted { max_depth: 4 })),
    ];
    let mean = |img: &Image, c: usize| {
        img.pixels()
            .iter()
            .map(|p| p.to_array()[c] as f64)
            .sum::<f64>()
            / img.pixels().len() as f64
    };
    for (name, integ) in integrators {
        let rgb = image(&scene, integ.as_ref(), 16);
        // Eight spectral renders from independent seeds: their spread gives the standard
        // error of the spectral mean.
        let runs: Vec<Image> = (0..8)
            .map(|seed| {
                let rs = RenderSettings {
                    spectral: true,
                    seed,
                    ..settings(64)
                };
                render(&scene, integ.as_ref(), &rs, &|_| {}).image
            })
            .collect();
        for c in 0..3 {
            let a = mean(&rgb, c);
            let m: Vec<f64> = runs.iter().map(|img| mean(img, c)).collect();
            let s = m.iter().sum::<f64>() / 8.0;
            let se = (m.iter().map(|x| (x - s).powi(2)).sum::<f64>() / 7.0 / 8.0).sqrt();
            eprintln!("{name} {c}: spectral {s} ± {se} vs RGB {a}");
            assert!(a > 0.0, "{name}: channel {c} is black");
            // Student's t, 7 degrees of freedom, α = 0.002: 4.79; plus the upsampling's fit
            // (1e-3 of the colour).
            assert!(
                (s - a).abs() <= 4.79 * se + 1e-3 * a,
                "{name}: channel {c}: spectral {s} ± {se} vs RGB {a}"
            );
        }
    }
}
