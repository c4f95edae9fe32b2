//! The unit sphere centred at the origin, placed by a transformation.
//!
//! Scene syntax: `sphere(MATERIAL, T)` (candela), `<shape type="sphere">` with `center` and
//! `radius` (Mitsuba: a transformation `translate(center)·scale(radius)`).
//!
//! Rays are moved into the sphere's frame by `T⁻¹`; the normal goes back by the inverse
//! transpose. uv follows the course: `u = atan2(y, x)/2π` in [0, 1), `v = acos(z)/π`.

use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Normal3, Point2, Point3, Ray, Transform, Vec3, INV_PI, PI};

/// A unit sphere placed by `world_from_object`.
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    /// Object → world.
    pub world_from_object: Transform,
}

impl Sphere {
    /// A sphere placed by `t`.
    pub fn new(world_from_object: Transform) -> Self {
        Self { world_from_object }
    }

    /// Both parameters where the ray's line crosses the sphere, in increasing order, in the
    /// sphere's frame; `None` when the line misses.
    ///
    /// The discriminant is computed from the distance of the line to the centre, which avoids
    /// the cancellation of `b² − 4ac` (Haines et al., "Precision Improvements for Ray/Sphere
    /// Intersection", Ray Tracing Gems 2019).
    #[inline]
    pub fn crossings(&self, ray: &Ray) -> Option<(f32, f32)> {
        let o = self.world_from_object.inv_point(ray.o).to_vec();
        let d = self.world_from_object.inv_vector(ray.d);
        let a = d.squared_norm();
        let half_b = o.dot(d);
        let f = o - d * (half_b / a);
        let disc = a * (1.0 - f.squared_norm());
        if !(disc >= 0.0) {
            return None;
        }
        let q = -(half_b + disc.sqrt().copysign(half_b));
        let c = o.squared_norm() - 1.0;
        let (t0, t1) = (c / q, q / a);
        Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
    }

    /// True when the inverse placement is affine (last row 0, 0, 0, 1): points then leave
    /// the world frame without the homogeneous division changing them.
    pub fn has_affine_inverse(&self) -> bool {
        self.world_from_object.inv.m[3] == [0.0, 0.0, 0.0, 1.0]
    }

    /// The closest crossing inside the ray's interval.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let (t0, t1) = self.crossings(ray)?;
        let t = if t0 > ray.tmin { t0 } else { t1 };
        (t > ray.tmin && t < ray.tmax).then_some(ShapeHit {
            t,
            uv: [0.0; 2],
            sub: 0,
            leaf: 0,
        })
    }

    /// The surface at a hit found by [`Sphere::intersect`].
    pub fn geometry(&self, ray: &Ray, t: f32) -> LocalGeometry {
        local_geometry(&self.world_from_object, self.object_hit(ray, t), true)
    }

    /// [`Sphere::geometry`] without texture coordinates (left at zero): for scenes where no
    /// texture reads them, which spares an arctangent and an arccosine per hit.
    #[inline(always)]
    pub fn geometry_without_uv(&self, ray: &Ray, t: f32) -> LocalGeometry {
        local_geometry(&self.world_from_object, self.object_hit(ray, t), false)
    }

    /// The hit at `t` along `ray` in object space, re-projected onto the unit sphere to remove
    /// the error accumulated along the ray.
    #[inline(always)]
    fn object_hit(&self, ray: &Ray, t: f32) -> Vec3 {
        let o = self.world_from_object.inv_point(ray.o);
        let d = self.world_from_object.inv_vector(ray.d);
        let q = (o + d * t).to_vec();
        q / q.norm()
    }

    /// The surface at the object-space point `q` (unit length).
    pub fn geometry_at(&self, q: Vec3) -> LocalGeometry {
        local_geometry(&self.world_from_object, q, true)
    }

    /// Exact bounds of the transformed sphere (an ellipsoid): along axis i its half extent is
    /// the norm of row i of the linear part.
    pub fn bounds(&self) -> Bounds3 {
        let m = &self.world_from_object.m.m;
        let c = self.world_from_object.point(Point3::ORIGIN);
        let ext = Vec3::new(
            (m[0][0] * m[0][0] + m[0][1] * m[0][1] + m[0][2] * m[0][2]).sqrt(),
            (m[1][0] * m[1][0] + m[1][1] * m[1][1] + m[1][2] * m[1][2]).sqrt(),
            (m[2][0] * m[2][0] + m[2][1] * m[2][1] + m[2][2] * m[2][2]).sqrt(),
        );
        Bounds3::new(c - ext, c + ext)
    }

    /// True when the point (world space) is strictly inside.
    pub fn contains(&self, p: Point3) -> bool {
        self.world_from_object.inv_point(p).to_vec().squared_norm() < 1.0
    }
}

/// The surface at the object-space point `q` (unit length), with its texture coordinates
/// when `uv` (else (0, 0)).
#[inline(always)]
fn local_geometry(t: &Transform, q: Vec3, uv: bool) -> LocalGeometry {
    let (u, v) = if uv { sphere_uv(q) } else { (0.0, 0.0) };
    let n = t.normal(Normal3::new(q.x, q.y, q.z)).normalize();
    let dpdu = t.vector(Vec3::new(-2.0 * PI * q.y, 2.0 * PI * q.x, 0.0));
    LocalGeometry {
        p: t.point(q.to_point()),
        n,
        ns: n,
        uv: Point2::new(u, v),
        dpdu,
    }
}

/// Longitude and colatitude of the unit vector `q`, both scaled to [0, 1).
fn sphere_uv(q: Vec3) -> (f32, f32) {
    let mut phi = q.y.atan2(q.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let u = (phi * 0.5 * INV_PI).min(super::ONE_MINUS_EPS);
    (u, crate::math::safe_acos(q.z) * INV_PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_from_outside_by_hand() {
        let s = Sphere::new(Transform::IDENTITY);
        let r = Ray::new(Point3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let h = s.intersect(&r).unwrap();
        assert_eq!(h.t, 1.0);
        let g = s.geometry(&r, h.t);
        assert_eq!(g.p, Point3::new(0.0, 0.0, 1.0));
        assert_eq!(g.n, Normal3::new(0.0, 0.0, 1.0));
        assert_eq!(g.uv.y, 0.0);

        let r = Ray::new(Point3::new(3.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0));
        let h = s.intersect(&r).unwrap();
        assert_eq!(h.t, 2.0);
        let g = s.geometry(&r, h.t);
        assert_eq!(g.p, Point3::new(1.0, 0.0, 0.0));
        assert_eq!((g.uv.x, g.uv.y), (0.0, 0.5));
    }

    #[test]
    fn hits_from_inside_and_misses() {
        let s = Sphere::new(Transform::IDENTITY);
        let r = Ray::new(Point3::ORIGIN, Vec3::X);
        let h = s.intersect(&r).unwrap();
        assert_eq!(h.t, 1.0);
        // The outward normal is kept; integrators orient it.
        assert_eq!(s.geometry(&r, h.t).n, Normal3::new(1.0, 0.0, 0.0));
        assert!(s
            .intersect(&Ray::new(Point3::new(0.0, 2.0, 2.0), Vec3::X))
            .is_none());
        assert!(s
            .intersect(&Ray::new(Point3::new(2.0, 0.0, 0.0), Vec3::X))
            .is_none());
    }

    #[test]
    fn transformed_sphere_by_hand() {
        let s = Sphere::new(Transform::translation(Vec3::new(10.0, 0.0, 0.0)));
        let r = Ray::new(Point3::new(10.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let h = s.intersect(&r).unwrap();
        let g = s.geometry(&r, h.t);
        assert_eq!(g.p, Point3::new(10.0, 0.0, 1.0));
        assert_eq!(g.n, Normal3::new(0.0, 0.0, 1.0));
        assert!(s
            .intersect(&Ray::new(
                Point3::new(0.0, 0.0, 2.0),
                Vec3::new(0.0, 0.0, -1.0)
            ))
            .is_none());

        // An ellipsoid stretched along x: its normal is not the radial direction.
        let e = Sphere::new(Transform::scaling(Vec3::new(2.0, 1.0, 1.0)));
        let q = Vec3::new(1.0, 0.0, 1.0).normalize();
        let g = e.geometry_at(q);
        let expected = Vec3::new(0.5, 0.0, 1.0).normalize();
        assert!(g.n.to_vec().approx_eq(expected, 1e-6));
        let b = e.bounds();
        assert!(
            b.min.approx_eq(Point3::new(-2.0, -1.0, -1.0), 1e-6)
                && b.max.approx_eq(Point3::new(2.0, 1.0, 1.0), 1e-6)
        );
    }

    #[test]
    fn course_uv_convention() {
        let s = Sphere::new(Transform::IDENTITY);
        let g = s.geometry_at(Vec3::new(0.0, 1.0, 0.0));
        assert!((g.uv.x - 0.25).abs() < 1e-6 && (g.uv.y - 0.5).abs() < 1e-6);
        let g = s.geometry_at(Vec3::new(0.0, -1.0, 0.0));
        assert!((g.uv.x - 0.75).abs() < 1e-6);
        let g = s.geometry_at(Vec3::new(0.0, 0.0, -1.0));
        assert!((g.uv.y - 1.0).abs() < 1e-6);
    }
}
