//! Measurements of the radiosity integrator: the Cornell box against the path tracer and
//! Mitsuba's reference, and timing and memory against the patch count. Each experiment prints
//! what it measures (and may write PFM images into the current directory):
//!
//! ```text
//! cargo run --release -p candela-render --example radiosity_experiments -- NAME
//! ```
//!
//! Without a name it lists the experiments. The Mitsuba reference is read from
//! `../shared/bench/` beside the repository (`CANDELA_BENCH` overrides it).

#[path = "../tests/support/radiosity.rs"]
mod support;

use candela_render::Image;

use candela_render::accel::AccelKind;
use candela_render::integrator::Path;
use candela_render::radiosity::{FormFactorMethod, Radiosity, RadiosityOptions, SolverKind};
use candela_render::Scene;
use std::time::Instant;
use support::*;

fn opts(
    h: Option<f32>,
    ff: FormFactorMethod,
    solver: SolverKind,
    refinements: u32,
) -> RadiosityOptions {
    RadiosityOptions {
        patch_size: h,
        form_factors: ff,
        solver,
        refinements,
        ..Default::default()
    }
}

/// A configuration of [`configs`] as options (Gauss–Seidel).
fn config_opts(&(ff, h, r, hres): &Config) -> RadiosityOptions {
    let mut o = opts(h, ff, SolverKind::GaussSeidel, r);
    o.hemicube_resolution = hres;
    o
}

/// Solves `scene`, with the seconds it took.
fn timed_solve(scene: &Scene, o: &RadiosityOptions) -> (Radiosity, f64) {
    let t = Instant::now();
    let rad = Radiosity::solve(scene, o);
    (rad, t.elapsed().as_secs_f64())
}

/// Method, patch size, refinements, hemicube resolution.
type Config = (FormFactorMethod, Option<f32>, u32, u32);

/// The configurations of `cornell_means`: (method, patch size, refinements, hemicube
/// resolution), from `RAD_CONFIGS` ("hc:0.14:0:256,rc:0.07:2:0") or a default list.
fn configs() -> Vec<Config> {
    let text = std::env::var("RAD_CONFIGS")
        .unwrap_or_else(|_| "hc:-:0:256,hc:-:2:256,hc:0.07:0:256,rc:-:0:0,rc:0.07:0:0".into());
    text.split(',')
        .map(|c| {
            let f: Vec<&str> = c.split(':').collect();
            let ff = if f[0] == "rc" {
                FormFactorMethod::RayCast
            } else {
                FormFactorMethod::Hemicube
            };
            (
                ff,
                f[1].parse().ok(),
                f[2].parse().unwrap_or(0),
                f[3].parse().unwrap_or(256),
            )
        })
        .collect()
}

fn cornell_means() {
    let scene = cornell(AccelKind::Bvh);
    let res = 128;
    let mask = emitter_mask(&scene, res);
    let t = Instant::now();
    let pt = image(&scene, &Path::default(), res, 256);
    let pm = masked_mean(&pt, &mask);
    println!(
        "path tracer {res}x{res}x256: {pm:.4?} ({:.1} s)",
        t.elapsed().as_secs_f64()
    );
    for cfg in configs() {
        let (ff, _, r, hres) = cfg;
        let (rad, ts) = timed_solve(&scene, &config_opts(&cfg));
        let img = image(&scene, &rad, res, 1);
        let m = masked_mean(&img, &mask);
        let rel: Vec<String> = (0..3)
            .map(|c| format!("{:+.2}%", 100.0 * (m[c] / pm[c] - 1.0)))
            .collect();
        let rp = rad.report();
        println!(
            "{:?} h={:.4} refine={r} res={hres}: {} patches, {m:.4?} vs path {} ({ts:.2} s; Σ F mean {:.3}, reciprocity {:.3})",
            ff, rp.patch_size, rp.patches, rel.join(" "), rp.row_sum_mean, rp.reciprocity_error
        );
    }
}

fn cornell_pictures() {
    let scene = cornell(AccelKind::Bvh);
    let res = 128;
    let mask = emitter_mask(&scene, res);
    let pt = image(&scene, &Path::default(), res, 64);
    write_pfm("rad_pt.pfm", &pt);
    let rad = Radiosity::solve(
        &scene,
        &opts(None, FormFactorMethod::Hemicube, SolverKind::GaussSeidel, 0),
    );
    write_pfm("rad_hc.pfm", &image(&scene, &rad, res, 1));
    let rad = Radiosity::solve(
        &scene,
        &opts(None, FormFactorMethod::RayCast, SolverKind::GaussSeidel, 0),
    );
    write_pfm("rad_rc.pfm", &image(&scene, &rad, res, 1));
    if let Some(r) = read_pfm(&bench("cornell-reference-unlimited-depth-256.pfm")) {
        let m = emitter_mask(&scene, 256);
        println!(
            "reference masked mean {:?} full {:?}",
            masked_mean(&r, &m),
            r.mean()
        );
    }
    println!("pt {:?}", masked_mean(&pt, &mask));
}

fn cornell_light_form_factors() {
    let scene = cornell(AccelKind::Bvh);
    for ff in [FormFactorMethod::Hemicube, FormFactorMethod::RayCast] {
        let m = candela_render::radiosity::FormFactorMatrix::compute(
            &scene,
            &opts(Some(0.25), ff, SolverKind::GaussSeidel, 0),
        );
        let emit: Vec<bool> = m.patches.iter().map(|p| p.emission[0] > 0.0).collect();
        // Floor patches (normal +y, centre y ≈ -1).
        let mut tot = 0.0;
        let mut n = 0;
        for (i, p) in m.patches.iter().enumerate() {
            if p.normal.y > 0.9 && p.centre.y < -0.99 {
                let f: f32 = m.rows[i]
                    .iter()
                    .filter(|(j, _)| emit[*j as usize])
                    .map(|x| x.1)
                    .sum();
                let s: f32 = m.rows[i].iter().map(|x| x.1).sum();
                if n < 5 {
                    println!(
                        "{ff:?} floor patch {i} at {:?}: F to light {f:.5}, row sum {s:.4}",
                        p.centre
                    );
                }
                tot += f;
                n += 1;
            }
        }
        println!("{ff:?}: mean F floor→light {:.5} over {n}", tot / n as f32);
    }
}

fn cornell_profile() {
    let scene = cornell(AccelKind::Bvh);
    let h: Option<f32> = std::env::var("RAD_H").ok().and_then(|s| s.parse().ok());
    let ff = if std::env::var("RAD_RC").is_ok() {
        FormFactorMethod::RayCast
    } else {
        FormFactorMethod::Hemicube
    };
    let solver = if std::env::var("RAD_PR").is_ok() {
        SolverKind::Progressive
    } else {
        SolverKind::GaussSeidel
    };
    let mut o = opts(h, ff, solver, 0);
    if let Ok(r) = std::env::var("RAD_RES") {
        o.hemicube_resolution = r.parse().unwrap();
    }
    if let Ok(r) = std::env::var("RAD_REFINE") {
        o.refinements = r.parse().unwrap();
    }
    if let Ok(r) = std::env::var("RAD_CACHE_MB") {
        o.row_cache_bytes = r.parse::<usize>().unwrap() << 20;
    }
    let (rad, secs) = timed_solve(&scene, &o);
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let hwm = status
        .lines()
        .find(|l| l.starts_with("VmHWM"))
        .unwrap_or("")
        .to_string();
    let r = rad.report();
    println!(
        "TABLE {} {} patches={} time={secs:.2}s ff={:.2}s rows={} ff_mem={:.1}MiB mesh_mem={:.2}MiB {} iters={} residual={:.1e}",
        r.form_factors.name(),
        r.solver.name(),
        r.patches,
        r.seconds_form_factors,
        r.rows_computed,
        r.form_factor_bytes as f64 / 1048576.0,
        r.mesh_bytes as f64 / 1048576.0,
        hwm.split_whitespace().skip(1).collect::<Vec<_>>().join(""),
        r.iterations,
        r.residual
    );
}

fn cornell_images() {
    let scene = cornell(AccelKind::Bvh);
    for (k, cfg) in configs().iter().enumerate() {
        let mut o = config_opts(cfg);
        if std::env::var("RAD_FLAT").is_ok() {
            o.display = candela_render::radiosity::DisplayMode::Flat;
        }
        if let Ok(n) = std::env::var("RAD_GATHER") {
            o.display = candela_render::radiosity::DisplayMode::FinalGather(n.parse().unwrap());
        }
        let rad = Radiosity::solve(&scene, &o);
        write_pfm(&format!("rad_img{k}.pfm"), &image(&scene, &rad, 256, 1));
    }
}

fn furnace_debug() {
    let scene = closed_box_with(
        0.6,
        Some(candela_render::Rgb::splat(1.0)),
        candela_render::math::Vec3::new(-0.5, 0.1, 0.05),
    );
    let o = RadiosityOptions {
        patch_size: Some(0.4),
        refinements: 0,
        hemicube_resolution: 128,
        ..Default::default()
    };
    let rad = Radiosity::solve(&scene, &o);
    println!("{}", rad.report());
    let img = image(&scene, &rad, 8, 1);
    for y in 0..8 {
        let row: Vec<String> = (0..8).map(|x| format!("{:.2}", img.get(x, y).r)).collect();
        println!("{}", row.join(" "));
    }
    for p in rad.patches().iter().take(3) {
        println!("{p:?}");
    }
}

fn point_light_debug() {
    use candela_render::light::{Components, Light, PointLight};
    use candela_render::math::{Point3, Transform, Vec3};
    use candela_render::shape::{Shape, Sphere};
    let mut b = candela_render::SceneBuilder::new();
    let m = b.add_material(candela_render::material::Material::diffuse(
        candela_render::texture::Texture::Uniform(candela_render::Rgb::splat(0.5)),
    ));
    b.add_shape(Shape::Sphere(Sphere::new(Transform::IDENTITY)), m, None);
    b.add_light(Light::Point(
        PointLight {
            position: Point3::new(1.5, 0.0, 0.0),
            intensity: candela_render::Rgb::splat(10.0),
            spectrum: None,
            falloff: Default::default(),
        },
        Components::from_intensity(candela_render::Rgb::splat(10.0)),
    ));
    let scene = b.build(AccelKind::Bvh);
    let r = Radiosity::solve(
        &scene,
        &RadiosityOptions {
            patch_size: Some(0.3),
            refinements: 0,
            ..Default::default()
        },
    );
    println!("{}", r.report());
    let ps = r.patches();
    let lit = ps.iter().filter(|p| p.radiosity[0] > 0.0).count();
    println!(
        "{} patches, {lit} lit; sides {:?}",
        ps.len(),
        ps.iter().map(|p| p.side).take(3).collect::<Vec<_>>()
    );
    let _ = Vec3::X;
}

fn mirror_debug() {
    let scene = cornell_with_mirror();
    let r = Radiosity::solve(
        &scene,
        &RadiosityOptions {
            patch_size: Some(0.3),
            refinements: 0,
            hemicube_resolution: 64,
            ..Default::default()
        },
    );
    let img = image(&scene, &r, 128, 1);
    write_pfm("rad_mirror.pfm", &img);
}

fn furnace_errors() {
    let scene = closed_box_with(
        0.6,
        Some(candela_render::Rgb::splat(1.0)),
        candela_render::math::Vec3::new(0.5, 0.1, 0.05),
    );
    for ff in [FormFactorMethod::Hemicube, FormFactorMethod::RayCast] {
        for h in [0.5f32, 0.4, 0.25, 0.125] {
            for res in [128u32, 256] {
                let o = RadiosityOptions {
                    patch_size: Some(h),
                    form_factors: ff,
                    refinements: 0,
                    threshold: 1e-8,
                    hemicube_resolution: res,
                    ..Default::default()
                };
                let r = Radiosity::solve(&scene, &o);
                let mut worst = 0f64;
                let mut mean = 0f64;
                let mut n = 0;
                for p in r.patches() {
                    if inward(&p) {
                        let d = (p.radiosity[0] / (p.emission[0] / 0.4) - 1.0).abs();
                        worst = worst.max(d);
                        mean += d;
                        n += 1;
                    }
                }
                println!(
                    "{ff:?} h={h} res={res}: worst {:.3}% mean {:.3}% ({} patches)",
                    100.0 * worst,
                    100.0 * mean / n as f64,
                    n
                );
                if ff == FormFactorMethod::RayCast {
                    break;
                }
            }
        }
    }
}

/// The Cornell box at 256 × 256 against Mitsuba's reference with unlimited depth
/// (`cornell-reference-unlimited-depth-256.pfm` of the bench folder), emitter pixels masked.
fn cornell_against_mitsuba_reference() {
    let Some(reference) = read_pfm(&bench("cornell-reference-unlimited-depth-256.pfm")) else {
        println!("no reference");
        return;
    };
    let scene = cornell(AccelKind::Bvh);
    let res = 256;
    let mask = emitter_mask(&scene, res);
    let rm = masked_mean(&reference, &mask);
    println!("Mitsuba reference, masked: {rm:.4?}");
    let t = Instant::now();
    let pm = masked_mean(&image(&scene, &Path::default(), res, 64), &mask);
    println!(
        "candela path tracer 64 spp: {pm:.4?} ({:+.2}% {:+.2}% {:+.2}%) {:.1} s",
        100.0 * (pm[0] / rm[0] - 1.0),
        100.0 * (pm[1] / rm[1] - 1.0),
        100.0 * (pm[2] / rm[2] - 1.0),
        t.elapsed().as_secs_f64()
    );
    for cfg in configs() {
        let (ff, _, r, _) = cfg;
        let (rad, ts) = timed_solve(&scene, &config_opts(&cfg));
        // 16 samples per pixel: antialiased emitter edges, as in the reference.
        let m = masked_mean(&image(&scene, &rad, res, 16), &mask);
        println!(
            "{} h={:.3} refine={r}: {} patches, {m:.4?} vs Mitsuba {:+.2}% {:+.2}% {:+.2}%, vs path {:+.2}% {:+.2}% {:+.2}% ({ts:.2} s)",
            ff.name(),
            rad.report().patch_size,
            rad.report().patches,
            100.0 * (m[0] / rm[0] - 1.0),
            100.0 * (m[1] / rm[1] - 1.0),
            100.0 * (m[2] / rm[2] - 1.0),
            100.0 * (m[0] / pm[0] - 1.0),
            100.0 * (m[1] / pm[1] - 1.0),
            100.0 * (m[2] / pm[2] - 1.0),
        );
    }
}

fn cornell_difference_image() {
    let scene = cornell(AccelKind::Bvh);
    let rad = Radiosity::solve(&scene, &config_opts(&configs()[0]));
    write_pfm("rad_256.pfm", &image(&scene, &rad, 256, 16));
}

fn cornell_convergence_64() {
    let scene = cornell(AccelKind::Bvh);
    let res = 64;
    let mask = emitter_mask(&scene, res);
    let path = masked_mean(&image(&scene, &Path::default(), res, 1024), &mask);
    println!("path {path:.4?}");
    for ff in [FormFactorMethod::RayCast, FormFactorMethod::Hemicube] {
        for h in [1.0f32, 0.7, 0.5, 0.35, 0.25, 0.18, 0.125] {
            let mut o = opts(Some(h), ff, SolverKind::GaussSeidel, 0);
            o.rays_per_patch = 1024;
            let r = Radiosity::solve(&scene, &o);
            let m = masked_mean(&image(&scene, &r, res, 16), &mask);
            println!(
                "{} h={h}: {} patches {m:.4?} {:.4}",
                ff.name(),
                r.len(),
                rel_diff(m, path)
            );
        }
    }
}

/// A file of the bench folder (`CANDELA_BENCH`, or `../shared/bench` beside the repository).
fn bench(name: &str) -> String {
    let dir = std::env::var("CANDELA_BENCH")
        .unwrap_or_else(|_| concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/bench").into());
    format!("{dir}/{name}")
}

/// Writes `img` as PFM (a note on failure: the experiments are measurements, not tests).
fn write_pfm(path: &str, img: &Image) {
    if let Err(e) = std::fs::write(path, candela_imageio::write_pfm(img)) {
        eprintln!("cannot write {path}: {e}");
    }
}

/// Reads a PFM, or `None` with a note when it cannot be read.
fn read_pfm(path: &str) -> Option<Image> {
    candela_imageio::read_pfm_file(std::path::Path::new(path))
        .map_err(|e| eprintln!("cannot read {path}: {e}"))
        .ok()
}

/// The experiments by name.
const EXPERIMENTS: &[(&str, fn())] = &[
    ("cornell_means", cornell_means),
    ("cornell_pictures", cornell_pictures),
    ("cornell_light_form_factors", cornell_light_form_factors),
    ("cornell_profile", cornell_profile),
    ("cornell_images", cornell_images),
    ("furnace_debug", furnace_debug),
    ("point_light_debug", point_light_debug),
    ("mirror_debug", mirror_debug),
    ("furnace_errors", furnace_errors),
    (
        "cornell_against_mitsuba_reference",
        cornell_against_mitsuba_reference,
    ),
    ("cornell_difference_image", cornell_difference_image),
    ("cornell_convergence_64", cornell_convergence_64),
];

fn main() {
    let name = std::env::args().nth(1).unwrap_or_default();
    match EXPERIMENTS.iter().find(|(n, _)| *n == name) {
        Some((_, run)) => run(),
        None => {
            eprintln!("usage: radiosity_experiments NAME, one of:");
            for (n, _) in EXPERIMENTS {
                eprintln!("  {n}");
            }
            std::process::exit(if name.is_empty() { 0 } else { 2 });
        }
    }
}
