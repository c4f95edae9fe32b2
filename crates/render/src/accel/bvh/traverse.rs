//! BVH traversal: the eight child boxes of a node tested at once, nearest child first for
//! closest hits, in sequence for shadow rays; leaves of triangles tested four at a time.

use super::layout::{
    BvhNode, Kind, Ref, Tri4, BOX_LEAF, COUNT_MASK, OBJ_LEAF, QUAD_LEAF, SPHERE_LEAF, STACK,
    TRI_LEAF, W,
};
use super::Bvh;
use crate::accel::blocks::{BlockHit, BlockRay};
use crate::accel::closest;
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Ray, BATCH, GAMMA3};
use crate::mem::Stack;
use crate::shape::ShearedRay;
use crate::simd::{Isa, F4};
use crate::stats::RayStats;

/// The far distance of a box grows by 2γ₃ (pbrt) to cover round-off.
pub(super) const FAR_SCALE: f32 = 1.0 + 2.0 * GAMMA3;

impl Bvh {
    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        let triangles = !self.tris.is_empty();
        let (best, visited, tests) = self.traverse_one(
            ray,
            |ray| ClosestQuery::new(geometry, ray, triangles),
            |q, visited| (q.best, visited, q.tests),
        );
        stats.nodes += visited;
        stats.prim_tests += tests;
        best
    }

    /// True when any primitive is hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        let triangles = !self.tris.is_empty();
        let (visited, tests) = self.traverse_one(
            ray,
            |ray| AnyQuery::new(geometry, ray, triangles),
            |q, visited| (visited, q.tests),
        );
        stats.nodes += visited & !FOUND;
        stats.prim_tests += tests;
        visited & FOUND != 0
    }

    /// Tests block `b` of the analytic kind in `meta` against the ray; returns the hits and
    /// the lanes' primitive ids.
    #[inline(always)]
    fn block_test(&self, meta: u32, b: usize, br: &BlockRay, ray: &Ray) -> (BlockHit, [u32; 4]) {
        match meta & !COUNT_MASK {
            QUAD_LEAF => {
                let (q, ids) = &self.quads[b];
                (q.test(br, ray.tmin, ray.tmax), *ids)
            }
            SPHERE_LEAF => {
                let (q, ids) = &self.spheres[b];
                (q.test(br, ray.tmin, ray.tmax), *ids)
            }
            _ => {
                debug_assert_eq!(meta & !COUNT_MASK, BOX_LEAF);
                let (q, ids) = &self.boxes[b];
                (q.test(br, ray.tmin, ray.tmax), *ids)
            }
        }
    }

    /// The id of lane `lane` of block `block` of a blocked leaf of `kind`.
    pub(super) fn block_id(&self, kind: Kind, block: usize, lane: usize) -> u32 {
        match kind {
            Kind::Quad => self.quads[block].1[lane],
            Kind::Sphere => self.spheres[block].1[lane],
            Kind::Box => self.boxes[block].1[lane],
            Kind::Tri => self.tris[block].id[lane],
            Kind::Other => self.ids[block * 4 + lane],
        }
    }

    /// The closest hit of `ray` among the primitives of leaf `r`.
    pub(super) fn leaf_closest(
        &self,
        geometry: &Geometry,
        r: Ref,
        ray: &Ray,
        stats: &mut RayStats,
    ) -> Option<Hit> {
        let mut q = ClosestQuery::new(geometry, ray, self.leaf_needs_sheared_ray(r));
        q.leaf(self, r);
        stats.prim_tests += q.tests;
        q.best
    }

    /// True when `ray` hits a primitive of leaf `r`.
    pub(super) fn leaf_any(
        &self,
        geometry: &Geometry,
        r: Ref,
        ray: &Ray,
        stats: &mut RayStats,
    ) -> bool {
        let mut q = AnyQuery::new(geometry, ray, self.leaf_needs_sheared_ray(r));
        let hit = q.leaf(self, r);
        stats.prim_tests += q.tests;
        hit
    }

    /// The root's children when all of them are leaves (a small scene), the root when it is a
    /// leaf, else nothing.
    /// Whether testing leaf `r` may need the sheared ray of the triangle test (blocks of
    /// parallelograms, spheres and boxes do not; it costs a division per ray).
    #[inline(always)]
    fn leaf_needs_sheared_ray(&self, r: Ref) -> bool {
        !self.tris.is_empty() && !matches!(r.meta & !COUNT_MASK, QUAD_LEAF | SPHERE_LEAF | BOX_LEAF)
    }

    pub(super) fn flat_root(&self) -> Vec<Ref> {
        if self.root.meta != 0 {
            return if self.root.meta & COUNT_MASK != 0 {
                vec![self.root]
            } else {
                Vec::new()
            };
        }
        let root = &self.nodes[self.root.child as usize];
        let kids: Vec<Ref> = (0..W)
            .map(|i| Ref {
                child: root.child[i],
                meta: root.meta[i],
            })
            .filter(|r| r.meta == 0 || r.meta & COUNT_MASK != 0)
            .collect();
        if kids.iter().all(|r| r.meta != 0) {
            kids
        } else {
            Vec::new()
        }
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
                crate::simd::prefetch_all(ts);
            }
        }
    }

    /// Visits the leaves whose boxes the ray crosses (nearest child first for closest hits, in
    /// sequence for any hit), with the query
    /// `make` makes (inside the kernel compiled for the instruction set chosen, where its
    /// setup stays in registers); `done` receives the query and the number of nodes visited,
    /// with [`FOUND`] set when the query stopped the traversal.
    #[inline(always)]
    fn traverse_one<Q: Query, R>(
        &self,
        ray: &Ray,
        make: impl FnOnce(&Ray) -> Q,
        done: impl FnOnce(Q, u64) -> R,
    ) -> R {
        if self.root.meta != 0 || !self.flat.is_empty() {
            let mut q = make(ray);
            let visited = self.traverse_small(&mut q);
            return done(q, visited);
        }
        crate::simd::run(One {
            bvh: self,
            ray,
            make,
            done,
        })
    }

    /// The traversal of a BVH whose root is a leaf, or whose leaves are all the root's
    /// children (a small scene: every leaf, without box tests).
    #[inline(always)]
    fn traverse_small<Q: Query>(&self, q: &mut Q) -> u64 {
        let cur = self.root;
        if cur.meta != 0 {
            return if q.leaf(self, cur) { FOUND } else { 0 };
        }
        for &r in &self.flat {
            if q.leaf(self, r) {
                return FOUND;
            }
        }
        0
    }

    /// [`Bvh::traverse_one`] from an inner root.
    #[inline(always)]
    fn traverse_from<Q: Query, I: Isa>(&self, ray: &Ray, q: &mut Q, isa: I) -> u64 {
        let mut cur = self.root;
        let rb = RayBox::new(ray, isa);
        let mut stack = Stack::<(Ref, f32), STACK>::new();
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
                        // In sequence (as Embree's any-hit traversal), without comparing
                        // distances: the last child next, the others on the stack.
                        // (Not prefetched: an any-hit query often stops before it comes back
                        // to them. Camera rays on the 1M-triangle bench: 1.05x the rays per
                        // second; random rays: 0.95x.)
                        let mut c = c0;
                        while mask != 0 {
                            stack.push((r(c), dist[c]));
                            c = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                        }
                        cur = r(c);
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
                        stack.push((r(far), dist[far]));
                        self.prefetch(r(far));
                        cur = r(near);
                        self.prefetch(cur);
                        continue;
                    }
                    // More: push all, sort the new entries by decreasing distance, continue
                    // with the nearest.
                    let base = stack.len();
                    stack.push((r(c0), dist[c0]));
                    stack.push((r(c1), dist[c1]));
                    while mask != 0 {
                        let c = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        stack.push((r(c), dist[c]));
                    }
                    let new = stack.above_mut(base);
                    for e in new.iter() {
                        self.prefetch(e.0);
                    }
                    for i in 1..new.len() {
                        let e = new[i];
                        let mut j = i;
                        while j > 0 && new[j - 1].1 < e.1 {
                            new[j] = new[j - 1];
                            j -= 1;
                        }
                        new[j] = e;
                    }
                    cur = stack.pop().map_or(cur, |e| e.0);
                    continue;
                }
            } else {
                leaves_are_rarer();
                if q.leaf(self, cur) {
                    return visited | FOUND;
                }
            }
            // Pop the next entry still in reach.
            loop {
                let Some((r, d)) = stack.pop() else {
                    return visited;
                };
                // (An any-hit query's far end never moves: what it pushed is still in reach.)
                if !Q::ORDERED || d <= q.tmax() * FAR_SCALE {
                    cur = r;
                    break;
                }
            }
        }
    }
}

impl Bvh {
    /// The closest hits of the rays of `lanes` (of `rays`), into `hits`: [`Bvh::intersect`]
    /// for each (see [`Bvh::traverse_lanes`]).
    pub(super) fn intersect_lanes(
        &self,
        geometry: &Geometry,
        rays: &[Ray; BATCH],
        lanes: u32,
        hits: &mut [Option<Hit>; BATCH],
        stats: &mut RayStats,
    ) {
        let triangles = !self.tris.is_empty();
        self.traverse_lanes(
            rays,
            lanes,
            |ray| ClosestQuery::new(geometry, ray, triangles),
            |i, q, visited| {
                hits[i] = q.best;
                stats.nodes += visited;
                stats.prim_tests += q.tests;
            },
        );
    }

    /// The lanes of `lanes` whose rays (of `rays`) hit something: [`Bvh::occluded`] for each
    /// (see [`Bvh::traverse_lanes`]).
    pub(super) fn occluded_lanes(
        &self,
        geometry: &Geometry,
        rays: &[Ray; BATCH],
        lanes: u32,
        stats: &mut RayStats,
    ) -> u32 {
        let triangles = !self.tris.is_empty();
        let mut hit = 0;
        self.traverse_lanes(
            rays,
            lanes,
            |ray| AnyQuery::new(geometry, ray, triangles),
            |i, q, visited| {
                hit |= ((visited & FOUND != 0) as u32) << i;
                stats.nodes += visited & !FOUND;
                stats.prim_tests += q.tests;
            },
        );
        hit
    }

    /// [`Bvh::traverse_one`] for the rays of `lanes` one after the other, with the
    /// instruction set chosen once for them all rather than once per ray. (Single rays keep
    /// [`Bvh::traverse_one`]: through this, one lane at a time, camera rays on the
    /// 1M-triangle bench were 0.93× as fast.) `make` makes a
    /// ray's query; `done` receives the lane, its query and the visit count (with [`FOUND`]
    /// when the query stopped).
    #[inline(always)]
    fn traverse_lanes<Q: Query>(
        &self,
        rays: &[Ray; BATCH],
        lanes: u32,
        make: impl Fn(&Ray) -> Q,
        mut done: impl FnMut(usize, Q, u64),
    ) {
        if self.root.meta != 0 || !self.flat.is_empty() {
            for i in crate::math::lanes(lanes) {
                let mut q = make(&rays[i]);
                let visited = self.traverse_small(&mut q);
                done(i, q, visited);
            }
            return;
        }
        crate::simd::run(Lanes {
            bvh: self,
            rays,
            lanes,
            make,
            done,
            query: std::marker::PhantomData,
        })
    }
}

#[cfg(test)]
impl Bvh {
    /// [`Bvh::intersect`] and [`Bvh::occluded`] of `ray` through the kernels compiled for
    /// `level` at most (a BVH with inner nodes: small ones take no kernel).
    pub(super) fn hits_at(
        &self,
        level: crate::simd::SimdLevel,
        geometry: &Geometry,
        ray: &Ray,
    ) -> (Option<Hit>, bool) {
        let triangles = !self.tris.is_empty();
        let closest = crate::simd::run_at(
            level,
            One {
                bvh: self,
                ray,
                make: |ray: &Ray| ClosestQuery::new(geometry, ray, triangles),
                done: |q: ClosestQuery, _| q.best,
            },
        );
        let any = crate::simd::run_at(
            level,
            One {
                bvh: self,
                ray,
                make: |ray: &Ray| AnyQuery::new(geometry, ray, triangles),
                done: |_, visited: u64| visited & FOUND != 0,
            },
        );
        (closest, any)
    }
}

/// [`Bvh::traverse_lanes`] as a kernel for [`crate::simd::run`].
struct Lanes<'a, Q, M, D> {
    bvh: &'a Bvh,
    rays: &'a [Ray; BATCH],
    lanes: u32,
    make: M,
    done: D,
    query: std::marker::PhantomData<fn() -> Q>,
}

impl<Q: Query, M: Fn(&Ray) -> Q, D: FnMut(usize, Q, u64)> crate::simd::Kernel
    for Lanes<'_, Q, M, D>
{
    type Output = ();

    #[inline(always)]
    fn run<I: Isa>(mut self, isa: I) {
        for i in crate::math::lanes(self.lanes) {
            let ray = &self.rays[i];
            let mut q = (self.make)(ray);
            let visited = self.bvh.traverse_from(ray, &mut q, isa);
            (self.done)(i, q, visited);
        }
    }
}

/// [`Bvh::traverse_one`] as a kernel for [`crate::simd::run`].
struct One<'a, M, D> {
    bvh: &'a Bvh,
    ray: &'a Ray,
    make: M,
    done: D,
}

impl<Q: Query, R, M: FnOnce(&Ray) -> Q, D: FnOnce(Q, u64) -> R> crate::simd::Kernel
    for One<'_, M, D>
{
    type Output = R;

    #[inline(always)]
    fn run<I: Isa>(self, isa: I) -> R {
        let mut q = (self.make)(self.ray);
        let visited = self.bvh.traverse_from(self.ray, &mut q, isa);
        (self.done)(q, visited)
    }
}

/// Marks the path that calls it as rarely taken (a call to a cold function): leaves, which a
/// ray reaches about a quarter as often as inner nodes, so that the register allocator keeps
/// the box test's reciprocals and origin in registers through the node loop and spills around
/// the leaf tests instead (it had kept them all on the stack). On the 1M-triangle bench, one
/// thread, against the same build without it (medians of pairs): camera rays 1.02× the rays
/// per second for closest hits, 0.99× for any hit; random rays 1.04× and 1.03×; first-bounce
/// rays 1.01×. (Keeping `tmin` or the far end in registers as well undid it: 0.90× on
/// first-bounce rays, 0.88× on any-hit camera rays.)
#[cold]
#[inline(never)]
fn leaves_are_rarer() {}

/// Set in the visit count of a traversal when the query stopped it.
const FOUND: u64 = 1 << 63;

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

impl<'a> ClosestQuery<'a> {
    /// The query of `ray`, with the sheared ray of the triangle test when `triangles`.
    #[inline(always)]
    fn new(geometry: &'a Geometry, ray: &Ray, triangles: bool) -> Self {
        Self {
            geometry,
            ray: *ray,
            tri: TriRay::new(ray, triangles),
            best: None,
            tests: 0,
        }
    }
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
        } else if r.meta & !COUNT_MASK == OBJ_LEAF {
            let sr = &self.tri.sr;
            for &id in &bvh.ids[first..first + n as usize] {
                if let Some(h) = self.geometry.intersect_prim(id, &self.ray, sr) {
                    if closest(&mut self.best, h) {
                        self.ray.tmax = h.t.next_up();
                    }
                }
            }
        } else {
            // (The ray broadcast here, not once per ray: as cheap as loading it back, and the
            // rays that meet no such leaf, as in meshes, do not pay for it.)
            let block = BlockRay::new(&self.ray);
            for k in 0..n.div_ceil(4) as usize {
                let (h, ids) = bvh.block_test(r.meta, first + k, &block, &self.ray);
                let mut mask = h.mask & lanes(n, k);
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let (t_hit, id) = (h.t[i], ids[i]);
                    let better = match &self.best {
                        None => true,
                        Some(b) => t_hit < b.t || (t_hit == b.t && id < b.prim),
                    };
                    if better {
                        self.best = Some(Hit {
                            t: t_hit,
                            prim: id,
                            uv: [h.uv[0][i], h.uv[1][i]],
                            sub: h.face[i],
                            leaf: 0,
                        });
                        self.ray.tmax = t_hit.next_up();
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
    /// The ray, copied as [`ClosestQuery`] copies it: read through a reference, its `tmax`
    /// was loaded again at every node (camera rays' any-hit queries on the 1M-triangle
    /// bench: 0.94× the time with the copy).
    ray: Ray,
    tri: TriRay,
    tests: u64,
}

impl<'a> AnyQuery<'a> {
    /// The query of `ray`, with the sheared ray of the triangle test when `triangles`.
    #[inline(always)]
    fn new(geometry: &'a Geometry, ray: &Ray, triangles: bool) -> Self {
        Self {
            geometry,
            ray: *ray,
            tri: TriRay::new(ray, triangles),
            tests: 0,
        }
    }
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
        } else if r.meta & !COUNT_MASK != OBJ_LEAF {
            let block = BlockRay::new(&self.ray);
            for k in 0..n.div_ceil(4) as usize {
                let (h, _) = bvh.block_test(r.meta, first + k, &block, &self.ray);
                if h.mask & lanes(n, k) != 0 {
                    self.tests += (n as u64).min(4 * k as u64 + 4);
                    return true;
                }
            }
            self.tests += n as u64;
        } else {
            for (k, &id) in bvh.ids[first..first + n as usize].iter().enumerate() {
                if self
                    .geometry
                    .intersect_prim(id, &self.ray, &self.tri.sr)
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

/// A ray prepared for box tests: origin, reciprocal direction (and the same grown by the far
/// distance's margin), and for each axis the plane (index into a node's `b`) crossed first and
/// last.
pub(super) struct RayBox<I: Isa> {
    isa: I,
    o: [I::F8; 3],
    pub(super) inv: [I::F8; 3],
    /// `inv` times [`FAR_SCALE`], for the far planes.
    inv_far: [I::F8; 3],
    near: [usize; 3],
    far: [usize; 3],
}

const _: () = assert!(W == 8, "the box test is written for eight children");

impl<I: Isa> RayBox<I> {
    #[inline(always)]
    pub(super) fn new(r: &Ray, isa: I) -> Self {
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
            inv_far: inv.map(|x| isa.splat8(x * FAR_SCALE)),
            near,
            far: [(near[0] + 3) % 6, (near[1] + 3) % 6, (near[2] + 3) % 6],
        }
    }

    /// The slab test of the child boxes against `[tmin, tmax]`, the far distances (and
    /// `tmax`) grown by 2γ₃ (pbrt's margin for the rounding of the slab distances: with the
    /// margin folded into the reciprocal, (b − o)·(inv·(1 + 2γ₃)) is rounded four times, as
    /// ((b − o)·inv)·(1 + 2γ₃) was, so it still bounds the exact distance from above). A NaN
    /// (0·∞ on a slab plane) never narrows the interval. Returns the mask of hit children and
    /// their entry distances.
    ///
    /// The three slabs are reduced as a tree (two maxima, then one) rather than one after the
    /// other, and no product follows the minima: a single ray's traversal waits on this chain
    /// from one node's load to the next. (On an Intel Xeon: camera rays on the 1M-triangle
    /// bench 1.01×, first-bounce rays 1.03× the rays per second; a frame of the bench's meshes
    /// 0.98× the time. Fifteen independent comparisons instead of the reductions, shorter
    /// still, were 0.86× as fast: the loop is bound by its instruction count too.)
    #[inline(always)]
    pub(super) fn test(&self, n: &BvhNode, tmin: f32, tmax: f32) -> (u32, [f32; W]) {
        let isa = self.isa;
        let mut tn = [isa.splat8(0.0); 3];
        let mut tf = [isa.splat8(0.0); 3];
        for a in 0..3 {
            tn[a] = isa.mul8(
                isa.sub8(isa.load8(&n.b[self.near[a]]), self.o[a]),
                self.inv[a],
            );
            tf[a] = isa.mul8(
                isa.sub8(isa.load8(&n.b[self.far[a]]), self.o[a]),
                self.inv_far[a],
            );
        }
        let [nx, ny, nz] = tn;
        let [fx, fy, fz] = tf;
        // `max_keep8(a, b)` keeps `b` when either is a NaN: a NaN slab may widen the interval
        // (dropping its partner's bound too), never narrow it.
        let t0 = isa.max_keep8(isa.max_keep8(nx, ny), isa.max_keep8(nz, isa.splat8(tmin)));
        let t1 = isa.min_keep8(
            isa.min_keep8(fx, fy),
            isa.min_keep8(fz, isa.splat8(tmax * FAR_SCALE)),
        );
        let mask = isa.le8(t0, t1);
        (mask, isa.store8(t0))
    }
}

/// The ray for the watertight triangle test: the sheared ray and the origin.
pub(super) struct TriRay {
    pub(super) sr: ShearedRay,
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
    pub(super) fn new(ray: &Ray, triangles: bool) -> Self {
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
