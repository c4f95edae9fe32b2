//! Lane-exact sixteen-lane tests of parallelograms, spheres, boxes and triangles
//! ([`crate::simd::Wide`]): one primitive against sixteen rays, each lane performing exactly
//! the operations of the shape's scalar test in the same order (as the four-primitive blocks of
//! [`crate::accel::blocks`] do), so that `t`, the surface parameters and the face are bit for
//! bit the single-ray ones. Used by small scenes' batches ([`super::batch`]) and, but for
//! triangles, by packets at leaves of these primitives ([`super::packet`]).
//!
//! The watertight triangle test permutes each ray's axes its own way ([`ShearedRay::axes`](crate::shape::ShearedRay::axes)):
//! the lanes' permuted origins and shears are made once per batch ([`Shear`]), and each
//! triangle's vertex coordinates are picked per lane by two selects.

use super::layout::{BOX_LEAF, COUNT_MASK, QUAD_LEAF, SPHERE_LEAF};
use super::Bvh;
use crate::geometry::{Geometry, PrimRef as GeomPrim};
use crate::math::{RayBatch, BATCH};
use crate::shape::Shape;
use crate::simd::Wide;

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
    /// A mesh triangle: its vertices, as its block of the tree holds them.
    Tri {
        /// Vertices: `v[vertex][axis]`.
        v: [[f32; 3]; 3],
        /// Primitive id.
        id: u32,
    },
}

impl FlatPrim {
    /// The batch form of primitive `id`, when its kind has one.
    pub(super) fn of(geometry: &Geometry, id: u32) -> Option<FlatPrim> {
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

    /// Lane `lane` of block `block` of a parallelogram, sphere or box leaf (`meta`: the
    /// leaf's reference), read from the block itself: the data of the single-ray block test.
    #[inline(always)]
    pub(super) fn of_block(bvh: &Bvh, meta: u32, block: usize, lane: usize) -> FlatPrim {
        match meta & !COUNT_MASK {
            QUAD_LEAF => {
                let (q, ids) = &bvh.quads[block];
                let (p, n, ds, dt) = q.lane(lane);
                FlatPrim::Quad {
                    p,
                    n,
                    ds,
                    dt,
                    id: ids[lane],
                }
            }
            SPHERE_LEAF => {
                let (s, ids) = &bvh.spheres[block];
                FlatPrim::Sphere {
                    inv: s.lane(lane),
                    id: ids[lane],
                }
            }
            _ => {
                debug_assert_eq!(meta & !COUNT_MASK, BOX_LEAF);
                let (b, ids) = &bvh.boxes[block];
                FlatPrim::Box {
                    inv: b.lane(lane),
                    id: ids[lane],
                }
            }
        }
    }
}

/// A batch loaded into registers.
pub(super) struct Lanes<W: Wide> {
    pub(super) o: [W::V; 3],
    pub(super) d: [W::V; 3],
    pub(super) tmin: W::V,
    /// What the triangle test needs (made only for primitive lists with triangles).
    pub(super) shear: Option<Shear<W>>,
}

impl<W: Wide> Lanes<W> {
    /// The lanes of `r`, with their [`Shear`] when `triangles`.
    #[inline(always)]
    pub(super) fn new(w: W, r: &RayBatch, triangles: bool) -> Self {
        Self {
            o: [w.load(&r.o[0]), w.load(&r.o[1]), w.load(&r.o[2])],
            d: [w.load(&r.d[0]), w.load(&r.d[1]), w.load(&r.d[2])],
            tmin: w.load(&r.tmin),
            shear: triangles.then(|| Shear::new(w, r)),
        }
    }
}

/// Each lane's ray as the watertight triangle test sees it ([`ShearedRay`](crate::shape::ShearedRay)): which of its
/// axes become x, y and z (as masks: the axis is 0, the axis is 1, else 2), its origin on
/// those axes and its shear, with the quotients of [`ShearedRay::new`](crate::shape::ShearedRay::new).
pub(super) struct Shear<W: Wide> {
    /// For x, y and z of the sheared space: the lanes whose axis is 0, and those whose axis
    /// is 1.
    axis: [(W::M, W::M); 3],
    /// The origin's coordinates on the permuted axes.
    o: [W::V; 3],
    /// d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz].
    s: [W::V; 3],
    /// The lanes made (the active ones).
    active: u32,
}

impl<W: Wide> Shear<W> {
    /// The shear of every lane of `r`: [`ShearedRay::new`](crate::shape::ShearedRay::new)'s choice of axes (the table of
    /// [`ShearedRay::axes`](crate::shape::ShearedRay::axes) as masks) and quotients.
    #[inline(always)]
    fn new(w: W, r: &RayBatch) -> Self {
        let all = w.mask(u32::MAX);
        let not = |m: W::M| w.and_not(all, m);
        let d = [w.load(&r.d[0]), w.load(&r.d[1]), w.load(&r.d[2])];
        let o = [w.load(&r.o[0]), w.load(&r.o[1]), w.load(&r.o[2])];
        let one = w.splat(1.0);
        let a = [
            w.copysign(d[0], one),
            w.copysign(d[1], one),
            w.copysign(d[2], one),
        ];
        let x_over_y = w.gt(a[0], a[1]);
        let m = w.select(x_over_y, a[0], a[1]);
        let dm = w.select(x_over_y, d[0], d[1]);
        let over_z = w.gt(m, a[2]);
        // z is axis 0, 1 or 2; x and y swap when d[kz] < 0.
        let z0 = w.and(over_z, x_over_y);
        let z1 = w.and_not(over_z, x_over_y);
        let z2 = not(over_z);
        let dz = w.select(over_z, dm, d[2]);
        let neg = w.lt(dz, w.splat(0.0));
        let pos = not(neg);
        let axis = [
            (
                w.or(w.and(z1, neg), w.and(z2, pos)),
                w.or(w.and(z0, pos), w.and(z2, neg)),
            ),
            (
                w.or(w.and(z1, pos), w.and(z2, neg)),
                w.or(w.and(z0, neg), w.and(z2, pos)),
            ),
            (z0, z1),
        ];
        let pick = |v: &[W::V; 3], (is0, is1): (W::M, W::M)| {
            w.select(is0, v[0], w.select(is1, v[1], v[2]))
        };
        Self {
            axis,
            o: [pick(&o, axis[0]), pick(&o, axis[1]), pick(&o, axis[2])],
            s: [
                w.div(pick(&d, axis[0]), dz),
                w.div(pick(&d, axis[1]), dz),
                w.div(one, dz),
            ],
            active: r.active,
        }
    }

    /// Coordinate `a` (0: x, 1: y, 2: z of the sheared space) of point `p`, lane by lane.
    #[inline(always)]
    fn pick(&self, w: W, p: &[f32; 3], a: usize) -> W::V {
        let (is0, is1) = self.axis[a];
        w.select(
            is0,
            w.splat(p[0]),
            w.select(is1, w.splat(p[1]), w.splat(p[2])),
        )
    }
}

/// What a primitive test gives every lane: hit flags, `t`, surface parameters and face.
pub(super) struct LaneHit<W: Wide> {
    pub(super) valid: W::M,
    pub(super) t: W::V,
    pub(super) u: W::V,
    pub(super) v: W::V,
    pub(super) face: W::V,
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

/// The 2D edge functions (u, v, w) of the watertight triangle test from the sheared corners'
/// x and y, on every lane. Where one of them is 0 on a lane of `lanes`, f32 cannot decide the
/// signs: that lane's three are computed again in f64, as the single-ray test does
/// ([`crate::shape::intersect_triangle`]).
#[inline(always)]
pub(super) fn edge_functions<W: Wide>(
    w: W,
    [ax, bx, cx]: [W::V; 3],
    [ay, by, cy]: [W::V; 3],
    lanes: u32,
) -> [W::V; 3] {
    let zero = w.splat(0.0);
    let u = w.sub(w.mul(cx, by), w.mul(cy, bx));
    let v = w.sub(w.mul(ax, cy), w.mul(ay, cx));
    let t = w.sub(w.mul(bx, ay), w.mul(by, ax));
    let on_edge = w.bits(w.or(w.or(w.eq(u, zero), w.eq(v, zero)), w.eq(t, zero))) & lanes;
    if on_edge == 0 {
        return [u, v, t];
    }
    let f = |a: f32, b: f32, c: f32, d: f32| (a as f64 * b as f64 - c as f64 * d as f64) as f32;
    let mut l = [[0f32; BATCH]; 9];
    for (dst, src) in l.iter_mut().zip([u, v, t, ax, ay, bx, by, cx, cy]) {
        w.store(src, dst);
    }
    let [mut u, mut v, mut t, ax, ay, bx, by, cx, cy] = l;
    for i in crate::math::lanes(on_edge) {
        u[i] = f(cx[i], by[i], cy[i], bx[i]);
        v[i] = f(ax[i], cy[i], ay[i], cx[i]);
        t[i] = f(bx[i], ay[i], by[i], ax[i]);
    }
    [w.load(&u), w.load(&v), w.load(&t)]
}

/// [`crate::shape::intersect_triangle`] on every lane (`u`, `v`: the barycentrics of the
/// second and third vertices).
#[inline(always)]
fn triangle<W: Wide>(w: W, l: &Lanes<W>, tmax: W::V, v: &[[f32; 3]; 3]) -> LaneHit<W> {
    let zero = w.splat(0.0);
    let Some(sh) = &l.shear else {
        // Not reached: lists with triangles come with their shear.
        return LaneHit {
            valid: w.mask(0),
            t: zero,
            u: zero,
            v: zero,
            face: zero,
        };
    };
    let [sx, sy, sz] = sh.s;
    // The vertices translated to the origin, on the permuted axes, and sheared.
    // (Written out: closures here would not be compiled for the kernel's instruction set.)
    let (za, zb, zc) = (
        w.sub(sh.pick(w, &v[0], 2), sh.o[2]),
        w.sub(sh.pick(w, &v[1], 2), sh.o[2]),
        w.sub(sh.pick(w, &v[2], 2), sh.o[2]),
    );
    let ax = w.sub(w.sub(sh.pick(w, &v[0], 0), sh.o[0]), w.mul(sx, za));
    let bx = w.sub(w.sub(sh.pick(w, &v[1], 0), sh.o[0]), w.mul(sx, zb));
    let cx = w.sub(w.sub(sh.pick(w, &v[2], 0), sh.o[0]), w.mul(sx, zc));
    let ay = w.sub(w.sub(sh.pick(w, &v[0], 1), sh.o[1]), w.mul(sy, za));
    let by = w.sub(w.sub(sh.pick(w, &v[1], 1), sh.o[1]), w.mul(sy, zb));
    let cy = w.sub(w.sub(sh.pick(w, &v[2], 1), sh.o[1]), w.mul(sy, zc));
    let [u, vv, ww] = edge_functions(w, [ax, bx, cx], [ay, by, cy], sh.active);
    let neg = w.or(w.or(w.lt(u, zero), w.lt(vv, zero)), w.lt(ww, zero));
    let pos = w.or(w.or(w.gt(u, zero), w.gt(vv, zero)), w.gt(ww, zero));
    let det = w.add(w.add(u, vv), ww);
    let t_scaled = w.add(
        w.add(w.mul(u, w.mul(sz, za)), w.mul(vv, w.mul(sz, zb))),
        w.mul(ww, w.mul(sz, zc)),
    );
    let inv_det = w.div(w.splat(1.0), det);
    let t = w.mul(t_scaled, inv_det);
    let inside = w.and_not(w.ne(det, zero), w.and(neg, pos));
    let valid = w.and(inside, w.and(w.gt(t, l.tmin), w.lt(t, tmax)));
    LaneHit {
        valid,
        t,
        u: w.mul(vv, inv_det),
        v: w.mul(ww, inv_det),
        face: zero,
    }
}

/// The test of one primitive on every lane.
#[inline(always)]
pub(super) fn test<W: Wide>(w: W, l: &Lanes<W>, tmax: W::V, p: &FlatPrim) -> (LaneHit<W>, u32) {
    match p {
        FlatPrim::Quad { p, n, ds, dt, id } => (quad(w, l, tmax, (*p, *n, *ds, *dt)), *id),
        FlatPrim::Sphere { inv, id } => (sphere(w, l, tmax, inv), *id),
        FlatPrim::Box { inv, id } => (cube(w, l, tmax, inv), *id),
        FlatPrim::Tri { v, id } => (triangle(w, l, tmax, v), *id),
    }
}
