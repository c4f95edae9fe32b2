//! Showing the solution from the camera.
//!
//! A camera ray finds its first surface; specular surfaces (mirror, glass, metal) are followed
//! through their sampled bounce (up to 16 bounces). On a diffuse surface the radiance is the
//! exact emitted radiance plus the reflected radiosity R = B − E divided by π, either
//! - **Gouraud** (default): R at each element corner is the mean of the patches that touch that
//!   point with a normal within 37° (so that creases keep their edges), including the patches
//!   of coarser neighbours whose edges pass through it (T-vertices), and is interpolated
//!   bilinearly (quads) or linearly (triangles) across the element;
//! - **flat**: the patch's own R;
//! - **final gather**: one bounce: direct light by sampling every light (shadow rays), plus
//!   `gather_rays` cosine-distributed rays that look up the Gouraud-interpolated R where they
//!   land (the classic way to hide the patch structure).

use super::mesh::Meshing;
use super::NONE;
use crate::color::Rgb;
use crate::math::{Frame, Point3, Ray};
use crate::sampling::{warp, Sampler};
use crate::scene::Scene;
use crate::spectrum::Wavelengths;
use crate::stats::RayStats;
use std::collections::HashMap;

/// Radiosity is solved and shown in RGB.
const RGB: Wavelengths = Wavelengths::Rgb;

/// Cosine of the largest angle between normals averaged at a vertex.
const CREASE_COS: f32 = 0.8;
/// Longest chain of specular bounces followed from the camera.
const MAX_SPECULAR: u32 = 16;

/// Per-patch display values: reflected radiance R/π at the corners and at the centre.
#[derive(Clone, Debug, Default)]
pub(crate) struct Shading {
    /// Per patch: the reflected radiosity averaged at its corners (Gouraud).
    pub corners: Vec<[Rgb; 4]>,
    /// Per patch: its own reflected radiosity.
    pub flat: Vec<Rgb>,
}

/// Quantised position key.
fn key(p: Point3, q: f32) -> (i64, i64, i64) {
    (
        (p.x / q).round() as i64,
        (p.y / q).round() as i64,
        (p.z / q).round() as i64,
    )
}

/// Reflected radiosity per corner of every patch, averaged over the patches touching each
/// corner (f64, per channel). Hidden patches (whose centre is covered, e.g. by a box standing
/// on them: see `Row::occluded`) count only where no visible patch touches the corner, so that
/// their darkness does not spread onto their visible neighbours.
pub(crate) fn corner_values(mesh: &Meshing, r: &[[f64; 3]], hidden: &[bool]) -> Vec<[[f64; 3]; 4]> {
    let q = (mesh.scale * 1e-5).max(f32::MIN_POSITIVE);
    let at = vertex_map(mesh, q);
    let mut out = Vec::with_capacity(mesh.patches.len());
    for (i, p) in mesh.patches.iter().enumerate() {
        let e = &mesh.elements[p.elem as usize];
        let nv = e.nverts as usize;
        let mut v = [[0f64; 3]; 4];
        for (k, vk) in v.iter_mut().enumerate().take(nv) {
            let mut sum = [0f64; 3];
            let mut w = 0f64;
            if let Some(list) = at.get(&key(e.corners[k], q)) {
                let mut last = NONE;
                for &j in list {
                    if j == last {
                        continue;
                    }
                    last = j;
                    if mesh.patches[j as usize].normal.dot(p.normal) < CREASE_COS {
                        continue;
                    }
                    let wj = if hidden.get(j as usize).copied().unwrap_or(false) {
                        1e-6
                    } else {
                        1.0
                    };
                    for c in 0..3 {
                        sum[c] += wj * r[j as usize][c];
                    }
                    w += wj;
                }
            }
            *vk = if w > 0.0 { sum.map(|s| s / w) } else { r[i] };
        }
        if nv == 3 {
            v[3] = v[2];
        }
        out.push(v);
    }
    out
}

/// The patches touching each point: every patch registers at its corners and at the points of
/// its edges where finer neighbours may have corners.
fn vertex_map(mesh: &Meshing, q: f32) -> HashMap<(i64, i64, i64), Vec<u32>> {
    let max_level = mesh.elements.iter().map(|e| e.level).max().unwrap_or(0);
    let mut at: HashMap<(i64, i64, i64), Vec<u32>> = HashMap::new();
    for (i, p) in mesh.patches.iter().enumerate() {
        let e = &mesh.elements[p.elem as usize];
        let nv = e.nverts as usize;
        let steps = 1u32 << (max_level - e.level).min(6);
        for k in 0..nv {
            let (a, b) = (e.corners[k], e.corners[(k + 1) % nv]);
            for s in 0..steps {
                let pt = a.lerp(b, s as f32 / steps as f32);
                at.entry(key(pt, q)).or_default().push(i as u32);
            }
        }
    }
    at
}

/// Per patch: true when a corner is shared with a visible patch of the same orientation while
/// the patch itself is hidden (the edge of the region under a box or behind a light).
pub(crate) fn hidden_boundary(mesh: &Meshing, hidden: &[bool]) -> Vec<bool> {
    let q = (mesh.scale * 1e-5).max(f32::MIN_POSITIVE);
    let at = vertex_map(mesh, q);
    mesh.patches
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if !hidden.get(i).copied().unwrap_or(false) {
                return false;
            }
            let e = &mesh.elements[p.elem as usize];
            e.corners[..e.nverts as usize].iter().any(|c| {
                at.get(&key(*c, q)).is_some_and(|list| {
                    list.iter().any(|&j| {
                        !hidden.get(j as usize).copied().unwrap_or(false)
                            && mesh.patches[j as usize].normal.dot(p.normal) >= CREASE_COS
                    })
                })
            })
        })
        .collect()
}

impl Shading {
    /// Display values from the reflected radiosity R of every patch.
    pub fn new(mesh: &Meshing, r: &[[f64; 3]], hidden: &[bool]) -> Self {
        let cv = corner_values(mesh, r, hidden);
        let to = |x: [f64; 3]| {
            Rgb::new(
                (x[0] / std::f64::consts::PI) as f32,
                (x[1] / std::f64::consts::PI) as f32,
                (x[2] / std::f64::consts::PI) as f32,
            )
        };
        Self {
            corners: cv.iter().map(|c| c.map(to)).collect(),
            flat: r.iter().map(|&x| to(x)).collect(),
        }
    }

    /// The interpolated reflected radiance of patch `p` at local coordinates `loc`.
    #[inline]
    pub fn gouraud(&self, mesh: &Meshing, p: u32, loc: [f32; 2]) -> Rgb {
        let c = &self.corners[p as usize];
        let e = &mesh.elements[mesh.patches[p as usize].elem as usize];
        let [a, b] = loc;
        if e.nverts == 3 {
            c[0] * (1.0 - a - b).max(0.0) + c[1] * a + c[2] * b
        } else {
            c[0] * ((1.0 - a) * (1.0 - b))
                + c[1] * (a * (1.0 - b))
                + c[2] * (a * b)
                + c[3] * ((1.0 - a) * b)
        }
    }
}

/// How the solution is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mode {
    Gouraud,
    Flat,
    Gather(u32),
}

/// The display part of the radiosity integrator.
#[derive(Clone, Debug)]
pub(crate) struct Display {
    /// Per-patch colours.
    pub shading: Shading,
    /// Per material: traced through at display time (mirrors, glass).
    pub traced: Vec<bool>,
    /// How the solution is shown.
    pub mode: Mode,
}

impl Display {
    /// The reflected radiance stored for a diffuse hit (patch lookup and interpolation);
    /// `None` when the hit has no patch on its side.
    fn stored(
        &self,
        mesh: &Meshing,
        hit: &crate::interaction::Hit,
        si: &crate::interaction::SurfaceInteraction,
        gouraud: bool,
    ) -> Option<Rgb> {
        let (e, loc) = mesh.locate(hit, si)?;
        let side = if si.n.dot_vec(si.wo) > 0.0 { 0 } else { 1 };
        let p = mesh.elements[e as usize].patch[side];
        if p == NONE {
            return None;
        }
        Some(if gouraud {
            self.shading.gouraud(mesh, p, loc)
        } else {
            self.shading.flat[p as usize]
        })
    }

    /// The radiance along a camera ray.
    pub fn radiance(
        &self,
        mesh: &Meshing,
        scene: &Scene,
        camera_ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let mut l = Rgb::BLACK;
        let mut beta = Rgb::WHITE;
        let mut ray = *camera_ray;
        for _ in 0..=MAX_SPECULAR {
            let Some(hit) = scene.intersect(&ray, stats) else {
                l += beta * scene.escaped(ray.d.normalize(), &RGB).to_rgb();
                break;
            };
            let si = scene.geometry.interaction(&ray, &hit);
            l += beta * scene.emitted(&si, &RGB).to_rgb();
            let m = si.props.material as usize;
            if self.traced.get(m).copied().unwrap_or(false) {
                let bsdf =
                    scene.materials[m].bsdf(si.shading_frame(), si.uv, &mut Wavelengths::Rgb);
                let Some(s) = bsdf.sample(si.wo, sampler.next_1d(), sampler.next_2d()) else {
                    break;
                };
                beta *= s.weight.to_rgb();
                if beta.is_black() {
                    break;
                }
                ray = si.spawn_ray(s.wi);
                continue;
            }
            match self.mode {
                Mode::Gouraud | Mode::Flat => {
                    if let Some(r) = self.stored(mesh, &hit, &si, self.mode == Mode::Gouraud) {
                        l += beta * r;
                    }
                }
                Mode::Gather(n) => l += beta * self.gather(mesh, scene, &si, n, sampler, stats),
            }
            break;
        }
        l
    }

    /// One final-gather bounce at a diffuse point.
    fn gather(
        &self,
        mesh: &Meshing,
        scene: &Scene,
        si: &crate::interaction::SurfaceInteraction,
        n: u32,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let mat = &scene.materials[si.props.material as usize];
        let bsdf = mat.bsdf(si.shading_frame(), si.uv, &mut Wavelengths::Rgb);
        let mut l = Rgb::BLACK;
        // Direct light: one sample of every light.
        for light in &scene.lights {
            let Some(s) = light.sample(
                &scene.geometry,
                &scene.emissions,
                si.p,
                sampler.next_2d(),
                &RGB,
            ) else {
                continue;
            };
            let f = bsdf.eval(si.wo, s.wi);
            if f.is_black() {
                continue;
            }
            let shadow = match s.target {
                crate::light::Target::Point(q) => si.spawn_ray_to(q),
                crate::light::Target::Surface(q, nq) => Ray::spawn_between(si.p, si.n, q, nq),
                crate::light::Target::Infinite => si.spawn_ray(s.wi),
            };
            if !scene.occluded(&shadow, stats) {
                l += (f * s.li).to_rgb() / s.pdf;
            }
        }
        // Indirect light: the stored reflected radiance where cosine rays land.
        let rho = super::mesh::lambert_reflectance(mat, si.uv).unwrap_or(Rgb::BLACK);
        let reflects = mat.two_sided || si.front_face();
        if n > 0 && reflects && !rho.is_black() {
            let nf = si.facing_normal();
            let frame = Frame::from_normal(nf);
            let mut sum = Rgb::BLACK;
            for _ in 0..n {
                let d = frame.to_world(warp::square_to_cosine_hemisphere(sampler.next_2d()));
                let r = si.spawn_ray(d);
                match scene.intersect(&r, stats) {
                    None => sum += scene.background,
                    Some(h) => {
                        let sj = scene.geometry.interaction(&r, &h);
                        if let Some(v) = self.stored(mesh, &h, &sj, true) {
                            sum += v;
                        }
                    }
                }
            }
            l += rho * sum / n as f32;
        }
        l
    }
}
