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
        let local = clipped_bounds(&planes)?;
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

/// Half the side of the box the half-spaces are clipped from: a polyhedron reaching it is
/// unbounded (or larger than any scene).
const BIG: f64 = 1e9;

/// The box of the vertices of ∩ {n·x ≤ d}, found by clipping a huge box by each half-space in
/// turn (its faces as convex polygons, Sutherland–Hodgman on each, the cut closed by a new
/// face). Each clip touches every vertex once and a polyhedron of n planes has O(n) vertices,
/// so the whole is O(n²) in the worst case.
/// The clipping runs twice: from the huge box to find the solid, then from a box just larger
/// than what was found, so that the vertices have the precision of the solid's own size.
fn clipped_bounds(planes: &[(Vec3, f32)]) -> Result<Bounds3, PolyhedronError> {
    let rough = clip_box(planes, [-BIG; 3], [BIG; 3])?;
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for p in &rough {
        if p.iter().any(|x| x.abs() >= BIG * 0.5) {
            return Err(PolyhedronError::Unbounded);
        }
    }
    for i in 0..3 {
        lo[i] = rough.iter().map(|p| p[i]).fold(f64::INFINITY, f64::min);
        hi[i] = rough.iter().map(|p| p[i]).fold(f64::NEG_INFINITY, f64::max);
    }
    let margin = 0.01 * (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max) + 1e-3;
    let fine = clip_box(planes, lo.map(|x| x - margin), hi.map(|x| x + margin))?;
    let mut b = Bounds3::EMPTY;
    for p in fine {
        b = b.union_point(crate::math::Point3::new(
            p[0] as f32,
            p[1] as f32,
            p[2] as f32,
        ));
    }
    Ok(b)
}

/// The vertices of the box [lo, hi] clipped by every half-space (see [`clipped_bounds`]).
fn clip_box(
    planes: &[(Vec3, f32)],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Result<Vec<[f64; 3]>, PolyhedronError> {
    type P = [f64; 3];
    let dot = |a: P, b: P| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let lerp = |a: P, b: P, t: f64| {
        [
            a[0] + (b[0] - a[0]) * t,
            a[1] + (b[1] - a[1]) * t,
            a[2] + (b[2] - a[2]) * t,
        ]
    };
    // The six faces of the box, each a polygon.
    let pick = |i: usize, side: bool| if side { hi[i] } else { lo[i] };
    let mut faces: Vec<Vec<P>> = Vec::with_capacity(6);
    for axis in 0..3 {
        for side in [false, true] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let face = [(false, false), (true, false), (true, true), (false, true)]
                .into_iter()
                .map(|(a, b)| {
                    let mut p = [0.0; 3];
                    p[axis] = pick(axis, side);
                    p[u] = pick(u, a);
                    p[v] = pick(v, b);
                    p
                })
                .collect();
            faces.push(face);
        }
    }
    for &(n, d) in planes {
        let n = [n.x as f64, n.y as f64, n.z as f64];
        let d = d as f64;
        let tol = 1e-6 * (1.0 + d.abs());
        // A half-space that cuts nothing off (a repeated or redundant plane) leaves the solid
        // as it is: adding its face anyway would let repeats pile up copies of one face.
        if faces.iter().flatten().all(|&p| dot(n, p) - d <= tol) {
            continue;
        }
        let mut kept = Vec::with_capacity(faces.len() + 1);
        let mut cut: Vec<P> = Vec::new();
        for face in faces {
            let dist: Vec<f64> = face.iter().map(|&p| dot(n, p) - d).collect();
            if dist.iter().all(|&x| x <= tol) {
                cut.extend(
                    face.iter()
                        .zip(&dist)
                        .filter(|(_, &x)| x >= -tol)
                        .map(|(p, _)| *p),
                );
                kept.push(face);
                continue;
            }
            let mut out = Vec::with_capacity(face.len() + 1);
            for i in 0..face.len() {
                let j = (i + 1) % face.len();
                let (a, b, da, db) = (face[i], face[j], dist[i], dist[j]);
                if da <= tol {
                    out.push(a);
                    if da >= -tol {
                        cut.push(a);
                    }
                }
                if (da < -tol && db > tol) || (da > tol && db < -tol) {
                    let p = lerp(a, b, da / (da - db));
                    out.push(p);
                    cut.push(p);
                }
            }
            if out.len() >= 3 {
                kept.push(out);
            }
        }
        if cut.len() >= 3 {
            // The new face: the cut points in angular order around their centroid.
            let k = cut.len() as f64;
            let c = cut.iter().fold([0.0; 3], |s, p| {
                [s[0] + p[0] / k, s[1] + p[1] / k, s[2] + p[2] / k]
            });
            let frame =
                Frame::from_normal(Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32).to_normal());
            let (fs, ft) = (frame.s, frame.t);
            let (fs, ft) = (
                [fs.x as f64, fs.y as f64, fs.z as f64],
                [ft.x as f64, ft.y as f64, ft.z as f64],
            );
            let angle = |p: &P| {
                let q = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
                dot(q, ft).atan2(dot(q, fs))
            };
            cut.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
            cut.dedup_by(|a, b| (0..3).all(|i| (a[i] - b[i]).abs() <= tol));
            if cut.len() >= 3 {
                kept.push(cut);
            }
        }
        faces = kept;
        if faces.is_empty() {
            return Err(PolyhedronError::Empty);
        }
    }
    Ok(faces.into_iter().flatten().collect())
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

    /// 2000 half-spaces tangent to the unit sphere (a Fibonacci lattice of normals): the
    /// clipping is O(n²), so this takes milliseconds, and the box is the sphere's.
    #[test]
    fn thousands_of_half_spaces_are_fast() {
        let n = 2000;
        let planes: Vec<(Vec3, f32)> = (0..n)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
                let r = (1.0 - z * z).sqrt();
                let phi = i as f32 * 2.399_963;
                (Vec3::new(r * phi.cos(), r * phi.sin(), z), 1.0)
            })
            .collect();
        let start = std::time::Instant::now();
        let p = Polyhedron::new(Transform::IDENTITY, &planes).unwrap();
        assert!(start.elapsed().as_secs_f64() < 2.0, "{:?}", start.elapsed());
        let b = p.bounds();
        for v in [b.max.x, b.max.y, b.max.z, -b.min.x, -b.min.y, -b.min.z] {
            assert!((1.0..1.01).contains(&v), "{b:?}");
        }
    }

    #[test]
    fn repeated_half_spaces_add_nothing() {
        // The same planes thousands of times: the cube, found as fast as from six planes.
        let mut planes = Vec::new();
        for _ in 0..3000 {
            planes.extend(cube_planes());
        }
        let start = std::time::Instant::now();
        let p = Polyhedron::new(Transform::IDENTITY, &planes).unwrap();
        assert!(start.elapsed().as_secs_f64() < 1.0, "{:?}", start.elapsed());
        let b = p.bounds();
        assert!(
            (b.max.x - 1.0).abs() < 1e-4 && (b.min.z + 1.0).abs() < 1e-4,
            "{b:?}"
        );
    }
}
