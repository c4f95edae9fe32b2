//! Radiosity: form factors against closed forms, closed rooms, the furnace, the two solvers,
//! reciprocity, the Cornell box against the path tracer, the cache, and degenerate scenes.

mod support;

use candela_render::accel::AccelKind;
use candela_render::camera::Camera;
use candela_render::integrator::{IntegratorKind, IntegratorSettings, Path};
use candela_render::light::Emission;
use candela_render::light::{Components, Light, PointLight};
use candela_render::material::Material;
use candela_render::math::{Point3, Transform, Vec3};
use candela_render::radiosity::{
    CacheStatus, DisplayMode, FormFactorMatrix, FormFactorMethod, PatchInfo, Radiosity,
    RadiosityOptions, Side, SolverKind,
};
use candela_render::shape::{Disk, Mesh, Shape, Sphere};
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene, SceneBuilder};
use std::f64::consts::PI;
use std::sync::Arc;
use support::radiosity::*;

const METHODS: [FormFactorMethod; 2] = [FormFactorMethod::Hemicube, FormFactorMethod::RayCast];

/// Options for form-factor tests: every side gets patches, no refinement.
fn ff_opts(method: FormFactorMethod, patch: f32) -> RadiosityOptions {
    RadiosityOptions {
        patch_size: Some(patch),
        form_factors: method,
        hemicube_resolution: 512,
        rays_per_patch: 16_384,
        refinements: 0,
        cull_hidden_sides: false,
        ..Default::default()
    }
}

/// The form factor from the side of primitive `a` facing point `towards` to primitive `b`:
/// Σ_{i ∈ a} A_i Σ_{j ∈ b} F_ij / Σ_{i ∈ a} A_i.
fn surface_ff(m: &FormFactorMatrix, a: u32, b: u32, towards: Point3) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (i, p) in m.patches.iter().enumerate() {
        if p.prim != a || p.normal.dot(towards - p.centre) <= 0.0 {
            continue;
        }
        let f: f64 = m.rows[i]
            .iter()
            .filter(|(j, _)| m.patches[*j as usize].prim == b)
            .map(|x| x.1 as f64)
            .sum();
        num += p.area * f;
        den += p.area;
    }
    num / den
}

/// Two parallel coaxial rectangles a × b at distance c (Incropera).
fn parallel_rectangles(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x2, y2) = (x * x, y * y);
    2.0 / (PI * x * y)
        * ((((1.0 + x2) * (1.0 + y2)) / (1.0 + x2 + y2)).sqrt().ln()
            + x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan()
            + y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan()
            - x * x.atan()
            - y * y.atan())
}

/// From a w × l rectangle to a perpendicular h × l rectangle sharing the edge of length l.
fn perpendicular_rectangles(w: f64, h: f64, l: f64) -> f64 {
    let (w, h) = (w / l, h / l);
    let (w2, h2) = (w * w, h * h);
    let s = w2 + h2;
    let log = ((1.0 + w2) * (1.0 + h2) / (1.0 + s)).ln()
        + w2 * (w2 * (1.0 + s) / ((1.0 + w2) * s)).ln()
        + h2 * (h2 * (1.0 + s) / ((1.0 + h2) * s)).ln();
    (w * (1.0 / w).atan() + h * (1.0 / h).atan() - s.sqrt() * (1.0 / s.sqrt()).atan() + 0.25 * log)
        / (PI * w)
}

fn white() -> Material {
    Material::diffuse(Texture::Uniform(Rgb::splat(0.5)))
}

#[test]
fn closed_forms_are_what_the_literature_says() {
    assert!((parallel_rectangles(1.0, 1.0, 1.0) - 0.19982).abs() < 1e-4);
    assert!((perpendicular_rectangles(1.0, 1.0, 1.0) - 0.20004).abs() < 1e-4);
}

#[test]
fn parallel_coaxial_squares() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(white());
    b.add_shape(
        para([-0.5, -0.5, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        m,
        None,
    );
    b.add_shape(
        para([-0.5, -0.5, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        m,
        None,
    );
    let scene = b.build(AccelKind::Bvh);
    let exact = parallel_rectangles(1.0, 1.0, 1.0);
    for method in METHODS {
        let mat = FormFactorMatrix::compute(&scene, &ff_opts(method, 0.125));
        let f12 = surface_ff(&mat, 0, 1, Point3::new(0.0, 0.0, 1.0));
        let f21 = surface_ff(&mat, 1, 0, Point3::ORIGIN);
        println!("{method:?}: F12 {f12:.5} F21 {f21:.5} exact {exact:.5}");
        assert!(
            (f12 / exact - 1.0).abs() < 0.01,
            "{method:?}: F12 = {f12}, exact {exact}"
        );
        // Reciprocity (equal areas): A1 F12 = A2 F21.
        assert!(
            (f12 / f21 - 1.0).abs() < 0.01,
            "{method:?}: F12 = {f12}, F21 = {f21}"
        );
    }
}

#[test]
fn perpendicular_rectangles_sharing_an_edge() {
    // A 1 × 1 floor (z = 0) and a 1 × 2 wall (x = 0) sharing the edge along y.
    let mut b = SceneBuilder::new();
    let m = b.add_material(white());
    b.add_shape(
        para([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        m,
        None,
    );
    b.add_shape(
        para([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]),
        m,
        None,
    );
    let scene = b.build(AccelKind::Bvh);
    let (f12_exact, f21_exact) = (
        perpendicular_rectangles(1.0, 2.0, 1.0),
        perpendicular_rectangles(2.0, 1.0, 1.0),
    );
    for method in METHODS {
        let mut o = ff_opts(method, 0.1);
        o.rays_per_patch = 8192;
        let mat = FormFactorMatrix::compute(&scene, &o);
        let f12 = surface_ff(&mat, 0, 1, Point3::new(0.5, 0.5, 1.0));
        let f21 = surface_ff(&mat, 1, 0, Point3::new(0.5, 0.5, 1.0));
        println!("{method:?}: F12 {f12:.5} ({f12_exact:.5}), F21 {f21:.5} ({f21_exact:.5})");
        assert!(
            (f12 / f12_exact - 1.0).abs() < 0.01,
            "{method:?}: F12 = {f12}, exact {f12_exact}"
        );
        assert!(
            (f21 / f21_exact - 1.0).abs() < 0.01,
            "{method:?}: F21 = {f21}, exact {f21_exact}"
        );
        // Reciprocity: A1 F12 = A2 F21 with A2 = 2 A1.
        assert!(
            (f12 / (2.0 * f21) - 1.0).abs() < 0.01,
            "{method:?}: F12 = {f12}, F21 = {f21}"
        );
    }
}

#[test]
fn differential_patch_to_a_coaxial_disk() {
    for (r, h) in [(1.0f32, 1.0f32), (0.5, 1.0), (1.0, 0.4)] {
        let mut b = SceneBuilder::new();
        let m = b.add_material(white());
        let e = 0.004;
        b.add_shape(
            para([-e / 2.0, -e / 2.0, 0.0], [e, 0.0, 0.0], [0.0, e, 0.0]),
            m,
            None,
        );
        let t = Transform::translation(Vec3::new(0.0, 0.0, h))
            * Transform::scaling(Vec3::new(r, r, 1.0));
        b.add_shape(Shape::Disk(Disk::new(t)), m, None);
        let scene = b.build(AccelKind::Bvh);
        let exact = (r * r / (r * r + h * h)) as f64;
        for method in METHODS {
            let mut o = ff_opts(method, 0.04 * r);
            o.rays_per_patch = 1 << 20;
            let mat = FormFactorMatrix::compute_rows(&scene, &o, &|p: &PatchInfo| {
                p.prim == 0 && p.side == Side::Front
            });
            let f = surface_ff(&mat, 0, 1, Point3::new(0.0, 0.0, 1.0));
            println!("{method:?} r={r} h={h}: F {f:.5} exact {exact:.5}");
            assert!(
                (f / exact - 1.0).abs() < 0.01,
                "{method:?} r={r} h={h}: F = {f}, exact {exact}"
            );
        }
    }
}

/// A closed box of six two-sided parallelograms [-1, 1]³; the walls emit `le` (both sides)
/// and reflect `rho`.
fn closed_box(rho: f32, le: f32) -> Scene {
    // Inside, looking along +x: the eye is d = 1 behind the camera's origin, at (−0.5, 0.1, 0.05).
    closed_box_with(
        rho,
        (le > 0.0).then(|| Rgb::new(le, 0.5 * le, 0.25 * le)),
        Vec3::new(0.5, 0.1, 0.05),
    )
}

#[test]
fn rows_sum_to_one_in_a_closed_box() {
    let scene = closed_box(0.5, 0.0);
    for method in METHODS {
        let mut o = ff_opts(method, 0.4);
        o.cull_hidden_sides = true;
        o.hemicube_resolution = 128;
        o.rays_per_patch = 1024;
        let m = FormFactorMatrix::compute(&scene, &o);
        // The outer sides see nothing and get no patches.
        assert!(
            m.patches.iter().all(inward),
            "{method:?}: outer sides were not culled"
        );
        assert_eq!(m.patches.len(), 6 * 25);
        for (i, row) in m.rows.iter().enumerate() {
            let s: f64 = row.iter().map(|x| x.1 as f64).sum();
            assert!((s - 1.0).abs() < 0.01, "{method:?}: row {i} sums to {s}");
        }
    }
}

#[test]
fn furnace_closed_room_with_uniform_emission_and_reflectance() {
    // B = E + ρ Σ F B with Σ F = 1 everywhere: B = E / (1 − ρ), and the radiance L_e / (1 − ρ).
    let (rho, le) = (0.6f32, 1.0f32);
    let scene = closed_box(rho, le);
    let emitted = Rgb::new(le, 0.5 * le, 0.25 * le);
    for method in METHODS {
        for solver in [SolverKind::GaussSeidel, SolverKind::Progressive] {
            let o = RadiosityOptions {
                patch_size: Some(0.4),
                form_factors: method,
                solver,
                threshold: 1e-7,
                hemicube_resolution: 128,
                rays_per_patch: 2048,
                ..Default::default()
            };
            let rad = Radiosity::solve(&scene, &o);
            assert!(
                rad.report().converged,
                "{method:?} {solver:?}: {}",
                rad.report()
            );
            // Gauss–Seidel gathers with rows that sum to 1: exact up to round-off. Progressive
            // refinement shoots with A_i F_ij / A_j: exact up to the reciprocity error of the
            // form factors (largest for patches next to a perpendicular wall).
            let tol = if solver == SolverKind::GaussSeidel {
                0.01
            } else {
                0.04
            };
            let mut worst = 0f64;
            for p in rad.patches().iter().filter(|p| inward(p)) {
                for c in 0..3 {
                    let expect = p.emission[c] / (1.0 - rho as f64);
                    worst = worst.max((p.radiosity[c] / expect - 1.0).abs());
                }
            }
            println!(
                "{method:?} {solver:?}: worst patch error {:.4}% ({})",
                100.0 * worst,
                rad.report().iterations
            );
            assert!(
                worst < tol,
                "{method:?} {solver:?}: a patch is {worst} off E/(1−ρ)"
            );
            let img = image(&scene, &rad, 24, 1);
            let expect = emitted / (1.0 - rho);
            for p in img.pixels() {
                assert!(
                    p.approx_eq(expect, tol as f32 * expect.r),
                    "{method:?} {solver:?}: pixel {p:?}, expected {expect:?}"
                );
            }
        }
    }
}

/// Solves the coarse Cornell box with `solver` and `row_cache_bytes`.
fn cornell_solve(solver: SolverKind, method: FormFactorMethod, cache: usize) -> Radiosity {
    cornell_solve_with(solver, method, cache, false)
}

fn cornell_solve_with(
    solver: SolverKind,
    method: FormFactorMethod,
    cache: usize,
    reciprocal_gather: bool,
) -> Radiosity {
    let o = RadiosityOptions {
        reciprocal_gather,
        patch_size: Some(0.25),
        form_factors: method,
        solver,
        threshold: 1e-7,
        hemicube_resolution: 128,
        rays_per_patch: 1024,
        refinements: 0,
        row_cache_bytes: cache,
        ..Default::default()
    };
    Radiosity::solve(&cornell(AccelKind::Bvh), &o)
}

/// Area-weighted relative difference of two solutions and the largest per-patch one (among
/// patches brighter than 1 % of the mean).
fn solution_difference(a: &[PatchInfo], b: &[PatchInfo]) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let lum = |x: &[f64; 3]| x[0] + x[1] + x[2];
    let total: f64 = a.iter().map(|p| p.area * lum(&p.radiosity)).sum();
    let area: f64 = a.iter().map(|p| p.area).sum();
    let mean = total / area;
    let (mut diff, mut worst) = (0f64, 0f64);
    for (p, q) in a.iter().zip(b) {
        let d = (lum(&p.radiosity) - lum(&q.radiosity)).abs();
        diff += p.area * d;
        if lum(&p.radiosity) > 0.01 * mean {
            worst = worst.max(d / lum(&p.radiosity));
        }
    }
    (diff / total, worst)
}

#[test]
fn both_solvers_give_the_same_radiosity() {
    for method in METHODS {
        // Gauss–Seidel gathering with the coefficients progressive refinement shoots with
        // (A_j F_ji / A_i): the same system, the same solution.
        let gs = cornell_solve_with(SolverKind::GaussSeidel, method, 256 << 20, true);
        let pr = cornell_solve(SolverKind::Progressive, method, 256 << 20);
        assert!(gs.report().converged && pr.report().converged);
        assert_eq!(gs.report().solver, SolverKind::GaussSeidel);
        assert_eq!(pr.report().solver, SolverKind::Progressive);
        let (mean, worst) = solution_difference(&gs.patches(), &pr.patches());
        println!(
            "{method:?}: GS {} sweeps, progressive {} shots; mean difference {mean:.2e}, worst patch {worst:.2e}",
            gs.report().iterations,
            pr.report().iterations
        );
        assert!(
            mean < 1e-5 && worst < 1e-4,
            "{method:?}: mean difference {mean}, worst {worst}"
        );
        // The lecture's gathering form (F_ij from patch i) differs by the form factors'
        // reciprocity error only.
        let gather = cornell_solve(SolverKind::GaussSeidel, method, 256 << 20);
        let (mean, worst) = solution_difference(&gather.patches(), &pr.patches());
        println!("{method:?}: gathering form vs progressive: mean difference {mean:.4}, worst patch {worst:.4} (reciprocity error {:.4})", gather.report().reciprocity_error);
        assert!(mean < 0.05, "{method:?}: mean difference {mean}");
    }
}

#[test]
fn progressive_refinement_needs_no_stored_matrix() {
    let cached = cornell_solve(
        SolverKind::Progressive,
        FormFactorMethod::Hemicube,
        256 << 20,
    );
    let bare = cornell_solve(SolverKind::Progressive, FormFactorMethod::Hemicube, 0);
    assert_eq!(bare.report().form_factor_bytes, 0, "{}", bare.report());
    assert!(bare.report().rows_computed > cached.report().rows_computed);
    // Rows are recomputed identically: the same shots give the same radiosity.
    for (p, q) in bare.patches().iter().zip(cached.patches()) {
        for c in 0..3 {
            assert!((p.radiosity[c] - q.radiosity[c]).abs() <= 1e-9 * (1.0 + q.radiosity[c]));
        }
    }
}

#[test]
fn reciprocity_is_reported_and_holds() {
    for method in METHODS {
        let r = cornell_solve(SolverKind::GaussSeidel, method, 0);
        let rp = r.report();
        println!(
            "{method:?}: reciprocity error {:.4} over {} pairs, row sums {:.4}..{:.4}",
            rp.reciprocity_error, rp.reciprocity_pairs, rp.row_sum_min, rp.row_sum_max
        );
        assert!(rp.reciprocity_pairs > 1000);
        let tol = if method == FormFactorMethod::Hemicube {
            0.1
        } else {
            0.25
        };
        assert!(rp.reciprocity_error < tol, "{method:?}: {rp}");
        assert!(rp.row_sum_max <= 1.01, "{method:?}: {rp}");
    }
}

#[test]
fn cornell_box_matches_the_path_tracer() {
    let scene = cornell(AccelKind::Bvh);
    let res = 64;
    // The emitter's pixels aside; both images antialiased alike (16 samples per pixel for the
    // radiosity image, whose display is otherwise deterministic), so that pixels partly
    // covered by the very bright emitter weigh the same in both.
    let mask = emitter_mask(&scene, res);
    let path = masked_mean(&image(&scene, &Path::default(), res, 256), &mask);
    let mean = |o: &RadiosityOptions| {
        let r = Radiosity::solve(&scene, o);
        (
            masked_mean(&image(&scene, &r, res, 16), &mask),
            r.report().patches,
        )
    };
    // The default patch size, as `--integrator radiosity` renders it (fewer hemicube pixels).
    let o = RadiosityOptions {
        hemicube_resolution: 128,
        refinements: 1,
        ..Default::default()
    };
    let (m, n) = mean(&o);
    println!(
        "hemicube, default patches ({n}): {m:.4?} vs path {path:.4?}: {:.4}",
        rel_diff(m, path)
    );
    assert!(
        rel_diff(m, path) < 0.05,
        "radiosity {m:?} vs path tracer {path:?}"
    );
    // The difference shrinks with the patches (halving them; finer still, the error is at the
    // level of how patch edges happen to fall on shadow and light boundaries).
    for method in METHODS {
        let mut last = f64::INFINITY;
        for h in [1.0, 0.5, 0.25] {
            let o = RadiosityOptions {
                patch_size: Some(h),
                form_factors: method,
                hemicube_resolution: 128,
                rays_per_patch: 1024,
                refinements: 0,
                ..Default::default()
            };
            let (m, n) = mean(&o);
            let d = rel_diff(m, path);
            println!("{method:?}, patch size {h} ({n} patches): {m:.4?}: {d:.4}");
            assert!(
                d < last,
                "{method:?}, patch size {h}: difference {d} (previous {last})"
            );
            last = d;
        }
        assert!(last < 0.03, "{method:?}: {last}");
    }
}

/// The mask grown by one pixel.
fn dilate(mask: &[bool], res: usize) -> Vec<bool> {
    let mut out = mask.to_vec();
    for y in 0..res {
        for x in 0..res {
            if mask[y * res + x] {
                for (dx, dy) in [
                    (-1i64, 0i64),
                    (1, 0),
                    (0, -1),
                    (0, 1),
                    (-1, -1),
                    (1, 1),
                    (-1, 1),
                    (1, -1),
                ] {
                    let (u, v) = (x as i64 + dx, y as i64 + dy);
                    if u >= 0 && v >= 0 && (u as usize) < res && (v as usize) < res {
                        out[v as usize * res + u as usize] = true;
                    }
                }
            }
        }
    }
    out
}

#[test]
fn the_cache_round_trips_and_detects_stale_solutions() {
    let scene = cornell(AccelKind::Bvh);
    let o = RadiosityOptions {
        patch_size: Some(0.3),
        hemicube_resolution: 64,
        refinements: 1,
        ..Default::default()
    };
    let a = Radiosity::solve(&scene, &o);
    assert_eq!(a.report().cache, CacheStatus::NotUsed);
    let bytes: Arc<[u8]> = a.to_bytes().into();
    let with = |opts: &RadiosityOptions, bytes: Arc<[u8]>| {
        let mut o = opts.clone();
        o.cache = Some(bytes);
        Radiosity::solve(&scene, &o)
    };
    let b = with(&o, bytes.clone());
    assert_eq!(b.report().cache, CacheStatus::Loaded);
    assert_eq!(a.patches(), b.patches());
    assert_eq!(image(&scene, &a, 16, 1), image(&scene, &b, 16, 1));
    // Other options: stale, recomputed.
    let other = RadiosityOptions {
        patch_size: Some(0.35),
        ..o.clone()
    };
    let c = with(&other, bytes.clone());
    assert_eq!(c.report().cache, CacheStatus::Stale);
    assert_ne!(c.len(), a.len());
    // Another scene: stale.
    let mut sb = SceneBuilder::new();
    let m = sb.add_material(white());
    sb.add_shape(
        para([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        m,
        None,
    );
    let mut o2 = o.clone();
    o2.cache = Some(bytes.clone());
    assert_eq!(
        Radiosity::solve(&sb.build(AccelKind::Bvh), &o2)
            .report()
            .cache,
        CacheStatus::Stale
    );
    // Corrupt bytes: invalid, recomputed.
    let mut bad = bytes.to_vec();
    let k = bad.len() / 2;
    bad[k] ^= 0x55;
    let d = with(&o, bad.into());
    assert!(
        matches!(d.report().cache, CacheStatus::Invalid(_)),
        "{:?}",
        d.report().cache
    );
    assert_eq!(d.patches(), a.patches());
    let e = with(&o, Arc::from(&b"not a cache"[..]));
    assert!(matches!(e.report().cache, CacheStatus::Invalid(_)));
}

#[test]
fn the_integrator_is_built_by_name_and_returns_its_report() {
    let scene = cornell(AccelKind::Bvh);
    let settings = IntegratorSettings {
        radiosity: RadiosityOptions {
            patch_size: Some(0.4),
            hemicube_resolution: 64,
            ..Default::default()
        },
        ..Default::default()
    };
    let built = IntegratorKind::Radiosity.build(&scene, &settings).unwrap();
    let (integrator, out) = (built.integrator, built.radiosity.expect("an outcome"));
    assert!(out.report.patches > 0 && out.cache_bytes.is_some());
    assert!(out.report.to_string().contains("patches"));
    let img = image(&scene, integrator.as_ref(), 16, 1);
    assert!(img.mean()[0] > 0.01);
    let bad = IntegratorSettings {
        radiosity: RadiosityOptions {
            patch_size: Some(-1.0),
            ..Default::default()
        },
        ..Default::default()
    };
    assert!(IntegratorKind::Radiosity.build(&scene, &bad).is_err());
}

#[test]
fn degenerate_scenes_give_black_images_without_panicking() {
    let black = |scene: &Scene, o: &RadiosityOptions| {
        let r = Radiosity::solve(scene, o);
        let img = image(scene, &r, 8, 1);
        assert!(
            img.pixels().iter().all(|p| *p == Rgb::BLACK),
            "{}",
            r.report()
        );
        r
    };
    let o = RadiosityOptions::default();
    // Nothing at all.
    let r = black(&SceneBuilder::new().build(AccelKind::Bvh), &o);
    assert!(r.is_empty());
    // No emitter: everything is black, whatever the solver.
    let closed = closed_box(0.5, 0.0);
    for solver in [SolverKind::GaussSeidel, SolverKind::Progressive] {
        black(
            &closed,
            &RadiosityOptions {
                patch_size: Some(0.5),
                solver,
                ..o.clone()
            },
        );
    }
    // Zero-area and degenerate triangles, tiny and huge patch sizes.
    let mut b = SceneBuilder::new();
    let m = b.add_material(white());
    let mut mesh = Mesh {
        positions: vec![
            Point3::ORIGIN,
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ],
        indices: vec![[0, 1, 2], [0, 0, 0], [0, 1, 3]],
        ..Default::default()
    };
    mesh.props.material = m;
    b.add_mesh(mesh);
    let s = b.build(AccelKind::Bvh);
    for h in [1e-9, 1e9] {
        let r = black(
            &s,
            &RadiosityOptions {
                patch_size: Some(h),
                ..o.clone()
            },
        );
        assert!(r.patches().iter().all(|p| p.area > 0.0));
    }
}

#[test]
fn a_camera_inside_a_two_sided_box_sees_the_lit_walls() {
    // The candela language: two-sided walls, a small two-sided light inside.
    let mut b = SceneBuilder::new();
    let m = b.add_material(white());
    let e = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::splat(5.0)),
        two_sided: true,
    });
    let walls = closed_box(0.5, 0.0);
    for o in walls.geometry.objects() {
        b.add_shape(o.shape.clone(), m, None);
    }
    b.add_shape(
        para([-0.2, 0.9, -0.2], [0.4, 0.0, 0.0], [0.0, 0.0, 0.4]),
        m,
        Some(e),
    );
    b.camera(walls.camera);
    let scene = b.build(AccelKind::Bvh);
    let r = Radiosity::solve(
        &scene,
        &RadiosityOptions {
            patch_size: Some(0.25),
            ..Default::default()
        },
    );
    // The light's two sides have patches; the walls' outer sides do not.
    let ps = r.patches();
    assert!(ps.iter().filter(|p| p.prim < 6).all(inward));
    assert!(
        ps.iter().any(|p| p.prim == 6 && p.side == Side::Back)
            && ps.iter().any(|p| p.prim == 6 && p.side == Side::Front)
    );
    let img = image(&scene, &r, 16, 1);
    assert!(
        img.pixels().iter().all(|p| p.g > 0.0),
        "a wall pixel is black"
    );
    // The path tracer agrees on the mean (emitters seen directly aside).
    let mask = dilate(&emitter_mask(&scene, 32), 32);
    let rm = masked_mean(&image(&scene, &r, 32, 1), &mask);
    let pm = masked_mean(&image(&scene, &Path::default(), 32, 128), &mask);
    assert!(
        rel_diff(rm, pm) < 0.05,
        "radiosity {rm:?}, path tracer {pm:?}"
    );
}

#[test]
fn spheres_and_meshes_are_tessellated_into_patches() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(white());
    b.add_shape(
        Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
            0.0, 0.0, 0.0,
        )))),
        m,
        None,
    );
    // Outside the sphere, looking at it along +x.
    b.camera(Camera::perspective(
        1.0,
        1.0,
        Transform::translation(Vec3::new(-2.0, 0.0, 0.0)),
    ));
    let mut mesh = Mesh {
        positions: vec![
            Point3::new(3.0, -2.0, -2.0),
            Point3::new(3.0, 2.0, -2.0),
            Point3::new(3.0, 0.0, 2.0),
        ],
        indices: vec![[0, 1, 2]],
        ..Default::default()
    };
    mesh.props.material = m;
    b.add_mesh(mesh);
    b.add_light(Light::Point(
        PointLight {
            position: Point3::new(-2.0, 0.5, 0.0),
            intensity: Rgb::splat(10.0),
            spectrum: None,
            falloff: Default::default(),
        },
        Components::from_intensity(Rgb::splat(10.0)),
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
    let ps = r.patches();
    let sphere: f64 = ps
        .iter()
        .filter(|p| p.prim == 0 && p.side == Side::Front)
        .map(|p| p.area)
        .sum();
    let tri: Vec<&PatchInfo> = ps
        .iter()
        .filter(|p| p.prim == 1 && p.side == Side::Front)
        .collect();
    let tri_area: f64 = tri.iter().map(|p| p.area).sum();
    println!(
        "sphere area {sphere:.4} (4π = {:.4}), triangle {} patches of area {tri_area:.4}",
        4.0 * PI,
        tri.len()
    );
    assert!((sphere / (4.0 * PI) - 1.0).abs() < 0.03);
    assert!((tri_area - 8.0).abs() < 1e-3 && tri.len() >= 64);
    // A point light lights them (through the direct source term).
    assert!(ps.iter().any(|p| p.prim == 0 && p.radiosity[0] > 0.0));
    assert!(image(&scene, &r, 8, 1).mean()[0] > 0.0);
}

#[test]
fn mirrors_are_traced_and_glossy_materials_use_their_diffuse_part() {
    // The tall box (object 7) is a mirror.
    let scene = cornell_with_mirror();
    for method in METHODS {
        let r = Radiosity::solve(
            &scene,
            &RadiosityOptions {
                patch_size: Some(0.3),
                form_factors: method,
                refinements: 0,
                hemicube_resolution: 64,
                ..Default::default()
            },
        );
        assert!(r.report().warnings.iter().any(|w| w.contains("specular")));
        assert!(
            r.patches().iter().all(|p| p.prim != 7),
            "the mirror got patches"
        );
        let res = 32;
        let img = image(&scene, &r, res, 1);
        assert!(img.pixels().iter().all(|p| p.is_finite()));
        // The mirror shows the lit floor below and the open front of the box (black) above.
        let mut st = candela_render::stats::RayStats::default();
        let (mut seen, mut lit) = (0, 0);
        for y in 0..res {
            for x in 0..res {
                let ray = pixel_ray(&scene, res, x, y);
                if scene.intersect(&ray, &mut st).is_some_and(|h| h.prim == 7) {
                    seen += 1;
                    lit += (img.get(x, y).r > 0.0) as usize;
                }
            }
        }
        assert!(
            seen > 20 && lit > seen / 4,
            "{method:?}: {lit} of the {seen} mirror pixels are lit"
        );
    }
}

#[test]
fn final_gather_and_flat_display_agree_with_gouraud_on_the_mean() {
    let scene = cornell(AccelKind::Bvh);
    let res = 32;
    let mask = emitter_mask(&scene, res);
    let mut means = Vec::new();
    for display in [
        DisplayMode::Gouraud,
        DisplayMode::Flat,
        DisplayMode::FinalGather(16),
    ] {
        let r = Radiosity::solve(
            &scene,
            &RadiosityOptions {
                patch_size: Some(0.2),
                hemicube_resolution: 128,
                refinements: 0,
                display,
                ..Default::default()
            },
        );
        means.push(masked_mean(&image(&scene, &r, res, 8), &mask));
    }
    println!("{means:.4?}");
    for m in &means[1..] {
        assert!(rel_diff(*m, means[0]) < 0.05, "{means:?}");
    }
}

/// Non-finite emission cannot be solved: `try_solve` refuses it before any form factor, and
/// `solve` stops its sweeps as soon as the residual is not finite (no thousands of sweeps).
#[test]
fn non_finite_emission_is_refused_up_front() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(white());
    let e = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::new(f32::NAN, 1.0, f32::INFINITY)),
        two_sided: true,
    });
    let walls = closed_box(0.5, 0.0);
    for o in walls.geometry.objects() {
        b.add_shape(o.shape.clone(), m, None);
    }
    b.add_shape(
        para([-0.2, 0.9, -0.2], [0.4, 0.0, 0.0], [0.0, 0.0, 0.4]),
        m,
        Some(e),
    );
    let scene = b.build(AccelKind::Bvh);
    let opts = RadiosityOptions {
        patch_size: Some(0.25),
        ..Default::default()
    };
    let start = std::time::Instant::now();
    let Err(err) = Radiosity::try_solve(&scene, &opts) else {
        panic!("a non-finite emission was solved");
    };
    assert!(err.contains("non-finite emission"), "{err}");
    assert!(start.elapsed().as_secs_f64() < 5.0);
    let r = Radiosity::solve(&scene, &opts);
    let report = r.outcome().report;
    assert!(report.iterations < 10, "{report}");
}
