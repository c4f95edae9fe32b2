//! Radiosity: the lectures' global method for Lambertian scenes.
//!
//! For surfaces that reflect and emit diffusely the rendering equation reduces to the radiosity
//! equation B(x) = E(x) + ρ(x) ∫ B(y) F(x, y) dy, discretised over N patches as
//! B_i = E_i + ρ_i Σ_j F_ij B_j with the form factors
//! F_ij = (1/A_i) ∫_{A_i} ∫_{A_j} cos θ_i cos θ_j V(x, y) / (π r²) dA_j dA_i.
//! The solution is view-independent: it is computed once, when the integrator is built, and
//! shown from any camera. Everything is per RGB channel; sums and the solve are in f64.
//!
//! The pipeline ([`Radiosity::solve`]):
//! 1. **Meshing** (`mesh`): every shape becomes patches of at most `patch_size` (default: the
//!    scene's bounding-box diagonal / 25): parallelograms and box faces in grids, spheres by
//!    latitude and longitude, disks by radius and angle, planes on a large square around the
//!    scene with cells growing away from it,
//!    polyhedra by their face polygons, mesh triangles split 4-way when too large. Each side of
//!    a surface that can be lit gets its own patches (the candela language is two-sided;
//!    Mitsuba's one-sided BSDFs and emitters give patches on the front only).
//! 2. **Form factors** (`hemicube`, `raycast`): by the hemicube (`--form-factors hemicube`,
//!    the default; resolution [`RadiosityOptions::hemicube_resolution`]) or by Monte Carlo ray
//!    casting through the acceleration structure (`--form-factors raycast`;
//!    [`RadiosityOptions::rays_per_patch`]).
//! 3. **Solve** (`solver`): Gauss–Seidel on (I − ρF)B = E (`--solver gauss-seidel`, default) or
//!    Southwell's progressive refinement (`--solver progressive`), which computes one row per
//!    shot and never stores the whole matrix; both stop when the relative residual is below
//!    [`RadiosityOptions::threshold`].
//! 4. **Adaptive subdivision**: patches whose corner values (averaged over their neighbours)
//!    differ from their own radiosity by more than [`RadiosityOptions::refine_threshold`] times
//!    the scene's mean are split in four, and the system is solved again, up to
//!    [`RadiosityOptions::refinements`] times and [`RadiosityOptions::max_patches`] patches.
//!    Patches whose centre is hidden (most of their hemicube sees, within half the patch size,
//!    surfaces or sides without patches: under a box, behind a light mounted close to the
//!    ceiling) and which border visible patches are split up to three levels deeper, where
//!    their children's centres come out of hiding; hidden patches do not take part in the
//!    vertex averages of their visible neighbours.
//! 5. **Display** (`display`): emitted radiance plus the reflected radiosity / π, interpolated
//!    across patches (Gouraud), flat, or by one final-gather bounce; specular surfaces are
//!    traced through.
//!
//! Lights that are not shapes (point, spot, distant, environment, the background) contribute
//! the radiosity they reflect directly as a source term (`direct`). The solution can be saved
//! as bytes and loaded back for other views (`cache`): the command line stores them in
//! `--radiosity-cache FILE`.

mod cache;
mod direct;
mod display;
mod formfactor;
mod hemicube;
mod mesh;
mod raycast;
mod solver;

use crate::color::Rgb;
use crate::integrator::Integrator;
use crate::math::{Point3, Ray, Vec3};
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::stats::RayStats;
use std::fmt;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Marks "no element / no patch".
pub(crate) const NONE: u32 = u32::MAX;

/// How form factors are computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FormFactorMethod {
    /// The hemicube: rasterisation with a z-buffer and delta form factors.
    #[default]
    Hemicube,
    /// Monte Carlo ray casting with visibility through the scene's acceleration structure.
    RayCast,
}

impl FormFactorMethod {
    /// The command-line names (`--form-factors`).
    pub const NAMES: &'static [&'static str] = &["hemicube", "raycast"];

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "hemicube" => Some(Self::Hemicube),
            "raycast" => Some(Self::RayCast),
            _ => None,
        }
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Hemicube => "hemicube",
            Self::RayCast => "raycast",
        }
    }
}

/// How the radiosity system is solved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SolverKind {
    /// Gauss–Seidel iteration on the whole matrix.
    #[default]
    GaussSeidel,
    /// Southwell's progressive refinement (shooting), one row at a time.
    Progressive,
}

impl SolverKind {
    /// The command-line names (`--solver`).
    pub const NAMES: &'static [&'static str] = &["gauss-seidel", "progressive"];

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "gauss-seidel" => Some(Self::GaussSeidel),
            "progressive" => Some(Self::Progressive),
            _ => None,
        }
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::GaussSeidel => "gauss-seidel",
            Self::Progressive => "progressive",
        }
    }
}

/// How the solution is shown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DisplayMode {
    /// Radiosity interpolated across patches from vertex averages.
    #[default]
    Gouraud,
    /// Each patch's own radiosity.
    Flat,
    /// One final-gather bounce with this many rays per camera sample.
    FinalGather(u32),
}

/// Where [`build`] leaves its report and the bytes of a freshly computed solution (for the
/// command line, which prints the report and writes the cache file).
#[derive(Clone, Default)]
pub struct RadiosityOutbox(Arc<Mutex<Option<RadiosityOutcome>>>);

impl RadiosityOutbox {
    /// An empty outbox.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes what was left.
    pub fn take(&self) -> Option<RadiosityOutcome> {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).take()
    }

    fn put(&self, o: RadiosityOutcome) {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(o);
    }
}

impl PartialEq for RadiosityOutbox {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl fmt::Debug for RadiosityOutbox {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("RadiosityOutbox")
    }
}

/// What building the radiosity integrator produced besides the integrator.
#[derive(Clone, Debug)]
pub struct RadiosityOutcome {
    /// Statistics and warnings of the solve.
    pub report: RadiosityReport,
    /// The solution as bytes when it was computed (not loaded from the cache).
    pub cache_bytes: Option<Vec<u8>>,
}

/// The options of the radiosity integrator.
#[derive(Clone, Debug, PartialEq)]
pub struct RadiosityOptions {
    /// Largest patch edge (`--patch-size`); `None`: the scene's bounding-box diagonal / 25.
    pub patch_size: Option<f32>,
    /// Form-factor method (`--form-factors`).
    pub form_factors: FormFactorMethod,
    /// Solver (`--solver`).
    pub solver: SolverKind,
    /// Relative residual at which the solver stops (default 1e-4).
    pub threshold: f64,
    /// Most sweeps (Gauss–Seidel) or shots (progressive); 0: automatic (10 000 sweeps,
    /// 200·N + 10 000 shots).
    pub max_iterations: u64,
    /// Hemicube resolution: pixels along the top face's edge (default 128).
    pub hemicube_resolution: u32,
    /// Rays per patch of ray-cast form factors (default 2048).
    pub rays_per_patch: u32,
    /// Adaptive refinement passes (default 2; 0 disables).
    pub refinements: u32,
    /// Split a patch when a corner value differs from it by more than this fraction of the
    /// scene's mean reflected radiosity (default 0.5).
    pub refine_threshold: f32,
    /// Refinement stops adding patches beyond this count (default 6000).
    pub max_patches: usize,
    /// How the solution is shown.
    pub display: DisplayMode,
    /// Memory for rows kept by progressive refinement (default 256 MiB).
    pub row_cache_bytes: usize,
    /// Memory above which Gauss–Seidel gives up storing the matrix and switches to progressive
    /// refinement (default 2 GiB).
    pub matrix_bytes_limit: usize,
    /// Give no patches to sides that cannot be lit (default true).
    pub cull_hidden_sides: bool,
    /// Gauss–Seidel gathers B_j into patch i with A_j F_ji / A_i (reciprocity, from the
    /// form factors computed at j: the coefficients progressive refinement shoots with, so both
    /// solvers solve the same system) instead of F_ij from patch i's own hemicube or rays
    /// (default false: the lecture's form, whose rows sum to 1 in a closed room).
    pub reciprocal_gather: bool,
    /// Seed of the Monte Carlo estimates.
    pub seed: u64,
    /// A solution saved earlier (the bytes of `--radiosity-cache FILE`), reused when it matches
    /// the scene and the options.
    pub cache: Option<Arc<[u8]>>,
    /// Where to leave the report and the bytes of a computed solution.
    pub outbox: Option<RadiosityOutbox>,
}

impl Default for RadiosityOptions {
    fn default() -> Self {
        Self {
            patch_size: None,
            form_factors: FormFactorMethod::Hemicube,
            solver: SolverKind::GaussSeidel,
            threshold: 1e-4,
            max_iterations: 0,
            hemicube_resolution: 128,
            rays_per_patch: 2048,
            refinements: 2,
            refine_threshold: 0.5,
            max_patches: 6000,
            display: DisplayMode::Gouraud,
            row_cache_bytes: 256 << 20,
            matrix_bytes_limit: 2 << 30,
            cull_hidden_sides: true,
            reciprocal_gather: false,
            seed: 0,
            cache: None,
            outbox: None,
        }
    }
}

impl RadiosityOptions {
    /// Checks the numeric options.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(h) = self.patch_size {
            if !(h > 0.0 && h.is_finite()) {
                return Err(format!(
                    "the patch size must be a positive number (got {h})"
                ));
            }
        }
        if !(self.threshold > 0.0 && self.threshold.is_finite()) {
            return Err(format!(
                "the residual threshold must be positive (got {})",
                self.threshold
            ));
        }
        if !(self.refine_threshold > 0.0) {
            return Err(format!(
                "the refinement threshold must be positive (got {})",
                self.refine_threshold
            ));
        }
        Ok(())
    }
}

/// What happened with the cached solution.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum CacheStatus {
    /// No cache was given.
    #[default]
    NotUsed,
    /// The cache matched and was used: nothing was computed.
    Loaded,
    /// The cache is of another scene or other options: recomputed.
    Stale,
    /// The bytes are not a valid cache: recomputed.
    Invalid(String),
}

/// Statistics of a radiosity solve.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RadiosityReport {
    /// Patches of the final mesh.
    pub patches: usize,
    /// Patches before adaptive refinement.
    pub base_patches: usize,
    /// Elements (all nodes of the subdivision forest).
    pub elements: usize,
    /// The largest patch edge used.
    pub patch_size: f32,
    /// Refinement passes that split something.
    pub refinement_passes: u32,
    /// Elements split by refinement.
    pub elements_split: usize,
    /// The form-factor method.
    pub form_factors: FormFactorMethod,
    /// The solver that produced the solution.
    pub solver: SolverKind,
    /// Sweeps (Gauss–Seidel) or shots (progressive) of the last solve.
    pub iterations: u64,
    /// Relative residual of the last solve (see the `solver` module).
    pub residual: f64,
    /// The threshold it was asked to reach.
    pub threshold: f64,
    /// Whether the residual reached the threshold.
    pub converged: bool,
    /// Form-factor rows computed, all passes together.
    pub rows_computed: u64,
    /// Smallest Σ_j F_ij over the rows of the last pass.
    pub row_sum_min: f64,
    /// Mean Σ_j F_ij.
    pub row_sum_mean: f64,
    /// Largest Σ_j F_ij.
    pub row_sum_max: f64,
    /// Σ|A_i F_ij − A_j F_ji| / Σ(A_i F_ij + A_j F_ji) over the pairs whose both rows were
    /// known in the last pass.
    pub reciprocity_error: f64,
    /// The largest |A_i F_ij − A_j F_ji| / mean among pairs with max(F_ij, F_ji) ≥ 0.01.
    pub reciprocity_max: f64,
    /// Pairs checked for reciprocity.
    pub reciprocity_pairs: u64,
    /// Peak memory of stored form factors (the matrix, or the row cache), in bytes.
    pub form_factor_bytes: usize,
    /// Memory of elements and patches, in bytes.
    pub mesh_bytes: usize,
    /// Seconds spent meshing.
    pub seconds_mesh: f64,
    /// Seconds spent computing form factors for Gauss–Seidel (progressive: inside the solve).
    pub seconds_form_factors: f64,
    /// Seconds spent solving (and refining).
    pub seconds_solve: f64,
    /// Seconds in total.
    pub seconds_total: f64,
    /// What happened with the cache.
    pub cache: CacheStatus,
    /// Approximations and fall-backs worth telling the user about.
    pub warnings: Vec<String>,
}

impl fmt::Display for RadiosityReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mib = |b: usize| b as f64 / (1024.0 * 1024.0);
        match &self.cache {
            CacheStatus::Loaded => writeln!(f, "radiosity: solution loaded from the cache")?,
            CacheStatus::Stale => writeln!(
                f,
                "radiosity: the cache is stale (other scene or options): recomputed"
            )?,
            CacheStatus::Invalid(m) => {
                writeln!(f, "radiosity: the cache is invalid ({m}): recomputed")?
            }
            CacheStatus::NotUsed => {}
        }
        writeln!(
            f,
            "radiosity: {} patches ({} before {} refinement pass(es), {} elements split), patch size {:.4}, {} elements",
            self.patches, self.base_patches, self.refinement_passes, self.elements_split, self.patch_size, self.elements
        )?;
        writeln!(
            f,
            "radiosity: {} form factors, {} rows; Σ_j F_ij min {:.4} mean {:.4} max {:.4}; reciprocity error {:.4} (worst pair {:.3}, {} pairs)",
            self.form_factors.name(),
            self.rows_computed,
            self.row_sum_min,
            self.row_sum_mean,
            self.row_sum_max,
            self.reciprocity_error,
            self.reciprocity_max,
            self.reciprocity_pairs
        )?;
        writeln!(
            f,
            "radiosity: {} solver, {} {}, residual {:.3e} (threshold {:.1e}, {})",
            self.solver.name(),
            self.iterations,
            if self.solver == SolverKind::GaussSeidel {
                "sweeps"
            } else {
                "shots"
            },
            self.residual,
            self.threshold,
            if self.converged {
                "converged"
            } else {
                "NOT converged"
            }
        )?;
        write!(
            f,
            "radiosity: memory {:.1} MiB form factors + {:.1} MiB mesh; time {:.3} s (mesh {:.3}, form factors {:.3}, solve {:.3})",
            mib(self.form_factor_bytes),
            mib(self.mesh_bytes),
            self.seconds_total,
            self.seconds_mesh,
            self.seconds_form_factors,
            self.seconds_solve
        )
    }
}

/// Which side of a surface a patch is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The side the shape's normal points to.
    Front,
    /// The other side.
    Back,
}

/// A patch as seen from outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchInfo {
    /// The scene primitive it lies on.
    pub prim: u32,
    /// The primitive's face (box face, polyhedron plane; 0 otherwise).
    pub face: u32,
    /// Its side.
    pub side: Side,
    /// Area.
    pub area: f64,
    /// Centre (on the true surface).
    pub centre: Point3,
    /// Unit normal of its side.
    pub normal: Vec3,
    /// Reflectance ρ.
    pub reflectance: [f64; 3],
    /// Emitted radiosity E = π L_e.
    pub emission: [f64; 3],
    /// Radiosity B (zero before a solve).
    pub radiosity: [f64; 3],
}

fn infos(m: &mesh::Meshing, b: &[[f64; 3]]) -> Vec<PatchInfo> {
    m.patches
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let s = &m.surfaces[m.elements[p.elem as usize].surface as usize];
            PatchInfo {
                prim: s.prim,
                face: s.face,
                side: if p.side == 0 { Side::Front } else { Side::Back },
                area: p.area,
                centre: p.centre,
                normal: p.normal,
                reflectance: p.rho,
                emission: p.emit,
                radiosity: b.get(i).copied().unwrap_or([0.0; 3]),
            }
        })
        .collect()
}

/// The patches of a scene (without refinement) and every row of their form-factor matrix.
#[derive(Clone, Debug)]
pub struct FormFactorMatrix {
    /// The patches.
    pub patches: Vec<PatchInfo>,
    /// Row i: the non-zero F_ij as (j, F_ij), sorted by j.
    pub rows: Vec<Vec<(u32, f32)>>,
}

impl FormFactorMatrix {
    /// Meshes `scene` and computes all form factors with the method and parameters of `opts`.
    pub fn compute(scene: &Scene, opts: &RadiosityOptions) -> Self {
        Self::compute_rows(scene, opts, &|_| true)
    }

    /// Like [`FormFactorMatrix::compute`], but only the rows of the patches `which` accepts
    /// (the others are left empty).
    pub fn compute_rows(
        scene: &Scene,
        opts: &RadiosityOptions,
        which: &dyn Fn(&PatchInfo) -> bool,
    ) -> Self {
        let m = mesh::Meshing::build(scene, opts.patch_size, opts.cull_hidden_sides);
        let patches = infos(&m, &[]);
        let engine = formfactor::Engine::new(
            scene,
            &m,
            opts.form_factors,
            opts.hemicube_resolution,
            opts.rays_per_patch,
            opts.seed,
        );
        let ids: Vec<u32> = (0..m.patches.len() as u32)
            .filter(|&i| which(&patches[i as usize]))
            .collect();
        let mut rows = vec![Vec::new(); m.patches.len()];
        for (i, r) in ids.iter().zip(engine.rows(&ids)) {
            rows[*i as usize] = r.cols.into_iter().zip(r.vals).collect();
        }
        Self { patches, rows }
    }
}

/// A solved scene: the patches, their radiosity, and what is needed to show them. It is the
/// `radiosity` integrator.
#[derive(Clone, Debug)]
pub struct Radiosity {
    mesh: mesh::Meshing,
    b: Vec<[f64; 3]>,
    hidden: Vec<bool>,
    display: display::Display,
    report: RadiosityReport,
    fingerprint: u64,
}

impl Radiosity {
    /// Meshes, computes form factors, solves and refines, or loads the solution from
    /// `opts.cache` when it matches the scene and the options.
    pub fn solve(scene: &Scene, opts: &RadiosityOptions) -> Radiosity {
        let start = Instant::now();
        let build = || mesh::Meshing::build(scene, opts.patch_size, opts.cull_hidden_sides);
        let mut m = build();
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
                        return Self::finish(
                            scene,
                            opts,
                            m,
                            d.b,
                            d.hidden,
                            report,
                            fingerprint,
                            start,
                        );
                    }
                    Err(e) => {
                        report.cache = CacheStatus::Invalid(e);
                        m = build();
                    }
                },
                Err(cache::CacheError::Stale) => report.cache = CacheStatus::Stale,
                Err(cache::CacheError::Invalid(e)) => report.cache = CacheStatus::Invalid(e),
            }
        }
        let (b, hidden) = compute(scene, opts, &mut m, &mut report);
        Self::finish(scene, opts, m, b, hidden, report, fingerprint, start)
    }

    fn finish(
        scene: &Scene,
        opts: &RadiosityOptions,
        m: mesh::Meshing,
        b: Vec<[f64; 3]>,
        hidden: Vec<bool>,
        mut report: RadiosityReport,
        fingerprint: u64,
        start: Instant,
    ) -> Radiosity {
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

impl Integrator for Radiosity {
    fn radiance(
        &self,
        scene: &Scene,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        self.display
            .radiance(&self.mesh, scene, ray, sampler, stats)
    }
}

/// Builds the `radiosity` integrator: solves (or loads) and leaves the report and the bytes
/// of a computed solution in `opts.outbox`.
pub fn build(scene: &Scene, opts: &RadiosityOptions) -> Result<Box<dyn Integrator>, String> {
    opts.validate()?;
    let r = Radiosity::solve(scene, opts);
    if let Some(outbox) = &opts.outbox {
        let cache_bytes = (r.report.cache != CacheStatus::Loaded).then(|| r.to_bytes());
        outbox.put(RadiosityOutcome {
            report: r.report.clone(),
            cache_bytes,
        });
    }
    Ok(Box::new(r))
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
    Ok(())
}

/// Luminance weights.
fn lum(x: &[f64; 3]) -> f64 {
    0.2126 * x[0] + 0.7152 * x[1] + 0.0722 * x[2]
}

/// Which patches are hidden: most of their hemicube (or rays) sees absorbers or surfaces
/// nearer than half their size; a patch without a computed row is hidden when it received
/// nothing.
fn hidden_patches(occluded: &[f32], b: &[[f64; 3]]) -> Vec<bool> {
    occluded
        .iter()
        .zip(b)
        .map(|(&o, b)| {
            if o < 0.0 {
                b.iter().all(|&x| x == 0.0)
            } else {
                o >= 0.5
            }
        })
        .collect()
}

/// Solves with refinement passes; returns B and the hidden patches, and fills the report.
fn compute(
    scene: &Scene,
    opts: &RadiosityOptions,
    m: &mut mesh::Meshing,
    report: &mut RadiosityReport,
) -> (Vec<[f64; 3]>, Vec<bool>) {
    let t_solve = Instant::now();
    let mut warm: Option<Vec<[f64; 3]>> = None;
    let mut pass = 0u32;
    let mut ff_seconds = 0f64;
    let mut fell_back = false;
    loop {
        let n = m.patches.len();
        let direct = direct::direct_sources(scene, m, opts.seed);
        let source: Vec<[f64; 3]> = m
            .patches
            .iter()
            .zip(&direct)
            .map(|(p, d)| [p.emit[0] + d[0], p.emit[1] + d[1], p.emit[2] + d[2]])
            .collect();
        let sol = {
            let engine = formfactor::Engine::new(
                scene,
                m,
                opts.form_factors,
                opts.hemicube_resolution,
                opts.rays_per_patch,
                opts.seed,
            );
            let max_shots = if opts.max_iterations > 0 {
                opts.max_iterations
            } else {
                200 * n as u64 + 10_000
            };
            let max_sweeps = if opts.max_iterations > 0 {
                opts.max_iterations
            } else {
                10_000
            };
            let progressive = |fell: bool| {
                let mut s = solver::progressive(
                    &engine,
                    &m.patches,
                    &source,
                    opts.threshold,
                    max_shots,
                    opts.row_cache_bytes,
                );
                s.fell_back = fell;
                s
            };
            match opts.solver {
                SolverKind::Progressive => progressive(false),
                SolverKind::GaussSeidel => {
                    let t = Instant::now();
                    let rows = solver::all_rows(&engine, n, opts.matrix_bytes_limit);
                    ff_seconds += t.elapsed().as_secs_f64();
                    match rows {
                        Some(rows) => solver::gauss_seidel(
                            rows,
                            &m.patches,
                            &source,
                            warm.take(),
                            opts.threshold,
                            max_sweeps,
                            opts.reciprocal_gather,
                        ),
                        None => progressive(true),
                    }
                }
            }
        };
        if sol.fell_back && !fell_back {
            fell_back = true;
            report.warnings.push(format!(
                "radiosity: the form-factor matrix of {n} patches needs more than {} MiB: solved by progressive refinement instead of Gauss–Seidel",
                opts.matrix_bytes_limit >> 20
            ));
        }
        report.solver = if sol.fell_back {
            SolverKind::Progressive
        } else {
            opts.solver
        };
        report.iterations = sol.iterations;
        report.residual = sol.residual;
        report.converged = sol.converged;
        report.rows_computed += sol.rows_computed;
        report.row_sum_min = sol.stats.sum_min;
        report.row_sum_max = sol.stats.sum_max;
        report.row_sum_mean = if sol.stats.rows > 0 {
            sol.stats.sum_total / sol.stats.rows as f64
        } else {
            0.0
        };
        (
            report.reciprocity_error,
            report.reciprocity_max,
            report.reciprocity_pairs,
        ) = sol.reciprocity;
        report.form_factor_bytes = report.form_factor_bytes.max(sol.row_bytes);
        let hidden = hidden_patches(&sol.occluded, &sol.b);
        if pass >= opts.refinements || n >= opts.max_patches {
            report.seconds_form_factors = ff_seconds;
            report.seconds_solve = t_solve.elapsed().as_secs_f64() - ff_seconds;
            return (sol.b, hidden);
        }
        let old_ids: Vec<[u32; 2]> = m.elements.iter().map(|e| e.patch).collect();
        let split = refine(scene, m, &sol.b, &hidden, opts);
        if split == 0 {
            report.seconds_form_factors = ff_seconds;
            report.seconds_solve = t_solve.elapsed().as_secs_f64() - ff_seconds;
            return (sol.b, hidden);
        }
        report.refinement_passes += 1;
        report.elements_split += split;
        m.assign_patches(scene);
        // Warm start: each new patch starts from its ancestor's radiosity.
        let mut b0 = Vec::with_capacity(m.patches.len());
        for p in &m.patches {
            let mut e = p.elem;
            let side = p.side as usize;
            let mut v = None;
            while e != NONE {
                if let Some(ids) = old_ids.get(e as usize) {
                    if ids[side] != NONE {
                        v = Some(sol.b[ids[side] as usize]);
                        break;
                    }
                }
                e = m.elements[e as usize].parent;
            }
            b0.push(v.unwrap_or(p.emit));
        }
        warm = Some(b0);
        pass += 1;
    }
}

/// Splits the elements where the reflected radiosity changes fast; returns how many.
fn refine(
    scene: &Scene,
    m: &mut mesh::Meshing,
    b: &[[f64; 3]],
    hidden: &[bool],
    opts: &RadiosityOptions,
) -> usize {
    let r: Vec<[f64; 3]> = b
        .iter()
        .zip(&m.patches)
        .map(|(b, p)| [b[0] - p.emit[0], b[1] - p.emit[1], b[2] - p.emit[2]])
        .collect();
    let cv = display::corner_values(m, &r, hidden);
    let (mut sum, mut area) = (0f64, 0f64);
    for (p, ri) in m.patches.iter().zip(&r) {
        if p.emit.iter().all(|&e| e == 0.0) {
            sum += p.area * lum(ri);
            area += p.area;
        }
    }
    if !(sum > 0.0 && area > 0.0) {
        return 0;
    }
    let mean = sum / area;
    // The largest corner difference per element, relative to the mean.
    let mut score: Vec<(f64, u32)> = Vec::new();
    let mut best: std::collections::HashMap<u32, f64> = std::collections::HashMap::new();
    for (i, p) in m.patches.iter().enumerate() {
        if p.emit.iter().any(|&e| e > 0.0) {
            continue;
        }
        let e = &m.elements[p.elem as usize];
        if e.level as u32 >= opts.refinements || e.max_edge() < m.patch_size / 64.0 {
            continue;
        }
        let own = lum(&r[i]);
        let d = cv[i][..e.nverts as usize]
            .iter()
            .map(|c| (lum(c) - own).abs())
            .fold(0.0, f64::max)
            / mean;
        if d > opts.refine_threshold as f64 {
            let v = best.entry(p.elem).or_insert(0.0);
            *v = v.max(d);
        }
    }
    score.extend(best.into_iter().map(|(e, d)| (d, e)));
    score.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    // Hidden patches on the edge of a hidden region: their radiosity (computed at a hidden
    // centre) does not represent their visible part, so they are split further, down to
    // HIDDEN_LEVELS below the refinement depth, where the children's centres change side.
    let boundary = display::hidden_boundary(m, hidden);
    let mut deep = Vec::new();
    for (i, p) in m.patches.iter().enumerate() {
        let e = &m.elements[p.elem as usize];
        if boundary[i]
            && p.emit.iter().all(|&x| x == 0.0)
            && (e.level as u32) < opts.refinements + HIDDEN_LEVELS
            && !deep.iter().any(|&(el, _)| el == p.elem)
        {
            deep.push((p.elem, p.side as usize));
        }
    }
    let mut patches = m.patches.len();
    let mut split = 0;
    let cost = |m: &mesh::Meshing, e: u32| {
        3 * m.elements[e as usize]
            .patch
            .iter()
            .filter(|&&p| p != NONE)
            .count()
    };
    for (_, e) in score {
        if m.elements[e as usize].children != NONE {
            continue;
        }
        let c = cost(m, e);
        if patches + c > opts.max_patches {
            break;
        }
        patches += c;
        m.split(e, true);
        m.splits.push(e);
        split += 1;
    }
    let mut stats = RayStats::default();
    let mut stack: Vec<(u32, usize)> = deep;
    while let Some((e, side)) = stack.pop() {
        let el = &m.elements[e as usize];
        if el.children != NONE || (el.level as u32) >= opts.refinements + HIDDEN_LEVELS {
            continue;
        }
        let c = 3 * m.surfaces[el.surface as usize]
            .active
            .iter()
            .filter(|&&a| a)
            .count();
        if patches + c > opts.max_patches {
            break;
        }
        patches += c;
        let first = m.split(e, true);
        m.splits.push(e);
        split += 1;
        let kids: Vec<(u32, bool)> = (first..first + 4)
            .map(|k| (k, hidden_point(scene, m, k, side, &mut stats)))
            .collect();
        if kids.iter().any(|k| k.1) && kids.iter().any(|k| !k.1) {
            stack.extend(kids.iter().filter(|k| k.1).map(|k| (k.0, side)));
        }
    }
    split
}

/// Levels of extra splitting at the edges of hidden regions.
const HIDDEN_LEVELS: u32 = 3;

/// True when the centre of `side` of element `e` is hidden: half of 16 cosine rays hit, within
/// half the patch size, something or a side without patches.
fn hidden_point(
    scene: &Scene,
    m: &mesh::Meshing,
    e: u32,
    side: usize,
    stats: &mut RayStats,
) -> bool {
    let el = &m.elements[e as usize];
    let n = if side == 0 { el.normal } else { -el.normal };
    let frame = crate::math::Frame::from_normal(n.to_normal());
    let near = 0.5 * m.patch_size;
    let mut hidden = 0;
    const RAYS: u32 = 16;
    for k in 0..RAYS {
        let u = crate::sampling::sampler::cmj(k, RAYS, e);
        let d = frame.to_world(crate::sampling::warp::square_to_cosine_hemisphere(u));
        let ray = Ray::spawn(el.centre, n.to_normal(), d);
        let Some(hit) = scene.intersect(&ray, stats) else {
            continue;
        };
        if hit.t * ray.d.norm() < near {
            hidden += 1;
            continue;
        }
        let si = scene.geometry.interaction(&ray, &hit);
        let absorbs = match m.locate(&hit, &si) {
            Some((h, _)) => {
                let s = if si.n.dot_vec(ray.d) < 0.0 { 0 } else { 1 };
                !m.surfaces[m.elements[h as usize].surface as usize].active[s]
            }
            None => true,
        };
        hidden += absorbs as u32;
    }
    2 * hidden >= RAYS
}
