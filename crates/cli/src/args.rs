//! Command-line options (scene-language.md §3), parsed by clap and validated before any work.

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// candela: a physically based renderer.
#[derive(Parser, Debug)]
#[command(name = "candela", version, about, propagate_version = true)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render the built-in demo scene.
    Demo(RenderArgs),
    /// Render a scene file (candela language, or Mitsuba 3 XML when it ends in .xml).
    Render(SceneArgs),
    /// Convert an image between PFM, OpenEXR and PNG (tone mapping for PNG).
    Convert(ConvertArgs),
}

/// `render`: a scene file and how to render it.
#[derive(Args, Debug)]
pub struct SceneArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// How to render it.
    #[command(flatten)]
    pub render: RenderArgs,
}

/// The options of `render` and `demo`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Output file, repeatable; the format follows the extension (.png, .pfm, .exr, .hdr).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub outputs: Vec<PathBuf>,
    /// Image width in pixels (default 640, or the XML film's).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=MAX_SIZE))]
    pub width: Option<u32>,
    /// Image height in pixels (default 480, or the XML film's).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=MAX_SIZE))]
    pub height: Option<u32>,
    /// Samples per pixel (default 1, or the XML's sample_count): 1 goes through the pixel centre.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=MAX_SPP))]
    pub spp: Option<u32>,
    /// How the samples of a pixel are placed: sobol (default), stratified, independent.
    #[arg(long, value_name = "NAME")]
    pub sampler: Option<String>,
    /// The integrator.
    #[arg(long, value_name = "NAME")]
    pub integrator: Option<String>,
    /// Path length limit (-1: unlimited with Russian roulette).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(i32).range(-1..=100_000))]
    pub max_depth: Option<i32>,
    /// The course's branching factor for `path`.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub num_of_rays: Option<u32>,
    /// The acceleration structure: bvh (default), kdtree, grid, octree, none.
    #[arg(long, value_name = "NAME")]
    pub accel: Option<String>,
    /// The seed of the random sequences (same seed, same image, any thread count).
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub seed: u64,
    /// Overrides a `float` variable (or a Mitsuba `<default>`): NAME=VALUE or NAME:VALUE.
    #[arg(short = 'd', long = "define", value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Radiosity: largest patch edge (default from the scene's size).
    #[arg(long, allow_negative_numbers = true, value_parser = positive_f32)]
    pub patch_size: Option<f32>,
    /// Radiosity: hemicube | raycast.
    #[arg(long, value_name = "METHOD")]
    pub form_factors: Option<String>,
    /// Radiosity: gauss-seidel | progressive.
    #[arg(long, value_name = "METHOD")]
    pub solver: Option<String>,
    /// Radiosity: save the solution, or reuse it when it matches the scene.
    #[arg(long, value_name = "FILE")]
    pub radiosity_cache: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Memory budget in bytes (suffixes K, M, G, T): limits image size, file sizes, texture
    /// pixels and meshes (docs/limits.md); default 2G, or half of `ulimit -v`.
    #[arg(long, value_name = "BYTES", value_parser = crate::bytes::parse_bytes)]
    pub max_memory: Option<u64>,
    /// Print rays traced, time and Mrays/s.
    #[arg(long)]
    pub stats: bool,
    /// No progress bar.
    #[arg(long, short = 'q')]
    pub quiet: bool,
    /// How LDR outputs are tone mapped.
    #[command(flatten)]
    pub tone: ToneArgs,
}

/// The tone-mapping options.
#[derive(Args, Debug, Clone)]
pub struct ToneArgs {
    /// Tone mapping: the key value a (course default 0.18).
    #[arg(long, default_value_t = 0.18, allow_negative_numbers = true, value_parser = positive_f32)]
    pub factor: f32,
    /// Tone mapping: the display gamma γ (default 1.0 for `convert`, as in the course; 2.2 for
    /// `render` and `demo`).
    #[arg(long, allow_negative_numbers = true, value_parser = positive_f32)]
    pub gamma: Option<f32>,
    /// Tone mapping: the average luminosity ⟨l⟩ to use instead of the image's.
    #[arg(long, allow_negative_numbers = true, value_parser = positive_f32)]
    pub luminosity: Option<f32>,
    /// Tone mapping: encode with the sRGB curve instead of the gamma power.
    #[arg(long)]
    pub srgb: bool,
}

/// `convert`: an input and an output image.
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// The input image (.pfm, .exr, .hdr, .png).
    pub input: PathBuf,
    /// The output image (.pfm, .exr, .hdr, .png; `-` for a PNG on standard output).
    pub output: PathBuf,
    /// Memory budget in bytes (suffixes K, M, G, T), as for `render`.
    #[arg(long, value_name = "BYTES", value_parser = crate::bytes::parse_bytes)]
    pub max_memory: Option<u64>,
    /// How an LDR output is tone mapped.
    #[command(flatten)]
    pub tone: ToneArgs,
}

/// Largest accepted image edge.
pub const MAX_SIZE: i64 = 1 << 15;
/// Largest accepted sample count per pixel.
pub const MAX_SPP: i64 = 1 << 20;

fn positive_f32(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        Ok(_) => Err(format!("'{s}' must be a positive finite number")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}
