//! Bounding volume hierarchy: an 8-wide tree built by binned SAH, with triangles stored in leaf
//! order, four to a block.
//!
//! Layout: a node holds the boxes of its eight children in structure-of-arrays form (`b[plane]
//! [child]`, planes min x, y, z then max x, y, z) and a reference per child: an inner node's
//! index, or a leaf (its kind, its primitive count and where its data starts), 256 bytes in all.
//! Triangle leaves point into [`Tri4`] blocks that hold exact copies of the vertex positions of
//! four triangles (one lane each) with their primitive ids, 160 bytes; other leaves point into
//! the list of primitive ids in leaf order and go through [`Geometry::intersect_prim`]. A leaf
//! is never mixed. Unused child slots hold an inverted box and an empty leaf, so that even a
//! NaN ray, which "hits" every box, only visits real nodes.
//!
//! Build (Wald 2007; Embree): primitives are binned by centroid ([`BINS`] bins on each axis) and
//! the split of lowest surface-area cost is taken, or a leaf when that is cheaper (cost of a
//! triangle range: its number of 4-blocks; of other primitives: [`OBJ_COST`] each; of a node:
//! [`TRAVERSAL_COST`]). A node is widened by splitting its child of largest area until it has
//! eight. Subtrees of more than [`PARALLEL_THRESHOLD`] primitives are built in parallel, each
//! into its own node array that the parent appends (inner references shifted); binning of large
//! ranges is parallel too; build records are 32 bytes and partitioned in place (no allocation
//! per node). Below [`MEDIAN_DEPTH`] splits are by count, which bounds the depth and so the
//! traversal stack (one per thread, kept between rays).
//!
//! Traversal: the eight boxes of a node are tested at once ([`crate::simd`]: one AVX register,
//! or two SSE ones), hit children are visited nearest entry first with the others on the stack
//! with their entry distance; entries beyond the current closest hit are dropped when popped.
//! Shadow rays take the nearest hit child next and the others in any order, and stop at the
//! first hit. Every child about to be visited or pushed is prefetched, all of it (the four
//! cache lines of a node, every block of a leaf), so that its lines load at once rather than
//! one after another as the box test, then the child references, reach them: this matters for
//! incoherent rays, which miss the caches.
//! A block of four triangles is tested at once by the same arithmetic as
//! [`crate::shape::intersect_triangle`], lane by lane, so that `t` and the barycentrics are
//! bit-identical to [`crate::shape::Mesh::intersect`]. The ray's `tmax` is one ULP above the
//! closest hit so far, so hits at equal `t` are still tested and go to the smaller id, exactly
//! as in the list. The sheared ray of the triangle test and the reciprocal direction are
//! computed once per ray (and not at all for scenes without triangles).

use rayon::prelude::*;

use super::{closest, BuildPrim};
use crate::geometry::{Geometry, PrimRef as GeomPrim};
use crate::interaction::Hit;
use crate::math::{Ray, GAMMA3};
use crate::shape::ShearedRay;
use crate::simd::{Isa, F4};
use crate::stats::RayStats;

/// Subtrees larger than this are built on separate threads.
pub const PARALLEL_THRESHOLD: usize = 8192;
/// Ranges larger than this are binned on several threads.
const PARALLEL_BINNING: usize = 65536;
/// Number of centroid bins per axis.
const BINS: usize = 16;
/// Largest triangle leaf (four blocks).
const MAX_TRI_LEAF: usize = 16;
/// Largest leaf of other primitives.
const MAX_OBJ_LEAF: usize = 4;
/// Cost of a node visit relative to testing one block of triangles.
const TRAVERSAL_COST: f32 = 0.5;
/// Cost of testing one primitive other than a triangle.
const OBJ_COST: f32 = 2.0;
/// Children per node.
const W: usize = 8;
/// From this depth on, ranges are split by count into `W` equal parts, which bounds the depth
/// at `MEDIAN_DEPTH + 11` (for up to 2³² primitives).
const MEDIAN_DEPTH: u32 = 16;
/// Traversal stack: at most `W - 1` entries per level.
const STACK: usize = (W - 1) * (MEDIAN_DEPTH as usize + 12);

/// A reference's kind bits: 0 for an inner node.
const KIND_SHIFT: u32 = 30;
const TRI_LEAF: u32 = 1 << KIND_SHIFT;
const OBJ_LEAF: u32 = 2 << KIND_SHIFT;
const COUNT_MASK: u32 = (1 << KIND_SHIFT) - 1;

/// The far distance of a box grows by 2γ₃ (pbrt) to cover round-off.
const FAR_SCALE: f32 = 1.0 + 2.0 * GAMMA3;

/// A node of `W` children.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct BvhNode {
    /// Child boxes: `b[plane][child]`, planes min x, y, z, max x, y, z.
    b: [[f32; W]; 6],
    /// Inner child: node index; leaf: first block (triangles) or first id (others).
    child: [u32; W],
    /// 0 for an inner child; otherwise the leaf kind and its primitive count.
    meta: [u32; W],
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32 * W);

impl BvhNode {
    /// No children: inverted boxes, empty leaves.
    const EMPTY: BvhNode = BvhNode {
        b: [
            [f32::INFINITY; W],
            [f32::INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::NEG_INFINITY; W],
        ],
        child: [0; W],
        meta: [OBJ_LEAF; W],
    };

    fn set(&mut self, i: usize, b: &Aabb, r: Ref) {
        for a in 0..3 {
            self.b[a][i] = b.lo[a];
            self.b[a + 3][i] = b.hi[a];
        }
        self.child[i] = r.child;
        self.meta[i] = r.meta;
    }
}

/// Four triangles: exact copies of their vertices (`v[vertex][axis][lane]`) and their
/// primitive ids (`u32::MAX` in unused lanes).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Tri4 {
    v: [[[f32; 4]; 3]; 3],
    id: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<Tri4>() == 160);

/// A child reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Ref {
    child: u32,
    meta: u32,
}

impl Ref {
    const EMPTY: Ref = Ref {
        child: 0,
        meta: OBJ_LEAF,
    };
}

/// A 4-wide BVH over the bounded primitives of a geometry.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    root: Ref,
    tris: Vec<Tri4>,
    /// Primitive ids in leaf order (other leaves index it).
    ids: Vec<u32>,
}

impl Default for Bvh {
    fn default() -> Self {
        Self {
            nodes: Vec::new(),
            root: Ref::EMPTY,
            tris: Vec::new(),
            ids: Vec::new(),
        }
    }
}

impl Bvh {
    /// Builds over `prims` (boxes and ids) of `geometry`.
    pub fn build(geometry: &Geometry, prims: &[BuildPrim]) -> Self {
        let mut refs: Vec<PrimRef> = if prims.len() > PARALLEL_BINNING {
            prims
                .par_iter()
                .map(|p| PrimRef::new(p, geometry))
                .collect()
        } else {
            prims.iter().map(|p| PrimRef::new(p, geometry)).collect()
        };
        Self::build_refs(geometry, &mut refs)
    }

    fn build_refs(geometry: &Geometry, refs: &mut [PrimRef]) -> Self {
        if refs.is_empty() {
            return Self::default();
        }
        let info = Info::of(refs);
        let mut nodes = Vec::with_capacity(refs.len() / 4);
        let root = build_node(refs, 0, &info, 0, &mut nodes);
        let ids: Vec<u32> = refs.iter().map(|p| p.id()).collect();
        let mut bvh = Self {
            nodes,
            root,
            tris: Vec::new(),
            ids,
        };
        bvh.pack_triangles(geometry);
        bvh
    }

    /// Replaces the triangle leaves' ranges of primitive ids by blocks of four triangles, in
    /// node order.
    fn pack_triangles(&mut self, geometry: &Geometry) {
        // Each block: the first primitive (in `ids`) and how many lanes it uses.
        let mut src: Vec<(u32, u32)> = Vec::new();
        let mut pack = |r: &mut Ref| {
            if r.meta & !COUNT_MASK == TRI_LEAF {
                let n = r.meta & COUNT_MASK;
                let first = src.len() as u32;
                for k in (0..n).step_by(4) {
                    src.push((r.child + k, (n - k).min(4)));
                }
                r.child = first;
            }
        };
        pack(&mut self.root);
        for node in &mut self.nodes {
            for i in 0..W {
                let mut r = Ref {
                    child: node.child[i],
                    meta: node.meta[i],
                };
                pack(&mut r);
                node.child[i] = r.child;
            }
        }
        let ids = &self.ids;
        let fill = |&(first, lanes): &(u32, u32)| {
            let mut t = Tri4 {
                v: [[[0.0; 4]; 3]; 3],
                id: [u32::MAX; 4],
            };
            for l in 0..lanes as usize {
                let id = ids[first as usize + l];
                let GeomPrim::Triangle { mesh, tri } = geometry.prim(id) else {
                    unreachable!("a triangle leaf holds triangles only")
                };
                let vs = geometry.meshes()[mesh as usize].vertices(tri);
                for (k, p) in vs.iter().enumerate() {
                    t.v[k][0][l] = p.x;
                    t.v[k][1][l] = p.y;
                    t.v[k][2][l] = p.z;
                }
                t.id[l] = id;
            }
            // Unused lanes repeat the first triangle (finite values) and are masked by id.
            for l in lanes as usize..4 {
                for k in 0..3 {
                    for a in 0..3 {
                        t.v[k][a][l] = t.v[k][a][0];
                    }
                }
            }
            t
        };
        self.tris = if src.len() > 4096 {
            src.par_iter().map(fill).collect()
        } else {
            src.iter().map(fill).collect()
        };
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of triangle blocks.
    pub fn block_count(&self) -> usize {
        self.tris.len()
    }

    /// Memory used by nodes, triangle blocks and the primitive order, in bytes.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<BvhNode>()
            + self.tris.len() * std::mem::size_of::<Tri4>()
            + self.ids.len() * 4
    }

    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        let mut q = ClosestQuery {
            geometry,
            ray: *ray,
            tri: TriRay::new(ray, !self.tris.is_empty()),
            best: None,
            tests: 0,
        };
        let visited = self.traverse(ray, &mut q);
        stats.nodes += visited;
        stats.prim_tests += q.tests;
        q.best
    }

    /// True when any primitive is hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        let mut q = AnyQuery {
            geometry,
            ray,
            tri: TriRay::new(ray, !self.tris.is_empty()),
            tests: 0,
        };
        let visited = self.traverse(ray, &mut q);
        stats.nodes += visited & !FOUND;
        stats.prim_tests += q.tests;
        visited & FOUND != 0
    }

    /// Starts loading what `r` refers to (it will be visited later, unless culled).
    #[inline(always)]
    fn prefetch(&self, r: Ref) {
        if r.meta == 0 {
            crate::simd::prefetch(&self.nodes[r.child as usize]);
        } else if r.meta & !COUNT_MASK == TRI_LEAF {
            let first = r.child as usize;
            let n = (r.meta & COUNT_MASK).div_ceil(4) as usize;
            if let Some(ts) = self.tris.get(first..first + n) {
                for t in ts {
                    crate::simd::prefetch(t);
                }
            }
        }
    }

    /// Visits the leaves whose boxes the ray crosses, nearest child first. Returns the number
    /// of nodes visited, with [`FOUND`] set when `q` stopped the traversal.
    #[inline(always)]
    fn traverse<Q: Query>(&self, ray: &Ray, q: &mut Q) -> u64 {
        let cur = self.root;
        if cur.meta != 0 {
            return if q.leaf(self, cur) { FOUND } else { 0 };
        }
        STACK_SPACE.with(|space| match space.try_borrow_mut() {
            Ok(mut stack) => crate::simd::run(Traversal {
                bvh: self,
                ray,
                q,
                stack: &mut stack,
            }),
            // Only reached if a leaf test traced rays through a BVH itself.
            Err(_) => crate::simd::run(Traversal {
                bvh: self,
                ray,
                q,
                stack: &mut [(Ref::EMPTY, 0.0); STACK],
            }),
        })
    }

    /// [`Bvh::traverse`] from an inner root, with a stack.
    #[inline(always)]
    fn traverse_from<Q: Query, I: Isa>(
        &self,
        ray: &Ray,
        q: &mut Q,
        stack: &mut [(Ref, f32); STACK],
        isa: I,
    ) -> u64 {
        let mut cur = self.root;
        let rb = RayBox::new(ray, isa);
        let mut sp = 0usize;
        let mut visited = 0u64;
        loop {
            if cur.meta == 0 {
                // An inner node: test the children's boxes.
                visited += 1;
                let node = &self.nodes[cur.child as usize];
                let (mut mask, dist) = rb.test(node, ray.tmin, q.tmax());
                if mask != 0 {
                    let r = |i: usize| Ref {
                        child: node.child[i],
                        meta: node.meta[i],
                    };
                    let c0 = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        cur = r(c0);
                        self.prefetch(cur);
                        continue;
                    }
                    if !Q::ORDERED {
                        // The nearest next, the others on the stack in any order.
                        let mut near = c0;
                        while mask != 0 {
                            let c = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            let (keep, push) = if dist[c] < dist[near] {
                                (c, near)
                            } else {
                                (near, c)
                            };
                            stack[sp] = (r(push), dist[push]);
                            self.prefetch(r(push));
                            sp += 1;
                            near = keep;
                        }
                        cur = r(near);
                        self.prefetch(cur);
                        continue;
                    }
                    let c1 = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        // Two: the nearer next, the other on the stack (without a branch).
                        let swap = (dist[c1] < dist[c0]) as usize;
                        let pair = [c0, c1];
                        let (near, far) = (pair[swap], pair[1 - swap]);
                        stack[sp] = (r(far), dist[far]);
                        self.prefetch(r(far));
                        cur = r(near);
                        self.prefetch(cur);
                        sp += 1;
                        continue;
                    }
                    // More: push all, sort the new entries by decreasing distance, continue
                    // with the nearest.
                    let base = sp;
                    stack[sp] = (r(c0), dist[c0]);
                    stack[sp + 1] = (r(c1), dist[c1]);
                    sp += 2;
                    while mask != 0 {
                        let c = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        stack[sp] = (r(c), dist[c]);
                        sp += 1;
                    }
                    for e in &stack[base..sp] {
                        self.prefetch(e.0);
                    }
                    for i in base + 1..sp {
                        let e = stack[i];
                        let mut j = i;
                        while j > base && stack[j - 1].1 < e.1 {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                        stack[j] = e;
                    }
                    sp -= 1;
                    cur = stack[sp].0;
                    continue;
                }
            } else if q.leaf(self, cur) {
                return visited | FOUND;
            }
            // Pop the next entry still in reach.
            loop {
                if sp == 0 {
                    return visited;
                }
                sp -= 1;
                let (r, d) = stack[sp];
                if d <= q.tmax() * FAR_SCALE {
                    cur = r;
                    break;
                }
            }
        }
    }
}

/// A traversal from an inner root, as a kernel for [`crate::simd::run`].
struct Traversal<'a, Q> {
    bvh: &'a Bvh,
    ray: &'a Ray,
    q: &'a mut Q,
    stack: &'a mut [(Ref, f32); STACK],
}

impl<Q: Query> crate::simd::Kernel for Traversal<'_, Q> {
    type Output = u64;

    #[inline(always)]
    fn run<I: Isa>(self, isa: I) -> u64 {
        self.bvh.traverse_from(self.ray, self.q, self.stack, isa)
    }
}

/// Set in the visit count returned by [`Bvh::traverse`] when the query stopped it.
const FOUND: u64 = 1 << 63;

thread_local! {
    /// The traversal stack of each thread (kept, so that it is not cleared for every ray).
    static STACK_SPACE: std::cell::RefCell<[(Ref, f32); STACK]> =
        const { std::cell::RefCell::new([(Ref::EMPTY, 0.0); STACK]) };
}

/// What a traversal does at leaves.
trait Query {
    /// Whether children are visited nearest first (any-hit queries need not).
    const ORDERED: bool;
    /// Tests a leaf's primitives; true to stop.
    fn leaf(&mut self, bvh: &Bvh, r: Ref) -> bool;
    /// The far end of the ray.
    fn tmax(&self) -> f32;
}

struct ClosestQuery<'a> {
    geometry: &'a Geometry,
    /// The ray, its `tmax` one ULP above the best hit.
    ray: Ray,
    tri: TriRay,
    best: Option<Hit>,
    tests: u64,
}

impl Query for ClosestQuery<'_> {
    const ORDERED: bool = true;

    #[inline(always)]
    fn leaf(&mut self, bvh: &Bvh, r: Ref) -> bool {
        let n = r.meta & COUNT_MASK;
        self.tests += n as u64;
        let first = r.child as usize;
        if r.meta & !COUNT_MASK == TRI_LEAF {
            for (k, t) in bvh.tris[first..first + n.div_ceil(4) as usize]
                .iter()
                .enumerate()
            {
                let h = self.tri.test(t, self.ray.tmin, self.ray.tmax, lanes(n, k));
                let mut mask = h.mask;
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let (t_hit, id) = (h.t[i], t.id[i]);
                    let better = match &self.best {
                        None => true,
                        Some(b) => t_hit < b.t || (t_hit == b.t && id < b.prim),
                    };
                    if better {
                        self.best = Some(Hit {
                            t: t_hit,
                            prim: id,
                            uv: [h.v[i] * h.inv_det[i], h.w[i] * h.inv_det[i]],
                            sub: 0,
                            leaf: 0,
                        });
                        self.ray.tmax = t_hit.next_up();
                    }
                }
            }
        } else {
            let sr = &self.tri.sr;
            for &id in &bvh.ids[first..first + n as usize] {
                if let Some(h) = self.geometry.intersect_prim(id, &self.ray, sr) {
                    if closest(&mut self.best, h) {
                        self.ray.tmax = h.t.next_up();
                    }
                }
            }
        }
        false
    }

    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.ray.tmax
    }
}

/// The lanes in use in block `k` of a leaf of `n` triangles.
#[inline(always)]
fn lanes(n: u32, k: usize) -> u32 {
    let rest = n - 4 * k as u32;
    if rest >= 4 {
        0xf
    } else {
        (1 << rest) - 1
    }
}

struct AnyQuery<'a> {
    geometry: &'a Geometry,
    ray: &'a Ray,
    tri: TriRay,
    tests: u64,
}

impl Query for AnyQuery<'_> {
    const ORDERED: bool = false;

    #[inline(always)]
    fn leaf(&mut self, bvh: &Bvh, r: Ref) -> bool {
        let n = r.meta & COUNT_MASK;
        let first = r.child as usize;
        if r.meta & !COUNT_MASK == TRI_LEAF {
            for (k, t) in bvh.tris[first..first + n.div_ceil(4) as usize]
                .iter()
                .enumerate()
            {
                if self
                    .tri
                    .test(t, self.ray.tmin, self.ray.tmax, lanes(n, k))
                    .mask
                    != 0
                {
                    self.tests += (n as u64).min(4 * k as u64 + 4);
                    return true;
                }
            }
            self.tests += n as u64;
        } else {
            for (k, &id) in bvh.ids[first..first + n as usize].iter().enumerate() {
                if self
                    .geometry
                    .intersect_prim(id, self.ray, &self.tri.sr)
                    .is_some()
                {
                    self.tests += k as u64 + 1;
                    return true;
                }
            }
            self.tests += n as u64;
        }
        false
    }

    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.ray.tmax
    }
}

/// A ray prepared for box tests: origin, reciprocal direction, and for each axis the plane
/// (index into a node's `b`) crossed first and last.
struct RayBox<I: Isa> {
    isa: I,
    o: [I::F8; 3],
    inv: [I::F8; 3],
    near: [usize; 3],
    far: [usize; 3],
}

const _: () = assert!(W == 8, "the box test is written for eight children");

impl<I: Isa> RayBox<I> {
    #[inline(always)]
    fn new(r: &Ray, isa: I) -> Self {
        // One division for the three reciprocals (the same IEEE quotients).
        let q = F4::splat(1.0)
            .div(F4::load(&[r.d.x, r.d.y, r.d.z, 1.0]))
            .to_array();
        let inv = [q[0], q[1], q[2]];
        let near = [
            if inv[0] < 0.0 { 3 } else { 0 },
            if inv[1] < 0.0 { 4 } else { 1 },
            if inv[2] < 0.0 { 5 } else { 2 },
        ];
        Self {
            isa,
            o: [isa.splat8(r.o.x), isa.splat8(r.o.y), isa.splat8(r.o.z)],
            inv: inv.map(|x| isa.splat8(x)),
            near,
            far: [(near[0] + 3) % 6, (near[1] + 3) % 6, (near[2] + 3) % 6],
        }
    }

    /// The slab test of the child boxes against `[tmin, tmax]` (the far distance grows by
    /// 2γ₃). A NaN (0·∞ on a slab plane) never narrows the interval. Returns the mask of hit
    /// children and their entry distances.
    #[inline(always)]
    fn test(&self, n: &BvhNode, tmin: f32, tmax: f32) -> (u32, [f32; W]) {
        let isa = self.isa;
        let mut t0 = isa.splat8(tmin);
        let mut t1 = isa.splat8(tmax);
        for a in 0..3 {
            let tn = isa.mul8(
                isa.sub8(isa.load8(&n.b[self.near[a]]), self.o[a]),
                self.inv[a],
            );
            let tf = isa.mul8(
                isa.sub8(isa.load8(&n.b[self.far[a]]), self.o[a]),
                self.inv[a],
            );
            t0 = isa.max_keep8(tn, t0);
            t1 = isa.min_keep8(tf, t1);
        }
        let mask = isa.le8(t0, isa.mul8(t1, isa.splat8(FAR_SCALE)));
        (mask, isa.store8(t0))
    }
}

/// The ray for the watertight triangle test: the sheared ray and the origin.
struct TriRay {
    sr: ShearedRay,
    /// The origin, permuted (x, y, z of the sheared space).
    o: [F4; 3],
    /// The shear.
    s: [F4; 3],
}

/// The results of a block test: the lanes hit, their `t`, the scaled barycentrics of B and C
/// and the reciprocal determinant.
struct Tri4Hit {
    mask: u32,
    t: [f32; 4],
    v: [f32; 4],
    w: [f32; 4],
    inv_det: [f32; 4],
}

impl TriRay {
    #[inline(always)]
    fn new(ray: &Ray, triangles: bool) -> Self {
        let sr = if triangles {
            // `ShearedRay::new` with one division for the three quotients.
            let k = ShearedRay::axes(ray);
            let d = [ray.d.x, ray.d.y, ray.d.z];
            let q = F4::load(&[d[k[0]], d[k[1]], 1.0, 1.0])
                .div(F4::splat(d[k[2]]))
                .to_array();
            ShearedRay {
                k,
                s: [q[0], q[1], q[2]],
            }
        } else {
            ShearedRay::unused()
        };
        let o = [ray.o.x, ray.o.y, ray.o.z];
        Self {
            sr,
            o: sr.k.map(|k| F4::splat(o[k])),
            s: sr.s.map(F4::splat),
        }
    }

    /// [`crate::shape::intersect_triangle`] on four triangles, lane by lane with the same
    /// operations in the same order (so the same results, bit for bit); only the lanes set in
    /// `lanes` can hit.
    #[inline(always)]
    fn test(&self, tri: &Tri4, tmin: f32, tmax: f32, lanes: u32) -> Tri4Hit {
        let [kx, ky, kz] = self.sr.k;
        let [sx, sy, sz] = self.s;
        let v = &tri.v;
        let mut pz = [F4::splat(0.0); 3];
        let mut px = [F4::splat(0.0); 3];
        let mut py = [F4::splat(0.0); 3];
        for k in 0..3 {
            let z = F4::load(&v[k][kz]).sub(self.o[2]);
            pz[k] = z;
            px[k] = F4::load(&v[k][kx]).sub(self.o[0]).sub(sx.mul(z));
            py[k] = F4::load(&v[k][ky]).sub(self.o[1]).sub(sy.mul(z));
        }
        let [ax, bx, cx] = px;
        let [ay, by, cy] = py;
        let mut u = cx.mul(by).sub(cy.mul(bx));
        let mut vv = ax.mul(cy).sub(ay.mul(cx));
        let mut w = bx.mul(ay).sub(by.mul(ax));
        let zero = F4::splat(0.0);
        if (u.eq(zero) | vv.eq(zero) | w.eq(zero)) != 0 {
            // On an edge, f32 cannot decide the sign: redo the edge functions in f64.
            let f =
                |a: f32, b: f32, c: f32, d: f32| (a as f64 * b as f64 - c as f64 * d as f64) as f32;
            let (mut uu, mut v2, mut ww) = (u.to_array(), vv.to_array(), w.to_array());
            let (ax, ay, bx, by, cx, cy) = (
                ax.to_array(),
                ay.to_array(),
                bx.to_array(),
                by.to_array(),
                cx.to_array(),
                cy.to_array(),
            );
            for i in 0..4 {
                if uu[i] == 0.0 || v2[i] == 0.0 || ww[i] == 0.0 {
                    uu[i] = f(cx[i], by[i], cy[i], bx[i]);
                    v2[i] = f(ax[i], cy[i], ay[i], cx[i]);
                    ww[i] = f(bx[i], ay[i], by[i], ax[i]);
                }
            }
            (u, vv, w) = (F4::load(&uu), F4::load(&v2), F4::load(&ww));
        }
        let neg = u.lt(zero) | vv.lt(zero) | w.lt(zero);
        let pos = u.gt(zero) | vv.gt(zero) | w.gt(zero);
        let det = u.add(vv).add(w);
        let t_scaled = u
            .mul(sz.mul(pz[0]))
            .add(vv.mul(sz.mul(pz[1])))
            .add(w.mul(sz.mul(pz[2])));
        let inv_det = F4::splat(1.0).div(det);
        let t = t_scaled.mul(inv_det);
        let valid =
            det.ne(zero) & t.gt(F4::splat(tmin)) & t.lt(F4::splat(tmax)) & !(neg & pos) & lanes;
        Tri4Hit {
            mask: valid,
            t: t.to_array(),
            v: vv.to_array(),
            w: w.to_array(),
            inv_det: inv_det.to_array(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Build

/// A primitive during the build: its box, with the id in the fourth lane of `lo` and the
/// kind (1: triangle) in the fourth lane of `hi`, as bits.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct PrimRef {
    lo: [f32; 4],
    hi: [f32; 4],
}

impl PrimRef {
    fn new(p: &BuildPrim, geometry: &Geometry) -> Self {
        let tri = matches!(geometry.prim(p.id), GeomPrim::Triangle { .. });
        let (l, h) = (p.bounds.min, p.bounds.max);
        Self {
            lo: [l.x, l.y, l.z, f32::from_bits(p.id)],
            hi: [h.x, h.y, h.z, f32::from_bits(tri as u32)],
        }
    }

    #[inline(always)]
    fn id(&self) -> u32 {
        self.lo[3].to_bits()
    }

    #[inline(always)]
    fn is_tri(&self) -> bool {
        self.hi[3].to_bits() != 0
    }

    /// Twice the centroid.
    #[inline(always)]
    fn centroid2(&self) -> [f32; 4] {
        [
            self.lo[0] + self.hi[0],
            self.lo[1] + self.hi[1],
            self.lo[2] + self.hi[2],
            0.0,
        ]
    }
}

/// A box as four lanes (the fourth unused).
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: [f32; 4],
    hi: [f32; 4],
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f32::INFINITY; 4],
        hi: [f32::NEG_INFINITY; 4],
    };

    #[inline(always)]
    fn grow(&mut self, lo: &[f32; 4], hi: &[f32; 4]) {
        for i in 0..4 {
            self.lo[i] = if lo[i] < self.lo[i] {
                lo[i]
            } else {
                self.lo[i]
            };
            self.hi[i] = if hi[i] > self.hi[i] {
                hi[i]
            } else {
                self.hi[i]
            };
        }
    }

    #[inline(always)]
    fn grow_point(&mut self, p: &[f32; 4]) {
        self.grow(p, p);
    }

    #[inline(always)]
    fn union(mut self, o: &Aabb) -> Aabb {
        self.grow(&o.lo, &o.hi);
        self
    }

    /// Half the surface area (0 when empty).
    #[inline(always)]
    fn half_area(&self) -> f32 {
        let d = [
            self.hi[0] - self.lo[0],
            self.hi[1] - self.lo[1],
            self.hi[2] - self.lo[2],
        ];
        if d[0] < 0.0 {
            return 0.0;
        }
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// What the build knows about a range: its box, the box of its (doubled) centroids and its
/// number of triangles.
#[derive(Clone, Copy, Debug)]
struct Info {
    b: Aabb,
    c: Aabb,
    n: usize,
    tris: usize,
}

impl Info {
    const EMPTY: Info = Info {
        b: Aabb::EMPTY,
        c: Aabb::EMPTY,
        n: 0,
        tris: 0,
    };

    #[inline(always)]
    fn add(&mut self, p: &PrimRef) {
        self.b.grow(&p.lo, &p.hi);
        self.c.grow_point(&p.centroid2());
        self.n += 1;
        self.tris += p.is_tri() as usize;
    }

    fn merge(mut self, o: &Info) -> Info {
        self.b = self.b.union(&o.b);
        self.c = self.c.union(&o.c);
        self.n += o.n;
        self.tris += o.tris;
        self
    }

    fn of(prims: &[PrimRef]) -> Info {
        if prims.len() > PARALLEL_BINNING {
            prims
                .par_chunks(PARALLEL_BINNING / 4)
                .map(Info::of)
                .reduce(|| Info::EMPTY, |a, b| a.merge(&b))
        } else {
            let mut i = Info::EMPTY;
            for p in prims {
                i.add(p);
            }
            i
        }
    }

    fn pure_triangles(&self) -> bool {
        self.tris == self.n
    }

    fn mixed(&self) -> bool {
        self.tris != 0 && self.tris != self.n
    }

    fn max_leaf(&self) -> usize {
        if self.pure_triangles() {
            MAX_TRI_LEAF
        } else {
            MAX_OBJ_LEAF
        }
    }
}

/// The cost of intersecting `n` primitives of a range: blocks of four for triangles,
/// [`OBJ_COST`] for each other primitive.
#[inline(always)]
fn prim_cost(n: usize, triangles: bool) -> f32 {
    if triangles {
        n.div_ceil(4) as f32
    } else {
        n as f32 * OBJ_COST
    }
}

/// Per-axis centroid bins.
#[derive(Clone, Copy)]
struct Bins {
    b: [[Aabb; BINS]; 3],
    n: [[u32; BINS]; 3],
}

impl Bins {
    fn new() -> Self {
        Self {
            b: [[Aabb::EMPTY; BINS]; 3],
            n: [[0; BINS]; 3],
        }
    }

    fn merge(mut self, o: &Bins) -> Bins {
        for a in 0..3 {
            for i in 0..BINS {
                self.b[a][i] = self.b[a][i].union(&o.b[a][i]);
                self.n[a][i] += o.n[a][i];
            }
        }
        self
    }
}

/// Maps doubled centroids to bins.
#[derive(Clone, Copy)]
struct Binner {
    lo: [f32; 4],
    scale: [f32; 4],
}

impl Binner {
    fn new(c: &Aabb) -> Self {
        let mut scale = [0.0; 4];
        for a in 0..3 {
            let ext = c.hi[a] - c.lo[a];
            if ext > 0.0 {
                scale[a] = BINS as f32 * 0.999_99 / ext;
            }
        }
        Self { lo: c.lo, scale }
    }

    #[inline(always)]
    fn bins(&self, p: &PrimRef) -> [usize; 3] {
        let c = p.centroid2();
        let mut r = [0usize; 3];
        for a in 0..3 {
            r[a] = (((c[a] - self.lo[a]) * self.scale[a]) as usize).min(BINS - 1);
        }
        r
    }

    #[inline(always)]
    fn bin(&self, p: &PrimRef, a: usize) -> usize {
        let c = p.lo[a] + p.hi[a];
        (((c - self.lo[a]) * self.scale[a]) as usize).min(BINS - 1)
    }

    fn fill(&self, prims: &[PrimRef]) -> Bins {
        if prims.len() > PARALLEL_BINNING {
            return prims
                .par_chunks(PARALLEL_BINNING / 4)
                .map(|c| self.fill(c))
                .reduce(Bins::new, |a, b| a.merge(&b));
        }
        let mut bins = Bins::new();
        for p in prims {
            let ix = self.bins(p);
            for a in 0..3 {
                bins.b[a][ix[a]].grow(&p.lo, &p.hi);
                bins.n[a][ix[a]] += 1;
            }
        }
        bins
    }
}

/// A split of a range: the left part's size and the two parts' infos.
type Split = (usize, Info, Info);

/// Splits `prims` in two, or `None` for a leaf.
fn split(prims: &mut [PrimRef], info: &Info, depth: u32) -> Option<Split> {
    let n = prims.len();
    if n <= 1 {
        return None;
    }
    let small = n <= info.max_leaf();
    if info.mixed() && n <= MAX_TRI_LEAF {
        // Leaves are never mixed: triangles first.
        return Some(partition(prims, |p| p.is_tri()));
    }
    if depth >= MEDIAN_DEPTH {
        return (!small || info.mixed()).then(|| median_split(prims, info));
    }
    let binner = Binner::new(&info.c);
    if binner.scale[..3].iter().all(|&s| s == 0.0) {
        // All centroids coincide.
        return (!small || info.mixed()).then(|| median_split(prims, info));
    }
    let tri = info.pure_triangles();
    let bins = binner.fill(prims);
    // Best over axes of the unnormalised SAH cost: A_L·C(L) + A_R·C(R).
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for a in 0..3 {
        if binner.scale[a] == 0.0 {
            continue;
        }
        let mut right = [0f32; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0usize);
        for i in (1..BINS).rev() {
            acc = acc.union(&bins.b[a][i]);
            cnt += bins.n[a][i] as usize;
            right[i] = acc.half_area() * prim_cost(cnt, tri);
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0usize);
        for i in 1..BINS {
            acc = acc.union(&bins.b[a][i - 1]);
            cnt += bins.n[a][i - 1] as usize;
            if cnt == 0 || cnt == n {
                continue;
            }
            let cost = acc.half_area() * prim_cost(cnt, tri) + right[i];
            if cost < best.0 {
                best = (cost, a, i);
            }
        }
    }
    let area = info.b.half_area();
    let leaf_cost = area * prim_cost(n, tri);
    let split_cost = area * TRAVERSAL_COST + best.0;
    if !best.0.is_finite() {
        return (!small || info.mixed()).then(|| median_split(prims, info));
    }
    if small && !info.mixed() && leaf_cost <= split_cost {
        return None;
    }
    let (a, s) = (best.1, best.2);
    Some(partition(prims, |p| binner.bin(p, a) < s))
}

/// Halves by count along the axis of largest centroid extent.
fn median_split(prims: &mut [PrimRef], info: &Info) -> Split {
    let n = prims.len();
    let mut axis = 0;
    for a in 1..3 {
        if info.c.hi[a] - info.c.lo[a] > info.c.hi[axis] - info.c.lo[axis] {
            axis = a;
        }
    }
    let key = |p: &PrimRef| p.lo[axis] + p.hi[axis];
    prims.select_nth_unstable_by(n / 2, |x, y| key(x).total_cmp(&key(y)));
    let (l, r) = prims.split_at(n / 2);
    (n / 2, Info::of(l), Info::of(r))
}

/// Reorders so that the elements satisfying `left` come first; returns how many do and the
/// infos of both parts.
fn partition(prims: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> Split {
    let (mut li, mut ri) = (Info::EMPTY, Info::EMPTY);
    let (mut i, mut j) = (0usize, prims.len());
    loop {
        while i < j && left(&prims[i]) {
            li.add(&prims[i]);
            i += 1;
        }
        while i < j && !left(&prims[j - 1]) {
            ri.add(&prims[j - 1]);
            j -= 1;
        }
        if i >= j {
            break;
        }
        prims.swap(i, j - 1);
        li.add(&prims[i]);
        ri.add(&prims[j - 1]);
        i += 1;
        j -= 1;
    }
    (i, li, ri)
}

/// A child of a node being built: a sub-range and whether it is a finished leaf.
#[derive(Clone, Copy)]
struct Kid {
    start: usize,
    end: usize,
    info: Info,
    leaf: bool,
}

/// The leaf over `prims[offset..offset + n]` (the primitive range; packed into blocks later).
fn leaf(offset: usize, info: &Info) -> Ref {
    debug_assert!(!info.mixed() && info.n <= COUNT_MASK as usize);
    Ref {
        child: offset as u32,
        meta: if info.pure_triangles() {
            TRI_LEAF
        } else {
            OBJ_LEAF
        } | info.n as u32,
    }
}

/// Builds the subtree over `prims` (at `offset` in the final order), appending its nodes to
/// `nodes`; returns its reference.
fn build_node(
    prims: &mut [PrimRef],
    offset: usize,
    info: &Info,
    depth: u32,
    nodes: &mut Vec<BvhNode>,
) -> Ref {
    let Some((mid, li, ri)) = split(prims, info, depth) else {
        return leaf(offset, info);
    };
    let n = prims.len();
    let mut kids = [Kid {
        start: 0,
        end: 0,
        info: Info::EMPTY,
        leaf: true,
    }; W];
    kids[0] = Kid {
        start: 0,
        end: mid,
        info: li,
        leaf: false,
    };
    kids[1] = Kid {
        start: mid,
        end: n,
        info: ri,
        leaf: false,
    };
    let mut count = 2;
    while count < W {
        // Split the open child of largest area (of most primitives once splits are by count).
        let mut pick = None;
        let mut best_area = -1.0;
        for (i, k) in kids[..count].iter().enumerate() {
            let a = if depth + 1 >= MEDIAN_DEPTH {
                k.info.n as f32
            } else {
                k.info.b.half_area()
            };
            if !k.leaf && a > best_area {
                best_area = a;
                pick = Some(i);
            }
        }
        let Some(i) = pick else { break };
        let k = kids[i];
        match split(&mut prims[k.start..k.end], &k.info, depth + 1) {
            None => kids[i].leaf = true,
            Some((m, li, ri)) => {
                kids.copy_within(i + 1..count, i + 2);
                kids[i] = Kid {
                    start: k.start,
                    end: k.start + m,
                    info: li,
                    leaf: false,
                };
                kids[i + 1] = Kid {
                    start: k.start + m,
                    end: k.end,
                    info: ri,
                    leaf: false,
                };
                count += 1;
            }
        }
    }
    let me = nodes.len();
    nodes.push(BvhNode::EMPTY);
    let mut node = BvhNode::EMPTY;
    if n > PARALLEL_THRESHOLD {
        let mut parts: Vec<(&mut [PrimRef], Kid)> = Vec::with_capacity(W);
        let mut rest = prims;
        let mut pos = 0;
        for k in &kids[..count] {
            let (part, tail) = rest.split_at_mut(k.end - pos);
            parts.push((part, *k));
            rest = tail;
            pos = k.end;
        }
        let built: Vec<(Vec<BvhNode>, Ref)> = parts
            .into_par_iter()
            .map(|(part, k)| {
                let mut sub = Vec::new();
                let r = if k.leaf {
                    leaf(offset + k.start, &k.info)
                } else {
                    build_node(part, offset + k.start, &k.info, depth + 1, &mut sub)
                };
                (sub, r)
            })
            .collect();
        for (i, (sub, mut r)) in built.into_iter().enumerate() {
            let base = nodes.len() as u32;
            if r.meta == 0 {
                r.child += base;
            }
            nodes.extend(sub.into_iter().map(|mut nd| {
                for j in 0..W {
                    if nd.meta[j] == 0 {
                        nd.child[j] += base;
                    }
                }
                nd
            }));
            node.set(i, &kids[i].info.b, r);
        }
    } else {
        for (i, k) in kids[..count].iter().enumerate() {
            let r = if k.leaf {
                leaf(offset + k.start, &k.info)
            } else {
                build_node(
                    &mut prims[k.start..k.end],
                    offset + k.start,
                    &k.info,
                    depth + 1,
                    nodes,
                )
            };
            node.set(i, &k.info.b, r);
        }
    }
    nodes[me] = node;
    Ref {
        child: me as u32,
        meta: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_scenes::{check_against_list, parallelogram_scene, triangles};
    use super::super::{build_prims, inflate, margin};
    use super::*;
    use crate::math::{Point3, Vec3};

    fn bvh(g: &Geometry) -> Bvh {
        let m = margin(&g.bounds());
        let prims: Vec<BuildPrim> = build_prims(g)
            .into_iter()
            .map(|p| BuildPrim {
                bounds: inflate(p.bounds, m),
                ..p
            })
            .collect();
        Bvh::build(g, &prims)
    }

    fn check(g: &Geometry) {
        let b = bvh(g);
        check_against_list(
            g,
            |g, r, s| b.intersect(g, r, s),
            |g, r, s| b.occluded(g, r, s),
        );
    }

    #[test]
    fn agrees_with_the_list_on_flat_and_duplicated_shapes() {
        check(&parallelogram_scene());
    }

    #[test]
    fn agrees_with_the_list_on_a_triangle_soup() {
        let mut rng = crate::sampling::Pcg32::new(3, 4);
        let mut tris = Vec::new();
        for _ in 0..500 {
            let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
            let p = |rng: &mut crate::sampling::Pcg32| {
                (c + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).to_point()
            };
            let t = [p(&mut rng), p(&mut rng), p(&mut rng)];
            tris.push(t);
            if tris.len() % 7 == 0 {
                // Exact duplicates: equal t, the smaller id must win.
                tris.push(t);
            }
        }
        let g = triangles(&tris);
        let b = bvh(&g);
        assert!(b.node_count() > 1 && b.block_count() >= tris.len() / 4);
        check(&g);
    }

    #[test]
    fn ray_precomputations_match_the_scalar_ones() {
        let mut rng = crate::sampling::Pcg32::new(8, 1);
        for i in 0..10_000 {
            let mut c = || (rng.next_f32() - 0.5) * 10f32.powi((i % 7) - 3);
            let mut d = Vec3::new(c(), c(), c());
            if i % 5 == 0 {
                d.y = 0.0;
            }
            if i % 11 == 0 {
                d.x = -0.0;
            }
            let r = Ray::new(Point3::new(c(), c(), c()), d);
            let (a, b) = (TriRay::new(&r, true).sr, ShearedRay::new(&r));
            assert_eq!(a.k, b.k);
            assert_eq!(a.s.map(f32::to_bits), b.s.map(f32::to_bits), "{r:?}");
            let rb = RayBox::new(&r, crate::simd::Sse);
            let inv = rb.inv.map(|x| x[0].to_array()[0]);
            assert_eq!(
                inv.map(f32::to_bits),
                [1.0 / d.x, 1.0 / d.y, 1.0 / d.z].map(f32::to_bits)
            );
        }
    }

    #[test]
    fn single_leaf_and_empty_trees() {
        let g = triangles(&[[
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ]]);
        assert_eq!(bvh(&g).node_count(), 0);
        check(&g);
        let empty = Geometry::new(Vec::new(), Vec::new());
        let b = bvh(&empty);
        let mut st = RayStats::default();
        let r = Ray::new(Point3::ORIGIN, Vec3::X);
        assert!(b.intersect(&empty, &r, &mut st).is_none());
        assert!(!b.occluded(&empty, &r, &mut st));
    }

    #[test]
    fn large_builds_are_parallel_and_agree() {
        // Enough triangles for the parallel build and binning paths, on a coarse lattice so
        // that many centroids coincide.
        let mut tris = Vec::new();
        for i in 0..70_000u32 {
            let (x, y, z) = (
                (i % 41) as f32,
                ((i / 41) % 37) as f32,
                (i / (41 * 37)) as f32,
            );
            let o = Point3::new(x, y, z);
            tris.push([
                o,
                o + Vec3::new(0.9, 0.0, 0.0),
                o + Vec3::new(0.0, 0.9, 0.3),
            ]);
        }
        let g = triangles(&tris);
        let b = bvh(&g);
        let mut seen = vec![false; tris.len()];
        for t in &b.tris {
            for &id in &t.id {
                if id != u32::MAX {
                    assert!(!seen[id as usize]);
                    seen[id as usize] = true;
                }
            }
        }
        assert!(
            seen.iter().all(|&s| s),
            "every triangle is in exactly one block"
        );
        // Against the list on a few hundred rays (the full check would be slow here).
        let list = super::super::List::new(&g);
        let mut rng = crate::sampling::Pcg32::new(1, 2);
        let mut st = RayStats::default();
        for i in 0..300 {
            let o = Point3::new(
                rng.next_f32() * 60.0 - 10.0,
                rng.next_f32() * 60.0 - 10.0,
                rng.next_f32() * 60.0 - 10.0,
            );
            let d = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            );
            let mut r = Ray::new(
                o,
                if i % 3 == 0 {
                    Vec3::new(0.0, 0.0, d.z)
                } else {
                    d
                },
            );
            if i % 4 == 0 {
                r.tmax = 5.0;
            }
            assert_eq!(
                list.intersect(&g, &r, &mut st),
                b.intersect(&g, &r, &mut st),
                "{r:?}"
            );
            assert_eq!(
                list.occluded(&g, &r, &mut st),
                b.occluded(&g, &r, &mut st),
                "{r:?}"
            );
        }
    }

    #[test]
    fn deep_degenerate_inputs_keep_the_stack_bounded() {
        // Nested triangles of geometrically shrinking size: SAH would peel one at a time.
        let mut tris = Vec::new();
        let mut s = 1.0f32;
        for _ in 0..3000 {
            tris.push([
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(s, 0.0, 0.0),
                Point3::new(0.0, s, 0.0),
            ]);
            s *= 0.97;
        }
        check(&triangles(&tris));
    }
}
