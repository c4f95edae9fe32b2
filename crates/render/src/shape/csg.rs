//! Constructive solid geometry: union, difference, intersection and fusion of solids.
//!
//! Scene syntax: `union(S1, S2 [, T])`, `difference(S1, S2 [, T])`, `intersection(S1, S2 [, T])`,
//! `fusion(S1, S2 [, T])`, nested to any depth. Operands are solids: spheres, boxes, convex
//! polyhedra, closed meshes (outward winding) and CSG nodes.
//!
//! A CSG tree is one primitive. Each node walks the crossings of the ray with its two operands
//! in order of `t`, each crossing knowing whether the ray is inside its operand before and after
//! it, and keeps the crossings that are surfaces of the result:
//! - `union` keeps every surface of both operands, the interior ones too (a grouping);
//! - `fusion` keeps only the boundary of A ∪ B (no interior surfaces: for transparent solids);
//! - `intersection` keeps the boundary of A ∩ B;
//! - `difference` keeps the boundary of A − B; surfaces of B are flipped to point out of it.
//!
//! The surviving hit keeps its operand's material. Nothing is allocated per ray: every node
//! asks its operands for their next crossing after a given `t`.

use super::cube::Crossing;
use super::mesh::ShearedRay;
use super::{Cube, LocalGeometry, Mesh, Polyhedron, ShapeHit, Sphere};
use crate::interaction::SurfaceProps;
use crate::math::{Bounds3, Ray, Transform};

/// A set operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsgOp {
    /// Every surface of both operands.
    Union,
    /// A − B.
    Difference,
    /// A ∩ B.
    Intersection,
    /// The boundary of A ∪ B.
    Fusion,
}

impl CsgOp {
    #[inline]
    fn inside(self, a: bool, b: bool) -> bool {
        match self {
            CsgOp::Union | CsgOp::Fusion => a || b,
            CsgOp::Difference => a && !b,
            CsgOp::Intersection => a && b,
        }
    }
}

/// A solid operand.
#[derive(Clone, Debug, PartialEq)]
pub enum Solid {
    /// A transformed unit sphere.
    Sphere(Sphere),
    /// A transformed cube.
    Cube(Cube),
    /// A convex polyhedron.
    Polyhedron(Polyhedron),
    /// A closed, outward-wound triangle mesh.
    Mesh(Mesh),
}

/// A node of a CSG tree.
#[derive(Clone, Debug, PartialEq)]
pub enum CsgNode {
    /// A solid with its surface.
    Leaf {
        /// The solid.
        solid: Solid,
        /// Its material, emission, light.
        props: SurfaceProps,
    },
    /// A set operation on two nodes.
    Op {
        /// The operation.
        op: CsgOp,
        /// Left operand (node index).
        a: u32,
        /// Right operand (node index).
        b: u32,
    },
}

/// A CSG tree: nodes in an array, the root last.
#[derive(Clone, Debug, PartialEq)]
pub struct Csg {
    nodes: Vec<CsgNode>,
    bounds: Bounds3,
}

/// A crossing of the ray with a node's surface.
#[derive(Clone, Copy, Debug)]
struct Event {
    hit: ShapeHit,
    leaf: u32,
    flip: bool,
    in_before: bool,
    in_after: bool,
}

/// Bit of [`ShapeHit::leaf`] telling that the leaf's normal is flipped.
const FLIP: u32 = 1 << 31;

impl Csg {
    /// A tree of `nodes` (operands before the nodes that use them; the root last).
    /// `None` when an operand index does not point to an earlier node.
    pub fn new(nodes: Vec<CsgNode>) -> Option<Self> {
        for (i, n) in nodes.iter().enumerate() {
            if let CsgNode::Op { a, b, .. } = n {
                if *a as usize >= i || *b as usize >= i {
                    return None;
                }
            }
        }
        if nodes.is_empty() {
            return None;
        }
        let mut bounds = vec![Bounds3::EMPTY; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            bounds[i] = match n {
                CsgNode::Leaf { solid, .. } => solid.bounds(),
                CsgNode::Op { op, a, b } => {
                    let (ba, bb) = (bounds[*a as usize], bounds[*b as usize]);
                    match op {
                        CsgOp::Union | CsgOp::Fusion => ba.union(bb),
                        CsgOp::Intersection => ba.intersection(bb),
                        CsgOp::Difference => ba,
                    }
                }
            };
        }
        let b = *bounds.last()?;
        Some(Self {
            nodes,
            bounds: if b.is_empty() {
                Bounds3::point(crate::math::Point3::ORIGIN)
            } else {
                b
            },
        })
    }

    /// The nodes (root last).
    pub fn nodes(&self) -> &[CsgNode] {
        &self.nodes
    }

    /// Bounds of the result.
    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }

    /// The closest surface crossing in the ray's interval.
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let sr = ShearedRay::new(ray);
        let root = (self.nodes.len() - 1) as u32;
        let e = self.next(root, ray, &sr, ray.tmin)?;
        (e.hit.t < ray.tmax).then_some(ShapeHit {
            leaf: e.leaf | if e.flip { FLIP } else { 0 },
            ..e.hit
        })
    }

    /// The surface of the hit's leaf, flipped for subtracted surfaces.
    pub fn geometry(&self, ray: &Ray, hit: &ShapeHit) -> LocalGeometry {
        let leaf = hit.leaf & !FLIP;
        let mut g = match &self.nodes[leaf as usize] {
            CsgNode::Leaf { solid, .. } => solid.geometry(ray, hit),
            CsgNode::Op { .. } => unreachable!("CSG hits always name a leaf"),
        };
        if hit.leaf & FLIP != 0 {
            g.n = -g.n;
            g.ns = -g.ns;
        }
        g
    }

    /// The surface properties of the hit's leaf.
    pub fn props(&self, hit: &ShapeHit) -> SurfaceProps {
        match &self.nodes[(hit.leaf & !FLIP) as usize] {
            CsgNode::Leaf { props, .. } => *props,
            CsgNode::Op { .. } => unreachable!("CSG hits always name a leaf"),
        }
    }

    /// The tree moved by `t` (applied after the leaves' own placements).
    pub fn transformed(mut self, t: &Transform) -> Self {
        for n in &mut self.nodes {
            if let CsgNode::Leaf { solid, .. } = n {
                *solid = solid.transformed(t);
            }
        }
        Self::new(self.nodes).expect("a valid tree stays valid")
    }

    /// The first crossing of node `node` with the ray's line strictly after `tmin`.
    fn next(&self, node: u32, ray: &Ray, sr: &ShearedRay, tmin: f32) -> Option<Event> {
        match &self.nodes[node as usize] {
            CsgNode::Leaf { solid, .. } => {
                solid
                    .next_crossing(ray, sr, tmin)
                    .map(|(hit, entering)| Event {
                        hit,
                        leaf: node,
                        flip: false,
                        in_before: !entering,
                        in_after: entering,
                    })
            }
            &CsgNode::Op { op, a, b } => {
                let mut ea = self.next(a, ray, sr, tmin);
                let mut eb = self.next(b, ray, sr, tmin);
                loop {
                    let from_a = match (&ea, &eb) {
                        (None, None) => return None,
                        (Some(_), None) => true,
                        (None, Some(_)) => false,
                        (Some(x), Some(y)) => x.hit.t <= y.hit.t,
                    };
                    let (e, other_in) = if from_a {
                        (ea?, eb.is_some_and(|y| y.in_before))
                    } else {
                        (eb?, ea.is_some_and(|x| x.in_before))
                    };
                    let (before, after) = if from_a {
                        (
                            op.inside(e.in_before, other_in),
                            op.inside(e.in_after, other_in),
                        )
                    } else {
                        (
                            op.inside(other_in, e.in_before),
                            op.inside(other_in, e.in_after),
                        )
                    };
                    let interior = e.in_before && e.in_after;
                    let visible = match op {
                        CsgOp::Union => true,
                        _ if !interior => before != after,
                        CsgOp::Fusion => false,
                        CsgOp::Intersection => other_in,
                        CsgOp::Difference => from_a != other_in,
                    };
                    if visible {
                        return Some(Event {
                            flip: e.flip ^ (op == CsgOp::Difference && !from_a),
                            in_before: before,
                            in_after: after,
                            ..e
                        });
                    }
                    if from_a {
                        ea = self.next(a, ray, sr, e.hit.t);
                    } else {
                        eb = self.next(b, ray, sr, e.hit.t);
                    }
                }
            }
        }
    }
}

impl Solid {
    /// World-space bounds.
    pub fn bounds(&self) -> Bounds3 {
        match self {
            Solid::Sphere(s) => s.bounds(),
            Solid::Cube(c) => c.bounds(),
            Solid::Polyhedron(p) => p.bounds(),
            Solid::Mesh(m) => {
                (0..m.len() as u32).fold(Bounds3::EMPTY, |b, i| b.union(m.triangle_bounds(i)))
            }
        }
    }

    /// The solid moved by `t`.
    pub fn transformed(&self, t: &Transform) -> Solid {
        match self {
            Solid::Sphere(s) => Solid::Sphere(Sphere::new(*t * s.world_from_object)),
            Solid::Cube(c) => Solid::Cube(Cube::new(*t * c.world_from_object)),
            Solid::Polyhedron(p) => {
                let mut p = p.clone();
                p.world_from_object = *t * p.world_from_object;
                Solid::Polyhedron(
                    Polyhedron::new(p.world_from_object, p.planes())
                        .expect("a valid polyhedron stays valid"),
                )
            }
            Solid::Mesh(m) => Solid::Mesh(m.transformed(t)),
        }
    }

    /// The first crossing strictly after `tmin` (no upper limit) and whether the ray enters
    /// the solid there.
    fn next_crossing(&self, ray: &Ray, sr: &ShearedRay, tmin: f32) -> Option<(ShapeHit, bool)> {
        let convex = |c: Option<(Crossing, Crossing)>| {
            let (near, far) = c?;
            let ((t, sub), entering) = if near.0 > tmin {
                (near, true)
            } else {
                (far, false)
            };
            (t > tmin).then_some((
                ShapeHit {
                    t,
                    uv: [0.0; 2],
                    sub,
                    leaf: 0,
                },
                entering,
            ))
        };
        match self {
            Solid::Sphere(s) => {
                let (t0, t1) = s.crossings(ray)?;
                convex(Some(((t0, 0), (t1, 0))))
            }
            Solid::Cube(c) => convex(c.crossings(ray)),
            Solid::Polyhedron(p) => convex(p.crossings(ray)),
            Solid::Mesh(m) => {
                let r = Ray {
                    tmin,
                    tmax: f32::INFINITY,
                    ..*ray
                };
                let mut best: Option<ShapeHit> = None;
                let mut rr = r;
                for i in 0..m.len() as u32 {
                    if let Some(h) = m.intersect(i, &rr, sr) {
                        rr.tmax = h.t;
                        best = Some(ShapeHit { sub: i, ..h });
                    }
                }
                let h = best?;
                let [a, b, c] = m.vertices(h.sub);
                let entering = (b - a).cross(c - a).dot(ray.d) < 0.0;
                Some((h, entering))
            }
        }
    }

    fn geometry(&self, ray: &Ray, hit: &ShapeHit) -> LocalGeometry {
        match self {
            Solid::Sphere(s) => s.geometry(ray, hit.t),
            Solid::Cube(c) => c.geometry(ray, hit.t, hit.sub),
            Solid::Polyhedron(p) => p.geometry(ray, hit.t, hit.sub),
            Solid::Mesh(m) => m.geometry(hit.sub, hit.uv[0], hit.uv[1]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Normal3, Point3, Vec3};

    fn sphere_at(x: f32, material: u32) -> CsgNode {
        CsgNode::Leaf {
            solid: Solid::Sphere(Sphere::new(Transform::translation(Vec3::new(x, 0.0, 0.0)))),
            props: SurfaceProps::new(material),
        }
    }

    /// Two unit spheres centred at x = 0 (material 0) and x = 1 (material 1), overlapping on
    /// [0, 1] along the x axis: A spans [-1, 1], B spans [0, 2].
    fn two(op: CsgOp) -> Csg {
        Csg::new(vec![
            sphere_at(0.0, 0),
            sphere_at(1.0, 1),
            CsgNode::Op { op, a: 0, b: 1 },
        ])
        .unwrap()
    }

    /// All visible crossings along the x axis from x = -5, in order: (x, material, normal x).
    fn walk(c: &Csg) -> Vec<(f32, u32, f32)> {
        let mut out = vec![];
        let mut r = Ray::new(Point3::new(-5.0, 0.0, 0.0), Vec3::X);
        while let Some(h) = c.intersect(&r) {
            let g = c.geometry(&r, &h);
            out.push((g.p.x, c.props(&h).material, g.n.x));
            r.tmin = h.t;
        }
        out
    }

    #[test]
    fn each_operation_keeps_the_right_intervals() {
        assert_eq!(
            walk(&two(CsgOp::Union)),
            vec![
                (-1.0, 0, -1.0),
                (0.0, 1, -1.0),
                (1.0, 0, 1.0),
                (2.0, 1, 1.0)
            ]
        );
        assert_eq!(
            walk(&two(CsgOp::Fusion)),
            vec![(-1.0, 0, -1.0), (2.0, 1, 1.0)]
        );
        assert_eq!(
            walk(&two(CsgOp::Intersection)),
            vec![(0.0, 1, -1.0), (1.0, 0, 1.0)]
        );
        // A − B: B's near surface becomes A−B's exit, its normal flipped to point out (+x... −(−1)).
        assert_eq!(
            walk(&two(CsgOp::Difference)),
            vec![(-1.0, 0, -1.0), (0.0, 1, 1.0)]
        );
    }

    #[test]
    fn rays_starting_inside_see_the_right_surface() {
        let d = two(CsgOp::Difference);
        let r = Ray::new(Point3::new(-0.5, 0.0, 0.0), Vec3::X);
        let h = d.intersect(&r).unwrap();
        assert_eq!(d.geometry(&r, &h).p, Point3::new(0.0, 0.0, 0.0));
        // From inside B (outside A − B) looking back at A − B: B's surface at x = 0, flipped.
        let r = Ray::new(Point3::new(0.5, 0.0, 0.0), -Vec3::X);
        let h = d.intersect(&r).unwrap();
        let g = d.geometry(&r, &h);
        assert_eq!(g.p.x, 0.0);
        assert_eq!(g.n, Normal3::new(1.0, 0.0, 0.0));
        // Inside the intersection, looking along +x: the exit at x = 1 (A's surface).
        let i = two(CsgOp::Intersection);
        let r = Ray::new(Point3::new(0.5, 0.0, 0.0), Vec3::X);
        assert_eq!(i.geometry(&r, &i.intersect(&r).unwrap()).p.x, 1.0);
    }

    #[test]
    fn nested_and_transformed_trees() {
        // (A ∪fusion B) − C with C a box around x = 2: the fusion's far end is cut away.
        let c = CsgNode::Leaf {
            solid: Solid::Cube(Cube::new(
                Transform::translation(Vec3::new(2.0, 0.0, 0.0))
                    * Transform::scaling(Vec3::new(0.5, 1.0, 1.0)),
            )),
            props: SurfaceProps::new(2),
        };
        let t = Csg::new(vec![
            sphere_at(0.0, 0),
            sphere_at(1.0, 1),
            CsgNode::Op {
                op: CsgOp::Fusion,
                a: 0,
                b: 1,
            },
            c,
            CsgNode::Op {
                op: CsgOp::Difference,
                a: 2,
                b: 3,
            },
        ])
        .unwrap();
        assert_eq!(walk(&t), vec![(-1.0, 0, -1.0), (1.5, 2, 1.0)]);
        let moved = t.transformed(&Transform::translation(Vec3::new(10.0, 0.0, 0.0)));
        let w = walk(&moved);
        assert_eq!(w.len(), 2);
        assert!((w[0].0 - 9.0).abs() < 1e-5 && (w[1].0 - 11.5).abs() < 1e-5);
        assert!(Csg::new(vec![CsgNode::Op {
            op: CsgOp::Union,
            a: 0,
            b: 0
        }])
        .is_none());
    }

    #[test]
    fn bounds_follow_the_operation() {
        assert!((two(CsgOp::Union).bounds().max.x - 2.0).abs() < 1e-6);
        assert!((two(CsgOp::Intersection).bounds().min.x - 0.0).abs() < 1e-6);
        assert!((two(CsgOp::Difference).bounds().max.x - 1.0).abs() < 1e-6);
    }
}
