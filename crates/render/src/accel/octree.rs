//! Octree (`--accel octree`): a cube around the scene, split recursively into eight octants.
//!
//! Build: the root is the cube around the scene's box (grown by the
//! margin (`accel::margin`)). A node holding more than [`MAX_LEAF`] primitives is split at its
//! centre into eight octants, down to [`MAX_DEPTH`]; a primitive goes into every octant its box
//! (grown by the margin) overlaps, boundaries included. A split whose octants would hold
//! [`DUPLICATION_LIMIT`] times the node's primitives or more (large, overlapping or identical
//! primitives) is not made: it would multiply references without separating them. Nodes are 8 bytes; the eight
//! children of a node are stored together, so a node keeps the index of its first child only.
//! Leaf primitive lists are stored in CSR form (offset and count into one array).
//!
//! Traversal: front to back with a fixed stack, in the spirit of the parametric algorithm of
//! Revelles, Ureña and Lastra ("An Efficient Parametric Algorithm for Octree Traversal", WSCG
//! 2000): at an interior node the ray parameters of the three mid-planes are computed, the
//! octant holding the ray at its entry is found from them, and each mid-plane crossed inside the
//! node's interval flips one bit of the octant; the octants so visited are pushed far to near
//! with their parameter intervals. Empty octants are skipped. A hit found in an octant may lie
//! in a later one, so traversal stops only at a node entered beyond
//! `t_limit` of the best hit; shadow rays stop at the first hit.

use super::prims::{inflate, margin, union_bounds, BuildPrim};
use super::visit::{clip, inv_dir, t_limit, AnyVisitor, CellVisitor, ClosestVisitor};
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Bounds3, Point3, Ray};
use crate::stats::RayStats;

/// A node is split when it holds more primitives than this.
pub const MAX_LEAF: usize = 8;
/// Largest depth (the root has depth 0).
pub const MAX_DEPTH: u32 = 12;
/// A node is not split when its octants would hold this many times its primitives.
pub const DUPLICATION_LIMIT: usize = 4;
const STACK: usize = 64;
// Each interior node pops one entry and pushes at most four.
const _: () = assert!(3 * MAX_DEPTH as usize + 4 <= STACK);

const INTERIOR: u32 = u32::MAX;

/// A node: an interior node holds the index of its first child (the eight children are
/// consecutive, octant `i` has bit `a` set when it is the upper half on axis `a`); a leaf holds
/// the offset and count of its primitive list.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct OctreeNode {
    first: u32,
    count: u32,
}

impl OctreeNode {
    #[inline(always)]
    fn is_interior(self) -> bool {
        self.count == INTERIOR
    }

    #[inline(always)]
    fn is_empty_leaf(self) -> bool {
        self.count == 0
    }
}

const _: () = assert!(std::mem::size_of::<OctreeNode>() == 8);

/// An octree over the bounded primitives of a geometry.
#[derive(Clone, Debug, Default)]
pub struct Octree {
    /// Lower corner of the root cube.
    min: [f32; 3],
    /// Side of the root cube.
    size: f32,
    nodes: Vec<OctreeNode>,
    prims: Vec<u32>,
}

/// A cube: its lower corner and side.
#[derive(Clone, Copy, Debug)]
struct Cube {
    min: [f32; 3],
    size: f32,
}

impl Cube {
    #[inline(always)]
    fn half(self) -> f32 {
        self.size * 0.5
    }

    /// The centre (computed identically by the build and the traversal).
    #[inline(always)]
    fn centre(self) -> [f32; 3] {
        let h = self.half();
        self.min.map(|m| m + h)
    }

    #[inline(always)]
    fn octant(self, i: usize) -> Cube {
        let c = self.centre();
        Cube {
            min: std::array::from_fn(|a| if i >> a & 1 == 1 { c[a] } else { self.min[a] }),
            size: self.half(),
        }
    }

    fn bounds(self) -> Bounds3 {
        let min = Point3::from_array(self.min);
        Bounds3 {
            min,
            max: Point3::from_array(self.min.map(|m| m + self.size)),
        }
    }
}

struct Builder<'a> {
    boxes: &'a [Bounds3],
    ids: &'a [u32],
    nodes: Vec<OctreeNode>,
    prims: Vec<u32>,
}

impl Builder<'_> {
    /// Fills node `node` (already allocated) for the primitives `list` inside `cube`.
    fn build(&mut self, node: usize, cube: Cube, list: Vec<u32>, depth: u32) {
        let n = list.len();
        if n > MAX_LEAF && depth < MAX_DEPTH {
            let c = cube.centre();
            let mut children: [Vec<u32>; 8] = Default::default();
            for &p in &list {
                let b = &self.boxes[p as usize];
                // Inclusive overlap of the lower and upper halves on each axis.
                let lo: [bool; 3] = std::array::from_fn(|a| b.min[a] <= c[a]);
                let hi: [bool; 3] = std::array::from_fn(|a| b.max[a] >= c[a]);
                for (i, child) in children.iter_mut().enumerate() {
                    if (0..3).all(|a| if i >> a & 1 == 1 { hi[a] } else { lo[a] }) {
                        child.push(p);
                    }
                }
            }
            // Splitting pays while the primitives are small against the octants; when they
            // span most of them (large or identical primitives) it only multiplies references.
            let refs: usize = children.iter().map(Vec::len).sum();
            if refs < DUPLICATION_LIMIT * n {
                drop(list);
                let first = self.nodes.len();
                self.nodes[node] = OctreeNode {
                    first: first as u32,
                    count: INTERIOR,
                };
                self.nodes.resize(first + 8, OctreeNode::default());
                for (i, ch) in children.into_iter().enumerate() {
                    self.build(first + i, cube.octant(i), ch, depth + 1);
                }
                return;
            }
        }
        self.nodes[node] = OctreeNode {
            first: self.prims.len() as u32,
            count: n as u32,
        };
        self.prims
            .extend(list.iter().map(|&p| self.ids[p as usize]));
    }
}

/// One entry of the traversal stack: a node, its cube and its parameter interval.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    t0: f32,
    t1: f32,
    cube: Cube,
}

impl Octree {
    /// Builds over `prims` (boxes and ids).
    pub fn build(prims: &[BuildPrim]) -> Self {
        if prims.is_empty() {
            return Self::default();
        }
        let scene = union_bounds(prims);
        let m = margin(&scene);
        let boxes: Vec<Bounds3> = prims.iter().map(|p| inflate(p.bounds, m)).collect();
        let ids: Vec<u32> = prims.iter().map(|p| p.id).collect();
        // The cube from the lower corner of the grown scene box, with its largest side (the
        // primitives' grown boxes stay a margin inside it).
        let grown = inflate(scene, 2.0 * m);
        let d = grown.diagonal();
        let root = Cube {
            min: grown.min.to_array(),
            size: d.x.max(d.y).max(d.z),
        };
        let mut b = Builder {
            boxes: &boxes,
            ids: &ids,
            nodes: vec![OctreeNode::default()],
            prims: Vec::with_capacity(prims.len()),
        };
        b.build(0, root, (0..prims.len() as u32).collect(), 0);
        Self {
            min: root.min,
            size: root.size,
            nodes: b.nodes,
            prims: b.prims,
        }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of primitive references in the leaves.
    pub fn reference_count(&self) -> usize {
        self.prims.len()
    }

    /// Memory used by nodes and leaf lists, in bytes.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<OctreeNode>() + self.prims.len() * 4
    }

    fn root(&self) -> Cube {
        Cube {
            min: self.min,
            size: self.size,
        }
    }

    /// Visits the leaves pierced by `ray` front to back while `v` wants to go on; returns the
    /// number of nodes visited.
    #[inline(always)]
    fn traverse(&self, ray: &Ray, v: &mut impl CellVisitor) -> u64 {
        if self.nodes.is_empty() {
            return 0;
        }
        let inv = inv_dir(ray.d);
        let root = self.root();
        let Some((t0, t1)) = clip(&root.bounds(), ray, inv) else {
            return 0;
        };
        let o = [ray.o.x, ray.o.y, ray.o.z];
        let inv = [inv.x, inv.y, inv.z];
        let pos = [ray.d.x > 0.0, ray.d.y > 0.0, ray.d.z > 0.0];
        let par = [ray.d.x == 0.0, ray.d.y == 0.0, ray.d.z == 0.0];
        let mut stack = [Entry {
            node: 0,
            t0,
            t1: t_limit(t1),
            cube: root,
        }; STACK];
        let mut sp = 1;
        let mut visited = 0u64;
        while sp > 0 {
            sp -= 1;
            let e = stack[sp];
            // Entries are popped in order of their entry parameter.
            if !(e.t0 <= v.limit()) {
                break;
            }
            visited += 1;
            let n = self.nodes[e.node as usize];
            if !n.is_interior() {
                let first = n.first as usize;
                if !v.cell(&self.prims[first..first + n.count as usize]) {
                    break;
                }
                continue;
            }
            let c = e.cube.centre();
            // Mid-plane parameters, the octant at t0, and the crossings inside (t0, t1).
            let mut tm = [f32::INFINITY; 3];
            let mut oct = 0usize;
            for a in 0..3 {
                let upper = if par[a] {
                    o[a] >= c[a]
                } else {
                    // An origin on the plane crosses it at 0 (never 0·∞ = NaN).
                    tm[a] = if c[a] == o[a] {
                        0.0
                    } else {
                        (c[a] - o[a]) * inv[a]
                    };
                    if pos[a] {
                        e.t0 >= tm[a]
                    } else {
                        e.t0 < tm[a]
                    }
                };
                oct |= (upper as usize) << a;
            }
            let mut cross = [(f32::INFINITY, 0usize); 3];
            let mut k = 0;
            for a in 0..3 {
                if tm[a] > e.t0 && tm[a] < e.t1 {
                    cross[k] = (tm[a], a);
                    k += 1;
                }
            }
            cross[..k].sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
            // Octants in order with their intervals; push far to near.
            let mut seq = [(0usize, 0f32, 0f32); 4];
            let mut t = e.t0;
            for (i, &(tc, a)) in cross[..k].iter().enumerate() {
                seq[i] = (oct, t, tc);
                oct ^= 1 << a;
                t = tc;
            }
            seq[k] = (oct, t, e.t1);
            for &(o, ta, tb) in seq[..=k].iter().rev() {
                let child = n.first + o as u32;
                if self.nodes[child as usize].is_empty_leaf() {
                    continue;
                }
                stack[sp] = Entry {
                    node: child,
                    t0: ta,
                    t1: tb,
                    cube: e.cube.octant(o),
                };
                sp += 1;
            }
        }
        visited
    }

    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        ClosestVisitor::run(geometry, ray, stats, |v| self.traverse(ray, v))
    }

    /// True when any primitive is hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        AnyVisitor::run(geometry, ray, stats, |v| self.traverse(ray, v))
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_scenes::{self, agrees_with_list, row, triangles};
    use super::*;
    use crate::math::Vec3;

    fn octree(g: &Geometry) -> Octree {
        Octree::build(&crate::accel::build_prims(g))
    }

    #[test]
    fn splits_and_finds_triangles_in_different_octants() {
        let g = triangles(&row(40));
        let o = octree(&g);
        assert!(o.node_count() > 1);
        let mut st = RayStats::default();
        let r = Ray::new(Point3::new(30.1, 0.1, 2.0), -Vec3::Z);
        let h = o.intersect(&g, &r, &mut st).unwrap();
        assert_eq!((h.prim, h.t), (30, 2.0));
        // Along the row, just above it: misses everything.
        assert!(o
            .intersect(&g, &Ray::new(Point3::new(-1.0, 0.1, 0.1), Vec3::X), &mut st)
            .is_none());
        assert!(st.nodes > 0 && st.prim_tests > 0);
        agrees_with_list(&g, &o);
    }

    #[test]
    fn flat_primitives_rays_inside_and_parallel() {
        test_scenes::flat_primitives_rays_inside_and_parallel(octree);
    }

    #[test]
    fn a_primitive_spanning_many_octants_is_found_at_the_nearer_one() {
        test_scenes::a_long_primitive_in_front_of_a_row(octree, 40, Octree::reference_count);
    }

    #[test]
    fn empty_single_and_identical() {
        test_scenes::empty_single_and_identical(octree, &[1, 9, 300]);
    }
}
