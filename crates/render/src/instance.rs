//! Two-level ray tracing of instances: each shared group of shapes has its own acceleration
//! structure (the bottom level, built once however often the group is placed), and a binary
//! BVH over the instances' world boxes (the top level) finds the instances a ray may hit.
//!
//! A ray is brought into an instance's group space by the inverse placement (origin and
//! direction, not renormalised, so the ray parameter `t` is the same in both spaces) and traced
//! through the group's structure; the closest hit keeps the instance's primitive id in
//! [`Hit::prim`] and the group's primitive in [`Hit::leaf`] (groups hold no CSG, whose hits
//! use it), and
//! [`Geometry::interaction`] moves the surface back to the world. Memory grows with the
//! distinct groups (their shapes and structures) plus a few hundred bytes per instance.
//!
//! The top level is always this BVH, whatever [`AccelKind`] is chosen: the kind picks the
//! structure of the scene's own primitives and of each group (so `--accel grid` traces grids
//! inside the instances). Scenes without instances never enter this module.

use crate::accel::{closest, Accel, AccelKind};
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Bounds3, Point3, Ray, Vec3};
use crate::stats::RayStats;

/// Most instances in one leaf of the top level.
const LEAF: usize = 2;
/// Traversal stack of the top level: its depth is at most ⌈log₂ n⌉ + 1 (median splits).
const STACK: usize = 64;

/// A node of the top-level BVH: a leaf (`count > 0`) lists `order[first..first + count]`;
/// an inner node has its first child right after it and its second at `first`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    bounds: Bounds3,
    first: u32,
    count: u32,
    /// An inner node's split axis (its first child lies on the lower side).
    axis: u8,
}

/// The two-level structure of a scene's instances (empty when it has none).
#[derive(Clone, Debug, Default)]
pub struct Instances {
    /// One structure per group of [`Geometry::groups`].
    groups: Vec<Accel>,
    /// The top level.
    nodes: Vec<Node>,
    /// Instance indices in leaf order.
    order: Vec<u32>,
    /// The primitive id of instance 0 ([`Geometry::prim_count`]).
    base: u32,
}

impl Instances {
    /// Builds the structure of `kind` for every group of `geometry` and the top level over its
    /// instances.
    pub fn build(kind: AccelKind, geometry: &Geometry) -> Self {
        if geometry.instances().is_empty() {
            return Self::default();
        }
        // Groups that no instance places get no structure (the list, which holds nothing).
        let mut placed = vec![false; geometry.groups().len()];
        for inst in geometry.instances() {
            placed[inst.group as usize] = true;
        }
        let groups = geometry
            .groups()
            .iter()
            .zip(placed)
            .map(|(g, placed)| Accel::build(if placed { kind } else { AccelKind::None }, g))
            .collect();
        let mut items: Vec<(Bounds3, Point3, u32)> = (0..geometry.instances().len() as u32)
            .filter_map(|i| {
                let b = geometry.instance_bounds(i);
                (!b.is_empty()).then(|| (b, b.centroid(), i))
            })
            .collect();
        // A hit computed in group space may land a hair outside the transformed box.
        let all = items.iter().fold(Bounds3::EMPTY, |a, it| a.union(it.0));
        let m = margin(&all);
        for it in &mut items {
            it.0 = grow(it.0, m);
        }
        let mut nodes = Vec::with_capacity(2 * items.len().div_ceil(LEAF));
        if !items.is_empty() {
            build(&mut items, 0, &mut nodes);
        }
        Self {
            groups,
            nodes,
            order: items.iter().map(|it| it.2).collect(),
            base: geometry.prim_count(),
        }
    }

    /// True when the scene has no instance.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Memory held by the top level and the groups' structures, in bytes.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
            + self.order.len() * 4
            + self.groups.iter().map(Accel::memory).sum::<usize>()
    }

    /// The number of groups with a structure and the number of top-level nodes.
    pub fn describe(&self) -> String {
        format!(
            "{} instances of {} groups, {} top-level nodes",
            self.order.len(),
            self.groups.len(),
            self.nodes.len()
        )
    }

    /// Replaces `best` by the closest hit of `ray` in an instance when there is one closer (ties
    /// to the smaller primitive id).
    #[inline]
    pub fn intersect(
        &self,
        geometry: &Geometry,
        ray: &Ray,
        best: &mut Option<Hit>,
        stats: &mut RayStats,
    ) {
        let mut r = *ray;
        if let Some(b) = best {
            r.tmax = r.tmax.min(b.t.next_up());
        }
        self.visit(ray, &mut r, stats, |i, r, stats| {
            let inst = &geometry.instances()[i as usize];
            let g = inst.group as usize;
            let local = local_ray(r, inst);
            if let Some(h) = self.groups[g].intersect(&geometry.groups()[g], &local, stats) {
                let h = Hit {
                    prim: self.base + i,
                    leaf: h.prim,
                    ..h
                };
                if closest(best, h) {
                    r.tmax = h.t.next_up();
                }
            }
            false
        });
    }

    /// True when `ray` hits an instance within its interval.
    #[inline]
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        let mut r = *ray;
        self.visit(ray, &mut r, stats, |i, r, stats| {
            let inst = &geometry.instances()[i as usize];
            let g = inst.group as usize;
            self.groups[g].occluded(&geometry.groups()[g], &local_ray(r, inst), stats)
        })
    }

    /// Calls `leaf` on each instance whose box `r` (whose `tmax` the callback may shorten)
    /// crosses, nearer boxes first, until it returns true; true when it did.
    #[inline(always)]
    fn visit(
        &self,
        ray: &Ray,
        r: &mut Ray,
        stats: &mut RayStats,
        mut leaf: impl FnMut(u32, &mut Ray, &mut RayStats) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inv = Vec3::new(1.0 / ray.d.x, 1.0 / ray.d.y, 1.0 / ray.d.z);
        let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
        let mut stack = [0u32; STACK];
        let mut top = 0;
        let mut node = 0usize;
        loop {
            stats.nodes += 1;
            let n = &self.nodes[node];
            if n.bounds.intersect(r, inv).is_some() {
                if n.count > 0 {
                    let first = n.first as usize;
                    for &i in &self.order[first..first + n.count as usize] {
                        stats.prim_tests += 1;
                        if leaf(i, r, stats) {
                            return true;
                        }
                    }
                } else {
                    // Nearer child first.
                    let (a, b) = (node + 1, n.first as usize);
                    let (near, far) = if neg[n.axis as usize] { (b, a) } else { (a, b) };
                    if top < STACK {
                        stack[top] = far as u32;
                        top += 1;
                    }
                    node = near;
                    continue;
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            node = stack[top] as usize;
        }
    }
}

/// The ray in instance `inst`'s group space (same `t` interval).
#[inline(always)]
fn local_ray(r: &Ray, inst: &crate::geometry::Instance) -> Ray {
    Ray {
        o: inst.to_world.inv_point(r.o),
        d: inst.to_world.inv_vector(r.d),
        tmin: r.tmin,
        tmax: r.tmax,
    }
}

/// The margin by which instance boxes grow: 2⁻¹⁶ of the largest extent of all of them plus 2⁻²⁰
/// of their largest coordinate (as the accelerators grow primitive boxes), at least 10⁻³⁰.
fn margin(all: &Bounds3) -> f32 {
    let d = all.diagonal();
    let ext = d.x.max(d.y).max(d.z);
    let mag = all.min.to_vec().abs().max(all.max.to_vec().abs());
    let mag = mag.x.max(mag.y).max(mag.z);
    (ext * (1.0 / 65536.0) + mag * (1.0 / 1_048_576.0)).max(1e-30)
}

/// `b` grown by `m` on every side.
fn grow(b: Bounds3, m: f32) -> Bounds3 {
    let v = Vec3::new(m, m, m);
    Bounds3 {
        min: b.min - v,
        max: b.max + v,
    }
}

/// Builds the subtree over `items` (median split of the centroids along their widest axis,
/// ties by instance index: deterministic) into `nodes`; `offset` is the index of `items[0]`
/// in the final order.
fn build(items: &mut [(Bounds3, Point3, u32)], offset: u32, nodes: &mut Vec<Node>) {
    let bounds = items.iter().fold(Bounds3::EMPTY, |a, it| a.union(it.0));
    let me = nodes.len();
    nodes.push(Node {
        bounds,
        first: offset,
        count: items.len() as u32,
        axis: 0,
    });
    if items.len() <= LEAF {
        return;
    }
    let c = items
        .iter()
        .fold(Bounds3::EMPTY, |a, it| a.union_point(it.1));
    let axis = c.max_extent();
    items.sort_unstable_by(|a, b| a.1[axis].total_cmp(&b.1[axis]).then(a.2.cmp(&b.2)));
    let mid = items.len() / 2;
    let (left, right) = items.split_at_mut(mid);
    build(left, offset, nodes);
    let second = nodes.len() as u32;
    build(right, offset + mid as u32, nodes);
    nodes[me].first = second;
    nodes[me].count = 0;
    nodes[me].axis = axis as u8;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::math::{Normal3, Point2, RayBatch, Transform, BATCH};
    use crate::sampling::Pcg32;
    use crate::scene::{GroupError, Scene, SceneBuilder};
    use crate::shape::{Mesh, Shape, Sphere};
    use crate::texture::Texture;
    use crate::Rgb;

    const KINDS: [AccelKind; 5] = [
        AccelKind::Bvh,
        AccelKind::None,
        AccelKind::KdTree,
        AccelKind::Grid,
        AccelKind::Octree,
    ];

    /// A closed octahedron of radius 1 with uv per vertex and flat normals.
    fn octahedron(material: u32) -> Mesh {
        let p = |x, y, z| Point3::new(x, y, z);
        let mut m = Mesh {
            positions: vec![
                p(1.0, 0.0, 0.0),
                p(-1.0, 0.0, 0.0),
                p(0.0, 1.0, 0.0),
                p(0.0, -1.0, 0.0),
                p(0.0, 0.0, 1.0),
                p(0.0, 0.0, -1.0),
            ],
            indices: vec![
                [0, 2, 4],
                [2, 1, 4],
                [1, 3, 4],
                [3, 0, 4],
                [2, 0, 5],
                [1, 2, 5],
                [3, 1, 5],
                [0, 3, 5],
            ],
            ..Default::default()
        };
        m.uvs = m
            .positions
            .iter()
            .map(|q| Point2::new(0.5 + 0.5 * q.x, 0.5 + 0.5 * q.y))
            .collect();
        m.props.material = material;
        m
    }

    /// A random placement: rotation, non-uniform scaling, translation.
    fn placement(rng: &mut Pcg32) -> Transform {
        let mut f = || rng.next_f32();
        let axis = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5 + 1e-3);
        Transform::translation(Vec3::new(f() * 20.0 - 10.0, f() * 20.0 - 10.0, f() * 4.0))
            * Transform::rotation(axis, f() * 360.0).unwrap()
            * Transform::scaling(Vec3::new(0.3 + f(), 0.3 + f(), 0.3 + f()))
    }

    /// A sphere of its own, and `placements` of a group (octahedron and sphere); with
    /// `instanced` false the same shapes are copied into the world instead.
    fn scene(placements: &[Transform], instanced: bool, kind: AccelKind) -> Scene {
        let mut b = SceneBuilder::new();
        let m0 = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
        let m1 = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
        let m2 = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.25))));
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                0.0, 0.0, -30.0,
            )))),
            m0,
            None,
        );
        let ball = Transform::translation(Vec3::new(0.0, 0.0, 2.0))
            * Transform::scaling(Vec3::new(0.5, 0.5, 0.5));
        if instanced {
            let g = b
                .add_group(
                    vec![(Shape::Sphere(Sphere::new(ball)), m2)],
                    vec![octahedron(m1)],
                )
                .unwrap();
            for t in placements {
                b.add_instance(g, *t);
            }
        } else {
            for t in placements {
                b.add_shape(Shape::Sphere(Sphere::new(*t * ball)), m2, None);
            }
            for t in placements {
                b.add_mesh(octahedron(m1).transformed(t));
            }
        }
        b.build(kind)
    }

    fn ray(rng: &mut Pcg32) -> Ray {
        let mut f = || rng.next_f32();
        let o = Point3::new(f() * 30.0 - 15.0, f() * 30.0 - 15.0, 10.0 + f() * 5.0);
        let target = Point3::new(f() * 24.0 - 12.0, f() * 24.0 - 12.0, f() * 5.0 - 1.0);
        Ray::new(o, target - o)
    }

    #[test]
    fn identity_instances_hit_exactly_what_the_copies_hit() {
        let placements = [Transform::IDENTITY; 3];
        for kind in KINDS {
            let a = scene(&placements, true, kind);
            let b = scene(&placements[..1], false, kind);
            let mut rng = Pcg32::new(1, 2);
            let mut st = RayStats::default();
            let mut hits = 0;
            for _ in 0..2000 {
                let mut f = || rng.next_f32();
                let o = Point3::new(f() * 6.0 - 3.0, f() * 6.0 - 3.0, 5.0 + f());
                let target = Point3::new(f() * 3.0 - 1.5, f() * 3.0 - 1.5, f() * 2.0 - 1.0);
                let r = Ray::new(o, target - o);
                let (x, y) = (a.interact(&r, &mut st), b.interact(&r, &mut st));
                assert_eq!(x.is_some(), y.is_some(), "{kind:?} {r:?}");
                let (Some(x), Some(y)) = (x, y) else { continue };
                hits += 1;
                assert_eq!(
                    (x.p, x.n, x.ns, x.uv, x.dpdu, x.wo, x.t, x.props),
                    (y.p, y.n, y.ns, y.uv, y.dpdu, y.wo, y.t, y.props),
                    "{kind:?}"
                );
                assert_eq!(
                    x.shading_frame(),
                    y.shading_frame(),
                    "{kind:?}: the same shading frame"
                );
                assert_eq!(a.occluded(&r, &mut st), b.occluded(&r, &mut st));
            }
            assert!(hits > 200, "{kind:?}: {hits}");
        }
    }

    #[test]
    fn transformed_instances_agree_with_transformed_copies() {
        let mut rng = Pcg32::new(7, 8);
        let placements: Vec<Transform> = (0..40).map(|_| placement(&mut rng)).collect();
        let a = scene(&placements, true, AccelKind::Bvh);
        let b = scene(&placements, false, AccelKind::Bvh);
        let mut st = RayStats::default();
        let (mut hits, mut differ) = (0, 0);
        for _ in 0..20_000 {
            let r = ray(&mut rng);
            let (x, y) = (a.interact(&r, &mut st), b.interact(&r, &mut st));
            let (Some(x), Some(y)) = (x, y) else {
                // Only grazing rays may see an edge differently.
                differ += (x.is_some() != y.is_some()) as u32;
                continue;
            };
            hits += 1;
            if (x.t - y.t).abs() > 1e-4 * y.t {
                differ += 1;
                continue;
            }
            assert!((x.p - y.p).norm() < 1e-3, "{:?} {:?}", x.p, y.p);
            assert!(x.n.to_vec().approx_eq(y.n.to_vec(), 1e-3), "{x:?} {y:?}");
            assert_eq!(x.props, y.props);
            assert!((x.uv.x - y.uv.x).abs() < 1e-3 && (x.uv.y - y.uv.y).abs() < 1e-3);
            let (hx, hy) = (
                a.intersect(&r, &mut st).unwrap(),
                b.intersect(&r, &mut st).unwrap(),
            );
            assert_eq!(
                a.shape_index(&hx) >= 1,
                b.shape_index(&hy) >= 1,
                "the world's own sphere is shape 0 in both"
            );
        }
        assert!(hits > 2000, "{hits}");
        assert!(differ < 20, "{differ} rays disagree");
    }

    #[test]
    fn every_structure_finds_the_brute_force_hit_through_the_top_level() {
        let mut rng = Pcg32::new(11, 12);
        let placements: Vec<Transform> = (0..200).map(|_| placement(&mut rng)).collect();
        for kind in KINDS {
            let s = scene(&placements, true, kind);
            let g = &s.geometry;
            let lists: Vec<Accel> = g
                .groups()
                .iter()
                .map(|gr| Accel::build(AccelKind::None, gr))
                .collect();
            let mut st = RayStats::default();
            let mut rng = Pcg32::new(13, 14);
            for _ in 0..3000 {
                let r = ray(&mut rng);
                // Brute force: every instance, each through the list.
                let mut best = s.accel.intersect(g, &r, &mut st);
                for (i, inst) in g.instances().iter().enumerate() {
                    let local = local_ray(&r, inst);
                    let gr = &g.groups()[inst.group as usize];
                    let mut l = local;
                    if let Some(b) = &best {
                        l.tmax = b.t.next_up();
                    }
                    if let Some(h) = lists[inst.group as usize].intersect(gr, &l, &mut st) {
                        closest(
                            &mut best,
                            Hit {
                                prim: g.prim_count() + i as u32,
                                leaf: h.prim,
                                ..h
                            },
                        );
                    }
                }
                assert_eq!(s.intersect(&r, &mut st), best, "{kind:?} {r:?}");
                assert_eq!(s.occluded(&r, &mut st), best.is_some(), "{kind:?}");
            }
        }
    }

    #[test]
    fn batches_get_the_single_ray_hits() {
        let mut rng = Pcg32::new(21, 22);
        let placements: Vec<Transform> = (0..100).map(|_| placement(&mut rng)).collect();
        let s = scene(&placements, true, AccelKind::Bvh);
        let mut st = RayStats::default();
        for _ in 0..100 {
            let rays: Vec<Ray> = (0..BATCH).map(|_| ray(&mut rng)).collect();
            let mut batch = RayBatch::default();
            for (i, r) in rays.iter().enumerate() {
                batch.set(i, r);
            }
            let mut hits = [None; BATCH];
            s.intersect_batch(&batch, &mut hits, &mut st);
            let occ = s.occluded_batch(&batch, &mut st);
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(hits[i], s.intersect(r, &mut st));
                assert_eq!(occ & (1 << i) != 0, s.occluded(r, &mut st));
            }
        }
    }

    /// By hand: the triangle A = (1,0,0), B = (0,0,1), C = (0,1,1) (plane x + z = 1, uv (0,0),
    /// (1,0), (0,1), vertex normals +z) placed by a scaling (2,1,1) lies in the plane
    /// x/2 + z = 1. A ray down from (0.5, 0.25, 5) meets it at t = 4.25, at (0.5, 0.25, 0.75):
    /// in group space (0.25, 0.25, 0.75), β = 0.5, γ = 0.25, so uv = (0.5, 0.25). The group
    /// normal (1,0,1)/√2 goes back by the inverse transpose diag(1/2, 1, 1): (1,0,2)/√5; the
    /// shading normal +z stays +z; ∂p/∂u = B − A = (−1,0,1) becomes (−2,0,1).
    #[test]
    fn a_hit_in_a_scaled_instance_by_hand() {
        let mut b = SceneBuilder::new();
        let m0 = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
        let m1 = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                50.0, 0.0, 0.0,
            )))),
            m0,
            None,
        );
        let mut tri = Mesh {
            positions: vec![
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 0.0, 1.0),
                Point3::new(0.0, 1.0, 1.0),
            ],
            normals: vec![Normal3::new(0.0, 0.0, 1.0); 3],
            uvs: vec![
                Point2::new(0.0, 0.0),
                Point2::new(1.0, 0.0),
                Point2::new(0.0, 1.0),
            ],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        };
        tri.props.material = m1;
        let g = b
            .add_group(
                vec![(
                    Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                        0.0, 0.0, -5.0,
                    )))),
                    m0,
                )],
                vec![tri],
            )
            .unwrap();
        b.add_instance(g, Transform::translation(Vec3::new(100.0, 0.0, 0.0)));
        b.add_instance(g, Transform::scaling(Vec3::new(2.0, 1.0, 1.0)));
        let s = b.build(AccelKind::Bvh);
        let r = Ray::new(Point3::new(0.5, 0.25, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let mut st = RayStats::default();
        let si = s.interact(&r, &mut st).unwrap();
        assert_eq!(si.t, 4.25);
        assert!((si.p - Point3::new(0.5, 0.25, 0.75)).norm() < 1e-6);
        assert!((si.uv.x - 0.5).abs() < 1e-6 && (si.uv.y - 0.25).abs() < 1e-6);
        let n = Vec3::new(1.0, 0.0, 2.0) / 5f32.sqrt();
        assert!(si.n.to_vec().approx_eq(n, 1e-6), "{:?}", si.n);
        assert_eq!(si.ns, Normal3::new(0.0, 0.0, 1.0));
        assert!(si.dpdu.approx_eq(Vec3::new(-2.0, 0.0, 1.0), 1e-6));
        assert_eq!(si.wo, Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(si.props.material, m1);
        // The second instance (primitive id after the world's sphere and the first instance),
        // its second shape (the triangle): shapes 0 (world sphere), 1–2 (first instance), 3–4.
        let h = s.intersect(&r, &mut st).unwrap();
        assert_eq!((si.prim, h.prim, h.leaf), (2, 2, 1));
        assert_eq!(s.shape_index(&h), 4);
        // Below the triangle: the group's sphere, moved and stretched along x.
        let r = Ray::new(Point3::new(-10.0, 0.0, -5.0), Vec3::new(1.0, 0.0, 0.0));
        let si = s.interact(&r, &mut st).unwrap();
        assert_eq!(si.t, 8.0);
        assert!(si.n.to_vec().approx_eq(Vec3::new(-1.0, 0.0, 0.0), 1e-6));
        assert_eq!(s.shape_index(&s.intersect(&r, &mut st).unwrap()), 3);
        assert_eq!(si.props.material, m0);
        assert!(s.occluded(&r, &mut st));
        assert!(!s.occluded(
            &Ray::new(Point3::new(0.0, 5.0, 0.0), Vec3::new(0.0, 1.0, 0.0)),
            &mut st
        ));
        // The world bounds cover both instances.
        let wb = s.geometry.bounds();
        assert!(wb.max.x >= 101.0 && wb.min.z <= -6.0);
    }

    #[test]
    fn groups_refuse_emitters_and_unbounded_shapes() {
        let mut b = SceneBuilder::new();
        let mut m = octahedron(0);
        m.props.emission = Some(0);
        assert_eq!(
            b.add_group(Vec::new(), vec![m]),
            Err(GroupError::Emitter(0))
        );
        let plane = Shape::Plane(crate::shape::Plane::new(Transform::IDENTITY));
        assert_eq!(
            b.add_group(vec![(plane, 0)], Vec::new()),
            Err(GroupError::Unbounded(0))
        );
    }

    #[test]
    fn memory_grows_with_the_groups_not_the_instances() {
        let mut rng = Pcg32::new(5, 5);
        let few: Vec<Transform> = (0..10).map(|_| placement(&mut rng)).collect();
        let many: Vec<Transform> = (0..10_000).map(|_| placement(&mut rng)).collect();
        let (a, b) = (
            scene(&few, true, AccelKind::Bvh),
            scene(&many, true, AccelKind::Bvh),
        );
        assert_eq!(a.geometry.groups().len(), 1);
        assert_eq!(b.geometry.groups().len(), 1);
        // Top level: one node per instance or less, 36 bytes each, and 4 bytes of order.
        let per_instance = (b.instances.memory() - a.instances.memory()) as f64 / 9990.0;
        assert!(per_instance < 2.0 * 40.0 + 4.0, "{per_instance}");
    }
}
