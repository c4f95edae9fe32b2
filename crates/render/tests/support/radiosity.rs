//! Scenes and image helpers shared by the radiosity tests.
#![allow(dead_code)]
// The matrices are copied verbatim from cornell.xml.
#![allow(clippy::excessive_precision)]

use candela_render::accel::AccelKind;
use candela_render::camera::Camera;
use candela_render::image::Image;
use candela_render::integrator::Integrator;
use candela_render::light::Emission;
use candela_render::material::{Material, Model};
use candela_render::math::{Matrix4, Point3, Ray, Transform, Vec3};
use candela_render::radiosity::PatchInfo;
use candela_render::render::{render, RenderSettings};
use candela_render::shape::{Cube, Parallelogram, Shape};
use candela_render::stats::RayStats;
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene, SceneBuilder};

/// The light's radiance in ../shared/bench/cornell.xml.
pub const CORNELL_LIGHT: Rgb = Rgb::new(18.387, 13.9873, 6.75357);

fn matrix(rows: [[f32; 4]; 4]) -> Transform {
    Transform::from_matrix(Matrix4::new(rows)).expect("invertible")
}

/// Mitsuba's `rectangle` ([-1,1]² of z = 0) placed by `t`, with the normal t·(+z).
fn rectangle(t: &Transform) -> Parallelogram {
    let p = t.point(Point3::new(-1.0, -1.0, 0.0));
    let (v, w) = (
        t.vector(Vec3::new(2.0, 0.0, 0.0)),
        t.vector(Vec3::new(0.0, 2.0, 0.0)),
    );
    let n = t
        .normal(candela_render::math::Normal3::new(0.0, 0.0, 1.0))
        .to_vec();
    let para = Parallelogram::new(p, v, w).expect("rectangle");
    if para.normal().to_vec().dot(n) >= 0.0 {
        para
    } else {
        Parallelogram::new(p, w, v).expect("rectangle")
    }
}

/// The Cornell box of ../shared/bench/cornell.xml (Mitsuba's rules: one-sided BSDFs and
/// emitter), with its camera (vertical field of view 39.3077°, square image).
pub fn cornell(accel: AccelKind) -> Scene {
    let mut b = SceneBuilder::new();
    let diffuse = |r: f32, g: f32, bl: f32| {
        Material::one_sided(Model::Diffuse {
            reflectance: Texture::Uniform(Rgb::new(r, g, bl)),
        })
    };
    let white = b.add_material(diffuse(0.885809, 0.698859, 0.666422));
    let green = b.add_material(diffuse(0.105421, 0.37798, 0.076425));
    let red = b.add_material(diffuse(0.570068, 0.0430135, 0.0443706));
    let light = b.add_emission(Emission {
        radiance: Texture::Uniform(CORNELL_LIGHT),
        two_sided: false,
    });
    let rect = |m: [[f32; 4]; 4]| Shape::Parallelogram(rectangle(&matrix(m)));
    b.add_shape(
        rect([
            [0.23, 0.0, 0.0, 0.0],
            [0.0, -8.30516367e-09, -0.19, 0.99],
            [0.0, 0.19, -8.30516367e-09, 0.01],
            [0.0, 0.0, 0.0, 1.0],
        ]),
        white,
        Some(light),
    );
    b.add_shape(
        rect([
            [0.99999994, 0.0, 0.0, 0.0],
            [0.0, -4.37113883e-08, 1.0, -1.0],
            [0.0, -1.0, -4.37113883e-08, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]),
        white,
        None,
    );
    b.add_shape(
        rect([
            [0.99999994, 0.0, 0.0, 0.0],
            [0.0, -4.37113883e-08, -1.0, 1.0],
            [0.0, 1.0, -4.37113883e-08, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]),
        white,
        None,
    );
    b.add_shape(
        rect([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, -1.0],
            [0.0, 0.0, 0.0, 1.0],
        ]),
        white,
        None,
    );
    b.add_shape(
        rect([
            [-4.37113883e-08, 0.0, -1.0, 1.0],
            [0.0, 0.99999994, 0.0, 0.0],
            [1.0, 0.0, -4.37113883e-08, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]),
        green,
        None,
    );
    b.add_shape(
        rect([
            [-4.37113883e-08, 0.0, 1.0, -1.0],
            [0.0, 0.99999994, 0.0, 0.0],
            [-1.0, 0.0, -4.37113883e-08, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]),
        red,
        None,
    );
    b.add_shape(
        Shape::Cube(Cube::new(matrix([
            [0.28689146, 0.0, -0.087711513, 0.335],
            [0.0, 0.3, 0.0, -0.7],
            [0.087711513, 0.0, 0.28689146, 0.38],
            [0.0, 0.0, 0.0, 1.0],
        ]))),
        white,
        None,
    );
    b.add_shape(
        Shape::Cube(Cube::new(matrix([
            [0.284909755, 0.0, 0.0939491391, -0.33],
            [0.0, 0.61, 0.0, -0.4],
            [-0.0939491391, 0.0, 0.284909755, -0.28],
            [0.0, 0.0, 0.0, 1.0],
        ]))),
        white,
        None,
    );
    // The eye at (0, 0, 3.9) looking along −z: candela's eye is `d` behind the transformation's
    // origin (the screen), so the frame moves forward by d.
    let d = candela_render::camera::distance_for_fov(39.3077);
    let eye = Transform::look_at(
        Point3::new(0.0, 0.0, 3.9),
        Point3::ORIGIN,
        Vec3::new(0.0, 1.0, 0.0),
    )
    .expect("camera");
    b.camera(Camera::perspective(
        d,
        1.0,
        eye * Transform::translation(Vec3::new(d, 0.0, 0.0)),
    ));
    b.build(accel)
}

/// The parallelogram with corner `p` and edges `v` and `w`.
pub fn para(p: [f32; 3], v: [f32; 3], w: [f32; 3]) -> Shape {
    Shape::Parallelogram(
        Parallelogram::new(
            Point3::new(p[0], p[1], p[2]),
            Vec3::new(v[0], v[1], v[2]),
            Vec3::new(w[0], w[1], w[2]),
        )
        .unwrap(),
    )
}

/// A closed box of six two-sided parallelograms [-1, 1]³ reflecting `rho`; with `radiance`,
/// every wall emits it from both sides. The camera looks along +x from inside, its origin at
/// `camera` (the eye is d = 1 behind it).
pub fn closed_box_with(rho: f32, radiance: Option<Rgb>, camera: Vec3) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(rho))));
    let e = radiance.map(|radiance| {
        b.add_emission(Emission {
            radiance: Texture::Uniform(radiance),
            two_sided: true,
        })
    });
    let walls = [
        ([-1.0, -1.0, -1.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        ([-1.0, -1.0, 1.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]),
        ([-1.0, -1.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
        ([-1.0, 1.0, -1.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
        ([-1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
        ([1.0, -1.0, -1.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]),
    ];
    for (p, v, w) in walls {
        b.add_shape(para(p, v, w), m, e);
    }
    b.camera(Camera::perspective(
        1.0,
        1.0,
        Transform::translation(camera),
    ));
    b.build(AccelKind::Bvh)
}

/// The Cornell box (BVH) with its tall box (object 7) turned into a two-sided mirror of
/// reflectance 0.9.
pub fn cornell_with_mirror() -> Scene {
    let base = cornell(AccelKind::Bvh);
    let mut b = SceneBuilder::new();
    for mat in &base.materials {
        b.add_material(mat.clone());
    }
    let mirror = b.add_material(Material::two_sided(Model::Specular {
        reflectance: Texture::Uniform(Rgb::splat(0.9)),
    }));
    let e = b.add_emission(base.emissions[0].clone());
    for (i, o) in base.geometry.objects().iter().enumerate() {
        let mat = if i == 7 { mirror } else { o.props.material };
        b.add_shape(o.shape.clone(), mat, o.props.emission.map(|_| e));
    }
    b.camera(base.camera);
    b.build(AccelKind::Bvh)
}

/// Whether a patch faces the origin (the inside of a box around it).
pub fn inward(p: &PatchInfo) -> bool {
    p.normal.dot(Point3::ORIGIN - p.centre) > 0.0
}

/// The camera ray through the centre of pixel (`x`, `y`) of a `res × res` image.
pub fn pixel_ray(scene: &Scene, res: usize, x: usize, y: usize) -> Ray {
    scene.camera.ray(
        (x as f32 + 0.5) / res as f32,
        1.0 - (y as f32 + 0.5) / res as f32,
    )
}

/// Renders `scene` at `res × res` with `spp` samples per pixel.
pub fn image(scene: &Scene, integrator: &dyn Integrator, res: usize, spp: u32) -> Image {
    let settings = RenderSettings {
        width: res,
        height: res,
        spp,
        seed: 7,
        ..Default::default()
    };
    render(scene, integrator, &settings, &|_| {}).image
}

/// Which pixels of a `res × res` image see an emitter through their centre.
pub fn emitter_mask(scene: &Scene, res: usize) -> Vec<bool> {
    let mut st = RayStats::default();
    let mut mask = Vec::with_capacity(res * res);
    for y in 0..res {
        for x in 0..res {
            let ray = pixel_ray(scene, res, x, y);
            mask.push(
                scene
                    .interact(&ray, &mut st)
                    .is_some_and(|si| si.props.emission.is_some()),
            );
        }
    }
    mask
}

/// The mean RGB of the pixels outside `mask`.
pub fn masked_mean(img: &Image, mask: &[bool]) -> [f64; 3] {
    let mut s = [0f64; 3];
    let mut n = 0usize;
    for (p, &m) in img.pixels().iter().zip(mask) {
        if !m {
            s[0] += p.r as f64;
            s[1] += p.g as f64;
            s[2] += p.b as f64;
            n += 1;
        }
    }
    s.map(|x| x / n.max(1) as f64)
}

/// Largest relative difference between two RGB means.
pub fn rel_diff(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3)
        .map(|c| (a[c] - b[c]).abs() / b[c].abs().max(1e-12))
        .fold(0.0, f64::max)
}
