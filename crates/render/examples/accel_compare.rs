//! Compares the acceleration structures: build time, memory, rays per second (one thread and
//! all threads, closest hit and any hit) and nodes / primitive tests per ray, on the scenes of
//! the accelerator benchmarks (a bumpy sphere of ~1M triangles, random spheres, the Cornell
//! box) for coherent camera rays and random rays. Every structure's hits are checked against
//! the BVH's (Embree's only by primitive, its triangle test being another one).
//!
//! `cargo run --release -p candela-render [--features embree] --example accel_compare --
//! [mesh|bounce|spheres|cornell|all] [--subdiv N] [--spheres N] [--rays N] [--repeat R]
//! [--accel bvh,embree,...] [--threads 1|all|both] [--set camera|random|both]
//! [--bounce-set first|random|missing|all]`
//!
//! `bounce` (also part of `mesh`): a path tracer's first-bounce rays on the bumpy sphere, sixteen
//! from each camera ray's hit in cosine-distributed directions (a pixel's samples), one thread,
//! ray by ray and in batches of sixteen through the BVH, and with the `embree` feature ray by
//! ray through Embree and sixteen at a time through its hybrid packet traversal
//! (`rtcIntersect16`, as Mitsuba traces them); random rays and rays that miss the mesh's box
//! (the cost of a call) as controls.
//!
//! `--bounce-set` runs one of `bounce`'s sets alone: with `--repeat 1` under Valgrind's callgrind,
//! the calls' inclusive counts give each structure's instructions per ray on that set (the
//! machine has no hardware counters; see `bench/README.md`).
//!
//! Rays/s are the best of R passes; the structures take turns within each pass so that a
//! busy machine slows all of them alike.

use std::time::Instant;

use candela_render::accel::{Accel, AccelKind};
use candela_render::geometry::Geometry;
use candela_render::math::Ray;
use candela_render::stats::RayStats;
use rayon::prelude::*;

#[path = "../benches/support/scenes.rs"]
mod scenes;

/// Closest hits as (primitive, t).
type Hits = Vec<Option<(u32, f32)>>;

/// Traces all rays (in parallel chunks when `par`); returns seconds and, for closest-hit
/// queries, the hits as (primitive, t).
fn trace(accel: &Accel, g: &Geometry, rays: &[Ray], any: bool, par: bool) -> (f64, Hits, RayStats) {
    let t = Instant::now();
    let one = |r: &Ray, st: &mut RayStats| {
        if any {
            accel.occluded(g, r, st).then_some((0, 0.0))
        } else {
            accel.intersect(g, r, st).map(|h| (h.prim, h.t))
        }
    };
    let (hits, st) = if par {
        let parts: Vec<(Hits, RayStats)> = rays
            .par_chunks(256)
            .map(|c| {
                let mut st = RayStats::default();
                (c.iter().map(|r| one(r, &mut st)).collect(), st)
            })
            .collect();
        let mut st = RayStats::default();
        let mut hits = Vec::with_capacity(rays.len());
        for (h, s) in parts {
            hits.extend(h);
            st += s;
        }
        (hits, st)
    } else {
        let mut st = RayStats::default();
        (rays.iter().map(|r| one(r, &mut st)).collect(), st)
    };
    (t.elapsed().as_secs_f64(), hits, st)
}

struct Row {
    kind: AccelKind,
    accel: Accel,
    /// Per ray set: best seconds for (closest, any) × (1 thread, all threads).
    secs: Vec<[f64; 4]>,
    stats: Vec<RayStats>,
    hits: Vec<Hits>,
}

fn bench(b: &scenes::Bench, kinds: &[AccelKind], repeat: usize, threads: &str, only: &str) {
    let g = &b.geometry;
    let sets: Vec<(&str, &Vec<Ray>)> = [("camera", &b.coherent), ("random", &b.incoherent)]
        .into_iter()
        .filter(|(n, _)| only == "both" || *n == only)
        .collect();
    println!(
        "\n== {}: {} primitives, {} rays per set",
        b.name,
        g.bounded_count(),
        b.coherent.len()
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let all = rayon::ThreadPoolBuilder::new().build().unwrap();
    let (do1, doall) = match threads {
        "1" => (true, false),
        "all" => (false, true),
        _ => (true, true),
    };
    // Embree holds triangles only: without them it would time candela's BVH again.
    let kinds: Vec<AccelKind> = kinds
        .iter()
        .copied()
        .filter(|k| g.meshes().iter().any(|m| !m.is_empty()) || format!("{k:?}") != "Embree")
        .collect();
    let mut rows: Vec<Row> = kinds
        .iter()
        .map(|&kind| {
            // Best of `repeat` builds on one thread and on all.
            let mut best = (f64::INFINITY, f64::INFINITY);
            let mut accel = None;
            for _ in 0..repeat.min(3) {
                if do1 {
                    let t = Instant::now();
                    let a = one.install(|| Accel::build(kind, g));
                    best.0 = best.0.min(t.elapsed().as_secs_f64());
                    accel = Some(a);
                }
                if doall {
                    let t = Instant::now();
                    let a = all.install(|| Accel::build(kind, g));
                    best.1 = best.1.min(t.elapsed().as_secs_f64());
                    accel = Some(a);
                }
            }
            let accel = accel.unwrap();
            println!(
                "{:<7} build {:>7.3} s (1 thread) {:>7.3} s (all), memory {:>7.1} MiB ({})",
                format!("{kind:?}"),
                best.0,
                best.1,
                accel.memory() as f64 / (1 << 20) as f64,
                accel.describe()
            );
            Row {
                kind,
                accel,
                secs: vec![[f64::INFINITY; 4]; 2],
                stats: vec![RayStats::default(); 2],
                hits: vec![Vec::new(); 2],
            }
        })
        .collect();
    for _ in 0..repeat {
        for row in &mut rows {
            for (si, (_, rays)) in sets.iter().enumerate() {
                for (k, (any, par)) in [(false, false), (true, false), (false, true), (true, true)]
                    .into_iter()
                    .enumerate()
                {
                    if (par && !doall) || (!par && !do1) {
                        continue;
                    }
                    let pool = if par { &all } else { &one };
                    let (s, hits, st) = pool.install(|| trace(&row.accel, g, rays, any, par));
                    row.secs[si][k] = row.secs[si][k].min(s);
                    if !any {
                        row.hits[si] = hits;
                        row.stats[si] = st;
                    }
                }
            }
        }
    }
    let reference = rows
        .iter()
        .position(|r| r.kind == AccelKind::Bvh)
        .unwrap_or(0);
    let embree = rows
        .iter()
        .position(|r| format!("{:?}", r.kind) == "Embree");
    for (si, (set, rays)) in sets.iter().enumerate() {
        println!("  {set} rays (Mrays/s: closest 1 thread, any-hit 1 thread | closest all threads, any-hit all threads)");
        let n = rays.len() as f64;
        for row in &rows {
            let rate = |k: usize| n / row.secs[si][k] / 1e6;
            let mismatches = row.hits[si]
                .iter()
                .zip(&rows[reference].hits[si])
                .filter(|(a, b)| match (a, b) {
                    (Some(a), Some(b)) if format!("{:?}", row.kind) == "Embree" => a.0 != b.0,
                    _ => a != b,
                })
                .count();
            let vs = |k: usize| match embree {
                Some(e) => format!("{:.2}x", rows[e].secs[si][k] / row.secs[si][k]),
                None => "-".into(),
            };
            println!(
                "    {:<7} {:>8.4} {:>8.4} | {:>8.4} {:>8.4}  vs Embree {} {} | {} {}  {:>6.1} nodes/ray {:>6.1} tests/ray  {} hits, {} differ from the BVH",
                format!("{:?}", row.kind),
                rate(0),
                rate(1),
                rate(2),
                rate(3),
                vs(0),
                vs(1),
                vs(2),
                vs(3),
                row.stats[si].nodes as f64 / n,
                row.stats[si].prim_tests as f64 / n,
                row.hits[si].iter().filter(|h| h.is_some()).count(),
                mismatches
            );
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opt = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let num = |name: &str, def: usize| opt(name).and_then(|v| v.parse().ok()).unwrap_or(def);
    let which = args
        .first()
        .filter(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "all".into());
    let rays = num("--rays", 1 << 20);
    let repeat = num("--repeat", 3);
    let threads = opt("--threads").unwrap_or_else(|| "both".into());
    let only = opt("--set").unwrap_or_else(|| "both".into());
    let kinds: Vec<AccelKind> = match opt("--accel") {
        Some(list) => list
            .split(',')
            .map(|n| AccelKind::parse(n).unwrap_or_else(|e| panic!("--accel: {e}")))
            .collect(),
        None => AccelKind::NAMES
            .iter()
            .filter(|&&n| n != "none")
            .map(|n| AccelKind::from_name(n).unwrap())
            .collect(),
    };
    if which == "all" || which == "mesh" {
        let t = Instant::now();
        let b = scenes::mesh_bench(num("--subdiv", 289) as u32, rays);
        println!("\n(mesh generated in {:.2} s)", t.elapsed().as_secs_f64());
        bench(&b, &kinds, repeat, &threads, &only);
    }
    if which == "all" || which == "mesh" || which == "bounce" {
        let only = opt("--bounce-set").unwrap_or_else(|| "all".into());
        bounce(num("--subdiv", 289) as u32, rays, repeat, &only);
    }
    if which == "all" || which == "spheres" {
        bench(
            &scenes::spheres_bench(num("--spheres", 10_000), rays),
            &kinds,
            repeat,
            &threads,
            &only,
        );
    }
    if which == "all" || which == "cornell" {
        bench(
            &scenes::cornell_bench(rays),
            &kinds,
            repeat,
            &threads,
            &only,
        );
    }
}

/// The `bounce` comparison (see the module's documentation): first-bounce rays, and as
/// controls random rays from inside the mesh and rays that miss its box (the cost of a call).
/// The rays of `rs` one by one through `accel`; returns how many hit. (A function of its own,
/// never inlined, so that a profile counts exactly one pass's calls: see `--bounce-set`.)
#[inline(never)]
fn single_pass(accel: &Accel, g: &Geometry, rs: &[Ray]) -> usize {
    let mut st = RayStats::default();
    rs.iter()
        .filter(|r| accel.intersect(g, r, &mut st).is_some())
        .count()
}

/// [`single_pass`] through Embree.
#[cfg(feature = "embree")]
#[inline(never)]
fn single_pass_embree(e: &candela_render::accel::Embree, g: &Geometry, rs: &[Ray]) -> usize {
    let mut st = RayStats::default();
    rs.iter()
        .filter(|r| e.intersect(g, r, &mut st).is_some())
        .count()
}

fn bounce(subdiv: u32, n: usize, repeat: usize, only: &str) {
    let b = scenes::mesh_bench(subdiv, n / 16);
    let g = &b.geometry;
    let bvh = Accel::build(AccelKind::Bvh, g);
    let mut st = RayStats::default();
    let mut rng = candela_render::sampling::Pcg32::new(3, 4);
    let mut rays = Vec::with_capacity(n);
    for cam in &b.coherent {
        let Some(hit) = bvh.intersect(g, cam, &mut st) else {
            continue;
        };
        let si = g.interaction(cam, &hit);
        let n = if si.n.to_vec().dot(cam.d) > 0.0 {
            -si.n
        } else {
            si.n
        };
        let frame = candela_render::math::Frame::from_normal(n);
        for _ in 0..16 {
            let local = candela_render::sampling::warp::square_to_cosine_hemisphere([
                rng.next_f32(),
                rng.next_f32(),
            ]);
            rays.push(Ray::spawn_unit(si.p, n, frame.to_world(local)));
        }
    }
    let random = scenes::random_rays(candela_render::math::Point3::ORIGIN, 0.6, rays.len());
    let away: Vec<Ray> = (0..rays.len())
        .map(|i| {
            Ray::new(
                candela_render::math::Point3::new(100.0 + i as f32 * 1e-3, 100.0, 100.0),
                candela_render::math::Vec3::new(1.0, 0.5, 0.25),
            )
        })
        .collect();
    println!(
        "\n== bounce: {} first-bounce rays (16 per camera hit) on the mesh, Mrays/s, 1 thread",
        rays.len()
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let rate = |rays: &[Ray], f: &(dyn Fn(&[Ray]) -> usize + Sync)| {
        let mut best = f64::INFINITY;
        let mut hits = 0;
        for _ in 0..repeat {
            let t = Instant::now();
            hits = one.install(|| f(rays));
            best = best.min(t.elapsed().as_secs_f64());
        }
        (rays.len() as f64 / best / 1e6, hits)
    };
    let sets: [(&str, &[Ray]); 3] = [
        ("first bounce", &rays),
        ("random", &random),
        ("missing (per call)", &away),
    ];
    for (name, set) in sets {
        if only != "all" && !name.starts_with(only) {
            continue;
        }
        let (single, hits) = rate(set, &|rs| single_pass(&bvh, g, rs));
        // Sixteen at a time through the batch entry (packets for any six sharing an octant).
        let (batch, _) = rate(set, &|rs| {
            let mut st = RayStats::default();
            let mut hits = [None; candela_render::math::BATCH];
            let mut n = 0;
            for group in rs.chunks(16) {
                let mut b = candela_render::math::RayBatch::default();
                for (i, r) in group.iter().enumerate() {
                    b.set(i, r);
                }
                bvh.intersect_batch(g, &b, &mut hits, &mut st);
                n += hits.iter().flatten().count();
            }
            n
        });
        print!("    {name:<19} Bvh {single:7.2} (batches of 16: {batch:7.2})");
        #[cfg(feature = "embree")]
        {
            let e = candela_render::accel::Embree::build(g);
            let (e1, _) = rate(set, &|rs| single_pass_embree(&e, g, rs));
            let (e16, _) = rate(set, &|rs| e.intersect16(rs).iter().flatten().count());
            print!(
                "  Embree {e1:7.2}, 16 at a time {e16:7.2}  Bvh {:.2}x, {:.2}x",
                single / e1,
                single / e16
            );
        }
        println!("  ({hits} hits)");
    }
}
