//! The renderable scene: geometry with its acceleration structure, materials, emitters, lights
//! and the camera. Built once by [`SceneBuilder`]; immutable and shared by all threads after.

use crate::accel::{Accel, AccelKind, BatchHits};
use crate::camera::Camera;
use crate::color::Rgb;
use crate::geometry::{Geometry, Instance, Object};
use crate::instance::Instances;
use crate::interaction::{Hit, SurfaceInteraction, SurfaceProps};
use crate::light::{AreaLight, Emission, Light, LightSelector};
use crate::material::{Material, MaterialId};
use crate::math::{Point3, Ray, RayBatch, Transform, Vec3};
use crate::sampling::guide::{Guide, MAX_GUIDES};
use crate::sampling::pcg::hash2;
use crate::shape::{Mesh, Shape, ShearedRay};
use crate::spectrum::{upsample, RgbRole, SampledSpectrum, Wavelengths};
use crate::stats::RayStats;
use std::sync::Arc;

/// A scene ready to render.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// The shapes.
    pub geometry: Geometry,
    /// The acceleration structure over `geometry`.
    pub accel: Accel,
    /// The two-level structure of `geometry`'s instances (empty without instances).
    pub instances: Instances,
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
    /// How the path tracer chooses the light it samples at a shading point.
    pub light_selector: LightSelector,
    /// The ambient intensity I_a of the local model (sum of `ambient_light`s).
    pub ambient: Rgb,
    /// True when a material has a stochastic opacity (see [`Material::opacity`]).
    pub has_masks: bool,
    /// True when a material's or emitter's texture varies over a surface: only then do
    /// [`Scene::interaction`]s carry texture coordinates (see [`Material::reads_uv`]).
    pub reads_uv: bool,
    /// Spheres bounding the perfectly specular objects, which diffuse vertices sample
    /// directions towards beside their cosine-weighted ones (see [`crate::sampling::guide`]).
    pub guides: Vec<Guide>,
}

/// The bounding spheres of the objects of `geometry` whose material is a perfect mirror or a
/// smooth dielectric ([`crate::material::Model::is_delta`]; the first [`MAX_GUIDES`]): a
/// sphere's own, other shapes' the sphere about their bounds. (Meshes are left out.)
fn guides_of(geometry: &Geometry, materials: &[Material]) -> Vec<Guide> {
    geometry
        .objects()
        .iter()
        .filter(|o| materials[o.props.material as usize].model.is_delta())
        .filter_map(|o| match &o.shape {
            Shape::Sphere(s) => {
                let (c, r) = s.bounding_sphere();
                Some(Guide { c, r })
            }
            shape => shape.bounds().map(|b| Guide {
                c: b.centroid(),
                r: b.diagonal().norm() * 0.5,
            }),
        })
        .filter(|g| g.r.is_finite() && g.r > 0.0)
        .take(MAX_GUIDES)
        .collect()
}

/// The most masked surfaces a ray passes through before the next one counts as a hit.
const MAX_MASK_LAYERS: usize = 256;

impl Scene {
    /// The radiance arriving from direction `d` along a ray that escaped the scene, in the
    /// lanes of `lambda`.
    pub fn escaped(&self, d: Vec3, lambda: &Wavelengths) -> SampledSpectrum {
        self.infinite_lights
            .iter()
            .fold(self.background(lambda), |acc, &i| {
                acc + self.lights[i as usize].escaped(d, lambda)
            })
    }

    /// The background colour in the lanes of `lambda` (an emitter's colour).
    #[inline]
    pub fn background(&self, lambda: &Wavelengths) -> SampledSpectrum {
        if self.background.is_black() {
            return SampledSpectrum::ZERO;
        }
        lambda.colour(self.background, RgbRole::Emission)
    }

    /// Readies the scene for spectral rendering: the uniform colours of materials, emitters
    /// and environments are upsampled once here rather than at every use. RGB renders of the
    /// prepared scene are unchanged.
    pub fn prepare_spectral(&mut self) {
        for m in &mut self.materials {
            m.prepare_spectral();
        }
        for e in &mut self.emissions {
            e.radiance.prepare_spectral(RgbRole::Emission);
        }
        let prepared = |rgb: Rgb, s: &mut Option<std::sync::Arc<crate::spectrum::Spectrum>>| {
            if s.is_none() {
                *s = Some(std::sync::Arc::new(upsample(rgb, RgbRole::Emission)));
            }
        };
        for l in &mut self.lights {
            match l {
                Light::Environment(e) => e.radiance.prepare_spectral(RgbRole::Emission),
                Light::Point(p, _) => prepared(p.intensity, &mut p.spectrum),
                Light::Spot(p, _) => prepared(p.intensity, &mut p.spectrum),
                Light::Distant(d, _) => prepared(d.irradiance, &mut d.spectrum),
                Light::Hemisphere(..) | Light::Area(_) => {}
            }
        }
    }

    /// The closest hit along `ray`. A surface with a stochastic opacity α is hit with
    /// probability α and passed through otherwise; the choice is a hash of the ray and the hit
    /// distance (deterministic, no sample dimension used, the same for a ray traced alone or
    /// in a batch).
    #[inline]
    pub fn intersect(&self, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        let hit = self.intersect_opaque(ray, stats);
        if !self.has_masks {
            return hit;
        }
        self.through_masks(ray, hit, stats)
    }

    /// `hit` (the closest hit of `ray` counting every surface), or the first hit beyond it
    /// that the stochastic opacities keep.
    #[inline(never)]
    fn through_masks(&self, ray: &Ray, mut hit: Option<Hit>, stats: &mut RayStats) -> Option<Hit> {
        let mut r = *ray;
        for _ in 0..MAX_MASK_LAYERS {
            let h = hit?;
            if !self.passes_through(&r, &h) {
                return Some(h);
            }
            r.tmin = h.t;
            hit = self.intersect_opaque(&r, stats);
        }
        hit
    }

    /// True when the ray passes through the surface of `h` (a masked material, and a uniform
    /// number hashed from the ray and `h.t` at or above the opacity there).
    fn passes_through(&self, ray: &Ray, h: &Hit) -> bool {
        let si = self.geometry.interaction(ray, h);
        let Some(opacity) = &self.materials[si.props.material as usize].opacity else {
            return false;
        };
        // Mitsuba reads a colour opacity as its luminance.
        let alpha = opacity.eval(si.uv).luminance();
        let bits = |v: f32| v.to_bits() as u64;
        let key = hash2(
            bits(ray.o.x) | bits(ray.o.y) << 32,
            bits(ray.o.z) | bits(ray.d.x) << 32,
        );
        let key = hash2(key, bits(ray.d.y) | bits(ray.d.z) << 32);
        let u = (hash2(key, bits(h.t)) >> 40) as f32 * (1.0 / (1u64 << 24) as f32);
        u >= alpha
    }

    /// The closest hit along `ray`, every surface opaque.
    #[inline]
    fn intersect_opaque(&self, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        stats.rays += 1;
        let mut best = self.accel.intersect(&self.geometry, ray, stats);
        if !self.instances.is_empty() {
            self.instances
                .intersect(&self.geometry, ray, &mut best, stats);
        }
        if self.geometry.bounded_count() == self.geometry.prim_count() {
            return best;
        }
        // The unbounded primitives (planes, which ignore the sheared ray).
        let sr = ShearedRay::unused();
        let mut r = *ray;
        if let Some(b) = &best {
            r.tmax = b.t.next_up();
        }
        for prim in self.geometry.bounded_count()..self.geometry.prim_count() {
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
        if self.has_masks {
            // Masked surfaces block shadow rays stochastically too: the closest kept hit.
            stats.shadow_rays += 1;
            return self.intersect(ray, stats).is_some();
        }
        stats.shadow_rays += 1;
        let sr = ShearedRay::unused();
        (self.geometry.bounded_count()..self.geometry.prim_count()).any(|p| {
            stats.prim_tests += 1;
            self.geometry.intersect_prim(p, ray, &sr).is_some()
        }) || self.accel.occluded(&self.geometry, ray, stats)
            || (!self.instances.is_empty() && self.instances.occluded(&self.geometry, ray, stats))
    }

    /// The closest hit of every active lane of `rays`: the hits [`Scene::intersect`] gives ray
    /// by ray, small scenes testing each primitive against all lanes at once.
    #[inline]
    pub fn intersect_batch(&self, rays: &RayBatch, hits: &mut BatchHits, stats: &mut RayStats) {
        stats.rays += rays.active.count_ones() as u64;
        self.accel
            .intersect_batch(&self.geometry, rays, hits, stats);
        if !self.instances.is_empty() {
            for i in rays.lanes() {
                self.instances
                    .intersect(&self.geometry, &rays.ray(i), &mut hits[i], stats);
            }
        }
        if self.geometry.bounded_count() != self.geometry.prim_count() {
            self.intersect_unbounded_batch(rays, hits, stats);
        }
        if self.has_masks {
            for i in rays.lanes() {
                hits[i] = self.through_masks(&rays.ray(i), hits[i], stats);
            }
        }
    }

    /// The unbounded primitives' part of [`Scene::intersect_batch`].
    fn intersect_unbounded_batch(
        &self,
        rays: &RayBatch,
        hits: &mut BatchHits,
        stats: &mut RayStats,
    ) {
        // The unbounded primitives (planes, which ignore the sheared ray), lane by lane.
        let sr = ShearedRay::unused();
        for i in rays.lanes() {
            let mut r = rays.ray(i);
            let best = &mut hits[i];
            if let Some(b) = best {
                r.tmax = b.t.next_up();
            }
            for prim in self.geometry.bounded_count()..self.geometry.prim_count() {
                stats.prim_tests += 1;
                if let Some(h) = self.geometry.intersect_prim(prim, &r, &sr) {
                    if crate::accel::closest(best, h) {
                        r.tmax = h.t.next_up();
                    }
                }
            }
        }
    }

    /// The active lanes of `rays` that something blocks within their interval (bit i for
    /// lane i).
    #[inline]
    pub fn occluded_batch(&self, rays: &RayBatch, stats: &mut RayStats) -> u32 {
        if self.has_masks {
            return rays.lanes().fold(0, |acc, i| {
                acc | (self.occluded(&rays.ray(i), stats) as u32) << i
            });
        }
        stats.shadow_rays += rays.active.count_ones() as u64;
        let mut hit = 0;
        if self.geometry.bounded_count() != self.geometry.prim_count() {
            let sr = ShearedRay::unused();
            for i in rays.lanes() {
                let r = rays.ray(i);
                if (self.geometry.bounded_count()..self.geometry.prim_count()).any(|p| {
                    stats.prim_tests += 1;
                    self.geometry.intersect_prim(p, &r, &sr).is_some()
                }) {
                    hit |= 1 << i;
                }
            }
        }
        let rest = RayBatch {
            active: rays.active & !hit,
            ..*rays
        };
        if rest.active != 0 {
            hit |= self.accel.occluded_batch(&self.geometry, &rest, stats);
        }
        if !self.instances.is_empty() {
            let open = rays.active & !hit;
            for i in rays.lanes().filter(|&i| open & (1 << i) != 0) {
                if self.instances.occluded(&self.geometry, &rays.ray(i), stats) {
                    hit |= 1 << i;
                }
            }
        }
        hit
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

    /// The shape index (the `shape` output variable) of a hit (in an instance, the hit knows
    /// the group's shape; the interaction does not).
    #[inline]
    pub fn shape_index(&self, hit: &Hit) -> u32 {
        self.geometry.shape_index(hit.prim, hit.leaf)
    }

    /// The material of an interaction.
    #[inline]
    pub fn material(&self, si: &SurfaceInteraction) -> &Material {
        &self.materials[si.props.material as usize]
    }

    /// The surface at `hit` along `ray`, for shading: texture coordinates are left at zero
    /// when nothing in the scene reads them ([`Scene::reads_uv`]).
    #[inline]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        self.geometry.interaction_with(ray, hit, self.reads_uv)
    }

    /// The radiance emitted by the surface of `si` back along the ray, in the lanes of
    /// `lambda`.
    #[inline]
    pub fn emitted(&self, si: &SurfaceInteraction, lambda: &Wavelengths) -> SampledSpectrum {
        match si.props.emission {
            Some(e) => self.emissions[e as usize].radiance(si, si.wo, lambda),
            None => SampledSpectrum::ZERO,
        }
    }
}

/// Why [`SceneBuilder::add_group`] refused a group: the index of the offending shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupError {
    /// An unbounded shape (a plane).
    Unbounded(usize),
    /// An emitting shape.
    Emitter(usize),
    /// A CSG shape (its hits use the field that instances use, `Hit::leaf`).
    Csg(usize),
}

impl std::fmt::Display for GroupError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GroupError::Unbounded(_) => {
                write!(f, "a shape group cannot hold unbounded shapes (planes)")
            }
            GroupError::Csg(_) => write!(f, "a shape group cannot hold CSG shapes"),
            GroupError::Emitter(_) => write!(
                f,
                "a shape group cannot hold emitters (instanced emitters are not supported, as in Mitsuba 3)"
            ),
        }
    }
}

/// Collects the parts of a scene and builds it.
#[derive(Clone, Debug)]
pub struct SceneBuilder {
    camera: Option<Camera>,
    objects: Vec<Object>,
    meshes: Vec<Mesh>,
    groups: Vec<Arc<Geometry>>,
    instances: Vec<Instance>,
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
            groups: Vec::new(),
            instances: Vec::new(),
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

    /// Adds a triangle mesh as [`SceneBuilder::add_mesh`] does, or, when it is a few flat
    /// parallelograms ([`Mesh::parallelograms`]) and nothing reads its texture coordinates
    /// (its material and emission are the same all over), as those parallelograms: the same
    /// surface, at half the intersection tests, and a rectangle light sampled by its area
    /// (the Lambert lanes sample it themselves) instead of a mesh light. An emissive mesh is
    /// taken for a parallelogram only when it is one (several would become as many lights,
    /// chosen uniformly rather than by their areas). Nor is a mesh whose material turns with
    /// the tangent ([`crate::material::Material::reads_tangent`]): a parallelogram's tangent is
    /// its edge, a mesh's its texture coordinates' or its normal's basis. Scene files' meshes
    /// come this way.
    pub fn add_mesh_or_parallelograms(&mut self, mesh: Mesh) -> &mut Self {
        let props = mesh.props;
        let flat_look = self
            .materials
            .get(props.material as usize)
            .is_some_and(|m| !m.reads_uv() && !m.reads_tangent())
            && props.emission.is_none_or(|e| {
                self.emissions
                    .get(e as usize)
                    .is_some_and(|e| e.radiance.is_constant())
            });
        let one_if_emissive = props.emission.is_none() || mesh.len() == 2;
        match mesh.parallelograms() {
            Some(quads) if flat_look && one_if_emissive => {
                for q in quads {
                    self.add_shape(Shape::Parallelogram(q), props.material, props.emission);
                }
                self
            }
            _ => self.add_mesh(mesh),
        }
    }

    /// Adds a group of shapes to be placed by [`SceneBuilder::add_instance`] (and not
    /// otherwise), in its own space, and returns its index. Each shape is given as
    /// `(shape, material)`; meshes carry their material. A group holds bounded shapes that
    /// emit nothing (as in Mitsuba, whose shape groups refuse emitters) and are not CSG; the
    /// error says which rule a shape breaks (its index among `shapes`, then `meshes`). Empty
    /// meshes are dropped.
    pub fn add_group(
        &mut self,
        shapes: Vec<(Shape, MaterialId)>,
        meshes: Vec<Mesh>,
    ) -> Result<u32, GroupError> {
        for (i, (s, _)) in shapes.iter().enumerate() {
            if s.bounds().is_none() {
                return Err(GroupError::Unbounded(i));
            }
            if matches!(s, Shape::Csg(_)) {
                return Err(GroupError::Csg(i));
            }
        }
        for (i, m) in meshes.iter().enumerate() {
            if m.props.emission.is_some() || m.props.light.is_some() {
                return Err(GroupError::Emitter(shapes.len() + i));
            }
        }
        let objects = shapes
            .into_iter()
            .map(|(shape, material)| Object {
                shape,
                props: SurfaceProps::new(material),
            })
            .collect();
        let meshes = meshes.into_iter().filter(|m| !m.is_empty()).collect();
        self.groups.push(Arc::new(Geometry::new(objects, meshes)));
        Ok((self.groups.len() - 1) as u32)
    }

    /// Places group `group` (from [`SceneBuilder::add_group`]) by `to_world`; its geometry is
    /// shared, not copied. A group index that does not exist is ignored.
    pub fn add_instance(&mut self, group: u32, to_world: Transform) -> &mut Self {
        if (group as usize) < self.groups.len() {
            self.instances.push(Instance {
                group,
                to_world,
                first_shape: 0,
            });
        }
        self
    }

    /// Builds the scene with the acceleration structure `accel`. Without a camera, the
    /// course's default is used: perspective, distance 1, aspect 4/3, at the origin.
    pub fn build(self, accel: AccelKind) -> Scene {
        let geometry =
            Geometry::with_instances(self.objects, self.meshes, self.groups, self.instances);
        let instances = Instances::build(accel, &geometry);
        let accel = Accel::build(accel, &geometry);
        let has_masks = self.materials.iter().any(|m| m.opacity.is_some());
        let light_selector = LightSelector::new(&self.lights, &self.emissions, &geometry);
        let reads_uv = self.materials.iter().any(Material::reads_uv)
            || self.emissions.iter().any(|e| !e.radiance.is_constant());
        let guides = guides_of(&geometry, &self.materials);
        Scene {
            guides,
            camera: self
                .camera
                .unwrap_or_else(|| Camera::perspective(1.0, 4.0 / 3.0, Transform::IDENTITY)),
            geometry,
            accel,
            instances,
            materials: self.materials,
            emissions: self.emissions,
            background: self.background,
            infinite_lights: (0..self.lights.len() as u32)
                .filter(|&i| self.lights[i as usize].is_infinite())
                .collect(),
            light_selector,
            lights: self.lights,
            ambient: self.ambient,
            has_masks,
            reads_uv,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::{Plane, Sphere};
    use crate::texture::Texture;

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

    /// Shading interactions leave texture coordinates out only when no texture reads them:
    /// the rest of the surface is the same bit for bit, and a checkered sphere keeps them.
    #[test]
    fn texture_coordinates_only_where_read() {
        let plain = two_spheres_and_a_plane();
        assert!(!plain.reads_uv);
        let ray = Ray::new(Point3::new(5.3, 0.4, 3.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = plain.intersect(&ray, &mut RayStats::default()).unwrap();
        let (full, lazy) = (
            plain.geometry.interaction(&ray, &hit),
            plain.interaction(&ray, &hit),
        );
        assert_eq!((lazy.uv.x, lazy.uv.y), (0.0, 0.0));
        assert!(full.uv.x > 0.0 && full.uv.y > 0.0);
        assert_eq!(
            (lazy.p, lazy.n, lazy.ns, lazy.dpdu, lazy.wo, lazy.t),
            (full.p, full.n, full.ns, full.dpdu, full.wo, full.t)
        );

        let mut b = SceneBuilder::new();
        let checker = Texture::Checkered {
            c1: Rgb::WHITE,
            c2: Rgb::BLACK,
            steps: [4.0, 4.0],
            offset: [0.0, 0.0],
        };
        let m = b.add_material(Material::diffuse(checker));
        b.add_shape(
            Shape::Sphere(Sphere::new(Transform::translation(Vec3::new(
                5.3, 0.0, 0.0,
            )))),
            m,
            None,
        );
        let textured = b.build(AccelKind::None);
        assert!(textured.reads_uv);
        let hit = textured.intersect(&ray, &mut RayStats::default()).unwrap();
        let (full, lazy) = (
            textured.geometry.interaction(&ray, &hit),
            textured.interaction(&ray, &hit),
        );
        assert_eq!((lazy.uv.x, lazy.uv.y), (full.uv.x, full.uv.y));
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

    /// Scene files' quads become parallelograms (a lit one a rectangle light), unless a
    /// texture reads their coordinates or an emissive mesh has several.
    #[test]
    fn flat_quads_become_parallelograms_when_nothing_reads_their_coordinates() {
        use crate::light::AreaShape;
        use crate::shape::Mesh;
        let quad = |y: f32, n: usize| {
            let mut m = Mesh::default();
            for k in 0..n {
                let x = 2.0 * k as f32;
                let b = m.positions.len() as u32;
                m.positions.extend([
                    Point3::new(x, y, 0.0),
                    Point3::new(x + 1.0, y, 0.0),
                    Point3::new(x + 1.0, y, 1.0),
                    Point3::new(x, y, 1.0),
                ]);
                m.indices.extend([[b, b + 2, b + 1], [b, b + 3, b + 2]]);
            }
            m
        };
        let mut b = SceneBuilder::new();
        let plain = b.add_material(Material::diffuse(Texture::Uniform(Rgb::splat(0.5))));
        let checkered = b.add_material(Material::diffuse(Texture::Checkered {
            c1: Rgb::splat(0.2),
            c2: Rgb::splat(0.8),
            steps: [4.0, 4.0],
            offset: [0.0, 0.0],
        }));
        let glow = b.add_emission(Emission {
            radiance: Texture::Uniform(Rgb::splat(3.0)),
            two_sided: false,
        });
        let mut add = |y: f32, n: usize, material: u32, emission: Option<u32>| {
            let mut m = quad(y, n);
            m.props.material = material;
            m.props.emission = emission;
            b.add_mesh_or_parallelograms(m);
        };
        add(0.0, 2, plain, None); // two parallelograms
        add(1.0, 1, checkered, None); // a mesh: its texture reads uv
        add(2.0, 1, plain, Some(glow)); // a rectangle light
        add(3.0, 2, plain, Some(glow)); // a mesh light: two quads
        let s = b.build(crate::accel::AccelKind::Bvh);
        let objects = s.geometry.objects();
        assert_eq!(objects.len(), 3);
        assert!(objects
            .iter()
            .all(|o| matches!(o.shape, Shape::Parallelogram(_))));
        assert_eq!(s.geometry.meshes().len(), 2);
        assert_eq!(s.lights.len(), 2);
        assert!(matches!(
            &s.lights[0],
            Light::Area(a) if matches!(a.shape, AreaShape::Parallelogram(_))
        ));
        assert!(matches!(
            &s.lights[1],
            Light::Area(a) if matches!(a.shape, AreaShape::Mesh { .. })
        ));
        // The light faces as the triangles wind: (b, b+2, b+1) turns to +y.
        let Some(Light::Area(a)) = s.lights.first() else {
            unreachable!()
        };
        let AreaShape::Parallelogram(q) = &a.shape else {
            unreachable!()
        };
        assert!(q.normal().y > 0.999);
    }
}
