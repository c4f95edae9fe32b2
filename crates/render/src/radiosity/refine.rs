//! The solve with adaptive refinement: solve, split the elements where the reflected
//! radiosity changes fast (and those at the edges of hidden regions), solve again.

use super::options::{RadiosityOptions, SolverKind};
use super::report::RadiosityReport;
use super::{direct, display, formfactor, mesh, solver, NONE};
use crate::math::Ray;
use crate::scene::Scene;
use crate::stats::RayStats;
use std::time::Instant;

/// Luminance weights.
fn lum(x: &[f64; 3]) -> f64 {
    0.2126 * x[0] + 0.7152 * x[1] + 0.0722 * x[2]
}

/// Which patches are hidden: most of their hemicube (or rays) sees absorbers or surfaces
/// nearer than half their size; a patch without a computed row is hidden when it received
/// nothing.
fn hidden_patches(occluded: &[f32], b: &[[f64; 3]]) -> Vec<bool> {
    occluded
        .iter()
        .zip(b)
        .map(|(&o, b)| {
            if o < 0.0 {
                b.iter().all(|&x| x == 0.0)
            } else {
                o >= 0.5
            }
        })
        .collect()
}

/// Solves with refinement passes; returns B and the hidden patches, and fills the report.
pub(super) fn compute(
    scene: &Scene,
    opts: &RadiosityOptions,
    m: &mut mesh::Meshing,
    report: &mut RadiosityReport,
) -> (Vec<[f64; 3]>, Vec<bool>) {
    let t_solve = Instant::now();
    let mut warm: Option<Vec<[f64; 3]>> = None;
    let mut pass = 0u32;
    let mut ff_seconds = 0f64;
    let mut fell_back = false;
    loop {
        let n = m.patches.len();
        let direct = direct::direct_sources(scene, m, opts.seed);
        let source: Vec<[f64; 3]> = m
            .patches
            .iter()
            .zip(&direct)
            .map(|(p, d)| [p.emit[0] + d[0], p.emit[1] + d[1], p.emit[2] + d[2]])
            .collect();
        let sol = {
            let engine = formfactor::Engine::new(
                scene,
                m,
                opts.form_factors,
                opts.hemicube_resolution,
                opts.rays_per_patch,
                opts.seed,
            );
            let max_shots = if opts.max_iterations > 0 {
                opts.max_iterations
            } else {
                200 * n as u64 + 10_000
            };
            let max_sweeps = if opts.max_iterations > 0 {
                opts.max_iterations
            } else {
                10_000
            };
            let progressive = |fell: bool| {
                let mut s = solver::progressive(
                    &engine,
                    &m.patches,
                    &source,
                    opts.threshold,
                    max_shots,
                    opts.row_cache_bytes,
                );
                s.fell_back = fell;
                s
            };
            match opts.solver {
                SolverKind::Progressive => progressive(false),
                SolverKind::GaussSeidel => {
                    let t = Instant::now();
                    let rows = solver::all_rows(&engine, n, opts.matrix_bytes_limit);
                    ff_seconds += t.elapsed().as_secs_f64();
                    match rows {
                        Some(rows) => solver::gauss_seidel(
                            rows,
                            &m.patches,
                            &source,
                            warm.take(),
                            opts.threshold,
                            max_sweeps,
                            opts.reciprocal_gather,
                        ),
                        None => progressive(true),
                    }
                }
            }
        };
        if sol.fell_back && !fell_back {
            fell_back = true;
            report.warnings.push(format!(
                "radiosity: the form-factor matrix of {n} patches needs more than {} MiB: solved by progressive refinement instead of Gauss–Seidel",
                opts.matrix_bytes_limit >> 20
            ));
        }
        report.solver = if sol.fell_back {
            SolverKind::Progressive
        } else {
            opts.solver
        };
        report.iterations = sol.iterations;
        report.residual = sol.residual;
        report.converged = sol.converged;
        report.rows_computed += sol.rows_computed;
        report.row_sum_min = sol.stats.sum_min;
        report.row_sum_max = sol.stats.sum_max;
        report.row_sum_mean = if sol.stats.rows > 0 {
            sol.stats.sum_total / sol.stats.rows as f64
        } else {
            0.0
        };
        (
            report.reciprocity_error,
            report.reciprocity_max,
            report.reciprocity_pairs,
        ) = sol.reciprocity;
        report.form_factor_bytes = report.form_factor_bytes.max(sol.row_bytes);
        let hidden = hidden_patches(&sol.occluded, &sol.b);
        if pass >= opts.refinements || n >= opts.max_patches {
            report.seconds_form_factors = ff_seconds;
            report.seconds_solve = t_solve.elapsed().as_secs_f64() - ff_seconds;
            return (sol.b, hidden);
        }
        let old_ids: Vec<[u32; 2]> = m.elements.iter().map(|e| e.patch).collect();
        let split = refine(scene, m, &sol.b, &hidden, opts);
        if split == 0 {
            report.seconds_form_factors = ff_seconds;
            report.seconds_solve = t_solve.elapsed().as_secs_f64() - ff_seconds;
            return (sol.b, hidden);
        }
        report.refinement_passes += 1;
        report.elements_split += split;
        m.assign_patches(scene);
        // Warm start: each new patch starts from its ancestor's radiosity.
        let mut b0 = Vec::with_capacity(m.patches.len());
        for p in &m.patches {
            let mut e = p.elem;
            let side = p.side as usize;
            let mut v = None;
            while e != NONE {
                if let Some(ids) = old_ids.get(e as usize) {
                    if ids[side] != NONE {
                        v = Some(sol.b[ids[side] as usize]);
                        break;
                    }
                }
                e = m.elements[e as usize].parent;
            }
            b0.push(v.unwrap_or(p.emit));
        }
        warm = Some(b0);
        pass += 1;
    }
}

/// Splits the elements where the reflected radiosity changes fast; returns how many.
fn refine(
    scene: &Scene,
    m: &mut mesh::Meshing,
    b: &[[f64; 3]],
    hidden: &[bool],
    opts: &RadiosityOptions,
) -> usize {
    let r: Vec<[f64; 3]> = b
        .iter()
        .zip(&m.patches)
        .map(|(b, p)| [b[0] - p.emit[0], b[1] - p.emit[1], b[2] - p.emit[2]])
        .collect();
    let cv = display::corner_values(m, &r, hidden);
    let (mut sum, mut area) = (0f64, 0f64);
    for (p, ri) in m.patches.iter().zip(&r) {
        if p.emit.iter().all(|&e| e == 0.0) {
            sum += p.area * lum(ri);
            area += p.area;
        }
    }
    if !(sum > 0.0 && area > 0.0) {
        return 0;
    }
    let mean = sum / area;
    // The largest corner difference per element, relative to the mean.
    let mut score: Vec<(f64, u32)> = Vec::new();
    let mut best: std::collections::HashMap<u32, f64> = std::collections::HashMap::new();
    for (i, p) in m.patches.iter().enumerate() {
        if p.emit.iter().any(|&e| e > 0.0) {
            continue;
        }
        let e = &m.elements[p.elem as usize];
        if e.level as u32 >= opts.refinements || e.max_edge() < m.patch_size / 64.0 {
            continue;
        }
        let own = lum(&r[i]);
        let d = cv[i][..e.nverts as usize]
            .iter()
            .map(|c| (lum(c) - own).abs())
            .fold(0.0, f64::max)
            / mean;
        if d > opts.refine_threshold as f64 {
            let v = best.entry(p.elem).or_insert(0.0);
            *v = v.max(d);
        }
    }
    score.extend(best.into_iter().map(|(e, d)| (d, e)));
    score.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    // Hidden patches on the edge of a hidden region: their radiosity (computed at a hidden
    // centre) does not represent their visible part, so they are split further, down to
    // HIDDEN_LEVELS below the refinement depth, where the children's centres change side.
    let boundary = display::hidden_boundary(m, hidden);
    let mut deep = Vec::new();
    for (i, p) in m.patches.iter().enumerate() {
        let e = &m.elements[p.elem as usize];
        if boundary[i]
            && p.emit.iter().all(|&x| x == 0.0)
            && (e.level as u32) < opts.refinements + HIDDEN_LEVELS
            && !deep.iter().any(|&(el, _)| el == p.elem)
        {
            deep.push((p.elem, p.side as usize));
        }
    }
    let mut patches = m.patches.len();
    let mut split = 0;
    let cost = |m: &mesh::Meshing, e: u32| {
        3 * m.elements[e as usize]
            .patch
            .iter()
            .filter(|&&p| p != NONE)
            .count()
    };
    for (_, e) in score {
        if m.elements[e as usize].children != NONE {
            continue;
        }
        let c = cost(m, e);
        if patches + c > opts.max_patches {
            break;
        }
        patches += c;
        m.split(e, true);
        m.splits.push(e);
        split += 1;
    }
    let mut stats = RayStats::default();
    let mut stack: Vec<(u32, usize)> = deep;
    while let Some((e, side)) = stack.pop() {
        let el = &m.elements[e as usize];
        if el.children != NONE || (el.level as u32) >= opts.refinements + HIDDEN_LEVELS {
            continue;
        }
        let c = 3 * m.surfaces[el.surface as usize]
            .active
            .iter()
            .filter(|&&a| a)
            .count();
        if patches + c > opts.max_patches {
            break;
        }
        patches += c;
        let first = m.split(e, true);
        m.splits.push(e);
        split += 1;
        let kids: Vec<(u32, bool)> = (first..first + 4)
            .map(|k| (k, hidden_point(scene, m, k, side, &mut stats)))
            .collect();
        if kids.iter().any(|k| k.1) && kids.iter().any(|k| !k.1) {
            stack.extend(kids.iter().filter(|k| k.1).map(|k| (k.0, side)));
        }
    }
    split
}

/// Levels of extra splitting at the edges of hidden regions.
const HIDDEN_LEVELS: u32 = 3;

/// True when the centre of `side` of element `e` is hidden: half of 16 cosine rays hit, within
/// half the patch size, something or a side without patches.
fn hidden_point(
    scene: &Scene,
    m: &mesh::Meshing,
    e: u32,
    side: usize,
    stats: &mut RayStats,
) -> bool {
    let el = &m.elements[e as usize];
    let n = if side == 0 { el.normal } else { -el.normal };
    let frame = crate::math::Frame::from_normal(n.to_normal());
    let near = 0.5 * m.patch_size;
    let mut hidden = 0;
    const RAYS: u32 = 16;
    for k in 0..RAYS {
        let u = crate::sampling::sampler::cmj(k, RAYS, e);
        let d = frame.to_world(crate::sampling::warp::square_to_cosine_hemisphere(u));
        let ray = Ray::spawn(el.centre, n.to_normal(), d);
        let Some(hit) = scene.intersect(&ray, stats) else {
            continue;
        };
        if hit.t * ray.d.norm() < near {
            hidden += 1;
            continue;
        }
        let si = scene.geometry.interaction(&ray, &hit);
        let absorbs = match m.locate(&hit, &si) {
            Some((h, _)) => {
                let s = if si.n.dot_vec(ray.d) < 0.0 { 0 } else { 1 };
                !m.surfaces[m.elements[h as usize].surface as usize].active[s]
            }
            None => true,
        };
        hidden += absorbs as u32;
    }
    2 * hidden >= RAYS
}
