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

mod element;
mod locate;
mod sides;
mod surface;

pub(crate) use element::{Element, Patch};
pub(crate) use sides::lambert_reflectance;
pub(crate) use surface::{Surface, SurfaceKind, SurfaceMap, TexMap};

use surface::SurfaceSpec;

use sides::is_glossy;
use surface::stretch_for;

use crate::geometry::{Object, PrimRef};
use crate::math::{Bounds3, Frame, Normal3, Point2, Point3, Vec3, PI};
use crate::scene::Scene;
use crate::shape::Shape;

/// The scene cut into elements and patches.
#[derive(Clone, Debug, Default)]
pub(crate) struct Meshing {
    /// Every surface of the scene.
    pub surfaces: Vec<Surface>,
    /// Every element (the nodes of the subdivision forests).
    pub elements: Vec<Element>,
    /// Per scene primitive: first surface and count.
    pub prim_surfaces: Vec<(u32, u32)>,
    /// The patches (sides of leaf elements that take part).
    pub patches: Vec<Patch>,
    /// Elements split by adaptive refinement, in order (replayed when loading a cache).
    pub splits: Vec<u32>,
    /// Root elements (before refinement).
    pub base_elements: usize,
    /// The largest patch edge used.
    pub patch_size: f32,
    /// The scene's size (bounding-box diagonal, or 10 when unbounded or empty).
    pub scale: f32,
    /// Approximations worth telling the user about.
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

/// The most root elements the patch size may ask for (it is raised beyond, with a warning):
/// form factors take time growing faster than the patch count, so a tiny `--patch-size` must
/// not ask for hours of work (docs/limits.md).
const MAX_ROOTS: usize = 16_384;

/// The total area of the scene's bounded surfaces (planes have a fixed number of patches).
fn total_area(scene: &Scene) -> f32 {
    let geo = &scene.geometry;
    let mut a = 0f32;
    for o in geo.objects() {
        a += match &o.shape {
            Shape::Parallelogram(p) => p.area(),
            Shape::Polygon(p) => p.area(),
            Shape::Cube(c) => c.face_areas().iter().sum(),
            Shape::Plane(_) => 0.0,
            Shape::Sphere(_) | Shape::Disk(_) | Shape::Polyhedron(_) | Shape::Cylinder(_) => {
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
                    m.add_shape(obj, (prim, o), h, bounds, scale);
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
                        SurfaceSpec {
                            map: SurfaceMap::Triangle { a, b, c, n },
                            kind: SurfaceKind::MeshTriangle,
                            tex,
                            prim,
                            face: 0,
                            props: me.props,
                            solid: None,
                        },
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
        let instances = scene.geometry.instances().len();
        if instances > 0 {
            m.warnings.push(format!(
                "radiosity: {instances} instance(s) of shape groups are not meshed into patches: they are shown black and do not block light in hemicube form factors"
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

    /// Adds the surfaces of `object`, an analytic shape (scene primitive `prim`, object `obj`).
    fn add_shape(
        &mut self,
        object: &Object,
        (prim, obj): (u32, u32),
        h: f32,
        bounds: Bounds3,
        scale: f32,
    ) {
        let props = object.props;
        match &object.shape {
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
                    SurfaceSpec {
                        map,
                        kind: SurfaceKind::Parallelogram,
                        tex: TexMap::Same,
                        prim,
                        face: 0,
                        props,
                        solid: None,
                    },
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
                        SurfaceSpec {
                            map,
                            kind: SurfaceKind::CubeFace,
                            tex: TexMap::Same,
                            prim,
                            face,
                            props,
                            solid: Some(obj),
                        },
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
                    SurfaceSpec {
                        map,
                        kind: SurfaceKind::Sphere,
                        tex: TexMap::Same,
                        prim,
                        face: 0,
                        props,
                        solid: Some(obj),
                    },
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
                    SurfaceSpec {
                        map,
                        kind: SurfaceKind::Disk,
                        tex: TexMap::Same,
                        prim,
                        face: 0,
                        props,
                        solid: None,
                    },
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
                    SurfaceSpec {
                        map,
                        kind: SurfaceKind::Plane,
                        tex,
                        prim,
                        face: 0,
                        props,
                        solid: None,
                    },
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
                            SurfaceSpec {
                                map,
                                kind: SurfaceKind::PolyFan,
                                tex: tex.clone(),
                                prim,
                                face: k as u32,
                                props,
                                solid: Some(obj),
                            },
                            h,
                        );
                    }
                }
            }
            // Polygons and cylinders, like CSG, get no patches (radiosity leaves them black).
            Shape::Csg(_) | Shape::Polygon(_) | Shape::Cylinder(_) => {}
        }
    }

    /// Adds a triangle surface, split uniformly until its edges are at most `h`.
    fn add_surface(&mut self, spec: SurfaceSpec, h: f32) {
        let sid = self.surfaces.len() as u32;
        let root = self.elements.len() as u32;
        self.surfaces.push(spec.surface(root, 1, 1));
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
    fn add_grid(&mut self, spec: SurfaceSpec, nu: u32, nv: u32) {
        let sid = self.surfaces.len() as u32;
        let first = self.elements.len() as u32;
        self.surfaces.push(spec.surface(first, nu, nv));
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

    /// Elements' and patches' memory in bytes.
    pub fn bytes(&self) -> usize {
        self.elements.len() * std::mem::size_of::<Element>()
            + self.patches.len() * std::mem::size_of::<Patch>()
            + self.surfaces.len() * std::mem::size_of::<Surface>()
            + self.prim_surfaces.len() * 8
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

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
