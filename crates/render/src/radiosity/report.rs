//! What a radiosity solve reports: statistics, warnings, what happened with the cache.

use super::options::{FormFactorMethod, SolverKind};
use std::fmt;

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

/// What a solve produced besides the solution: its report, and the solution as bytes when it
/// was computed rather than loaded (for the command line to save as a cache).
#[derive(Clone, Debug)]
pub struct RadiosityOutcome {
    /// Statistics and warnings of the solve.
    pub report: RadiosityReport,
    /// The solution as bytes when it was computed (not loaded from the cache).
    pub cache_bytes: Option<Vec<u8>>,
}
