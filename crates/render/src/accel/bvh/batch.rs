//! Batches of rays through the BVH ([`RayBatch`]).
//!
//! A small scene, whose root's children are all leaves ([`Bvh::flat`]), is tested brute force:
//! each parallelogram, sphere and box is broadcast and tested against all the rays at once,
//! sixteen lanes wide ([`crate::simd::Wide`]: one AVX-512 register, two AVX or four SSE ones),
//! by lane-exact copies of the shapes' scalar tests, so every lane gets the single-ray hit bit
//! for bit. These primitives are kept in increasing id order ([`FlatPrim`]), so that a strict
//! `t < best` is the single-ray rule "equal t goes to the smaller id". Other primitives of a
//! small scene, and every ray of a deeper tree, go through the single-ray traversal, lane by
//! lane.

use super::layout::{Kind, Ref, COUNT_MASK, KIND_SHIFT};
use super::packet::Coherence;
use super::Bvh;
use crate::geometry::{Geometry, PrimRef as GeomPrim};
use crate::interaction::Hit;
use crate::math::{RayBatch, BATCH};
use crate::shape::Shape;
use crate::simd::{SimdLevel, Wide, WideKernel};
use crate::stats::RayStats;

/// A primitive of a small scene tested against whole batches, with what its test needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FlatPrim {
    /// A parallelogram: corner, v × w and the dual edge vectors.
    Quad {
        /// Corner.
        p: [f32; 3],
        /// v × w.
        n: [f32; 3],
        /// Dual of v.
        ds: [f32; 3],
        /// Dual of w.
        dt: [f32; 3],
        /// Primitive id.
        id: u32,
    },
    /// A sphere with an affine inverse placement (its first three rows).
    Sphere {
        /// Inverse placement, rows.
        inv: [[f32; 4]; 3],
        /// Primitive id.
        id: u32,
    },
    /// A box with an affine placement (its inverse's first three rows).
    Box {
        /// Inverse placement, rows.
        inv: [[f32; 4]; 3],
        /// Primitive id.
        id: u32,
    },
}

impl FlatPrim {
    /// The batch form of primitive `id`, when its kind has one.
    fn of(geometry: &Geometry, id: u32) -> Option<FlatPrim> {
        let GeomPrim::Object(o) = geometry.prim(id) else {
            return None;
        };
        let rows = |m: &[[f32; 4]; 4]| [m[0], m[1], m[2]];
        match &geometry.objects()[o as usize].shape {
            Shape::Parallelogram(q) => {
                let (p, n, ds, dt) = q.lane_data();
                Some(FlatPrim::Quad { p, n, ds, dt, id })
            }
            Shape::Sphere(s) if s.has_affine_inverse() => Some(FlatPrim::Sphere {
                inv: rows(&s.world_from_object.inv.m),
                id,
            }),
            Shape::Cube(c) if c.is_affine() => Some(FlatPrim::Box {
                inv: rows(&c.world_from_object.inv.m),
                id,
            }),
            _ => None,
        }
    }
}

/// The closest hits of a batch, one per lane (`None` for misses and inactive lanes).
pub type BatchHits = [Option<Hit>; BATCH];

impl Bvh {
    /// Splits the leaves of a flat tree into primitives tested in batches (sorted by id) and
    /// leaves tested ray by ray.
    pub(super) fn flat_split(&self, geometry: &Geometry) -> (Vec<FlatPrim>, Vec<Ref>) {
        let mut prims = Vec::new();
        let mut rest = Vec::new();
        for &r in &self.flat {
            let kind = Kind::from_bits((r.meta >> KIND_SHIFT).wrapping_sub(1));
            let batchable = matches!(kind, Kind::Quad | Kind::Sphere | Kind::Box);
            if !batchable {
                rest.push(r);
                continue;
            }
            // Blocked leaves: their primitive ids, from the blocks' id lanes.
            let n = (r.meta & COUNT_MASK) as usize;
            for k in 0..n {
                let id = self.block_id(kind, r.child as usize + k / 4, k % 4);
                prims.push(FlatPrim::of(geometry, id).expect("a batchable primitive"));
            }
        }
        prims.sort_by_key(|p| match *p {
            FlatPrim::Quad { id, .. } | FlatPrim::Sphere { id, .. } | FlatPrim::Box { id, .. } => {
                id
            }
        });
        (prims, rest)
    }

    /// True when batches test every primitive against all their rays at once (small scenes),
    /// a cost that does not shrink with the number of active lanes.
    pub fn is_flat(&self) -> bool {
        !self.flat_prims.is_empty() || !self.flat_rest.is_empty()
    }

    /// The closest hit of every active lane of `rays`.
    pub fn intersect_batch(
        &self,
        geometry: &Geometry,
        rays: &RayBatch,
        hits: &mut BatchHits,
        stats: &mut RayStats,
    ) {
        self.intersect_batch_at(SimdLevel::detected(), geometry, rays, hits, stats)
    }

    /// [`Bvh::intersect_batch`] with the registers of `level` (or the widest below it).
    fn intersect_batch_at(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        hits: &mut BatchHits,
        stats: &mut RayStats,
    ) {
        *hits = [None; BATCH];
        if !self.is_flat() {
            if let Some(c) = self.packet_for(level, rays) {
                return self.intersect_packet(level, geometry, rays, c, hits, stats);
            }
            for i in rays.lanes() {
                hits[i] = self.intersect(geometry, &rays.ray(i), stats);
            }
            return;
        }
        if !self.flat_prims.is_empty() {
            crate::simd::run_wide_at(
                level,
                Closest {
                    prims: &self.flat_prims,
                    rays,
                    hits,
                },
            );
            stats.prim_tests += self.flat_prims.len() as u64 * rays.active.count_ones() as u64;
        }
        // The other primitives lane by lane (none, in most small scenes).
        let rest = if self.flat_rest.is_empty() {
            0
        } else {
            rays.active
        };
        for i in crate::math::lanes(rest) {
            let mut ray = rays.ray(i);
            if let Some(h) = &hits[i] {
                ray.tmax = h.t.next_up();
            }
            for &r in &self.flat_rest {
                if let Some(h) = self.leaf_closest(geometry, r, &ray, stats) {
                    if crate::accel::closest(&mut hits[i], h) {
                        ray.tmax = h.t.next_up();
                    }
                }
            }
        }
    }

    /// The active lanes of `rays` that hit something (bit i for lane i).
    pub fn occluded_batch(
        &self,
        geometry: &Geometry,
        rays: &RayBatch,
        stats: &mut RayStats,
    ) -> u32 {
        self.occluded_batch_at(SimdLevel::detected(), geometry, rays, stats)
    }

    /// [`Bvh::occluded_batch`] with the registers of `level` (or the widest below it).
    fn occluded_batch_at(
        &self,
        level: SimdLevel,
        geometry: &Geometry,
        rays: &RayBatch,
        stats: &mut RayStats,
    ) -> u32 {
        if !self.is_flat() {
            if let Some(c) = self.packet_for(level, rays) {
                return self.occluded_packet(level, geometry, rays, c, stats);
            }
            let mut hit = 0;
            for i in rays.lanes() {
                if self.occluded(geometry, &rays.ray(i), stats) {
                    hit |= 1 << i;
                }
            }
            return hit;
        }
        let mut hit = 0;
        if !self.flat_prims.is_empty() {
            hit = crate::simd::run_wide_at(
                level,
                Any {
                    prims: &self.flat_prims,
                    rays,
                },
            );
            stats.prim_tests += self.flat_prims.len() as u64 * rays.active.count_ones() as u64;
        }
        let mut rest = if self.flat_rest.is_empty() {
            0
        } else {
            rays.active & !hit
        };
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let ray = rays.ray(i);
            if self
                .flat_rest
                .iter()
                .any(|&r| self.leaf_any(geometry, r, &ray, stats))
            {
                hit |= 1 << i;
            }
        }
        hit
    }
}

impl Bvh {
    /// Whether a deep tree traces `rays` as one packet ([`super::packet`]): on sixteen-lane
    /// registers, when the rays are coherent.
    #[inline]
    fn packet_for(&self, level: SimdLevel, rays: &RayBatch) -> Option<Coherence> {
        if self.root.meta != 0 || level.min(SimdLevel::supported()) < PACKET_LEVEL {
            return None;
        }
        Coherence::of(rays)
    }
}

/// The narrowest registers packets are taken on (see [`super::packet`]).
const PACKET_LEVEL: SimdLevel = SimdLevel::Avx2;

/// A batch loaded into registers.
struct Lanes<W: Wide> {
    o: [W::V; 3],
    d: [W::V; 3],
    tmin: W::V,
}

impl<W: Wide> Lanes<W> {
    #[inline(always)]
    fn new(w: W, r: &RayBatch) -> Self {
        Self {
            o: [w.load(&r.o[0]), w.load(&r.o[1]), w.load(&r.o[2])],
            d: [w.load(&r.d[0]), w.load(&r.d[1]), w.load(&r.d[2])],
            tmin: w.load(&r.tmin),
        }
    }
}

/// What a primitive test gives every lane: hit flags, `t`, surface parameters and face.
struct LaneHit<W: Wide> {
    valid: W::M,
    t: W::V,
    u: W::V,
    v: W::V,
    face: W::V,
}

/// x·a + y·b + z·c with scalar a, b, c, in the order of `Vec3::dot`.
#[inline(always)]
fn dot_s<W: Wide>(w: W, x: &[W::V; 3], a: [f32; 3]) -> W::V {
    w.add(
        w.add(w.mul(w.splat(a[0]), x[0]), w.mul(w.splat(a[1]), x[1])),
        w.mul(w.splat(a[2]), x[2]),
    )
}

/// Lane-wise dot product, in the order of `Vec3::dot`.
#[inline(always)]
fn dot<W: Wide>(w: W, a: &[W::V; 3], b: &[W::V; 3]) -> W::V {
    w.add(
        w.add(w.mul(a[0], b[0]), w.mul(a[1], b[1])),
        w.mul(a[2], b[2]),
    )
}

/// `r · (x, y, z)` of one row (linear part), in the order of `Transform::inv_vector`.
#[inline(always)]
fn row3<W: Wide>(w: W, r: &[f32; 4], x: &[W::V; 3]) -> W::V {
    w.add(
        w.add(w.mul(w.splat(r[0]), x[0]), w.mul(w.splat(r[1]), x[1])),
        w.mul(w.splat(r[2]), x[2]),
    )
}

/// `m · p` (affine rows), in the order of `Transform::inv_point`.
#[inline(always)]
fn affine_point<W: Wide>(w: W, m: &[[f32; 4]; 3], p: &[W::V; 3]) -> [W::V; 3] {
    [
        w.add(row3(w, &m[0], p), w.splat(m[0][3])),
        w.add(row3(w, &m[1], p), w.splat(m[1][3])),
        w.add(row3(w, &m[2], p), w.splat(m[2][3])),
    ]
}

/// `m · v` (linear part), in the order of `Transform::inv_vector`.
#[inline(always)]
fn linear<W: Wide>(w: W, m: &[[f32; 4]; 3], v: &[W::V; 3]) -> [W::V; 3] {
    [row3(w, &m[0], v), row3(w, &m[1], v), row3(w, &m[2], v)]
}

/// [`crate::shape::Parallelogram::intersect`] on every lane; `tmax` is per lane.
#[inline(always)]
fn quad<W: Wide>(
    w: W,
    l: &Lanes<W>,
    tmax: W::V,
    q: ([f32; 3], [f32; 3], [f32; 3], [f32; 3]),
) -> LaneHit<W> {
    let (p, n, ds, dt) = q;
    let zero = w.splat(0.0);
    let one = w.splat(1.0);
    let denom = dot_s(w, &l.d, n);
    let po = [
        w.sub(w.splat(p[0]), l.o[0]),
        w.sub(w.splat(p[1]), l.o[1]),
        w.sub(w.splat(p[2]), l.o[2]),
    ];
    let t = w.div(dot_s(w, &po, n), denom);
    let qv = [
        w.sub(w.add(l.o[0], w.mul(l.d[0], t)), w.splat(p[0])),
        w.sub(w.add(l.o[1], w.mul(l.d[1], t)), w.splat(p[1])),
        w.sub(w.add(l.o[2], w.mul(l.d[2], t)), w.splat(p[2])),
    ];
    let s = dot_s(w, &qv, ds);
    let tt = dot_s(w, &qv, dt);
    let mut valid = w.and(w.ne(denom, zero), w.gt(t, l.tmin));
    valid = w.and(valid, w.lt(t, tmax));
    valid = w.and(valid, w.and(w.ge(s, zero), w.le(s, one)));
    valid = w.and(valid, w.and(w.ge(tt, zero), w.le(tt, one)));
    LaneHit {
        valid,
        t,
        u: s,
        v: tt,
        face: zero,
    }
}

/// [`crate::shape::Sphere::intersect`] on every lane.
#[inline(always)]
fn sphere<W: Wide>(w: W, l: &Lanes<W>, tmax: W::V, inv: &[[f32; 4]; 3]) -> LaneHit<W> {
    let o = affine_point(w, inv, &l.o);
    let d = linear(w, inv, &l.d);
    let zero = w.splat(0.0);
    let a = dot(w, &d, &d);
    let half_b = dot(w, &o, &d);
    let k = w.div(half_b, a);
    let f = [
        w.sub(o[0], w.mul(d[0], k)),
        w.sub(o[1], w.mul(d[1], k)),
        w.sub(o[2], w.mul(d[2], k)),
    ];
    let disc = w.mul(a, w.sub(w.splat(1.0), dot(w, &f, &f)));
    let ok = w.ge(disc, zero);
    let q = w.neg(w.add(half_b, w.copysign(w.sqrt(disc), half_b)));
    let c = w.sub(dot(w, &o, &o), w.splat(1.0));
    let (t0, t1) = (w.div(c, q), w.div(q, a));
    let keep = w.le(t0, t1);
    let lo = w.select(keep, t0, t1);
    let hi = w.select(keep, t1, t0);
    let t = w.select(w.gt(lo, l.tmin), lo, hi);
    let valid = w.and(ok, w.and(w.gt(t, l.tmin), w.lt(t, tmax)));
    LaneHit {
        valid,
        t,
        u: zero,
        v: zero,
        face: zero,
    }
}

/// [`crate::shape::Cube::intersect`] on every lane (faces as f32 values 0–5).
#[inline(always)]
fn cube<W: Wide>(w: W, l: &Lanes<W>, tmax: W::V, inv: &[[f32; 4]; 3]) -> LaneHit<W> {
    let o = affine_point(w, inv, &l.o);
    let d = linear(w, inv, &l.d);
    let (zero, one, m_one) = (w.splat(0.0), w.splat(1.0), w.splat(-1.0));
    let mut near = w.splat(f32::NEG_INFINITY);
    let mut far = w.splat(f32::INFINITY);
    let mut near_face = zero;
    let mut far_face = zero;
    let mut valid = w.mask(u32::MAX);
    for axis in 0..3 {
        let (oa, da) = (o[axis], d[axis]);
        // A direction parallel to the slabs: inside them, or no hit.
        let parallel = w.eq(da, zero);
        let inside = w.and(w.le(m_one, oa), w.le(oa, one));
        valid = w.and(valid, w.or(w.and_not(w.mask(u32::MAX), parallel), inside));
        let inv_d = w.div(one, da);
        let t_minus = w.mul(w.sub(m_one, oa), inv_d);
        let t_plus = w.mul(w.sub(one, oa), inv_d);
        let minus_face = w.splat(2.0 * axis as f32);
        let plus_face = w.splat(2.0 * axis as f32 + 1.0);
        let order = w.lt(t_minus, t_plus);
        let tn = w.select(order, t_minus, t_plus);
        let fn_ = w.select(order, minus_face, plus_face);
        let tf = w.select(order, t_plus, t_minus);
        let ff = w.select(order, plus_face, minus_face);
        let grow = w.and_not(w.gt(tn, near), parallel);
        near = w.select(grow, tn, near);
        near_face = w.select(grow, fn_, near_face);
        let shrink = w.and_not(w.lt(tf, far), parallel);
        far = w.select(shrink, tf, far);
        far_face = w.select(shrink, ff, far_face);
    }
    valid = w.and(valid, w.le(near, far));
    let enter = w.gt(near, l.tmin);
    let t = w.select(enter, near, far);
    let face = w.select(enter, near_face, far_face);
    valid = w.and(valid, w.and(w.gt(t, l.tmin), w.lt(t, tmax)));
    LaneHit {
        valid,
        t,
        u: zero,
        v: zero,
        face,
    }
}

/// The test of one primitive on every lane.
#[inline(always)]
fn test<W: Wide>(w: W, l: &Lanes<W>, tmax: W::V, p: &FlatPrim) -> (LaneHit<W>, u32) {
    match p {
        FlatPrim::Quad { p, n, ds, dt, id } => (quad(w, l, tmax, (*p, *n, *ds, *dt)), *id),
        FlatPrim::Sphere { inv, id } => (sphere(w, l, tmax, inv), *id),
        FlatPrim::Box { inv, id } => (cube(w, l, tmax, inv), *id),
    }
}

/// The closest-hit kernel: the primitives in id order, a strict `t < best`.
struct Closest<'a> {
    prims: &'a [FlatPrim],
    rays: &'a RayBatch,
    hits: &'a mut BatchHits,
}

impl WideKernel for Closest<'_> {
    type Output = ();

    #[inline(always)]
    fn run<W: Wide>(self, w: W) {
        let l = Lanes::new(w, self.rays);
        let mut best_t = w.load(&self.rays.tmax);
        let none = w.splat_bits(u32::MAX);
        let mut best_id = none;
        let zero = w.splat(0.0);
        let (mut best_u, mut best_v, mut best_face) = (zero, zero, zero);
        for p in self.prims {
            let (h, id) = test(w, &l, best_t, p);
            let better = h.valid;
            best_t = w.select(better, h.t, best_t);
            best_id = w.select(better, w.splat_bits(id), best_id);
            best_u = w.select(better, h.u, best_u);
            best_v = w.select(better, h.v, best_v);
            best_face = w.select(better, h.face, best_face);
        }
        let (mut t, mut id, mut u, mut v, mut face) =
            ([0f32; 16], [0f32; 16], [0f32; 16], [0f32; 16], [0f32; 16]);
        w.store(best_t, &mut t);
        w.store(best_id, &mut id);
        w.store(best_u, &mut u);
        w.store(best_v, &mut v);
        w.store(best_face, &mut face);
        let mut m = self.rays.active;
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            let prim = id[i].to_bits();
            if prim != u32::MAX {
                self.hits[i] = Some(Hit {
                    t: t[i],
                    prim,
                    uv: [u[i], v[i]],
                    sub: face[i] as u32,
                    leaf: 0,
                });
            }
        }
    }
}

/// The any-hit kernel: the lanes that hit any primitive, stopping once every active lane has.
struct Any<'a> {
    prims: &'a [FlatPrim],
    rays: &'a RayBatch,
}

impl WideKernel for Any<'_> {
    type Output = u32;

    #[inline(always)]
    fn run<W: Wide>(self, w: W) -> u32 {
        let l = Lanes::new(w, self.rays);
        let tmax = w.load(&self.rays.tmax);
        let active = self.rays.active;
        let mut hit = 0u32;
        for p in self.prims {
            let (h, _) = test(w, &l, tmax, p);
            hit |= w.bits(h.valid) & active;
            if hit == active {
                break;
            }
        }
        hit
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
    use crate::shape::{Cube, Mesh, Parallelogram, Sphere};

    /// A scene of `n` spheres, boxes and parallelograms (with a twin of the first primitive
    /// for exact ties, one non-affine box and a few triangles when `mixed`).
    fn geometry(n: usize, seed: u64, mixed: bool) -> Geometry {
        let mut rng = Pcg32::new(seed, 5);
        let mut u = || rng.next_f32() * 2.0 - 1.0;
        let props = SurfaceProps::default();
        let mut objects = Vec::new();
        for i in 0..n {
            let c = Vec3::new(u() * 3.0, u() * 3.0, u() * 3.0);
            let place = Transform::translation(c)
                * Transform::rotation_z(u() * 180.0)
                * Transform::scaling(Vec3::new(0.5 + u().abs(), 0.4, 0.7));
            let shape = match i % 3 {
                0 => Shape::Sphere(Sphere::new(place)),
                1 => Shape::Cube(Cube::new(place)),
                _ => Shape::Parallelogram(
                    Parallelogram::new(
                        Point3::new(c.x, c.y, c.z),
                        Vec3::new(u() * 2.0, u(), 0.3),
                        Vec3::new(0.2, u() * 2.0, u()),
                    )
                    .unwrap(),
                ),
            };
            if i == 0 {
                objects.push(Object {
                    shape: shape.clone(),
                    props,
                });
            }
            objects.push(Object { shape, props });
        }
        let mut meshes = Vec::new();
        if mixed {
            // A box whose placement is projective: not batchable, tested ray by ray.
            let mut m = Transform::translation(Vec3::new(0.5, 0.2, 0.1)).m;
            m.m[3][2] = 0.05;
            if let Some(t) = Transform::from_matrix(m) {
                objects.push(Object {
                    shape: Shape::Cube(Cube::new(t)),
                    props,
                });
            }
            meshes.push(Mesh {
                positions: vec![
                    Point3::new(-1.0, -1.0, 0.5),
                    Point3::new(1.0, -1.0, 0.4),
                    Point3::new(0.0, 1.0, 0.6),
                ],
                indices: vec![[0, 1, 2]],
                ..Mesh::default()
            });
        }
        Geometry::new(objects, meshes)
    }

    fn batch(rng: &mut Pcg32, k: usize) -> RayBatch {
        let mut b = RayBatch::default();
        for i in 0..BATCH {
            let mut u = || rng.next_f32() * 2.0 - 1.0;
            let o = Point3::new(u() * 5.0, u() * 5.0, u() * 5.0);
            let d = match (i + k) % 9 {
                0 => Vec3::new(0.0, 0.0, 1.0),
                1 => Vec3::new(u(), 0.0, u()),
                _ => -o.to_vec() + Vec3::new(u(), u(), u()),
            };
            let mut ray = Ray::new(o, d);
            if i % 4 == 3 {
                ray.tmax = 0.7;
            }
            if i % 5 == 4 {
                ray.tmin = 0.2;
            }
            // Some lanes stay inactive.
            if !(i * 7 + k).is_multiple_of(11) {
                b.set(i, &ray);
            }
        }
        b
    }

    #[test]
    fn batches_get_the_single_ray_hits_at_every_simd_level() {
        let levels = [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512];
        for (n, mixed) in [(5, false), (12, false), (7, true), (40, false), (300, true)] {
            let g = geometry(n, n as u64, mixed);
            let bvh = Bvh::build(&g, &build_prims(&g));
            assert_eq!(
                !bvh.flat.is_empty(),
                n < 40,
                "{n} primitives: flat tree or not"
            );
            let mut rng = Pcg32::new(1, 2);
            let mut hits_seen = 0;
            for k in 0..200 {
                let rays = batch(&mut rng, k);
                for &level in &levels {
                    let mut st = RayStats::default();
                    let mut hits = [None; BATCH];
                    bvh.intersect_batch_at(level, &g, &rays, &mut hits, &mut st);
                    let occluded = bvh.occluded_batch_at(level, &g, &rays, &mut st);
                    for i in 0..BATCH {
                        if rays.active >> i & 1 == 0 {
                            assert!(hits[i].is_none() && occluded >> i & 1 == 0);
                            continue;
                        }
                        let ray = rays.ray(i);
                        let single = bvh.intersect(&g, &ray, &mut st);
                        assert_eq!(hits[i], single, "{n} prims, {level:?}, lane {i}: {ray:?}");
                        assert_eq!(occluded >> i & 1 == 1, bvh.occluded(&g, &ray, &mut st));
                        hits_seen += single.is_some() as usize;
                    }
                }
            }
            assert!(hits_seen > 500, "{n} primitives: only {hits_seen} hits");
        }
    }
}
