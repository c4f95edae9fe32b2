//! Bounding volume hierarchy: binned SAH build, flattened depth-first into 32-byte nodes.
//!
//! Build: the primitives' boxes and centroids are binned (16 bins on each axis) and the split
//! of lowest surface-area-heuristic cost is kept, or a leaf when that is cheaper (Wald 2007;
//! pbrt-v4 §7.3). Subtrees of more than [`PARALLEL_THRESHOLD`] primitives are built in parallel;
//! each subtree is emitted depth-first with the offset of its second child stored *relative* to
//! the node, so subtrees built apart are concatenated without fix-ups. Primitive ids are
//! reordered into leaf order.
//!
//! Traversal: near child first along the split axis, with a fixed stack; shadow rays stop at the
//! first hit. Candidate hits at the current closest `t` are still tested (the ray's `tmax` is
//! one ULP above it) so that ties go to the smaller primitive id, exactly as in the list.

use super::{closest, BuildPrim};
use crate::interaction::Hit;
use crate::math::{Bounds3, Ray, GAMMA3};
use crate::scene::Geometry;
use crate::shape::ShearedRay;
use crate::stats::RayStats;

/// Subtrees larger than this are built on separate threads.
pub const PARALLEL_THRESHOLD: usize = 4096;
const BINS: usize = 16;
const MAX_LEAF: usize = 8;
/// Cost of visiting a node relative to one primitive test.
const TRAVERSAL_COST: f32 = 0.5;
const STACK: usize = 64;

/// A node: bounds, and either the first primitive of a leaf or the relative offset of the
/// second child (the first child follows the node).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct BvhNode {
    /// min x, y, z, then max x, y, z.
    bounds: [f32; 6],
    offset: u32,
    count: u16,
    axis: u8,
    _pad: u8,
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);

/// A binned-SAH BVH over the bounded primitives of a geometry.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    prims: Vec<u32>,
}

impl Bvh {
    /// Builds over `prims` (boxes, centroids and ids).
    pub fn build(mut prims: Vec<BuildPrim>) -> Self {
        if prims.is_empty() {
            return Self::default();
        }
        let nodes = build_range(&mut prims, 0);
        Self {
            nodes,
            prims: prims.iter().map(|p| p.id).collect(),
        }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Memory used by nodes and the primitive order, in bytes.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<BvhNode>() + self.prims.len() * 4
    }

    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        let sr = ShearedRay::new(ray);
        let mut r = *ray;
        let mut best: Option<Hit> = None;
        let mut tests = 0u64;
        let visited = self.traverse(ray, |prims, tmax| {
            for &id in prims {
                tests += 1;
                if let Some(h) = geometry.intersect_prim(id, &r, &sr) {
                    if closest(&mut best, h) {
                        r.tmax = h.t.next_up();
                        *tmax = r.tmax;
                    }
                }
            }
            false
        });
        stats.nodes += visited;
        stats.prim_tests += tests;
        best
    }

    /// True when any primitive is hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        let sr = ShearedRay::new(ray);
        let mut tests = 0u64;
        let mut found = false;
        let visited = self.traverse(ray, |prims, _| {
            found = prims.iter().any(|&id| {
                tests += 1;
                geometry.intersect_prim(id, ray, &sr).is_some()
            });
            found
        });
        stats.nodes += visited;
        stats.prim_tests += tests;
        found
    }

    /// Visits the leaves whose boxes the ray crosses, near child first, calling `leaf` with the
    /// leaf's primitives and the current far end of the ray (which `leaf` may shorten); stops
    /// when `leaf` returns true. Returns the number of nodes visited.
    #[inline(always)]
    fn traverse(&self, ray: &Ray, mut leaf: impl FnMut(&[u32], &mut f32) -> bool) -> u64 {
        if self.nodes.is_empty() {
            return 0;
        }
        let rd = RayData::new(ray);
        let mut tmax = ray.tmax;
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut node = 0usize;
        let mut visited = 0u64;
        loop {
            let n = &self.nodes[node];
            visited += 1;
            if rd.hits(n, ray.tmin, tmax) {
                if n.count > 0 {
                    let first = n.offset as usize;
                    if leaf(&self.prims[first..first + n.count as usize], &mut tmax) {
                        return visited;
                    }
                } else {
                    let second = (node + n.offset as usize) as u32;
                    if rd.neg[n.axis as usize] {
                        stack[sp] = node as u32 + 1;
                        node = second as usize;
                    } else {
                        stack[sp] = second;
                        node += 1;
                    }
                    sp += 1;
                    continue;
                }
            }
            if sp == 0 {
                return visited;
            }
            sp -= 1;
            node = stack[sp] as usize;
        }
    }
}

/// A ray prepared for slab tests: origin, inverse direction, and for each axis the index in a
/// node's `bounds` of the plane crossed first (`near`) and last (`far`).
struct RayData {
    o: [f32; 3],
    inv: [f32; 3],
    near: [usize; 3],
    far: [usize; 3],
    neg: [bool; 3],
}

impl RayData {
    #[inline(always)]
    fn new(r: &Ray) -> Self {
        let inv = [1.0 / r.d.x, 1.0 / r.d.y, 1.0 / r.d.z];
        let neg = [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0];
        let near = [neg[0] as usize * 3, 1 + neg[1] as usize * 3, 2 + neg[2] as usize * 3];
        Self {
            o: [r.o.x, r.o.y, r.o.z],
            inv,
            near,
            far: [3 - near[0], 5 - near[1], 7 - near[2]],
            neg,
        }
    }

    /// The slab test of a node's box against `[tmin, tmax]` (pbrt's robust version: the far
    /// distance grows by 2γ₃ to cover round-off). The comparisons are written so that a NaN
    /// (0·∞ on a slab boundary) never narrows the interval, and compile to plain min/max.
    #[inline(always)]
    fn hits(&self, n: &BvhNode, tmin: f32, tmax: f32) -> bool {
        let b = &n.bounds;
        let mut t0 = tmin;
        let mut t1 = tmax;
        for a in 0..3 {
            let tn = (b[self.near[a]] - self.o[a]) * self.inv[a];
            let tf = (b[self.far[a]] - self.o[a]) * self.inv[a];
            t0 = if tn > t0 { tn } else { t0 };
            t1 = if tf < t1 { tf } else { t1 };
        }
        t0 <= t1 * (1.0 + 2.0 * GAMMA3)
    }
}

/// Builds the subtree over `prims` (whose first element has index `base` in the final
/// primitive order), depth-first.
fn build_range(prims: &mut [BuildPrim], base: usize) -> Vec<BvhNode> {
    let bounds = prims.iter().fold(Bounds3::EMPTY, |b, p| b.union(p.bounds));
    let leaf = |prims: &[BuildPrim]| {
        vec![node(bounds, base as u32, prims.len() as u16, 0)]
    };
    let n = prims.len();
    if n == 1 {
        return leaf(prims);
    }
    let cb = prims.iter().fold(Bounds3::EMPTY, |b, p| b.union_point(p.centroid));
    let Some((axis, split)) = best_split(prims, &cb, &bounds) else {
        if n <= MAX_LEAF {
            return leaf(prims);
        }
        // All centroids coincide or no split helps but the leaf is too big: halve by count.
        let axis = cb.max_extent();
        prims.select_nth_unstable_by(n / 2, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
        return join(prims, base, n / 2, bounds, axis as u8);
    };
    let mid = partition(prims, |p| bin_of(p.centroid[axis], &cb, axis) < split);
    if mid == 0 || mid == n {
        let axis = cb.max_extent();
        prims.select_nth_unstable_by(n / 2, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
        return join(prims, base, n / 2, bounds, axis as u8);
    }
    join(prims, base, mid, bounds, axis as u8)
}

/// An interior node over `prims[..mid]` and `prims[mid..]`, built in parallel when large.
fn join(prims: &mut [BuildPrim], base: usize, mid: usize, bounds: Bounds3, axis: u8) -> Vec<BvhNode> {
    let large = prims.len() > PARALLEL_THRESHOLD;
    let (left, right) = prims.split_at_mut(mid);
    let (l, r) = if large {
        rayon::join(|| build_range(left, base), || build_range(right, base + mid))
    } else {
        (build_range(left, base), build_range(right, base + mid))
    };
    let mut nodes = Vec::with_capacity(1 + l.len() + r.len());
    nodes.push(node(bounds, 1 + l.len() as u32, 0, axis));
    nodes.extend(l);
    nodes.extend(r);
    nodes
}

fn node(b: Bounds3, offset: u32, count: u16, axis: u8) -> BvhNode {
    BvhNode {
        bounds: [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z],
        offset,
        count,
        axis,
        _pad: 0,
    }
}

#[inline]
fn bin_of(c: f32, cb: &Bounds3, axis: usize) -> usize {
    let (lo, hi) = (cb.min[axis], cb.max[axis]);
    let b = (BINS as f32 * (c - lo) / (hi - lo)) as usize;
    b.min(BINS - 1)
}

/// The split (axis, first bin of the right side) of lowest SAH cost, or `None` when a leaf is
/// cheaper (and allowed) or no axis has extent.
fn best_split(prims: &[BuildPrim], cb: &Bounds3, bounds: &Bounds3) -> Option<(usize, usize)> {
    let n = prims.len();
    let area = bounds.surface_area();
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if cb.max[axis] <= cb.min[axis] {
            continue;
        }
        let mut count = [0u32; BINS];
        let mut bb = [Bounds3::EMPTY; BINS];
        for p in prims {
            let b = bin_of(p.centroid[axis], cb, axis);
            count[b] += 1;
            bb[b] = bb[b].union(p.bounds);
        }
        // Sweep from the right to get the right-hand areas and counts of each split.
        let mut right_area = [0f32; BINS];
        let mut right_count = [0u32; BINS];
        let (mut acc, mut c) = (Bounds3::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = acc.union(bb[i]);
            c += count[i];
            right_area[i] = acc.surface_area();
            right_count[i] = c;
        }
        let (mut acc, mut c) = (Bounds3::EMPTY, 0);
        for i in 1..BINS {
            acc = acc.union(bb[i - 1]);
            c += count[i - 1];
            if c == 0 || right_count[i] == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST + (c as f32 * acc.surface_area() + right_count[i] as f32 * right_area[i]) / area;
            if cost < best.0 {
                best = (cost, axis, i);
            }
        }
    }
    if !best.0.is_finite() {
        return None;
    }
    if n <= MAX_LEAF && n as f32 <= best.0 {
        return None;
    }
    Some((best.1, best.2))
}

/// Reorders so that elements satisfying `pred` come first; returns how many do.
fn partition(prims: &mut [BuildPrim], pred: impl Fn(&BuildPrim) -> bool) -> usize {
    let mut i = 0;
    for j in 0..prims.len() {
        if pred(&prims[j]) {
            prims.swap(i, j);
            i += 1;
        }
    }
    i
}

