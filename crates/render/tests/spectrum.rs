//! Physics of the spectral foundation (issue 16): the wavelength sampler against its density
//! (χ²), colorimetry (a unit spectrum's Y, D65 white), the RGB → spectrum round trip over the
//! sRGB gamut, Planck's locus, dispersion of named glasses, tabulated spectra, measured
//! conductors against the Mitsuba import's RGB values, and the unbiasedness of hero-wavelength
//! estimators, with and without terminated secondary wavelengths.

mod support;

use support::chi2;

use candela_render::spectrum::cie::{integrate_xyz, xyz_to_linear_srgb_f64, xyz_to_xy};
use candela_render::spectrum::*;
use candela_render::Rgb;

/// A small deterministic generator (SplitMix64) for the Monte Carlo tests.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// The linear sRGB of a reflectance `r` lit by D65 (Y = 1), in f64.
fn reflectance_rgb(r: impl Fn(f32) -> f32) -> [f64; 3] {
    xyz_to_linear_srgb_f64(integrate_xyz(|l| r(l) as f64 * d65_normalized(l) as f64))
}

#[test]
fn rgb_round_trip_over_the_srgb_gamut() {
    let mut worst = (0f64, [0f32; 3], [0f64; 3]);
    let mut out_of_range = 0usize;
    let mut check = |rgb: [f32; 3]| {
        let s = RgbSigmoid::from_rgb(Rgb::new(rgb[0], rgb[1], rgb[2]));
        let bad = (0..=470 * 4).any(|i| !(0.0..=1.0).contains(&s.eval(360.0 + i as f32 * 0.25)));
        out_of_range += bad as usize;
        let back = reflectance_rgb(|l| s.eval(l));
        let e = (0..3)
            .map(|k| (back[k] - rgb[k] as f64).abs())
            .fold(0.0, f64::max);
        if e > worst.0 {
            worst = (e, rgb, back);
        }
    };
    let n = 48;
    for r in 0..=n {
        for g in 0..=n {
            for b in 0..=n {
                check([r, g, b].map(|v| v as f32 / n as f32));
            }
        }
    }
    let mut rng = Rng(7);
    for _ in 0..100_000 {
        check([rng.f32(), rng.f32(), rng.f32()]);
    }
    println!(
        "round trip: max error {:.3e} at {:?} -> {:?}",
        worst.0, worst.1, worst.2
    );
    assert_eq!(out_of_range, 0, "upsampled reflectances leave [0, 1]");
    assert!(
        worst.0 < 1e-3,
        "max error {:.3e} at {:?} -> {:?}",
        worst.0,
        worst.1,
        worst.2
    );
}

/// Mean and standard error of `n` Monte Carlo estimates.
fn monte_carlo(
    n: usize,
    seed: u64,
    mut f: impl FnMut(&mut Rng) -> [f64; 3],
) -> ([f64; 3], [f64; 3]) {
    let mut rng = Rng(seed);
    let (mut s, mut s2) = ([0f64; 3], [0f64; 3]);
    for _ in 0..n {
        let v = f(&mut rng);
        for k in 0..3 {
            s[k] += v[k];
            s2[k] += v[k] * v[k];
        }
    }
    let mut mean = [0.0; 3];
    let mut err = [0.0; 3];
    for k in 0..3 {
        (mean[k], err[k]) = chi2::mean_and_error(s[k], s2[k], n);
    }
    (mean, err)
}

fn assert_estimate(what: &str, mean: [f64; 3], err: [f64; 3], expected: [f64; 3]) {
    for k in 0..3 {
        assert!(
            (mean[k] - expected[k]).abs() <= 4.0 * err[k] + 1e-4,
            "{what}: channel {k}: {} ± {} instead of {}",
            mean[k],
            err[k],
            expected[k]
        );
    }
}

#[test]
fn wavelength_sampler_matches_its_density() {
    // χ² of each lane against the visible density, 94 bins of 5 nm.
    const SAMPLES: usize = 400_000;
    const BINS: usize = 94;
    let level = chi2::sidak(chi2::ALPHA, 4);
    let mut counts = [[0f64; BINS]; 4];
    let mut rng = Rng(1);
    for i in 0..SAMPLES {
        let u = rng.f32();
        let w = SampledWavelengths::sample_visible(u);
        for lane in 0..4 {
            let l = w.lambda(lane);
            assert!((360.0..=830.0).contains(&l));
            if i % 16 == 0 {
                // The reported density is the density at the lane's wavelength…
                // (computed in closed form from the sampled tanh, the same function to f32
                // round-off)
                let p = visible_wavelength_pdf(l);
                assert!(
                    (w.pdf()[lane] - p).abs() <= 1e-5 * p,
                    "{} vs {p}",
                    w.pdf()[lane]
                );
                // …and the lanes are stratified: a quarter apart in the CDF.
                let c = visible_wavelength_cdf(l) as f64;
                let expected = (u as f64 + lane as f64 * 0.25).fract();
                let d = (c - expected).abs();
                assert!(d.min(1.0 - d) < 1e-4, "lane {lane}: cdf {c}, u {u}");
            }
            let bin = (((l - 360.0) / 5.0) as usize).min(BINS - 1);
            counts[lane][bin] += 1.0;
        }
    }
    for (lane, observed) in counts.iter().enumerate() {
        let mut chi2 = 0.0;
        let mut total = 0.0;
        for (b, &o) in observed.iter().enumerate() {
            let lo = 360.0 + 5.0 * b as f32;
            let p = visible_wavelength_cdf(lo + 5.0) as f64 - visible_wavelength_cdf(lo) as f64;
            // Cross-check the CDF against the density (Simpson's rule on the bin).
            let simpson = 5.0 / 6.0
                * (visible_wavelength_pdf(lo) as f64
                    + 4.0 * visible_wavelength_pdf(lo + 2.5) as f64
                    + visible_wavelength_pdf(lo + 5.0) as f64);
            assert!(
                (p - simpson).abs() < 1e-5,
                "bin {b}: cdf {p}, pdf {simpson}"
            );
            let e = p * SAMPLES as f64;
            assert!(e > 5.0);
            chi2 += (o - e) * (o - e) / e;
            total += p;
        }
        assert!((total - 1.0).abs() < 1e-5);
        let p_value = chi2::chi2_survival(chi2, (BINS - 1) as f64);
        println!("lane {lane}: χ² = {chi2:.1}, p = {p_value:.3}");
        assert!(
            p_value > level,
            "lane {lane}: χ² = {chi2:.1}, p = {p_value:.2e}"
        );
    }
}

#[test]
fn unit_spectrum_has_unit_luminance() {
    // Deterministic: the trapezoid integral of the tables.
    let xyz = integrate_xyz(|_| 1.0);
    assert!((xyz[1] - 1.0).abs() < 1e-6, "{xyz:?}");
    assert!((CIE_Y_NORMALIZER - 106.857).abs() < 1e-3);
    // The equal-energy white is (1/3, 1/3) by the CIE's construction.
    let xy = xyz_to_xy(xyz);
    assert!((xy[0] - 1.0 / 3.0).abs() < 1e-3 && (xy[1] - 1.0 / 3.0).abs() < 1e-3);
    // The hero-wavelength estimator converges to it.
    let (mean, err) = monte_carlo(400_000, 2, |rng| {
        let w = SampledWavelengths::sample_visible(rng.f32());
        to_xyz(&SampledSpectrum::ONE, &w).map(|v| v as f64)
    });
    println!("unit spectrum XYZ: {mean:?} ± {err:?}");
    assert_estimate("unit spectrum", mean, err, xyz);
    assert!((mean[1] - 1.0).abs() < 2e-3);
}

#[test]
fn d65_lit_white_is_srgb_white() {
    // Deterministic: a unit reflectance lit by D65 (Y = 1).
    let rgb = reflectance_rgb(|_| 1.0);
    println!("D65 white in linear sRGB: {rgb:?}");
    for c in rgb {
        assert!((c - 1.0).abs() < 1e-3, "{rgb:?}");
    }
    // The spectral film on a white emitter seen through a white reflectance (furnace).
    let light = Spectrum::rgb_illuminant(Rgb::WHITE);
    let albedo = Spectrum::rgb_albedo(Rgb::WHITE);
    let (mean, err) = monte_carlo(200_000, 3, |rng| {
        let w = SampledWavelengths::sample_visible(rng.f32());
        let l = light.eval4(&w) * albedo.eval4(&w);
        let c = xyz_to_linear_srgb(to_xyz(&l, &w));
        [c.r as f64, c.g as f64, c.b as f64]
    });
    println!("spectral white furnace: {mean:?} ± {err:?}");
    assert_estimate("white furnace", mean, err, rgb);
}

#[test]
fn rgb_emitters_and_unbounded_values_render_back_to_their_rgb() {
    let colours = [
        Rgb::new(1.0, 1.0, 1.0),
        Rgb::new(0.8, 0.3, 0.1),
        Rgb::new(17.0, 12.0, 4.0),
        Rgb::new(0.0, 0.5, 2.0),
        Rgb::new(0.05, 0.02, 0.01),
    ];
    for c in colours {
        // Emission: the spectrum's own colour.
        let e = RgbIlluminantSpectrum::new(c);
        let back = xyz_to_linear_srgb_f64(integrate_xyz(|l| e.eval(l) as f64));
        // Unbounded value: its colour under D65.
        let u = RgbUnboundedSpectrum::new(c);
        let back_u = reflectance_rgb(|l| u.eval(l));
        let m = c.max_component() as f64;
        for (k, v) in [c.r, c.g, c.b].into_iter().enumerate() {
            let tol = 1e-3 * m.max(1.0);
            assert!((back[k] - v as f64).abs() < tol, "emitter {c:?} → {back:?}");
            assert!(
                (back_u[k] - v as f64).abs() < tol,
                "unbounded {c:?} → {back_u:?}"
            );
        }
    }
    // And through the Monte Carlo film.
    let c = Rgb::new(3.0, 1.5, 0.5);
    let e = Spectrum::rgb_illuminant(c);
    let (mean, err) = monte_carlo(200_000, 4, |rng| {
        let w = SampledWavelengths::sample_visible(rng.f32());
        let c = xyz_to_linear_srgb(to_xyz(&e.eval4(&w), &w));
        [c.r as f64, c.g as f64, c.b as f64]
    });
    assert_estimate("RGB emitter", mean, err, [3.0, 1.5, 0.5]);
}

#[test]
fn blackbody_chromaticity_is_on_the_planckian_locus() {
    for (t, x, y) in [
        (6500.0, 0.3135, 0.3237),
        (2856.0, 0.4476, 0.4074),
        (5000.0, 0.3451, 0.3516),
    ] {
        let xyz = integrate_xyz(|l| planck(l, t) as f64);
        let xy = xyz_to_xy(xyz);
        println!(
            "{t} K: xy = ({:.5}, {:.5}), Y = {:.4e}",
            xy[0], xy[1], xyz[1]
        );
        assert!(
            (xy[0] - x).abs() < 5e-4 && (xy[1] - y).abs() < 5e-4,
            "{t} K: {xy:?}"
        );
    }
    // Mitsuba's normalisation: absolute spectral radiance, scaled.
    let b = Spectrum::blackbody(6500.0, 2.0);
    assert_eq!(b.eval(500.0), 2.0 * planck(500.0, 6500.0));
    assert!((planck(500.0, 6500.0) / 4.6094e4 - 1.0).abs() < 1e-3);
}

#[test]
fn sellmeier_glasses() {
    let bk7 = Ior::glass("bk7").unwrap();
    assert!(
        (bk7.eval(587.6) - 1.5168).abs() < 1e-4,
        "{}",
        bk7.eval(587.6)
    );
    let silica = Ior::glass("fused silica").unwrap();
    assert!((silica.eval(587.6) - 1.4585).abs() < 1e-4);
    assert!(bk7.eval(400.0) > bk7.eval(700.0));
    let w = SampledWavelengths::new([450.0, 550.0, 650.0, 750.0], [1.0; 4]);
    let n = bk7.eval4(&w);
    assert!(n[0] > n[1] && n[1] > n[2] && n[2] > n[3]);
}

#[test]
fn tabulated_spectra() {
    // A Mitsuba value list (a reflectance of its spectral Cornell box) and the same as a file.
    let list = "400:0.343, 404:0.445, 408:0.551, 412:0.624, 416:0.665";
    let a = Spectrum::parse(list).unwrap();
    let spd =
        "# Cornell box white\n400 0.343\n404 0.445\n\n408 0.551 # comment\n412 0.624\n416 0.665\n";
    let b = Spectrum::parse_spd(spd).unwrap();
    assert_eq!(a, b);
    assert!((a.eval(402.0) - 0.394).abs() < 1e-6);
    assert!((a.eval(414.0) - 0.6445).abs() < 1e-6);
    assert_eq!(a.eval(399.0), 0.0);
    assert_eq!(a.eval(417.0), 0.0);
    let w = SampledWavelengths::new([400.0, 406.0, 416.0, 500.0], [1.0; 4]);
    let v = a.eval4(&w);
    assert!((v[1] - 0.498).abs() < 1e-6);
    assert_eq!(v[3], 0.0);
    let e = Spectrum::parse_spd("400 1\n300 2\n").unwrap_err();
    assert_eq!(e.line, Some(2));
}

#[test]
fn terminated_secondary_wavelengths_stay_unbiased() {
    // ∫ f dλ / ∫ ȳ for a spectrum f = ȳ·R with a non-trivial R, estimated with the secondary
    // wavelengths terminated always, never, or on a decision that depends on the whole set of
    // wavelengths (as a path's decision does: through its four-lane throughput).
    let r = Spectrum::parse("360:0.9, 450:0.2, 550:0.7, 650:0.1, 830:0.5").unwrap();
    let expected = integrate_xyz(|l| r.eval(l) as f64);
    for mode in 0..3 {
        let (mean, err) = monte_carlo(400_000, 10 + mode, |rng| {
            let mut w = SampledWavelengths::sample_visible(rng.f32());
            let v = r.eval4(&w);
            let terminate = match mode {
                0 => true,
                1 => false,
                _ => v.average() > 0.45,
            };
            if terminate {
                w.terminate_secondary();
                assert!(w.secondary_terminated());
            }
            to_xyz(&v, &w).map(|x| x as f64)
        });
        println!("termination mode {mode}: {mean:?} ± {err:?} (expected {expected:?})");
        assert_estimate(&format!("termination mode {mode}"), mean, err, expected);
    }
}

/// The conductor table of the Mitsuba import (`crates/scene/src/mitsuba/presets.rs`):
/// (name, η RGB, k RGB), read from its source.
fn preset_conductors() -> Vec<(String, [f32; 3], [f32; 3])> {
    let src = include_str!("../../scene/src/mitsuba/presets.rs");
    let start = src
        .find("const CONDUCTORS")
        .expect("CONDUCTORS table in presets.rs");
    let body = &src[start..];
    let body = &body[body.find("= &[").unwrap() + 4..body.find("\n];").unwrap()];
    let mut out = Vec::new();
    let mut rest = body;
    while let Some(open) = rest.find('"') {
        rest = &rest[open + 1..];
        let name_end = rest.find('"').unwrap();
        let name = rest[..name_end].to_string();
        let mut arrays = [[0f32; 3]; 2];
        for a in &mut arrays {
            let s = rest.find('[').unwrap();
            let e = rest.find(']').unwrap();
            let nums: Vec<f32> = rest[s + 1..e]
                .split(',')
                .map(|v| v.trim().parse().unwrap())
                .collect();
            *a = [nums[0], nums[1], nums[2]];
            rest = &rest[e + 1..];
        }
        out.push((name, arrays[0], arrays[1]));
    }
    out
}

#[test]
fn measured_metals_match_the_import_rgb_values() {
    let presets = preset_conductors();
    assert!(presets.len() >= 60, "parsed {} conductors", presets.len());
    let mut worst = (0f32, String::new());
    for (name, eta_rgb, k_rgb) in &presets {
        let (eta, k) = metal(name).unwrap_or_else(|| panic!("no measured data for {name}"));
        for (s, want, what) in [(&eta, eta_rgb, "η"), (&k, k_rgb, "k")] {
            let got = s.to_rgb(RgbRole::OpticalConstant);
            for (g, w) in [got.r, got.g, got.b].into_iter().zip(want) {
                let e = (g - w).abs() / w.abs().max(0.05);
                if e > worst.0 {
                    worst = (e, format!("{name} {what}: {got:?} vs {want:?}"));
                }
            }
        }
    }
    println!(
        "metals: worst relative difference {:.2e} ({})",
        worst.0, worst.1
    );
    assert!(worst.0 < 5e-3, "{}", worst.1);
}
