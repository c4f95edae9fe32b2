//! The open cylinder x² + y² = 1, 0 ≤ z ≤ 1 (no caps), placed by a transformation: Mitsuba's
//! `cylinder` (whose `p0`, `p1`, `radius` the importer folds into the transformation) and the
//! candela language's `cylinder(MAT, T)`.
//!
//! uv = (φ/2π, z) as in Mitsuba; the geometric normal points outwards (away from the axis).

use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Normal3, Point2, Point3, Ray, Transform, Vec3, INV_PI, PI};

/// A unit cylinder placed by `world_from_object`.
#[derive(Clone, Debug, PartialEq)]
pub struct Cylinder {
    /// Object → world.
    pub world_from_object: Transform,
}

impl Cylinder {
    /// A cylinder placed by `t`.
    pub fn new(world_from_object: Transform) -> Self {
        Self { world_from_object }
    }

    /// The closest crossing with the ray in its interval (in object space, where the ray keeps
    /// its parameter).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let o = self.world_from_object.inv_point(ray.o);
        let d = self.world_from_object.inv_vector(ray.d);
        let (ox, oy, dx, dy) = (o.x as f64, o.y as f64, d.x as f64, d.y as f64);
        let a = dx * dx + dy * dy;
        if a == 0.0 {
            return None;
        }
        let b = 2.0 * (dx * ox + dy * oy);
        let c = ox * ox + oy * oy - 1.0;
        let disc = b * b - 4.0 * a * c;
        if !(disc >= 0.0) {
            return None;
        }
        // The numerically stable pair of roots.
        let q = -0.5 * (b + disc.sqrt().copysign(b));
        let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { q / a });
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        for t in [t0, t1] {
            let tf = t as f32;
            if !(tf > ray.tmin && tf < ray.tmax) {
                continue;
            }
            let z = o.z + tf * d.z;
            if (0.0..=1.0).contains(&z) {
                return Some(ShapeHit {
                    t: tf,
                    uv: [0.0, 0.0],
                    sub: 0,
                    leaf: 0,
                });
            }
        }
        None
    }

    /// The surface at the hit `t` of `ray`.
    pub fn geometry(&self, ray: &Ray, t: f32) -> LocalGeometry {
        let w = &self.world_from_object;
        let o = w.inv_point(ray.o);
        let d = w.inv_vector(ray.d);
        let (x, y, z) = (
            o.x + t * d.x,
            o.y + t * d.y,
            (o.z + t * d.z).clamp(0.0, 1.0),
        );
        // Back onto the surface (radius 1) to keep the error small.
        let r = (x * x + y * y).sqrt();
        let (x, y) = if r > 0.0 { (x / r, y / r) } else { (1.0, 0.0) };
        let mut phi = y.atan2(x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let n = w.normal(Normal3::new(x, y, 0.0)).normalize();
        LocalGeometry {
            p: w.point(Point3::new(x, y, z)),
            n,
            ns: n,
            uv: Point2::new(
                (phi * 0.5 * INV_PI).min(super::ONE_MINUS_EPS),
                z.min(super::ONE_MINUS_EPS),
            ),
            dpdu: w.vector(Vec3::new(-y, x, 0.0) * (2.0 * PI)),
        }
    }

    /// Bounds of the transformed box around the cylinder.
    pub fn bounds(&self) -> Bounds3 {
        Bounds3::new(Point3::new(-1.0, -1.0, 0.0), Point3::new(1.0, 1.0, 1.0))
            .transform(&self.world_from_object)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_by_hand() {
        // Radius 2, height 3, axis along z, from z = 1.
        let c = Cylinder::new(
            Transform::translation(Vec3::new(0.0, 0.0, 1.0))
                * Transform::scaling(Vec3::new(2.0, 2.0, 3.0)),
        );
        let r = Ray::new(Point3::new(-5.0, 0.0, 2.5), Vec3::new(1.0, 0.0, 0.0));
        let h = c.intersect(&r).unwrap();
        assert!((h.t - 3.0).abs() < 1e-5);
        let g = c.geometry(&r, h.t);
        assert!((g.p - Point3::new(-2.0, 0.0, 2.5)).norm() < 1e-5);
        assert!((g.n.to_vec() - Vec3::new(-1.0, 0.0, 0.0)).norm() < 1e-5);
        assert!((g.uv.x - 0.5).abs() < 1e-5 && (g.uv.y - 0.5).abs() < 1e-5);
        // From inside: the far wall, normal still outwards.
        let inside = Ray::new(Point3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 1.0, 0.0));
        let h = c.intersect(&inside).unwrap();
        assert!((h.t - 2.0).abs() < 1e-5);
        assert!(c.geometry(&inside, h.t).n.y > 0.99);
        // Open ends: along the axis, and above the top.
        assert!(c
            .intersect(&Ray::new(
                Point3::new(0.0, 0.0, -5.0),
                Vec3::new(0.0, 0.0, 1.0)
            ))
            .is_none());
        assert!(c
            .intersect(&Ray::new(
                Point3::new(-5.0, 0.0, 4.5),
                Vec3::new(1.0, 0.0, 0.0)
            ))
            .is_none());
        // A ray entering through the open top hits the inside wall.
        let down = Ray::new(
            Point3::new(0.0, 0.0, 6.0),
            Vec3::new(1.0, 0.0, -1.0).normalize(),
        );
        let h = c.intersect(&down).unwrap();
        let g = c.geometry(&down, h.t);
        assert!(
            (g.p.x - 2.0).abs() < 1e-4 && (g.p.z - 4.0).abs() < 1e-4,
            "{:?}",
            g.p
        );
        let b = c.bounds();
        assert_eq!((b.min.z, b.max.z, b.max.x), (1.0, 4.0, 2.0));
    }
}
