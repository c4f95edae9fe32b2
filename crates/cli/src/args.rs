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
    /// Render a scene file (candela language, or Mitsuba 3 XML when it ends in .xml), or `-`:
    /// the scene on standard input (XML when its first non-blank character is `<`).
    Render(SceneArgs),
    /// Convert an image between PFM, OpenEXR and PNG (tone mapping for PNG).
    Convert(ConvertArgs),
    /// Denoise a rendered image with Intel Open Image Denoise (using its albedo and normal
    /// layers when it has them).
    Denoise(DenoiseArgs),
    /// Merge partial renders (`render --partial`) and checkpoints into the image of the frame.
    Merge(MergeArgs),
}

/// `render`: a scene file and how to render it.
#[derive(Args, Debug)]
pub struct SceneArgs {
    /// The scene file, or `-` for standard input (Mitsuba XML when its first non-blank
    /// character is `<`, the candela language otherwise).
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
    /// The reconstruction filter: box (the candela language's default), tent, gaussian (Mitsuba's
    /// default), mitchell, catmullrom, lanczos; samples are splatted to the pixels the filter
    /// reaches, as Mitsuba does (importance-sampled instead with --aov).
    #[arg(long, value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(candela_render::filter::FILTER_NAMES))]
    pub filter: Option<String>,
    /// The integrator.
    #[arg(long, value_name = "NAME")]
    pub integrator: Option<String>,
    /// Spectral rendering: radiance per wavelength (four wavelengths per path, hero-wavelength
    /// sampling), turned into colour through the CIE 1931 observer; measured spectra,
    /// blackbodies and dispersion take effect. For path, direct, local and whitted.
    #[arg(long)]
    pub spectral: bool,
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
    #[arg(
        short = 'd',
        long = "define",
        visible_alias = "declare-float",
        value_name = "NAME=VALUE"
    )]
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
    #[arg(long, value_name = "BYTES", value_parser = crate::bytes::parse_budget)]
    pub max_memory: Option<u64>,
    /// Print rays traced, time and Mrays/s.
    #[arg(long)]
    pub stats: bool,
    /// No progress bar (the same as `--progress none`).
    #[arg(long, short = 'q')]
    pub quiet: bool,
    /// How progress is shown on stderr: bar (default), json (one JSON object per line, for
    /// schedulers and wrappers), none.
    #[arg(long, value_name = "HOW")]
    pub progress: Option<String>,
    /// Render only sample indices A ≤ i < B of every pixel of the --spp frame (A..B).
    #[arg(long, value_name = "A..B", value_parser = sample_range)]
    pub samples: Option<(u32, u32)>,
    /// Render only the pixels X0 ≤ x < X1, Y0 ≤ y < Y1 (row 0 at the top).
    #[arg(long, value_name = "X0,X1,Y0,Y1", value_parser = crop_window)]
    pub crop: Option<[u32; 4]>,
    /// Write only this partial file (sums, counts, scene hash and settings) for `candela merge`.
    #[arg(long, value_name = "FILE")]
    pub partial: Option<PathBuf>,
    /// Save progress to FILE (a partial file) every --checkpoint-every seconds, on SIGINT and
    /// SIGTERM, and at the end.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0, allow_negative_numbers = true, value_parser = positive_f64)]
    pub checkpoint_every: f64,
    /// Continue the render saved in this checkpoint (and keep checkpointing to it unless
    /// --checkpoint names another file).
    #[arg(long, value_name = "FILE")]
    pub resume: Option<PathBuf>,
    /// Render whole sample passes until this many seconds have passed, then write the image of
    /// the samples done and a checkpoint to resume from.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true, value_parser = positive_f64)]
    pub time_limit: Option<f64>,
    /// Render frames A ≤ f < B of an animation: the float --frame-var is set to f (as by -d)
    /// and `%d` / `%04d` in output, partial and checkpoint names becomes the frame number.
    #[arg(long, value_name = "A..B", value_parser = frame_range)]
    pub frames: Option<(u32, u32)>,
    /// The variable --frames sets to the frame number.
    #[arg(long, value_name = "NAME", default_value = "clock")]
    pub frame_var: String,
    /// Output variables besides radiance, comma-separated: albedo, normal, depth, position,
    /// uv, shape (OpenEXR layers, or NAME.VARIABLE.pfm files beside other outputs).
    #[arg(long, value_name = "LIST")]
    pub aov: Option<String>,
    /// Denoise the image with Intel Open Image Denoise (loaded at run time from OIDN_DIR or
    /// the system) using albedo and normal auxiliaries; the noisy image is kept as
    /// NAME.noisy.EXT.
    #[arg(long)]
    pub denoise: bool,
    /// With --denoise: do not keep the noisy image.
    #[arg(long)]
    pub no_keep_noisy: bool,
    /// Serve a page on 127.0.0.1 that shows the image refining pass by pass (its address is
    /// printed as `preview: http://127.0.0.1:PORT/`), with /image.png and /status.json.
    #[arg(long)]
    pub preview: bool,
    /// The preview's port (default: a free one).
    #[arg(long, value_name = "PORT", requires = "preview")]
    pub preview_port: Option<u16>,
    /// Keep the preview up after the render until Ctrl-C.
    #[arg(long, requires = "preview")]
    pub preview_hold: bool,
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

/// `denoise`: an image in, a denoised image out.
#[derive(Args, Debug)]
pub struct DenoiseArgs {
    /// The noisy image (.exr with optional albedo.R/G/B and normal.X/Y/Z layers, .pfm, .hdr).
    pub input: PathBuf,
    /// The denoised image (.exr, .pfm, .hdr, .png).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// How an LDR output is tone mapped (gamma 2.2 unless --gamma).
    #[command(flatten)]
    pub tone: ToneArgs,
}

/// `merge`: partial renders into an image.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The partial files (from `render --partial` or `--checkpoint`).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output file, repeatable: an image (.png, .pfm, .exr, .hdr) or, with any other extension,
    /// the merged partial file.
    #[arg(short = 'o', long = "output", value_name = "FILE", required = true)]
    pub outputs: Vec<PathBuf>,
    /// Write the image even when samples are missing (each pixel the mean of what it has).
    #[arg(long)]
    pub allow_incomplete: bool,
    /// How LDR outputs are tone mapped (gamma 2.2 unless --gamma, as for `render`).
    #[command(flatten)]
    pub tone: ToneArgs,
}

/// `convert`: an input and an output image.
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// The input image (.pfm, .exr, .hdr, .png).
    pub input: PathBuf,
    /// The output image (.pfm, .exr, .hdr, .png; `-` for a PNG on standard output).
    pub output: PathBuf,
    /// Memory budget in bytes (suffixes K, M, G, T), as for `render`.
    #[arg(long, value_name = "BYTES", value_parser = crate::bytes::parse_budget)]
    pub max_memory: Option<u64>,
    /// How an LDR output is tone mapped.
    #[command(flatten)]
    pub tone: ToneArgs,
}

/// Largest accepted image edge.
pub const MAX_SIZE: i64 = 1 << 15;
/// Largest accepted sample count per pixel.
pub const MAX_SPP: i64 = 1 << 20;

fn positive_f64(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        Ok(_) => Err(format!("'{s}' must be a positive finite number")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}

/// `A..B` with A < B.
fn range(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("'{s}' is not a range A..B"))?;
    let num = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{x}' in '{s}' is not a whole number"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if a >= b {
        return Err(format!("'{s}': the range is empty (A must be less than B)"));
    }
    Ok((a, b))
}

fn sample_range(s: &str) -> Result<(u32, u32), String> {
    let r = range(s)?;
    if r.1 as i64 > MAX_SPP {
        return Err(format!("'{s}': sample indices go up to {MAX_SPP}"));
    }
    Ok(r)
}

fn frame_range(s: &str) -> Result<(u32, u32), String> {
    let r = range(s)?;
    if r.1 - r.0 > MAX_FRAMES {
        return Err(format!("'{s}': at most {MAX_FRAMES} frames per run"));
    }
    Ok(r)
}

/// Largest number of frames one `--frames` run renders.
pub const MAX_FRAMES: u32 = 1 << 20;

fn crop_window(s: &str) -> Result<[u32; 4], String> {
    let n: Vec<&str> = s.split(',').collect();
    let [x0, x1, y0, y1] = n[..] else {
        return Err(format!("'{s}' is not X0,X1,Y0,Y1"));
    };
    let num = |x: &str| {
        x.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{x}' in '{s}' is not a whole number"))
    };
    let c = [num(x0)?, num(x1)?, num(y0)?, num(y1)?];
    if c[0] >= c[1] || c[2] >= c[3] {
        return Err(format!("'{s}': the window is empty (X0 < X1 and Y0 < Y1)"));
    }
    Ok(c)
}

fn positive_f32(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        Ok(_) => Err(format!("'{s}' must be a positive finite number")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}
