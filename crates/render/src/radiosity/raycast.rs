//! Ray-cast form factors: Monte Carlo estimation with visibility through the scene's
//! acceleration structure.
//!
//! Row i is estimated by `rays` rays (`RadiosityOptions::rays_per_patch`, default 2048) leaving
//! patch i: origins stratified over the patch (mapped onto the true surface), directions
//! cosine-distributed and stratified (correlated multi-jittered patterns). With the cosine
//! density cos θ/π, the fraction of rays whose first diffuse hit is patch j is an unbiased
//! estimate of F_ij = (1/A_i) ∫∫ cos θ_i cos θ_j V / (π r²) dA_j dA_i. Rays that hit a specular
//! surface (mirror, glass, metal) follow its sampled bounce with the mean of its weight, so the
//! solve includes light reflected and refracted by them (extended form factors).
//!
//! Small bright emitters would be found by few rays; so when the scene has at most 256 emitting
//! patches covering at most a tenth of the area, form factors towards them are instead
//! estimated by sampling point pairs (8 per emitting patch) with shadow rays and the disk
//! approximation
//! ΔF = V cos θ_i cos θ_j ΔA_j / (π r² + ΔA_j) (Wallace et al. 1989), and hemisphere rays that
//! land directly on them are ignored. The rows of the emitting patches themselves (which
//! progressive refinement shoots first) take their direct entries from the same estimates by
//! reciprocity, A_i F_ij = A_j F_ji, instead of the few hemisphere rays that would reach each
//! receiver.

use super::mesh::{lambert_reflectance, Meshing};
use super::row::{Row, RowAcc};
use super::NONE;
use crate::math::{Frame, Point2, Ray, Vec3, PI};
use crate::sampling::pcg::hash2;
use crate::sampling::sampler::cmj;
use crate::sampling::{warp, Sampler};
use crate::scene::Scene;
use crate::stats::RayStats;

/// Samples per emitting patch of the explicit emitter estimate.
const EMITTER_SAMPLES: u32 = 8;
/// Longest chain of specular bounces followed by a form-factor ray.
const MAX_SPECULAR: u32 = 8;

/// A point on patch `i` at the stratified sample `k` of `n` with pattern `pattern`: the point,
/// the side's unit normal.
pub(crate) fn patch_point(
    mesh: &Meshing,
    i: u32,
    k: u32,
    n: u32,
    pattern: u32,
) -> (crate::math::Point3, Vec3) {
    let p = &mesh.patches[i as usize];
    let e = &mesh.elements[p.elem as usize];
    let map = &mesh.surfaces[e.surface as usize].map;
    let tri = map.is_triangle();
    let [a, b] = cmj(k, n, pattern);
    let (a, b) = if tri {
        warp::square_to_uniform_triangle([a, b])
    } else {
        (a, b)
    };
    let (s, t) = e.param(tri, a, b);
    let mut nn = map.normal(s, t);
    if p.side == 1 {
        nn = -nn;
    }
    (map.point(s, t), nn)
}

/// The patches that emit, when they are few (at most 256) and small (at most a tenth of the
/// total area) enough for the explicit estimate.
pub(crate) fn emitter_list(mesh: &Meshing) -> Option<Vec<u32>> {
    let list: Vec<u32> = (0..mesh.patches.len() as u32)
        .filter(|&i| mesh.patches[i as usize].emit.iter().any(|&x| x > 0.0))
        .collect();
    let area: f64 = list.iter().map(|&i| mesh.patches[i as usize].area).sum();
    let total: f64 = mesh.patches.iter().map(|p| p.area).sum();
    (list.len() <= 256 && area <= 0.1 * total).then_some(list)
}

/// What ray-cast form factors are computed with.
pub(crate) struct RayCasting<'a> {
    /// The scene the rays are traced in.
    pub scene: &'a Scene,
    /// Its patches.
    pub mesh: &'a Meshing,
    /// Per material: traced through (mirrors, glass) rather than absorbing.
    pub traced: &'a [bool],
    /// Rays per row.
    pub rays: u32,
    /// The seed of the estimates.
    pub seed: u64,
    /// The emitting patches, sorted, when few enough to be aimed at directly.
    pub emitters: Option<&'a [u32]>,
}

impl RayCasting<'_> {
    /// Row `i` estimated with `self.rays` rays (deterministic for a given seed).
    pub(crate) fn row(&self, i: u32, acc: &mut RowAcc) -> Row {
        let (scene, mesh, traced, rays, seed, emitters) = (
            self.scene,
            self.mesh,
            self.traced,
            self.rays,
            self.seed,
            self.emitters,
        );
        let rays = rays.max(1);
        let h = hash2(seed, i as u64);
        let (pat_pos, pat_dir) = (h as u32, (h >> 32) as u32);
        let mut sampler = Sampler::new(seed ^ 0x5eed, i as u64);
        let mut stats = RayStats::default();
        let is_emitter = |j: u32| emitters.is_some_and(|l| l.binary_search(&j).is_ok());
        let w0 = 1.0 / rays as f64;
        // Hits nearer than this, or on a side without a patch, count as occluded.
        let near = 0.5 * mesh.patch_size;
        let mut occluded = 0f64;
        for k in 0..rays {
            let (x, n) = patch_point(mesh, i, k, rays, pat_pos);
            let d = Frame::from_normal(n.to_normal())
                .to_world(warp::square_to_cosine_hemisphere(cmj(k, rays, pat_dir)));
            let mut ray = Ray::spawn(x, n.to_normal(), d);
            let mut w = w0;
            for depth in 0..=MAX_SPECULAR {
                let Some(hit) = scene.intersect(&ray, &mut stats) else {
                    break;
                };
                let si = scene.geometry.interaction(&ray, &hit);
                if depth == 0 && hit.t * ray.d.norm() < near {
                    occluded += w0;
                }
                let m = si.props.material as usize;
                if traced.get(m).copied().unwrap_or(false) {
                    // Follow the specular bounce with its mean weight.
                    let mat = &scene.materials[m];
                    let bsdf = mat.bsdf(
                        si.shading_frame(),
                        si.uv,
                        &mut crate::spectrum::Wavelengths::Rgb,
                    );
                    let Some(s) = bsdf.sample(si.wo, sampler.next_1d(), sampler.next_2d()) else {
                        break;
                    };
                    w *= s.weight.average_rgb().max(0.0) as f64;
                    if !(w > 0.0) || depth == MAX_SPECULAR {
                        break;
                    }
                    ray = si.spawn_ray(s.wi);
                    continue;
                }
                let Some((e, _)) = mesh.locate(&hit, &si) else {
                    // Not meshed (CSG): an absorber.
                    if depth == 0 && hit.t * ray.d.norm() >= near {
                        occluded += w0;
                    }
                    break;
                };
                let side = if si.n.dot_vec(ray.d) < 0.0 { 0 } else { 1 };
                let j = mesh.elements[e as usize].patch[side];
                if depth == 0 && j == NONE && hit.t * ray.d.norm() >= near {
                    occluded += w0;
                }
                // Direct exchanges with emitters are estimated explicitly below.
                if j != NONE && j != i && !(depth == 0 && (is_emitter(j) || is_emitter(i))) {
                    acc.add(j, w);
                }
                break;
            }
        }
        if let Some(list) = emitters {
            if is_emitter(i) {
                // An emitter's row (what progressive refinement shoots with) by reciprocity from
                // the receivers' explicit estimates: A_i F_ij = A_j F_ji.
                let ai = mesh.patches[i as usize].area;
                for j in 0..mesh.patches.len() as u32 {
                    if j == i {
                        continue;
                    }
                    let f = explicit(scene, mesh, j, i, seed, &mut stats);
                    if f > 0.0 {
                        acc.add(j, f * mesh.patches[j as usize].area / ai);
                    }
                }
            } else {
                for &j in list {
                    if j == i {
                        continue;
                    }
                    let f = explicit(scene, mesh, i, j, seed, &mut stats);
                    if f > 0.0 {
                        acc.add(j, f);
                    }
                }
            }
        }
        let mut row = acc.finish();
        row.occluded = occluded as f32;
        row
    }
}

/// The form factor from patch `i` to the emitting patch `j` by point pairs (the same pairs
/// whichever row asks for it): ΔF = V cos θ_i cos θ_j ΔA_j / (π r² + ΔA_j), ΔA_j = A_j / M.
fn explicit(scene: &Scene, mesh: &Meshing, i: u32, j: u32, seed: u64, stats: &mut RayStats) -> f64 {
    let h = hash2(seed, i as u64);
    let (pat_pos, pat_dir) = (h as u32, (h >> 32) as u32);
    let pj = &mesh.patches[j as usize];
    let da = pj.area as f32 / EMITTER_SAMPLES as f32;
    let mut sum = 0f64;
    for k in 0..EMITTER_SAMPLES {
        let (x, nx) = patch_point(mesh, i, k, EMITTER_SAMPLES, pat_pos ^ j);
        let (y, ny) = patch_point(mesh, j, k, EMITTER_SAMPLES, pat_dir ^ i);
        let r = y - x;
        let d2 = r.squared_norm();
        if !(d2 > 0.0) {
            continue;
        }
        let dist = d2.sqrt();
        let (ci, cj) = (nx.dot(r) / dist, -ny.dot(r) / dist);
        if ci <= 0.0 || cj <= 0.0 {
            continue;
        }
        let shadow = Ray::spawn_between(x, nx.to_normal(), y, ny.to_normal());
        if scene.occluded(&shadow, stats) {
            continue;
        }
        sum += (ci * cj * da / (PI * d2 + da)) as f64;
    }
    sum
}

/// Per material: true when it is traced through (no Lambertian part).
pub(crate) fn traced_materials(scene: &Scene) -> Vec<bool> {
    scene
        .materials
        .iter()
        .map(|m| lambert_reflectance(m, Point2::new(0.5, 0.5)).is_none())
        .collect()
}
