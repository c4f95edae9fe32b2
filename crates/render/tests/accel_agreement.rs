//! Every acceleration structure returns exactly the closest hit of the linear list: the same
//! primitive, t, normal and uv, bit for bit (property test over random scenes and rays).

mod support;

use support::scenes;

use candela_render::accel::AccelKind;
use candela_render::math::{Ray, Vec3};
use candela_render::sampling::Pcg32;
use candela_render::stats::RayStats;
use proptest::prelude::*;

const STRUCTURES: &[AccelKind] = &[
    AccelKind::Bvh,
    AccelKind::KdTree,
    AccelKind::Grid,
    AccelKind::Octree,
];

fn agree(seed: u64, n: usize, rays: usize) {
    let reference = scenes::random_scene(seed, n, AccelKind::None);
    let mut st = RayStats::default();
    for &kind in STRUCTURES {
        let scene = scenes::random_scene(seed, n, kind);
        let mut rng = Pcg32::new(seed, 99);
        for i in 0..rays {
            let o = scenes::point(&mut rng, 14.0);
            // Half the rays are aimed at the centre of the scene, half are random.
            let d = if i % 2 == 0 {
                -o.to_vec() + scenes::point(&mut rng, 3.0).to_vec()
            } else {
                scenes::direction(&mut rng)
            };
            let mut ray = Ray::new(o, d);
            if i % 5 == 0 {
                ray.tmax = 5.0 + rng.next_f32() * 10.0;
            }
            let a = reference.intersect(&ray, &mut st);
            let b = scene.intersect(&ray, &mut st);
            assert_eq!(a, b, "{kind:?}, seed {seed}, ray {i}: {ray:?}");
            if let (Some(a), Some(b)) = (a, b) {
                let (sa, sb) = (
                    reference.geometry.interaction(&ray, &a),
                    scene.geometry.interaction(&ray, &b),
                );
                assert_eq!(sa, sb);
            }
            assert_eq!(
                reference.occluded(&ray, &mut st),
                scene.occluded(&ray, &mut st),
                "{kind:?}, seed {seed}, ray {i}"
            );
        }
    }
}

#[test]
fn structures_agree_on_a_scene_with_duplicates() {
    agree(1, 400, 4000);
    // Rays along the axes, through the duplicated sphere.
    let reference = scenes::random_scene(2, 50, AccelKind::None);
    let mut st = RayStats::default();
    for &kind in STRUCTURES {
        let scene = scenes::random_scene(2, 50, kind);
        for d in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X] {
            let r = Ray::new(
                candela_render::math::Point3::new(0.5, 0.5, 0.5) - d * 20.0,
                d,
            );
            let a = reference.intersect(&r, &mut st);
            assert_eq!(a, scene.intersect(&r, &mut st), "{kind:?}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    #[test]
    fn structures_agree_on_random_scenes(seed in any::<u64>(), n in 1usize..300) {
        agree(seed, n, 300);
    }
}

/// Two copies of a triangulated lattice (shared edges and vertices, exact duplicates) plus a
/// tilted copy, hit by rays through lattice points, edges and vertices.
fn lattice_scene(kind: AccelKind) -> candela_render::Scene {
    use candela_render::material::Material;
    use candela_render::math::Point3;
    use candela_render::shape::Mesh;
    use candela_render::texture::Texture;
    let mut b = candela_render::SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(
        candela_render::Rgb::WHITE,
    )));
    for layer in 0..3 {
        let mut mesh = Mesh::default();
        mesh.props.material = m;
        let n = 8u32;
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f32 - 4.0, j as f32 - 4.0);
                mesh.positions.push(if layer < 2 {
                    Point3::new(x, y, 0.0)
                } else {
                    Point3::new(x, y, 0.25 * x)
                });
            }
        }
        for j in 0..n {
            for i in 0..n {
                let k = j * (n + 1) + i;
                mesh.indices.push([k, k + 1, k + n + 2]);
                mesh.indices.push([k, k + n + 2, k + n + 1]);
            }
        }
        b.add_mesh(mesh);
    }
    b.build(kind)
}

#[test]
fn structures_agree_on_shared_edges_and_vertices() {
    use candela_render::math::Point3;
    let reference = lattice_scene(AccelKind::None);
    let mut st = RayStats::default();
    for &kind in STRUCTURES {
        let scene = lattice_scene(kind);
        for i in -10..=10 {
            for j in -10..=10 {
                let (x, y) = (i as f32 * 0.5, j as f32 * 0.5);
                for (o, d) in [
                    (Point3::new(x, y, 5.0), -Vec3::Z),
                    (Point3::new(x, y, -5.0), Vec3::Z),
                    (Point3::new(x, y, 5.0), Vec3::new(1.0, 1.0, -4.0)),
                    (Point3::new(x - 6.0, y, 0.0), Vec3::X),
                    (Point3::new(x, y - 6.0, 0.0), Vec3::Y),
                    (Point3::new(x, y, 0.0), Vec3::new(1.0, 0.0, 0.0)),
                    (Point3::new(x, y, 3.0), Vec3::new(0.5, -0.25, -1.0)),
                ] {
                    let r = Ray::new(o, d);
                    let a = reference.intersect(&r, &mut st);
                    assert_eq!(a, scene.intersect(&r, &mut st), "{kind:?} {r:?}");
                    if let Some(a) = a {
                        assert_eq!(
                            reference.geometry.interaction(&r, &a),
                            scene.geometry.interaction(&r, &a)
                        );
                    }
                    assert_eq!(
                        reference.occluded(&r, &mut st),
                        scene.occluded(&r, &mut st),
                        "{kind:?} {r:?}"
                    );
                }
            }
        }
    }
}

/// Axis-aligned boxes and parallelograms on a half-integer lattice, spheres, and rays from
/// lattice points (along and nearly along the axes, through lattice points, random), each
/// followed by two bounces spawned off the surface hit.
#[test]
fn structures_agree_on_axis_aligned_scenes_and_secondary_rays() {
    use candela_render::material::Material;
    use candela_render::math::{Point3, Transform};
    use candela_render::shape::{Cube, Parallelogram, Shape, Sphere};
    use candela_render::texture::Texture;
    let seeds: u64 = std::env::var("ACCEL_AGREEMENT_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(24);
    for seed in 0..seeds {
        let build = |kind: AccelKind| {
            let mut rng = Pcg32::new(seed, 5);
            let mut b = candela_render::SceneBuilder::new();
            let m = b.add_material(Material::diffuse(Texture::Uniform(
                candela_render::Rgb::WHITE,
            )));
            let cnt = 5 + (seed % 60) as usize;
            for i in 0..cnt {
                let q = |r: &mut Pcg32| (r.next_f32() * 8.0).floor() - 4.0;
                let c = Vec3::new(q(&mut rng), q(&mut rng), q(&mut rng));
                let s = Vec3::new(
                    1.0 + (rng.next_f32() * 3.0).floor(),
                    1.0 + (rng.next_f32() * 3.0).floor(),
                    1.0 + (rng.next_f32() * 3.0).floor(),
                ) * 0.5;
                match i % 4 {
                    0 => {
                        b.add_shape(
                            Shape::Cube(Cube::new(
                                Transform::translation(c) * Transform::scaling(s),
                            )),
                            m,
                            None,
                        );
                    }
                    1 => {
                        b.add_shape(
                            Shape::Parallelogram(
                                Parallelogram::new(
                                    c.to_point(),
                                    Vec3::new(s.x * 2.0, 0.0, 0.0),
                                    Vec3::new(0.0, s.y * 2.0, 0.0),
                                )
                                .unwrap(),
                            ),
                            m,
                            None,
                        );
                    }
                    2 => {
                        b.add_shape(
                            Shape::Parallelogram(
                                Parallelogram::new(
                                    c.to_point(),
                                    Vec3::new(0.0, 0.0, s.z * 2.0),
                                    Vec3::new(0.0, s.y * 2.0, 0.0),
                                )
                                .unwrap(),
                            ),
                            m,
                            None,
                        );
                    }
                    _ => {
                        b.add_shape(
                            Shape::Sphere(Sphere::new(
                                Transform::translation(c)
                                    * Transform::scaling(Vec3::new(s.x, s.x, s.x)),
                            )),
                            m,
                            None,
                        );
                    }
                }
            }
            b.build(kind)
        };
        let reference = build(AccelKind::None);
        let mut st = RayStats::default();
        for &kind in STRUCTURES {
            let scene = build(kind);
            let mut rng = Pcg32::new(seed, 77);
            for i in 0..1000 {
                let q = |r: &mut Pcg32| ((r.next_f32() * 24.0).floor() - 12.0) * 0.5;
                let o = if i % 2 == 0 {
                    Point3::new(q(&mut rng), q(&mut rng), q(&mut rng))
                } else {
                    scenes::point(&mut rng, 9.0)
                };
                let d = match i % 3 {
                    0 => scenes::direction(&mut rng),
                    1 => {
                        let t = Point3::new(q(&mut rng), q(&mut rng), q(&mut rng));
                        t - o
                    }
                    _ => {
                        [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z]
                            [(rng.next_u32() % 6) as usize]
                            + Vec3::new(0.0, 0.0, 1e-4 * (rng.next_f32() - 0.5))
                    }
                };
                let mut ray = Ray::new(o, d);
                for _bounce in 0..3 {
                    let a = reference.intersect(&ray, &mut st);
                    let b2 = scene.intersect(&ray, &mut st);
                    assert_eq!(a, b2, "{kind:?} seed {seed} ray {i} {ray:?}");
                    assert_eq!(
                        reference.occluded(&ray, &mut st),
                        scene.occluded(&ray, &mut st),
                        "{kind:?} seed {seed} ray {i} {ray:?}"
                    );
                    let Some(h) = a else { break };
                    let si = reference.geometry.interaction(&ray, &h);
                    ray = si.spawn_ray(scenes::direction(&mut rng));
                }
            }
        }
    }
}
