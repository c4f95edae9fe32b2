//! Random scenes shared by the integration tests of the render core.
#![allow(dead_code)]

use candela_render::accel::AccelKind;
use candela_render::material::Material;
use candela_render::math::{Point3, Transform, Vec3};
use candela_render::sampling::Pcg32;
use candela_render::shape::{Cube, Mesh, Parallelogram, Shape, Sphere};
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene, SceneBuilder};

/// A uniform point in the cube [-s, s]³.
pub fn point(rng: &mut Pcg32, s: f32) -> Point3 {
    Point3::new(
        (rng.next_f32() * 2.0 - 1.0) * s,
        (rng.next_f32() * 2.0 - 1.0) * s,
        (rng.next_f32() * 2.0 - 1.0) * s,
    )
}

/// A uniform random direction.
pub fn direction(rng: &mut Pcg32) -> Vec3 {
    candela_render::sampling::warp::square_to_uniform_sphere([rng.next_f32(), rng.next_f32()])
}

/// A scene of `n` random spheres, boxes, parallelograms and triangles (some touching or
/// overlapping, some sharing exact positions) built with `accel`.
pub fn random_scene(seed: u64, n: usize, accel: AccelKind) -> Scene {
    let mut rng = Pcg32::new(seed, 17);
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
    let mut mesh = Mesh::default();
    mesh.props.material = m;
    for i in 0..n {
        let c = point(&mut rng, 10.0);
        let s = 0.1 + rng.next_f32() * 1.5;
        let place = Transform::translation(c.to_vec())
            * Transform::rotation_z(rng.next_f32() * 360.0)
            * Transform::rotation_x(rng.next_f32() * 360.0)
            * Transform::scaling(Vec3::new(s, s * (0.5 + rng.next_f32()), s));
        match i % 4 {
            0 => {
                b.add_shape(Shape::Sphere(Sphere::new(place)), m, None);
            }
            1 => {
                b.add_shape(Shape::Cube(Cube::new(place)), m, None);
            }
            2 => {
                let v = direction(&mut rng) * s;
                let w = direction(&mut rng) * s;
                if let Some(p) = Parallelogram::new(c, v, w) {
                    b.add_shape(Shape::Parallelogram(p), m, None);
                }
            }
            _ => {
                let k = mesh.positions.len() as u32;
                mesh.positions.push(c);
                mesh.positions.push(c + direction(&mut rng) * s);
                mesh.positions.push(c + direction(&mut rng) * s);
                mesh.indices.push([k, k + 1, k + 2]);
                // A twin sharing an edge, so that ties and shared edges occur.
                mesh.positions.push(c + direction(&mut rng) * s);
                mesh.indices.push([k + 1, k + 2, k + 3]);
            }
        }
    }
    // Exact duplicates: the same sphere twice, so that equal t must go to the smaller id.
    let dup = Transform::translation(Vec3::new(0.5, 0.5, 0.5));
    b.add_shape(Shape::Sphere(Sphere::new(dup)), m, None);
    b.add_shape(Shape::Sphere(Sphere::new(dup)), m, None);
    b.add_mesh(mesh);
    b.build(accel)
}
