//! Convex polygons of n ≥ 3 coplanar vertices, intersected as in the course's seed lecture: the
//! ray meets the polygon's plane, the hit point is projected on two axes of that plane, and a
//! 2D edge test (the point is on the inner side of every edge: the 2D cross product of the edge
//! and the vector from its start to the point is not negative) decides.
//!
//! Scene syntax: `polygon(MAT, [p1], [p2], …, [pn])` (candela language, world coordinates). The
//! geometric normal follows the vertex order by the right-hand rule (counter-clockwise seen from
//! the side it points to). uv: the 2D coordinates normalised to the polygon's bounding rectangle
//! in its plane, u along the first edge p1→p2, v across it (towards the polygon).

use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Normal3, Point2, Point3, Ray, Vec3};

/// Why a list of vertices is not a convex polygon.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PolygonError {
    /// Fewer than three vertices.
    TooFewVertices,
    /// A vertex is not finite.
    NotFinite,
    /// The vertices enclose no area (all aligned, or repeated).
    Degenerate,
    /// A vertex is off the plane of the others (its index).
    NotCoplanar(usize),
    /// The polygon is not convex, or its vertices are not in order around it (the vertex at
    /// the first wrong corner).
    NotConvex(usize),
}

impl std::fmt::Display for PolygonError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::TooFewVertices => write!(f, "a polygon needs at least 3 vertices"),
            Self::NotFinite => write!(f, "a vertex is not finite"),
            Self::Degenerate => write!(f, "the polygon is degenerate (its vertices are aligned)"),
            Self::NotCoplanar(i) => write!(f, "vertex {} is not in the plane of the others", i + 1),
            Self::NotConvex(i) => write!(
                f,
                "the polygon is not convex or its vertices are not in order (at vertex {})",
                i + 1
            ),
        }
    }
}

/// A convex polygon in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    /// The first vertex, origin of the 2D coordinates.
    origin: Point3,
    /// The 2D axes in the plane (unit, orthogonal): along the first edge, and `n × e1`.
    e1: Vec3,
    e2: Vec3,
    /// The unit normal.
    n: Normal3,
    /// The vertices in 2D, counter-clockwise.
    pts: Vec<[f32; 2]>,
    /// The 2D bounding rectangle: min corner and size.
    min: [f32; 2],
    size: [f32; 2],
    /// World bounds.
    bounds: Bounds3,
    /// Area.
    area: f32,
}

impl Polygon {
    /// The polygon through `vertices` (in order, counter-clockwise around the normal).
    pub fn new(vertices: &[Point3]) -> Result<Self, PolygonError> {
        if vertices.len() < 3 {
            return Err(PolygonError::TooFewVertices);
        }
        if vertices.iter().any(|p| !p.is_finite()) {
            return Err(PolygonError::NotFinite);
        }
        // Newell's normal: robust for any planar polygon, its length is twice the area.
        let mut nw = Vec3::new(0.0, 0.0, 0.0);
        let o = vertices[0];
        for i in 0..vertices.len() {
            let a = vertices[i] - o;
            let b = vertices[(i + 1) % vertices.len()] - o;
            nw += a.cross(b);
        }
        let area = 0.5 * nw.norm();
        let extent = vertices
            .iter()
            .map(|p| (*p - o).norm())
            .fold(0.0f32, f32::max);
        if !(area > 1e-6 * extent * extent && area.is_finite()) {
            return Err(PolygonError::Degenerate);
        }
        // The plane: through the first vertex, spanned by the first edge and the first vertex
        // off its line (so that the first vertex off that plane is the one reported), facing
        // the side of Newell's normal.
        let d1 = vertices[1] - o;
        let n = vertices[2..]
            .iter()
            .map(|p| d1.cross(*p - o))
            .find(|c| c.norm() > 1e-6 * extent * extent)
            .ok_or(PolygonError::Degenerate)?;
        let n = if n.dot(nw) < 0.0 { -n } else { n }.normalize();
        for (i, p) in vertices.iter().enumerate() {
            if (*p - o).dot(n).abs() > 1e-4 * extent.max(1e-30) {
                return Err(PolygonError::NotCoplanar(i));
            }
        }
        // The first edge of non-zero length gives the first axis.
        let e1 = vertices
            .iter()
            .skip(1)
            .map(|p| *p - o)
            .find(|d| d.norm() > 1e-6 * extent)
            .ok_or(PolygonError::Degenerate)?;
        let e1 = (e1 - n * e1.dot(n)).normalize();
        let e2 = n.cross(e1);
        let pts: Vec<[f32; 2]> = vertices
            .iter()
            .map(|p| {
                let d = *p - o;
                [d.dot(e1), d.dot(e2)]
            })
            .collect();
        // Convexity: every corner turns left (collinear corners allowed).
        let k = pts.len();
        for i in 0..k {
            let (a, b, c) = (pts[i], pts[(i + 1) % k], pts[(i + 2) % k]);
            let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
            if cross < -1e-5 * extent * extent {
                return Err(PolygonError::NotConvex((i + 1) % k));
            }
        }
        // A convex polygon turns once: the angles must add up to one turn (no star shapes).
        let mut turn = 0.0f64;
        for i in 0..k {
            let (a, b, c) = (pts[i], pts[(i + 1) % k], pts[(i + 2) % k]);
            let (ux, uy) = ((b[0] - a[0]) as f64, (b[1] - a[1]) as f64);
            let (vx, vy) = ((c[0] - b[0]) as f64, (c[1] - b[1]) as f64);
            if ux * ux + uy * uy > 0.0 && vx * vx + vy * vy > 0.0 {
                turn += (ux * vy - uy * vx).atan2(ux * vx + uy * vy);
            }
        }
        if (turn - std::f64::consts::TAU).abs() > 1e-3 {
            return Err(PolygonError::NotConvex(0));
        }
        let mut min = [f32::INFINITY; 2];
        let mut max = [f32::NEG_INFINITY; 2];
        for p in &pts {
            for a in 0..2 {
                min[a] = min[a].min(p[a]);
                max[a] = max[a].max(p[a]);
            }
        }
        let mut bounds = Bounds3::EMPTY;
        for p in vertices {
            bounds = bounds.union_point(*p);
        }
        Ok(Self {
            origin: o,
            e1,
            e2,
            n: n.to_normal(),
            pts,
            min,
            size: [max[0] - min[0], max[1] - min[1]],
            bounds,
            area,
        })
    }

    /// The lecture's test in the plane's 2D coordinates: `(x, y)` is inside (or on the border)
    /// when it is on the inner side of every edge.
    #[inline]
    pub fn contains_2d(&self, x: f32, y: f32) -> bool {
        let k = self.pts.len();
        (0..k).all(|i| {
            let a = self.pts[i];
            let b = self.pts[(i + 1) % k];
            (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) >= 0.0
        })
    }

    /// The crossing with the ray in its interval; `uv` of the hit holds the 2D coordinates.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let n = self.n.to_vec();
        let denom = n.dot(ray.d);
        if denom == 0.0 {
            return None;
        }
        let t = n.dot(self.origin - ray.o) / denom;
        if !(t > ray.tmin && t < ray.tmax) {
            return None;
        }
        let q = ray.at(t) - self.origin;
        let (x, y) = (q.dot(self.e1), q.dot(self.e2));
        self.contains_2d(x, y).then_some(ShapeHit {
            t,
            uv: [x, y],
            sub: 0,
            leaf: 0,
        })
    }

    /// The surface at the 2D coordinates `(x, y)` of a hit.
    pub fn geometry(&self, x: f32, y: f32) -> LocalGeometry {
        let p = self.origin + self.e1 * x + self.e2 * y;
        let uv = |c: f32, a: usize| {
            if self.size[a] > 0.0 {
                ((c - self.min[a]) / self.size[a]).clamp(0.0, super::ONE_MINUS_EPS)
            } else {
                0.0
            }
        };
        LocalGeometry {
            p,
            n: self.n,
            ns: self.n,
            uv: Point2::new(uv(x, 0), uv(y, 1)),
            dpdu: self.e1 * self.size[0],
        }
    }

    /// World-space bounds.
    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }

    /// The area.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// The unit normal.
    pub fn normal(&self) -> Normal3 {
        self.n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f32, y: f32, z: f32) -> Point3 {
        Point3::new(x, y, z)
    }

    /// A regular hexagon of circumradius 1 in the plane z = 2, counter-clockwise seen from +z.
    fn hexagon() -> Polygon {
        let v: Vec<Point3> = (0..6)
            .map(|i| {
                let a = i as f32 * std::f32::consts::PI / 3.0;
                p(a.cos(), a.sin(), 2.0)
            })
            .collect();
        Polygon::new(&v).unwrap()
    }

    #[test]
    fn rays_hit_inside_and_miss_outside_with_normal_and_uv() {
        let h = hexagon();
        assert!((h.area() - 1.5 * 3f32.sqrt()).abs() < 1e-5);
        assert_eq!(h.normal(), Normal3::new(0.0, 0.0, 1.0));
        let down = |x: f32, y: f32| Ray::new(p(x, y, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = h.intersect(&down(0.0, 0.0)).unwrap();
        assert!((hit.t - 3.0).abs() < 1e-6);
        let g = h.geometry(hit.uv[0], hit.uv[1]);
        assert!((g.p - p(0.0, 0.0, 2.0)).norm() < 1e-6);
        // The bounding rectangle along the first edge (1,0)→(½,√3/2): the centre is at (½, ½).
        assert!(
            (g.uv.x - 0.5).abs() < 1e-5 && (g.uv.y - 0.5).abs() < 1e-5,
            "{:?}",
            g.uv
        );
        // Inside near a vertex, outside past an edge (the edge midpoints are at √3/2 ≈ 0.866).
        assert!(h.intersect(&down(0.95, 0.0)).is_some());
        assert!(h.intersect(&down(0.0, 0.85)).is_some());
        assert!(h.intersect(&down(0.0, 0.88)).is_none());
        assert!(h.intersect(&down(0.8, 0.5)).is_none());
        // Parallel rays miss.
        assert!(h
            .intersect(&Ray::new(p(0.0, 0.0, 2.0), Vec3::new(1.0, 0.0, 0.0)))
            .is_none());
        let b = h.bounds();
        assert!((b.min.z - 2.0).abs() < 1e-6 && (b.max.x - 1.0).abs() < 1e-6);
    }

    #[test]
    fn the_vertex_order_gives_the_normal() {
        let v = [
            p(0.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(1.0, 0.0, 0.0),
        ];
        let poly = Polygon::new(&v).unwrap();
        assert_eq!(poly.normal(), Normal3::new(0.0, 0.0, -1.0));
        let r = Ray::new(p(0.5, 0.5, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(poly.intersect(&r).is_some());
    }

    #[test]
    fn bad_polygons_are_rejected() {
        assert_eq!(
            Polygon::new(&[p(0., 0., 0.), p(1., 0., 0.)]),
            Err(PolygonError::TooFewVertices)
        );
        assert_eq!(
            Polygon::new(&[p(0., 0., 0.), p(1., 0., 0.), p(2., 0., 0.)]),
            Err(PolygonError::Degenerate)
        );
        assert_eq!(
            Polygon::new(&[p(0., 0., 0.), p(1., 0., 0.), p(1., 1., 0.), p(0., 1., 0.5)]),
            Err(PolygonError::NotCoplanar(3))
        );
        // A dart (concave) and a bow tie (vertices out of order).
        assert!(matches!(
            Polygon::new(&[p(0., 0., 0.), p(2., 0., 0.), p(1., 0.5, 0.), p(1., 2., 0.)]),
            Err(PolygonError::NotConvex(_))
        ));
        assert!(matches!(
            Polygon::new(&[p(0., 0., 0.), p(1., 1., 0.), p(1., 0., 0.), p(0., 1., 0.)]),
            Err(PolygonError::NotConvex(_)) | Err(PolygonError::Degenerate)
        ));
        assert_eq!(
            Polygon::new(&[p(0., 0., 0.), p(1., 0., 0.), p(f32::NAN, 1., 0.)]),
            Err(PolygonError::NotFinite)
        );
    }
}
