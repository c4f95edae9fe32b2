//! Instanced scenes render what the same shapes placed one by one render: bit for bit when
//! the placements are identities (the two-level traversal then reproduces every hit exactly),
//! and within round-off of the transformed geometry otherwise (rays are brought into each
//! instance's space instead of the triangles into the world, so hits differ in the last bits
//! and a few paths diverge); and the same bytes at any thread count.

use candela_render::accel::AccelKind;
use candela_render::camera::Camera;
use candela_render::integrator::Path;
use candela_render::light::Emission;
use candela_render::material::Material;
use candela_render::math::{Normal3, Point2, Point3, Transform, Vec3};
use candela_render::render::{render, RenderOutput, RenderSettings};
use candela_render::shape::{Mesh, Parallelogram, Shape, Sphere};
use candela_render::texture::Texture;
use candela_render::{Rgb, Scene, SceneBuilder};

/// A UV sphere of radius 1 with `n` × 2`n` quads, vertex normals and uv.
fn uv_sphere(n: usize) -> Mesh {
    let mut m = Mesh::default();
    for i in 0..=n {
        for j in 0..=2 * n {
            let (v, u) = (i as f32 / n as f32, j as f32 / (2 * n) as f32);
            let (th, ph) = (v * std::f32::consts::PI, u * std::f32::consts::TAU);
            let p = Point3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            m.positions.push(p);
            m.normals.push(Normal3::new(p.x, p.y, p.z));
            m.uvs.push(Point2::new(u, v));
        }
    }
    let w = 2 * n as u32 + 1;
    for i in 0..n as u32 {
        for j in 0..2 * n as u32 {
            let (a, b, c, d) = (
                i * w + j,
                (i + 1) * w + j,
                (i + 1) * w + j + 1,
                i * w + j + 1,
            );
            m.indices.push([a, b, c]);
            m.indices.push([a, c, d]);
        }
    }
    m
}

/// Ground, an area light, and the group (a glossy-free red sphere mesh with a small white
/// ball above it) at each of `placements`, instanced or copied.
fn scene(placements: &[Transform], instanced: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let white = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.7))));
    let red = b.add_material(Material::diffuse(Texture::Uniform(Rgb::new(0.8, 0.2, 0.1))));
    let e = b.add_emission(Emission {
        radiance: Texture::Uniform(Rgb::splat(6.0)),
        two_sided: true,
    });
    b.add_shape(
        Shape::Parallelogram(
            Parallelogram::new(
                Point3::new(-8.0, -8.0, -1.0),
                Vec3::new(24.0, 0.0, 0.0),
                Vec3::new(0.0, 16.0, 0.0),
            )
            .unwrap(),
        ),
        white,
        None,
    );
    b.add_shape(
        Shape::Parallelogram(
            Parallelogram::new(
                Point3::new(-1.5, -1.5, 5.0),
                Vec3::new(3.0, 0.0, 0.0),
                Vec3::new(0.0, 3.0, 0.0),
            )
            .unwrap(),
        ),
        white,
        Some(e),
    );
    let mut mesh = uv_sphere(12);
    mesh.props.material = red;
    let ball = Transform::translation(Vec3::new(0.0, 0.0, 1.3))
        * Transform::scaling(Vec3::new(0.3, 0.3, 0.3));
    if instanced {
        let g = b
            .add_group(vec![(Shape::Sphere(Sphere::new(ball)), white)], vec![mesh])
            .unwrap();
        for t in placements {
            b.add_instance(g, *t);
        }
    } else {
        for t in placements {
            b.add_shape(Shape::Sphere(Sphere::new(*t * ball)), white, None);
        }
        for t in placements {
            // (`transformed` renormalises the vertex normals even for the identity.)
            b.add_mesh(if t.is_identity() {
                mesh.clone()
            } else {
                mesh.transformed(t)
            });
        }
    }
    b.camera(Camera::perspective(
        1.5,
        4.0 / 3.0,
        Transform::translation(Vec3::new(-6.0, 0.0, 1.0)) * Transform::rotation_y(12.0),
    ));
    b.build(AccelKind::Bvh)
}

fn image(s: &Scene, spp: u32) -> RenderOutput {
    let settings = RenderSettings {
        width: 48,
        height: 36,
        spp,
        seed: 3,
        ..Default::default()
    };
    render(s, &Path::default(), &settings, &|_| {})
}

fn placements() -> Vec<Transform> {
    (0..6)
        .map(|i| {
            let (x, y) = (-1.5 + (i / 3) as f32 * 2.5, -2.5 + (i % 3) as f32 * 2.5);
            Transform::translation(Vec3::new(x, y, 0.0))
                * Transform::rotation(Vec3::new(1.0, 2.0, 3.0), 25.0 * i as f32).unwrap()
                * Transform::scaling(Vec3::new(1.0, 0.6 + 0.1 * i as f32, 0.8))
        })
        .collect()
}

#[test]
fn identity_instances_render_the_same_bits_as_copies() {
    let id = [Transform::IDENTITY; 1];
    let a = image(&scene(&id, true), 8);
    let b = image(&scene(&id, false), 8);
    assert!(a.image.mean()[0] > 0.05, "{:?}", a.image.mean());
    assert_eq!(a.image, b.image);
}

#[test]
fn transformed_instances_render_what_transformed_copies_render() {
    let p = placements();
    let a = image(&scene(&p, true), 32).image;
    let b = image(&scene(&p, false), 32).image;
    let (ma, mb) = (a.mean(), b.mean());
    for c in 0..3 {
        assert!(
            (ma[c] - mb[c]).abs() <= 2e-3 * mb[c],
            "channel {c}: {} vs {}",
            ma[c],
            mb[c]
        );
    }
    // 6×6-pixel blocks: equal up to the few paths that diverge.
    let (w, h) = (a.width(), a.height());
    for by in 0..h / 6 {
        for bx in 0..w / 6 {
            let block = |img: &candela_render::Image| {
                let mut s = 0.0;
                for y in by * 6..by * 6 + 6 {
                    for x in bx * 6..bx * 6 + 6 {
                        let p = img.get(x, y);
                        s += (p.r + p.g + p.b) as f64;
                    }
                }
                s / 108.0
            };
            let (x, y) = (block(&a), block(&b));
            assert!(
                (x - y).abs() <= 0.02 * y + 2e-3,
                "block ({bx}, {by}): {x} vs {y}"
            );
        }
    }
}

#[test]
fn an_instanced_scene_gives_the_same_bytes_at_any_thread_count() {
    let s = scene(&placements(), true);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| image(&s, 4))
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.image, b.image);
    assert_eq!(a.stats, b.stats);
}
