//! The cube [-1, 1]³ placed by a transformation (`box(MAT, T)`, Mitsuba `cube`).
//!
//! Intersected by slabs in the cube's frame. The hit face decides the normal (±x, ±y, ±z in
//! the cube's frame, then by the inverse transpose) and the uv: the face's two other
//! coordinates mapped from [-1, 1] to [0, 1] (x-faces: (y, z); y-faces: (x, z); z-faces: (x, y)).

use super::{LocalGeometry, ShapeHit};
use crate::math::{Bounds3, Frame, Matrix4, Normal3, Point2, Point3, Ray, Transform, Vec3};

/// The cube [-1,1]³ placed by `world_from_object`.
#[derive(Clone, Debug, PartialEq)]
pub struct Cube {
    /// Object → world.
    pub world_from_object: Transform,
    /// The matrix and its inverse both have the last row (0, 0, 0, 1): points then move
    /// between the frames without the homogeneous division, with the same results.
    affine: bool,
    /// What the surface of a hit needs, computed once by [`Cube::new`] (kept apart so that
    /// the shape stays small).
    faces: Box<Faces>,
}

/// The per-face quantities of a placed cube.
#[derive(Clone, Debug, PartialEq)]
struct Faces {
    /// Unit world normal of each face (`2·axis + side`).
    normals: [Normal3; 6],
    /// ∂p/∂u of the faces of each axis.
    dpdu: [Vec3; 3],
    /// The shading frame of each face: [`Frame::from_normal_tangent`] of its normal and ∂p/∂u.
    frames: [Frame; 6],
}

/// Applies the top three rows of a matrix to a point: the same operations as
/// [`Transform::point`] when the last row is (0, 0, 0, 1) (for finite points, w is exactly 1).
#[inline(always)]
fn affine_point(m: &Matrix4, p: Point3) -> Point3 {
    let m = &m.m;
    Point3::new(
        m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
        m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
        m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3],
    )
}

/// A crossing of a ray with a convex solid: the parameter and the face crossed.
pub type Crossing = (f32, u32);

impl Cube {
    /// A cube placed by `t`.
    pub fn new(world_from_object: Transform) -> Self {
        let w = &world_from_object;
        let normals = std::array::from_fn(|face| {
            let sign = if face % 2 == 1 { 1.0 } else { -1.0 };
            let mut n = [0.0; 3];
            n[face / 2] = sign;
            w.normal(Normal3::new(n[0], n[1], n[2])).normalize()
        });
        let dpdu = [Vec3::Y, Vec3::X, Vec3::X].map(|t| w.vector(t * 2.0));
        let frames =
            std::array::from_fn(|face| Frame::from_normal_tangent(normals[face], dpdu[face / 2]));
        let last = [0.0, 0.0, 0.0, 1.0];
        let affine = w.m.m[3] == last && w.inv.m[3] == last;
        Self {
            world_from_object,
            affine,
            faces: Box::new(Faces {
                normals,
                dpdu,
                frames,
            }),
        }
    }

    /// The ray's origin in the cube's frame.
    #[inline(always)]
    fn local_origin(&self, o: Point3) -> Point3 {
        if self.affine {
            affine_point(&self.world_from_object.inv, o)
        } else {
            self.world_from_object.inv_point(o)
        }
    }

    /// True when the placement and its inverse are affine (last row 0, 0, 0, 1).
    pub fn is_affine(&self) -> bool {
        self.affine
    }

    /// Where the ray's line enters and leaves the cube (parameters and faces), or `None`.
    /// Face ids are `2·axis + (1 if the + side)`.
    #[inline]
    pub fn crossings(&self, ray: &Ray) -> Option<(Crossing, Crossing)> {
        let o = self.local_origin(ray.o);
        let d = self.world_from_object.inv_vector(ray.d);
        let mut near = (f32::NEG_INFINITY, 0u32);
        let mut far = (f32::INFINITY, 0u32);
        for axis in 0..3 {
            let (oa, da) = (o[axis], d[axis]);
            if da == 0.0 {
                if !(-1.0..=1.0).contains(&oa) {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / da;
            let (t_minus, t_plus) = ((-1.0 - oa) * inv, (1.0 - oa) * inv);
            let a = axis as u32 * 2;
            let (tn, tf) = if t_minus < t_plus {
                ((t_minus, a), (t_plus, a + 1))
            } else {
                ((t_plus, a + 1), (t_minus, a))
            };
            if tn.0 > near.0 {
                near = tn;
            }
            if tf.0 < far.0 {
                far = tf;
            }
        }
        (near.0 <= far.0).then_some((near, far))
    }

    /// The closest crossing inside the ray's interval.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ShapeHit> {
        let (near, far) = self.crossings(ray)?;
        let (t, face) = if near.0 > ray.tmin { near } else { far };
        (t > ray.tmin && t < ray.tmax).then_some(ShapeHit {
            t,
            uv: [0.0; 2],
            sub: face,
            leaf: 0,
        })
    }

    /// The surface where the ray crosses `face` at `t` (inlined: returned from a call, the
    /// surface went through memory in other pieces than the caller read back).
    #[inline(always)]
    pub fn geometry(&self, ray: &Ray, t: f32, face: u32) -> LocalGeometry {
        let q = self.local_origin(ray.o) + self.world_from_object.inv_vector(ray.d) * t;
        self.surface(face, q)
    }

    /// The surface of `face` at the object-space point `q` (snapped onto the face).
    #[inline(always)]
    pub fn surface(&self, face: u32, q: Point3) -> LocalGeometry {
        let axis = (face / 2) as usize;
        let sign = if face % 2 == 1 { 1.0 } else { -1.0 };
        // Snap onto the face and keep the other coordinates on the cube.
        let clamp = |x: f32| x.clamp(-1.0, 1.0);
        let mut q = Point3::new(clamp(q.x), clamp(q.y), clamp(q.z));
        match axis {
            0 => q.x = sign,
            1 => q.y = sign,
            _ => q.z = sign,
        }
        let (a, b) = match axis {
            0 => (q.y, q.z),
            1 => (q.x, q.z),
            _ => (q.x, q.y),
        };
        let nw = self.faces.normals[face as usize];
        let p = if self.affine {
            affine_point(&self.world_from_object.m, q)
        } else {
            self.world_from_object.point(q)
        };
        LocalGeometry {
            p,
            n: nw,
            ns: nw,
            uv: Point2::new((a + 1.0) * 0.5, (b + 1.0) * 0.5),
            dpdu: self.faces.dpdu[axis],
        }
    }

    /// The shading frame of `face` (the same at every point of the face), as
    /// [`Frame::from_normal_tangent`] computes it from the face's [`LocalGeometry`].
    #[inline]
    pub fn face_frame(&self, face: u32) -> Frame {
        self.faces.frames[face as usize]
    }

    /// The world-space area of each face (faces `2·axis + side`).
    pub fn face_areas(&self) -> [f32; 6] {
        let w = &self.world_from_object;
        let (ex, ey, ez) = (
            w.vector(Vec3::X * 2.0),
            w.vector(Vec3::Y * 2.0),
            w.vector(Vec3::Z * 2.0),
        );
        let (ax, ay, az) = (
            ey.cross(ez).norm(),
            ex.cross(ez).norm(),
            ex.cross(ey).norm(),
        );
        [ax, ax, ay, ay, az, az]
    }

    /// The object-space point of `face` at face coordinates (a, b) ∈ [-1, 1]².
    pub fn face_point(face: u32, a: f32, b: f32) -> Point3 {
        let s = if face % 2 == 1 { 1.0 } else { -1.0 };
        match face / 2 {
            0 => Point3::new(s, a, b),
            1 => Point3::new(a, s, b),
            _ => Point3::new(a, b, s),
        }
    }

    /// Bounds of the transformed corners.
    pub fn bounds(&self) -> Bounds3 {
        Bounds3::new(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0))
            .transform(&self.world_from_object)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_by_hand() {
        let c = Cube::new(Transform::IDENTITY);
        let r = Ray::new(Point3::new(-3.0, 0.5, 0.0), Vec3::X);
        let h = c.intersect(&r).unwrap();
        assert_eq!((h.t, h.sub), (2.0, 0));
        let g = c.geometry(&r, h.t, h.sub);
        assert_eq!(g.p, Point3::new(-1.0, 0.5, 0.0));
        assert_eq!(g.n, Normal3::new(-1.0, 0.0, 0.0));
        assert_eq!((g.uv.x, g.uv.y), (0.75, 0.5));
        // From inside: the exit face, with its outward normal.
        let r = Ray::new(Point3::ORIGIN, Vec3::new(0.0, 0.0, 1.0));
        let h = c.intersect(&r).unwrap();
        assert_eq!((h.t, h.sub), (1.0, 5));
        assert_eq!(c.geometry(&r, h.t, h.sub).n, Normal3::new(0.0, 0.0, 1.0));
        // Parallel to faces: inside the slab, and outside it.
        assert!(c
            .intersect(&Ray::new(Point3::new(-3.0, 2.0, 0.0), Vec3::X))
            .is_none());
        assert!(c
            .intersect(&Ray::new(Point3::new(-3.0, 1.0, 0.0), Vec3::X))
            .is_some());
        // Along an edge and through a vertex.
        assert!(c
            .intersect(&Ray::new(Point3::new(-3.0, 1.0, 1.0), Vec3::X))
            .is_some());
        let diag = Ray::new(Point3::new(-2.0, -2.0, -2.0), Vec3::new(1.0, 1.0, 1.0));
        assert_eq!(c.intersect(&diag).unwrap().t, 1.0);
        // Pointing away.
        assert!(c
            .intersect(&Ray::new(Point3::new(-3.0, 0.0, 0.0), -Vec3::X))
            .is_none());
    }

    #[test]
    fn transformed_cube_by_hand() {
        let c = Cube::new(
            Transform::translation(Vec3::new(0.0, 0.0, 5.0))
                * Transform::scaling(Vec3::new(1.0, 1.0, 2.0)),
        );
        let r = Ray::new(Point3::ORIGIN, Vec3::Z);
        let h = c.intersect(&r).unwrap();
        assert_eq!((h.t, h.sub), (3.0, 4));
        let g = c.geometry(&r, h.t, h.sub);
        assert_eq!(g.n, Normal3::new(0.0, 0.0, -1.0));
        assert_eq!(g.p, Point3::new(0.0, 0.0, 3.0));
        assert_eq!(
            c.bounds(),
            Bounds3::new(Point3::new(-1.0, -1.0, 3.0), Point3::new(1.0, 1.0, 7.0))
        );
    }
}
