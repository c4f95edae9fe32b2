//! What an integrator knows about the point where a ray hit the scene.

use crate::material::MaterialId;
use crate::math::{Frame, Normal3, Point2, Point3, Ray, Vec3};

/// Per-surface data shared by all primitives of one object or mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SurfaceProps {
    /// The material.
    pub material: MaterialId,
    /// The emission, as an index into the scene's emission table.
    pub emission: Option<u32>,
    /// The area light that samples this surface, if any (index into the scene's lights).
    pub light: Option<u32>,
}

impl SurfaceProps {
    /// A non-emitting surface.
    pub fn new(material: MaterialId) -> Self {
        Self {
            material,
            emission: None,
            light: None,
        }
    }
}

/// The preliminary hit of a ray with the scene: enough to compute the interaction later.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter.
    pub t: f32,
    /// The primitive hit (scene-wide id; ties in `t` go to the smaller id).
    pub prim: u32,
    /// Primitive-specific surface parameters.
    pub uv: [f32; 2],
    /// Primitive-specific index.
    pub sub: u32,
    /// For CSG: the leaf hit. In an instance (`prim` is then the instance's id): the
    /// primitive hit in the shared geometry of its group (groups hold no CSG).
    pub leaf: u32,
}

impl Hit {
    /// True when `self` is closer than `other` (ties broken by primitive id).
    #[inline]
    pub fn closer_than(&self, other: &Hit) -> bool {
        self.t < other.t || (self.t == other.t && self.prim < other.prim)
    }
}

/// The full description of a surface point hit by a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceInteraction {
    /// The point.
    pub p: Point3,
    /// Unit geometric normal as the shape orients it (not flipped towards the ray).
    pub n: Normal3,
    /// Unit shading normal, on the side of `n`.
    pub ns: Normal3,
    /// Surface coordinates.
    pub uv: Point2,
    /// ∂p/∂u (may be zero).
    pub dpdu: Vec3,
    /// Unit direction towards where the ray came from (−d/|d|).
    pub wo: Vec3,
    /// The ray parameter (the distance when the ray direction is unit).
    pub t: f32,
    /// The primitive hit.
    pub prim: u32,
    /// Material, emission and light of the surface.
    pub props: SurfaceProps,
    /// The shading frame when the shape has it ready (flat shapes keep one per face); `None`:
    /// computed from `ns` and `dpdu` on demand. Equal to what [`Frame::from_normal_tangent`]
    /// gives for them.
    pub frame: Option<Frame>,
}

impl SurfaceInteraction {
    /// True when the ray arrived on the side the geometric normal points to.
    #[inline]
    pub fn front_face(&self) -> bool {
        self.n.dot_vec(self.wo) > 0.0
    }

    /// The geometric normal flipped to face the incoming ray (the course's convention).
    #[inline]
    pub fn facing_normal(&self) -> Normal3 {
        self.n.face_forward(self.wo)
    }

    /// The shading normal flipped to the side the ray came from.
    #[inline]
    pub fn facing_shading_normal(&self) -> Normal3 {
        if self.front_face() {
            self.ns
        } else {
            -self.ns
        }
    }

    /// The shading frame around the shading normal as the shape orients it.
    #[inline]
    pub fn shading_frame(&self) -> Frame {
        match self.frame {
            Some(f) => f,
            None => Frame::from_normal_tangent(self.ns, self.dpdu),
        }
    }

    /// A ray leaving this point in direction `d`, offset against self-intersection.
    #[inline]
    pub fn spawn_ray(&self, d: Vec3) -> Ray {
        // `n` is a unit normal.
        Ray::spawn_unit(self.p, self.n, d)
    }

    /// A shadow ray from this point to `target`, stopping short of it.
    #[inline]
    pub fn spawn_ray_to(&self, target: Point3) -> Ray {
        Ray::spawn_to(self.p, self.n, target)
    }
}
