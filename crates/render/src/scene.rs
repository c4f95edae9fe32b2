//! The renderable scene: geometry with its acceleration structure, materials, emitters, lights
//! and the camera. Built once by [`SceneBuilder`]; immutable and shared by all threads after.

use crate::accel::{Accel, AccelKind};
use crate::camera::Camera;
use crate::color::Rgb;
use crate::interaction::{Hit, SurfaceInteraction, SurfaceProps};
use crate::light::{AreaLight, Light};
use crate::material::{Material, MaterialId};
use crate::math::{Bounds3, Point3, Ray, Transform, Vec3};
use crate::shape::{Mesh, Shape, ShapeHit, ShearedRay};
use crate::stats::RayStats;
use crate::texture::Texture;

/// Emitted radiance of a surface.
#[derive(Clone, Debug, PartialEq)]
pub struct Emission {
    /// Radiance over the surface's uv.
    pub radiance: Texture,
    /// Emits on both sides (candela language) or only on the side of the normal (Mitsuba).
    pub two_sided: bool,
}

impl Emission {
    /// The radiance leaving the surface point of `si` towards `w` (pointing away from it).
    #[inline]
    pub fn radiance(&self, si: &SurfaceInteraction, w: Vec3) -> Rgb {
        self.radiance_at(si.uv, si.n, w)
    }

    /// The radiance leaving the point with surface coordinates `uv` and geometric normal `n`
    /// towards `w`.
    #[inline]
    pub fn radiance_at(&self, uv: crate::math::Point2, n: crate::math::Normal3, w: Vec3) -> Rgb {
        if !self.two_sided && n.dot_vec(w) <= 0.0 {
            return Rgb::BLACK;
        }
        self.radiance.eval(uv)
    }
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

/// A scene ready to render.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// The shapes.
    pub geometry: Geometry,
    /// The acceleration structure over `geometry`.
    pub accel: Accel,
    /// Materials, indexed by [`MaterialId`].
    pub materials: Vec<Material>,
    /// Emitters, indexed by [`SurfaceProps::emission`].
    pub emissions: Vec<Emission>,
    /// Radiance seen where rays escape the scene (besides lights at infinity).
    pub background: Rgb,
    /// All lights, area lights included.
    pub lights: Vec<Light>,
    /// Indices of the lights at infinity (seen by escaping rays).
    pub infinite_lights: Vec<u32>,
    /// The ambient intensity I_a of the local model (sum of `ambient_light`s).
    pub ambient: Rgb,
}

impl Scene {
    /// The radiance arriving from direction `d` along a ray that escaped the scene.
    pub fn escaped(&self, d: Vec3) -> Rgb {
        self.infinite_lights
            .iter()
            .fold(self.background, |acc, &i| {
                acc + self.lights[i as usize].escaped(d)
            })
    }

    /// The closest hit along `ray`.
    #[inline]
    pub fn intersect(&self, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        stats.rays += 1;
        let mut best = self.accel.intersect(&self.geometry, ray, stats);
        if self.geometry.bounded == self.geometry.prim_count() {
            return best;
        }
        // The unbounded primitives (planes, which ignore the sheared ray).
        let sr = ShearedRay::unused();
        let mut r = *ray;
        if let Some(b) = &best {
            r.tmax = b.t.next_up();
        }
        for prim in self.geometry.bounded..self.geometry.prim_count() {
            stats.prim_tests += 1;
            if let Some(h) = self.geometry.intersect_prim(prim, &r, &sr) {
                if crate::accel::closest(&mut best, h) {
                    r.tmax = h.t.next_up();
                }
            }
        }
        best
    }

    /// True when something blocks `ray` within its interval.
    #[inline]
    pub fn occluded(&self, ray: &Ray, stats: &mut RayStats) -> bool {
        stats.shadow_rays += 1;
        let sr = ShearedRay::unused();
        (self.geometry.bounded..self.geometry.prim_count()).any(|p| {
            stats.prim_tests += 1;
            self.geometry.intersect_prim(p, ray, &sr).is_some()
        }) || self.accel.occluded(&self.geometry, ray, stats)
    }

    /// True when nothing lies strictly between the points `a` and `b`.
    pub fn visible(&self, a: Point3, b: Point3, stats: &mut RayStats) -> bool {
        let r = Ray {
            o: a,
            d: b - a,
            tmin: crate::math::SHADOW_EPSILON,
            tmax: 1.0 - crate::math::SHADOW_EPSILON,
        };
        !self.occluded(&r, stats)
    }

    /// The closest hit's full interaction.
    #[inline(always)]
    pub fn interact(&self, ray: &Ray, stats: &mut RayStats) -> Option<SurfaceInteraction> {
        // No `map`: its closure can become a function of its own, which returns the
        // interaction through memory.
        let h = self.intersect(ray, stats)?;
        Some(self.geometry.interaction(ray, &h))
    }

    /// The material of an interaction.
    #[inline]
    pub fn material(&self, si: &SurfaceInteraction) -> &Material {
        &self.materials[si.props.material as usize]
    }

    /// The radiance emitted by the surface of `si` back along the ray.
    #[inline]
    pub fn emitted(&self, si: &SurfaceInteraction) -> Rgb {
        match si.props.emission {
            Some(e) => self.emissions[e as usize].radiance(si, si.wo),
            None => Rgb::BLACK,
        }
    }
}

/// Collects the parts of a scene and builds it.
#[derive(Clone, Debug)]
pub struct SceneBuilder {
    camera: Option<Camera>,
    objects: Vec<Object>,
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    emissions: Vec<Emission>,
    background: Rgb,
    lights: Vec<Light>,
    ambient: Rgb,
}

impl Default for SceneBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl SceneBuilder {
    /// An empty scene.
    pub fn new() -> Self {
        Self {
            camera: None,
            objects: Vec::new(),
            meshes: Vec::new(),
            materials: Vec::new(),
            emissions: Vec::new(),
            background: Rgb::BLACK,
            lights: Vec::new(),
            ambient: Rgb::BLACK,
        }
    }

    /// Adds a light (area lights come from emissive shapes instead).
    pub fn add_light(&mut self, light: Light) -> &mut Self {
        self.lights.push(light);
        self
    }

    /// Adds to the local model's ambient intensity.
    pub fn add_ambient(&mut self, i: Rgb) -> &mut Self {
        self.ambient += i;
        self
    }

    /// Sets the camera (the last call wins).
    pub fn camera(&mut self, camera: Camera) -> &mut Self {
        self.camera = Some(camera);
        self
    }

    /// True when a camera has been set.
    pub fn has_camera(&self) -> bool {
        self.camera.is_some()
    }

    /// Sets the radiance seen where rays escape.
    pub fn background(&mut self, c: Rgb) -> &mut Self {
        self.background = c;
        self
    }

    /// Adds a material and returns its id.
    pub fn add_material(&mut self, m: Material) -> MaterialId {
        self.materials.push(m);
        (self.materials.len() - 1) as MaterialId
    }

    /// Adds an emitter and returns its index.
    pub fn add_emission(&mut self, e: Emission) -> u32 {
        self.emissions.push(e);
        (self.emissions.len() - 1) as u32
    }

    /// Adds a shape with its material and optional emission. Emissive spheres,
    /// parallelograms, disks and boxes become area lights.
    pub fn add_shape(
        &mut self,
        shape: Shape,
        material: MaterialId,
        emission: Option<u32>,
    ) -> &mut Self {
        let light = emission.and_then(|e| {
            let l = match &shape {
                Shape::Sphere(s) => AreaLight::sphere(s.clone(), e),
                Shape::Parallelogram(p) => AreaLight::parallelogram(p.clone(), e),
                Shape::Disk(d) => AreaLight::disk(d.clone(), e),
                Shape::Cube(c) => AreaLight::cube(c.clone(), e),
                _ => return None,
            };
            self.lights.push(Light::Area(l));
            Some((self.lights.len() - 1) as u32)
        });
        self.objects.push(Object {
            shape,
            props: SurfaceProps {
                material,
                emission,
                light,
            },
        });
        self
    }

    /// Adds a triangle mesh (its surface properties are in the mesh); empty meshes are dropped.
    /// An emissive mesh becomes an area light.
    pub fn add_mesh(&mut self, mut mesh: Mesh) -> &mut Self {
        if mesh.is_empty() {
            return self;
        }
        if let Some(e) = mesh.props.emission {
            self.lights.push(Light::Area(AreaLight::mesh(
                &mesh,
                self.meshes.len() as u32,
                e,
            )));
            mesh.props.light = Some((self.lights.len() - 1) as u32);
        }
        self.meshes.push(mesh);
        self
    }

    /// Builds the scene with the acceleration structure `accel`. Without a camera, the
    /// course's default is used: perspective, distance 1, aspect 4/3, at the origin.
    pub fn build(self, accel: AccelKind) -> Scene {
        let geometry = Geometry::new(self.objects, self.meshes);
        let accel = Accel::build(accel, &geometry);
        Scene {
            camera: self
                .camera
                .unwrap_or_else(|| Camera::perspective(1.0, 4.0 / 3.0, Transform::IDENTITY)),
            geometry,
            accel,
            materials: self.materials,
            emissions: self.emissions,
            background: self.background,
            infinite_lights: (0..self.lights.len() as u32)
                .filter(|&i| self.lights[i as usize].is_infinite())
                .collect(),
            lights: self.lights,
            ambient: self.ambient,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::{Plane, Sphere};

    fn two_spheres_and_a_plane() -> Scene {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(Texture::Uniform(Rgb::WHITE)));
        b.add_shape(
            Shape::Plane(Plane::new(Transform::translation(Vec3::new(
                0.0, 0.0, -1.0,
            )))),
            m,
            None,
        );
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                5.0, 0.0, 0.0,
            )))),
            m,
            None,
        );
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                10.0, 0.0, 0.0,
            )))),
            m,
            None,
        );
        b.build(AccelKind::None)
    }

    #[test]
    fn world_returns_the_closest_hit() {
        let s = two_spheres_and_a_plane();
        let mut st = RayStats::default();
        let h = s
            .interact(&Ray::new(Point3::ORIGIN, Vec3::X), &mut st)
            .unwrap();
        assert_eq!(h.p, Point3::new(4.0, 0.0, 0.0));
        let h = s
            .interact(&Ray::new(Point3::new(20.0, 0.0, 0.0), -Vec3::X), &mut st)
            .unwrap();
        assert_eq!(h.p, Point3::new(11.0, 0.0, 0.0));
        let h = s
            .interact(
                &Ray::new(Point3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0)),
                &mut st,
            )
            .unwrap();
        assert_eq!(h.p, Point3::new(0.0, 0.0, -1.0));
        assert!(s
            .interact(&Ray::new(Point3::ORIGIN, Vec3::Z), &mut st)
            .is_none());
        assert_eq!(st.rays, 4);
    }

    #[test]
    fn point_to_point_visibility() {
        let s = two_spheres_and_a_plane();
        let mut st = RayStats::default();
        assert!(!s.visible(Point3::ORIGIN, Point3::new(20.0, 0.0, 0.0), &mut st));
        assert!(s.visible(Point3::ORIGIN, Point3::new(3.9, 0.0, 0.0), &mut st));
        assert!(s.visible(Point3::ORIGIN, Point3::new(0.0, 10.0, 0.0), &mut st));
        assert!(!s.visible(Point3::ORIGIN, Point3::new(0.0, 0.0, -2.0), &mut st));
    }
}
