//! Meshing the scene into patches.
//!
//! Every shape becomes one or more *surfaces*: a map from a parameter domain to the shape's
//! world-space surface (parallelogram: (s, t); box: one surface per face; sphere: latitude and
//! longitude; disk: radius and angle; plane: a square 20 times the scene's size (or the plane's
//! distance to it) in 32 × 32 cells growing geometrically away from the scene; convex
//! polyhedron: the fan triangles of each face polygon; mesh: one surface per triangle, with its
//! barycentrics). A surface is cut into a grid of root *elements* no larger than the patch size
//! (triangles: by repeated 4-way midpoint splits), and elements are split again by the adaptive
//! refinement of the solver. Elements form a forest: a hit is located by the surface's root grid
//! and a descent through the children, in O(depth).
//!
//! A *patch* is one side (front: the side of the shape's normal; back: the other) of a leaf
//! element. A side gets patches when it can reflect or emit (a one-sided Mitsuba BSDF is black
//! on its back; a one-sided emitter emits on its front only) and when it can be reached by light:
//! the inside of a closed solid (sphere, box, polyhedron) only when an emitter is inside it, an
//! open surface's side only when some of a few test rays from it hit something (or when the scene
//! has lights that are not shapes). Sides without patches are black absorbers.
//!
//! Curved elements are approximated by the planar polygon of their corners (which lie on the
//! true surface) for areas and the hemicube; sample points for ray casting and the hemicube's
//! eye are mapped onto the true surface.

use super::NONE;
use crate::color::Rgb;
use crate::geometry::PrimRef;
use crate::interaction::{Hit, SurfaceInteraction, SurfaceProps};
use crate::material::{Material, Model};
use crate::math::{Bounds3, Frame, Normal3, Point2, Point3, Ray, Transform, Vec3, PI};
use crate::sampling::sampler::cmj;
use crate::sampling::warp;
use crate::scene::Scene;
use crate::shape::{Cube, Shape, Sphere};
use crate::stats::RayStats;

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
fn unstretch(a: f32, x: f32) -> f32 {
    if a < 1e-3 {
        x
    } else {
        (x * a.sinh()).asinh() / a
    }
}

/// The a > 0 with a / sinh(a) = c for c ∈ (0, 1) (0 when c ≥ 1).
fn stretch_for(c: f32) -> f32 {
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
    pub map: SurfaceMap,
    pub kind: SurfaceKind,
    pub tex: TexMap,
    /// The scene primitive.
    pub prim: u32,
    /// Sub-index within the primitive (box face, polyhedron plane).
    pub face: u32,
    pub props: SurfaceProps,
    /// First root element and the root grid (triangles: 1 × 1).
    pub first_root: u32,
    pub nu: u32,
    pub nv: u32,
    /// Whether each side (front, back) gets patches.
    pub active: [bool; 2],
    /// Object index when the surface bounds a closed solid (sphere, box, polyhedron).
    pub solid: Option<u32>,
}

/// A node of the element forest.
#[derive(Clone, Debug)]
pub(crate) struct Element {
    pub surface: u32,
    /// Quad domains: (s0, t0, s1, t1). Triangle domains: unused.
    pub rect: [f32; 4],
    /// Triangle domains: the three parameter corners.
    pub tri: [[f32; 2]; 3],
    /// World corners (quads: (s0,t0), (s1,t0), (s1,t1), (s0,t1); triangles: a, b, c, c).
    pub corners: [Point3; 4],
    /// 3 or 4.
    pub nverts: u8,
    /// The true surface point at the parameter centre.
    pub centre: Point3,
    /// The unit front normal at the centre.
    pub normal: Vec3,
    /// The unit normal of the planar polygon, on the side of `normal`.
    pub pnormal: Vec3,
    /// Area of the planar polygon.
    pub area: f32,
    /// First of the four children, or NONE for a leaf.
    pub children: u32,
    /// The parent, or NONE for a root.
    pub parent: u32,
    /// Adaptive refinement depth (uniform splits of large triangles do not count).
    pub level: u8,
    /// Patch of each side (NONE when that side has none).
    pub patch: [u32; 2],
}

impl Element {
    /// The parameter point at local coordinates (a, b) ∈ [0,1]² (quads) or barycentrics of the
    /// element's second and third corners (triangles).
    #[inline]
    pub fn param(&self, tri: bool, a: f32, b: f32) -> (f32, f32) {
        if tri {
            let [p0, p1, p2] = self.tri;
            let c = 1.0 - a - b;
            (
                c * p0[0] + a * p1[0] + b * p2[0],
                c * p0[1] + a * p1[1] + b * p2[1],
            )
        } else {
            let [s0, t0, s1, t1] = self.rect;
            (s0 + (s1 - s0) * a, t0 + (t1 - t0) * b)
        }
    }

    /// The largest edge of the polygon.
    pub fn max_edge(&self) -> f32 {
        let n = self.nverts as usize;
        (0..n)
            .map(|k| self.corners[k].distance(self.corners[(k + 1) % n]))
            .fold(0.0, f32::max)
    }
}

/// A patch: one side of a leaf element, with its Lambertian data.
#[derive(Clone, Debug)]
pub(crate) struct Patch {
    pub elem: u32,
    /// 0 front, 1 back.
    pub side: u8,
    pub area: f64,
    /// Reflectance ρ per channel.
    pub rho: [f64; 3],
    /// Emitted radiosity E = π·L_e per channel.
    pub emit: [f64; 3],
    /// The centre on the true surface and the unit normal of this side.
    pub centre: Point3,
    pub normal: Vec3,
}

/// The Lambertian reflectance a material contributes to radiosity at `uv`: `None` for the
/// materials traced at display time (mirrors, dielectrics, conductors).
pub(crate) fn lambert_reflectance(m: &Material, uv: Point2) -> Option<Rgb> {
    match &m.model {
        Model::Diffuse { reflectance } => Some(reflectance.eval(uv)),
        Model::Phong { kd, .. }
        | Model::CookTorrance { kd, .. }
        | Model::Plastic { kd, .. }
        | Model::RoughPlastic { kd, .. } => Some(kd.eval(uv)),
        Model::Specular { .. } | Model::Dielectric { .. } | Model::Conductor { .. } => None,
    }
}

/// True when the material is only approximated by its diffuse part.
fn is_glossy(m: &Material) -> bool {
    matches!(
        m.model,
        Model::Phong { .. }
            | Model::CookTorrance { .. }
            | Model::Plastic { .. }
            | Model::RoughPlastic { .. }
    )
}

/// The scene cut into elements and patches.
#[derive(Clone, Debug, Default)]
pub(crate) struct Meshing {
    pub surfaces: Vec<Surface>,
    pub elements: Vec<Element>,
    /// Per scene primitive: first surface and count.
    pub prim_surfaces: Vec<(u32, u32)>,
    pub patches: Vec<Patch>,
    /// Elements split by adaptive refinement, in order (replayed when loading a cache).
    pub splits: Vec<u32>,
    /// Root elements (before refinement).
    pub base_elements: usize,
    pub patch_size: f32,
    /// The scene's size (bounding-box diagonal, or 10 when unbounded or empty).
    pub scale: f32,
    pub warnings: Vec<String>,
}

/// The default largest patch edge for a scene of diagonal `scale`.
pub(crate) fn default_patch_size(scale: f32) -> f32 {
    scale / 25.0
}

/// The scene's size: the diagonal of the bounded primitives, or 10.
pub(crate) fn scene_scale(scene: &Scene) -> (Bounds3, f32) {
    let b = scene.geometry.bounds();
    let d = if b.is_empty() || !b.is_finite() {
        0.0
    } else {
        b.diagonal().norm()
    };
    if d > 0.0 && d.is_finite() {
        (b, d)
    } else {
        (
            Bounds3::new(Point3::new(-5.0, -5.0, -5.0), Point3::new(5.0, 5.0, 5.0)),
            10.0,
        )
    }
}

/// The most root elements the patch size may ask for (it is raised beyond).
const MAX_ROOTS: usize = 250_000;

/// The total area of the scene's bounded surfaces (planes have a fixed number of patches).
fn total_area(scene: &Scene) -> f32 {
    let geo = &scene.geometry;
    let mut a = 0f32;
    for o in geo.objects() {
        a += match &o.shape {
            Shape::Parallelogram(p) => p.area(),
            Shape::Cube(c) => c.face_areas().iter().sum(),
            Shape::Plane(_) => 0.0,
            Shape::Sphere(_) | Shape::Disk(_) | Shape::Polyhedron(_) => {
                o.shape.bounds().map_or(0.0, |b| b.surface_area())
            }
            Shape::Csg(_) => 0.0,
        };
    }
    for m in geo.meshes() {
        a += (0..m.len() as u32).map(|t| m.area(t)).sum::<f32>();
    }
    if a.is_finite() {
        a
    } else {
        0.0
    }
}

/// Number of grid cells so that `len / n ≤ h` (at least `min`, at most 4096).
fn cells(len: f32, h: f32, min: u32) -> u32 {
    let n = (len / h).ceil();
    if n.is_finite() {
        (n as u32).clamp(min.max(1), 4096)
    } else {
        min.max(1)
    }
}

impl Meshing {
    /// Meshes `scene` with largest patch edge `patch_size` (`None`: from the scene's size).
    pub fn build(scene: &Scene, patch_size: Option<f32>, cull: bool) -> Meshing {
        let (bounds, scale) = scene_scale(scene);
        let mut h = match patch_size {
            Some(h) if h > 0.0 && h.is_finite() => h,
            _ => default_patch_size(scale),
        };
        // At most about MAX_ROOTS patches per side from the patch size alone.
        let area = total_area(scene);
        let h_min = (area / MAX_ROOTS as f32).sqrt();
        let mut warnings = Vec::new();
        if h < h_min && h_min.is_finite() {
            warnings.push(format!(
                "radiosity: a patch size of {h} would give more than {MAX_ROOTS} patches: using {h_min} instead"
            ));
            h = h_min;
        }
        let mut m = Meshing {
            patch_size: h,
            scale,
            warnings,
            ..Default::default()
        };
        let geo = &scene.geometry;
        let mut csg = 0usize;
        let mut glossy = 0usize;
        let mut traced = 0usize;
        for prim in 0..geo.prim_count() {
            let first = m.surfaces.len() as u32;
            match geo.prim(prim) {
                PrimRef::Object(o) => {
                    let obj = &geo.objects()[o as usize];
                    if let Shape::Csg(_) = obj.shape {
                        csg += 1;
                    }
                    m.add_shape(&obj.shape, prim, o, obj.props, h, bounds, scale);
                }
                PrimRef::Triangle { mesh, tri } => {
                    let me = &geo.meshes()[mesh as usize];
                    let [a, b, c] = me.vertices(tri);
                    let n = me.geometry(tri, 1.0 / 3.0, 1.0 / 3.0).n.to_vec();
                    let tex = if me.uvs.is_empty() {
                        TexMap::Same
                    } else {
                        let [ia, ib, ic] = me.indices[tri as usize];
                        TexMap::Bary([
                            me.uvs[ia as usize],
                            me.uvs[ib as usize],
                            me.uvs[ic as usize],
                        ])
                    };
                    m.add_surface(
                        SurfaceMap::Triangle { a, b, c, n },
                        SurfaceKind::MeshTriangle,
                        tex,
                        prim,
                        0,
                        me.props,
                        None,
                        h,
                    );
                }
            }
            let count = m.surfaces.len() as u32 - first;
            m.prim_surfaces.push((first, count));
        }
        for s in &m.surfaces {
            let mat = &scene.materials[s.props.material as usize];
            if is_glossy(mat) {
                glossy += 1;
            } else if lambert_reflectance(mat, Point2::new(0.5, 0.5)).is_none() {
                traced += 1;
            }
        }
        if csg > 0 {
            m.warnings.push(format!(
                "radiosity: {csg} CSG object(s) are not meshed into patches: they are shown black and do not block light in hemicube form factors"
            ));
        }
        if glossy > 0 {
            m.warnings.push(format!(
                "radiosity: {glossy} surface(s) with glossy materials (phong, cook_torrance, plastic) are approximated by their diffuse part"
            ));
        }
        if traced > 0 {
            m.warnings.push(format!(
                "radiosity: {traced} surface(s) with specular materials (mirror, glass, metal) are traced through at display time; in the solve they reflect nothing (hemicube) or are followed by the form-factor rays (raycast)"
            ));
        }
        m.base_elements = m.elements.len();
        m.set_active_sides(scene, cull);
        m.assign_patches(scene);
        if m.patches.len() > 20_000 {
            m.warnings.push(format!(
                "radiosity: {} patches (mesh triangles are patches at least): form factors grow with the square of the count",
                m.patches.len()
            ));
        }
        m
    }

    /// Adds the surfaces of an analytic shape.
    fn add_shape(
        &mut self,
        shape: &Shape,
        prim: u32,
        obj: u32,
        props: SurfaceProps,
        h: f32,
        bounds: Bounds3,
        scale: f32,
    ) {
        match shape {
            Shape::Parallelogram(p) => {
                let n = p.normal().to_vec();
                let map = SurfaceMap::Parallelogram {
                    p: p.p,
                    v: p.v,
                    w: p.w,
                    n,
                };
                let (nu, nv) = (cells(p.v.norm(), h, 1), cells(p.w.norm(), h, 1));
                self.add_grid(
                    map,
                    SurfaceKind::Parallelogram,
                    TexMap::Same,
                    prim,
                    0,
                    props,
                    None,
                    nu,
                    nv,
                );
            }
            Shape::Cube(c) => {
                let t = c.world_from_object;
                let ex = [
                    t.vector(Vec3::X * 2.0).norm(),
                    t.vector(Vec3::Y * 2.0).norm(),
                    t.vector(Vec3::Z * 2.0).norm(),
                ];
                for face in 0..6u32 {
                    let axis = (face / 2) as usize;
                    let sign = if face % 2 == 1 { 1.0 } else { -1.0 };
                    let mut nl = [0.0f32; 3];
                    nl[axis] = sign;
                    let n = t
                        .normal(Normal3::new(nl[0], nl[1], nl[2]))
                        .normalize()
                        .to_vec();
                    // The face's (a, b) axes (see `Cube::face_point`).
                    let (la, lb) = match axis {
                        0 => (ex[1], ex[2]),
                        1 => (ex[0], ex[2]),
                        _ => (ex[0], ex[1]),
                    };
                    let map = SurfaceMap::CubeFace { t, face, n };
                    self.add_grid(
                        map,
                        SurfaceKind::CubeFace,
                        TexMap::Same,
                        prim,
                        face,
                        props,
                        Some(obj),
                        cells(la, h, 1),
                        cells(lb, h, 1),
                    );
                }
            }
            Shape::Sphere(s) => {
                let b = s.bounds();
                let r = 0.5 * b.diagonal().x.max(b.diagonal().y).max(b.diagonal().z);
                let map = SurfaceMap::Sphere { sphere: s.clone() };
                let nv = cells(PI * r, h, 4);
                let nu = cells(2.0 * PI * r, h, 8);
                self.add_grid(
                    map,
                    SurfaceKind::Sphere,
                    TexMap::Same,
                    prim,
                    0,
                    props,
                    Some(obj),
                    nu,
                    nv,
                );
            }
            Shape::Disk(d) => {
                let t = d.world_from_object;
                let r = t.vector(Vec3::X).norm().max(t.vector(Vec3::Y).norm());
                let n = t.normal(Normal3::new(0.0, 0.0, 1.0)).normalize().to_vec();
                let map = SurfaceMap::Disk { t, n };
                self.add_grid(
                    map,
                    SurfaceKind::Disk,
                    TexMap::Same,
                    prim,
                    0,
                    props,
                    None,
                    cells(r, h, 1),
                    cells(2.0 * PI * r, h, 8),
                );
            }
            Shape::Plane(p) => {
                // A square around the scene's centre, 20 times as large as the scene and as the
                // plane's distance from it (so that it covers nearly everything the scene sees of
                // the plane), in 32 × 32 cells growing geometrically from twice the patch size
                // (or a tenth of the distance) at the centre.
                let t = p.world_from_object;
                let c = bounds.centroid();
                let q = t.inv_point(c);
                let (sx, sy) = (t.vector(Vec3::X).norm(), t.vector(Vec3::Y).norm());
                if !(sx > 0.0 && sy > 0.0) {
                    return;
                }
                let n = t.normal(Normal3::new(0.0, 0.0, 1.0)).normalize().to_vec();
                let dist = (c - t.point(Point3::new(q.x, q.y, 0.0))).norm();
                let half_world = 20.0 * scale.max(dist);
                let centre_cell = (2.0 * h).max(0.1 * dist);
                const CELLS: u32 = 32;
                let half = half_world / sx.max(sy);
                // Central cell width 2·a·half / (sinh(a)·CELLS) = centre_cell.
                let a = stretch_for(centre_cell * CELLS as f32 / (2.0 * half_world));
                let map = SurfaceMap::Plane {
                    t,
                    cx: q.x,
                    cy: q.y,
                    half,
                    a,
                    n,
                };
                let frame = Frame::from_normal(Normal3::new(0.0, 0.0, 1.0));
                let tex = TexMap::PlaneFrac {
                    t,
                    s: frame.s,
                    tt: frame.t,
                };
                self.add_grid(
                    map,
                    SurfaceKind::Plane,
                    tex,
                    prim,
                    0,
                    props,
                    None,
                    CELLS,
                    CELLS,
                );
            }
            Shape::Polyhedron(poly) => {
                let t = poly.world_from_object;
                let planes = poly.planes();
                let big = {
                    let b = poly.bounds();
                    let d = t
                        .inv_point(b.min)
                        .to_vec()
                        .norm()
                        .max(t.inv_point(b.max).to_vec().norm());
                    4.0 * d.max(1.0)
                };
                for (k, &(n, d)) in planes.iter().enumerate() {
                    let f = Frame::from_normal(n.to_normal());
                    let c = n * d;
                    let mut poly_pts: Vec<Vec3> = vec![
                        c + (f.s + f.t) * big,
                        c + (f.t - f.s) * big,
                        c - (f.s + f.t) * big,
                        c + (f.s - f.t) * big,
                    ];
                    // Counter-clockwise around n: s × t = n, so (+,+), (−,+), (−,−), (+,−) is CCW.
                    for (j, &(m, e)) in planes.iter().enumerate() {
                        if j != k {
                            poly_pts = clip_halfspace(&poly_pts, m, e);
                        }
                    }
                    if poly_pts.len() < 3 {
                        continue;
                    }
                    let world: Vec<Point3> =
                        poly_pts.iter().map(|p| t.point(p.to_point())).collect();
                    let nw = poly.plane_normal(k as u32).to_vec();
                    let tex = TexMap::PlaneFrac { t, s: f.s, tt: f.t };
                    for i in 1..world.len() - 1 {
                        let map = SurfaceMap::Triangle {
                            a: world[0],
                            b: world[i],
                            c: world[i + 1],
                            n: nw,
                        };
                        self.add_surface(
                            map,
                            SurfaceKind::PolyFan,
                            tex.clone(),
                            prim,
                            k as u32,
                            props,
                            Some(obj),
                            h,
                        );
                    }
                }
            }
            Shape::Csg(_) => {}
        }
    }

    /// Adds a triangle surface, split uniformly until its edges are at most `h`.
    fn add_surface(
        &mut self,
        map: SurfaceMap,
        kind: SurfaceKind,
        tex: TexMap,
        prim: u32,
        face: u32,
        props: SurfaceProps,
        solid: Option<u32>,
        h: f32,
    ) {
        let sid = self.surfaces.len() as u32;
        let root = self.elements.len() as u32;
        self.surfaces.push(Surface {
            map,
            kind,
            tex,
            prim,
            face,
            props,
            first_root: root,
            nu: 1,
            nv: 1,
            active: [false; 2],
            solid,
        });
        let e = self.make_tri(sid, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], 0);
        self.elements.push(e);
        // Uniform 4-way splits (at most 10 levels: a million sub-triangles).
        let mut level = vec![root];
        for _ in 0..10 {
            if level
                .iter()
                .all(|&i| self.elements[i as usize].max_edge() <= h)
            {
                break;
            }
            let mut next = Vec::with_capacity(level.len() * 4);
            for &i in &level {
                let c = self.split(i, false);
                next.extend(c..c + 4);
            }
            level = next;
        }
    }

    /// Adds a quad surface with an `nu × nv` grid of root elements.
    fn add_grid(
        &mut self,
        map: SurfaceMap,
        kind: SurfaceKind,
        tex: TexMap,
        prim: u32,
        face: u32,
        props: SurfaceProps,
        solid: Option<u32>,
        nu: u32,
        nv: u32,
    ) {
        let sid = self.surfaces.len() as u32;
        let first = self.elements.len() as u32;
        self.surfaces.push(Surface {
            map,
            kind,
            tex,
            prim,
            face,
            props,
            first_root: first,
            nu,
            nv,
            active: [false; 2],
            solid,
        });
        for j in 0..nv {
            for i in 0..nu {
                let rect = [
                    i as f32 / nu as f32,
                    j as f32 / nv as f32,
                    (i + 1) as f32 / nu as f32,
                    (j + 1) as f32 / nv as f32,
                ];
                let e = self.make_quad(sid, rect, 0);
                self.elements.push(e);
            }
        }
    }

    fn make_quad(&self, sid: u32, rect: [f32; 4], level: u8) -> Element {
        let map = &self.surfaces[sid as usize].map;
        let [s0, t0, s1, t1] = rect;
        let corners = [
            map.point(s0, t0),
            map.point(s1, t0),
            map.point(s1, t1),
            map.point(s0, t1),
        ];
        let (sc, tc) = (0.5 * (s0 + s1), 0.5 * (t0 + t1));
        let centre = map.point(sc, tc);
        let normal = map.normal(sc, tc);
        let cross = (corners[2] - corners[0]).cross(corners[3] - corners[1]);
        finish(
            sid,
            rect,
            [[0.0; 2]; 3],
            corners,
            4,
            centre,
            normal,
            cross,
            level,
        )
    }

    fn make_tri(&self, sid: u32, tri: [[f32; 2]; 3], level: u8) -> Element {
        let map = &self.surfaces[sid as usize].map;
        let [a, b, c] = tri.map(|p| map.point(p[0], p[1]));
        let (sc, tc) = (
            (tri[0][0] + tri[1][0] + tri[2][0]) / 3.0,
            (tri[0][1] + tri[1][1] + tri[2][1]) / 3.0,
        );
        let centre = map.point(sc, tc);
        let normal = map.normal(sc, tc);
        let cross = (b - a).cross(c - a);
        finish(
            sid,
            [0.0; 4],
            tri,
            [a, b, c, c],
            3,
            centre,
            normal,
            cross,
            level,
        )
    }

    /// Splits element `i` into four children (one refinement level deeper when `refine`);
    /// returns the index of the first.
    pub fn split(&mut self, i: u32, refine: bool) -> u32 {
        let e = self.elements[i as usize].clone();
        let first = self.elements.len() as u32;
        let tri = self.surfaces[e.surface as usize].map.is_triangle();
        let level = if refine {
            e.level.saturating_add(1)
        } else {
            e.level
        };
        let kids: Vec<Element> = if tri {
            let [p0, p1, p2] = e.tri;
            let mid = |a: [f32; 2], b: [f32; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
            let (m01, m12, m02) = (mid(p0, p1), mid(p1, p2), mid(p0, p2));
            [
                [p0, m01, m02],
                [m01, p1, m12],
                [m02, m12, p2],
                [m12, m02, m01],
            ]
            .into_iter()
            .map(|t| self.make_tri(e.surface, t, level))
            .collect()
        } else {
            let [s0, t0, s1, t1] = e.rect;
            let (sm, tm) = (0.5 * (s0 + s1), 0.5 * (t0 + t1));
            [
                [s0, t0, sm, tm],
                [sm, t0, s1, tm],
                [s0, tm, sm, t1],
                [sm, tm, s1, t1],
            ]
            .into_iter()
            .map(|r| self.make_quad(e.surface, r, level))
            .collect()
        };
        self.elements.extend(kids.into_iter().map(|mut k| {
            k.parent = i;
            k
        }));
        let el = &mut self.elements[i as usize];
        el.children = first;
        el.patch = [NONE; 2];
        first
    }

    /// Decides which sides of which surfaces get patches.
    fn set_active_sides(&mut self, scene: &Scene, cull: bool) {
        // Points of every emitter, to find closed solids with a light inside.
        let mut emitter_points = Vec::new();
        for s in &self.surfaces {
            if s.props.emission.is_some() {
                for e in
                    &self.elements[s.first_root as usize..(s.first_root + s.nu * s.nv) as usize]
                {
                    emitter_points.push((s.prim, e.centre));
                }
            }
        }
        let escape_test = cull
            && scene.background.is_black()
            && scene
                .lights
                .iter()
                .all(|l| matches!(l, crate::light::Light::Area(_)));
        let mut stats = RayStats::default();
        for si in 0..self.surfaces.len() {
            let s = &self.surfaces[si];
            let mat = &scene.materials[s.props.material as usize];
            let rho = lambert_reflectance(mat, Point2::new(0.5, 0.5)).is_some();
            let mut active = [false; 2];
            for (side, a) in active.iter_mut().enumerate() {
                let reflects = rho && (side == 0 || mat.two_sided);
                let emits = s
                    .props
                    .emission
                    .is_some_and(|e| side == 0 || scene.emissions[e as usize].two_sided);
                *a = reflects || emits;
                if !*a || emits || !cull {
                    continue;
                }
                if side == 1 {
                    if let Some(obj) = s.solid {
                        // The inside of a closed solid: lit only by an emitter inside it.
                        let shape = &scene.geometry.objects()[obj as usize].shape;
                        *a = emitter_points
                            .iter()
                            .any(|&(p, q)| p != s.prim && solid_contains(shape, q));
                        continue;
                    }
                }
                if escape_test && s.solid.is_none() {
                    *a = !self.all_rays_escape(scene, si, side, &mut stats);
                }
            }
            self.surfaces[si].active = active;
        }
    }

    /// True when every one of a few test rays leaving `side` of surface `si` escapes the scene.
    fn all_rays_escape(&self, scene: &Scene, si: usize, side: usize, stats: &mut RayStats) -> bool {
        const N: u32 = 32;
        let s = &self.surfaces[si];
        let tri = s.map.is_triangle();
        for k in 0..N {
            let [a, b] = cmj(k, N, 0x9e37_79b9 ^ si as u32);
            let (a, b) = if tri {
                let (b1, b2) = warp::square_to_uniform_triangle([a, b]);
                (b1, b2)
            } else {
                (a, b)
            };
            let p = s.map.point(a, b);
            let mut n = s.map.normal(a, b);
            if side == 1 {
                n = -n;
            }
            let d = Frame::from_normal(n.to_normal()).to_world(warp::square_to_cosine_hemisphere(
                cmj(k, N, 0x85eb_ca6b ^ si as u32),
            ));
            if scene
                .intersect(&Ray::spawn(p, n.to_normal(), d), stats)
                .is_some()
            {
                return false;
            }
        }
        true
    }

    /// Gives patches to the active sides of all leaf elements, computing ρ and E.
    pub fn assign_patches(&mut self, scene: &Scene) {
        self.patches.clear();
        for i in 0..self.elements.len() {
            let e = &self.elements[i];
            if e.children != NONE {
                continue;
            }
            let s = &self.surfaces[e.surface as usize];
            let mut ids = [NONE; 2];
            if e.area > 0.0 && e.area.is_finite() {
                for (side, id) in ids.iter_mut().enumerate() {
                    if !s.active[side] {
                        continue;
                    }
                    let (rho, emit) = self.side_data(scene, s, e, side);
                    *id = self.patches.len() as u32;
                    let n = if side == 0 { e.normal } else { -e.normal };
                    self.patches.push(Patch {
                        elem: i as u32,
                        side: side as u8,
                        area: e.area as f64,
                        rho,
                        emit,
                        centre: e.centre,
                        normal: n,
                    });
                }
            }
            self.elements[i].patch = ids;
        }
    }

    /// The mean reflectance and emitted radiosity of one side of an element (textures averaged
    /// over a 3 × 3 grid).
    fn side_data(
        &self,
        scene: &Scene,
        s: &Surface,
        e: &Element,
        side: usize,
    ) -> ([f64; 3], [f64; 3]) {
        let mat = &scene.materials[s.props.material as usize];
        let emission = s
            .props
            .emission
            .map(|k| &scene.emissions[k as usize])
            .filter(|em| side == 0 || em.two_sided);
        let reflects = side == 0 || mat.two_sided;
        let tri = s.map.is_triangle();
        let mut rho = [0f64; 3];
        let mut emit = [0f64; 3];
        const G: usize = 3;
        for j in 0..G {
            for i in 0..G {
                let (mut a, mut b) = ((i as f32 + 0.5) / G as f32, (j as f32 + 0.5) / G as f32);
                if tri {
                    (a, b) = warp::square_to_uniform_triangle([a, b]);
                }
                let (ps, pt) = e.param(tri, a, b);
                let uv = self.tex_uv(s, ps, pt);
                if reflects {
                    if let Some(r) = lambert_reflectance(mat, uv) {
                        rho[0] += r.r as f64;
                        rho[1] += r.g as f64;
                        rho[2] += r.b as f64;
                    }
                }
                if let Some(em) = emission {
                    let l = em.radiance.eval(uv);
                    emit[0] += l.r as f64;
                    emit[1] += l.g as f64;
                    emit[2] += l.b as f64;
                }
            }
        }
        let k = 1.0 / (G * G) as f64;
        // ρ ∈ [0, 1) keeps the system solvable.
        let rho = rho.map(|x| (x * k).clamp(0.0, 0.999));
        let emit = emit.map(|x| (x * k * std::f64::consts::PI).max(0.0));
        (rho, emit)
    }

    /// Texture coordinates of the surface point (s, t).
    pub fn tex_uv(&self, s: &Surface, ps: f32, pt: f32) -> Point2 {
        match &s.tex {
            TexMap::Same => Point2::new(ps, pt),
            TexMap::Bary([a, b, c]) => {
                let w = 1.0 - ps - pt;
                Point2::new(w * a.x + ps * b.x + pt * c.x, w * a.y + ps * b.y + pt * c.y)
            }
            TexMap::PlaneFrac { t, s: fs, tt } => {
                let q = t.inv_point(s.map.point(ps, pt)).to_vec();
                let (a, b) = (q.dot(*fs), q.dot(*tt));
                Point2::new(a - a.floor(), b - b.floor())
            }
        }
    }

    /// The leaf element containing a hit, with the local coordinates of the hit in it.
    pub fn locate(&self, hit: &Hit, si: &SurfaceInteraction) -> Option<(u32, [f32; 2])> {
        let &(first, count) = self.prim_surfaces.get(hit.prim as usize)?;
        if count == 0 {
            return None;
        }
        let s0 = &self.surfaces[first as usize];
        let (sid, s, t) = match s0.kind {
            SurfaceKind::Parallelogram | SurfaceKind::MeshTriangle => (first, hit.uv[0], hit.uv[1]),
            SurfaceKind::CubeFace => {
                let f = hit.sub.min(count - 1);
                (first + f, si.uv.x, si.uv.y)
            }
            SurfaceKind::Sphere => (first, si.uv.x, si.uv.y),
            SurfaceKind::Disk => {
                let (x, y) = (hit.uv[0], hit.uv[1]);
                let mut phi = y.atan2(x) / (2.0 * PI);
                if phi < 0.0 {
                    phi += 1.0;
                }
                (first, (x * x + y * y).sqrt(), phi)
            }
            SurfaceKind::Plane => {
                let SurfaceMap::Plane {
                    t, cx, cy, half, a, ..
                } = &s0.map
                else {
                    return None;
                };
                let q = t.inv_point(si.p);
                let u = |x: f32| 0.5 * (unstretch(*a, (x / half).clamp(-1.0, 1.0)) + 1.0);
                (first, u(q.x - cx), u(q.y - cy))
            }
            SurfaceKind::PolyFan => {
                // The fan triangle of face `sub` that contains the point best.
                let mut best: Option<(u32, f32, f32, f32)> = None;
                for k in first..first + count {
                    let sk = &self.surfaces[k as usize];
                    if sk.face != hit.sub {
                        continue;
                    }
                    let SurfaceMap::Triangle { a, b, c, .. } = &sk.map else {
                        continue;
                    };
                    let (b1, b2) = barycentric(*a, *b, *c, si.p);
                    let inside = b1.min(b2).min(1.0 - b1 - b2);
                    if best.is_none_or(|x| inside > x.3) {
                        best = Some((k, b1, b2, inside));
                    }
                }
                let (k, b1, b2, _) = best?;
                (k, b1, b2)
            }
        };
        Some(self.descend(sid, s, t))
    }

    /// The leaf element of surface `sid` at parameters (s, t) and the local coordinates in it.
    pub fn descend(&self, sid: u32, s: f32, t: f32) -> (u32, [f32; 2]) {
        let sf = &self.surfaces[sid as usize];
        let fix = |x: f32| {
            if x.is_finite() {
                x.clamp(0.0, 1.0)
            } else {
                0.5
            }
        };
        let (s, t) = (fix(s), fix(t));
        if sf.map.is_triangle() {
            let mut e = sf.first_root;
            loop {
                let el = &self.elements[e as usize];
                let [p0, p1, p2] = el.tri;
                let (l1, l2) = bary2(p0, p1, p2, [s, t]);
                let l0 = 1.0 - l1 - l2;
                if el.children == NONE {
                    return (e, [l1.clamp(0.0, 1.0), l2.clamp(0.0, 1.0)]);
                }
                let k = if l0 >= 0.5 {
                    0
                } else if l1 >= 0.5 {
                    1
                } else if l2 >= 0.5 {
                    2
                } else {
                    3
                };
                e = el.children + k;
            }
        } else {
            let i = ((s * sf.nu as f32) as u32).min(sf.nu - 1);
            let j = ((t * sf.nv as f32) as u32).min(sf.nv - 1);
            let mut e = sf.first_root + j * sf.nu + i;
            loop {
                let el = &self.elements[e as usize];
                let [s0, t0, s1, t1] = el.rect;
                if el.children == NONE {
                    let a = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.5 };
                    let b = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.5 };
                    return (e, [a.clamp(0.0, 1.0), b.clamp(0.0, 1.0)]);
                }
                let k = (s >= 0.5 * (s0 + s1)) as u32 + 2 * (t >= 0.5 * (t0 + t1)) as u32;
                e = el.children + k;
            }
        }
    }

    /// Elements' and patches' memory in bytes.
    pub fn bytes(&self) -> usize {
        self.elements.len() * std::mem::size_of::<Element>()
            + self.patches.len() * std::mem::size_of::<Patch>()
            + self.surfaces.len() * std::mem::size_of::<Surface>()
            + self.prim_surfaces.len() * 8
    }
}

/// Completes an element from its corners and the polygon's cross product (2·area·normal).
fn finish(
    surface: u32,
    rect: [f32; 4],
    tri: [[f32; 2]; 3],
    corners: [Point3; 4],
    nverts: u8,
    centre: Point3,
    normal: Vec3,
    cross: Vec3,
    level: u8,
) -> Element {
    let len = cross.norm();
    let area = if len.is_finite() { 0.5 * len } else { 0.0 };
    let normal = if normal.is_finite() && normal.norm() > 0.0 {
        normal
    } else {
        Vec3::Z
    };
    let mut pnormal = if len > 0.0 && len.is_finite() {
        cross / len
    } else {
        normal
    };
    if pnormal.dot(normal) < 0.0 {
        pnormal = -pnormal;
    }
    Element {
        surface,
        rect,
        tri,
        corners,
        nverts,
        centre,
        normal,
        pnormal,
        area,
        children: NONE,
        parent: NONE,
        level,
        patch: [NONE; 2],
    }
}

/// Clips a convex polygon (object space) by the half-space n·x ≤ d.
fn clip_halfspace(poly: &[Vec3], n: Vec3, d: f32) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (fa, fb) = (n.dot(a) - d, n.dot(b) - d);
        if fa <= 0.0 {
            out.push(a);
        }
        if (fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0) {
            out.push(a + (b - a) * (fa / (fa - fb)));
        }
    }
    out
}

/// Barycentrics (of b and c) of the projection of `p` onto the triangle's plane.
fn barycentric(a: Point3, b: Point3, c: Point3, p: Point3) -> (f32, f32) {
    let (e1, e2, q) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (q1, q2) = (q.dot(e1), q.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if !(det.abs() > 0.0) {
        return (1.0 / 3.0, 1.0 / 3.0);
    }
    ((d22 * q1 - d12 * q2) / det, (d11 * q2 - d12 * q1) / det)
}

/// Barycentrics (of p1 and p2) of the 2D point `q` in the triangle p0 p1 p2.
fn bary2(p0: [f32; 2], p1: [f32; 2], p2: [f32; 2], q: [f32; 2]) -> (f32, f32) {
    let (e1, e2) = (
        [p1[0] - p0[0], p1[1] - p0[1]],
        [p2[0] - p0[0], p2[1] - p0[1]],
    );
    let d = [q[0] - p0[0], q[1] - p0[1]];
    let det = e1[0] * e2[1] - e1[1] * e2[0];
    if det == 0.0 {
        return (1.0 / 3.0, 1.0 / 3.0);
    }
    (
        (d[0] * e2[1] - d[1] * e2[0]) / det,
        (e1[0] * d[1] - e1[1] * d[0]) / det,
    )
}

/// True when the world point `p` is inside the closed solid `shape`.
fn solid_contains(shape: &Shape, p: Point3) -> bool {
    match shape {
        Shape::Sphere(s) => s.contains(p),
        Shape::Cube(c) => {
            let q = c.world_from_object.inv_point(p);
            q.x.abs() < 1.0 && q.y.abs() < 1.0 && q.z.abs() < 1.0
        }
        Shape::Polyhedron(poly) => {
            let q = poly.world_from_object.inv_point(p).to_vec();
            poly.planes().iter().all(|&(n, d)| n.dot(q) < d)
        }
        _ => false,
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

    #[test]
    fn polygons_clip_to_half_spaces() {
        let sq = vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        let half = clip_halfspace(&sq, Vec3::X, 0.0);
        assert_eq!(half.len(), 4);
        assert!(half.iter().all(|p| p.x <= 0.0));
        assert!(clip_halfspace(&sq, Vec3::X, -2.0).is_empty());
        let (b1, b2) = barycentric(
            Point3::ORIGIN,
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.25, 0.5, 3.0),
        );
        assert!((b1 - 0.25).abs() < 1e-6 && (b2 - 0.5).abs() < 1e-6);
    }
}
