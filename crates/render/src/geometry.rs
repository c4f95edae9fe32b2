//! The shapes of a scene behind *primitive ids*, and the one intersection routine per primitive
//! that every acceleration structure calls.
//!
//! Primitive ids list the bounded primitives first (analytic shapes and every mesh triangle
//! individually: the ones the acceleration structures hold), then the unbounded ones (planes,
//! tested one by one). Hits are resolved into [`SurfaceInteraction`]s here too, so that
//! everything above the accelerators sees one surface type.

use crate::interaction::{Hit, SurfaceInteraction, SurfaceProps};
use crate::math::{Bounds3, Ray};
use crate::shape::{Mesh, Shape, ShapeHit, ShearedRay};

/// A shape with its surface properties.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// The shape.
    pub shape: Shape,
    /// Material, emission, light.
    pub props: SurfaceProps,
}

/// What a primitive id stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimRef {
    /// An analytic shape (index into the objects).
    Object(u32),
    /// A mesh triangle.
    Triangle {
        /// The mesh.
        mesh: u32,
        /// The triangle in the mesh.
        tri: u32,
    },
}

/// All shapes of a scene, indexed by primitive id: bounded primitives first (the ones the
/// acceleration structures hold: analytic shapes and individual mesh triangles), then unbounded
/// ones (planes, tested one by one).
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    objects: Vec<Object>,
    meshes: Vec<Mesh>,
    prims: Vec<PrimRef>,
    bounded: u32,
}

impl Geometry {
    /// Gathers objects and meshes; primitive ids list bounded objects, then every mesh
    /// triangle, then unbounded objects.
    pub fn new(objects: Vec<Object>, meshes: Vec<Mesh>) -> Self {
        let (bounded, unbounded): (Vec<u32>, Vec<u32>) =
            (0..objects.len() as u32).partition(|&i| objects[i as usize].shape.bounds().is_some());
        let mut prims: Vec<PrimRef> = bounded.into_iter().map(PrimRef::Object).collect();
        for (m, mesh) in meshes.iter().enumerate() {
            prims.extend((0..mesh.len() as u32).map(|tri| PrimRef::Triangle {
                mesh: m as u32,
                tri,
            }));
        }
        let n = prims.len() as u32;
        prims.extend(unbounded.into_iter().map(PrimRef::Object));
        Self {
            objects,
            meshes,
            prims,
            bounded: n,
        }
    }

    /// Number of bounded primitives (ids `0..bounded_count()`).
    #[inline]
    pub fn bounded_count(&self) -> u32 {
        self.bounded
    }

    /// The index of the shape primitive `prim` belongs to: objects first (in the order given),
    /// then meshes.
    pub fn shape_index(&self, prim: u32) -> u32 {
        match self.prims[prim as usize] {
            PrimRef::Object(i) => i,
            PrimRef::Triangle { mesh, .. } => self.objects.len() as u32 + mesh,
        }
    }

    /// Number of primitives.
    #[inline]
    pub fn prim_count(&self) -> u32 {
        self.prims.len() as u32
    }

    /// The objects.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// The meshes.
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    /// What primitive `prim` is.
    #[inline]
    pub fn prim(&self, prim: u32) -> PrimRef {
        self.prims[prim as usize]
    }

    /// The one intersection routine of primitive `prim`, shared by every accelerator.
    #[inline]
    pub fn intersect_prim(&self, prim: u32, ray: &Ray, sr: &ShearedRay) -> Option<Hit> {
        let h = match self.prims[prim as usize] {
            PrimRef::Object(o) => self.objects[o as usize].shape.intersect(ray),
            PrimRef::Triangle { mesh, tri } => self.meshes[mesh as usize].intersect(tri, ray, sr),
        }?;
        Some(Hit {
            t: h.t,
            prim,
            uv: h.uv,
            sub: h.sub,
            leaf: h.leaf,
        })
    }

    /// Bounds of a bounded primitive.
    pub fn prim_bounds(&self, prim: u32) -> Bounds3 {
        match self.prims[prim as usize] {
            PrimRef::Object(o) => self.objects[o as usize]
                .shape
                .bounds()
                .unwrap_or(Bounds3::EMPTY),
            PrimRef::Triangle { mesh, tri } => self.meshes[mesh as usize].triangle_bounds(tri),
        }
    }

    /// Bounds of all bounded primitives.
    pub fn bounds(&self) -> Bounds3 {
        (0..self.bounded).fold(Bounds3::EMPTY, |b, p| b.union(self.prim_bounds(p)))
    }

    /// The full interaction for a hit found along `ray`.
    #[inline(always)]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let sh = ShapeHit {
            t: hit.t,
            uv: hit.uv,
            sub: hit.sub,
            leaf: hit.leaf,
        };
        let (g, props, frame) = match self.prims[hit.prim as usize] {
            PrimRef::Object(o) => {
                let obj = &self.objects[o as usize];
                match &obj.shape {
                    // Flat shapes with their frames ready.
                    Shape::Parallelogram(p) => {
                        (p.geometry(sh.uv[0], sh.uv[1]), obj.props, Some(p.frame()))
                    }
                    Shape::Cube(c) => (
                        c.geometry(ray, sh.t, sh.sub),
                        obj.props,
                        Some(c.face_frame(sh.sub)),
                    ),
                    shape => (
                        shape.geometry(ray, &sh),
                        shape.hit_props(&sh).unwrap_or(obj.props),
                        None,
                    ),
                }
            }
            PrimRef::Triangle { mesh, tri } => {
                let m = &self.meshes[mesh as usize];
                (m.geometry(tri, hit.uv[0], hit.uv[1]), m.props, None)
            }
        };
        SurfaceInteraction {
            p: g.p,
            n: g.n,
            ns: g.ns,
            uv: g.uv,
            dpdu: g.dpdu,
            wo: -ray.d.normalize(),
            t: hit.t,
            prim: hit.prim,
            props,
            frame,
        }
    }
}
