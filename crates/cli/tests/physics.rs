//! Path tracing scenes of the candela language: two independent unbiased estimators (NEE + MIS,
//! and the course's branching estimator) converge to the same image.

use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::render::{render, RenderSettings};
use candela_render::Image;
use candela_scene::{load_scene, LoadOptions};
use std::path::Path;

fn render_example(
    name: &str,
    integrator: &str,
    settings: IntegratorSettings,
    spp: u32,
    seed: u64,
) -> Image {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name);
    let loaded = load_scene(&path, &LoadOptions::default()).unwrap();
    let integ = IntegratorKind::from_name(integrator)
        .unwrap()
        .build(&loaded.scene, &settings)
        .unwrap()
        .integrator;
    let rs = RenderSettings {
        width: 24,
        height: 24,
        spp,
        seed,
        ..Default::default()
    };
    render(&loaded.scene, integ.as_ref(), &rs, &|_| {}).image
}

/// Mean and standard error of the per-pixel means of several independent renders.
fn mean_and_error(images: &[Image]) -> ([f64; 3], [f64; 3]) {
    let n = images.len() as f64;
    let means: Vec<[f64; 3]> = images.iter().map(|i| i.mean()).collect();
    let mut m = [0.0; 3];
    let mut e = [0.0; 3];
    for c in 0..3 {
        m[c] = means.iter().map(|x| x[c]).sum::<f64>() / n;
        let var = means.iter().map(|x| (x[c] - m[c]).powi(2)).sum::<f64>() / (n - 1.0);
        e[c] = (var / n).sqrt();
    }
    (m, e)
}

/// The course's demo scene (an emissive sky plane, a checkered ground, a mirror sphere) under
/// `path` (NEE + MIS) and under the course's estimator (`--num-of-rays 3`, roulette from depth 3):
/// the image means agree within 4 combined standard errors.
#[test]
fn course_demo_estimators_agree() {
    let nee: Vec<Image> = (0..6)
        .map(|s| {
            render_example(
                "course-demo.scene",
                "path",
                IntegratorSettings::default(),
                32,
                s,
            )
        })
        .collect();
    let course_settings = || IntegratorSettings {
        num_of_rays: 3,
        rr_depth: Some(3),
        max_depth: Some(12),
        ..Default::default()
    };
    let course: Vec<Image> = (10..16)
        .map(|s| render_example("course-demo.scene", "path", course_settings(), 8, s))
        .collect();
    let (a, ea) = mean_and_error(&nee);
    let (b, eb) = mean_and_error(&course);
    for c in 0..3 {
        let z = (a[c] - b[c]).abs() / (ea[c] * ea[c] + eb[c] * eb[c]).sqrt().max(1e-6);
        assert!(
            z < 4.0,
            "channel {c}: path {} ± {}, course {} ± {} (z = {z:.2})",
            a[c],
            ea[c],
            b[c],
            eb[c]
        );
        assert!(a[c] > 0.01);
    }
    for img in nee.iter().chain(&course) {
        assert!(img.pixels().iter().all(|p| p.is_finite()));
    }
}

/// Glossy materials of the language (Phong, Blinn–Phong, Cook–Torrance, glass) under the path
/// tracer: two seeds agree within their noise, and no pixel is NaN.
#[test]
fn language_materials_under_path() {
    let imgs: Vec<Image> = (0..6)
        .map(|s| {
            render_example(
                "materials.scene",
                "path",
                IntegratorSettings::default(),
                16,
                s,
            )
        })
        .collect();
    let (m, e) = mean_and_error(&imgs);
    for c in 0..3 {
        assert!(
            m[c] > 0.0 && e[c] < 0.05 * m[c],
            "channel {c}: {} ± {}",
            m[c],
            e[c]
        );
    }
}
