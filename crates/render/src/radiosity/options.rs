//! What a radiosity solve can be asked: the form-factor method, the solver, the display mode,
//! thresholds and limits, and a cached solution to reuse.

use std::sync::Arc;

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
