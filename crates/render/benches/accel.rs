//! Accelerator benchmarks: build time and traversal rays/s of every structure (bvh, kdtree,
//! grid, octree; embree with the `embree` feature) on a bumpy sphere of ~1M triangles, 10k
//! random spheres and the Cornell box, for coherent camera rays and incoherent random rays,
//! on one thread and on all threads; and the BVH against the linear list at 100k triangles.
//!
//! `cargo bench -p candela-render --bench accel [--features embree] [-- FILTER]`
//! (about two minutes). Throughput is printed in items (rays) per second. For the detailed
//! comparison with Embree (nodes and tests per ray, any-hit rays, hit agreement) run
//! `examples/accel_compare.rs`.

use std::sync::OnceLock;

use candela_render::accel::{Accel, AccelKind};
use candela_render::geometry::Geometry;
use candela_render::math::Ray;
use candela_render::stats::RayStats;
use divan::counter::ItemsCount;
use divan::{black_box, Bencher};
use rayon::prelude::*;

#[path = "support/scenes.rs"]
mod scenes;

fn main() {
    divan::main();
}

/// The structures benchmarked.
#[cfg(not(feature = "embree"))]
const KINDS: &[&str] = &["bvh", "kdtree", "grid", "octree"];
/// The structures benchmarked.
#[cfg(feature = "embree")]
const KINDS: &[&str] = &["bvh", "kdtree", "grid", "octree", "embree"];

/// Rays per set (per benchmark iteration).
const RAYS: usize = 1 << 16;

/// A scene with every structure built over it.
struct Fixture {
    bench: scenes::Bench,
    accels: Vec<(&'static str, Accel)>,
}

impl Fixture {
    fn new(bench: scenes::Bench) -> Self {
        let accels = KINDS
            .iter()
            .map(|&k| (k, Accel::build(kind(k), &bench.geometry)))
            .collect();
        Self { bench, accels }
    }

    fn accel(&self, k: &str) -> &Accel {
        &self.accels.iter().find(|(n, _)| *n == k).expect("built").1
    }
}

fn kind(name: &str) -> AccelKind {
    AccelKind::parse(name).expect("a known structure")
}

fn mesh() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| Fixture::new(scenes::mesh_bench(289, RAYS)))
}

fn spheres() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| Fixture::new(scenes::spheres_bench(10_000, RAYS)))
}

fn cornell() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| Fixture::new(scenes::cornell_bench(RAYS)))
}

fn one_thread() -> &'static rayon::ThreadPool {
    static P: OnceLock<rayon::ThreadPool> = OnceLock::new();
    P.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a pool")
    })
}

/// Closest hits along all rays; returns the number of hits.
fn trace(accel: &Accel, g: &Geometry, rays: &[Ray], parallel: bool) -> usize {
    let chunk = |rays: &[Ray]| {
        let mut st = RayStats::default();
        rays.iter()
            .filter(|r| accel.intersect(g, r, &mut st).is_some())
            .count()
    };
    if parallel {
        rays.par_chunks(512).map(chunk).sum()
    } else {
        chunk(rays)
    }
}

fn traverse(b: Bencher, f: &Fixture, k: &str, coherent: bool, parallel: bool) {
    let rays = if coherent {
        &f.bench.coherent
    } else {
        &f.bench.incoherent
    };
    let accel = f.accel(k);
    let g = &f.bench.geometry;
    b.counter(ItemsCount::new(rays.len())).bench(|| {
        if parallel {
            trace(accel, g, black_box(rays), true)
        } else {
            one_thread().install(|| trace(accel, g, black_box(rays), false))
        }
    });
}

fn build(b: Bencher, g: &Geometry, k: &str, parallel: bool) {
    b.counter(ItemsCount::new(g.bounded_count() as usize))
        .bench(|| {
            if parallel {
                Accel::build(kind(k), black_box(g))
            } else {
                one_thread().install(|| Accel::build(kind(k), black_box(g)))
            }
        });
}

/// Build time (items: primitives), one thread and all threads.
mod build {
    use super::*;

    #[divan::bench(args = KINDS, sample_count = 3, sample_size = 1)]
    fn mesh_1t(b: Bencher, k: &str) {
        build(b, &mesh().bench.geometry, k, false);
    }

    #[divan::bench(args = KINDS, sample_count = 3, sample_size = 1)]
    fn mesh_all(b: Bencher, k: &str) {
        build(b, &mesh().bench.geometry, k, true);
    }

    #[divan::bench(args = KINDS, sample_count = 5, sample_size = 1)]
    fn spheres_1t(b: Bencher, k: &str) {
        build(b, &spheres().bench.geometry, k, false);
    }

    #[divan::bench(args = KINDS, sample_count = 5, sample_size = 1)]
    fn spheres_all(b: Bencher, k: &str) {
        build(b, &spheres().bench.geometry, k, true);
    }

    #[divan::bench(args = KINDS, sample_count = 20, sample_size = 10)]
    fn cornell_1t(b: Bencher, k: &str) {
        build(b, &cornell().bench.geometry, k, false);
    }
}

/// Generates the traversal benchmarks of one scene: coherent / incoherent rays on one
/// thread / all threads (items: rays).
macro_rules! traversal {
    ($scene:ident, $samples:expr) => {
        mod $scene {
            use super::*;

            #[divan::bench(args = KINDS, sample_count = $samples, sample_size = 1)]
            fn coherent_1t(b: Bencher, k: &str) {
                traverse(b, super::$scene(), k, true, false);
            }

            #[divan::bench(args = KINDS, sample_count = $samples, sample_size = 1)]
            fn coherent_all(b: Bencher, k: &str) {
                traverse(b, super::$scene(), k, true, true);
            }

            #[divan::bench(args = KINDS, sample_count = $samples, sample_size = 1)]
            fn incoherent_1t(b: Bencher, k: &str) {
                traverse(b, super::$scene(), k, false, false);
            }

            #[divan::bench(args = KINDS, sample_count = $samples, sample_size = 1)]
            fn incoherent_all(b: Bencher, k: &str) {
                traverse(b, super::$scene(), k, false, true);
            }
        }
    };
}

traversal!(mesh, 3);
traversal!(spheres, 5);
traversal!(cornell, 10);

/// The BVH against the linear list on a bumpy sphere of 99,372 triangles (random rays from
/// inside; items: rays, so the ratio of the two throughputs is the speed-up per ray).
mod versus_list {
    use super::*;

    struct Small {
        g: Geometry,
        rays: Vec<Ray>,
        list: Accel,
        bvh: Accel,
    }

    fn small() -> &'static Small {
        static F: OnceLock<Small> = OnceLock::new();
        F.get_or_init(|| {
            let g = scenes::bumpy_sphere_geometry(91);
            let rays = scenes::random_rays(candela_render::math::Point3::ORIGIN, 0.6, 256);
            let list = Accel::build(AccelKind::None, &g);
            let bvh = Accel::build(AccelKind::Bvh, &g);
            Small { g, rays, list, bvh }
        })
    }

    #[divan::bench(sample_count = 3, sample_size = 1)]
    fn list_100k(b: Bencher) {
        let s = small();
        b.counter(ItemsCount::new(s.rays.len()))
            .bench(|| trace(&s.list, &s.g, black_box(&s.rays), false));
    }

    #[divan::bench(sample_count = 10, sample_size = 10)]
    fn bvh_100k(b: Bencher) {
        let s = small();
        b.counter(ItemsCount::new(s.rays.len()))
            .bench(|| trace(&s.bvh, &s.g, black_box(&s.rays), false));
    }
}
