//! Axis-aligned bounding boxes.

use super::{Point3, Ray, Transform, Vec3};

/// An axis-aligned box `[min, max]`; empty when some `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds3 {
    /// Lower corner.
    pub min: Point3,
    /// Upper corner.
    pub max: Point3,
}

impl Default for Bounds3 {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Bounds3 {
    /// The empty box (the identity of `union`).
    pub const EMPTY: Bounds3 = Bounds3 {
        min: Point3::new(f32::INFINITY, f32::INFINITY, f32::INFINITY),
        max: Point3::new(f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY),
    };

    /// The box spanned by two corners (in any order).
    pub fn new(a: Point3, b: Point3) -> Self {
        Self {
            min: a.min(b),
            max: a.max(b),
        }
    }

    /// The box of a single point.
    pub fn point(p: Point3) -> Self {
        Self { min: p, max: p }
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(self, o: Bounds3) -> Bounds3 {
        Bounds3 {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// The smallest box holding `self` and `p`.
    #[inline]
    pub fn union_point(self, p: Point3) -> Bounds3 {
        Bounds3 {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The common part of two boxes (possibly empty).
    pub fn intersection(self, o: Bounds3) -> Bounds3 {
        Bounds3 {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }

    /// True when the box holds no point.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// True when every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// The diagonal `max - min`.
    #[inline]
    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }

    /// The centre.
    #[inline]
    pub fn centroid(&self) -> Point3 {
        self.min.lerp(self.max, 0.5)
    }

    /// Surface area (0 for an empty box).
    #[inline]
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.diagonal();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// The axis of largest extent.
    pub fn max_extent(&self) -> usize {
        self.diagonal().max_dimension()
    }

    /// The position of `p` relative to the corners: 0 at `min`, 1 at `max`, per axis.
    pub fn offset(&self, p: Point3) -> Vec3 {
        let mut o = p - self.min;
        let d = self.diagonal();
        if d.x > 0.0 {
            o.x /= d.x;
        }
        if d.y > 0.0 {
            o.y /= d.y;
        }
        if d.z > 0.0 {
            o.z /= d.z;
        }
        o
    }

    /// True when `p` is inside or on the boundary.
    pub fn contains(&self, p: Point3) -> bool {
        p.x >= self.min.x
            && p.x <= self.max.x
            && p.y >= self.min.y
            && p.y <= self.max.y
            && p.z >= self.min.z
            && p.z <= self.max.z
    }

    /// The box of the eight transformed corners.
    pub fn transform(&self, t: &Transform) -> Bounds3 {
        if self.is_empty() {
            return *self;
        }
        let mut b = Bounds3::EMPTY;
        for i in 0..8 {
            let c = Point3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            b = b.union_point(t.point(c));
        }
        b
    }

    /// The parametric interval `[t0, t1]` where the ray is inside the box, clipped to the ray's
    /// own interval; `None` when it misses. `inv_d` is `1/ray.d` per component.
    #[inline]
    pub fn intersect(&self, ray: &Ray, inv_d: Vec3) -> Option<(f32, f32)> {
        let mut t0 = ray.tmin;
        let mut t1 = ray.tmax;
        for a in 0..3 {
            let mut tn = (self.min[a] - ray.o[a]) * inv_d[a];
            let mut tf = (self.max[a] - ray.o[a]) * inv_d[a];
            if tn > tf {
                std::mem::swap(&mut tn, &mut tf);
            }
            // Widen the far bound by the slab test's round-off (pbrt's 1 + 2γ₃).
            tf *= 1.0 + 2.0 * GAMMA3;
            t0 = if tn > t0 { tn } else { t0 };
            t1 = if tf < t1 { tf } else { t1 };
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }
}

/// pbrt's γ₃ = 3ε/(1 − 3ε): the relative error bound of three floating-point operations.
pub const GAMMA3: f32 = 3.0 * (f32::EPSILON * 0.5) / (1.0 - 3.0 * (f32::EPSILON * 0.5));

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn union_area_and_slabs_by_hand() {
        let b = Bounds3::new(Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 2.0, 3.0));
        assert_eq!(b.surface_area(), 2.0 * (2.0 + 6.0 + 3.0));
        assert_eq!(b.max_extent(), 2);
        assert_eq!(b.centroid(), Point3::new(0.5, 1.0, 1.5));
        let u = b.union(Bounds3::point(Point3::new(-1.0, 5.0, 0.0)));
        assert_eq!(u.min, Point3::new(-1.0, 0.0, 0.0));
        assert_eq!(u.max, Point3::new(1.0, 5.0, 3.0));
        assert!(Bounds3::EMPTY.is_empty());
        assert_eq!(Bounds3::EMPTY.union(b), b);

        let r = Ray::new(Point3::new(-1.0, 1.0, 1.0), Vec3::new(1.0, 0.0, 0.0));
        let inv = Vec3::new(1.0, f32::INFINITY, f32::INFINITY);
        let (t0, t1) = b.intersect(&r, inv).unwrap();
        assert_eq!(t0, 1.0);
        assert!((t1 - 2.0).abs() < 1e-5);
        let miss = Ray::new(Point3::new(-1.0, 3.0, 1.0), Vec3::new(1.0, 0.0, 0.0));
        assert!(b.intersect(&miss, inv).is_none());
    }

    #[test]
    fn transformed_box_holds_transformed_corners() {
        let b = Bounds3::new(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0));
        let t = Transform::rotation_z(45.0);
        let tb = b.transform(&t);
        let s = 2f32.sqrt();
        assert!(tb.max.approx_eq(Point3::new(s, s, 1.0), 1e-5));
    }
}
