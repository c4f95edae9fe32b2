//! The BVH build (Wald 2007; Embree): binned SAH over primitive centroids, nodes widened to
//! eight children, large subtrees in parallel.

use rayon::prelude::*;

use super::lanes::FlatPrim;
use super::layout::{BvhNode, Kind, Ref, COUNT_MASK, KINDS, KIND_SHIFT, MEDIAN_DEPTH, W};
use super::Bvh;
use crate::accel::BuildPrim;
use crate::geometry::Geometry;
use crate::simd::F4;

/// Subtrees larger than this are built on separate threads.
pub(super) const PARALLEL_THRESHOLD: usize = 8192;
/// Ranges larger than this are binned on several threads.
const PARALLEL_BINNING: usize = 65536;
/// Number of centroid bins per axis.
const BINS: usize = 16;
/// Largest leaf of primitives tested in blocks (four blocks).
const MAX_TRI_LEAF: usize = 16;
/// Largest leaf of other primitives (tested one by one).
const MAX_OBJ_LEAF: usize = 4;
/// Cost of a node visit relative to testing one block of triangles.
const TRAVERSAL_COST: f32 = 0.5;
/// Cost of testing one primitive other than a triangle.
const OBJ_COST: f32 = 2.0;

impl BvhNode {
    /// Sets child `i` to `r` with box `b`.
    fn set(&mut self, i: usize, b: &Aabb, r: Ref) {
        for a in 0..3 {
            self.b[a][i] = b.lo()[a];
            self.b[a + 3][i] = b.hi()[a];
        }
        self.child[i] = r.child;
        self.meta[i] = r.meta;
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
            root,
            ids,
            ..Self::default()
        };
        bvh.pack_triangles(&mut nodes, geometry);
        bvh.pack_objects(&mut nodes, geometry);
        bvh.nodes = nodes.into();
        bvh.flat = bvh.flat_root();
        if !bvh.flat.is_empty() {
            (bvh.flat_prims, bvh.flat_rest) = bvh.flat_split(geometry);
            bvh.flat_triangles = bvh
                .flat_prims
                .iter()
                .any(|p| matches!(p, FlatPrim::Tri { .. }));
        }
        bvh
    }
}

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
        let kind = Kind::of(geometry, p.id);
        let (l, h) = (p.bounds.min, p.bounds.max);
        Self {
            lo: [l.x, l.y, l.z, f32::from_bits(p.id)],
            hi: [h.x, h.y, h.z, f32::from_bits(kind as u32)],
        }
    }

    #[inline(always)]
    fn id(&self) -> u32 {
        self.lo[3].to_bits()
    }

    #[inline(always)]
    fn kind(&self) -> Kind {
        Kind::from_bits(self.hi[3].to_bits())
    }

    /// The box's corners, their fourth lanes (the id and the kind) zero.
    #[inline(always)]
    fn corners(&self) -> (F4, F4) {
        let xyz = F4::load(&[0.0, 0.0, 0.0, 1.0]).eq_mask(F4::splat(0.0));
        let zero = F4::splat(0.0);
        (
            F4::select(xyz, F4::load(&self.lo), zero),
            F4::select(xyz, F4::load(&self.hi), zero),
        )
    }
}

/// A box as four lanes (the fourth unused), in SSE registers: growing a box by another is one
/// minimum and one maximum (the binning and partitioning loops are most of a build).
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: F4,
    hi: F4,
}

impl Aabb {
    #[inline(always)]
    fn empty() -> Aabb {
        Aabb {
            lo: F4::splat(f32::INFINITY),
            hi: F4::splat(f32::NEG_INFINITY),
        }
    }

    /// Grows the box by `[lo, hi]`: per lane `if lo < self.lo { lo } else { self.lo }`, and
    /// likewise for the maxima.
    #[inline(always)]
    fn grow(&mut self, lo: F4, hi: F4) {
        self.lo = lo.min_keep(self.lo);
        self.hi = hi.max_keep(self.hi);
    }

    #[inline(always)]
    fn union(mut self, o: &Aabb) -> Aabb {
        self.grow(o.lo, o.hi);
        self
    }

    /// The lower corner.
    #[inline(always)]
    fn lo(&self) -> [f32; 4] {
        self.lo.to_array()
    }

    /// The upper corner.
    #[inline(always)]
    fn hi(&self) -> [f32; 4] {
        self.hi.to_array()
    }

    /// Half the surface area (0 when empty).
    #[inline(always)]
    fn half_area(&self) -> f32 {
        let d = self.hi.sub(self.lo).to_array();
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
    /// Primitives of each [`Kind`].
    kinds: [u32; KINDS],
}

impl Info {
    #[inline(always)]
    fn empty() -> Info {
        Info {
            b: Aabb::empty(),
            c: Aabb::empty(),
            n: 0,
            kinds: [0; KINDS],
        }
    }

    #[inline(always)]
    fn add(&mut self, p: &PrimRef) {
        let (lo, hi) = p.corners();
        self.b.grow(lo, hi);
        // Twice the centroid.
        let c = lo.add(hi);
        self.c.grow(c, c);
        self.n += 1;
        self.kinds[p.kind() as usize] += 1;
    }

    fn merge(mut self, o: &Info) -> Info {
        self.b = self.b.union(&o.b);
        self.c = self.c.union(&o.c);
        self.n += o.n;
        for k in 0..KINDS {
            self.kinds[k] += o.kinds[k];
        }
        self
    }

    fn of(prims: &[PrimRef]) -> Info {
        if prims.len() > PARALLEL_BINNING {
            prims
                .par_chunks(PARALLEL_BINNING / 4)
                .map(Info::of)
                .reduce(Info::empty, |a, b| a.merge(&b))
        } else {
            let mut i = Info::empty();
            for p in prims {
                i.add(p);
            }
            i
        }
    }

    /// The one kind of the range (the first present when mixed).
    fn kind(&self) -> Kind {
        let k = self.kinds.iter().position(|&c| c != 0).unwrap_or(0);
        Kind::from_bits(k as u32)
    }

    /// All primitives of the range go into blocks of four.
    fn blocked(&self) -> bool {
        !self.mixed() && self.kind().blocked()
    }

    fn mixed(&self) -> bool {
        self.kinds.iter().filter(|&&c| c != 0).count() > 1
    }

    fn max_leaf(&self) -> usize {
        if self.blocked() {
            MAX_TRI_LEAF
        } else {
            MAX_OBJ_LEAF
        }
    }
}

/// The cost of intersecting `n` primitives of a range: blocks of four for the kinds tested in
/// blocks, [`OBJ_COST`] for each other primitive.
#[inline(always)]
fn prim_cost(n: usize, blocked: bool) -> f32 {
    if blocked {
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
            b: [[Aabb::empty(); BINS]; 3],
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
            let ext = c.hi()[a] - c.lo()[a];
            if ext > 0.0 {
                scale[a] = BINS as f32 * 0.999_99 / ext;
            }
        }
        Self { lo: c.lo(), scale }
    }

    /// The bins of a doubled centroid `c2` (a primitive's `lo + hi`) on the three axes: its
    /// scaled position from the corner, truncated, between 0 (a NaN and negatives too) and the
    /// last bin. Clamped while still a float, the position is truncated in one instruction for
    /// all three axes, where three saturating conversions took about a fifth of a mesh's
    /// build.
    #[inline(always)]
    fn bins(&self, c2: F4) -> [usize; 3] {
        let x = c2
            .sub(F4::load(&self.lo))
            .mul(F4::load(&self.scale))
            .max_keep(F4::splat(0.0))
            .min_keep(F4::splat((BINS - 1) as f32))
            .trunc_i32();
        [0, 1, 2].map(|a| x[a] as usize)
    }

    /// The bin of primitive `p` on axis `a` (as [`Binner::bins`] gives it: one conversion
    /// rule for the binning and the partition that follows it).
    #[inline(always)]
    fn bin(&self, p: &PrimRef, a: usize) -> usize {
        let (lo, hi) = p.corners();
        self.bins(lo.add(hi))[a]
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
            let (lo, hi) = p.corners();
            let ix = self.bins(lo.add(hi));
            for a in 0..3 {
                bins.b[a][ix[a]].grow(lo, hi);
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
        // Leaves are never mixed: one kind first.
        let first = info.kind();
        return Some(partition(prims, |p| p.kind() == first));
    }
    if depth >= MEDIAN_DEPTH {
        return (!small || info.mixed()).then(|| median_split(prims, info));
    }
    let binner = Binner::new(&info.c);
    if binner.scale[..3].iter().all(|&s| s == 0.0) {
        // All centroids coincide.
        return (!small || info.mixed()).then(|| median_split(prims, info));
    }
    let tri = info.blocked();
    let bins = binner.fill(prims);
    // Best over axes of the unnormalised SAH cost: A_L·C(L) + A_R·C(R).
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for a in 0..3 {
        if binner.scale[a] == 0.0 {
            continue;
        }
        let mut right = [0f32; BINS];
        let (mut acc, mut cnt) = (Aabb::empty(), 0usize);
        for i in (1..BINS).rev() {
            acc = acc.union(&bins.b[a][i]);
            cnt += bins.n[a][i] as usize;
            right[i] = acc.half_area() * prim_cost(cnt, tri);
        }
        let (mut acc, mut cnt) = (Aabb::empty(), 0usize);
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
        let (lo, hi) = (info.c.lo(), info.c.hi());
        if hi[a] - lo[a] > hi[axis] - lo[axis] {
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
    let (mut li, mut ri) = (Info::empty(), Info::empty());
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
        meta: (info.kind() as u32 + 1) << KIND_SHIFT | info.n as u32,
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
        info: Info::empty(),
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
