//! A radiosity solution: solved (or loaded from a cache), shown from any camera, saved as
//! bytes.

use super::options::{DisplayMode, RadiosityOptions};
use super::patches::{infos, PatchInfo};
use super::refine::compute;
use super::report::{CacheStatus, RadiosityOutcome, RadiosityReport};
use super::{cache, display, mesh, raycast, NONE};
use crate::color::Rgb;
use crate::math::Ray;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::stats::RayStats;
use std::time::Instant;

/// A solved scene: the patches, their radiosity, and what is needed to show them (the
/// `radiosity` integrator shows it).
#[derive(Clone, Debug)]
pub struct Radiosity {
    mesh: mesh::Meshing,
    b: Vec<[f64; 3]>,
    hidden: Vec<bool>,
    display: display::Display,
    report: RadiosityReport,
    fingerprint: u64,
}

/// A solution before it is prepared for display.
struct Solved {
    mesh: mesh::Meshing,
    b: Vec<[f64; 3]>,
    hidden: Vec<bool>,
    report: RadiosityReport,
    fingerprint: u64,
}

impl Radiosity {
    /// Meshes, computes form factors, solves and refines, or loads the solution from
    /// `opts.cache` when it matches the scene and the options.
    ///
    /// Non-finite emission or reflectance (which no solve can converge on) is taken as 0 on the
    /// initial patches, and the solver stops as soon as its residual is not finite; see
    /// [`Radiosity::try_solve`] to refuse such input instead.
    pub fn solve(scene: &Scene, opts: &RadiosityOptions) -> Radiosity {
        match Self::solve_inner(scene, opts, false) {
            Ok(r) => r,
            Err(_) => unreachable!("non-finite input is cleaned, not refused"),
        }
    }

    /// Checks cache bytes against `scene` and `opts` as a solve would (format, checksum,
    /// fingerprint, replayed refinement, counts and values) without solving; `Err` says why
    /// the cache would not be used.
    pub fn check_cache(scene: &Scene, opts: &RadiosityOptions, bytes: &[u8]) -> Result<(), String> {
        let mut m = mesh::Meshing::build(scene, opts.patch_size, opts.cull_hidden_sides);
        let fingerprint = cache::fingerprint(scene, opts, m.patch_size);
        match cache::decode(bytes, fingerprint) {
            Ok(d) => replay(&mut m, scene, &d),
            Err(cache::CacheError::Stale) => Err("stale".into()),
            Err(cache::CacheError::Invalid(e)) => Err(e),
        }
    }

    /// As [`Radiosity::solve`], but a patch with a non-finite emission or reflectance is an
    /// error, found before any form factor is computed.
    pub fn try_solve(scene: &Scene, opts: &RadiosityOptions) -> Result<Radiosity, String> {
        Self::solve_inner(scene, opts, true)
    }

    fn solve_inner(
        scene: &Scene,
        opts: &RadiosityOptions,
        refuse: bool,
    ) -> Result<Radiosity, String> {
        let start = Instant::now();
        let build = || {
            let mut m = mesh::Meshing::build(scene, opts.patch_size, opts.cull_hidden_sides);
            let mut bad = None;
            for (i, p) in m.patches.iter_mut().enumerate() {
                for v in p.emit.iter_mut().chain(p.rho.iter_mut()) {
                    if !v.is_finite() {
                        bad.get_or_insert(i);
                        *v = 0.0;
                    }
                }
            }
            (m, bad)
        };
        let (mut m, bad) = build();
        if let (true, Some(i)) = (refuse, bad) {
            return Err(format!(
                "patch {i} (element {}) has a non-finite emission or reflectance: the radiosity solve is refused",
                m.patches[i].elem
            ));
        }
        let seconds_mesh = start.elapsed().as_secs_f64();
        let fingerprint = cache::fingerprint(scene, opts, m.patch_size);
        let mut report = RadiosityReport {
            warnings: m.warnings.clone(),
            base_patches: m.patches.len(),
            seconds_mesh,
            threshold: opts.threshold,
            form_factors: opts.form_factors,
            solver: opts.solver,
            ..Default::default()
        };
        if let Some(bytes) = &opts.cache {
            match cache::decode(bytes, fingerprint) {
                Ok(d) => match replay(&mut m, scene, &d) {
                    Ok(()) => {
                        report.cache = CacheStatus::Loaded;
                        report.iterations = d.iterations;
                        report.residual = d.residual;
                        report.converged = d.converged;
                        report.elements_split = d.splits.len();
                        let solved = Solved {
                            mesh: m,
                            b: d.b,
                            hidden: d.hidden,
                            report,
                            fingerprint,
                        };
                        return Ok(Self::finish(scene, opts, solved, start));
                    }
                    Err(e) => {
                        report.cache = CacheStatus::Invalid(e);
                        m = build().0;
                    }
                },
                Err(cache::CacheError::Stale) => report.cache = CacheStatus::Stale,
                Err(cache::CacheError::Invalid(e)) => report.cache = CacheStatus::Invalid(e),
            }
        }
        let (b, hidden) = compute(scene, opts, &mut m, &mut report);
        let solved = Solved {
            mesh: m,
            b,
            hidden,
            report,
            fingerprint,
        };
        Ok(Self::finish(scene, opts, solved, start))
    }

    /// The solution shown as `opts` says, its report completed (`start`: when solving began).
    fn finish(scene: &Scene, opts: &RadiosityOptions, solved: Solved, start: Instant) -> Radiosity {
        let Solved {
            mesh: m,
            b,
            hidden,
            mut report,
            fingerprint,
        } = solved;
        let r: Vec<[f64; 3]> = b
            .iter()
            .zip(&m.patches)
            .map(|(b, p)| [b[0] - p.emit[0], b[1] - p.emit[1], b[2] - p.emit[2]])
            .collect();
        let display = display::Display {
            shading: display::Shading::new(&m, &r, &hidden),
            traced: raycast::traced_materials(scene),
            mode: match opts.display {
                DisplayMode::Gouraud => display::Mode::Gouraud,
                DisplayMode::Flat => display::Mode::Flat,
                DisplayMode::FinalGather(n) => display::Mode::Gather(n),
            },
        };
        report.patches = m.patches.len();
        report.elements = m.elements.len();
        report.patch_size = m.patch_size;
        report.mesh_bytes = m.bytes();
        report.seconds_total = start.elapsed().as_secs_f64();
        Radiosity {
            mesh: m,
            b,
            hidden,
            display,
            report,
            fingerprint,
        }
    }

    /// Statistics of the solve.
    pub fn report(&self) -> &RadiosityReport {
        &self.report
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.mesh.patches.len()
    }

    /// True when the scene has no patch.
    pub fn is_empty(&self) -> bool {
        self.mesh.patches.is_empty()
    }

    /// The patches with their radiosity.
    pub fn patches(&self) -> Vec<PatchInfo> {
        infos(&self.mesh, &self.b)
    }

    /// The solution as bytes (see [`RadiosityOptions::cache`]).
    pub fn to_bytes(&self) -> Vec<u8> {
        cache::encode(&cache::CacheData {
            fingerprint: self.fingerprint,
            elements: self.mesh.elements.len() as u32,
            patches: self.mesh.patches.len() as u32,
            splits: self.mesh.splits.clone(),
            b: self.b.clone(),
            hidden: self.hidden.clone(),
            iterations: self.report.iterations,
            residual: self.report.residual,
            converged: self.report.converged,
        })
    }
}

/// Replays the refinement of a cached solution on a fresh mesh.
fn replay(m: &mut mesh::Meshing, scene: &Scene, d: &cache::CacheData) -> Result<(), String> {
    for &e in &d.splits {
        let ok = (e as usize) < m.elements.len() && m.elements[e as usize].children == NONE;
        if !ok {
            return Err(format!("element {e} cannot be split"));
        }
        m.split(e, true);
        m.splits.push(e);
    }
    m.assign_patches(scene);
    if m.elements.len() != d.elements as usize
        || m.patches.len() != d.patches as usize
        || d.b.len() != m.patches.len()
        || d.hidden.len() != m.patches.len()
    {
        return Err("the mesh does not match".to_string());
    }
    // The values must be a radiosity of this mesh: finite, at least the emission, and no
    // reflected light on a channel that reflects nothing.
    for (i, (b, p)) in d.b.iter().zip(&m.patches).enumerate() {
        for c in 0..3 {
            let reflected = b[c] - p.emit[c];
            let tol = 1e-9 * (1.0 + b[c].abs() + p.emit[c].abs());
            if !(b[c].is_finite() && b[c] < 1e30 && reflected >= -tol)
                || (p.rho[c] == 0.0 && reflected.abs() > tol)
            {
                return Err(format!(
                    "patch {i}: radiosity {} out of range (emission {}, reflectance {})",
                    b[c], p.emit[c], p.rho[c]
                ));
            }
        }
    }
    Ok(())
}

impl Radiosity {
    /// The radiance arriving along `ray` (a camera ray) from the solution: emitted radiance
    /// plus the reflected radiosity / π, shown as [`RadiosityOptions::display`] says; specular
    /// surfaces are traced through.
    pub fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        self.display
            .radiance(&self.mesh, scene, ray, sampler, stats)
    }

    /// What the command line needs besides the solution: the report, and the solution as
    /// bytes when it was computed (not loaded from the cache).
    pub fn outcome(&self) -> RadiosityOutcome {
        RadiosityOutcome {
            report: self.report.clone(),
            cache_bytes: (self.report.cache != CacheStatus::Loaded).then(|| self.to_bytes()),
        }
    }
}
