//! Blocks of four analytic primitives of one kind (parallelograms, spheres, boxes), tested at
//! once, one SSE lane each.
//!
//! Each block test performs, lane by lane, exactly the operations of the shape's own scalar
//! test in the same order (no fused multiply-add, correctly rounded `sqrt` and division), so
//! its `t`, surface parameters and face are bit-identical to [`Parallelogram::intersect`],
//! [`Sphere::intersect`] and [`Cube::intersect`]. Only spheres and boxes whose inverse
//! placement is affine (last row 0, 0, 0, 1) go into blocks: their scalar tests then skip the
//! homogeneous division, as the lanes do.

use crate::math::Ray;
use crate::shape::{Cube, Parallelogram, Sphere};
use crate::simd::F4;

/// One ray, broadcast to four lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BlockRay {
    o: [F4; 3],
    d: [F4; 3],
}

impl BlockRay {
    /// The ray in every lane.
    #[inline(always)]
    pub(crate) fn new(r: &Ray) -> Self {
        Self {
            o: [F4::splat(r.o.x), F4::splat(r.o.y), F4::splat(r.o.z)],
            d: [F4::splat(r.d.x), F4::splat(r.d.y), F4::splat(r.d.z)],
        }
    }
}

/// The result of a block test: the lanes hit, and per lane `t`, the surface parameters and
/// the face (boxes) — meaningful only in hit lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BlockHit {
    /// Bit i set when lane i is hit inside the ray's interval.
    pub mask: u32,
    /// Ray parameter.
    pub t: [f32; 4],
    /// Surface parameters (parallelograms).
    pub uv: [[f32; 4]; 2],
    /// Face crossed (boxes).
    pub face: [u32; 4],
}

/// x·a + y·b + z·c of three lane vectors, in the order of `Vec3::dot`.
#[inline(always)]
fn dot(a: &[F4; 3], b: &[F4; 3]) -> F4 {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}

/// `m · p` for the first three rows of an affine matrix (`[row][col][lane]`), in the order of
/// `Transform::inv_point` (whose division by w = 1 is exact).
#[inline(always)]
fn affine_point(m: &[[[f32; 4]; 4]; 3], p: &[F4; 3]) -> [F4; 3] {
    std::array::from_fn(|r| {
        F4::load(&m[r][0])
            .mul(p[0])
            .add(F4::load(&m[r][1]).mul(p[1]))
            .add(F4::load(&m[r][2]).mul(p[2]))
            .add(F4::load(&m[r][3]))
    })
}

/// `m · v` (linear part), in the order of `Transform::inv_vector`.
#[inline(always)]
fn linear(m: &[[[f32; 4]; 4]; 3], v: &[F4; 3]) -> [F4; 3] {
    std::array::from_fn(|r| {
        F4::load(&m[r][0])
            .mul(v[0])
            .add(F4::load(&m[r][1]).mul(v[1]))
            .add(F4::load(&m[r][2]).mul(v[2]))
    })
}

fn load3(a: &[[f32; 4]; 3]) -> [F4; 3] {
    [F4::load(&a[0]), F4::load(&a[1]), F4::load(&a[2])]
}

/// Four parallelograms: corner, unnormalised normal v × w and the dual edge vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct Quad4 {
    p: [[f32; 4]; 3],
    n: [[f32; 4]; 3],
    ds: [[f32; 4]; 3],
    dt: [[f32; 4]; 3],
}

impl Quad4 {
    /// The block of `quads` (one to four; unused lanes repeat the first).
    pub(crate) fn new(quads: &[&Parallelogram]) -> Self {
        let mut b = Quad4 {
            p: [[0.0; 4]; 3],
            n: [[0.0; 4]; 3],
            ds: [[0.0; 4]; 3],
            dt: [[0.0; 4]; 3],
        };
        for l in 0..4 {
            let q = quads[l.min(quads.len() - 1)];
            let (p, n, ds, dt) = q.lane_data();
            for a in 0..3 {
                b.p[a][l] = p[a];
                b.n[a][l] = n[a];
                b.ds[a][l] = ds[a];
                b.dt[a][l] = dt[a];
            }
        }
        b
    }

    /// Lane `l`'s corner, v × w and dual edge vectors (as [`Parallelogram::lane_data`]).
    #[inline(always)]
    pub(crate) fn lane(&self, l: usize) -> ([f32; 3], [f32; 3], [f32; 3], [f32; 3]) {
        let a = |x: &[[f32; 4]; 3]| [x[0][l], x[1][l], x[2][l]];
        (a(&self.p), a(&self.n), a(&self.ds), a(&self.dt))
    }

    /// [`Parallelogram::intersect`] on the four lanes.
    #[inline(always)]
    pub(crate) fn test(&self, r: &BlockRay, tmin: f32, tmax: f32) -> BlockHit {
        let n = load3(&self.n);
        let p = load3(&self.p);
        let zero = F4::splat(0.0);
        let one = F4::splat(1.0);
        let denom = dot(&n, &r.d);
        let po = [p[0].sub(r.o[0]), p[1].sub(r.o[1]), p[2].sub(r.o[2])];
        let t = dot(&n, &po).div(denom);
        let q: [F4; 3] = std::array::from_fn(|a| r.o[a].add(r.d[a].mul(t)).sub(p[a]));
        let s = dot(&q, &load3(&self.ds));
        let tt = dot(&q, &load3(&self.dt));
        let mask = denom.ne(zero)
            & t.gt(F4::splat(tmin))
            & t.lt(F4::splat(tmax))
            & s.ge(zero)
            & s.le(one)
            & tt.ge(zero)
            & tt.le(one);
        BlockHit {
            mask,
            t: t.to_array(),
            uv: [s.to_array(), tt.to_array()],
            face: [0; 4],
        }
    }
}

/// The first three rows of an affine inverse placement, lane by lane.
type Rows4 = [[[f32; 4]; 4]; 3];

/// Lane `l`'s three rows.
#[inline(always)]
fn lane_rows(m: &Rows4, l: usize) -> [[f32; 4]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[r][c][l]))
}

fn rows_of(blocks: &mut Rows4, lane: usize, m: &[[f32; 4]; 4]) {
    for r in 0..3 {
        for c in 0..4 {
            blocks[r][c][lane] = m[r][c];
        }
    }
}

/// Four spheres (transformed unit spheres with affine inverses).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct Sphere4 {
    inv: Rows4,
}

impl Sphere4 {
    /// The block of `spheres` (one to four, each with [`Sphere::affine_inverse`]).
    pub(crate) fn new(spheres: &[&Sphere]) -> Self {
        let mut inv = [[[0.0; 4]; 4]; 3];
        for l in 0..4 {
            let s = spheres[l.min(spheres.len() - 1)];
            rows_of(&mut inv, l, &s.world_from_object.inv.m);
        }
        Self { inv }
    }

    /// Lane `l`'s inverse placement (its first three rows).
    #[inline(always)]
    pub(crate) fn lane(&self, l: usize) -> [[f32; 4]; 3] {
        lane_rows(&self.inv, l)
    }

    /// [`Sphere::intersect`] on the four lanes.
    #[inline(always)]
    pub(crate) fn test(&self, r: &BlockRay, tmin: f32, tmax: f32) -> BlockHit {
        let o = affine_point(&self.inv, &r.o);
        let d = linear(&self.inv, &r.d);
        let a = dot(&d, &d);
        let half_b = dot(&o, &d);
        let k = half_b.div(a);
        let f: [F4; 3] = std::array::from_fn(|i| o[i].sub(d[i].mul(k)));
        let disc = a.mul(F4::splat(1.0).sub(dot(&f, &f)));
        let valid = disc.ge(F4::splat(0.0));
        let q = half_b.add(disc.sqrt().copysign(half_b)).neg();
        let c = dot(&o, &o).sub(F4::splat(1.0));
        let (t0, t1) = (c.div(q), q.div(a));
        // (t0, t1) sorted as `if t0 <= t1 { (t0, t1) } else { (t1, t0) }`.
        let keep = t0.le_mask(t1);
        let lo = F4::select(keep, t0, t1);
        let hi = F4::select(keep, t1, t0);
        let vmin = F4::splat(tmin);
        let t = F4::select(lo.gt_mask(vmin), lo, hi);
        BlockHit {
            mask: valid & t.gt(vmin) & t.lt(F4::splat(tmax)),
            t: t.to_array(),
            uv: [[0.0; 4]; 2],
            face: [0; 4],
        }
    }
}

/// Four boxes (transformed cubes [-1, 1]³ with affine placements).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct Box4 {
    inv: Rows4,
}

impl Box4 {
    /// The block of `cubes` (one to four, each with [`Cube::is_affine`]).
    pub(crate) fn new(cubes: &[&Cube]) -> Self {
        let mut inv = [[[0.0; 4]; 4]; 3];
        for l in 0..4 {
            let c = cubes[l.min(cubes.len() - 1)];
            rows_of(&mut inv, l, &c.world_from_object.inv.m);
        }
        Self { inv }
    }

    /// Lane `l`'s inverse placement (its first three rows).
    #[inline(always)]
    pub(crate) fn lane(&self, l: usize) -> [[f32; 4]; 3] {
        lane_rows(&self.inv, l)
    }

    /// [`Cube::intersect`] on the four lanes.
    #[inline(always)]
    pub(crate) fn test(&self, r: &BlockRay, tmin: f32, tmax: f32) -> BlockHit {
        let o = affine_point(&self.inv, &r.o);
        let d = linear(&self.inv, &r.d);
        let (zero, one, m_one) = (F4::splat(0.0), F4::splat(1.0), F4::splat(-1.0));
        let mut near = F4::splat(f32::NEG_INFINITY);
        let mut far = F4::splat(f32::INFINITY);
        let mut near_face = zero;
        let mut far_face = zero;
        let mut valid = 0xf;
        for axis in 0..3 {
            let (oa, da) = (o[axis], d[axis]);
            // A direction parallel to the slabs: inside them, or no hit.
            let parallel = da.eq_mask(zero);
            valid &= !parallel.bits() | (m_one.le(oa) & oa.le(one));
            let inv = one.div(da);
            let t_minus = m_one.sub(oa).mul(inv);
            let t_plus = one.sub(oa).mul(inv);
            let minus_face = F4::splat(2.0 * axis as f32);
            let plus_face = F4::splat(2.0 * axis as f32 + 1.0);
            let order = t_minus.lt_mask(t_plus);
            let tn = F4::select(order, t_minus, t_plus);
            let fn_ = F4::select(order, minus_face, plus_face);
            let tf = F4::select(order, t_plus, t_minus);
            let ff = F4::select(order, plus_face, minus_face);
            let grow = tn.gt_mask(near).and_not(parallel);
            near = F4::select(grow, tn, near);
            near_face = F4::select(grow, fn_, near_face);
            let shrink = tf.lt_mask(far).and_not(parallel);
            far = F4::select(shrink, tf, far);
            far_face = F4::select(shrink, ff, far_face);
        }
        valid &= near.le(far);
        let vmin = F4::splat(tmin);
        let enter = near.gt_mask(vmin);
        let t = F4::select(enter, near, far);
        let face = F4::select(enter, near_face, far_face).to_array();
        BlockHit {
            mask: valid & t.gt(vmin) & t.lt(F4::splat(tmax)),
            t: t.to_array(),
            uv: [[0.0; 4]; 2],
            face: face.map(|f| f as u32),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Point3, Transform, Vec3};
    use crate::sampling::Pcg32;
    use crate::shape::ShapeHit;

    fn rays(n: usize) -> Vec<Ray> {
        let mut rng = Pcg32::new(7, 3);
        let mut u = || rng.next_f32() * 2.0 - 1.0;
        (0..n)
            .map(|i| {
                let o = Point3::new(u() * 3.0, u() * 3.0, u() * 3.0);
                // Some axis-parallel directions, to reach the slab special cases.
                let d = match i % 7 {
                    0 => Vec3::new(0.0, 0.0, 1.0),
                    1 => Vec3::new(u(), 0.0, u()),
                    _ => Vec3::new(u(), u(), u()),
                };
                let tmin = if i % 5 == 0 { 0.5 } else { 0.0 };
                Ray {
                    o,
                    d,
                    tmin,
                    tmax: if i % 3 == 0 { 2.0 } else { f32::INFINITY },
                }
            })
            .collect()
    }

    fn placements() -> Vec<Transform> {
        vec![
            Transform::translation(Vec3::new(0.3, -0.2, 0.1)),
            Transform::translation(Vec3::new(-1.0, 0.5, 0.0))
                * Transform::scaling(Vec3::new(0.7, 0.4, 1.2)),
            Transform::rotation(Vec3::new(1.0, 2.0, 0.5), 40.0).unwrap()
                * Transform::scaling(Vec3::new(0.5, 0.5, 0.5)),
            Transform::translation(Vec3::new(0.0, 1.5, -0.5)) * Transform::rotation_z(70.0),
        ]
    }

    /// Checks the four lanes of `block` against `scalar(lane, ray)` on many rays.
    fn check(
        block: impl Fn(&BlockRay, f32, f32) -> BlockHit,
        scalar: impl Fn(usize, &Ray) -> Option<ShapeHit>,
    ) {
        let mut hits = 0;
        for r in rays(20_000) {
            let h = block(&BlockRay::new(&r), r.tmin, r.tmax);
            for l in 0..4 {
                let s = scalar(l, &r);
                assert_eq!(h.mask >> l & 1 == 1, s.is_some(), "lane {l} ray {r:?}");
                if let Some(s) = s {
                    hits += 1;
                    assert_eq!(h.t[l].to_bits(), s.t.to_bits(), "lane {l} ray {r:?}");
                    assert_eq!(h.face[l], s.sub, "lane {l} ray {r:?}");
                    assert_eq!(h.uv[0][l].to_bits(), s.uv[0].to_bits(), "lane {l}");
                    assert_eq!(h.uv[1][l].to_bits(), s.uv[1].to_bits(), "lane {l}");
                }
            }
        }
        assert!(
            hits > 2000,
            "only {hits} hits: the rays miss too often to test much"
        );
    }

    #[test]
    fn quads_match_the_scalar_test() {
        let qs: Vec<Parallelogram> = (0..4)
            .map(|i| {
                let f = i as f32;
                Parallelogram::new(
                    Point3::new(-1.0 + 0.3 * f, -0.5, 0.2 * f),
                    Vec3::new(3.0, 0.4 * f, 0.2),
                    Vec3::new(-0.6, 2.4, 0.8 - 0.4 * f),
                )
                .unwrap()
            })
            .collect();
        let b = Quad4::new(&qs.iter().collect::<Vec<_>>());
        check(|r, a, t| b.test(r, a, t), |l, r| qs[l].intersect(r));
    }

    #[test]
    fn spheres_match_the_scalar_test() {
        let ss: Vec<Sphere> = placements().into_iter().map(Sphere::new).collect();
        let b = Sphere4::new(&ss.iter().collect::<Vec<_>>());
        check(|r, a, t| b.test(r, a, t), |l, r| ss[l].intersect(r));
    }

    #[test]
    fn boxes_match_the_scalar_test() {
        let cs: Vec<Cube> = placements().into_iter().map(Cube::new).collect();
        assert!(cs.iter().all(Cube::is_affine));
        let b = Box4::new(&cs.iter().collect::<Vec<_>>());
        check(|r, a, t| b.test(r, a, t), |l, r| cs[l].intersect(r));
    }
}
