//! The unit disk x² + y² ≤ 1 of the plane z = 0, placed by a transformation (Mitsuba `disk`).
//!
//! uv = (r, φ/2π) as in Mitsuba; the normal is +z of the disk's frame.

use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Normal3, Point2, Point3, Ray, Transform, Vec3, INV_PI, PI};

/// A unit disk placed by `world_from_object`.
#[derive(Clone, Debug, PartialEq)]
pub struct Disk {
    /// Object → world.
    pub world_from_object: Transform,
}

impl Disk {
    /// A disk placed by `t`.
    pub fn new(world_from_object: Transform) -> Self {
        Self { world_from_object }
    }

    /// The crossing with the ray in its interval.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let o = self.world_from_object.inv_point(ray.o);
        let d = self.world_from_object.inv_vector(ray.d);
        if d.z == 0.0 {
            return None;
        }
        let t = -o.z / d.z;
        if !(t > ray.tmin && t < ray.tmax) {
            return None;
        }
        let (x, y) = (o.x + t * d.x, o.y + t * d.y);
        (x * x + y * y <= 1.0).then_some(ShapeHit {
            t,
            uv: [x, y],
            sub: 0,
            leaf: 0,
        })
    }

    /// The surface at the local point (x, y).
    pub fn geometry(&self, x: f32, y: f32) -> LocalGeometry {
        let w = &self.world_from_object;
        let r = (x * x + y * y).sqrt();
        let mut phi = y.atan2(x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let n = w.normal(Normal3::new(0.0, 0.0, 1.0)).normalize();
        LocalGeometry {
            p: w.point(Point3::new(x, y, 0.0)),
            n,
            ns: n,
            uv: Point2::new(r, phi * 0.5 * INV_PI),
            dpdu: w.vector(Vec3::new(-y, x, 0.0)),
        }
    }

    /// Bounds of the transformed unit square around the disk.
    pub fn bounds(&self) -> Bounds3 {
        Bounds3::new(Point3::new(-1.0, -1.0, 0.0), Point3::new(1.0, 1.0, 0.0))
            .transform(&self.world_from_object)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_by_hand() {
        let d = Disk::new(Transform::translation(Vec3::new(0.0, 0.0, 1.0)));
        let r = Ray::new(Point3::new(0.0, 0.5, 3.0), Vec3::new(0.0, 0.0, -1.0));
        let h = d.intersect(&r).unwrap();
        assert_eq!(h.t, 2.0);
        let g = d.geometry(h.uv[0], h.uv[1]);
        assert_eq!(g.p, Point3::new(0.0, 0.5, 1.0));
        assert_eq!((g.uv.x, g.uv.y), (0.5, 0.25));
        assert!(d
            .intersect(&Ray::new(
                Point3::new(0.8, 0.8, 3.0),
                Vec3::new(0.0, 0.0, -1.0)
            ))
            .is_none());
    }
}
