//! The infinite plane z = 0, placed by a transformation.
//!
//! Scene syntax: `plane(MATERIAL, T)`. uv follows the course: `u = x − ⌊x⌋`, `v = y − ⌊y⌋` in the
//! plane's frame. Planes are unbounded: accelerators keep them outside their structure.

use super::{LocalGeometry, ShapeHit};
use crate::math::{Normal3, Point2, Point3, Ray, Transform, Vec3};

/// The plane z = 0 placed by `world_from_object`.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// Object → world.
    pub world_from_object: Transform,
}

impl Plane {
    /// A plane placed by `t`.
    pub fn new(world_from_object: Transform) -> Self {
        Self { world_from_object }
    }

    /// The crossing of the ray with the plane, in the ray's interval.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let oz = self.world_from_object.inv_point(ray.o).z;
        let dz = self.world_from_object.inv_vector(ray.d).z;
        if dz == 0.0 {
            return None;
        }
        let t = -oz / dz;
        (t > ray.tmin && t < ray.tmax).then_some(ShapeHit {
            t,
            uv: [0.0; 2],
            sub: 0,
            leaf: 0,
        })
    }

    /// The surface at a hit found by [`Plane::intersect`].
    pub fn geometry(&self, ray: &Ray, t: f32) -> LocalGeometry {
        let o = self.world_from_object.inv_point(ray.o);
        let d = self.world_from_object.inv_vector(ray.d);
        let (x, y) = (o.x + t * d.x, o.y + t * d.y);
        let w = &self.world_from_object;
        let n = w.normal(Normal3::new(0.0, 0.0, 1.0)).normalize();
        LocalGeometry {
            p: w.point(Point3::new(x, y, 0.0)),
            n,
            ns: n,
            uv: Point2::new(x - x.floor(), y - y.floor()),
            dpdu: w.vector(Vec3::X),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_by_hand() {
        let p = Plane::new(Transform::IDENTITY);
        let r = Ray::new(Point3::new(0.25, -1.75, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let h = p.intersect(&r).unwrap();
        assert_eq!(h.t, 1.0);
        let g = p.geometry(&r, h.t);
        assert_eq!(g.p, Point3::new(0.25, -1.75, 0.0));
        assert_eq!(g.n, Normal3::new(0.0, 0.0, 1.0));
        assert_eq!((g.uv.x, g.uv.y), (0.25, 0.25));
        // Parallel, pointing away, and from below.
        assert!(p
            .intersect(&Ray::new(Point3::new(0.0, 0.0, 1.0), Vec3::X))
            .is_none());
        assert!(p
            .intersect(&Ray::new(Point3::new(0.0, 0.0, 1.0), Vec3::Z))
            .is_none());
        let below = Ray::new(Point3::new(0.0, 0.0, -2.0), Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(p.intersect(&below).unwrap().t, 2.0);
    }

    #[test]
    fn transformed_plane_by_hand() {
        // The plane x = 3 with its normal along +x.
        let p = Plane::new(
            Transform::translation(Vec3::new(3.0, 0.0, 0.0)) * Transform::rotation_y(90.0),
        );
        let r = Ray::new(Point3::ORIGIN, Vec3::X);
        let h = p.intersect(&r).unwrap();
        assert!((h.t - 3.0).abs() < 1e-6);
        let g = p.geometry(&r, h.t);
        assert!(g.n.to_vec().approx_eq(Vec3::X, 1e-6));
        assert!(g.p.approx_eq(Point3::new(3.0, 0.0, 0.0), 1e-6));
    }
}
