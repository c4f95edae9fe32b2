//! Parallelograms `p + s·v + t·w`, s, t ∈ [0, 1].
//!
//! Scene syntax: `parallelogram(MAT, [p], [v], [w])` (candela), `<shape type="rectangle">`
//! (Mitsuba: the square [-1,1]² of the plane z = 0, transformed). uv = (s, t); the geometric
//! normal is v × w normalised.

use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Frame, Normal3, Point2, Point3, Ray, Vec3};

/// A parallelogram in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Parallelogram {
    /// The corner at (s, t) = (0, 0).
    pub p: Point3,
    /// The edge along s.
    pub v: Vec3,
    /// The edge along t.
    pub w: Vec3,
    /// v × w.
    n: Vec3,
    /// The unit normal v × w / |v × w|.
    unit_n: Normal3,
    /// The shading frame (the same everywhere): around the normal, with `v` as tangent.
    frame: Frame,
    /// Dual vectors: s = (x − p)·ds, t = (x − p)·dt for x in the plane.
    ds: Vec3,
    dt: Vec3,
}

impl Parallelogram {
    /// The parallelogram with corner `p` and edges `v`, `w`; `None` when degenerate.
    pub fn new(p: Point3, v: Vec3, w: Vec3) -> Option<Self> {
        let n = v.cross(w);
        let nn = n.squared_norm();
        if !(nn > 0.0 && nn.is_finite()) {
            return None;
        }
        let unit_n = n.normalize().to_normal();
        Some(Self {
            p,
            v,
            w,
            n,
            unit_n,
            frame: Frame::from_normal_tangent(unit_n, v),
            ds: w.cross(n) / nn,
            dt: n.cross(v) / nn,
        })
    }

    /// The crossing with the ray in its interval; `uv` of the hit holds (s, t).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let denom = self.n.dot(ray.d);
        if denom == 0.0 {
            return None;
        }
        let t = self.n.dot(self.p - ray.o) / denom;
        if !(t > ray.tmin && t < ray.tmax) {
            return None;
        }
        let q = ray.at(t) - self.p;
        let (s, tt) = (q.dot(self.ds), q.dot(self.dt));
        ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&tt)).then_some(ShapeHit {
            t,
            uv: [s, tt],
            sub: 0,
            leaf: 0,
        })
    }

    /// What a block test needs: the corner, v × w and the dual vectors, as arrays.
    pub(crate) fn lane_data(&self) -> ([f32; 3], [f32; 3], [f32; 3], [f32; 3]) {
        let a = |v: Vec3| [v.x, v.y, v.z];
        (
            [self.p.x, self.p.y, self.p.z],
            a(self.n),
            a(self.ds),
            a(self.dt),
        )
    }

    /// The surface at (s, t).
    #[inline]
    pub fn geometry(&self, s: f32, t: f32) -> LocalGeometry {
        let n = self.unit_n;
        LocalGeometry {
            p: self.p + self.v * s + self.w * t,
            n,
            ns: n,
            uv: Point2::new(s, t),
            dpdu: self.v,
        }
    }

    /// The unit normal v × w / |v × w|.
    #[inline]
    pub fn normal(&self) -> Normal3 {
        self.unit_n
    }

    /// The shading frame of every point: [`Frame::from_normal_tangent`] of the normal and
    /// ∂p/∂u = `v`.
    #[inline]
    pub fn frame(&self) -> Frame {
        self.frame
    }

    /// Area |v × w|.
    pub fn area(&self) -> f32 {
        self.n.norm()
    }

    /// Bounds of the four corners.
    pub fn bounds(&self) -> Bounds3 {
        Bounds3::point(self.p)
            .union_point(self.p + self.v)
            .union_point(self.p + self.w)
            .union_point(self.p + self.v + self.w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_by_hand() {
        let q = Parallelogram::new(
            Point3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        )
        .unwrap();
        let r = Ray::new(Point3::new(2.5, 0.5, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let h = q.intersect(&r).unwrap();
        assert_eq!(h.t, 1.0);
        // 2.5 = 1 + 2s + t, 0.5 = t.
        assert_eq!(h.uv, [0.5, 0.5]);
        let g = q.geometry(h.uv[0], h.uv[1]);
        assert_eq!(g.p, Point3::new(2.5, 0.5, 0.0));
        assert_eq!(g.n, Normal3::new(0.0, 0.0, 1.0));
        assert!((q.area() - 2.0).abs() < 1e-6);
        // Just outside the slanted edge, parallel, and edge/vertex hits.
        assert!(q
            .intersect(&Ray::new(
                Point3::new(1.2, 0.5, 1.0),
                Vec3::new(0.0, 0.0, -1.0)
            ))
            .is_none());
        assert!(q
            .intersect(&Ray::new(Point3::new(2.0, 0.5, 1.0), Vec3::X))
            .is_none());
        assert!(q
            .intersect(&Ray::new(
                Point3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 0.0, -1.0)
            ))
            .is_some());
        assert!(q
            .intersect(&Ray::new(Point3::new(4.0, 1.0, -1.0), Vec3::Z))
            .is_some());
        assert!(Parallelogram::new(Point3::ORIGIN, Vec3::X, Vec3::X * 2.0).is_none());
    }
}
