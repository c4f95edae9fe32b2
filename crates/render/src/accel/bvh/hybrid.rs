//! Incoherent batches of rays through a deep BVH: packet traversal at the top of the tree, ray
//! by ray below (hybrid traversal, after Embree's `BVHNIntersectorKHybrid`).
//!
//! The rays of a batch that share no direction signs still share the top of the tree: the
//! sixteen bounce rays of a pixel start near the same point. The batch goes down from the root
//! as a packet: each child box of a node is tested against all its rays at once, sixteen lanes
//! wide, each lane choosing its own near and far planes by the sign of its reciprocal direction
//! (a select), so that each lane's arithmetic is exactly the single-ray box test's; a child is
//! visited by the lanes whose rays cross its box. Once a node (or leaf) is reached by at most
//! [`threshold`] lanes, each of them goes on alone from there, by the single-ray traversal
//! ([`Bvh::intersect_from`], [`Bvh::occluded_from`]) started at that subtree with the lane's
//! closest hit so far. Leaves reached by more lanes are tested lane by lane (triangles: the
//! watertight test's axes differ between lanes) or, for parallelograms, spheres and boxes, all
//! lanes at once ([`super::packet::blocks_leaf`]).
//!
//! The closest hit is the single-ray one bit for bit: every leaf whose box a lane's ray crosses
//! (within the lane's current `tmax`) is still tested for that lane with the single-ray leaf
//! arithmetic, and the hit kept is the smallest (t, primitive id), whatever the order. Only the
//! number of nodes visited differs.

use super::lanes::Lanes;
use super::layout::{
    Ref, BOX_LEAF, COUNT_MASK, OBJ_LEAF, QUAD_LEAF, SPHERE_LEAF, STACK, W as NODE_WIDTH,
};
use super::packet::{blocks_leaf, Any, Closest, LaneState, PacketQuery};
use super::traverse::FAR_SCALE;
use super::Bvh;
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{RayBatch, BATCH};
use crate::simd::{SimdLevel, Wide, WideKernel};
use crate::stats::RayStats;

/// A node or leaf reached by at most this many lanes is left to each lane alone.
pub(super) fn threshold() -> u32 {
    super::batch::tune("PK_T", 3)
}

impl Bvh {
    /// The closest hits of the lanes `lanes` of `rays`, by the hybrid traversal.
    pub(super) fn intersect_hybrid(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        lanes: u32,
        hits: &mut [Option<Hit>; BATCH],
        stats: &mut RayStats,
    ) {
        crate::simd::run_wide_at(
            level,
            Hybrid {
                bvh: self,
                geometry,
                rays,
                lanes,
                threshold: threshold(),
                query: Closest { hits },
                stats,
            },
        );
    }

    /// The lanes `lanes` of `rays` that hit something, by the hybrid traversal.
    pub(super) fn occluded_hybrid(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        lanes: u32,
        stats: &mut RayStats,
    ) -> u32 {
        let mut found = 0;
        crate::simd::run_wide_at(
            level,
            Hybrid {
                bvh: self,
                geometry,
                rays,
                lanes,
                threshold: threshold(),
                query: Any { found: &mut found },
                stats,
            },
        );
        found
    }
}

/// A hybrid traversal, as a kernel for [`crate::simd::run_wide_at`].
struct Hybrid<'a, Q> {
    bvh: &'a Bvh,
    geometry: &'a Geometry,
    rays: &'a RayBatch,
    /// The lanes traced.
    lanes: u32,
    threshold: u32,
    query: Q,
    stats: &'a mut RayStats,
}

impl<Q: PacketQuery> WideKernel for Hybrid<'_, Q> {
    type Output = ();

    #[inline(always)]
    fn run<W: Wide>(mut self, w: W) {
        let bvh = self.bvh;
        let r = self.rays;
        let o = [w.load(&r.o[0]), w.load(&r.o[1]), w.load(&r.o[2])];
        let d = [w.load(&r.d[0]), w.load(&r.d[1]), w.load(&r.d[2])];
        let one = w.splat(1.0);
        let zero = w.splat(0.0);
        // The reciprocals of `RayBox::new` (the same quotients) and, per lane and axis,
        // whether the max plane is crossed first (`inv < 0`, as `RayBox::new` decides).
        let inv = [w.div(one, d[0]), w.div(one, d[1]), w.div(one, d[2])];
        let neg = [w.lt(inv[0], zero), w.lt(inv[1], zero), w.lt(inv[2], zero)];
        let tmin = w.load(&r.tmin);
        let lanes = Lanes { o, d, tmin };
        let far_scale = w.splat(FAR_SCALE);
        let mut st = LaneState {
            tmax_lanes: r.tmax,
            tmax: w.load(&r.tmax),
            live: self.lanes,
        };
        let mut stack = [(Ref::EMPTY, 0u32); STACK];
        let mut sp = 0usize;
        let mut cur = bvh.root;
        let mut mask = self.lanes;
        let mut t0_lanes = [0f32; BATCH];
        loop {
            if mask.count_ones() <= self.threshold {
                // Few lanes: each alone from this subtree down.
                let mut m = mask;
                let mut changed = false;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let mut ray = r.ray(i);
                    ray.tmax = st.tmax_lanes[i];
                    let (new_tmax, done) =
                        self.query
                            .subtree(bvh, self.geometry, cur, i, &ray, self.stats);
                    if let Some(tm) = new_tmax {
                        st.tmax_lanes[i] = tm;
                        changed = true;
                    }
                    if done {
                        st.live &= !(1 << i);
                    }
                }
                if changed {
                    st.tmax = w.load(&st.tmax_lanes);
                }
            } else if cur.meta == 0 {
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
                    let mut t1 = st.tmax;
                    for a in 0..3 {
                        let lo = w.mul(w.sub(w.splat(node.b[a][c]), o[a]), inv[a]);
                        let hi = w.mul(w.sub(w.splat(node.b[a + 3][c]), o[a]), inv[a]);
                        let tn = w.select(neg[a], hi, lo);
                        let tf = w.select(neg[a], lo, hi);
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
            } else if matches!(cur.meta & !COUNT_MASK, QUAD_LEAF | SPHERE_LEAF | BOX_LEAF) {
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
            } else {
                // Triangles (whose test axes differ between lanes) and other primitives.
                let mut m = mask;
                let mut changed = false;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let mut ray = r.ray(i);
                    ray.tmax = st.tmax_lanes[i];
                    let (new_tmax, done) =
                        self.query
                            .other_leaf(bvh, self.geometry, cur, i, &ray, self.stats);
                    if let Some(tm) = new_tmax {
                        st.tmax_lanes[i] = tm;
                        changed = true;
                    }
                    if done {
                        st.live &= !(1 << i);
                    }
                }
                if changed {
                    st.tmax = w.load(&st.tmax_lanes);
                }
            }
            // The next entry some live lane still visits.
            loop {
                if sp == 0 || st.live == 0 {
                    return;
                }
                sp -= 1;
                (cur, mask) = stack[sp];
                mask &= st.live;
                if mask != 0 {
                    break;
                }
            }
        }
    }
}
