//! What loading a scene needs ([`LoadOptions`]) and produces ([`LoadedScene`] with its
//! [`RenderHints`]), shared by the loader of each format.

use candela_imageio::Limits;
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
    /// File sizes, image pixels and the memory meshes may take (`--max-memory`).
    pub limits: Limits,
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
    /// Every file the load read, the scene file first (empty for the built-in demo): an output
    /// path equal to one of them is refused, and partial renders hash their contents.
    pub inputs: Vec<PathBuf>,
}

/// The name standard input takes in messages (`<stdin>:line:col: …`) when it holds the scene.
pub const STDIN_NAME: &str = "<stdin>";

/// Largest image width or height (a film's, or the command line's `--width`/`--height`).
pub const MAX_SIDE: u32 = 1 << 15;
/// Most samples per pixel (a sampler's `sample_count`, or `--spp`).
pub const MAX_SPP: u32 = 1 << 20;

/// Most shapes a scene may place (instances of instances count each copy).
pub const MAX_SHAPES: usize = 1 << 22;
/// Most solids in one CSG tree expanded (every use of a named shape counted): the most a ray
/// may have to test. Named shapes are shared, not copied, so memory grows with the distinct
/// nodes only; this bounds the time.
pub const MAX_CSG_SOLIDS: usize = 1 << 16;
/// Bytes of mesh data (each placed copy counted) per byte of `--max-memory`: meshes and their
/// acceleration structure may take at most half of the budget.
pub const MESH_MEMORY_FRACTION: f64 = 0.5;
/// Bytes of acceleration structure per triangle, added to the mesh data in the estimate.
pub const ACCEL_BYTES_PER_TRIANGLE: f64 = 64.0;
/// Bytes per instance of a shared group (its placement, inverse, top-level node), counted in
/// the mesh memory estimate instead of a copy of the group.
pub const INSTANCE_BYTES: f64 = 256.0;

/// Fails with a message naming the limit when `bytes` of meshes exceed what `limits` allow.
pub fn check_mesh_memory(bytes: f64, triangles: usize, limits: &Limits) -> Result<(), String> {
    let total = bytes + triangles as f64 * ACCEL_BYTES_PER_TRIANGLE;
    let max = limits.max_memory as f64 * MESH_MEMORY_FRACTION;
    if total > max {
        Err(format!(
            "the meshes placed so far ({triangles} triangles, every copy counted; instances of shared groups count {INSTANCE_BYTES} bytes each) need about {:.0} MB, more than half of --max-memory ({:.0} MB); raise --max-memory or place fewer copies",
            total / 1e6,
            limits.max_memory as f64 / 1e6
        ))
    } else {
        Ok(())
    }
}

/// Clamps negative and non-finite texels of a texture or environment image to 0 (they would
/// give negative or NaN radiance) and returns how many were changed.
pub fn clamp_texels(img: &mut candela_render::Image) -> usize {
    let mut changed = 0;
    for px in img.pixels_mut() {
        let clean = px.map(|x| if x.is_finite() && x > 0.0 { x } else { 0.0 });
        let same = |a: f32, b: f32| a == b || (a == 0.0 && b == 0.0);
        if !(same(clean.r, px.r) && same(clean.g, px.g) && same(clean.b, px.b)) {
            changed += 1;
            *px = clean;
        }
    }
    changed
}
