//! Spectra in the candela language: `spectrum(…)` and `blackbody(…)` pigments and light colours,
//! `metal("…")`, dispersive `glass` indices; what they build (the RGB conversion in the right
//! role, the spectra themselves for spectral renders), their errors at `line:col`, and renders
//! of single-bounce scenes agreeing between RGB and spectral mode.

mod support;

use candela_render::light::Light;
use candela_render::material::{Distribution, Model, REFERENCE_WAVELENGTH};
use candela_render::spectrum::{metal, Ior, RgbRole, Spectrum, TabulatedSpectrum};
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene};
use candela_scene::builder::build_scene;
use candela_scene::lang::*;
use candela_scene::{load_scene, LoadOptions};
use std::sync::Arc;
use support::lang::{error_of, parse};
use support::mitsuba::tmpdir;

/// Builds the scene of `text` (parsed as `scenes/test.txt`).
fn build(text: &str) -> Scene {
    let d = parse(text);
    build_scene(&d, Default::default(), &Default::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .0
}

/// The spectrum and RGB colour of a spectral texture.
fn spectral(t: &Texture) -> (Rgb, Arc<Spectrum>) {
    match t {
        Texture::Spectral { rgb, spectrum } => (*rgb, spectrum.clone()),
        t => panic!("not spectral: {t:?}"),
    }
}

fn tabulated(samples: &[(f32, f32)]) -> Spectrum {
    Spectrum::Tabulated(TabulatedSpectrum::new(samples.to_vec()).unwrap())
}

#[test]
fn spectrum_pigments_keep_their_samples_and_convert_by_role() {
    let text = "material m(diffuse(spectrum(400:0.2, 500:0.5, 700:0.8)), spectrum(400:1, 700:3))\n\
                sphere(m, identity)";
    let d = parse(text);
    let m = &d.materials[0];
    let BrdfKind::Diffuse { kd } = &m.brdf.kind else {
        panic!()
    };
    let reflectance = tabulated(&[(400.0, 0.2), (500.0, 0.5), (700.0, 0.8)]);
    assert_eq!(
        kd.kind,
        PigmentKind::Spectrum(SpectrumDef::Inline(reflectance.clone()))
    );
    // Piecewise linear, 0 outside: halfway between 400 and 500 nm, and beyond 700 nm.
    assert!((reflectance.eval(450.0) - 0.35).abs() < 1e-6);
    assert_eq!(reflectance.eval(750.0), 0.0);

    // Built: the reflectance converts as a reflectance, the emission as an emission.
    let scene = build(text);
    let Model::Diffuse { reflectance: tex } = &scene.materials[0].model else {
        panic!()
    };
    let (rgb, s) = spectral(tex);
    assert_eq!(*s, reflectance);
    assert_eq!(rgb, reflectance.to_rgb(RgbRole::Reflectance));
    let emission = tabulated(&[(400.0, 1.0), (700.0, 3.0)]);
    let (rgb, s) = spectral(&scene.emissions[0].radiance);
    assert_eq!(*s, emission);
    assert_eq!(rgb, emission.to_rgb(RgbRole::Emission));
    // The roles differ: the emission is not lit by D65 and not clamped to 1.
    assert_ne!(rgb, emission.to_rgb(RgbRole::Reflectance));
    assert!(rgb.g > 1.0, "{rgb:?}");

    // Wherever a pigment goes: phong, cook_torrance, glass's kt, checkered's neighbours.
    let d = parse(
        "material a(phong(spectrum(400:0.1, 700:0.2), <0.1, 0.1, 0.1>, 10))\n\
         material b(cook_torrance(<0, 0, 0>, spectrum(400:0.9, 700:0.5), 0.2))\n\
         material c(glass(1.5, spectrum(400:1, 700:0.5)))\n\
         material e(diffuse(<0, 0, 0>), blackbody(3000))",
    );
    assert_eq!(d.materials.len(), 4);
    let e = &d.materials[3].emission.kind;
    assert_eq!(
        *e,
        PigmentKind::Spectrum(SpectrumDef::Inline(Spectrum::blackbody(3000.0, 1.0)))
    );
}

/// Planck's law in Mitsuba's units (W·m⁻²·sr⁻¹·nm⁻¹): the documented luminance of a 6500 K
/// blackbody, the scale, and the conversion of an environment.
#[test]
fn blackbody_emission_is_plancks_law_times_the_scale() {
    let scene = build(
        "material lamp(diffuse(<0, 0, 0>), blackbody(6500))\n\
         material dim(diffuse(<0, 0, 0>), blackbody(6500, 1 / 42000))\n\
         sphere(lamp, identity)\nsphere(dim, translation([3, 0, 0]))\n\
         environment(blackbody(2700, 0.01))",
    );
    let (rgb, s) = spectral(&scene.emissions[0].radiance);
    assert_eq!(*s, Spectrum::blackbody(6500.0, 1.0));
    // B(550 nm, 6500 K) = 2hc²/λ⁵ / (exp(hc/λkT) − 1) · 1e-9 per nm, computed by hand:
    // 2hc²/λ⁵ = 1.1910e-16 / 5.0328e-32 = 2.3665e15; hc/λkT = 4.0250; exp − 1 = 54.998.
    let expected = 2.3665e15 / 54.998 * 1e-9;
    assert!(
        (s.eval(550.0) / expected - 1.0).abs() < 1e-3,
        "{} vs {expected}",
        s.eval(550.0)
    );
    // Its luminance (Y, with ∫ȳ = 1) is about 4.2e4, as the language reference says.
    let y = |c: Rgb| 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
    assert!((y(rgb) / 4.2e4 - 1.0).abs() < 0.01, "{rgb:?}");
    // 1/42000 of it is about unit luminance, and the scale is linear.
    let (dim, _) = spectral(&scene.emissions[1].radiance);
    assert!((y(dim) - y(rgb) / 42000.0).abs() < 1e-5 * y(rgb) / 42000.0 + 1e-6);
    assert!((y(dim) - 1.0).abs() < 0.01, "{dim:?}");
    // A 6500 K blackbody is close to white (D65's correlated colour temperature).
    assert!(dim.b / dim.r > 0.9 && dim.b / dim.r < 1.1, "{dim:?}");
    // The environment's radiance is a spectral texture too.
    let env = scene
        .lights
        .iter()
        .find_map(|l| match l {
            Light::Environment(e) => Some(e),
            _ => None,
        })
        .expect("an environment");
    let (rgb, s) = spectral(&env.radiance);
    assert_eq!(
        rgb,
        Spectrum::blackbody(2700.0, 0.01).to_rgb(RgbRole::Emission)
    );
    assert_eq!(*s, Spectrum::blackbody(2700.0, 0.01));
    // 2700 K is warm: more red than blue.
    assert!(rgb.r > 2.0 * rgb.b, "{rgb:?}");
}

#[test]
fn lights_take_spectra_with_their_emission_colour() {
    let bb = Spectrum::blackbody(3000.0, 1e-3);
    let list = tabulated(&[(450.0, 2.0), (650.0, 1.0)]);
    let text = "point_light([0, 0, 5], blackbody(3000, 1e-3), 0)\n\
                spot_light([0, 0, 4], [0, 0, -1], spectrum(450:2, 650:1), 30, 2)\n\
                distant_light([0, 0, -1], blackbody(3000, 1e-3), components(<0.1, 0.1, 0.1>, <1, 1, 1>, <1, 1, 1>))\n\
                point_light([1, 0, 5], <1, 2, 3>, 0)";
    let d = parse(text);
    assert_eq!(d.lights[0].spectrum, Some(SpectrumDef::Inline(bb.clone())));
    assert_eq!(d.lights[0].intensity(), bb.to_rgb(RgbRole::Emission));
    // The local model's default components are the conversion.
    let c = d.lights[0].local_components();
    assert_eq!(
        (c.ambient, c.diffuse, c.specular),
        (Rgb::BLACK, c.diffuse, c.diffuse)
    );
    assert_eq!(c.diffuse, bb.to_rgb(RgbRole::Emission));
    assert_eq!(
        d.lights[1].spectrum,
        Some(SpectrumDef::Inline(list.clone()))
    );
    assert!(d.lights[2].components.is_some());
    assert_eq!(d.lights[3].spectrum, None);

    let scene = build(text);
    let lights: Vec<_> = scene
        .lights
        .iter()
        .filter(|l| !matches!(l, Light::Environment(_)))
        .collect();
    match lights[0] {
        Light::Point(p, _) => {
            assert_eq!(p.spectrum.as_deref(), Some(&bb));
            assert_eq!(p.intensity, bb.to_rgb(RgbRole::Emission));
        }
        l => panic!("{l:?}"),
    }
    match lights[1] {
        Light::Spot(s, _) => {
            assert_eq!(s.spectrum.as_deref(), Some(&list));
            assert_eq!(s.intensity, list.to_rgb(RgbRole::Emission));
        }
        l => panic!("{l:?}"),
    }
    match lights[2] {
        Light::Distant(s, comp) => {
            assert_eq!(s.spectrum.as_deref(), Some(&bb));
            assert_eq!(s.irradiance, bb.to_rgb(RgbRole::Emission));
            assert_eq!(comp.ambient, Rgb::splat(0.1));
        }
        l => panic!("{l:?}"),
    }
    match lights[3] {
        Light::Point(p, _) => {
            assert_eq!(p.spectrum, None);
            assert_eq!(p.intensity, Rgb::new(1.0, 2.0, 3.0));
        }
        l => panic!("{l:?}"),
    }
}

#[test]
fn spectrum_files_are_read_beside_the_scene_and_recorded_as_inputs() {
    let dir = tmpdir("lang-spd");
    std::fs::write(
        dir.join("warm.spd"),
        "# a warm lamp\n400 0.5\n550 1.0 # peak\n\n700 2\n",
    )
    .unwrap();
    let scene_path = dir.join("s.scene");
    std::fs::write(
        &scene_path,
        "material lamp(diffuse(spectrum(\"warm.spd\")), spectrum(\"warm.spd\"))\n\
         sphere(lamp, identity)\npoint_light([0, 0, 3], spectrum(\"warm.spd\"), 0)\n",
    )
    .unwrap();
    let l = load_scene(&scene_path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let expected = tabulated(&[(400.0, 0.5), (550.0, 1.0), (700.0, 2.0)]);
    let Model::Diffuse { reflectance } = &l.scene.materials[0].model else {
        panic!()
    };
    let (rgb, s) = spectral(reflectance);
    assert_eq!(*s, expected);
    // Values above 1 are clamped by the reflectance conversion, not the emission's.
    assert_eq!(rgb, expected.to_rgb(RgbRole::Reflectance));
    let (rgb, _) = spectral(&l.scene.emissions[0].radiance);
    assert_eq!(rgb, expected.to_rgb(RgbRole::Emission));
    let Some(Light::Point(p, _)) = l.scene.lights.first() else {
        panic!()
    };
    assert_eq!(p.intensity, expected.to_rgb(RgbRole::Emission));
    assert_eq!(p.spectrum.as_deref(), Some(&expected));
    // Read once, and part of the scene's inputs (partial renders' scene hash).
    let spd = dir.join("warm.spd");
    assert_eq!(
        l.inputs.iter().filter(|p| **p == spd).count(),
        1,
        "{:?}",
        l.inputs
    );

    // A bad file is an error at the string, with the line of the file.
    std::fs::write(dir.join("bad.spd"), "400 0.5\n380 1\n").unwrap();
    std::fs::write(
        &scene_path,
        "material m(diffuse(spectrum(\"bad.spd\")))\nsphere(m, identity)\n",
    )
    .unwrap();
    let e = load_scene(&scene_path, &LoadOptions::default()).unwrap_err();
    let msg = format!("{}: {}", e.pos.unwrap_or_default(), e.message);
    assert!(
        msg.starts_with("1:29: spectrum 'bad.spd' (line 2): wavelengths must increase"),
        "{msg}"
    );
    std::fs::write(dir.join("neg.spd"), "400 0.5\n500 -1\n").unwrap();
    std::fs::write(
        &scene_path,
        "material m(diffuse(<1, 1, 1>), spectrum(\"neg.spd\"))\nsphere(m, identity)\n",
    )
    .unwrap();
    let e = load_scene(&scene_path, &LoadOptions::default()).unwrap_err();
    assert!(
        e.message
            .contains("500:-1 is not a positive wavelength with a non-negative value"),
        "{e}"
    );
    std::fs::write(
        &scene_path,
        "material m(diffuse(spectrum(\"nowhere.spd\")))\nsphere(m, identity)\n",
    )
    .unwrap();
    let e = load_scene(&scene_path, &LoadOptions::default()).unwrap_err();
    let msg = format!("{}: {}", e.pos.unwrap_or_default(), e.message);
    assert!(
        msg.starts_with("1:29: spectrum file 'nowhere.spd' not found"),
        "{msg}"
    );
}

#[test]
fn metals_are_measured_conductors() {
    let scene = build(
        "material gold(metal(\"Au\"))\nmaterial copper(metal(\"Cu\", 0.2, \"beckmann\"))\n\
         material silver(metal(\"Ag\", 0.1))\nmaterial mirror(metal(\"Au\", 0))",
    );
    let (eta, k) = metal("Au").unwrap();
    let Model::Conductor {
        eta_k: Some((e, kk)),
        reflectance,
        mf: None,
    } = &scene.materials[0].model
    else {
        panic!("{:?}", scene.materials[0].model)
    };
    let (rgb, s) = spectral(e);
    assert_eq!(*s, eta);
    assert_eq!(rgb, eta.to_rgb(RgbRole::OpticalConstant));
    let (rgb, s) = spectral(kk);
    assert_eq!(*s, k);
    assert_eq!(rgb, k.to_rgb(RgbRole::OpticalConstant));
    assert!(matches!(reflectance, Texture::Uniform(c) if *c == Rgb::WHITE));
    // Gold's k is larger in the red than in the blue: it reflects red more (its yellow).
    assert!(rgb.r > rgb.b, "{rgb:?}");
    let Model::Conductor {
        eta_k: Some((e, _)),
        mf: Some(mf),
        ..
    } = &scene.materials[1].model
    else {
        panic!()
    };
    assert_eq!(*spectral(e).1, metal("Cu").unwrap().0);
    assert_eq!((mf.dist, mf.alpha), (Distribution::Beckmann, 0.2));
    let Model::Conductor { mf: Some(mf), .. } = &scene.materials[2].model else {
        panic!()
    };
    assert_eq!((mf.dist, mf.alpha), (Distribution::Ggx, 0.1));
    assert!(matches!(
        scene.materials[3].model,
        Model::Conductor { mf: None, .. }
    ));
}

#[test]
fn glass_indices_may_vary_with_the_wavelength() {
    let glass = |text: &str| {
        let d = parse(&format!("material g(glass({text}))"));
        let BrdfKind::Glass {
            ior, dispersion, ..
        } = &d.materials[0].brdf.kind
        else {
            panic!()
        };
        (*ior, dispersion.clone())
    };
    // N-BK7's catalogue n_d (587.56 nm) is 1.51680.
    let (n, disp) = glass("sellmeier(\"bk7\")");
    assert!((n - 1.5168).abs() < 1e-4, "{n}");
    assert_eq!(disp, Ior::glass("bk7"));
    // N-SF11: n_d = 1.78472; names are case-insensitive, as Ior::glass reads them.
    let (n, _) = glass("sellmeier(\"N-SF11\")");
    assert!((n - 1.78472).abs() < 1e-4, "{n}");
    // Cauchy: 1.5 + 0.01 / 0.58756² = 1.528966.
    let (n, disp) = glass("cauchy(1.5, 0.01)");
    assert!((n - 1.528966).abs() < 1e-5, "{n}");
    assert_eq!(disp, Some(Ior::Cauchy { a: 1.5, b: 0.01 }));
    // A table: 1.6 − 0.1 · (587.56 − 400) / 300 = 1.537480.
    let (n, disp) = glass("spectrum(400:1.6, 700:1.5)");
    assert!((n - 1.53748).abs() < 1e-5, "{n}");
    assert!(matches!(disp, Some(Ior::Tabulated(_))));
    // No dispersion when the index does not vary.
    assert_eq!(glass("cauchy(1.4, 0)"), (1.4, None));
    assert_eq!(glass("spectrum(400:1.5, 700:1.5)"), (1.5, None));
    assert_eq!(glass("1.5"), (1.5, None));
    // A variable named like a keyword is still a number.
    let d = parse("float cauchy(1.25)\nmaterial g(glass(cauchy))");
    assert!(matches!(
        d.materials[0].brdf.kind,
        BrdfKind::Glass {
            ior: 1.25,
            dispersion: None,
            ..
        }
    ));

    // Built: the dielectric's RGB eta is the index at the reference, its dispersion the
    // interior's index in air.
    let scene = build("material g(glass(sellmeier(\"sf11\"), <0.9, 0.9, 0.9>))");
    let Model::Dielectric {
        eta, dispersion, ..
    } = &scene.materials[0].model
    else {
        panic!()
    };
    let d = dispersion.as_deref().expect("dispersion");
    assert_eq!(d.exterior, 1.0);
    assert_eq!(d.interior, Ior::glass("sf11").unwrap());
    assert_eq!(*eta, d.interior.eval(REFERENCE_WAVELENGTH));
    // Dense flint disperses: blue bends more than red.
    assert!(d.interior.eval(450.0) > d.interior.eval(650.0) + 0.02);
}

/// Every bad spectrum is an error at the offending token.
#[test]
fn bad_spectra_are_positioned_errors() {
    let cases: &[(&str, &str)] = &[
        // Odd pairs: a wavelength without its value.
        (
            "material m(diffuse(spectrum(400:0.2, 500)))",
            "1:41: expected ':' (a spectrum is wavelength:value pairs) but found ')'",
        ),
        (
            "material m(diffuse(spectrum(400, 0.2)))",
            "1:32: expected ':' (a spectrum is wavelength:value pairs) but found ','",
        ),
        (
            "material m(diffuse(spectrum(500:0.2, 400:0.3)))",
            "1:38: wavelengths must increase: 400 nm follows 500 nm",
        ),
        (
            "material m(diffuse(spectrum(500:0.2, 500:0.3)))",
            "1:38: wavelengths must increase: 500 nm follows 500 nm",
        ),
        (
            "material m(diffuse(spectrum(400:0.2)))",
            "1:20: a spectrum needs at least two wavelength:value samples (found 1)",
        ),
        (
            "material m(diffuse(spectrum()))",
            "1:29: expected a number but found ')'",
        ),
        (
            "material m(diffuse(spectrum(-400:0.2, 500:1)))",
            "1:29: a wavelength must be positive (nm) (found -400)",
        ),
        (
            "material m(diffuse(spectrum(400:-0.2, 500:1)))",
            "1:33: a spectrum value must not be negative (found -0.2)",
        ),
        (
            "material m(diffuse(spectrum(400:1e30 * 1e30, 500:1)))",
            "1:33: the expression is not a finite number (inf)",
        ),
        (
            "material m(diffuse(<0, 0, 0>), spectrum(400:3e38, 700:3e38))",
            "1:32: the spectrum's values are too large (its colour is not finite)",
        ),
        (
            "material m(diffuse(<0, 0, 0>), blackbody(-5))",
            "1:42: the temperature must be positive (kelvin) (found -5)",
        ),
        (
            "material m(diffuse(<0, 0, 0>), blackbody(0))",
            "1:42: the temperature must be positive (kelvin) (found 0)",
        ),
        (
            "material m(diffuse(<0, 0, 0>), blackbody(6500, -1))",
            "1:48: the scale must not be negative (found -1)",
        ),
        (
            "material m(diffuse(<0, 0, 0>), blackbody(1e30, 1e30))",
            "1:32: the blackbody's radiance is not finite (the temperature or the scale is too large)",
        ),
        (
            "material m(diffuse(<0, 0, 0>), blackbody(6500, 3e38))",
            "1:32: the blackbody's radiance is not finite (the temperature or the scale is too large)",
        ),
        (
            "material m(diffuse(blackbody(6500)))",
            "1:20: a blackbody is an emission, not a reflectance: use it for a material's emission, a light or the environment",
        ),
        (
            "hemisphere_light(blackbody(6500))",
            "1:18: hemisphere_light takes an RGB colour '<r, g, b>' (spectra are for point, spot and distant lights, emissions and the environment)",
        ),
        (
            "point_light([0, 0, 1], spectrum(400:1), 0)",
            "1:24: a spectrum needs at least two wavelength:value samples (found 1)",
        ),
        (
            "material m(metal(\"au\"))",
            "1:18: unknown metal 'au' (names are case-sensitive; known: ",
        ),
        (
            "material m(metal(\"Au\", -0.1))",
            "1:24: the roughness must not be negative (found -0.1)",
        ),
        (
            "material m(metal(\"Au\", 0.1, \"phong\"))",
            "1:29: expected \"beckmann\" or \"ggx\" but found string \"phong\"",
        ),
        (
            "material m(metal(Au))",
            "1:18: expected a metal name string such as \"Au\" but found 'Au'",
        ),
        (
            "material m(glass(sellmeier(\"crown\")))",
            "1:28: unknown glass 'crown' (known: \"bk7\", \"n-bk7\", \"fused silica\", \"fused quartz\", \"sf11\", \"n-sf11\", \"f2\")",
        ),
        (
            "material m(glass(cauchy(-1, 0)))",
            "1:18: the index of refraction must be positive over the visible range (it is -1 at 360 nm)",
        ),
        (
            "material m(glass(cauchy(1, -1)))",
            "1:18: the index of refraction must be positive over the visible range (it is -6.716049 at 360 nm)",
        ),
        (
            "material m(glass(spectrum(400:1.5, 700:0)))",
            "1:40: the index of refraction must be positive (found 0)",
        ),
        (
            "material m(glass(spectrum(\"n.spd\")))",
            "1:27: expected wavelength:index pairs (a glass's index is written in the scene, not read from a file) but found string \"n.spd\"",
        ),
        (
            "material m(glass(-1.5))",
            "1:18: the index of refraction must be positive (found -1.5)",
        ),
    ];
    for (text, expected) in cases {
        let got = error_of(text);
        assert!(
            got.starts_with(expected),
            "{text}\n  got:      {got}\n  expected: {expected}"
        );
    }
    // Every known metal is listed in the message.
    let msg = error_of("material m(metal(\"Unobtainium\"))");
    for name in candela_render::spectrum::metal_names() {
        assert!(msg.contains(name), "{name} missing from {msg}");
    }
    // Too many samples: the error is at the first sample over the cap.
    let mut text = String::from("material m(diffuse(spectrum(");
    for i in 0..=MAX_SPECTRUM_SAMPLES {
        if i > 0 {
            text.push_str(", ");
        }
        text.push_str(&format!("{}:0.5", 360 + i));
    }
    text.push_str(")))");
    let got = error_of(&text);
    let col = text
        .find(&format!("{}:0.5", 360 + MAX_SPECTRUM_SAMPLES))
        .unwrap()
        + 1;
    assert_eq!(
        got,
        format!("1:{col}: a spectrum has at most {MAX_SPECTRUM_SAMPLES} samples")
    );
}

/// The per-pixel difference spectral − RGB of a render of `text` at `spp` samples per pixel:
/// its mean and the standard error of the mean, per channel, and the RGB render's mean.
fn spectral_minus_rgb(text: &str, spp: u32) -> ([f64; 3], [f64; 3], [f64; 3]) {
    use candela_render::integrator::Path;
    use candela_render::render::{render, RenderSettings};
    let mut scene = build(text);
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp,
        ..Default::default()
    };
    let rgb = render(&scene, &Path::default(), &settings, &|_| {}).image;
    scene.prepare_spectral();
    let spectral_settings = RenderSettings {
        spectral: true,
        ..settings
    };
    let spec = render(&scene, &Path::default(), &spectral_settings, &|_| {}).image;
    let n = rgb.pixels().len() as f64;
    let (mut mean, mut se, mut rgb_mean) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    for c in 0..3 {
        let ch = |p: &Rgb| [p.r, p.g, p.b][c] as f64;
        let d: Vec<f64> = spec
            .pixels()
            .iter()
            .zip(rgb.pixels())
            .map(|(s, r)| ch(s) - ch(r))
            .collect();
        let m = d.iter().sum::<f64>() / n;
        let var = d.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
        mean[c] = m;
        se[c] = (var / n).sqrt();
        rgb_mean[c] = rgb.pixels().iter().map(ch).sum::<f64>() / n;
    }
    (mean, se, rgb_mean)
}

/// Single-bounce scenes render the same colour in RGB and spectral mode, up to the noise of
/// the wavelength sampling: a `blackbody` emitter seen directly (its RGB colour is the
/// spectrum's emission conversion, the colour spectral rendering estimates), and a diffuse
/// plane of a `spectrum` reflectance lit by a white distant light (white is D65 in spectral
/// mode, and the reflectance conversion is the colour of the reflectance under D65).
///
/// Tolerance: the mean per-pixel difference must be within 4 standard errors of 0 (pixels are
/// independent estimates, so the standard error of their mean is sd/√n); a false failure has
/// probability ~6e-5 per channel. An absolute 2e-4 of the RGB mean allows for the two
/// quadratures of the CIE integrals (1 nm trapezoid vs the film's f32 conversion).
#[test]
fn single_bounce_scenes_agree_between_rgb_and_spectral_rendering() {
    let camera = "camera(perspective, identity, 1, 1)\n";
    let scenes = [
        format!(
            "material lamp(diffuse(<0, 0, 0>), blackbody(4000, 1 / 3500))\n\
             parallelogram(lamp, [2, -5, -5], [0, 10, 0], [0, 0, 10])\n{camera}"
        ),
        format!(
            "material paper(diffuse(spectrum(400:0.2, 450:0.3, 500:0.6, 600:0.7, 700:0.4)))\n\
             parallelogram(paper, [2, -5, -5], [0, 10, 0], [0, 0, 10])\n\
             distant_light([1, 0.3, 0.2], <3, 3, 3>)\n{camera}"
        ),
    ];
    for text in &scenes {
        let (mean, se, rgb_mean) = spectral_minus_rgb(text, 16);
        for c in 0..3 {
            assert!(
                rgb_mean[c] > 0.05,
                "{text}: channel {c} is dark: {rgb_mean:?}"
            );
            let tolerance = 4.0 * se[c] + 2e-4 * rgb_mean[c];
            assert!(
                mean[c].abs() < tolerance,
                "{text}: channel {c}: spectral − RGB = {} ± {} (RGB mean {})",
                mean[c],
                se[c],
                rgb_mean[c]
            );
            // The spectral render samples wavelengths (it is noisy where the RGB render of a
            // uniform colour is not), and the test has power (the noise is small).
            assert!(
                se[c] > 0.0 && se[c] < 0.05 * rgb_mean[c],
                "{se:?} {rgb_mean:?}"
            );
        }
    }
    // The emitter seen directly is exactly its conversion in RGB mode.
    let (_, _, rgb_mean) = spectral_minus_rgb(&scenes[0], 1);
    let expected = Spectrum::blackbody(4000.0, 1.0 / 3500.0).to_rgb(RgbRole::Emission);
    for (got, want) in rgb_mean.iter().zip([expected.r, expected.g, expected.b]) {
        assert!(
            (got - want as f64).abs() < 1e-5 * want as f64,
            "{rgb_mean:?} {expected:?}"
        );
    }
}
