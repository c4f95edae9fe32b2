//! Rays leaving a surface never re-hit it by round-off, and closed meshes do not leak.

mod support;

use support::scenes;

use candela_render::accel::AccelKind;
use candela_render::material::Material;
use candela_render::math::{Normal3, Point3, Ray, Transform, Vec3};
use candela_render::sampling::Pcg32;
use candela_render::shape::{Cube, Disk, Mesh, Parallelogram, Plane, Polyhedron, Shape, Sphere};
use candela_render::stats::RayStats;
use candela_render::texture::Texture;
use candela_render::{Rgb, SceneBuilder};

/// Each shape with the smallest radius of curvature of its curved parts (0 for flat faces).
fn shapes() -> Vec<(&'static str, Shape, f32)> {
    let t = Transform::translation(Vec3::new(3.0, -20.0, 7.0))
        * Transform::rotation_x(33.0)
        * Transform::rotation_z(17.0);
    let tet = [
        (Vec3::new(-1.0, 0.0, 0.0), 0.0),
        (Vec3::new(0.0, -1.0, 0.0), 0.0),
        (Vec3::new(0.0, 0.0, -1.0), 0.0),
        (Vec3::new(1.0, 1.0, 1.0), 2.0),
    ];
    vec![
        (
            "sphere",
            Shape::Sphere(Sphere::new(
                t * Transform::scaling(Vec3::new(2.0, 0.5, 1.0)),
            )),
            0.125,
        ),
        (
            "small sphere",
            Shape::Sphere(Sphere::new(Transform::scaling(Vec3::new(0.01, 0.01, 0.01)))),
            0.01,
        ),
        (
            "big sphere",
            Shape::Sphere(Sphere::new(
                t * Transform::scaling(Vec3::new(300.0, 300.0, 300.0)),
            )),
            300.0,
        ),
        (
            "cube",
            Shape::Cube(Cube::new(t * Transform::scaling(Vec3::new(1.0, 3.0, 0.2)))),
            0.0,
        ),
        (
            "polyhedron",
            Shape::Polyhedron(Polyhedron::new(t, &tet).unwrap()),
            0.0,
        ),
        (
            "parallelogram",
            Shape::Parallelogram(
                Parallelogram::new(
                    Point3::new(100.0, 3.0, -2.0),
                    Vec3::new(3.0, 1.0, 0.0),
                    Vec3::new(0.0, 1.0, 5.0),
                )
                .unwrap(),
            ),
            0.0,
        ),
        ("disk", Shape::Disk(Disk::new(t)), 0.0),
        ("plane", Shape::Plane(Plane::new(t)), 0.0),
    ]
}

/// Random points on each shape (found by rays shot at it), then random rays leaving each point
/// on the side they point to: a ray leaving a convex solid or a flat surface outward never hits
/// it again; one going into a solid hits another face, or (curved surfaces) the far side at
/// least a fraction of the chord 2·r·cos θ away.
#[test]
fn spawned_rays_never_rehit_their_surface() {
    let mut rng = Pcg32::new(3, 4);
    let mut st = RayStats::default();
    for (name, shape, curvature_radius) in shapes() {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
        let centre = shape
            .bounds()
            .map(|b| b.centroid())
            .unwrap_or(Point3::new(3.0, -20.0, 7.0));
        let radius = shape.bounds().map(|b| b.diagonal().norm()).unwrap_or(10.0);
        b.add_shape(shape, m, None);
        let scene = b.build(AccelKind::Bvh);
        let mut points = 0;
        while points < 2000 {
            let o = centre + scenes::direction(&mut rng) * (radius * 2.0);
            let target = centre + scenes::point(&mut rng, radius * 0.3).to_vec();
            let first_ray = Ray::new(o, target - o);
            let Some(first) = scene.intersect(&first_ray, &mut st) else {
                continue;
            };
            let si = scene.geometry.interaction(&first_ray, &first);
            points += 1;
            for _ in 0..4 {
                let d = scenes::direction(&mut rng);
                let outward = si.n.dot_vec(d) > 0.0;
                let r = si.spawn_ray(d);
                match scene.intersect(&r, &mut st) {
                    None => {}
                    Some(h) => {
                        let flat = matches!(name, "parallelogram" | "disk" | "plane");
                        assert!(
                            !outward && !flat,
                            "{name}: a ray leaving {:?} along {d:?} re-hit at t = {}",
                            si.p,
                            h.t
                        );
                        let cos = si.n.dot_vec(d).abs();
                        let same_face = h.sub == first.sub;
                        assert!(
                            !same_face
                                || (curvature_radius > 0.0 && h.t > 0.1 * curvature_radius * cos),
                            "{name}: an inward ray from {:?} along {d:?} re-hit its face at t = {}",
                            si.p,
                            h.t
                        );
                    }
                }
            }
        }
    }
}

/// A closed icosphere-like mesh: no ray from inside escapes through shared edges or vertices.
#[test]
fn closed_meshes_are_watertight() {
    let mesh = octasphere(4);
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
    let mut mesh = mesh;
    mesh.props.material = m;
    let vertices = mesh.positions.clone();
    b.add_mesh(mesh);
    let scene = b.build(AccelKind::Bvh);
    let mut rng = Pcg32::new(8, 9);
    let mut st = RayStats::default();
    for i in 0..100_000 {
        let o = scenes::point(&mut rng, 0.3);
        // Aim some rays exactly at vertices and edge midpoints, where leaks happen.
        let d = match i % 3 {
            0 => vertices[rng.next_bounded(vertices.len() as u32) as usize] - o,
            1 => {
                let a = vertices[rng.next_bounded(vertices.len() as u32) as usize];
                let b = vertices[rng.next_bounded(vertices.len() as u32) as usize];
                a.lerp(b, 0.5) - o
            }
            _ => scenes::direction(&mut rng),
        };
        assert!(
            scene.intersect(&Ray::new(o, d), &mut st).is_some(),
            "ray {i} from {o:?} along {d:?} escaped"
        );
    }
}

/// An octahedron subdivided `levels` times and pushed onto the unit sphere, outward wound.
fn octasphere(levels: u32) -> Mesh {
    let mut positions = vec![
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(-1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(0.0, -1.0, 0.0),
        Point3::new(0.0, 0.0, 1.0),
        Point3::new(0.0, 0.0, -1.0),
    ];
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut mid = std::collections::HashMap::new();
    for _ in 0..levels {
        let mut next = Vec::new();
        for [a, b, c] in tris {
            let mut m = |x: u32, y: u32| {
                *mid.entry((x.min(y), x.max(y))).or_insert_with(|| {
                    let p = positions[x as usize].lerp(positions[y as usize], 0.5);
                    positions.push((p.to_vec().normalize()).to_point());
                    positions.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        tris = next;
    }
    let _ = Normal3::default();
    Mesh {
        positions,
        indices: tris,
        ..Default::default()
    }
}
