//! `candela demo` and `candela render`: load, validate options, render, write.

use crate::args::{RenderArgs, SceneArgs, ToneArgs};
use anyhow::{bail, Context, Result};
use candela_imageio::{write_atomically, Encoding, ToneMap};
use candela_render::accel::AccelKind;
use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::radiosity::{
    CacheStatus, FormFactorMethod, RadiosityOptions, RadiosityOutcome, SolverKind,
};
use candela_render::render::{render as render_image, RenderSettings};
use candela_render::sampling::SamplerKind;
use candela_scene::{LoadOptions, LoadedScene};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

/// `candela demo`.
pub fn demo(args: RenderArgs) -> Result<()> {
    let outputs = crate::outputs::resolve(&args.outputs, "demo.png");
    let opts = load_options(&args)?;
    let start = Instant::now();
    let loaded = candela_scene::demo_scene(&opts).map_err(|e| anyhow::anyhow!("{e}"))?;
    render_and_write(loaded, &args, &outputs, start.elapsed().as_secs_f64())
}

/// `candela render SCENE`.
pub fn render(a: SceneArgs) -> Result<()> {
    let default_out = crate::inputs::default_output(&a.scene);
    let outputs = crate::outputs::resolve(&a.render.outputs, &default_out);
    let opts = load_options(&a.render)?;
    // Scene errors carry their own `file:line:col`; print them as they are.
    let start = Instant::now();
    let loaded = candela_scene::load_scene(&a.scene, &opts).map_err(|e| anyhow::anyhow!("{e}"))?;
    render_and_write(loaded, &a.render, &outputs, start.elapsed().as_secs_f64())
}

/// The `--sampler` option.
fn sampler_kind(args: &RenderArgs) -> Result<SamplerKind> {
    match &args.sampler {
        None => Ok(SamplerKind::default()),
        Some(name) => SamplerKind::from_name(name).with_context(|| {
            format!(
                "--sampler '{name}': unknown sampler (expected one of: {})",
                SamplerKind::NAMES.join(", ")
            )
        }),
    }
}

/// Everything the scene loaders need from the command line (checking the other options that
/// need no scene first, so that a bad one fails before any work).
fn load_options(args: &RenderArgs) -> Result<LoadOptions> {
    sampler_kind(args)?;
    let accel = match &args.accel {
        None => AccelKind::default(),
        Some(name) => {
            AccelKind::parse(name).map_err(|e| anyhow::anyhow!("--accel '{name}': {e}"))?
        }
    };
    let mut defines = Vec::new();
    for d in &args.defines {
        let (name, value) = d
            .split_once('=')
            .or_else(|| d.split_once(':'))
            .with_context(|| format!("--define '{d}': expected NAME=VALUE or NAME:VALUE"))?;
        if name.trim().is_empty() {
            bail!("--define '{d}': the name is empty");
        }
        defines.push((name.trim().to_string(), value.trim().to_string()));
    }
    Ok(LoadOptions {
        defines,
        accel,
        limits: crate::inputs::limits(args),
    })
}

/// Builds the tone mapping for LDR outputs, with `default_gamma` unless `--gamma` is given.
pub fn tone_map(t: &ToneArgs, default_gamma: f32) -> ToneMap {
    ToneMap {
        factor: t.factor,
        luminosity: t.luminosity,
        encoding: if t.srgb {
            Encoding::Srgb
        } else {
            Encoding::Gamma(t.gamma.unwrap_or(default_gamma))
        },
    }
}

/// The radiosity options of the command line (`--patch-size`, `--form-factors`, `--solver`,
/// `--radiosity-cache`); the cache file is read only for the `radiosity` integrator.
fn radiosity_options(args: &RenderArgs, kind: IntegratorKind) -> Result<RadiosityOptions> {
    let mut o = RadiosityOptions {
        seed: args.seed,
        ..Default::default()
    };
    if let Some(h) = args.patch_size {
        if !(h > 0.0 && h.is_finite()) {
            bail!("--patch-size '{h}': the patch size must be a positive number");
        }
        o.patch_size = Some(h);
    }
    if let Some(name) = &args.form_factors {
        o.form_factors = FormFactorMethod::from_name(name).with_context(|| {
            format!(
                "--form-factors '{name}': unknown form-factor method (expected one of: {})",
                FormFactorMethod::NAMES.join(", ")
            )
        })?;
    }
    if let Some(name) = &args.solver {
        o.solver = SolverKind::from_name(name).with_context(|| {
            format!(
                "--solver '{name}': unknown radiosity solver (expected one of: {})",
                SolverKind::NAMES.join(", ")
            )
        })?;
    }
    if kind == IntegratorKind::Radiosity {
        if let Some(path) = &args.radiosity_cache {
            match crate::inputs::read_cache(path, args) {
                Ok(bytes) => o.cache = Some(bytes.into()),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => eprintln!(
                    "candela: warning: --radiosity-cache '{}': cannot read it ({e}); solving again",
                    path.display()
                ),
            }
        }
    }
    Ok(o)
}

/// Prints the radiosity warnings (and the report with `--stats`) and saves a computed
/// solution to `--radiosity-cache`.
fn radiosity_outcome(outcome: &RadiosityOutcome, args: &RenderArgs) -> Result<()> {
    for w in &outcome.report.warnings {
        eprintln!("candela: warning: {w}");
    }
    if let Some(path) = &args.radiosity_cache {
        match &outcome.report.cache {
            CacheStatus::Stale => {
                eprintln!("candela: --radiosity-cache '{}' does not match this scene and these options: solved again", path.display())
            }
            CacheStatus::Invalid(why) => eprintln!(
                "candela: --radiosity-cache '{}' is invalid ({why}): solved again",
                path.display()
            ),
            CacheStatus::Loaded | CacheStatus::NotUsed => {}
        }
    }
    if args.stats {
        eprintln!("{}", outcome.report);
    }
    if let (Some(path), Some(bytes)) = (&args.radiosity_cache, &outcome.cache_bytes) {
        write_atomically(path, bytes)
            .with_context(|| format!("--radiosity-cache '{}': cannot write it", path.display()))?;
    }
    Ok(())
}

/// The display gamma of rendered LDR images unless `--gamma` says otherwise.
const RENDER_GAMMA: f32 = 2.2;

fn render_and_write(
    loaded: LoadedScene,
    args: &RenderArgs,
    outputs: &[PathBuf],
    load_seconds: f64,
) -> Result<()> {
    crate::outputs::not_inputs(outputs, &loaded.inputs)?;
    for w in &loaded.warnings {
        eprintln!("candela: warning: {w}");
    }
    let hints = &loaded.hints;
    let name = args
        .integrator
        .as_deref()
        .or(hints.integrator.as_deref())
        .unwrap_or("path");
    let kind = IntegratorKind::from_name(name).with_context(|| {
        format!(
            "--integrator '{name}': unknown integrator (expected one of: {})",
            IntegratorKind::NAMES.join(", ")
        )
    })?;
    let integrator_settings = IntegratorSettings {
        max_depth: args.max_depth.or(hints.max_depth),
        num_of_rays: args.num_of_rays.unwrap_or(1),
        rr_depth: hints.rr_depth,
        hide_emitters: hints.hide_emitters,
        radiosity: radiosity_options(args, kind)?,
    };
    if matches!(kind, IntegratorKind::Path | IntegratorKind::Radiosity) {
        for place in &loaded.local_model_terms {
            eprintln!("candela: warning: {place} is a term of the local model, ignored by the {name} integrator");
        }
    }
    let built = kind
        .build(&loaded.scene, &integrator_settings)
        .map_err(|e| anyhow::anyhow!("--integrator '{name}': {e}"))?;
    if let Some(outcome) = &built.radiosity {
        radiosity_outcome(outcome, args)?;
    }
    let integrator = built.integrator;

    let settings = RenderSettings {
        width: args.width.or(hints.width).unwrap_or(640) as usize,
        height: args.height.or(hints.height).unwrap_or(480) as usize,
        spp: args.spp.or(hints.spp).unwrap_or(1),
        seed: args.seed,
        sampler: sampler_kind(args)?,
    };
    crate::inputs::check_render(settings.width, settings.height, args)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0) as usize)
        .build()
        .context("--threads: cannot start the worker threads")?;

    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new((settings.width * settings.height) as u64 * settings.spp as u64);
        b.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {percent}% ETA {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    };
    let start = Instant::now();
    let out = pool.install(|| {
        render_image(&loaded.scene, integrator.as_ref(), &settings, &|n| {
            bar.inc(n)
        })
    });
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let tone = tone_map(&args.tone, RENDER_GAMMA);
    crate::outputs::write_all(outputs, &out.image, &tone)?;
    if args.stats {
        eprintln!("scene loaded and built in {load_seconds:.3} s");
        if let Some((triangles, bytes)) = loaded.mesh_stats {
            eprintln!("meshes: {triangles} triangles, {bytes:.1} bytes per triangle");
        }
        let s = &out.stats;
        let rays = s.total_rays();
        eprintln!(
            "{}x{} at {} spp with {} ({} threads): {:.3} s, {} rays ({} camera/bounce + {} shadow), {:.3} Mrays/s, {:.3} Msamples/s, {:.1} nodes and {:.1} primitive tests per ray, {} samples rejected (NaN/Inf)",
            settings.width,
            settings.height,
            settings.spp,
            name,
            pool.current_num_threads(),
            seconds,
            rays,
            s.rays,
            s.shadow_rays,
            rays as f64 / seconds / 1e6,
            s.samples as f64 / seconds / 1e6,
            s.nodes as f64 / rays.max(1) as f64,
            s.prim_tests as f64 / rays.max(1) as f64,
            s.rejected_samples
        );
    }
    Ok(())
}
