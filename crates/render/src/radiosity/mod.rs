//! Radiosity: the lectures' global method for Lambertian scenes.
//!
//! For surfaces that reflect and emit diffusely the rendering equation reduces to the radiosity
//! equation B(x) = E(x) + ρ(x) ∫ B(y) F(x, y) dy, discretised over N patches as
//! B_i = E_i + ρ_i Σ_j F_ij B_j with the form factors
//! F_ij = (1/A_i) ∫_{A_i} ∫_{A_j} cos θ_i cos θ_j V(x, y) / (π r²) dA_j dA_i.
//! The solution is view-independent: it is computed once and shown from any camera (the
//! `radiosity` integrator of [`crate::integrator`]). Everything is per RGB channel; sums and the solve are in f64.
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
mod options;
mod patches;
mod raycast;
mod refine;
mod report;
mod row;
mod solution;
mod solver;

pub use formfactor::FormFactorMatrix;
pub use options::{DisplayMode, FormFactorMethod, RadiosityOptions, SolverKind};
pub use patches::{PatchInfo, Side};
pub use report::{CacheStatus, RadiosityOutcome, RadiosityReport};
pub use solution::Radiosity;

/// Marks "no element / no patch".
pub(crate) const NONE: u32 = u32::MAX;
