//! Surfaces: maps from a parameter domain (s, t) to a shape's world-space surface, what a
//! surface comes from, and how its texture coordinates follow from (s, t).

use crate::interaction::SurfaceProps;
use crate::math::{Point2, Point3, Transform, Vec3, PI};
use crate::shape::{Cube, Sphere};

/// How a surface maps its parameters (s, t) to the world.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum SurfaceMap {
    /// `p + s·v + t·w`.
    Parallelogram {
        p: Point3,
        v: Vec3,
        w: Vec3,
        n: Vec3,
    },
    /// Face `face` of a box: (s, t) ↦ the face point (2s − 1, 2t − 1).
    CubeFace { t: Transform, face: u32, n: Vec3 },
    /// The sphere at longitude 2πs and colatitude πt (the sphere's uv).
    Sphere { sphere: Sphere },
    /// The disk at radius s and angle 2πt.
    Disk { t: Transform, n: Vec3 },
    /// The plane's square of half side `half` around (cx, cy) (object coordinates), with cells
    /// growing away from the centre: x = cx + half·sinh(a(2s − 1))/sinh(a).
    Plane {
        t: Transform,
        cx: f32,
        cy: f32,
        half: f32,
        a: f32,
        n: Vec3,
    },
    /// A triangle by barycentrics (β, γ): `a + β(b − a) + γ(c − a)`.
    Triangle {
        a: Point3,
        b: Point3,
        c: Point3,
        n: Vec3,
    },
}

impl SurfaceMap {
    /// True for triangle domains (barycentric parameters).
    #[inline]
    pub fn is_triangle(&self) -> bool {
        matches!(self, SurfaceMap::Triangle { .. })
    }

    /// The world point at (s, t).
    pub fn point(&self, s: f32, t: f32) -> Point3 {
        match self {
            SurfaceMap::Parallelogram { p, v, w, .. } => *p + *v * s + *w * t,
            SurfaceMap::CubeFace { t: tr, face, .. } => {
                tr.point(Cube::face_point(*face, 2.0 * s - 1.0, 2.0 * t - 1.0))
            }
            SurfaceMap::Sphere { sphere } => sphere.geometry_at(sphere_dir(s, t)).p,
            SurfaceMap::Disk { t: tr, .. } => {
                let phi = 2.0 * PI * t;
                tr.point(Point3::new(s * phi.cos(), s * phi.sin(), 0.0))
            }
            SurfaceMap::Plane {
                t: tr,
                cx,
                cy,
                half,
                a,
                ..
            } => tr.point(Point3::new(
                cx + half * stretch(*a, 2.0 * s - 1.0),
                cy + half * stretch(*a, 2.0 * t - 1.0),
                0.0,
            )),
            SurfaceMap::Triangle { a, b, c, .. } => *a + (*b - *a) * s + (*c - *a) * t,
        }
    }

    /// The unit front normal at (s, t).
    pub fn normal(&self, s: f32, t: f32) -> Vec3 {
        match self {
            SurfaceMap::Parallelogram { n, .. }
            | SurfaceMap::CubeFace { n, .. }
            | SurfaceMap::Disk { n, .. }
            | SurfaceMap::Plane { n, .. }
            | SurfaceMap::Triangle { n, .. } => *n,
            SurfaceMap::Sphere { sphere } => sphere.geometry_at(sphere_dir(s, t)).n.to_vec(),
        }
    }
}

/// sinh(a·u)/sinh(a) for u ∈ [−1, 1] (u itself when a is small).
#[inline]
fn stretch(a: f32, u: f32) -> f32 {
    if a < 1e-3 {
        u
    } else {
        (a * u).sinh() / a.sinh()
    }
}

/// The inverse of [`stretch`].
#[inline]
pub(super) fn unstretch(a: f32, x: f32) -> f32 {
    if a < 1e-3 {
        x
    } else {
        (x * a.sinh()).asinh() / a
    }
}

/// The a > 0 with a / sinh(a) = c for c ∈ (0, 1) (0 when c ≥ 1).
pub(super) fn stretch_for(c: f32) -> f32 {
    if !(c < 1.0) {
        return 0.0;
    }
    let c = c.max(1e-6);
    let (mut lo, mut hi) = (0f32, 20f32);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if mid / mid.sinh() > c {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The unit-sphere direction of the sphere's uv (s, t).
#[inline]
fn sphere_dir(s: f32, t: f32) -> Vec3 {
    let (phi, theta) = (2.0 * PI * s, PI * t);
    let st = theta.sin();
    Vec3::new(st * phi.cos(), st * phi.sin(), theta.cos())
}

/// What a surface comes from, for locating hits on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SurfaceKind {
    /// A parallelogram (hit uv = (s, t)).
    Parallelogram,
    /// A box face (interaction uv = (s, t), face = hit sub).
    CubeFace,
    /// A sphere (interaction uv = (s, t)).
    Sphere,
    /// A disk (hit uv = local (x, y)).
    Disk,
    /// A plane (from the world point).
    Plane,
    /// A mesh triangle (hit uv = barycentrics).
    MeshTriangle,
    /// A fan triangle of a polyhedron face (face = hit sub; from the world point).
    PolyFan,
}

/// How the texture coordinates of a surface follow from (s, t).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum TexMap {
    /// uv = (s, t).
    Same,
    /// Interpolated vertex uvs of a triangle.
    Bary([Point2; 3]),
    /// The course's plane coordinates (fractional parts) of a world point in an object frame.
    PlaneFrac { t: Transform, s: Vec3, tt: Vec3 },
}

/// A surface of the scene and its root elements.
#[derive(Clone, Debug)]
pub(crate) struct Surface {
    /// How (s, t) maps to the world.
    pub map: SurfaceMap,
    /// What it comes from.
    pub kind: SurfaceKind,
    /// How its texture coordinates follow from (s, t).
    pub tex: TexMap,
    /// The scene primitive.
    pub prim: u32,
    /// Sub-index within the primitive (box face, polyhedron plane).
    pub face: u32,
    /// Material, emission, light.
    pub props: SurfaceProps,
    /// First root element and the root grid (triangles: 1 × 1).
    pub first_root: u32,
    /// Root elements along s.
    pub nu: u32,
    /// Root elements along t.
    pub nv: u32,
    /// Whether each side (front, back) gets patches.
    pub active: [bool; 2],
    /// Object index when the surface bounds a closed solid (sphere, box, polyhedron).
    pub solid: Option<u32>,
}

/// What a new surface is, before its root elements exist.
pub(super) struct SurfaceSpec {
    /// Its parameter map.
    pub map: SurfaceMap,
    /// What it comes from.
    pub kind: SurfaceKind,
    /// Its texture coordinates.
    pub tex: TexMap,
    /// The scene primitive.
    pub prim: u32,
    /// The primitive's face (box face, polyhedron plane; 0 otherwise).
    pub face: u32,
    /// Material, emission, light.
    pub props: SurfaceProps,
    /// The closed solid it bounds, if any.
    pub solid: Option<u32>,
}

impl SurfaceSpec {
    /// The surface, its `nu × nv` root elements starting at `first_root`.
    pub(super) fn surface(self, first_root: u32, nu: u32, nv: u32) -> Surface {
        Surface {
            map: self.map,
            kind: self.kind,
            tex: self.tex,
            prim: self.prim,
            face: self.face,
            props: self.props,
            first_root,
            nu,
            nv,
            active: [false; 2],
            solid: self.solid,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_cells_grow_away_from_the_centre_and_invert() {
        for c in [0.05f32, 0.3, 0.9] {
            let a = stretch_for(c);
            assert!((a / a.sinh() - c).abs() < 1e-4, "{c}: {a}");
            for u in [-1.0f32, -0.3, 0.0, 0.7, 1.0] {
                assert!((unstretch(a, stretch(a, u)) - u).abs() < 1e-4);
            }
        }
        assert_eq!(stretch_for(1.5), 0.0);
        assert_eq!(stretch(0.0, 0.25), 0.25);
    }
}
