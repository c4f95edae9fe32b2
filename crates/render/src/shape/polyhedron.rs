//! Convex polyhedra: the intersection of half-spaces n·x ≤ d, placed by a transformation.
//!
//! Scene syntax: `polyhedron(MAT, T, [n1], d1, [n2], d2, …)`. The ray is clipped by each
//! half-space in turn (the lecture's entering/exiting intervals): where n·d < 0 it enters, where
//! n·d > 0 it leaves; the solid is crossed on `[max enter, min exit]`. The normal is that of the
//! plane crossed; uv are the course's plane coordinates (fractional parts) in a frame of that
//! face.

use super::cube::Crossing;
use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Frame, Normal3, Point2, Ray, Transform, Vec3};

/// A bounded convex polyhedron.
#[derive(Clone, Debug, PartialEq)]
pub struct Polyhedron {
    /// Object → world.
    pub world_from_object: Transform,
    /// Half-spaces (unit normal, offset) in the object frame.
    planes: Vec<(Vec3, f32)>,
    bounds: Bounds3,
}

/// Why a set of half-spaces is not a valid polyhedron.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PolyhedronError {
    /// A normal is zero or not finite.
    BadNormal(usize),
    /// The half-spaces leave an unbounded region.
    Unbounded,
    /// The half-spaces leave no volume.
    Empty,
}

impl std::fmt::Display for PolyhedronError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PolyhedronError::BadNormal(i) => {
                write!(f, "half-space {} has a zero or invalid normal", i + 1)
            }
            PolyhedronError::Unbounded => {
                write!(f, "the half-spaces do not enclose a bounded solid")
            }
            PolyhedronError::Empty => write!(f, "the half-spaces have no common volume"),
        }
    }
}

impl Polyhedron {
    /// The polyhedron ∩ {n·x ≤ d}, placed by `t`.
    pub fn new(
        world_from_object: Transform,
        halfspaces: &[(Vec3, f32)],
    ) -> Result<Self, PolyhedronError> {
        let mut planes = Vec::with_capacity(halfspaces.len());
        for (i, &(n, d)) in halfspaces.iter().enumerate() {
            let len = n.norm();
            if !(len > 0.0 && len.is_finite() && d.is_finite()) {
                return Err(PolyhedronError::BadNormal(i));
            }
            planes.push((n / len, d / len));
        }
        if recession_direction(&planes) {
            return Err(PolyhedronError::Unbounded);
        }
        let local = vertex_bounds(&planes).ok_or(PolyhedronError::Empty)?;
        let d = local.diagonal();
        if d.x <= 0.0 || d.y <= 0.0 || d.z <= 0.0 {
            return Err(PolyhedronError::Empty);
        }
        Ok(Self {
            world_from_object,
            planes,
            bounds: local.transform(&world_from_object),
        })
    }

    /// The half-spaces (unit normals) in the object frame.
    pub fn planes(&self) -> &[(Vec3, f32)] {
        &self.planes
    }

    /// Where the ray's line enters and leaves the solid (parameters and planes), or `None`.
    #[inline]
    pub fn crossings(&self, ray: &Ray) -> Option<(Crossing, Crossing)> {
        let o = self.world_from_object.inv_point(ray.o).to_vec();
        let d = self.world_from_object.inv_vector(ray.d);
        let mut near = (f32::NEG_INFINITY, 0u32);
        let mut far = (f32::INFINITY, 0u32);
        for (i, &(n, off)) in self.planes.iter().enumerate() {
            let nd = n.dot(d);
            let dist = off - n.dot(o);
            if nd == 0.0 {
                if dist < 0.0 {
                    return None;
                }
                continue;
            }
            let t = dist / nd;
            if nd < 0.0 {
                if t > near.0 {
                    near = (t, i as u32);
                }
            } else if t < far.0 {
                far = (t, i as u32);
            }
            if near.0 > far.0 {
                return None;
            }
        }
        Some((near, far))
    }

    /// The closest crossing inside the ray's interval.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let (near, far) = self.crossings(ray)?;
        let (t, plane) = if near.0 > ray.tmin { near } else { far };
        (t > ray.tmin && t < ray.tmax).then_some(ShapeHit {
            t,
            uv: [0.0; 2],
            sub: plane,
            leaf: 0,
        })
    }

    /// The surface where the ray crosses plane `plane` at `t`.
    pub fn geometry(&self, ray: &Ray, t: f32, plane: u32) -> LocalGeometry {
        let w = &self.world_from_object;
        let (n, off) = self.planes[plane as usize];
        let mut q = (w.inv_point(ray.o) + w.inv_vector(ray.d) * t).to_vec();
        // Project onto the plane.
        q = q - n * (n.dot(q) - off);
        let f = Frame::from_normal(n.to_normal());
        let (a, b) = (q.dot(f.s), q.dot(f.t));
        let nw = w.normal(n.to_normal()).normalize();
        LocalGeometry {
            p: w.point(q.to_point()),
            n: nw,
            ns: nw,
            uv: Point2::new(a - a.floor(), b - b.floor()),
            dpdu: w.vector(f.s),
        }
    }

    /// World-space bounds (of the transformed vertices' box).
    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }
}

/// True when some direction u ≠ 0 has n·u ≤ 0 for every plane (the region is unbounded).
/// The extreme rays of that cone are crossings of two planes (±nᵢ × nⱼ).
fn recession_direction(planes: &[(Vec3, f32)]) -> bool {
    let mut any_candidate = false;
    for (i, &(a, _)) in planes.iter().enumerate() {
        for &(b, _) in &planes[i + 1..] {
            let u = a.cross(b);
            let len = u.norm();
            if len < 1e-6 {
                continue;
            }
            any_candidate = true;
            let u = u / len;
            for dir in [u, -u] {
                if planes.iter().all(|&(n, _)| n.dot(dir) <= 1e-6) {
                    return true;
                }
            }
        }
    }
    !any_candidate
}

/// The box of the vertices (crossings of three planes inside all half-spaces).
fn vertex_bounds(planes: &[(Vec3, f32)]) -> Option<Bounds3> {
    let mut b = Bounds3::EMPTY;
    let n = planes.len();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b1, c) = (planes[i], planes[j], planes[k]);
                let det = a.0.dot(b1.0.cross(c.0));
                if det.abs() < 1e-9 {
                    continue;
                }
                // Cramer's rule for x with nᵢ·x = dᵢ for the three planes.
                let x =
                    (b1.0.cross(c.0) * a.1 + c.0.cross(a.0) * b1.1 + a.0.cross(b1.0) * c.1) / det;
                let scale = 1.0 + x.norm();
                if planes
                    .iter()
                    .all(|&(pn, pd)| pn.dot(x) <= pd + 1e-5 * scale)
                {
                    b = b.union_point(x.to_point());
                }
            }
        }
    }
    (!b.is_empty()).then_some(b)
}

impl Polyhedron {
    /// The outward normal of plane `i` in world space (unit).
    pub fn plane_normal(&self, i: u32) -> Normal3 {
        self.world_from_object
            .normal(self.planes[i as usize].0.to_normal())
            .normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Point3;

    fn cube_planes() -> Vec<(Vec3, f32)> {
        vec![
            (Vec3::X, 1.0),
            (-Vec3::X, 1.0),
            (Vec3::Y, 1.0),
            (-Vec3::Y, 1.0),
            (Vec3::Z, 1.0),
            (-Vec3::Z, 1.0),
        ]
    }

    #[test]
    fn a_cube_of_six_half_spaces_by_hand() {
        let p = Polyhedron::new(Transform::IDENTITY, &cube_planes()).unwrap();
        assert_eq!(
            p.bounds(),
            Bounds3::new(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0))
        );
        let r = Ray::new(Point3::new(-3.0, 0.5, 0.0), Vec3::X);
        let h = p.intersect(&r).unwrap();
        assert_eq!((h.t, h.sub), (2.0, 1));
        let g = p.geometry(&r, h.t, h.sub);
        assert_eq!(g.n, Normal3::new(-1.0, 0.0, 0.0));
        assert_eq!(g.p, Point3::new(-1.0, 0.5, 0.0));
        // From inside: the exit plane.
        let h = p.intersect(&Ray::new(Point3::ORIGIN, Vec3::Y)).unwrap();
        assert_eq!((h.t, h.sub), (1.0, 2));
        // Parallel outside a slab.
        assert!(p
            .intersect(&Ray::new(Point3::new(-3.0, 2.0, 0.0), Vec3::X))
            .is_none());
    }

    #[test]
    fn a_tetrahedron_by_hand() {
        // x, y, z ≥ 0 and x + y + z ≤ 1.
        let planes = [
            (-Vec3::X, 0.0),
            (-Vec3::Y, 0.0),
            (-Vec3::Z, 0.0),
            (Vec3::new(1.0, 1.0, 1.0), 1.0),
        ];
        let p = Polyhedron::new(Transform::IDENTITY, &planes).unwrap();
        assert!(p.bounds().max.approx_eq(Point3::new(1.0, 1.0, 1.0), 1e-6));
        let r = Ray::new(Point3::new(0.2, 0.2, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let h = p.intersect(&r).unwrap();
        assert!((h.t - 4.4).abs() < 1e-5);
        assert_eq!(h.sub, 3);
        assert!(p
            .geometry(&r, h.t, h.sub)
            .n
            .to_vec()
            .approx_eq(Vec3::new(1.0, 1.0, 1.0).normalize(), 1e-6));
    }

    #[test]
    fn invalid_sets_are_rejected() {
        let open = [
            (Vec3::X, 1.0),
            (-Vec3::X, 1.0),
            (Vec3::Y, 1.0),
            (-Vec3::Y, 1.0),
            (Vec3::Z, 1.0),
        ];
        assert_eq!(
            Polyhedron::new(Transform::IDENTITY, &open),
            Err(PolyhedronError::Unbounded)
        );
        let cone = [(-Vec3::X, 0.0), (-Vec3::Y, 0.0), (-Vec3::Z, 0.0)];
        assert_eq!(
            Polyhedron::new(Transform::IDENTITY, &cone),
            Err(PolyhedronError::Unbounded)
        );
        let mut empty = cube_planes();
        empty.push((Vec3::X, -2.0));
        assert_eq!(
            Polyhedron::new(Transform::IDENTITY, &empty),
            Err(PolyhedronError::Empty)
        );
        assert_eq!(
            Polyhedron::new(Transform::IDENTITY, &[(Vec3::ZERO, 1.0)]),
            Err(PolyhedronError::BadNormal(0))
        );
    }
}
