//! Shapes: ray intersection, surface geometry and bounds.
//!
//! Intersection has two stages (as in Mitsuba): `intersect` finds the parameter `t` of the
//! closest crossing and the little it needs to finish later ([`ShapeHit`]); only for the
//! closest hit of a ray is `geometry` called, which computes the point, normals, uv and
//! tangent. Shapes report their *outward* geometric normal; integrators orient it.
//!
//! Triangles are not in [`Shape`]: they live in [`Mesh`]es, one array per attribute, and the
//! scene indexes them individually.

mod csg;
mod cube;
mod cylinder;
mod disk;
mod mesh;
mod parallelogram;
mod plane;
mod polygon;
mod polyhedron;
mod sphere;

pub use csg::{Csg, CsgError, CsgNode, CsgOp, Solid, MAX_EXPANDED_LEAVES};
pub use cube::Cube;
pub use cylinder::Cylinder;
pub use disk::Disk;
pub use mesh::{
    intersect_triangle, Face, Mesh, ShearedRay, FACE_TRIANGLES, MAX_PARALLELOGRAM_TRIANGLES,
};
pub use parallelogram::Parallelogram;
pub use plane::Plane;
pub use polygon::{Polygon, PolygonError};
pub use polyhedron::{Polyhedron, PolyhedronError};
pub use sphere::Sphere;

use crate::interaction::SurfaceProps;
use crate::math::{Bounds3, Normal3, Point2, Point3, Ray, Vec3};

/// The largest f32 below 1 (keeps uv in `[0, 1)`).
pub(crate) const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// The preliminary result of a ray–shape intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeHit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Shape-specific surface parameters (e.g. barycentrics) kept for the geometry stage.
    pub uv: [f32; 2],
    /// Shape-specific index (the face of a box, the plane of a polyhedron, a triangle).
    pub sub: u32,
    /// For CSG: the leaf hit (and whether its normal is flipped).
    pub leaf: u32,
}

/// The surface at a hit point, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalGeometry {
    /// The point.
    pub p: Point3,
    /// Unit geometric normal, pointing out of the shape (or along its orientation).
    pub n: Normal3,
    /// Unit shading normal (interpolated for meshes), on the same side as `n`.
    pub ns: Normal3,
    /// Surface coordinates.
    pub uv: Point2,
    /// ∂p/∂u (not normalised; may be zero when undefined).
    pub dpdu: Vec3,
}

/// The closed set of shape types (besides mesh triangles).
// An explicit tag: a match reads one byte, where the niche in a field cost six instructions
// at every interaction.
#[derive(Clone, Debug, PartialEq)]
#[repr(u8)]
pub enum Shape {
    /// The unit sphere, transformed.
    Sphere(Sphere),
    /// The plane z = 0, transformed (unbounded).
    Plane(Plane),
    /// The cube [-1,1]³, transformed.
    Cube(Cube),
    /// A parallelogram.
    Parallelogram(Parallelogram),
    /// A convex polyhedron.
    Polyhedron(Polyhedron),
    /// A convex polygon.
    Polygon(Polygon),
    /// The unit disk, transformed.
    Disk(Disk),
    /// The open unit cylinder (radius 1, z from 0 to 1), transformed.
    Cylinder(Cylinder),
    /// A CSG tree.
    Csg(Box<Csg>),
}

impl Shape {
    /// The closest crossing of `ray` inside `(ray.tmin, ray.tmax)`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        match self {
            Shape::Sphere(s) => s.intersect(ray),
            Shape::Plane(p) => p.intersect(ray),
            Shape::Cube(c) => c.intersect(ray),
            Shape::Parallelogram(p) => p.intersect(ray),
            Shape::Polyhedron(p) => p.intersect(ray),
            Shape::Polygon(p) => p.intersect(ray),
            Shape::Disk(d) => d.intersect(ray),
            Shape::Cylinder(c) => c.intersect(ray),
            Shape::Csg(c) => c.intersect(ray),
        }
    }

    /// The surface at a hit returned by [`Shape::intersect`] for the same ray.
    pub fn geometry(&self, ray: &Ray, hit: &ShapeHit) -> LocalGeometry {
        match self {
            Shape::Sphere(s) => s.geometry(ray, hit.t),
            Shape::Plane(p) => p.geometry(ray, hit.t),
            Shape::Cube(c) => c.geometry(ray, hit.t, hit.sub),
            Shape::Parallelogram(p) => p.geometry(hit.uv[0], hit.uv[1]),
            Shape::Polyhedron(p) => p.geometry(ray, hit.t, hit.sub),
            Shape::Polygon(p) => p.geometry(hit.uv[0], hit.uv[1]),
            Shape::Disk(d) => d.geometry(hit.uv[0], hit.uv[1]),
            Shape::Cylinder(c) => c.geometry(ray, hit.t),
            Shape::Csg(c) => c.geometry(ray, hit),
        }
    }

    /// The surface properties of a hit when they differ from the object's (CSG leaves).
    pub fn hit_props(&self, hit: &ShapeHit) -> Option<SurfaceProps> {
        match self {
            Shape::Csg(c) => Some(c.props(hit)),
            _ => None,
        }
    }

    /// World-space bounds, or `None` for an unbounded shape.
    pub fn bounds(&self) -> Option<Bounds3> {
        match self {
            Shape::Sphere(s) => Some(s.bounds()),
            Shape::Plane(_) => None,
            Shape::Cube(c) => Some(c.bounds()),
            Shape::Parallelogram(p) => Some(p.bounds()),
            Shape::Polyhedron(p) => Some(p.bounds()),
            Shape::Polygon(p) => Some(p.bounds()),
            Shape::Disk(d) => Some(d.bounds()),
            Shape::Cylinder(c) => Some(c.bounds()),
            Shape::Csg(c) => Some(c.bounds()),
        }
    }
}
