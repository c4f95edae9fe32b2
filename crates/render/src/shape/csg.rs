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
//!
//! A tree may hold [`CsgNode::Shared`] nodes: another tree behind an `Arc`, placed by a
//! transformation, as instances are (`crate::instance`): the ray enters it by the inverse
//! placement (origin and direction, not renormalised, so `t` is the same in both spaces), and a
//! ray whose line misses the shared tree's world box after `tmin` skips it. A named shape used
//! many times is thus stored once, and a chain of n doublings is n nodes in memory. The work of
//! a ray still grows with the *expanded* tree (every use of a shared tree counted) where its
//! boxes overlap the ray, so [`Csg::leaves`] and [`Csg::depth`] report the expanded size for
//! the scene builders to limit. A hit names its leaf by its index in the expanded tree, in
//! operand order, which [`Csg::geometry`] follows down again (iteratively).

use super::cube::Crossing;
use super::mesh::ShearedRay;
use super::{Cube, LocalGeometry, Mesh, Polyhedron, ShapeHit, Sphere};
use crate::interaction::SurfaceProps;
use crate::math::{Bounds3, Normal3, Ray, Transform, Vec3};
use std::sync::Arc;

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
    /// A tree shared with other nodes (a named shape used several times), placed by a
    /// transformation from its space to this tree's.
    Shared {
        /// The shared tree.
        tree: Arc<Csg>,
        /// Its placement (rays enter the tree by the inverse).
        placement: Transform,
    },
}

/// Largest number of leaves of the expanded tree: hits name a leaf by its index, below the
/// bit that marks a flipped normal.
pub const MAX_EXPANDED_LEAVES: u64 = (FLIP - 1) as u64;

/// Why a list of nodes is not a tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsgError {
    /// No node, or an operand that is not an earlier node.
    Invalid,
    /// The expanded tree has more than [`MAX_EXPANDED_LEAVES`] leaves (this many, saturated).
    TooLarge(u64),
}

impl std::fmt::Display for CsgError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CsgError::Invalid => write!(f, "invalid CSG tree"),
            CsgError::TooLarge(n) => write!(
                f,
                "the CSG tree expands to {n} solids, more than {MAX_EXPANDED_LEAVES}"
            ),
        }
    }
}

impl std::error::Error for CsgError {}

/// A CSG tree: nodes in an array, the root last.
#[derive(Clone, Debug, PartialEq)]
pub struct Csg {
    nodes: Vec<CsgNode>,
    /// Leaves of each node's expanded subtree.
    leaves: Vec<u32>,
    /// World boxes of the shared nodes (grown by a margin), empty boxes for the others.
    shared_bounds: Vec<Bounds3>,
    /// Operations whose operands are twins: the same shared tree at the same placement, or the
    /// same sphere or box. Their crossings are the same (only the leaf numbers differ), so
    /// the second operand reuses the first's instead of tracing them again: a chain of named
    /// doublings `union(s, s)` costs a ray one walk per level, not 2ⁿ.
    twins: Vec<bool>,
    /// Bounds of the result, empty when it is.
    extent: Bounds3,
    /// `extent`, or the origin when it is empty.
    bounds: Bounds3,
    /// Nodes on the longest path from the root to a leaf of the expanded tree, less one.
    depth: u32,
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
    /// A tree of `nodes` (operands before the nodes that use them; the root last). Fails when
    /// an operand index does not point to an earlier node, or when the expanded tree has more
    /// than [`MAX_EXPANDED_LEAVES`] leaves.
    pub fn new(nodes: Vec<CsgNode>) -> Result<Self, CsgError> {
        if nodes.is_empty() {
            return Err(CsgError::Invalid);
        }
        let n = nodes.len();
        let (mut bounds, mut shared_bounds) = (vec![Bounds3::EMPTY; n], vec![Bounds3::EMPTY; n]);
        let (mut leaves, mut depths) = (vec![0u64; n], vec![0u32; n]);
        let mut twins = vec![false; n];
        for (i, node) in nodes.iter().enumerate() {
            (bounds[i], leaves[i], depths[i]) = match node {
                CsgNode::Leaf { solid, .. } => (solid.bounds(), 1, 0),
                &CsgNode::Op { op, a, b } => {
                    let (a, b) = (a as usize, b as usize);
                    if a >= i || b >= i {
                        return Err(CsgError::Invalid);
                    }
                    let (ba, bb) = (bounds[a], bounds[b]);
                    let bounds = match op {
                        CsgOp::Union | CsgOp::Fusion => ba.union(bb),
                        CsgOp::Intersection => ba.intersection(bb),
                        CsgOp::Difference => ba,
                    };
                    let depth = depths[a].max(depths[b]).saturating_add(1);
                    twins[i] = a == b
                        || match (&nodes[a], &nodes[b]) {
                            (
                                CsgNode::Shared {
                                    tree: t,
                                    placement: p,
                                },
                                CsgNode::Shared {
                                    tree: u,
                                    placement: q,
                                },
                            ) => Arc::ptr_eq(t, u) && p == q,
                            (
                                CsgNode::Leaf {
                                    solid: Solid::Sphere(x),
                                    ..
                                },
                                CsgNode::Leaf {
                                    solid: Solid::Sphere(y),
                                    ..
                                },
                            ) => x == y,
                            (
                                CsgNode::Leaf {
                                    solid: Solid::Cube(x),
                                    ..
                                },
                                CsgNode::Leaf {
                                    solid: Solid::Cube(y),
                                    ..
                                },
                            ) => x == y,
                            _ => false,
                        };
                    (bounds, leaves[a].saturating_add(leaves[b]), depth)
                }
                CsgNode::Shared { tree, placement } => {
                    let b = tree.extent.transform(placement);
                    shared_bounds[i] = grow(b);
                    let depth = tree.depth.saturating_add(1);
                    (b, tree.leaves() as u64, depth)
                }
            };
        }
        let total = leaves[n - 1];
        if total > MAX_EXPANDED_LEAVES {
            return Err(CsgError::TooLarge(total));
        }
        let b = bounds[n - 1];
        Ok(Self {
            nodes,
            // Every node's count is at most the root's (counts only add up towards the root).
            leaves: leaves.into_iter().map(|l| l as u32).collect(),
            shared_bounds,
            twins,
            extent: b,
            bounds: if b.is_empty() {
                Bounds3::point(crate::math::Point3::ORIGIN)
            } else {
                b
            },
            depth: depths[n - 1],
        })
    }

    /// The nodes (root last).
    pub fn nodes(&self) -> &[CsgNode] {
        &self.nodes
    }

    /// The number of leaves of the expanded tree (every use of a shared tree counted): the
    /// most solids one ray may have to test.
    pub fn leaves(&self) -> u32 {
        self.leaves[self.nodes.len() - 1]
    }

    /// The depth of the expanded tree (operations and shared nodes on the longest path from
    /// the root to a leaf): the depth of the recursion that traces it.
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Bounds of the result.
    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }

    /// The closest surface crossing in the ray's interval.
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let sr = ShearedRay::new(ray);
        let root = (self.nodes.len() - 1) as u32;
        let e = self.next(root, 0, ray, &sr, ray.tmin)?;
        (e.hit.t < ray.tmax).then_some(ShapeHit {
            leaf: e.leaf | if e.flip { FLIP } else { 0 },
            ..e.hit
        })
    }

    /// The surface of the hit's leaf, flipped for subtracted surfaces.
    pub fn geometry(&self, ray: &Ray, hit: &ShapeHit) -> LocalGeometry {
        let (solid, _, placement) = self.leaf(hit.leaf & !FLIP);
        let mut g = match placement {
            None => solid.geometry(ray, hit),
            Some(t) => {
                let local = Ray {
                    o: t.inv_point(ray.o),
                    d: t.inv_vector(ray.d),
                    ..*ray
                };
                let g = solid.geometry(&local, hit);
                let n = unit(t.normal(g.n), g.n);
                let mut ns = unit(t.normal(g.ns), n);
                // Keep the shading normal on the side of the geometric one, which a
                // non-uniform scaling could otherwise break.
                if n.dot_vec(ns.to_vec()) < 0.0 {
                    ns = -ns;
                }
                LocalGeometry {
                    p: t.point(g.p),
                    n,
                    ns,
                    uv: g.uv,
                    dpdu: t.vector(g.dpdu),
                }
            }
        };
        if hit.leaf & FLIP != 0 {
            g.n = -g.n;
            g.ns = -g.ns;
        }
        g
    }

    /// The surface properties of the hit's leaf.
    pub fn props(&self, hit: &ShapeHit) -> SurfaceProps {
        *self.leaf(hit.leaf & !FLIP).1
    }

    /// The leaf with index `index` in the expanded tree, with its placement in this tree's
    /// space (`None` when it is not inside a shared tree).
    fn leaf(&self, mut index: u32) -> (&Solid, &SurfaceProps, Option<Transform>) {
        let mut tree = self;
        let mut node = self.nodes.len() - 1;
        let mut placement: Option<Transform> = None;
        loop {
            match &tree.nodes[node] {
                CsgNode::Leaf { solid, props } => return (solid, props, placement),
                &CsgNode::Op { a, b, .. } => {
                    let left = tree.leaves[a as usize];
                    if index < left {
                        node = a as usize;
                    } else {
                        index -= left;
                        node = b as usize;
                    }
                }
                CsgNode::Shared {
                    tree: t,
                    placement: p,
                } => {
                    placement = Some(placement.map_or(*p, |q| q * *p));
                    tree = t;
                    node = tree.nodes.len() - 1;
                }
            }
        }
    }

    /// The tree moved by `t` (applied after the leaves' own placements).
    pub fn transformed(mut self, t: &Transform) -> Self {
        for n in &mut self.nodes {
            match n {
                CsgNode::Leaf { solid, .. } => *solid = solid.transformed(t),
                CsgNode::Op { .. } => {}
                CsgNode::Shared { placement, .. } => *placement = *t * *placement,
            }
        }
        Self::new(self.nodes).expect("a valid tree stays valid")
    }

    /// The first crossing of node `node`, whose first leaf has the index `base` in the expanded
    /// tree, with the ray's line strictly after `tmin`.
    fn next(&self, node: u32, base: u32, ray: &Ray, sr: &ShearedRay, tmin: f32) -> Option<Event> {
        match &self.nodes[node as usize] {
            CsgNode::Leaf { solid, .. } => {
                solid
                    .next_crossing(ray, sr, tmin)
                    .map(|(hit, entering)| Event {
                        hit,
                        leaf: base,
                        flip: false,
                        in_before: !entering,
                        in_after: entering,
                    })
            }
            CsgNode::Shared { tree, placement } => {
                // A line that misses the box after `tmin` crosses nothing inside: it is outside
                // the shared solid from there on, which is what no crossing means.
                let after = Ray {
                    tmin,
                    tmax: f32::INFINITY,
                    ..*ray
                };
                let inv_d = Vec3::new(1.0 / ray.d.x, 1.0 / ray.d.y, 1.0 / ray.d.z);
                self.shared_bounds[node as usize].intersect(&after, inv_d)?;
                let local = Ray {
                    o: placement.inv_point(ray.o),
                    d: placement.inv_vector(ray.d),
                    ..*ray
                };
                let lsr = ShearedRay::new(&local);
                let root = (tree.nodes.len() - 1) as u32;
                tree.next(root, base, &local, &lsr, tmin)
            }
            &CsgNode::Op { op, a, b } => {
                let base_b = base + self.leaves[a as usize];
                let twins = self.twins[node as usize];
                // A twin's crossing: the first operand's, numbered in the second.
                let twin = |e: Option<Event>| {
                    e.map(|e| Event {
                        leaf: e.leaf - base + base_b,
                        ..e
                    })
                };
                let mut ea = self.next(a, base, ray, sr, tmin);
                // The first operand's last query (its `tmin`) and answer.
                let mut last_a = (tmin, ea);
                let mut eb = if twins {
                    twin(ea)
                } else {
                    self.next(b, base_b, ray, sr, tmin)
                };
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
                        ea = self.next(a, base, ray, sr, e.hit.t);
                        last_a = (e.hit.t, ea);
                    } else if twins && last_a.0 == e.hit.t {
                        eb = twin(last_a.1);
                    } else {
                        eb = self.next(b, base_b, ray, sr, e.hit.t);
                    }
                }
            }
        }
    }
}

/// A transformed normal made unit, or `fallback` when it degenerates.
fn unit(n: Normal3, fallback: Normal3) -> Normal3 {
    let len = n.to_vec().norm();
    if len > 0.0 && len.is_finite() {
        n / len
    } else {
        fallback
    }
}

/// `b` grown on every side by 2⁻¹⁶ of its largest extent plus 2⁻²⁰ of its largest coordinate
/// (as instance boxes are): a crossing computed in the shared tree's space may land a hair
/// outside its transformed box.
fn grow(b: Bounds3) -> Bounds3 {
    if b.is_empty() {
        return b;
    }
    let d = b.diagonal();
    let mag = b.min.to_vec().abs().max(b.max.to_vec().abs());
    let m = (d.x.max(d.y).max(d.z) * (1.0 / 65536.0)
        + mag.x.max(mag.y).max(mag.z) * (1.0 / 1_048_576.0))
        .max(1e-30);
    let v = Vec3::new(m, m, m);
    Bounds3 {
        min: b.min - v,
        max: b.max + v,
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
        .is_err());
    }

    #[test]
    fn bounds_follow_the_operation() {
        assert!((two(CsgOp::Union).bounds().max.x - 2.0).abs() < 1e-6);
        assert!((two(CsgOp::Intersection).bounds().min.x - 0.0).abs() < 1e-6);
        assert!((two(CsgOp::Difference).bounds().max.x - 1.0).abs() < 1e-6);
    }

    /// `two(op)` as a shared tree placed at x = `x`.
    fn shared(tree: &Arc<Csg>, x: f32) -> CsgNode {
        CsgNode::Shared {
            tree: tree.clone(),
            placement: Transform::translation(Vec3::new(x, 0.0, 0.0)),
        }
    }

    #[test]
    fn shared_trees_hit_what_their_copies_hit() {
        for op in [
            CsgOp::Union,
            CsgOp::Fusion,
            CsgOp::Intersection,
            CsgOp::Difference,
        ] {
            let t = Arc::new(two(op));
            // The tree used four times: at 0 and 0.5, and that pair again at 10.
            let pair = Arc::new(
                Csg::new(vec![
                    shared(&t, 0.0),
                    shared(&t, 0.5),
                    CsgNode::Op { op, a: 0, b: 1 },
                ])
                .unwrap(),
            );
            let s = Csg::new(vec![
                shared(&pair, 0.0),
                shared(&pair, 10.0),
                CsgNode::Op {
                    op: CsgOp::Union,
                    a: 0,
                    b: 1,
                },
            ])
            .unwrap();
            // The same tree written out: four copies of the two spheres.
            let mut nodes = vec![];
            let copy = |x: f32, nodes: &mut Vec<CsgNode>| {
                let i = nodes.len() as u32;
                nodes.push(sphere_at(x, 0));
                nodes.push(sphere_at(x + 1.0, 1));
                nodes.push(CsgNode::Op { op, a: i, b: i + 1 });
                i + 2
            };
            let a = copy(0.0, &mut nodes);
            let b = copy(0.5, &mut nodes);
            nodes.push(CsgNode::Op { op, a, b });
            let p = nodes.len() as u32 - 1;
            let c = copy(10.0, &mut nodes);
            let d = copy(10.5, &mut nodes);
            nodes.push(CsgNode::Op { op, a: c, b: d });
            let q = nodes.len() as u32 - 1;
            nodes.push(CsgNode::Op {
                op: CsgOp::Union,
                a: p,
                b: q,
            });
            let e = Csg::new(nodes).unwrap();
            assert_eq!((s.leaves(), e.leaves()), (8, 8));
            assert_eq!((s.depth(), e.depth()), (5, 3));
            assert_eq!(s.bounds(), e.bounds());
            let (ws, we) = (walk(&s), walk(&e));
            assert!(!we.is_empty());
            assert_eq!(ws, we, "{op:?}");
        }
    }

    #[test]
    fn shared_trees_are_skipped_by_rays_that_miss_their_box_and_move_normals() {
        let t = Arc::new(two(CsgOp::Difference));
        let rotated = Csg::new(vec![CsgNode::Shared {
            tree: t.clone(),
            placement: Transform::translation(Vec3::new(0.0, 3.0, 0.0))
                * Transform::rotation_z(90.0),
        }])
        .unwrap();
        // A − B rotated by 90° about z and moved up: A's far side is at y = 2, B's cut at y = 3.
        let r = Ray::new(Point3::new(0.0, -5.0, 0.0), Vec3::Y);
        let h = rotated.intersect(&r).unwrap();
        let g = rotated.geometry(&r, &h);
        assert!((g.p.y - 2.0).abs() < 1e-5, "{:?}", g.p);
        assert!((g.n.to_vec() - Vec3::new(0.0, -1.0, 0.0)).norm() < 1e-5);
        let mut r2 = r;
        r2.tmin = h.t;
        let h2 = rotated.intersect(&r2).unwrap();
        let g2 = rotated.geometry(&r2, &h2);
        assert!((g2.p.y - 3.0).abs() < 1e-5 && (g2.n.to_vec() - Vec3::Y).norm() < 1e-5);
        assert_eq!(rotated.props(&h2).material, 1);
        // Along x at the old height: the tree was moved away.
        assert!(rotated
            .intersect(&Ray::new(Point3::new(-5.0, 0.0, 0.0), Vec3::X))
            .is_none());
        assert!(Csg::new(vec![CsgNode::Op {
            op: CsgOp::Union,
            a: 0,
            b: 0
        }])
        .is_err());
    }

    #[test]
    fn a_chain_of_doublings_is_one_node_per_level() {
        let mut t = Arc::new(two(CsgOp::Union));
        for _ in 0..29 {
            t = Arc::new(
                Csg::new(vec![
                    shared(&t, 0.0),
                    shared(&t, 0.0),
                    CsgNode::Op {
                        op: CsgOp::Union,
                        a: 0,
                        b: 1,
                    },
                ])
                .unwrap(),
            );
        }
        // 2³⁰ leaves in 1 + 29 × 3 nodes.
        assert_eq!(t.leaves(), 1 << 30);
        assert_eq!(t.depth(), 59);
        // A ray that misses the box is done at the first shared nodes (2³⁰ tests otherwise).
        assert!(t
            .intersect(&Ray::new(Point3::new(-5.0, 5.0, 0.0), Vec3::X))
            .is_none());
        let more = Csg::new(vec![
            shared(&t, 0.0),
            shared(&t, 0.0),
            CsgNode::Op {
                op: CsgOp::Union,
                a: 0,
                b: 1,
            },
        ]);
        assert_eq!(more, Err(CsgError::TooLarge(1 << 31)));
    }

    #[test]
    fn twins_are_traced_once_and_hit_what_copies_hit() {
        // Each level: an operation on the level below and itself (twins), or on the level
        // below and a copy of it in another allocation (traced twice). Coincident surfaces are
        // a degenerate case for CSG, but twins must give exactly what copies give.
        let walk_from = |c: &Csg, o: Point3, d: Vec3| {
            let mut out = vec![];
            let mut r = Ray::new(o, d);
            while let Some(h) = c.intersect(&r) {
                let g = c.geometry(&r, &h);
                out.push((h.t, h.leaf, c.props(&h).material, g.n));
                r.tmin = h.t;
            }
            out
        };
        let mut hits = 0;
        for ops in [
            [CsgOp::Union, CsgOp::Fusion, CsgOp::Union],
            [CsgOp::Intersection, CsgOp::Union, CsgOp::Fusion],
            [CsgOp::Difference, CsgOp::Union, CsgOp::Intersection],
        ] {
            let (mut twin, mut copy) = (Arc::new(two(CsgOp::Union)), Arc::new(two(CsgOp::Union)));
            for level in 0..14 {
                let op = ops[level % 3];
                let pair = |a: &Arc<Csg>, b: &Arc<Csg>| {
                    Arc::new(
                        Csg::new(vec![
                            shared(a, 0.0),
                            shared(b, 0.0),
                            CsgNode::Op { op, a: 0, b: 1 },
                        ])
                        .unwrap(),
                    )
                };
                twin = pair(&twin, &twin);
                copy = pair(&copy, &Arc::new((*copy).clone()));
                assert!(twin.twins[2] && !copy.twins[2]);
            }
            assert_eq!(twin.leaves(), 1 << 15);
            for (o, d) in [
                (Point3::new(-5.0, 0.0, 0.0), Vec3::X),
                (Point3::new(0.5, 0.0, 0.0), -Vec3::X),
                (Point3::new(0.5, -3.0, 0.2), Vec3::new(0.1, 1.0, 0.05)),
                (Point3::new(3.0, 2.0, 1.0), Vec3::new(-1.0, -0.8, -0.5)),
            ] {
                let w = walk_from(&twin, o, d);
                assert_eq!(w, walk_from(&copy, o, d), "{ops:?}");
                hits += w.len();
            }
        }
        assert!(hits >= 3, "{hits}");
    }
}
