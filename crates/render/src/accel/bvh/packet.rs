//! Coherent batches of rays through a deep BVH together (packet traversal).
//!
//! The samples of one pixel are traced side by side ([`RayBatch`]); their camera rays, and
//! often their shadow rays towards a small light, start close together and point the same way,
//! so they cross the same nodes. The active rays of a batch that the caller marks coherent
//! ([`RayBatch::coherent`]: the path tracer marks a pixel's camera rays and the shadow rays of
//! its first hits, not the rays of deeper vertices, which start at scattered points: as packets
//! they made meshes-sky 1.04× slower) are grouped by their direction signs and their axes for
//! the watertight triangle test ([`Coherence::groups`]); each group of
//! at least [`PACKET_MIN`] rays (all of a pixel's camera rays; its shadow rays towards a small
//! light while those towards the sky go elsewhere) goes down the tree as one packet: each child
//! box of a node is tested against all the group's rays at once, sixteen lanes wide
//! ([`crate::simd::Wide`]), a child is visited by the rays that hit its box (a lane mask),
//! nearest child first (by its first ray's entry distance), and each triangle, parallelogram,
//! sphere or box of a leaf is tested against all those rays at once (the latter three by the
//! lane-exact tests of [`super::lanes`]). The rays in no group go one by one.
//!
//! Results are the single-ray traversal's, bit for bit: the box test is the same arithmetic
//! per lane (a packet may visit more nodes than a ray alone, never fewer: boxes only cull), the
//! triangle test is [`crate::shape::intersect_triangle`]'s arithmetic per lane (with its f64
//! edge fallback), the other tests those of the four-primitive blocks
//! ([`crate::accel::blocks`]), with the same `t`, surface parameters and face, and the closest
//! hit is the smallest (t, primitive id) over every primitive whose test passes, which does not
//! depend on the order of the tests. Leaves of other primitives go through the single-ray leaf
//! routines, lane by lane.
//!
//! A node costs a packet about eight single-ray node tests, so packets pay when most lanes
//! follow the same nodes and the sixteen lanes take one or two registers: [`Bvh::intersect_batch`]
//! takes this path with AVX2 or AVX-512 (measured on meshes-sky: 0.94× the frame time with
//! either; the wide leaves of parallelograms, spheres and boxes 0.82× at `max_depth=1`, where
//! the ground rectangle takes 45% of the camera rays, 0.96× at full depth; sub-groups 0.99×;
//! the kernels run and are tested at every width, SSE included). Incoherent rays stay one by
//! one: a hybrid traversal (a packet at the top of the tree, per-lane near planes, each lane
//! on its own below a node reached by at most a few lanes) measured 0.97–1.06× with 1.6% more
//! instructions, as rays here visit about five nodes each and share little more than the root;
//! ordering children by the smallest entry distance of their lanes and skipping popped entries
//! beyond every lane's closest hit measured 1.03× (full depth) and 1.04× (`max_depth=1`).

use super::lanes::{edge_functions, test, FlatPrim, Lanes};
use super::layout::{
    Ref, BOX_LEAF, COUNT_MASK, OBJ_LEAF, QUAD_LEAF, SPHERE_LEAF, STACK, TRI_LEAF, W as NODE_WIDTH,
};
use super::traverse::FAR_SCALE;
use super::Bvh;
use crate::accel::closest;
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{RayBatch, BATCH};
use crate::shape::ShearedRay;
use crate::simd::{SimdLevel, Wide, WideKernel};
use crate::stats::RayStats;

/// The fewest active rays a packet is worth.
const PACKET_MIN: u32 = 6;

/// What the rays of a coherent batch share: the axes of the watertight triangle test
/// ([`ShearedRay::axes`]) and, per axis, the box plane (index into a node's `b`) crossed first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Coherence {
    k: [u8; 3],
    near: [u8; 3],
}

impl Coherence {
    /// What every active ray of `rays` shares, when they share it and there are enough of them.
    #[cfg(test)]
    pub(super) fn of(rays: &RayBatch) -> Option<Self> {
        let g = Self::groups(rays, rays.active);
        (g.len == 1 && g.groups[0].1 == rays.active).then_some(g.groups[0].0)
    }

    /// The lanes of `rays` in `active` grouped by what they share: every group of at least
    /// [`PACKET_MIN`] lanes (at most two of sixteen), in order of their lowest lane; lanes in
    /// no group go ray by ray.
    pub(super) fn groups(rays: &RayBatch, active: u32) -> Groups {
        let mut out = Groups {
            groups: [(
                Coherence {
                    k: [0; 3],
                    near: [0; 3],
                },
                0,
            ); 2],
            len: 0,
        };
        if active.count_ones() < PACKET_MIN {
            return out;
        }
        // Straight from the lanes (this runs for every batch of a deep tree), every lane at
        // once without branches (the compiler vectorises it; active or not, a lane's key is
        // only read when it is active): the sign of the reciprocal, as the single-ray box
        // test sees it (1/-0 = -∞ < 0, 1/NaN is not), and the axes of `ShearedRay::axes` (the
        // largest |d| and its sign).
        let mut keys = [0u32; BATCH];
        for (i, k) in keys.iter_mut().enumerate() {
            *k = key(rays, i);
        }
        let mut rest = active;
        while rest.count_ones() >= PACKET_MIN {
            let first = rest.trailing_zeros() as usize;
            let k0 = keys[first];
            let mut same = 0u32;
            for (i, &k) in keys.iter().enumerate() {
                same |= ((k == k0) as u32) << i;
            }
            let group = same & rest;
            rest &= !group;
            if group.count_ones() >= PACKET_MIN {
                let near = [0, 1, 2].map(|a| if k0 >> (2 - a) & 1 == 1 { a + 3 } else { a });
                out.groups[out.len] = (
                    Self {
                        k: ShearedRay::axes(&rays.ray(first)).map(|a| a as u8),
                        near,
                    },
                    group,
                );
                out.len += 1;
            }
        }
        out
    }
}

/// Lane `i`'s coherence key: its watertight-test axis and sign, and its direction signs
/// ([`crate::math::Vec3::max_dimension`]'s choice, with the same comparisons, made by selects).
#[inline(always)]
fn key(rays: &RayBatch, i: usize) -> u32 {
    let [x, y, z] = [rays.d[0][i], rays.d[1][i], rays.d[2][i]];
    let [ax, ay, az] = [x.abs(), y.abs(), z.abs()];
    let negative = |v: f32| (v.to_bits() >> 31) & !v.is_nan() as u32;
    let below = |v: f32| (v < 0.0) as u32;
    let (kz, neg_k) = if ax > ay {
        if ax > az {
            (0, below(x))
        } else {
            (2, below(z))
        }
    } else if ay > az {
        (1, below(y))
    } else {
        (2, below(z))
    };
    kz << 4 | neg_k << 3 | negative(x) << 2 | negative(y) << 1 | negative(z)
}

/// The coherent groups of a batch's lanes ([`Coherence::groups`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Groups {
    /// What each group shares, and its lanes.
    pub(super) groups: [(Coherence, u32); 2],
    /// How many groups there are.
    pub(super) len: usize,
}

impl Groups {
    /// The groups, with their lanes.
    pub(super) fn iter(&self) -> impl Iterator<Item = (Coherence, u32)> + '_ {
        self.groups[..self.len].iter().copied()
    }

    /// The lanes in some group.
    pub(super) fn lanes(&self) -> u32 {
        self.iter().fold(0, |m, g| m | g.1)
    }
}

impl Bvh {
    /// The closest hits of the lanes `lanes` of `rays`, which share `c`, as one packet.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn intersect_packet(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        c: Coherence,
        lanes: u32,
        hits: &mut [Option<Hit>; BATCH],
        stats: &mut RayStats,
    ) {
        crate::simd::run_wide_at(
            level,
            Packet {
                bvh: self,
                geometry,
                rays,
                c,
                lanes,
                query: Closest { hits },
                stats,
            },
        );
    }

    /// The lanes `lanes` of `rays` (which share `c`) that hit something, as one packet.
    pub(super) fn occluded_packet(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        c: Coherence,
        lanes: u32,
        stats: &mut RayStats,
    ) -> u32 {
        let mut found = 0;
        crate::simd::run_wide_at(
            level,
            Packet {
                bvh: self,
                geometry,
                rays,
                c,
                lanes,
                query: Any { found: &mut found },
                stats,
            },
        );
        found
    }
}

/// What a packet looks for: the closest hit of every lane, or any hit.
pub(super) trait PacketQuery {
    /// Whether children are visited nearest first.
    const ORDERED: bool;
    /// Lane `i` found the hit `h`; returns the lane's new `tmax` when the hit is kept, and
    /// whether the lane is finished.
    fn hit(&mut self, i: usize, h: Hit) -> (Option<f32>, bool);
    /// A leaf of other primitives for lane `i` along `ray`; returns what [`Self::hit`] does.
    fn other_leaf(
        &mut self,
        bvh: &Bvh,
        geometry: &Geometry,
        r: Ref,
        i: usize,
        ray: &crate::math::Ray,
        stats: &mut RayStats,
    ) -> (Option<f32>, bool);
}

/// The closest hit of every lane.
pub(super) struct Closest<'a> {
    pub(super) hits: &'a mut [Option<Hit>; BATCH],
}

impl PacketQuery for Closest<'_> {
    const ORDERED: bool = true;

    #[inline(always)]
    fn hit(&mut self, i: usize, h: Hit) -> (Option<f32>, bool) {
        // The single-ray rule: smaller t, equal t to the smaller id.
        let kept = closest(&mut self.hits[i], h);
        (kept.then(|| h.t.next_up()), false)
    }

    fn other_leaf(
        &mut self,
        bvh: &Bvh,
        geometry: &Geometry,
        r: Ref,
        i: usize,
        ray: &crate::math::Ray,
        stats: &mut RayStats,
    ) -> (Option<f32>, bool) {
        match bvh.leaf_closest(geometry, r, ray, stats) {
            Some(h) => self.hit(i, h),
            None => (None, false),
        }
    }
}

/// Any hit: bit i set when lane i found one.
pub(super) struct Any<'a> {
    pub(super) found: &'a mut u32,
}

impl PacketQuery for Any<'_> {
    const ORDERED: bool = false;

    #[inline(always)]
    fn hit(&mut self, i: usize, _: Hit) -> (Option<f32>, bool) {
        *self.found |= 1 << i;
        (None, true)
    }

    fn other_leaf(
        &mut self,
        bvh: &Bvh,
        geometry: &Geometry,
        r: Ref,
        i: usize,
        ray: &crate::math::Ray,
        stats: &mut RayStats,
    ) -> (Option<f32>, bool) {
        if bvh.leaf_any(geometry, r, ray, stats) {
            *self.found |= 1 << i;
            (None, true)
        } else {
            (None, false)
        }
    }
}

/// A packet traversal, as a kernel for [`crate::simd::run_wide_at`].
struct Packet<'a, Q> {
    bvh: &'a Bvh,
    geometry: &'a Geometry,
    rays: &'a RayBatch,
    c: Coherence,
    /// The lanes traced (a subset of the active ones).
    lanes: u32,
    query: Q,
    stats: &'a mut RayStats,
}

impl<Q: PacketQuery> WideKernel for Packet<'_, Q> {
    type Output = ();

    #[inline(always)]
    fn run<W: Wide>(mut self, w: W) {
        let bvh = self.bvh;
        let r = self.rays;
        let o = [w.load(&r.o[0]), w.load(&r.o[1]), w.load(&r.o[2])];
        let d = [w.load(&r.d[0]), w.load(&r.d[1]), w.load(&r.d[2])];
        let one = w.splat(1.0);
        let inv = [w.div(one, d[0]), w.div(one, d[1]), w.div(one, d[2])];
        let near = self.c.near.map(usize::from);
        let far = near.map(|p| (p + 3) % 6);
        let [kx, ky, kz] = self.c.k.map(usize::from);
        // The sheared ray of the watertight test: the same quotients as `TriRay::new`.
        let sx = w.div(d[kx], d[kz]);
        let sy = w.div(d[ky], d[kz]);
        let sz = w.div(one, d[kz]);
        let (ox, oy, oz) = (o[kx], o[ky], o[kz]);
        let tmin = w.load(&r.tmin);
        let lanes = Lanes {
            o,
            d,
            tmin,
            shear: None,
        };
        let mut tmax_lanes = r.tmax;
        let mut tmax = w.load(&tmax_lanes);
        let far_scale = w.splat(FAR_SCALE);
        let zero = w.splat(0.0);

        // Lanes still looking (any-hit lanes leave when they find something).
        let mut live = self.lanes;
        let mut stack = [(Ref::EMPTY, 0u32); STACK];
        let mut sp = 0usize;
        let mut cur = bvh.root;
        let mut mask = live;
        let mut t0_lanes = [0f32; BATCH];
        loop {
            if cur.meta == 0 {
                self.stats.nodes += mask.count_ones() as u64;
                let node = &bvh.nodes[cur.child as usize];
                let mut kids = [(Ref::EMPTY, 0u32, 0f32); NODE_WIDTH];
                let mut n = 0;
                for c in 0..NODE_WIDTH {
                    if node.meta[c] == OBJ_LEAF {
                        // An empty leaf (an unused slot): nothing to find there. (Not
                        // judged by its box: a real child's box may be inverted on an axis,
                        // and a ray alone may still cross it.)
                        continue;
                    }
                    let mut t0 = tmin;
                    let mut t1 = tmax;
                    for a in 0..3 {
                        let tn = w.mul(w.sub(w.splat(node.b[near[a]][c]), o[a]), inv[a]);
                        let tf = w.mul(w.sub(w.splat(node.b[far[a]][c]), o[a]), inv[a]);
                        // A NaN never narrows the interval (as `max_keep8` / `min_keep8`).
                        t0 = w.select(w.gt(tn, t0), tn, t0);
                        t1 = w.select(w.lt(tf, t1), tf, t1);
                    }
                    let m = w.bits(w.le(t0, w.mul(t1, far_scale))) & mask;
                    if m != 0 {
                        let dist = if Q::ORDERED {
                            w.store(t0, &mut t0_lanes);
                            t0_lanes[m.trailing_zeros() as usize]
                        } else {
                            0.0
                        };
                        let child = Ref {
                            child: node.child[c],
                            meta: node.meta[c],
                        };
                        // Insertion by entry distance, nearest first.
                        let mut j = n;
                        while Q::ORDERED && j > 0 && kids[j - 1].2 > dist {
                            kids[j] = kids[j - 1];
                            j -= 1;
                        }
                        kids[j] = (child, m, dist);
                        n += 1;
                    }
                }
                if n > 0 {
                    // The others on the stack, farthest deepest.
                    for k in (1..n).rev() {
                        stack[sp] = (kids[k].0, kids[k].1);
                        sp += 1;
                    }
                    (cur, mask) = (kids[0].0, kids[0].1);
                    continue;
                }
            } else {
                let n = cur.meta & COUNT_MASK;
                let first = cur.child as usize;
                if cur.meta & !COUNT_MASK == TRI_LEAF {
                    self.stats.prim_tests += n as u64 * mask.count_ones() as u64;
                    'blocks: for (k, tri) in bvh.tris[first..first + n.div_ceil(4) as usize]
                        .iter()
                        .enumerate()
                    {
                        let in_leaf = (n as usize - 4 * k).min(4);
                        for j in 0..in_leaf {
                            let v = &tri.v;
                            let z = [0, 1, 2].map(|p| w.sub(w.splat(v[p][kz][j]), oz));
                            let px = [0, 1, 2]
                                .map(|p| w.sub(w.sub(w.splat(v[p][kx][j]), ox), w.mul(sx, z[p])));
                            let py = [0, 1, 2]
                                .map(|p| w.sub(w.sub(w.splat(v[p][ky][j]), oy), w.mul(sy, z[p])));
                            let [ax, bx, cx] = px;
                            let [ay, by, cy] = py;
                            let [u, vv, ww] = edge_functions(w, [ax, bx, cx], [ay, by, cy], mask);
                            let neg = w.or(w.or(w.lt(u, zero), w.lt(vv, zero)), w.lt(ww, zero));
                            let pos = w.or(w.or(w.gt(u, zero), w.gt(vv, zero)), w.gt(ww, zero));
                            let det = w.add(w.add(u, vv), ww);
                            let inside = w.bits(w.and_not(w.ne(det, zero), w.and(neg, pos)));
                            if inside & mask == 0 {
                                continue;
                            }
                            let t_scaled = w.add(
                                w.add(w.mul(u, w.mul(sz, z[0])), w.mul(vv, w.mul(sz, z[1]))),
                                w.mul(ww, w.mul(sz, z[2])),
                            );
                            let inv_det = w.div(one, det);
                            let t = w.mul(t_scaled, inv_det);
                            let mut valid =
                                inside & mask & w.bits(w.and(w.gt(t, tmin), w.lt(t, tmax)));
                            if valid == 0 {
                                continue;
                            }
                            let mut lanes = [[0f32; BATCH]; 4];
                            for (dst, src) in lanes.iter_mut().zip([t, vv, ww, inv_det]) {
                                w.store(src, dst);
                            }
                            let [tl, vl, wl, il] = lanes;
                            let mut changed = false;
                            while valid != 0 {
                                let i = valid.trailing_zeros() as usize;
                                valid &= valid - 1;
                                let h = Hit {
                                    t: tl[i],
                                    prim: tri.id[j],
                                    uv: [vl[i] * il[i], wl[i] * il[i]],
                                    sub: 0,
                                    leaf: 0,
                                };
                                let (new_tmax, done) = self.query.hit(i, h);
                                if let Some(tm) = new_tmax {
                                    tmax_lanes[i] = tm;
                                    changed = true;
                                }
                                if done {
                                    live &= !(1 << i);
                                    mask &= !(1 << i);
                                }
                            }
                            if changed {
                                tmax = w.load(&tmax_lanes);
                            }
                            if mask == 0 {
                                break 'blocks;
                            }
                        }
                    }
                } else if matches!(cur.meta & !COUNT_MASK, QUAD_LEAF | SPHERE_LEAF | BOX_LEAF) {
                    let mut st = LaneState {
                        tmax_lanes,
                        tmax,
                        live,
                    };
                    blocks_leaf(
                        w,
                        bvh,
                        cur,
                        &lanes,
                        &mut mask,
                        &mut st,
                        &mut self.query,
                        self.stats,
                    );
                    (tmax_lanes, tmax, live) = (st.tmax_lanes, st.tmax, st.live);
                } else {
                    let mut m = mask;
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let mut ray = r.ray(i);
                        ray.tmax = tmax_lanes[i];
                        let (new_tmax, done) =
                            self.query
                                .other_leaf(bvh, self.geometry, cur, i, &ray, self.stats);
                        if let Some(tm) = new_tmax {
                            tmax_lanes[i] = tm;
                        }
                        if done {
                            live &= !(1 << i);
                        }
                    }
                    tmax = w.load(&tmax_lanes);
                }
            }
            // The next entry some live lane still visits.
            loop {
                if sp == 0 || live == 0 {
                    return;
                }
                sp -= 1;
                (cur, mask) = stack[sp];
                mask &= live;
                if mask != 0 {
                    break;
                }
            }
        }
    }
}

/// What a packet knows of its lanes as it goes: each lane's `tmax` (one ULP above its closest
/// hit so far), in memory and in a register, and the lanes still looking.
pub(super) struct LaneState<W: Wide> {
    pub(super) tmax_lanes: [f32; BATCH],
    pub(super) tmax: W::V,
    pub(super) live: u32,
}

/// A leaf of parallelogram, sphere or box blocks (`cur`) for the lanes in `mask`: each
/// primitive against all of them at once, by the lane-exact wide tests ([`super::lanes`]);
/// lanes that finish leave `mask` and `st.live`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn blocks_leaf<W: Wide, Q: PacketQuery>(
    w: W,
    bvh: &Bvh,
    cur: Ref,
    lanes: &Lanes<W>,
    mask: &mut u32,
    st: &mut LaneState<W>,
    query: &mut Q,
    stats: &mut RayStats,
) {
    let n = cur.meta & COUNT_MASK;
    let first = cur.child as usize;
    stats.prim_tests += n as u64 * mask.count_ones() as u64;
    for k in 0..n.div_ceil(4) as usize {
        let in_leaf = (n as usize - 4 * k).min(4);
        for j in 0..in_leaf {
            let p = FlatPrim::of_block(bvh, cur.meta, first + k, j);
            let (h, id) = test(w, lanes, st.tmax, &p);
            let mut valid = w.bits(h.valid) & *mask;
            if valid == 0 {
                continue;
            }
            let mut out = [[0f32; BATCH]; 4];
            for (dst, src) in out.iter_mut().zip([h.t, h.u, h.v, h.face]) {
                w.store(src, dst);
            }
            let [tl, ul, vl, fl] = out;
            let mut changed = false;
            while valid != 0 {
                let i = valid.trailing_zeros() as usize;
                valid &= valid - 1;
                let h = Hit {
                    t: tl[i],
                    prim: id,
                    uv: [ul[i], vl[i]],
                    sub: fl[i] as u32,
                    leaf: 0,
                };
                let (new_tmax, done) = query.hit(i, h);
                if let Some(tm) = new_tmax {
                    st.tmax_lanes[i] = tm;
                    changed = true;
                }
                if done {
                    st.live &= !(1 << i);
                    *mask &= !(1 << i);
                }
            }
            if changed {
                st.tmax = w.load(&st.tmax_lanes);
            }
            if *mask == 0 {
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::build_prims;
    use crate::geometry::Object;
    use crate::interaction::SurfaceProps;
    use crate::math::{Point3, Ray, Transform, Vec3};
    use crate::sampling::Pcg32;
    use crate::shape::{Mesh, Shape, Sphere};

    /// A deep tree: a bumpy grid of triangles on integer vertices (rays through its vertices
    /// and edges meet the f64 fallback), a cloud of loose triangles and a few spheres (leaves of
    /// other primitives).
    fn geometry() -> Geometry {
        let mut rng = Pcg32::new(9, 1);
        let mut u = || rng.next_f32() * 2.0 - 1.0;
        let n = 24;
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let z = if (i * 7 + j * 3) % 5 == 0 { 1.0 } else { 0.0 };
                positions.push(Point3::new(i as f32 - 12.0, j as f32 - 12.0, z));
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = (j * (n + 1) + i) as u32;
                let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32 + 2);
                indices.push([a, b, d]);
                indices.push([a, d, c]);
            }
        }
        let grid = Mesh {
            positions,
            indices,
            ..Mesh::default()
        };
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for t in 0..600u32 {
            let c = Vec3::new(u() * 8.0, u() * 8.0, 2.0 + u().abs() * 6.0);
            for _ in 0..3 {
                positions.push((c + Vec3::new(u(), u(), u()) * 0.6).to_point());
            }
            indices.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        let cloud = Mesh {
            positions,
            indices,
            ..Mesh::default()
        };
        let objects = (0..6)
            .map(|_| Object {
                shape: Shape::Sphere(Sphere::new(
                    Transform::translation(Vec3::new(u() * 6.0, u() * 6.0, 3.0 + u().abs() * 3.0))
                        * Transform::scaling(Vec3::new(0.8, 0.8, 0.8)),
                )),
                props: SurfaceProps::default(),
            })
            .collect();
        Geometry::new(objects, vec![grid, cloud])
    }

    /// A coherent batch: origins near `o`, directions near `d` (exactly `o` and `d` when
    /// `exact`, so that rays through vertices stay on them), some lanes inactive or clipped.
    fn batch(rng: &mut Pcg32, o: Point3, d: Vec3, spread: f32, k: usize) -> RayBatch {
        let mut b = RayBatch::default();
        for i in 0..BATCH {
            let mut u = || (rng.next_f32() * 2.0 - 1.0) * spread;
            let shift = Vec3::new(u(), u(), 0.0);
            let mut ray = Ray::new(o + shift, d + Vec3::new(u(), u(), u()) * 0.1);
            if spread == 0.0 {
                // Integer offsets: rays straight down through grid vertices.
                ray = Ray::new(
                    o + Vec3::new((i % 4) as f32, (i / 4) as f32, 0.0),
                    Vec3::new(0.0, 0.0, -1.0),
                );
            }
            if (i + k) % 6 == 5 {
                ray.tmax = 6.5;
            }
            if (i + k) % 7 == 3 {
                ray.tmin = 1.5;
            }
            if !(i * 5 + k).is_multiple_of(13) {
                b.set(i, &ray);
            }
        }
        b
    }

    #[test]
    fn packets_get_the_single_ray_hits_at_every_simd_level() {
        let g = geometry();
        let bvh = Bvh::build(&g, &build_prims(&g));
        assert!(bvh.flat.is_empty() && bvh.root.meta == 0, "a deep tree");
        let mut rng = Pcg32::new(3, 4);
        let (mut packets, mut hits_seen, mut blocked_seen) = (0, 0, 0);
        for k in 0..300 {
            let spread = [0.0, 0.01, 0.3, 2.0][k % 4];
            let o = Point3::new(
                (rng.next_f32() * 16.0 - 8.0).round(),
                (rng.next_f32() * 16.0 - 8.0).round(),
                12.0,
            );
            let target = Point3::new(rng.next_f32() * 8.0 - 4.0, rng.next_f32() * 8.0 - 4.0, 0.0);
            let rays = batch(&mut rng, o, target - o, spread, k);
            let Some(c) = Coherence::of(&rays) else {
                continue;
            };
            packets += 1;
            for level in [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512] {
                let mut st = RayStats::default();
                let mut hits = [None; BATCH];
                bvh.intersect_packet(level, &g, &rays, c, rays.active, &mut hits, &mut st);
                let blocked = bvh.occluded_packet(level, &g, &rays, c, rays.active, &mut st);
                for i in 0..BATCH {
                    if rays.active >> i & 1 == 0 {
                        assert!(hits[i].is_none() && blocked >> i & 1 == 0);
                        continue;
                    }
                    let ray = rays.ray(i);
                    let single = bvh.intersect(&g, &ray, &mut st);
                    assert_eq!(hits[i], single, "{level:?}, batch {k}, lane {i}: {ray:?}");
                    let occluded = bvh.occluded(&g, &ray, &mut st);
                    assert_eq!(blocked >> i & 1 == 1, occluded, "{level:?} {k} {i}");
                    hits_seen += single.is_some() as usize;
                    blocked_seen += occluded as usize;
                }
            }
        }
        assert!(packets > 200, "only {packets} coherent batches");
        assert!(
            hits_seen > 5000 && blocked_seen > 5000,
            "{hits_seen} {blocked_seen}"
        );
    }

    #[test]
    fn batches_of_mixed_directions_are_not_packets() {
        let mut b = RayBatch::default();
        for i in 0..BATCH {
            let d = if i == 9 { -1.0 } else { 1.0 };
            b.set(i, &Ray::new(Point3::ORIGIN, Vec3::new(0.3, d, 2.0)));
        }
        assert_eq!(Coherence::of(&b), None);
        // -0 is crossed the other way round.
        b.set(9, &Ray::new(Point3::ORIGIN, Vec3::new(0.3, 1.0, 2.0)));
        assert!(Coherence::of(&b).is_some());
        b.set(3, &Ray::new(Point3::ORIGIN, Vec3::new(-0.0, 1.0, 2.0)));
        assert_eq!(Coherence::of(&b), None);
        // Too few rays.
        b.active = 0b11111;
        assert_eq!(Coherence::of(&b), None);
    }
}
