//! The Cornell box of ../shared/bench (Mitsuba 3 XML, copied to examples/cornell-box.xml)
//! against Mitsuba 3.9.1's own render at ~2800 spp, block-averaged from 512² to 64² (the box
//! filter makes that exact): the mean luminance agrees within 1 %, every pixel's error is
//! consistent with candela's noise (a per-pixel z-test), and the error shrinks as samples grow.

use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::render::{render, RenderSettings};
use candela_render::{Image, Rgb};
use candela_scene::{load_scene, LoadOptions};
use std::path::Path;

const SIZE: usize = 64;

fn reference() -> Image {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cornell-reference-64.pfm");
    candela_imageio::read_image(&path).unwrap()
}

fn renders(spp: u32, seeds: std::ops::Range<u64>) -> Vec<Image> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/cornell-box.xml");
    let loaded = load_scene(&path, &LoadOptions::default()).unwrap();
    let settings = IntegratorSettings {
        max_depth: loaded.hints.max_depth,
        rr_depth: loaded.hints.rr_depth,
        hide_emitters: loaded.hints.hide_emitters,
        ..Default::default()
    };
    let integ = IntegratorKind::Path
        .build(&loaded.scene, &settings)
        .unwrap()
        .integrator;
    seeds
        .map(|seed| {
            let rs = RenderSettings {
                width: SIZE,
                height: SIZE,
                spp,
                seed,
                ..Default::default()
            };
            render(&loaded.scene, integ.as_ref(), &rs, &|_| {}).image
        })
        .collect()
}

fn luminance(p: Rgb) -> f64 {
    p.luminance() as f64
}

#[test]
fn cornell_box_matches_mitsuba_statistically() {
    let reference = reference();
    let n = 8;
    let imgs = renders(32, 0..n);
    let px = SIZE * SIZE;
    // Per-pixel mean and standard error over independent renders.
    let mut mean = vec![[0f64; 3]; px];
    let mut sq = vec![[0f64; 3]; px];
    for img in &imgs {
        for (i, p) in img.pixels().iter().enumerate() {
            for (c, v) in p.to_array().into_iter().enumerate() {
                mean[i][c] += v as f64 / n as f64;
                sq[i][c] += (v as f64).powi(2) / n as f64;
            }
        }
    }
    // Mean luminance within 1 %.
    let lum = |f: &dyn Fn(usize) -> Rgb| (0..px).map(|i| luminance(f(i))).sum::<f64>() / px as f64;
    let ours = lum(&|i| Rgb::new(mean[i][0] as f32, mean[i][1] as f32, mean[i][2] as f32));
    let theirs = lum(&|i| reference.pixels()[i]);
    assert!(
        (ours / theirs - 1.0).abs() < 0.01,
        "mean luminance {ours} vs Mitsuba {theirs}"
    );
    // t-test per pixel and channel at α = 0.01 (the standard error comes from n = 8 renders:
    // Student's t with 7 degrees of freedom, critical value 3.4995); the light's pixels
    // (constant radiance) have no variance and are compared with a small relative tolerance.
    let (mut tested, mut failed) = (0usize, 0usize);
    for i in 0..px {
        for c in 0..3 {
            let var = (sq[i][c] - mean[i][c] * mean[i][c]).max(0.0) * n as f64 / (n as f64 - 1.0);
            let se = (var / n as f64).sqrt() + 1e-3 * reference.pixels()[i].to_array()[c] as f64;
            let r = reference.pixels()[i].to_array()[c] as f64;
            tested += 1;
            if (mean[i][c] - r).abs() > 3.4995 * se.max(1e-6) {
                failed += 1;
            }
        }
    }
    let rate = failed as f64 / tested as f64;
    assert!(
        rate < 0.02,
        "{failed} of {tested} pixel channels fail the z-test ({:.2} %)",
        rate * 100.0
    );
}

#[test]
fn cornell_box_error_shrinks_with_samples() {
    let reference = reference();
    let rmse = |img: &Image| {
        let s: f64 = img
            .pixels()
            .iter()
            .zip(reference.pixels())
            .map(|(a, b)| {
                (*a - *b)
                    .to_array()
                    .iter()
                    .map(|d| (*d as f64).powi(2))
                    .sum::<f64>()
            })
            .sum();
        (s / (3 * SIZE * SIZE) as f64).sqrt()
    };
    let low = rmse(&renders(8, 100..101)[0]);
    let high = rmse(&renders(128, 200..201)[0]);
    // 16× the samples: ideally ¼ of the error; allow for the reference's own noise.
    assert!(
        high < 0.4 * low,
        "RMSE {low:.4} at 8 spp, {high:.4} at 128 spp"
    );
}
