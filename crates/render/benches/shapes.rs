//! Ray–shape intersection throughput, one shape type at a time (`cargo bench --bench shapes`).

use candela_render::math::{Point3, Ray, Transform, Vec3};
use candela_render::sampling::{warp, Pcg32};
use candela_render::shape::{Cube, Mesh, Parallelogram, Plane, Shape, ShearedRay, Sphere};
use divan::{black_box, Bencher};

fn main() {
    divan::main();
}

const RAYS: usize = 4096;

/// Rays from a sphere of radius 4 towards points near the origin: about half hit.
fn rays() -> Vec<Ray> {
    let mut rng = Pcg32::new(1, 2);
    (0..RAYS)
        .map(|_| {
            let o = warp::square_to_uniform_sphere([rng.next_f32(), rng.next_f32()]) * 4.0;
            let t = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            ) * 3.0;
            Ray::new(o.to_point(), t - o)
        })
        .collect()
}

fn bench_shape(b: Bencher, shape: Shape) {
    let rays = rays();
    b.counter(divan::counter::ItemsCount::new(RAYS)).bench(|| {
        let mut hits = 0u32;
        for r in &rays {
            hits += black_box(&shape).intersect(r).is_some() as u32;
        }
        hits
    });
}

#[divan::bench]
fn sphere(b: Bencher) {
    bench_shape(
        b,
        Shape::Sphere(Sphere::new(
            Transform::rotation_z(20.0) * Transform::scaling(Vec3::new(1.0, 0.7, 1.2)),
        )),
    );
}

#[divan::bench]
fn cube(b: Bencher) {
    bench_shape(b, Shape::Cube(Cube::new(Transform::rotation_z(20.0))));
}

#[divan::bench]
fn plane(b: Bencher) {
    bench_shape(b, Shape::Plane(Plane::new(Transform::rotation_x(30.0))));
}

#[divan::bench]
fn parallelogram(b: Bencher) {
    let p = Parallelogram::new(
        Point3::new(-1.0, -1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.2),
        Vec3::new(0.0, 2.0, 0.0),
    )
    .unwrap();
    bench_shape(b, Shape::Parallelogram(p));
}

#[divan::bench]
fn triangle(b: Bencher) {
    let m = Mesh {
        positions: vec![
            Point3::new(-1.0, -1.0, 0.0),
            Point3::new(1.0, -1.0, 0.1),
            Point3::new(0.0, 1.0, -0.1),
        ],
        indices: vec![[0, 1, 2]],
        ..Default::default()
    };
    let rays = rays();
    b.counter(divan::counter::ItemsCount::new(RAYS)).bench(|| {
        let mut hits = 0u32;
        for r in &rays {
            hits += black_box(&m).intersect(0, r, &ShearedRay::new(r)).is_some() as u32;
        }
        hits
    });
}
