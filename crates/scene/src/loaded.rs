//! What loading a scene needs ([`LoadOptions`]) and produces ([`LoadedScene`] with its
//! [`RenderHints`]), shared by the loader of each format.

use candela_render::accel::AccelKind;
use candela_render::filter::Filter;
use candela_render::Scene;
use std::path::PathBuf;

/// What loading needs from the command line.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// `-d NAME=VALUE` overrides, in order (numbers for the candela language, any value for
    /// Mitsuba `<default>`s).
    pub defines: Vec<(String, String)>,
    /// The acceleration structure to build.
    pub accel: AccelKind,
}

/// Render settings a scene file may suggest (Mitsuba's film, sampler and integrator; the demo's
/// defaults); command-line options override them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderHints {
    /// Image width.
    pub width: Option<u32>,
    /// Image height.
    pub height: Option<u32>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// The integrator's name.
    pub integrator: Option<String>,
    /// Path length limit (-1 unlimited).
    pub max_depth: Option<i32>,
    /// Russian roulette start.
    pub rr_depth: Option<u32>,
    /// Hide directly visible emitters.
    pub hide_emitters: bool,
    /// The reconstruction filter (Mitsuba's `<rfilter>`, Gaussian when the film names none; the
    /// candela language's `filter` statement).
    pub filter: Option<Filter>,
}

/// A loaded scene with its hints and warnings.
#[derive(Debug)]
pub struct LoadedScene {
    /// The scene, ready to render.
    pub scene: Scene,
    /// Suggested render settings.
    pub hints: RenderHints,
    /// Warnings to show the user (already formatted with positions).
    pub warnings: Vec<String>,
    /// Triangles in meshes and the memory they take per triangle.
    pub mesh_stats: Option<(usize, f64)>,
    /// Where the scene uses terms of the local model only (ambient light, per-light components),
    /// which the physically based integrators ignore.
    pub local_model_terms: Vec<String>,
    /// The files the load read, the scene file first (empty for the built-in demo).
    pub inputs: Vec<PathBuf>,
}
