//! kd-tree (`--accel kdtree`): axis-aligned splitting planes chosen by the surface area
//! heuristic, after pbrt-v3's `KdTreeAccel` (Pharr, Jakob, Humphreys, *Physically Based
//! Rendering*, 3rd ed., §4.4).
//!
//! Build: a node over `n` primitives becomes a leaf when `n ≤ MAX_PRIMS` or at the depth limit
//! `8 + 1.3·log₂ N`. Otherwise the split of lowest cost
//!
//! C = C_trav + C_isect · (1 − b_e) · (P_L · N_L + P_R · N_R),
//!
//! is sought, where P_{L,R} are the ratios of the children's surface areas to the node's,
//! N_{L,R} the primitives on each side and b_e the empty bonus when a side is empty (costs:
//! isect 80, traversal 1, empty bonus 0.5). Nodes of at most [`SWEEP_MAX`] primitives sweep the
//! sorted box edges exactly (pbrt: the axis of largest extent first, the others only when it
//! has no candidate); larger nodes bin the edges into [`BINS`] intervals on each of the three
//! axes (binned SAH: O(N) per node, so the build is O(N log N) and stays fast at millions of
//! triangles; pbrt's exact sweep re-sorts at every node). As in pbrt, a split that costs more
//! than a leaf is tolerated twice on a path ("bad refines"), and a node is a leaf when no plane
//! lies strictly inside it. Classification is exact, as in pbrt: a primitive goes below when
//! its box starts before the plane, above when it ends after it (both when it straddles; a box
//! lying in the plane goes below), so triangles that only touch the plane at a shared vertex are
//! not duplicated. Subtrees of more than [`PARALLEL_THRESHOLD`] primitives are built in
//! parallel.
//!
//! Layout: 8-byte nodes as in pbrt: an interior node holds the split position, the axis and the
//! offset of its above child relative to the node (the below child follows the node); a leaf
//! holds its primitive count and either the one primitive's id or an offset into the
//! primitive-index array.
//!
//! Traversal: front to back over the ray's interval clipped to the tree's bounds (grown by the
//! margin), with a fixed stack of the far children still to visit and their intervals (pbrt's
//! recursive interval subdivision). For exactness each splitting plane is *thick*: the child
//! below is entered over `x ≤ split + m` and the one above over `x ≥ split − m` (m the margin,
//! `accel::margin`), so a hit that round-off puts a hair outside its primitive's box, or a ray
//! that touches a plane exactly where a primitive ends, still reaches a leaf holding the
//! primitive. The child the ray is in first is visited first; the other one only when the ray
//! reaches its thickened region inside the interval. A hit found in a leaf may lie beyond it, so
//! a node entered beyond `t_limit` of the best hit is skipped (entries are only nearly ordered
//! with thick planes, so the stack is still emptied); shadow rays stop at the first hit.

use super::prims::{inflate, margin, union_bounds, BuildPrim};
use super::visit::{clip, inv_dir, AnyVisitor, CellVisitor, ClosestVisitor};
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Bounds3, Ray};
use crate::stats::RayStats;

/// Cost of a ray–primitive test.
pub const ISECT_COST: f32 = 80.0;
/// Cost of an interior node.
pub const TRAVERSAL_COST: f32 = 1.0;
/// Cost reduction of a split with an empty side.
pub const EMPTY_BONUS: f32 = 0.5;
/// Leaves are made at this many primitives or fewer.
pub const MAX_PRIMS: usize = 1;
/// Nodes with at most this many primitives sweep the exact edges; larger ones bin them.
pub const SWEEP_MAX: usize = 1024;
/// Number of bins per axis for large nodes.
pub const BINS: usize = 64;
/// Subtrees larger than this are built on separate threads.
pub const PARALLEL_THRESHOLD: usize = 32 * 1024;
const STACK: usize = 64;
/// The depth limit never exceeds this (each level pushes at most one stack entry).
const MAX_DEPTH: u32 = STACK as u32 - 2;
const LEAF: u32 = 3;

/// A node, 8 bytes: `flags` holds the axis (0–2) or 3 for a leaf in its low two bits and the
/// relative offset of the above child (interior) or the primitive count (leaf) in the others;
/// `data` holds the split position's bits (interior), the primitive's id (leaf of one) or the
/// offset of the leaf's list in the primitive-index array.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct KdNode {
    data: u32,
    flags: u32,
}

const _: () = assert!(std::mem::size_of::<KdNode>() == 8);

impl KdNode {
    fn interior(axis: usize, split: f32, above: usize) -> Self {
        assert!(above < 1 << 30, "kd-tree too large");
        Self {
            data: split.to_bits(),
            flags: axis as u32 | (above as u32) << 2,
        }
    }

    #[inline(always)]
    fn is_leaf(self) -> bool {
        self.flags & 3 == LEAF
    }

    /// The split axis (interior) or [`LEAF`].
    #[inline(always)]
    fn axis(self) -> usize {
        (self.flags & 3) as usize
    }

    #[inline(always)]
    fn split(self) -> f32 {
        f32::from_bits(self.data)
    }

    /// The above child's offset (interior) or the primitive count (leaf).
    #[inline(always)]
    fn high(self) -> u32 {
        self.flags >> 2
    }
}

/// An SAH kd-tree over the bounded primitives of a geometry.
#[derive(Clone, Debug, Default)]
pub struct KdTree {
    /// The scene's box grown by twice the margin.
    bounds: Bounds3,
    /// The margin by which traversal thickens the splitting planes.
    margin: f32,
    nodes: Vec<KdNode>,
    prims: Vec<u32>,
}

/// The grown boxes and ids, indexed by the builder's local primitive numbers.
struct Ctx<'a> {
    boxes: &'a [Bounds3],
    ids: &'a [u32],
}

/// A (sub)tree under construction: nodes depth-first, leaf lists.
#[derive(Default)]
struct Out {
    nodes: Vec<KdNode>,
    prims: Vec<u32>,
}

impl Out {
    fn leaf(&mut self, ctx: &Ctx, list: &[u32]) {
        let n = list.len();
        assert!(n < 1 << 30, "kd-tree leaf too large");
        let data = if n == 1 {
            ctx.ids[list[0] as usize]
        } else {
            let off = self.prims.len() as u32;
            self.prims.extend(list.iter().map(|&p| ctx.ids[p as usize]));
            off
        };
        self.nodes.push(KdNode {
            data,
            flags: LEAF | (n as u32) << 2,
        });
    }

    /// Appends a subtree built apart, moving its leaf-list offsets after ours.
    fn append(&mut self, o: Out) {
        let base = self.prims.len() as u32;
        self.nodes.extend(o.nodes.into_iter().map(|mut n| {
            if n.is_leaf() && n.high() > 1 {
                n.data += base;
            }
            n
        }));
        self.prims.extend(o.prims);
    }
}

/// A split candidate: cost, axis, position.
type Split = (f32, usize, f32);

impl KdTree {
    /// Builds over `prims` (boxes and ids).
    pub fn build(prims: &[BuildPrim]) -> Self {
        if prims.is_empty() {
            return Self::default();
        }
        let scene = union_bounds(prims);
        let m = margin(&scene);
        let boxes: Vec<Bounds3> = prims.iter().map(|p| p.bounds).collect();
        let ids: Vec<u32> = prims.iter().map(|p| p.id).collect();
        let depth = ((8.0 + 1.3 * (prims.len() as f32).log2()).round() as u32).min(MAX_DEPTH);
        let ctx = Ctx {
            boxes: &boxes,
            ids: &ids,
        };
        let mut out = Out::default();
        build(
            &ctx,
            &mut out,
            scene,
            (0..prims.len() as u32).collect(),
            depth,
            0,
            &mut Vec::new(),
        );
        Self {
            bounds: inflate(scene, 2.0 * m),
            margin: m,
            nodes: out.nodes,
            prims: out.prims,
        }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of primitive references in the leaves.
    pub fn reference_count(&self) -> usize {
        self.nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.high() as usize)
            .sum()
    }

    /// Largest depth of a leaf (the root has depth 0).
    pub fn depth(&self) -> usize {
        fn walk(nodes: &[KdNode], i: usize) -> usize {
            let n = nodes[i];
            if n.is_leaf() {
                0
            } else {
                1 + walk(nodes, i + 1).max(walk(nodes, i + n.high() as usize))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(&self.nodes, 0)
        }
    }

    /// Memory used by nodes and leaf lists, in bytes.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<KdNode>() + self.prims.len() * 4
    }

    /// Visits the leaves pierced by `ray` front to back while `v` wants to go on; returns the
    /// number of nodes visited.
    #[inline(always)]
    fn traverse(&self, ray: &Ray, v: &mut impl CellVisitor) -> u64 {
        if self.nodes.is_empty() {
            return 0;
        }
        let inv = inv_dir(ray.d);
        let Some((t0, t1)) = clip(&self.bounds, ray, inv) else {
            return 0;
        };
        let o = [ray.o.x, ray.o.y, ray.o.z];
        let inv = [inv.x, inv.y, inv.z];
        let pos = [ray.d.x > 0.0, ray.d.y > 0.0, ray.d.z > 0.0];
        let par = [ray.d.x == 0.0, ray.d.y == 0.0, ray.d.z == 0.0];
        let m = self.margin;
        // The parameter where the ray crosses x = p on axis a (0 when it starts there).
        let cross = |a: usize, p: f32| if p == o[a] { 0.0 } else { (p - o[a]) * inv[a] };
        let mut stack = [(0u32, 0f32, 0f32); STACK];
        let mut sp = 0;
        let (mut node, mut tmin, mut tmax) = (0usize, t0, t1);
        let mut visited = 0u64;
        loop {
            // Thick planes make entry parameters only nearly ordered: skip, do not stop.
            if tmin <= v.limit() {
                visited += 1;
                let n = self.nodes[node];
                if !n.is_leaf() {
                    let a = n.axis();
                    let split = n.split();
                    let (below, above) = (node + 1, node + n.high() as usize);
                    // Each child is entered over its region grown by the margin: below is
                    // x ≤ split + m, above is x ≥ split − m.
                    let (before, after, before_end, after_start) = if par[a] {
                        let (b, f) = (o[a] <= split + m, o[a] >= split - m);
                        (
                            below,
                            above,
                            if b { f32::INFINITY } else { f32::NEG_INFINITY },
                            if f { f32::NEG_INFINITY } else { f32::INFINITY },
                        )
                    } else if pos[a] {
                        (below, above, cross(a, split + m), cross(a, split - m))
                    } else {
                        (above, below, cross(a, split - m), cross(a, split + m))
                    };
                    let go_before = before_end >= tmin;
                    let go_after = after_start <= tmax;
                    if go_before && !go_after {
                        node = before;
                        tmax = tmax.min(before_end);
                        continue;
                    }
                    if go_after && !go_before {
                        node = after;
                        tmin = tmin.max(after_start);
                        continue;
                    }
                    // Both (or NaN: both, over the whole interval).
                    let (ta, tb) = if go_before {
                        (tmin.max(after_start), tmax.min(before_end))
                    } else {
                        (tmin, tmax)
                    };
                    stack[sp] = (after as u32, ta, tmax);
                    sp += 1;
                    node = before;
                    tmax = tb;
                    continue;
                }
                let count = n.high() as usize;
                let go_on = if count == 1 {
                    v.cell(std::slice::from_ref(&n.data))
                } else {
                    let first = n.data as usize;
                    v.cell(&self.prims[first..first + count])
                };
                if !go_on {
                    break;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            let (nn, a, b) = stack[sp];
            (node, tmin, tmax) = (nn as usize, a, b);
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

/// Builds the subtree over `list` inside `bounds` into `out`, depth-first.
fn build(
    ctx: &Ctx,
    out: &mut Out,
    bounds: Bounds3,
    list: Vec<u32>,
    depth: u32,
    bad: u32,
    scratch: &mut Vec<u64>,
) {
    let n = list.len();
    if n <= MAX_PRIMS || depth == 0 {
        out.leaf(ctx, &list);
        return;
    }
    let split = if n > SWEEP_MAX {
        binned(ctx, &bounds, &list)
    } else {
        swept(ctx, &bounds, &list, scratch)
    };
    let leaf_cost = ISECT_COST * n as f32;
    let Some((cost, axis, t)) = split else {
        out.leaf(ctx, &list);
        return;
    };
    let bad = if cost > leaf_cost { bad + 1 } else { bad };
    if (cost > 4.0 * leaf_cost && n < 16) || bad == 3 {
        out.leaf(ctx, &list);
        return;
    }
    // A box lying in the plane itself goes below.
    let below: Vec<u32> = list
        .iter()
        .copied()
        .filter(|&p| {
            let b = &ctx.boxes[p as usize];
            b.min[axis] < t || b.max[axis] <= t
        })
        .collect();
    let above: Vec<u32> = list
        .iter()
        .copied()
        .filter(|&p| ctx.boxes[p as usize].max[axis] > t)
        .collect();
    drop(list);
    let (mut bb, mut ab) = (bounds.max.to_array(), bounds.min.to_array());
    bb[axis] = t;
    ab[axis] = t;
    let below_bounds = Bounds3 {
        min: bounds.min,
        max: crate::math::Point3::from_array(bb),
    };
    let above_bounds = Bounds3 {
        min: crate::math::Point3::from_array(ab),
        max: bounds.max,
    };
    let me = out.nodes.len();
    out.nodes.push(KdNode::default());
    let above_offset = if n > PARALLEL_THRESHOLD {
        let sub = |b: Bounds3, l: Vec<u32>| {
            let mut o = Out::default();
            build(ctx, &mut o, b, l, depth - 1, bad, &mut Vec::new());
            o
        };
        let (l, r) = rayon::join(|| sub(below_bounds, below), || sub(above_bounds, above));
        out.append(l);
        let off = out.nodes.len() - me;
        out.append(r);
        off
    } else {
        build(ctx, out, below_bounds, below, depth - 1, bad, scratch);
        let off = out.nodes.len() - me;
        build(ctx, out, above_bounds, above, depth - 1, bad, scratch);
        off
    };
    out.nodes[me] = KdNode::interior(axis, t, above_offset);
}

/// The SAH cost of splitting `bounds` at `t` on `axis` with `nb` primitives below and `na`
/// above.
#[inline]
fn sah(bounds: &Bounds3, axis: usize, t: f32, nb: u32, na: u32) -> f32 {
    let d = bounds.diagonal();
    let (d0, d1) = (d[(axis + 1) % 3], d[(axis + 2) % 3]);
    let inv_area = 1.0 / bounds.surface_area();
    let below = 2.0 * (d0 * d1 + (t - bounds.min[axis]) * (d0 + d1));
    let above = 2.0 * (d0 * d1 + (bounds.max[axis] - t) * (d0 + d1));
    let eb = if nb == 0 || na == 0 { EMPTY_BONUS } else { 0.0 };
    TRAVERSAL_COST
        + ISECT_COST * (1.0 - eb) * (below * inv_area * nb as f32 + above * inv_area * na as f32)
}

/// The cheapest split seen so far.
struct Cheapest {
    cost: f32,
    split: Option<Split>,
}

impl Cheapest {
    fn new() -> Self {
        Self {
            cost: f32::INFINITY,
            split: None,
        }
    }

    /// Considers the plane at `t` on `axis` with `nb` primitives below and `na` above, when it
    /// lies strictly inside `bounds`.
    #[inline]
    fn consider(&mut self, bounds: &Bounds3, axis: usize, t: f32, nb: u32, na: u32) {
        if t > bounds.min[axis] && t < bounds.max[axis] {
            let cost = sah(bounds, axis, t, nb, na);
            if cost < self.cost {
                self.cost = cost;
                self.split = Some((cost, axis, t));
            }
        }
    }
}

/// A sort key ordering edges by position, starts before ends at the same position.
#[inline]
fn edge_key(t: f32, end: bool) -> u64 {
    let b = t.to_bits();
    let ordered = if b >> 31 == 1 { !b } else { b | 1 << 31 };
    (ordered as u64) << 1 | end as u64
}

#[inline]
fn edge_pos(key: u64) -> f32 {
    let ordered = (key >> 1) as u32;
    f32::from_bits(if ordered >> 31 == 1 {
        ordered & !(1 << 31)
    } else {
        !ordered
    })
}

/// The best split by an exact sweep over the sorted edges (pbrt-v3): the axis of largest
/// extent first, the next ones only when it has no plane strictly inside the node.
fn swept(ctx: &Ctx, bounds: &Bounds3, list: &[u32], edges: &mut Vec<u64>) -> Option<Split> {
    let n = list.len() as u32;
    let mut axis = bounds.max_extent();
    for _ in 0..3 {
        edges.clear();
        for &p in list {
            let b = &ctx.boxes[p as usize];
            edges.push(edge_key(b.min[axis], false));
            edges.push(edge_key(b.max[axis], true));
        }
        edges.sort_unstable();
        let mut best = Cheapest::new();
        let (mut nb, mut na) = (0u32, n);
        for &e in edges.iter() {
            let end = e & 1 == 1;
            let t = edge_pos(e);
            if end {
                na -= 1;
            }
            best.consider(bounds, axis, t, nb, na);
            if !end {
                nb += 1;
            }
        }
        if best.split.is_some() {
            return best.split;
        }
        axis = (axis + 1) % 3;
    }
    None
}

/// The best split among the boundaries of [`BINS`] equal intervals on each axis, from the
/// counts of box starts and ends per interval.
fn binned(ctx: &Ctx, bounds: &Bounds3, list: &[u32]) -> Option<Split> {
    let n = list.len() as u32;
    let mut best = Cheapest::new();
    for axis in 0..3 {
        let (lo, hi) = (bounds.min[axis], bounds.max[axis]);
        if !(hi > lo) {
            continue;
        }
        let scale = BINS as f32 / (hi - lo);
        let bin = |x: f32| (((x - lo) * scale) as i64).clamp(0, BINS as i64 - 1) as usize;
        let mut starts = [0u32; BINS];
        let mut ends = [0u32; BINS];
        for &p in list {
            let b = &ctx.boxes[p as usize];
            starts[bin(b.min[axis])] += 1;
            ends[bin(b.max[axis])] += 1;
        }
        let (mut nb, mut na) = (0u32, n);
        for i in 1..BINS {
            nb += starts[i - 1];
            na -= ends[i - 1];
            let t = lo + (hi - lo) * (i as f32 / BINS as f32);
            best.consider(bounds, axis, t, nb, na);
        }
    }
    best.split
}

#[cfg(test)]
mod tests {
    use super::super::test_scenes::{self, agrees_with_list, triangles};
    use super::*;
    use crate::math::{Point3, Vec3};

    fn kdtree(g: &Geometry) -> KdTree {
        KdTree::build(&crate::accel::build_prims(g))
    }

    #[test]
    fn edge_keys_sort_like_positions() {
        let xs = [-3.5f32, -0.0, 0.0, 1e-30, 2.0, f32::MAX, -f32::MAX];
        for &a in &xs {
            assert_eq!(edge_pos(edge_key(a, true)).to_bits(), a.to_bits());
            for &b in &xs {
                if a < b {
                    assert!(edge_key(a, true) < edge_key(b, false));
                }
            }
            assert!(edge_key(a, false) < edge_key(a, true));
        }
    }

    #[test]
    fn two_triangles_are_split_apart() {
        let g = test_scenes::two_triangles();
        let k = kdtree(&g);
        assert!(k.node_count() >= 3);
        assert_eq!(k.reference_count(), 2);
        let mut st = RayStats::default();
        let h = k
            .intersect(&g, &Ray::new(Point3::new(9.2, 0.2, 5.0), -Vec3::Z), &mut st)
            .unwrap();
        assert_eq!((h.prim, h.t), (1, 4.0));
        // Through both, along x at their height: the first is hit from behind the second.
        let r = Ray::new(Point3::new(20.0, 0.2, 0.0), Vec3::new(-1.0, 0.0, 0.05));
        assert_eq!(
            k.intersect(&g, &r, &mut st),
            crate::accel::List::new(&g).intersect(&g, &r, &mut st)
        );
        assert!(st.nodes > 0 && st.prim_tests > 0);
        agrees_with_list(&g, &k);
    }

    #[test]
    fn flat_primitives_rays_inside_and_parallel() {
        test_scenes::flat_primitives_rays_inside_and_parallel(kdtree);
    }

    #[test]
    fn a_primitive_spanning_many_leaves_is_found_at_the_nearer_one() {
        test_scenes::a_long_primitive_in_front_of_a_row(kdtree, 60, KdTree::reference_count);
    }

    #[test]
    fn large_nodes_use_bins_and_agree() {
        // More than SWEEP_MAX triangles on a sphere-like shell.
        let mut tris = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let (u, v) = (
                    i as f32 / 40.0 * std::f32::consts::TAU,
                    j as f32 / 40.0 * 3.1,
                );
                let p = |u: f32, v: f32| {
                    Point3::new(
                        3.0 * u.cos() * v.sin(),
                        3.0 * u.sin() * v.sin(),
                        3.0 * v.cos(),
                    )
                };
                tris.push([p(u, v), p(u + 0.16, v), p(u, v + 0.08)]);
            }
        }
        assert!(tris.len() > SWEEP_MAX);
        let g = triangles(&tris);
        let k = kdtree(&g);
        assert!(
            k.depth() > 8 && k.depth() <= 8 + (1.3 * (tris.len() as f32).log2()).round() as usize
        );
        agrees_with_list(&g, &k);
    }

    #[test]
    fn empty_single_and_identical() {
        test_scenes::empty_single_and_identical(kdtree, &[1, 2, 300]);
    }
}
