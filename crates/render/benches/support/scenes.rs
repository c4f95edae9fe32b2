//! The scenes and ray sets of the accelerator benchmarks (`benches/accel.rs`) and of
//! `examples/accel_compare.rs`, made in code: a bumpy subdivided sphere (about a million
//! triangles at the default size), random spheres, and the Cornell box; coherent camera rays
//! and incoherent random rays.
#![allow(dead_code)]

use candela_render::geometry::{Geometry, Object};
use candela_render::interaction::SurfaceProps;
use candela_render::math::{Point3, Ray, Transform, Vec3};
use candela_render::sampling::Pcg32;
use candela_render::shape::{Cube, Mesh, Parallelogram, Shape, Sphere};

/// A cube subdivided into `n`×`n` quads per face (12·n² triangles), pushed onto a sphere of
/// radius 1 with bumps of a few percent at several frequencies. `n = 289` gives 1,002,252
/// triangles.
pub fn bumpy_sphere(n: u32) -> Mesh {
    let mut positions = Vec::with_capacity(6 * (n as usize + 1).pow(2));
    let mut indices = Vec::with_capacity(12 * (n as usize).pow(2));
    let bump = |d: Vec3| {
        1.0 + 0.04 * (7.0 * d.x).sin() * (9.0 * d.y).sin() * (8.0 * d.z).sin()
            + 0.01 * (41.0 * d.x + 3.0).sin() * (37.0 * d.y).sin() * (43.0 * d.z + 1.0).sin()
    };
    // Each face: a point of the cube [-1, 1]³ from the face's axes.
    let faces: [(Vec3, Vec3, Vec3); 6] = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (-Vec3::Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, Vec3::Y, Vec3::X),
    ];
    for (normal, u, v) in faces {
        let base = positions.len() as u32;
        for j in 0..=n {
            for i in 0..=n {
                let s = i as f32 / n as f32 * 2.0 - 1.0;
                let t = j as f32 / n as f32 * 2.0 - 1.0;
                // Equal-angle mapping keeps the triangles of similar size.
                let (s, t) = (
                    (s * std::f32::consts::FRAC_PI_4).tan(),
                    (t * std::f32::consts::FRAC_PI_4).tan(),
                );
                let d = (normal + u * s + v * t).normalize();
                positions.push((d * bump(d)).to_point());
            }
        }
        for j in 0..n {
            for i in 0..n {
                let k = base + j * (n + 1) + i;
                indices.push([k, k + 1, k + n + 2]);
                indices.push([k, k + n + 2, k + n + 1]);
            }
        }
    }
    Mesh {
        positions,
        indices,
        ..Mesh::default()
    }
}

/// The geometry of one bumpy sphere.
pub fn bumpy_sphere_geometry(n: u32) -> Geometry {
    Geometry::new(Vec::new(), vec![bumpy_sphere(n)])
}

/// `n` random spheres (radii 0.05 to 0.25) in the cube [-10, 10]³.
pub fn random_spheres(n: usize) -> Geometry {
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

/// The Cornell box of `examples/cornell-box.scene`: five walls, the light and two boxes.
pub fn cornell_box() -> Geometry {
    let obj = |shape| Object {
        shape,
        props: SurfaceProps::new(0),
    };
    let pg = |p: [f32; 3], v: [f32; 3], w: [f32; 3]| {
        obj(Shape::Parallelogram(
            Parallelogram::new(
                Point3::new(p[0], p[1], p[2]),
                Vec3::new(v[0], v[1], v[2]),
                Vec3::new(w[0], w[1], w[2]),
            )
            .unwrap(),
        ))
    };
    let cube = |m: [f32; 12]| {
        let mut a = [[0.0; 4]; 4];
        for r in 0..3 {
            a[r].copy_from_slice(&m[4 * r..4 * r + 4]);
        }
        a[3][3] = 1.0;
        obj(Shape::Cube(Cube::new(
            Transform::from_matrix(candela_render::math::Matrix4 { m: a }).unwrap(),
        )))
    };
    let objects = vec![
        pg([-1.0, -1.0, -1.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        pg([-1.0, -1.0, 1.0], [2.0, 0.0, 0.0], [0.0, 0.0, -2.0]),
        pg([-1.0, 1.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
        pg([-1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
        pg([1.0, -1.0, -1.0], [0.0, 0.0, 2.0], [0.0, 2.0, 0.0]),
        pg([-0.23, 0.99, -0.18], [0.46, 0.0, 0.0], [0.0, 0.0, 0.38]),
        cube([
            0.286_891_46,
            0.0,
            -0.087_711_51,
            0.335,
            0.0,
            0.3,
            0.0,
            -0.7,
            0.087_711_51,
            0.0,
            0.286_891_46,
            0.38,
        ]),
        cube([
            0.284_909_75,
            0.0,
            0.093_949_14,
            -0.33,
            0.0,
            0.61,
            0.0,
            -0.4,
            -0.093_949_14,
            0.0,
            0.284_909_75,
            -0.28,
        ]),
    ];
    Geometry::new(objects, Vec::new())
}

/// `n` pinhole-camera rays (a square image) from `eye` towards `target`, with `fov_tan` the
/// tangent of the half field of view.
pub fn camera_rays(eye: Point3, target: Point3, fov_tan: f32, n: usize) -> Vec<Ray> {
    let side = (n as f32).sqrt().ceil() as usize;
    let w = (target - eye).normalize();
    let up = if w.cross(Vec3::Z).norm() > 1e-3 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let u = w.cross(up).normalize();
    let v = u.cross(w);
    let mut rays = Vec::with_capacity(n);
    'outer: for j in 0..side {
        for i in 0..side {
            if rays.len() == n {
                break 'outer;
            }
            let x = ((i as f32 + 0.5) / side as f32 * 2.0 - 1.0) * fov_tan;
            let y = ((j as f32 + 0.5) / side as f32 * 2.0 - 1.0) * fov_tan;
            rays.push(Ray::new(eye, (w + u * x + v * y).normalize()));
        }
    }
    rays
}

/// `n` rays from uniform points of the box `c ± s` in uniform directions.
pub fn random_rays(c: Point3, s: f32, n: usize) -> Vec<Ray> {
    let mut rng = Pcg32::new(11, 2);
    (0..n)
        .map(|_| {
            let o = c + Vec3::new(
                rng.next_f32() * 2.0 - 1.0,
                rng.next_f32() * 2.0 - 1.0,
                rng.next_f32() * 2.0 - 1.0,
            ) * s;
            let d = candela_render::sampling::warp::square_to_uniform_sphere([
                rng.next_f32(),
                rng.next_f32(),
            ]);
            Ray::new(o, d)
        })
        .collect()
}

/// A benchmark scene with its two ray sets.
pub struct Bench {
    /// Its name.
    pub name: &'static str,
    /// The geometry.
    pub geometry: Geometry,
    /// Camera rays.
    pub coherent: Vec<Ray>,
    /// Random rays.
    pub incoherent: Vec<Ray>,
}

/// The bumpy sphere (`n` as in [`bumpy_sphere`]) seen from outside, filling most of the
/// image, and random rays from inside it (all hit).
pub fn mesh_bench(n: u32, rays: usize) -> Bench {
    Bench {
        name: "mesh",
        geometry: bumpy_sphere_geometry(n),
        coherent: camera_rays(Point3::new(2.4, -2.0, 1.4), Point3::ORIGIN, 0.3, rays),
        incoherent: random_rays(Point3::ORIGIN, 0.6, rays),
    }
}

/// `n` random spheres seen from outside, and random rays through them.
pub fn spheres_bench(n: usize, rays: usize) -> Bench {
    Bench {
        name: "spheres",
        geometry: random_spheres(n),
        coherent: camera_rays(Point3::new(30.0, -25.0, 18.0), Point3::ORIGIN, 0.45, rays),
        incoherent: random_rays(Point3::ORIGIN, 10.0, rays),
    }
}

/// The Cornell box from its camera, and random rays from inside it.
pub fn cornell_bench(rays: usize) -> Bench {
    Bench {
        name: "cornell",
        geometry: cornell_box(),
        coherent: camera_rays(Point3::new(0.0, 0.0, 3.9), Point3::ORIGIN, 0.357, rays),
        incoherent: random_rays(Point3::ORIGIN, 0.95, rays),
    }
}
