//! Light from lights that are not shapes: point, spot and distant lights, lights at infinity
//! (hemisphere, environment) and the background.
//!
//! Radiosity's emitters are patches; other lights enter the system as a source term: the
//! radiosity each patch reflects directly, ρ_i · Ē_i, where Ē_i is the irradiance averaged over
//! 16 stratified points of the patch, each with one sample of every light (shadow rays through
//! the scene) and one cosine-distributed ray for the background.

use super::mesh::Meshing;
use super::raycast::patch_point;
use crate::light::{Light, Target};
use crate::math::{Frame, Ray, PI};
use crate::sampling::sampler::cmj;
use crate::sampling::warp;
use crate::scene::Scene;
use crate::stats::RayStats;
use rayon::prelude::*;

/// Points per patch.
const POINTS: u32 = 16;

/// True when the scene has light besides emissive shapes.
pub(crate) fn has_other_lights(scene: &Scene) -> bool {
    !scene.background.is_black() || scene.lights.iter().any(|l| !matches!(l, Light::Area(_)))
}

/// The directly reflected radiosity ρ_i Ē_i of every patch (zeros when there are no such
/// lights).
pub(crate) fn direct_sources(scene: &Scene, mesh: &Meshing, seed: u64) -> Vec<[f64; 3]> {
    let n = mesh.patches.len();
    if !has_other_lights(scene) {
        return vec![[0.0; 3]; n];
    }
    (0..n as u32)
        .into_par_iter()
        .map(|i| {
            let p = &mesh.patches[i as usize];
            if p.rho.iter().all(|&r| r == 0.0) {
                return [0.0; 3];
            }
            let mut stats = RayStats::default();
            let mut e = [0f64; 3];
            let pattern = (seed as u32) ^ i.wrapping_mul(0x9e37_79b9);
            for k in 0..POINTS {
                let (x, nx) = patch_point(mesh, i, k, POINTS, pattern);
                let nn = nx.to_normal();
                for (li, light) in scene.lights.iter().enumerate() {
                    if matches!(light, Light::Area(_)) {
                        continue;
                    }
                    let u = cmj(k, POINTS, pattern ^ (li as u32).wrapping_mul(0x85eb_ca6b));
                    let rgb = &crate::spectrum::Wavelengths::Rgb;
                    let Some(s) = light.sample(&scene.geometry, &scene.emissions, x, u, rgb) else {
                        continue;
                    };
                    let cos = nx.dot(s.wi);
                    if cos <= 0.0 {
                        continue;
                    }
                    let shadow = match s.target {
                        Target::Point(q) | Target::Surface(q, _) => Ray::spawn_to(x, nn, q),
                        Target::Infinite => Ray::spawn(x, nn, s.wi),
                    };
                    if scene.occluded(&shadow, &mut stats) {
                        continue;
                    }
                    let w = cos / s.pdf;
                    e[0] += (s.li[0] * w) as f64;
                    e[1] += (s.li[1] * w) as f64;
                    e[2] += (s.li[2] * w) as f64;
                }
                if !scene.background.is_black() {
                    let d = Frame::from_normal(nn)
                        .to_world(warp::square_to_cosine_hemisphere(cmj(k, POINTS, !pattern)));
                    if scene.intersect(&Ray::spawn(x, nn, d), &mut stats).is_none() {
                        // E = ∫ L cos dω estimated with the density cos/π.
                        let bg = scene.background;
                        e[0] += (bg.r * PI) as f64;
                        e[1] += (bg.g * PI) as f64;
                        e[2] += (bg.b * PI) as f64;
                    }
                }
            }
            let k = 1.0 / POINTS as f64;
            [
                p.rho[0] * e[0] * k,
                p.rho[1] * e[1] * k,
                p.rho[2] * e[2] * k,
            ]
        })
        .collect()
}
