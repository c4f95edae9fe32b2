//! Test scenes and checks shared by the acceleration structures' tests: every structure must
//! return exactly the list's hits.
use super::List;
use crate::geometry::{Geometry, Object};
use crate::interaction::{Hit, SurfaceProps};
use crate::math::{Point3, Ray, Transform, Vec3};
use crate::sampling::Pcg32;
use crate::shape::{Mesh, Parallelogram, Shape, Sphere};
use crate::stats::RayStats;

/// One mesh of the given triangles (ids in order).
pub fn triangles(tris: &[[Point3; 3]]) -> Geometry {
    let mut mesh = Mesh::default();
    for t in tris {
        let k = mesh.positions.len() as u32;
        mesh.positions.extend_from_slice(t);
        mesh.indices.push([k, k + 1, k + 2]);
    }
    let meshes = if mesh.is_empty() {
        Vec::new()
    } else {
        vec![mesh]
    };
    Geometry::new(Vec::new(), meshes)
}

/// Two unit triangles facing +z, far apart along x: id 0 at z = 0 from the origin, id 1 at
/// z = 1 from x = 9.
pub fn two_triangles() -> Geometry {
    triangles(&[
        [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ],
        [
            Point3::new(9.0, 0.0, 1.0),
            Point3::new(10.0, 0.0, 1.0),
            Point3::new(9.0, 1.0, 1.0),
        ],
    ])
}

/// A row of `n` small triangles along x, facing +z.
pub fn row(n: usize) -> Vec<[Point3; 3]> {
    (0..n)
        .map(|i| {
            let x = i as f32;
            [
                Point3::new(x, 0.0, 0.0),
                Point3::new(x + 0.5, 0.0, 0.0),
                Point3::new(x, 0.5, 0.0),
            ]
        })
        .collect()
}

/// A [`row`] of `n` with a long triangle (id `n`) in front of the whole row, so listed in
/// many cells (`references` of the structure exceed the triangles): a ray near the row's
/// start hits the long one; then the comparison with the list.
pub fn a_long_primitive_in_front_of_a_row<S: Structure>(
    build: impl Fn(&Geometry) -> S,
    n: usize,
    references: impl Fn(&S) -> usize,
) {
    let mut tris = row(n);
    tris.push([
        Point3::new(-1.0, -1.0, 1.0),
        Point3::new(n as f32 + 5.0, -1.0, 1.0),
        Point3::new(-1.0, 2.0, 1.0),
    ]);
    let g = triangles(&tris);
    let s = build(&g);
    assert!(references(&s) > tris.len());
    let mut st = RayStats::default();
    let h = s
        .hit(
            &g,
            &Ray::new(Point3::new(0.2, 0.1, 3.0), Vec3::new(0.05, 0.0, -1.0)),
            &mut st,
        )
        .unwrap();
    assert_eq!(h.prim as usize, n);
    agrees_with_list(&g, &s);
}

/// Flat parallelograms (zero thickness on an axis, some on cell-like boundaries, one
/// duplicated) and a few spheres: the wall at x = 4 spans y, z in [-2, 2].
pub fn parallelogram_scene() -> Geometry {
    let obj = |shape| Object {
        shape,
        props: SurfaceProps::new(0),
    };
    let pg = |p: Point3, v: Vec3, w: Vec3| {
        obj(Shape::Parallelogram(Parallelogram::new(p, v, w).unwrap()))
    };
    let sphere = |c: Vec3, r: f32| {
        obj(Shape::Sphere(Sphere::new(
            Transform::translation(c) * Transform::scaling(Vec3::new(r, r, r)),
        )))
    };
    let objects = vec![
        pg(
            Point3::new(4.0, -2.0, -2.0),
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::new(0.0, 0.0, 4.0),
        ),
        pg(
            Point3::new(-4.0, -4.0, 0.0),
            Vec3::new(8.0, 0.0, 0.0),
            Vec3::new(0.0, 8.0, 0.0),
        ),
        pg(
            Point3::new(-4.0, 0.0, -4.0),
            Vec3::new(8.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 8.0),
        ),
        pg(
            Point3::new(-4.0, 0.0, -4.0),
            Vec3::new(8.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 8.0),
        ),
        pg(
            Point3::new(-1.0, -1.0, 1.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ),
        sphere(Vec3::new(2.0, 2.0, 2.0), 0.5),
        sphere(Vec3::new(-2.0, -2.0, -2.0), 1.5),
        sphere(Vec3::new(-2.0, -2.0, -2.0), 1.5),
        sphere(Vec3::new(0.0, 0.0, 0.0), 0.25),
    ];
    Geometry::new(objects, Vec::new())
}

/// What the shared tests need of a structure.
pub trait Structure {
    /// The closest hit.
    fn hit(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> Option<Hit>;
    /// Any hit.
    fn occ(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> bool;
}

macro_rules! structures {
    ($($t:ty),*) => {$(
        impl Structure for $t {
            fn hit(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> Option<Hit> {
                self.intersect(g, r, st)
            }
            fn occ(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> bool {
                self.occluded(g, r, st)
            }
        }
    )*};
}
structures!(
    super::Bvh,
    super::KdTree,
    super::Grid,
    super::Octree,
    List,
    super::Accel
);

/// [`check_against_list`] for a structure.
pub fn agrees_with_list(g: &Geometry, s: &impl Structure) {
    check_against_list(g, |g, r, st| s.hit(g, r, st), |g, r, st| s.occ(g, r, st));
}

/// [`parallelogram_scene`]: a ray from inside, parallel to x, hits the wall at x = 4 (and
/// not when it stops short); then the comparison with the list.
pub fn flat_primitives_rays_inside_and_parallel<S: Structure>(build: impl Fn(&Geometry) -> S) {
    let g = parallelogram_scene();
    let s = build(&g);
    let mut st = RayStats::default();
    let r = Ray::new(Point3::new(0.5, 0.5, 0.5), Vec3::X);
    assert_eq!(s.hit(&g, &r, &mut st).unwrap().t, 3.5);
    assert!(s.occ(&g, &r, &mut st));
    let short = Ray { tmax: 3.0, ..r };
    assert!(s.hit(&g, &short, &mut st).is_none());
    assert!(!s.occ(&g, &short, &mut st));
    agrees_with_list(&g, &s);
}

/// An empty scene, then `counts` copies of one triangle: the first copy wins the tie.
pub fn empty_single_and_identical<S: Structure>(build: impl Fn(&Geometry) -> S, counts: &[usize]) {
    let g = triangles(&[]);
    let s = build(&g);
    let mut st = RayStats::default();
    assert!(s
        .hit(&g, &Ray::new(Point3::ORIGIN, Vec3::X), &mut st)
        .is_none());
    assert!(!s.occ(&g, &Ray::new(Point3::ORIGIN, Vec3::X), &mut st));
    let t = [
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
    ];
    for &n in counts {
        let g = triangles(&vec![t; n]);
        let s = build(&g);
        let h = s
            .hit(&g, &Ray::new(Point3::new(0.1, 0.1, 1.0), -Vec3::Z), &mut st)
            .unwrap();
        assert_eq!((h.prim, h.t), (0, 1.0));
        agrees_with_list(&g, &s);
    }
}

/// Compares `intersect` and `occluded` with the list on many rays: random, along the axes
/// from points on a lattice (through edges, vertices and flat primitives), and aimed at
/// the corners of the primitives' boxes.
pub fn check_against_list(
    g: &Geometry,
    intersect: impl Fn(&Geometry, &Ray, &mut RayStats) -> Option<Hit>,
    occluded: impl Fn(&Geometry, &Ray, &mut RayStats) -> bool,
) {
    let list = List::new(g);
    let b = g.bounds();
    let (c, r) = if b.is_empty() {
        (Point3::ORIGIN, 1.0)
    } else {
        let d = b.diagonal();
        (b.centroid(), d.x.max(d.y).max(d.z).max(1.0))
    };
    let mut rng = Pcg32::new(7, 3);
    let mut pt = |s: f32| {
        c + Vec3::new(
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
        ) * (2.0 * s * r)
    };
    let mut rays = Vec::new();
    for i in 0..3000 {
        let o = pt(if i % 3 == 0 { 0.4 } else { 1.5 });
        let target = pt(0.5);
        let mut ray = Ray::new(o, target - o);
        if i % 7 == 0 {
            ray.tmax = 0.7;
        }
        rays.push(ray);
    }
    for ix in -8..=8 {
        for iy in -8..=8 {
            let (u, v) = (ix as f32 * 0.5, iy as f32 * 0.5);
            for (o, d) in [
                (Point3::new(u, v, -30.0), Vec3::Z),
                (Point3::new(u, v, 30.0), -Vec3::Z),
                (Point3::new(-30.0, u, v), Vec3::X),
                (Point3::new(30.0, u, v), -Vec3::X),
                (Point3::new(u, -30.0, v), Vec3::Y),
                (Point3::new(u, 30.0, v), -Vec3::Y),
                (Point3::new(u, v, 0.0), Vec3::new(1.0, 1.0, 0.0)),
            ] {
                rays.push(Ray::new(c + o.to_vec(), d));
            }
        }
    }
    for id in 0..g.bounded_count() {
        let pb = g.prim_bounds(id);
        for k in 0..8 {
            let corner = Point3::new(
                if k & 1 == 0 { pb.min.x } else { pb.max.x },
                if k & 2 == 0 { pb.min.y } else { pb.max.y },
                if k & 4 == 0 { pb.min.z } else { pb.max.z },
            );
            let o = pt(1.5);
            rays.push(Ray::new(o, corner - o));
        }
    }
    let mut st = RayStats::default();
    for ray in &rays {
        let a = list.intersect(g, ray, &mut st);
        let h = intersect(g, ray, &mut st);
        assert_eq!(a, h, "{ray:?}");
        assert_eq!(
            list.occluded(g, ray, &mut st),
            occluded(g, ray, &mut st),
            "{ray:?}"
        );
    }
}
