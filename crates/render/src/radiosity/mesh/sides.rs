//! Which sides of which surfaces get patches (those that can reflect or emit and can be
//! reached by light), and each patch's Lambertian data.

use super::element::{Element, Patch};
use super::surface::{Surface, TexMap};
use super::Meshing;
use crate::color::Rgb;
use crate::material::{Material, Model};
use crate::math::{Frame, Point2, Point3, Ray};
use crate::radiosity::NONE;
use crate::sampling::sampler::cmj;
use crate::sampling::warp;
use crate::scene::Scene;
use crate::shape::Shape;
use crate::stats::RayStats;

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
pub(super) fn is_glossy(m: &Material) -> bool {
    matches!(
        m.model,
        Model::Phong { .. }
            | Model::CookTorrance { .. }
            | Model::Plastic { .. }
            | Model::RoughPlastic { .. }
    )
}

impl Meshing {
    /// Decides which sides of which surfaces get patches.
    pub(super) fn set_active_sides(&mut self, scene: &Scene, cull: bool) {
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
