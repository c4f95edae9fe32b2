//! The unit sphere centred at the origin, placed by a transformation.
//!
//! Scene syntax: `sphere(MATERIAL, T)` (candela), `<shape type="sphere">` with `center` and
//! `radius` (Mitsuba: a transformation `translate(center)·scale(radius)`).
//!
//! Rays are moved into the sphere's frame by `T⁻¹`; the normal goes back by the inverse
//! transpose. A sphere placed by a translation after a uniform scale (a centre and a radius)
//! finds the surface at a hit in world space instead, with the same result up to rounding.
//! uv follows the course: `u = atan2(y, x)/2π` in [0, 1), `v = acos(z)/π`.

use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Normal3, Point2, Point3, Ray, Transform, Vec3, INV_PI, PI};

/// A unit sphere placed by `world_from_object`.
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    /// Object → world.
    pub world_from_object: Transform,
    /// Centre and radius when the placement is a translation after a uniform scale (Mitsuba's
    /// `center` and `radius`): the surface at a hit is then found in world space (a point on
    /// the sphere is the centre plus the radius times its unit direction), without moving the
    /// ray into the object frame and the point, normal and tangent back out of it.
    round: Option<(Point3, f32)>,
}

impl Sphere {
    /// A sphere placed by `t`.
    pub fn new(world_from_object: Transform) -> Self {
        let m = &world_from_object.m.m;
        let r = m[0][0];
        let uniform = r > 0.0
            && r.is_finite()
            && m[1][1] == r
            && m[2][2] == r
            && [m[0][1], m[0][2], m[1][0], m[1][2], m[2][0], m[2][1]] == [0.0; 6]
            && m[3] == [0.0, 0.0, 0.0, 1.0];
        let round = uniform.then(|| (Point3::new(m[0][3], m[1][3], m[2][3]), r));
        Self {
            world_from_object,
            round,
        }
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
        self.geometry_at_hit(ray, t, true)
    }

    /// [`Sphere::geometry`] without texture coordinates (left at zero): for scenes where no
    /// texture reads them, which spares an arctangent and an arccosine per hit.
    #[inline(always)]
    pub fn geometry_without_uv(&self, ray: &Ray, t: f32) -> LocalGeometry {
        self.geometry_at_hit(ray, t, false)
    }

    /// The surface at the hit at `t` along `ray`, with texture coordinates when `uv`.
    #[inline(always)]
    fn geometry_at_hit(&self, ray: &Ray, t: f32, uv: bool) -> LocalGeometry {
        match self.round {
            Some((c, r)) => {
                // The hit's direction from the centre is the object-space point (the uniform
                // scale divides out), re-projected onto the sphere.
                let q = (ray.o + ray.d * t) - c;
                round_geometry(c, r, q / q.norm(), uv)
            }
            None => local_geometry(&self.world_from_object, self.object_hit(ray, t), uv),
        }
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
        match self.round {
            Some((c, r)) => round_geometry(c, r, q, true),
            None => local_geometry(&self.world_from_object, q, true),
        }
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

    /// The centre and radius of a sphere (world space) around the transformed sphere: its
    /// centre, and its longest semi-axis.
    pub fn bounding_sphere(&self) -> (Point3, f32) {
        let m = &self.world_from_object;
        let r = [Vec3::X, Vec3::Y, Vec3::Z]
            .iter()
            .map(|&a| m.vector(a).norm())
            .fold(0.0f32, f32::max);
        (m.point(Point3::ORIGIN), r)
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

/// [`local_geometry`] for the sphere of centre `c` and radius `r` (a translation after a
/// uniform scale): the same surface, in world space.
#[inline(always)]
fn round_geometry(c: Point3, r: f32, q: Vec3, uv: bool) -> LocalGeometry {
    let (u, v) = if uv { sphere_uv(q) } else { (0.0, 0.0) };
    let n = Normal3::new(q.x, q.y, q.z);
    LocalGeometry {
        p: c + q * r,
        n,
        ns: n,
        uv: Point2::new(u, v),
        dpdu: Vec3::new(-2.0 * PI * r * q.y, 2.0 * PI * r * q.x, 0.0),
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

    /// A sphere placed by a translation after a uniform scale takes the world-space shortcut
    /// (`round`), and gives the surface the object-space route gives, within rounding: point,
    /// normal, tangent and texture coordinates, at hits of random rays and at given points.
    /// Placements that rotate, stretch or mirror keep the object-space route.
    #[test]
    fn round_spheres_match_the_object_space_route() {
        let place = Transform::translation(Vec3::new(0.38, -0.68, 0.3))
            * Transform::scaling(Vec3::new(0.32, 0.32, 0.32));
        let fast = Sphere::new(place);
        assert_eq!(fast.round, Some((Point3::new(0.38, -0.68, 0.3), 0.32)));
        let slow = Sphere {
            world_from_object: place,
            round: None,
        };
        for t in [
            Transform::rotation_z(30.0) * place,
            Transform::scaling(Vec3::new(1.0, 2.0, 1.0)),
            Transform::scaling(Vec3::new(-1.0, -1.0, -1.0)),
        ] {
            assert_eq!(Sphere::new(t).round, None);
        }
        let mut rng = crate::sampling::pcg::Pcg32::new(7, 1);
        let mut checked = 0;
        for _ in 0..2000 {
            let o = Point3::new(
                rng.next_f32() * 4.0 - 2.0,
                rng.next_f32() * 4.0 - 2.0,
                rng.next_f32() * 4.0 - 2.0,
            );
            let target = Point3::new(
                0.38 + rng.next_f32() * 0.6 - 0.3,
                -0.68 + rng.next_f32() * 0.6 - 0.3,
                0.3 + rng.next_f32() * 0.6 - 0.3,
            );
            let ray = Ray::new(o, (target - o).normalize());
            let Some(h) = fast.intersect(&ray) else {
                continue;
            };
            checked += 1;
            for uv in [false, true] {
                let (a, b) = (
                    fast.geometry_at_hit(&ray, h.t, uv),
                    slow.geometry_at_hit(&ray, h.t, uv),
                );
                assert!(a.p.approx_eq(b.p, 2e-6), "{a:?} {b:?}");
                assert!(a.n.to_vec().approx_eq(b.n.to_vec(), 2e-6), "{a:?} {b:?}");
                assert!(a.dpdu.approx_eq(b.dpdu, 1e-5), "{a:?} {b:?}");
                assert!((a.uv.x - b.uv.x).abs() < 1e-5 || (a.uv.x - b.uv.x).abs() > 0.99999);
                assert!((a.uv.y - b.uv.y).abs() < 1e-5);
                // On the sphere, to rounding.
                assert!(((a.p - Point3::new(0.38, -0.68, 0.3)).norm() - 0.32).abs() < 1e-6);
            }
        }
        assert!(checked > 500, "{checked} hits");
    }
}
