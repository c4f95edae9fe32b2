//! Two-level ray tracing of instances: each shared group of shapes has its own acceleration
//! structure (the bottom level, built once however often the group is placed), and a binary
//! BVH over the instances' world boxes (the top level) finds the instances a ray may hit.
//!
//! A ray is brought into an instance's group space by the inverse placement (origin and
//! direction, not renormalised, so the ray parameter `t` is the same in both spaces) and traced
//! through the group's structure; the closest hit keeps the instance's primitive id in
//! [`Hit::prim`] and the group's primitive in [`Hit::inner`], and
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
        let groups = geometry
            .groups()
            .iter()
            .map(|g| Accel::build(kind, g))
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
                    inner: h.prim,
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
