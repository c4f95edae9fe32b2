//! Compares the acceleration structures: build time, memory, rays per second (one thread) and
//! nodes / primitive tests per ray, on random spheres and on a subdivided-sphere mesh, for
//! coherent camera rays and random rays. Every structure's hits are checked against the BVH's.
//!
//! `cargo run --release -p candela-render --example accel_compare -- [spheres|mesh|all]
//! [--spheres N] [--subdiv K] [--rays N] [--repeat R]` (rays/s: best of R passes)

use std::collections::HashMap;
use std::time::Instant;

use candela_render::accel::{Accel, AccelKind};
use candela_render::interaction::SurfaceProps;
use candela_render::math::{Point3, Ray, Transform, Vec3};
use candela_render::sampling::Pcg32;
use candela_render::scene::{Geometry, Object};
use candela_render::shape::{Mesh, Shape, Sphere};
use candela_render::stats::RayStats;

fn random_spheres(n: usize) -> Geometry {
    let mut rng = Pcg32::new(5, 1);
    let objects = (0..n)
        .map(|_| {
            let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0
                - Vec3::new(10.0, 10.0, 10.0);
            let r = 0.05 + 0.2 * rng.next_f32();
            Object {
                shape: Shape::Sphere(Sphere::new(
                    Transform::translation(c) * Transform::scaling(Vec3::new(r, r, r)),
                )),
                props: SurfaceProps::new(0),
            }
        })
        .collect();
    Geometry::new(objects, Vec::new())
}

/// An icosahedron subdivided `k` times onto the sphere of radius 10 (20·4^k triangles).
fn icosphere(k: u32) -> Geometry {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut pos: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..k {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        for &[a, b, c] in &tris {
            let mut m = |i: u32, j: u32| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    pos.push(((pos[i as usize] + pos[j as usize]) * 0.5).normalize());
                    pos.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let mesh = Mesh {
        positions: pos.iter().map(|p| (*p * 10.0).to_point()).collect(),
        indices: tris,
        ..Mesh::default()
    };
    Geometry::new(Vec::new(), vec![mesh])
}

/// `n` pinhole-camera rays looking at the origin from `eye`, on a square image grid.
fn camera_rays(eye: Point3, fov_tan: f32, n: usize) -> Vec<Ray> {
    let side = (n as f32).sqrt() as usize;
    let w = (Point3::ORIGIN - eye).normalize();
    let u = w.cross(Vec3::Z).normalize();
    let v = u.cross(w);
    let mut rays = Vec::with_capacity(side * side);
    for j in 0..side {
        for i in 0..side {
            let x = ((i as f32 + 0.5) / side as f32 * 2.0 - 1.0) * fov_tan;
            let y = ((j as f32 + 0.5) / side as f32 * 2.0 - 1.0) * fov_tan;
            rays.push(Ray::new(eye, (w + u * x + v * y).normalize()));
        }
    }
    rays
}

/// `n` rays from uniform points in the cube [-s, s]³ in uniform directions.
fn random_rays(s: f32, n: usize) -> Vec<Ray> {
    let mut rng = Pcg32::new(11, 2);
    (0..n)
        .map(|_| {
            let o = Point3::new(
                rng.next_f32() * 2.0 - 1.0,
                rng.next_f32() * 2.0 - 1.0,
                rng.next_f32() * 2.0 - 1.0,
            );
            let d = candela_render::sampling::warp::square_to_uniform_sphere([
                rng.next_f32(),
                rng.next_f32(),
            ]);
            Ray::new(Point3::new(o.x * s, o.y * s, o.z * s), d)
        })
        .collect()
}

fn memory(a: &Accel) -> usize {
    match a {
        Accel::List(_) => 0,
        Accel::Bvh(b) => b.memory(),
        Accel::KdTree(k) => k.memory(),
        Accel::Grid(g) => g.memory(),
        Accel::Octree(o) => o.memory(),
    }
}

fn describe(a: &Accel) -> String {
    match a {
        Accel::List(_) => String::new(),
        Accel::Bvh(b) => format!("{} nodes", b.node_count()),
        Accel::KdTree(k) => format!(
            "{} nodes, depth {}, {} refs",
            k.node_count(),
            k.depth(),
            k.reference_count()
        ),
        Accel::Grid(g) => format!("{:?} cells, {} refs", g.resolution(), g.reference_count()),
        Accel::Octree(o) => format!("{} nodes, {} refs", o.node_count(), o.reference_count()),
    }
}

fn bench(name: &str, g: &Geometry, sets: &[(&str, Vec<Ray>)], repeat: usize) {
    println!("\n== {name}: {} primitives", g.bounded_count());
    let mut reference: Vec<Vec<Option<(u32, f32)>>> = Vec::new();
    let mut bvh_rate: Vec<f64> = Vec::new();
    for kind in [
        AccelKind::Bvh,
        AccelKind::KdTree,
        AccelKind::Grid,
        AccelKind::Octree,
    ] {
        let t = Instant::now();
        let accel = Accel::build(kind, g);
        let build = t.elapsed().as_secs_f64();
        println!(
            "{:<7} build {:>7.3} s, memory {:>7.1} MiB ({})",
            format!("{kind:?}"),
            build,
            memory(&accel) as f64 / (1 << 20) as f64,
            describe(&accel)
        );
        for (si, (set, rays)) in sets.iter().enumerate() {
            // Best of `repeat` passes (the machine may be shared).
            let (mut secs, mut shadow_secs) = (f64::INFINITY, f64::INFINITY);
            let (mut st, mut hits, mut blocked) = (RayStats::default(), Vec::new(), 0);
            for _ in 0..repeat {
                st = RayStats::default();
                hits = Vec::with_capacity(rays.len());
                let t = Instant::now();
                for r in rays {
                    hits.push(accel.intersect(g, r, &mut st).map(|h| (h.prim, h.t)));
                }
                secs = secs.min(t.elapsed().as_secs_f64());
                let mut sst = RayStats::default();
                let t = Instant::now();
                blocked = 0;
                for r in rays {
                    blocked += accel.occluded(g, r, &mut sst) as usize;
                }
                shadow_secs = shadow_secs.min(t.elapsed().as_secs_f64());
            }
            let rate = rays.len() as f64 / secs;
            let shadow_rate = rays.len() as f64 / shadow_secs;
            if kind == AccelKind::Bvh {
                reference.push(hits.clone());
                bvh_rate.push(rate);
            }
            let mismatches = hits
                .iter()
                .zip(&reference[si])
                .filter(|(a, b)| a != b)
                .count();
            let n = rays.len() as f64;
            println!(
                "    {set:<8} {:>8.3} Mrays/s ({:>5.2}x BVH), {:>7.1} nodes/ray, {:>6.1} tests/ray, any-hit {:>8.3} Mrays/s, {} hits {} blocked, {} mismatches",
                rate / 1e6,
                bvh_rate[si] / rate,
                st.nodes as f64 / n,
                st.prim_tests as f64 / n,
                shadow_rate / 1e6,
                hits.iter().filter(|h| h.is_some()).count(),
                blocked,
                mismatches
            );
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opt = |name: &str, def: usize| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(def)
    };
    let which = args
        .first()
        .filter(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "all".into());
    let rays = opt("--rays", 1 << 18);
    let repeat = opt("--repeat", 3);
    if which == "all" || which == "spheres" {
        let g = random_spheres(opt("--spheres", 10_000));
        bench(
            "random spheres",
            &g,
            &[
                (
                    "camera",
                    camera_rays(Point3::new(30.0, -25.0, 18.0), 0.45, rays),
                ),
                ("random", random_rays(10.0, rays)),
            ],
            repeat,
        );
    }
    if which == "all" || which == "mesh" {
        let t = Instant::now();
        let g = icosphere(opt("--subdiv", 8) as u32);
        println!("\n(mesh generated in {:.2} s)", t.elapsed().as_secs_f64());
        bench(
            "subdivided sphere",
            &g,
            &[
                (
                    "camera",
                    camera_rays(Point3::new(24.0, -20.0, 14.0), 0.45, rays),
                ),
                ("random", random_rays(7.0, rays)),
            ],
            repeat,
        );
    }
}
