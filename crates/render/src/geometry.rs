//! The shapes of a scene behind *primitive ids*, and the one intersection routine per primitive
//! that every acceleration structure calls.
//!
//! Primitive ids list the bounded primitives first (analytic shapes and every mesh triangle
//! individually: the ones the acceleration structures hold), then the unbounded ones (planes,
//! tested one by one), then the [`Instance`]s: placements of a shared group of shapes (a
//! `Geometry` of its own, behind an [`Arc`], in the group's space). The groups' own
//! acceleration structures and the top level over the instances are built above this layer
//! (`crate::instance`); hits in instances are resolved here like any other. Hits are resolved
//! into [`SurfaceInteraction`]s here too, so that everything above the accelerators sees one
//! surface type.

use std::sync::Arc;

use crate::interaction::{Hit, SurfaceInteraction, SurfaceProps};
use crate::math::{Bounds3, Frame, Ray, Transform};
use crate::shape::{Face, LocalGeometry, Mesh, Shape, ShapeHit, ShearedRay};

/// Geometries of at least this many primitives prefetch what shading their hits reads
/// ([`Geometry::prefetch_interactions`]); smaller ones stay in the caches.
pub const PREFETCH_PRIMS: usize = 1 << 15;

/// A placement of a shared group of shapes.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// The group (index into [`Geometry::groups`]).
    pub group: u32,
    /// Group space → world (with its inverse).
    pub to_world: Transform,
    /// The shape index (the `shape` output variable) of the group's first shape here.
    pub first_shape: u32,
}

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
    /// The id of each mesh's first triangle (the triangles are numbered mesh after mesh, in
    /// order): a hit's triangle is found from its id without reading `prims`
    /// ([`Geometry::triangle`]).
    first_triangle: Vec<u32>,
    /// Each mesh's [`Face`]s, when it keeps them ([`Mesh::faces`]; empty otherwise).
    faces: Vec<Vec<Face>>,
    /// Shared groups (each without instances of its own).
    groups: Vec<Arc<Geometry>>,
    /// The bounds of each group, in its space.
    group_bounds: Vec<Bounds3>,
    /// Placements of the groups.
    instances: Vec<Instance>,
}

impl Geometry {
    /// Gathers objects and meshes, without instances; primitive ids list bounded objects, then
    /// every mesh triangle, then unbounded objects.
    pub fn new(objects: Vec<Object>, meshes: Vec<Mesh>) -> Self {
        Self::with_instances(objects, meshes, Vec::new(), Vec::new())
    }

    /// Gathers objects, meshes and instances of `groups` (whose `first_shape` is set here: the
    /// shapes of the instances are numbered after the objects and meshes, in order). A group
    /// holds bounded shapes only and no instances; an instance names an existing group.
    pub fn with_instances(
        objects: Vec<Object>,
        meshes: Vec<Mesh>,
        groups: Vec<Arc<Geometry>>,
        mut instances: Vec<Instance>,
    ) -> Self {
        debug_assert!(groups
            .iter()
            .all(|g| g.instances.is_empty() && g.bounded == g.prims.len() as u32));
        let mut next = (objects.len() + meshes.len()) as u32;
        for inst in &mut instances {
            inst.first_shape = next;
            let g = &groups[inst.group as usize];
            next = next.saturating_add((g.objects.len() + g.meshes.len()) as u32);
        }
        let mut g = Self::own(objects, meshes);
        g.group_bounds = groups.iter().map(|g| g.bounds()).collect();
        g.groups = groups;
        g.instances = instances;
        g
    }

    /// Objects and meshes alone.
    fn own(objects: Vec<Object>, meshes: Vec<Mesh>) -> Self {
        let (bounded, unbounded): (Vec<u32>, Vec<u32>) =
            (0..objects.len() as u32).partition(|&i| objects[i as usize].shape.bounds().is_some());
        let mut prims: Vec<PrimRef> = bounded.into_iter().map(PrimRef::Object).collect();
        let mut first_triangle = Vec::with_capacity(meshes.len());
        for (m, mesh) in meshes.iter().enumerate() {
            first_triangle.push(prims.len() as u32);
            prims.extend((0..mesh.len() as u32).map(|tri| PrimRef::Triangle {
                mesh: m as u32,
                tri,
            }));
        }
        let n = prims.len() as u32;
        prims.extend(unbounded.into_iter().map(PrimRef::Object));
        let faces = meshes
            .iter()
            .map(|m| m.faces().unwrap_or_default())
            .collect();
        Self {
            objects,
            meshes,
            prims,
            bounded: n,
            first_triangle,
            faces,
            groups: Vec::new(),
            group_bounds: Vec::new(),
            instances: Vec::new(),
        }
    }

    /// The shared groups of the instances.
    pub fn groups(&self) -> &[Arc<Geometry>] {
        &self.groups
    }

    /// The instances; instance `i` has the primitive id `prim_count() + i`.
    pub fn instances(&self) -> &[Instance] {
        &self.instances
    }

    /// World bounds of instance `i` (its group's bounds, transformed).
    pub fn instance_bounds(&self, i: u32) -> Bounds3 {
        let inst = &self.instances[i as usize];
        let b = self.group_bounds[inst.group as usize];
        if b.is_empty() {
            b
        } else {
            b.transform(&inst.to_world)
        }
    }

    /// Number of bounded primitives (ids `0..bounded_count()`).
    #[inline]
    pub fn bounded_count(&self) -> u32 {
        self.bounded
    }

    /// The index of the shape primitive `prim` belongs to (`inner`: the primitive in the
    /// group of an instance, see [`Hit::leaf`]): objects first (in the order given), then
    /// meshes, then the shapes of each instance.
    pub fn shape_index(&self, prim: u32, inner: u32) -> u32 {
        match self.prims.get(prim as usize) {
            Some(PrimRef::Object(i)) => *i,
            Some(PrimRef::Triangle { mesh, .. }) => self.objects.len() as u32 + mesh,
            None => {
                let inst = &self.instances[(prim - self.prims.len() as u32) as usize];
                inst.first_shape + self.groups[inst.group as usize].shape_index(inner, 0)
            }
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

    /// The corners and [`Face`] of triangle `tri` of mesh `mesh`, when it keeps its face.
    #[inline]
    pub fn face(&self, mesh: u32, tri: u32) -> Option<([crate::math::Point3; 3], &Face)> {
        let f = self.faces.get(mesh as usize)?.get(tri as usize)?;
        let m = &self.meshes[mesh as usize];
        let [a, b, c] = m.indices[tri as usize].map(|i| m.positions[i as usize]);
        Some(([a, b, c], f))
    }

    /// [`Mesh::geometry`] of triangle `tri` of mesh `mesh` at barycentrics (β, γ), with its
    /// shading frame when the triangle keeps it ready ([`Face`]).
    #[inline(always)]
    pub fn mesh_geometry(
        &self,
        mesh: u32,
        tri: u32,
        beta: f32,
        gamma: f32,
    ) -> (LocalGeometry, Option<Frame>) {
        let m = &self.meshes[mesh as usize];
        match self.faces[mesh as usize].get(tri as usize) {
            Some(f) => (m.geometry_of_face(tri, beta, gamma, f), Some(f.frame)),
            None => (m.geometry_inline(tri, beta, gamma), None),
        }
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

    /// Bounds of all bounded primitives and instances.
    pub fn bounds(&self) -> Bounds3 {
        let own = (0..self.bounded).fold(Bounds3::EMPTY, |b, p| b.union(self.prim_bounds(p)));
        (0..self.instances.len() as u32).fold(own, |b, i| b.union(self.instance_bounds(i)))
    }

    /// Starts loading what [`Geometry::interaction`] reads for the hits in `lanes` (bit i:
    /// `hits[i]`), in stages over all of them, so that their cache misses overlap rather than
    /// come one after another as each interaction is computed. Only triangles need it (their
    /// primitive record, then their indices, then their vertices), and only in geometries too
    /// large for the caches ([`PREFETCH_PRIMS`] primitives or more).
    #[inline]
    pub fn prefetch_interactions(&self, hits: &[Option<Hit>], lanes: u32) {
        if self.prims.len() < PREFETCH_PRIMS {
            return;
        }
        // Each hit's mesh and triangle found once, for both stages.
        let mut found = [(0u32, 0u32); crate::math::BATCH];
        let mut n = 0;
        for i in crate::math::lanes(lanes) {
            let Some(h) = hits.get(i).and_then(Option::as_ref) else {
                continue;
            };
            let (Some((mesh, tri)), Some(slot)) = (self.triangle(h.prim), found.get_mut(n)) else {
                continue;
            };
            if let Some(ix) = self.meshes[mesh as usize].indices.get(tri as usize) {
                crate::simd::prefetch(ix);
            }
            *slot = (mesh, tri);
            n += 1;
        }
        for &(mesh, tri) in &found[..n] {
            self.meshes[mesh as usize].prefetch_vertices(tri);
        }
    }

    /// The number of bounded objects (ids `0..bounded_objects()`): the first triangle's id, or
    /// every bounded primitive when there are no meshes.
    #[inline(always)]
    fn bounded_objects(&self) -> u32 {
        self.first_triangle.first().copied().unwrap_or(self.bounded)
    }

    /// The mesh and triangle of primitive `prim` when it is a mesh triangle: from its id alone
    /// (what `prims` holds for it, without the cache miss of reading it in a large mesh).
    #[inline(always)]
    fn triangle(&self, prim: u32) -> Option<(u32, u32)> {
        let first = *self.first_triangle.first()?;
        if prim < first || prim >= self.bounded {
            return None;
        }
        if self.first_triangle.len() == 1 {
            return Some((0, prim - first));
        }
        // A small geometry's records stay in the caches: reading one beats a search (whose
        // branches a few meshes of different sizes make unpredictable).
        if self.prims.len() < PREFETCH_PRIMS {
            if let Some(&PrimRef::Triangle { mesh, tri }) = self.prims.get(prim as usize) {
                return Some((mesh, tri));
            }
        }
        // The last mesh starting at or before `prim` (an empty mesh starts where the next one
        // does, and is passed over).
        let m = self.first_triangle.partition_point(|&f| f <= prim) - 1;
        Some((m as u32, prim - self.first_triangle[m]))
    }

    /// The full interaction for a hit found along `ray`.
    #[inline(always)]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        self.interaction_with(ray, hit, true)
    }

    /// [`Geometry::interaction`], with texture coordinates only when `uv`: shapes whose
    /// coordinates cost something to compute (spheres) leave them at zero otherwise.
    #[inline(always)]
    pub fn interaction_with(&self, ray: &Ray, hit: &Hit, uv: bool) -> SurfaceInteraction {
        // A parallelogram (walls, floors, area lights) or a box is resolved in the caller: the
        // interaction is not returned through memory from a call (written by the callee in
        // other pieces than the caller reads back), and no call is made.
        // (Only bounded objects have these shapes: a triangle's record is not read.)
        let object = match hit.prim < self.bounded_objects() {
            true => self.prims.get(hit.prim as usize),
            false => None,
        };
        if let Some(&PrimRef::Object(o)) = object {
            let obj = &self.objects[o as usize];
            match (&obj.shape, uv) {
                (Shape::Parallelogram(p), _) => {
                    let g = p.geometry(hit.uv[0], hit.uv[1]);
                    return surface_interaction(ray, hit, g, obj.props, Some(p.frame()));
                }
                // Boxes (the blocks of a Cornell box), likewise.
                (Shape::Cube(c), _) => {
                    let g = c.geometry(ray, hit.t, hit.sub);
                    return surface_interaction(
                        ray,
                        hit,
                        g,
                        obj.props,
                        Some(c.face_frame(hit.sub)),
                    );
                }
                // Spheres (without texture coordinates), likewise.
                (Shape::Sphere(s), false) => {
                    let g = s.geometry_without_uv(ray, hit.t);
                    return surface_interaction(ray, hit, g, obj.props, None);
                }
                _ => {}
            }
        }
        self.interaction_general(ray, hit, uv)
    }

    /// [`Geometry::interaction_with`] for every primitive but a parallelogram and a sphere
    /// without texture coordinates.
    #[inline(never)]
    fn interaction_general(&self, ray: &Ray, hit: &Hit, uv: bool) -> SurfaceInteraction {
        let sh = ShapeHit {
            t: hit.t,
            uv: hit.uv,
            sub: hit.sub,
            leaf: hit.leaf,
        };
        if let Some((mesh, tri)) = self.triangle(hit.prim) {
            let (g, frame) = self.mesh_geometry(mesh, tri, hit.uv[0], hit.uv[1]);
            return surface_interaction(ray, hit, g, self.meshes[mesh as usize].props, frame);
        }
        let Some(&prim) = self.prims.get(hit.prim as usize) else {
            return self.instance_interaction(ray, hit);
        };
        let (g, props, frame) = match prim {
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
                    Shape::Sphere(s) if !uv => (s.geometry_without_uv(ray, sh.t), obj.props, None),
                    shape => (
                        shape.geometry(ray, &sh),
                        shape.hit_props(&sh).unwrap_or(obj.props),
                        None,
                    ),
                }
            }
            PrimRef::Triangle { mesh, tri } => {
                let (g, frame) = self.mesh_geometry(mesh, tri, hit.uv[0], hit.uv[1]);
                (g, self.meshes[mesh as usize].props, frame)
            }
        };
        surface_interaction(ray, hit, g, props, frame)
    }

    /// [`Geometry::interaction`] for a hit in an instance: the group's interaction along the
    /// ray brought into group space, moved back to the world (points and tangents by the
    /// placement, normals by its inverse transpose).
    #[cold]
    #[inline(never)]
    fn instance_interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let inst = &self.instances[(hit.prim - self.prims.len() as u32) as usize];
        let group = &self.groups[inst.group as usize];
        let t = &inst.to_world;
        let local = Ray {
            o: t.inv_point(ray.o),
            d: t.inv_vector(ray.d),
            tmin: ray.tmin,
            tmax: ray.tmax,
        };
        let inner = Hit {
            prim: hit.leaf,
            leaf: 0,
            ..*hit
        };
        let mut si = group.interaction(&local, &inner);
        si.prim = hit.prim;
        if t.is_identity() {
            return si;
        }
        let unit = |n: crate::math::Normal3, fallback: crate::math::Normal3| {
            let n = t.normal(n);
            let len = n.to_vec().norm();
            if len > 0.0 && len.is_finite() {
                n / len
            } else {
                fallback
            }
        };
        si.p = t.point(si.p);
        si.n = unit(si.n, si.n);
        si.ns = unit(si.ns, si.n);
        // The geometric normal stays on the side of the shading normal (as `Mesh::geometry`
        // keeps it), which a non-uniform scaling could otherwise break.
        if si.n.dot_vec(si.ns.to_vec()) < 0.0 {
            si.n = -si.n;
        }
        si.dpdu = t.vector(si.dpdu);
        si.wo = -ray.d.normalize();
        // Flat shapes' ready frames do not survive a non-uniform scaling: computed on demand.
        si.frame = None;
        si
    }
}

/// The interaction of `hit` along `ray` from its surface `g`.
#[inline(always)]
fn surface_interaction(
    ray: &Ray,
    hit: &Hit,
    g: LocalGeometry,
    props: SurfaceProps,
    frame: Option<Frame>,
) -> SurfaceInteraction {
    SurfaceInteraction {
        p: g.p,
        n: g.n,
        ns: g.ns,
        uv: g.uv,
        dpdu: g.dpdu,
        wo: -unit_direction(ray.d),
        t: hit.t,
        prim: hit.prim,
        props,
        frame,
    }
}

/// `d` normalised, or `d` itself when its squared length is within 2⁻²⁰ of 1 (the path
/// tracer's rays, unit to round-off): no square root and division on the way from a hit to
/// its shading, and a direction unit to the same round-off.
#[inline(always)]
pub(crate) fn unit_direction(d: crate::math::Vec3) -> crate::math::Vec3 {
    let l2 = d.squared_norm();
    if (l2 - 1.0).abs() <= 1.0 / 1_048_576.0 {
        d
    } else {
        d.normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Point3, Vec3};

    /// The outgoing direction is unit whatever the ray's length: directions unit to
    /// round-off are kept as they are, others normalised.
    #[test]
    fn outgoing_directions_are_unit() {
        let d = Vec3::new(0.6, 0.8, 0.0);
        assert_eq!(unit_direction(d), d);
        let nearly = Vec3::new(0.6f32.next_up(), 0.8, 0.0);
        assert_eq!(unit_direction(nearly), nearly);
        for d in [
            Vec3::new(3.0, -4.0, 12.0),
            Vec3::new(1e-3, 2e-3, 0.0),
            Vec3::new(0.6, 0.8, 0.01),
        ] {
            let u = unit_direction(d);
            assert!((u.norm() - 1.0).abs() < 1e-6, "{d:?}: {u:?}");
            assert!(u.cross(d).norm() < 1e-6 * d.norm());
        }
    }
    use crate::shape::{Cube, Parallelogram};

    /// A parallelogram's or a box's hit resolved in the caller is the general path's
    /// interaction, bit for bit; other shapes still take the general path.
    #[test]
    fn parallelogram_interactions_inline_match_the_general_path() {
        let q = Parallelogram::new(
            Point3::new(-1.0, -1.0, 0.5),
            Vec3::new(2.0, 0.0, 0.25),
            Vec3::new(0.0, 1.5, 0.0),
        )
        .unwrap();
        let props = SurfaceProps {
            material: 3,
            emission: Some(1),
            light: Some(0),
        };
        let g = Geometry::new(
            vec![
                Object {
                    shape: Shape::Parallelogram(q),
                    props,
                },
                Object {
                    shape: Shape::Cube(Cube::new(Transform::translation(Vec3::new(
                        0.0, 0.0, -3.0,
                    )))),
                    props: SurfaceProps::new(1),
                },
            ],
            Vec::new(),
        );
        let mut hits = 0;
        for (o, d) in [
            (Point3::new(0.1, 0.2, 3.0), Vec3::new(0.01, -0.02, -1.0)),
            (Point3::new(-0.5, 0.3, -2.0), Vec3::new(0.0, 0.1, 2.0)),
            (Point3::new(0.2, 0.1, 5.0), Vec3::new(0.0, 0.0, -3.0)),
        ] {
            let ray = Ray::new(o, d);
            for prim in 0..g.prim_count() {
                let Some(hit) = g.intersect_prim(prim, &ray, &ShearedRay::new(&ray)) else {
                    continue;
                };
                for uv in [false, true] {
                    let (a, b) = (
                        g.interaction_with(&ray, &hit, uv),
                        g.interaction_general(&ray, &hit, uv),
                    );
                    assert_eq!(format!("{a:?}"), format!("{b:?}"));
                }
                hits += 1;
            }
        }
        assert!(hits >= 3, "{hits}");
    }

    /// A triangle found from its id alone is the one `prims` records, for every id of a
    /// geometry of bounded and unbounded objects and several meshes (one of them empty).
    #[test]
    fn triangles_are_found_from_their_ids() {
        let tri = |z: f32| Mesh {
            positions: vec![
                Point3::new(0.0, 0.0, z),
                Point3::new(1.0, 0.0, z),
                Point3::new(0.0, 1.0, z),
                Point3::new(1.0, 1.0, z),
            ],
            indices: vec![[0, 1, 2], [1, 3, 2]],
            ..Default::default()
        };
        let object = |shape| Object {
            shape,
            props: SurfaceProps::new(0),
        };
        let cube = || Shape::Cube(Cube::new(Transform::translation(Vec3::new(0.0, 0.0, -3.0))));
        let plane = || Shape::Plane(crate::shape::Plane::new(Transform::IDENTITY));
        for (objects, meshes) in [
            (
                vec![object(cube()), object(plane()), object(cube())],
                vec![tri(0.0), Mesh::default(), tri(1.0), tri(2.0)],
            ),
            (vec![object(plane())], vec![Mesh::default(), tri(0.0)]),
            (vec![object(cube())], vec![]),
            (vec![], vec![tri(0.0)]),
        ] {
            let g = Geometry::new(objects, meshes);
            for p in 0..g.prim_count() + 2 {
                let want = match g.prims.get(p as usize) {
                    Some(&PrimRef::Triangle { mesh, tri }) => Some((mesh, tri)),
                    _ => None,
                };
                assert_eq!(g.triangle(p), want, "{p}");
                let object = p < g.bounded_objects();
                assert_eq!(
                    object,
                    matches!(g.prims.get(p as usize), Some(PrimRef::Object(_))) && p < g.bounded,
                    "{p}"
                );
            }
        }
    }
}
