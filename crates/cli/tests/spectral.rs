//! Spectral rendering (issue 16) against Mitsuba 3.9.1's `llvm_ad_spectral` variant and
//! against Snell's law.
//!
//! - examples/mitsuba/spectral-cbox.xml (reflectances and emission given as λ:value lists),
//!   spectral-blackbody.xml (a 4000 K blackbody area light and a 2500 K blackbody point light),
//!   spectral-metals.xml (measured Au, Cu, Ag, smooth and rough) and the RGB-only
//!   glass-mirror-box.xml, rendered by candela with `spectral: true` from independent seeds, are
//!   compared with Mitsuba's spectral renders at 16384 spp (tests/data/NAME-mitsuba-spectral.pfm,
//!   made by scripts/spectral-references.sh): channel means within 1 %, and 4×4-block means
//!   within the renders' noise. Rendered in RGB, the spectral scenes match Mitsuba's
//!   `llvm_ad_rgb` (NAME-mitsuba-rgb.pfm) the same way.
//! - examples/mitsuba/prism.xml (an SF11 prism whose index is given per wavelength with the
//!   `<spectrum name="int_ior">` extension, between the camera and a thin white strip): the
//!   image column where each colour appears is where Snell's law at both faces sends that
//!   wavelength onto the strip.

#[path = "support/reference.rs"]
mod reference;

use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::render::{render, RenderSettings};
use candela_render::spectrum::Ior;
use candela_render::Image;
use candela_scene::{load_scene, LoadOptions, LoadedScene};
use reference::{block_means, check_against_reference};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The scene `examples/mitsuba/NAME.xml` (with `res` = 48 where it has that parameter), ready
/// for spectral renders.
fn load(name: &str, defines: &[(&str, &str)]) -> LoadedScene {
    let opts = LoadOptions {
        defines: defines
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect(),
        ..Default::default()
    };
    let path = root().join(format!("examples/mitsuba/{name}.xml"));
    let mut loaded = load_scene(&path, &opts).unwrap();
    loaded.scene.prepare_spectral();
    loaded
}

/// Renders `loaded` with the path tracer in spectral mode, `spp` samples from seed `seed`.
fn render_spectral(loaded: &LoadedScene, size: (usize, usize), spp: u32, seed: u64) -> Image {
    render_mode(loaded, size, (spp, seed), true)
}

/// Renders `loaded` with the path tracer, spectrally or in RGB.
fn render_mode(
    loaded: &LoadedScene,
    size: (usize, usize),
    (spp, seed): (u32, u64),
    spectral: bool,
) -> Image {
    let settings = IntegratorSettings {
        max_depth: loaded.hints.max_depth,
        rr_depth: loaded.hints.rr_depth,
        ..Default::default()
    };
    let integ = IntegratorKind::Path
        .build(&loaded.scene, &settings)
        .unwrap()
        .integrator;
    let rs = RenderSettings {
        width: size.0,
        height: size.1,
        spp,
        seed,
        filter: loaded.hints.filter.unwrap_or_default(),
        spectral,
        ..Default::default()
    };
    render(&loaded.scene, integ.as_ref(), &rs, &|_| {}).image
}

/// Independent renders per comparison.
const RUNS: u64 = 8;

fn matches_mitsuba_spectral(name: &str, defines: &[(&str, &str)], spp: u32) {
    matches_mitsuba(name, defines, spp, true);
}

/// Compares candela's renders of `examples/mitsuba/NAME.xml` with Mitsuba's reference
/// (`llvm_ad_spectral` when `spectral`, else `llvm_ad_rgb`).
fn matches_mitsuba(name: &str, defines: &[(&str, &str)], spp: u32, spectral: bool) {
    const B: usize = 4;
    let variant = if spectral { "spectral" } else { "rgb" };
    let reference = candela_imageio::read_image(&root().join(format!(
        "crates/cli/tests/data/{name}-mitsuba-{variant}.pfm"
    )))
    .unwrap();
    let size = (reference.width(), reference.height());
    let loaded = load(name, defines);
    let runs: Vec<Vec<[f64; 3]>> = (0..RUNS)
        .map(|seed| block_means(&render_mode(&loaded, size, (spp, seed), spectral), B))
        .collect();
    // Student's t, 7 degrees of freedom, two-sided α = 0.002: 4.79; over ~300 block tests a
    // few may fail by chance. The reference has 16384 spp, its noise counts too.
    check_against_reference(
        name,
        &runs,
        &block_means(&reference, B),
        size.0 / B,
        (0.01, 4.79, 3, 16384.0 / spp as f64),
    );
}

#[test]
fn tabulated_spectra_match_mitsuba_spectral() {
    matches_mitsuba_spectral("spectral-cbox", &[], 256);
}

#[test]
fn blackbody_lights_match_mitsuba_spectral() {
    matches_mitsuba_spectral("spectral-blackbody", &[], 256);
}

#[test]
fn measured_metals_match_mitsuba_spectral() {
    matches_mitsuba_spectral("spectral-metals", &[], 256);
}

/// Without `--spectral`, spectra become the colours Mitsuba's RGB variants give them.
#[test]
fn spectra_in_rgb_renders_match_mitsuba_rgb() {
    matches_mitsuba("spectral-cbox", &[], 256, false);
    matches_mitsuba("spectral-metals", &[], 256, false);
}

#[test]
fn an_rgb_scene_rendered_spectrally_matches_mitsuba_spectral() {
    matches_mitsuba_spectral("glass-mirror-box", &[("res", "48")], 256);
}

/// A ray in the prism's cross-section plane (x, z).
type V2 = [f64; 2];

fn dot(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// The direction `d` (unit) refracted through a surface of unit normal `n` (facing against
/// `d`) from index 1 into relative index `eta` (Snell's law in vector form).
fn refract(d: V2, n: V2, eta: f64) -> Option<V2> {
    let c = -dot(d, n);
    let k = 1.0 - (1.0 - c * c) / (eta * eta);
    (k >= 0.0).then(|| {
        let t = c / eta - k.sqrt();
        [d[0] / eta + t * n[0], d[1] / eta + t * n[1]]
    })
}

#[test]
fn the_prism_puts_each_colour_where_snells_law_sends_it() {
    let (w, h) = (200, 8);
    let loaded = load("prism", &[]);
    // The prism's cross-section: the first three vertices of its mesh (y = -1).
    let obj = std::fs::read_to_string(root().join("examples/mitsuba/meshes/prism.obj")).unwrap();
    let v: Vec<V2> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .take(3)
        .map(|l| {
            let n: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [n[0], n[2]]
        })
        .collect();
    let centroid = [
        (v[0][0] + v[1][0] + v[2][0]) / 3.0,
        (v[0][1] + v[1][1] + v[2][1]) / 3.0,
    ];
    // Each face: a point and its outward unit normal.
    let faces: Vec<(V2, V2)> = (0..3)
        .map(|i| {
            let (a, b) = (v[i], v[(i + 1) % 3]);
            let e = [b[0] - a[0], b[1] - a[1]];
            let len = dot(e, e).sqrt();
            let mut n = [e[1] / len, -e[0] / len];
            if dot(n, [a[0] - centroid[0], a[1] - centroid[1]]) < 0.0 {
                n = [-n[0], -n[1]];
            }
            (a, n)
        })
        .collect();
    // The strip (prism.xml): centre, unit normal facing the prism, half-width.
    let phi = (-67.1654f64).to_radians();
    let strip_c = [2.636251, -4.315882];
    let strip_n = [phi.sin(), phi.cos()];
    let half = 0.02;
    let glass = Ior::glass("sf11").unwrap();
    // Where a ray from the camera (origin) along d lands across the strip, at λ nm, or None.
    // A ray enters a convex polygon through the front-facing edge line it crosses last, and
    // leaves through the back-facing one it crosses first.
    let land = |d: V2, lambda: f64| -> Option<f64> {
        let hit = |o: V2, d: V2, inside: bool| {
            let ts = faces.iter().filter_map(|&(p, n)| {
                let den = dot(d, n);
                let facing = if inside { den > 0.0 } else { den < 0.0 };
                facing.then(|| (dot([p[0] - o[0], p[1] - o[1]], n) / den, n))
            });
            if inside {
                ts.filter(|h| h.0 > 1e-9).min_by(|a, b| a.0.total_cmp(&b.0))
            } else {
                ts.max_by(|a, b| a.0.total_cmp(&b.0))
            }
        };
        let eta = glass.eval(lambda as f32) as f64;
        let (t, n1) = hit([0.0, 0.0], d, false)?;
        // The entry point must be on the polygon: inside every other edge line.
        let p = [t * d[0], t * d[1]];
        if faces
            .iter()
            .any(|&(a, n)| dot([p[0] - a[0], p[1] - a[1]], n) > 1e-9)
        {
            return None;
        }
        let d1 = refract(d, n1, eta)?;
        let (t, n2) = hit(p, d1, true)?;
        let q = [p[0] + t * d1[0], p[1] + t * d1[1]];
        let d2 = refract(d1, [-n2[0], -n2[1]], 1.0 / eta)?;
        let den = dot(d2, strip_n);
        if den >= 0.0 {
            return None;
        }
        let t = dot([strip_c[0] - q[0], strip_c[1] - q[1]], strip_n) / den;
        let x = [q[0] + t * d2[0] - strip_c[0], q[1] + t * d2[1] - strip_c[1]];
        Some(dot(x, [-strip_n[1], strip_n[0]]).abs())
    };
    let image = render_spectral(&loaded, (w, h), 128, 1);
    // Each column's mean over the rows, and the wavelengths Snell's law sends onto the strip
    // through its centre (the camera ray of the middle row, projected onto the plane).
    let mut checked = [0; 3];
    for col in 0..w {
        let ray = loaded.scene.camera.ray((col as f32 + 0.5) / w as f32, 0.5);
        let d = [ray.d.x as f64, ray.d.z as f64];
        let len = dot(d, d).sqrt();
        let d = [d[0] / len, d[1] / len];
        let lit: Vec<f64> = (380..=780)
            .step_by(2)
            .map(f64::from)
            .filter(|&l| land(d, l).is_some_and(|x| x < half))
            .collect();
        let mut c = [0f64; 3];
        for y in 0..h {
            for (k, v) in image.get(col, y).to_array().into_iter().enumerate() {
                c[k] += v as f64 / h as f64;
            }
        }
        let lum = c[0] + c[1] + c[2];
        let Some((&lo, &hi)) = lit.first().zip(lit.last()) else {
            continue;
        };
        // Colour by wavelength band (the column's own band; neighbouring pixels share edges).
        // (Away from the ends of the visible range, where the eye, and so the image, sees
        // almost nothing.)
        let (what, ok) = if lo >= 430.0 && hi <= 470.0 {
            ("blue", c[2] > c[0] && c[2] > c[1])
        } else if (510.0..=560.0).contains(&lo) && hi <= 570.0 {
            ("green", c[1] > c[0] && c[1] > c[2])
        } else if lo >= 600.0 && hi <= 720.0 {
            ("red", c[0] > c[1] && c[0] > c[2])
        } else {
            continue;
        };
        eprintln!("column {col}: {lo}-{hi} nm ({what}): {c:?}");
        assert!(
            lum > 0.01 && ok,
            "column {col} should look {what} ({lo}-{hi} nm): {c:?}"
        );
        checked[["blue", "green", "red"]
            .iter()
            .position(|&s| s == what)
            .unwrap()] += 1;
    }
    assert!(
        checked.iter().all(|&n| n >= 1) && checked.iter().sum::<usize>() >= 6,
        "columns checked (blue, green, red): {checked:?}"
    );
}
