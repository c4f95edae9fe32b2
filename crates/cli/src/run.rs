//! `candela demo` and `candela render`: load, validate options, render, write.

use crate::args::{RenderArgs, SceneArgs};
use crate::exit::Usage;
use crate::frames;
use crate::identity;
use crate::images::{crop, parse_aovs, tone_map, write_film, Extras, RENDER_GAMMA};
use crate::parts;
use crate::preview::{Preview, Status as PreviewStatus};
use crate::progress::{json_string, Progress, ProgressMode};
use crate::session::{self, run_passes, Ending, Interrupted, Job, Plan};
use anyhow::{bail, Context, Result};
use candela_imageio::partial::{encode_partial, Partial, PartialMeta};
use candela_imageio::write_atomically;
use candela_render::accel::AccelKind;
use candela_render::aov::{Aov, AovSet};
use candela_render::film::{Film, Window};
use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::radiosity::{
    CacheStatus, FormFactorMethod, RadiosityOptions, RadiosityOutcome, SolverKind,
};
use candela_render::render::RenderSettings;
use candela_render::sampling::SamplerKind;
use candela_scene::{LoadOptions, LoadedScene};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `candela demo`.
pub fn demo(args: RenderArgs) -> Result<()> {
    run_frames(Source::Demo, &args)
}

/// `candela render SCENE` (`-`: standard input).
pub fn render(a: SceneArgs) -> Result<()> {
    if crate::inputs::is_stdin(&a.scene) {
        run_frames(Source::Stdin, &a.render)
    } else {
        run_frames(Source::File(&a.scene), &a.render)
    }
}

/// Where the scene comes from.
#[derive(Clone, Copy)]
enum Source<'a> {
    /// The built-in demo.
    Demo,
    /// A scene file.
    File(&'a Path),
    /// Standard input (`render -`), read once for every frame.
    Stdin,
}

/// Renders each frame of `--frames` (or the one frame) of the scene.
fn run_frames(scene: Source<'_>, args: &RenderArgs) -> Result<()> {
    let default_out = match scene {
        Source::File(s) => crate::inputs::default_output(s),
        Source::Stdin => crate::inputs::default_output(Path::new("-")),
        Source::Demo => "demo.png".to_string(),
    };
    let outputs = crate::outputs::resolve(&args.outputs, &default_out);
    let base_opts = load_options(args)?;
    // The scene's text when it is not a file: hashed for partial renders and checkpoints.
    let text = match scene {
        Source::Demo => Some(candela_scene::DEMO_SCENE.to_string()),
        Source::File(_) => None,
        Source::Stdin => Some(
            candela_scene::read_stdin_scene(&base_opts.limits)
                .map_err(|e| anyhow::anyhow!("{e}"))?,
        ),
    };
    let mode = ProgressMode::from_args(args.progress.as_deref(), args.quiet)?;
    let frames: Vec<Option<u32>> = match args.frames {
        Some((a, b)) => (a..b).map(Some).collect(),
        None => vec![None],
    };
    if frames.len() > 1 {
        let named = outputs
            .iter()
            .chain(&args.partial)
            .chain(&args.checkpoint)
            .chain(&args.resume);
        for p in named {
            if !frames::has_number(p) {
                return Err(Usage(format!(
                    "--frames: '{}' has no %d (or %04d) for the frame number, so every frame would overwrite it",
                    p.display()
                ))
                .into());
            }
        }
    }
    session::catch_signals();
    let preview = if args.preview {
        Some(Preview::start(args.preview_port)?)
    } else {
        None
    };
    let show = Show {
        mode,
        preview: preview.as_ref(),
    };
    for frame in frames {
        let mut opts = base_opts.clone();
        let paths = FramePaths {
            outputs: outputs.iter().map(|p| frames::name(p, frame)).collect(),
            partial: args.partial.as_deref().map(|p| frames::name(p, frame)),
            checkpoint: args.checkpoint.as_deref().map(|p| frames::name(p, frame)),
            resume: args.resume.as_deref().map(|p| frames::name(p, frame)),
        };
        if let Some(f) = frame {
            opts.defines.push((args.frame_var.clone(), f.to_string()));
        }
        let start = Instant::now();
        let loaded = match (scene, &text) {
            (Source::File(path), _) => candela_scene::load_scene(path, &opts),
            (Source::Stdin, Some(text)) => candela_scene::load_scene_text(text, &opts),
            _ => candela_scene::demo_scene(&opts),
        }
        // Scene errors carry their own `file:line:col`; print them as they are.
        .map_err(|e| anyhow::anyhow!("{e}"))?;
        let load_seconds = start.elapsed().as_secs_f64();
        let loaded = Loaded {
            scene: loaded,
            text: text.as_deref(),
            seconds: load_seconds,
        };
        render_frame(loaded, args, &opts.defines, &paths, frame, show)?;
    }
    if let (Some(p), true) = (&preview, args.preview_hold) {
        p.hold();
    }
    Ok(())
}

/// How a render shows its progress: on stderr, and on the preview page if there is one.
#[derive(Clone, Copy)]
struct Show<'a> {
    mode: ProgressMode,
    preview: Option<&'a Preview>,
}

/// A frame's loaded scene.
struct Loaded<'a> {
    scene: LoadedScene,
    /// The scene's text when it is not a file (the demo, standard input), for its hash.
    text: Option<&'a str>,
    /// Seconds the load took.
    seconds: f64,
}

/// The files one frame reads and writes (`%d` already replaced).
struct FramePaths {
    outputs: Vec<PathBuf>,
    partial: Option<PathBuf>,
    checkpoint: Option<PathBuf>,
    resume: Option<PathBuf>,
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

/// The output variables of `--aov`, with albedo and normal added for `--denoise`.
fn aov_set(args: &RenderArgs) -> Result<AovSet> {
    let mut set = parse_aovs(args.aov.as_deref())?;
    if args.denoise {
        set = set
            .with(Aov::Albedo)
            .with(Aov::Normal)
            .with(Aov::Emission)
            .with(Aov::EmissionAa);
    }
    Ok(set)
}

/// Everything the scene loaders need from the command line (checking the other options that
/// need no scene first, so that a bad one fails before any work).
fn load_options(args: &RenderArgs) -> Result<LoadOptions> {
    sampler_kind(args)?;
    aov_set(args)?;
    if args.denoise && !candela_denoise::available() {
        bail!(
            "--denoise: Intel Open Image Denoise 2.x cannot be loaded: {}",
            candela_denoise::HOW_TO_GET_OIDN
        );
    }
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

/// Prints the radiosity warnings (and the report with `--stats`).
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
    Ok(())
}

/// Saves a computed radiosity solution to `--radiosity-cache`: after the images (a failed
/// image write leaves no cache behind), or when the render is interrupted (the solution is
/// finished work).
fn save_radiosity_cache(outcome: Option<&RadiosityOutcome>, args: &RenderArgs) -> Result<()> {
    if let (Some(path), Some(bytes)) = (
        &args.radiosity_cache,
        outcome.and_then(|o| o.cache_bytes.as_ref()),
    ) {
        write_atomically(path, bytes).map_err(|e| {
            crate::exit::Output(format!(
                "--radiosity-cache '{}': cannot write it ({e})",
                path.display()
            ))
        })?;
    }
    Ok(())
}

fn render_frame(
    loaded: Loaded<'_>,
    args: &RenderArgs,
    defines: &[(String, String)],
    paths: &FramePaths,
    frame: Option<u32>,
    show: Show<'_>,
) -> Result<()> {
    let Loaded {
        scene: mut loaded,
        text,
        seconds: load_seconds,
    } = loaded;
    for w in &loaded.warnings {
        eprintln!("candela: warning: {w}");
    }
    crate::outputs::not_inputs(
        &crate::inputs::with_side_outputs(&paths.outputs, args),
        &loaded.inputs,
    )?;
    for (option, path) in [
        ("--partial", &paths.partial),
        ("--checkpoint", &paths.checkpoint),
        ("--radiosity-cache", &args.radiosity_cache),
    ] {
        if let Some(p) = path {
            crate::outputs::check_partial_target(option, p, &[], &loaded.inputs)?;
        }
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
    let settings = RenderSettings {
        width: args.width.or(hints.width).unwrap_or(640) as usize,
        height: args.height.or(hints.height).unwrap_or(480) as usize,
        spp: args.spp.or(hints.spp).unwrap_or(1),
        seed: args.seed,
        sampler: sampler_kind(args)?,
        aovs: aov_set(args)?,
        filter: args
            .filter
            .as_deref()
            .and_then(candela_render::filter::Filter::by_name)
            .or(hints.filter)
            .unwrap_or_default(),
        spectral: args.spectral,
    };
    if args.spectral {
        crate::inputs::spectral_integrator(args, kind, name)?;
        loaded.scene.prepare_spectral();
    }
    crate::inputs::check_render(settings.width, settings.height, args)?;
    // What this job renders: a window of the frame and a range of sample indices.
    let window = match args.crop {
        None => Window::full(settings.width, settings.height),
        Some([x0, x1, y0, y1]) => {
            let w = Window {
                x0: x0 as usize,
                x1: x1 as usize,
                y0: y0 as usize,
                y1: y1 as usize,
            };
            if !w.fits(settings.width, settings.height) {
                return Err(Usage(format!(
                    "--crop {x0},{x1},{y0},{y1}: the window does not fit the {}×{} image",
                    settings.width, settings.height
                ))
                .into());
            }
            w
        }
    };
    let target = args.samples.unwrap_or((0, settings.spp));
    if target.1 > settings.spp {
        return Err(Usage(format!(
            "--samples {}..{}: the frame has only {} samples per pixel (--spp)",
            target.0, target.1, settings.spp
        ))
        .into());
    }
    // A time limit without a checkpoint file saves beside the first output.
    let checkpoint = paths
        .checkpoint
        .clone()
        .or(paths.resume.clone())
        .or_else(|| {
            args.time_limit.map(|_| {
                let first = paths.partial.as_ref().unwrap_or(&paths.outputs[0]);
                let mut name = first.clone().into_os_string();
                name.push(".checkpoint");
                PathBuf::from(name)
            })
        });
    if let (Some(c), None, None) = (&checkpoint, &paths.checkpoint, &paths.resume) {
        // The checkpoint --time-limit saves beside the first output.
        crate::outputs::check_partial_target("--time-limit's checkpoint", c, &[], &loaded.inputs)?;
    }
    let needs_identity = paths.partial.is_some() || checkpoint.is_some();
    let meta = if needs_identity {
        let scene =
            identity::scene_hash(text, &loaded.inputs).context("hashing the scene's files")?;
        Some(PartialMeta {
            spp: settings.spp,
            samples: (target.0, target.0),
            target,
            scene,
            settings: identity::pixel_settings(
                args,
                defines,
                &settings,
                kind,
                &integrator_settings,
            ),
        })
    } else {
        None
    };
    let channels = 3 + settings.aovs.channels();
    let mut film = Film::new(settings.width, settings.height, window, channels);
    let mut first = target.0;
    if let Some(path) = &paths.resume {
        let part = parts::read_part(path)?;
        let meta = meta.as_ref().expect("resuming needs the identity");
        if let Err(why) = parts::same_job(&part, meta, &film) {
            bail!(
                "--resume '{}': the checkpoint is of another render ({why})",
                path.display()
            );
        }
        first = part.meta.samples.1;
        film = part.film;
    }

    if matches!(kind, IntegratorKind::Path | IntegratorKind::Radiosity) {
        for place in &loaded.local_model_terms {
            eprintln!("candela: warning: {place} is a term of the local model, ignored by the {name} integrator");
        }
    }
    let built = kind
        .build(&loaded.scene, &integrator_settings)
        .map_err(|e| anyhow::anyhow!("--integrator '{name}': {e}"))?;
    // From here on an interruption is handled by the render loop (it saves what it has).
    session::NOTHING_TO_SAVE.store(false, std::sync::atomic::Ordering::SeqCst);
    if let Some(outcome) = &built.radiosity {
        radiosity_outcome(outcome, args)?;
    }
    let integrator = &built.integrator;
    let pool = worker_pool(args.threads)?;

    let per_sample = window.pixels() as u64;
    let progress = Progress::new(
        show.mode,
        per_sample * (target.1 - target.0) as u64,
        per_sample * (first - target.0) as u64,
        frame,
    );
    let save_partial = |path: &Path, film: &Film, done: u32| -> Result<()> {
        let meta = meta.as_ref().expect("partial files need the identity");
        let part = Partial {
            meta: PartialMeta {
                samples: (target.0, done),
                ..meta.clone()
            },
            film: film.clone(),
        };
        write_atomically(path, &encode_partial(&part))
            .with_context(|| format!("cannot write '{}'", path.display()))
    };
    let mut save_checkpoint = |film: &Film, done: u32| -> Result<()> {
        if let Some(path) = &checkpoint {
            save_partial(path, film, done)?;
            progress.event(
                "checkpoint",
                &format!(
                    ",\"file\":{},\"samples\":[{},{done}]",
                    json_string(&path.to_string_lossy()),
                    target.0
                ),
            );
        }
        Ok(())
    };
    let plan = Plan {
        checkpoint_every: checkpoint.as_ref().map(|_| args.checkpoint_every),
        time_limit: args.time_limit,
        progressive: show.preview.is_some(),
    };
    let spp_total = target.1 - target.0;
    let status = |state: &'static str, done: u32| {
        let (rays_per_s, eta_s, elapsed_s) = progress.rates();
        PreviewStatus {
            state,
            spp_done: done - target.0,
            spp_total,
            rays_per_s,
            eta_s: if state == "rendering" {
                eta_s
            } else {
                Some(0.0)
            },
            elapsed_s,
        }
    };
    if let Some(p) = show.preview {
        p.set_status(status("rendering", first));
    }
    let mut after_pass = |film: &Film, done: u32| {
        if let Some(p) = show.preview {
            p.publish(crop(&film.rgb(0), window), status("rendering", done));
        }
    };
    let job = Job {
        scene: &loaded.scene,
        integrator: integrator.as_ref(),
        settings: &settings,
    };
    let start = Instant::now();
    let (ending, done, stats) = pool.install(|| {
        run_passes(
            job,
            &mut film,
            (first, target.1),
            plan,
            &progress,
            &mut save_checkpoint,
            &mut after_pass,
        )
    })?;
    let seconds = start.elapsed().as_secs_f64();
    progress.finish();

    let held = format!("samples {}..{done} of {}..{}", target.0, target.0, target.1);
    match ending {
        Ending::Interrupted => {
            let saved = match &checkpoint {
                Some(path) => {
                    save_checkpoint(&film, done)?;
                    format!(
                        "{held} saved in '{}' (continue with --resume)",
                        path.display()
                    )
                }
                None => format!("{held} done, not saved (--checkpoint FILE keeps them)"),
            };
            save_radiosity_cache(built.radiosity.as_ref(), args)?;
            return Err(Interrupted(format!("interrupted: {saved}")).into());
        }
        Ending::TimeUp => {
            save_checkpoint(&film, done)?;
            progress.message(&format!(
                "time limit reached: {held}; continue with --resume '{}'",
                checkpoint
                    .as_ref()
                    .map(|p| p.display().to_string())
                    .unwrap_or_default()
            ));
        }
        Ending::Complete => {
            if paths.checkpoint.is_some() || paths.resume.is_some() {
                save_checkpoint(&film, done)?;
            }
        }
    }

    if let Some(path) = &paths.partial {
        save_partial(path, &film, done)?;
        if let Some(p) = show.preview {
            p.publish(crop(&film.rgb(0), window), status("done", done));
        }
    } else {
        let extras = Extras {
            aovs: settings.aovs,
            written: parse_aovs(args.aov.as_deref())?,
            exact_emission: kind == IntegratorKind::Path && !hints.hide_emitters,
            denoise: args.denoise,
            keep_noisy: !args.no_keep_noisy,
        };
        let tone = tone_map(&args.tone, RENDER_GAMMA);
        let image = write_film(&paths.outputs, &film, window, &extras, &tone)?;
        if let Some(p) = show.preview {
            let state = if args.denoise { "denoised" } else { "done" };
            p.publish(image, status(state, done));
        }
    }
    save_radiosity_cache(built.radiosity.as_ref(), args)?;
    progress.event("done", "");
    if args.stats {
        eprintln!("scene loaded and built in {load_seconds:.3} s");
        if let Some((triangles, bytes)) = loaded.mesh_stats {
            eprintln!("meshes: {triangles} triangles, {bytes:.1} bytes per triangle");
        }
        if !loaded.scene.instances.is_empty() {
            eprintln!("instances: {}", loaded.scene.instances.describe());
        }
        let s = &stats;
        let rays = s.total_rays();
        eprintln!(
            "{}x{} at {} spp with {} ({} threads): {:.3} s, {} rays ({} camera/bounce + {} shadow), {:.3} Mrays/s, {:.3} Msamples/s, {:.1} nodes and {:.1} primitive tests per ray, {} samples rejected (NaN/Inf)",
            window.width(),
            window.height(),
            done - first,
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

/// The worker threads: `threads` (default: one per core), or as many as the system lets start
/// (a tight address-space or process limit), with a warning; the image does not depend on the
/// count. An error only when not even one starts.
fn worker_pool(threads: Option<u32>) -> Result<rayon::ThreadPool> {
    let wanted = match threads {
        Some(n) => n as usize,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    // Under an address-space limit (`ulimit -v`) each thread's stack and malloc arena take
    // room (a 64 MiB arena each, reserved): at most one thread per 128 MiB of it.
    let room =
        crate::inputs::address_space_limit().map_or(usize::MAX, |l| (l >> 27).max(1) as usize);
    let mut n = wanted.clamp(1, room);
    loop {
        match rayon::ThreadPoolBuilder::new().num_threads(n).build() {
            Ok(pool) => {
                if n < wanted {
                    crate::exit::eprint_line(format_args!(
                        "candela: warning: --threads: only {n} of {wanted} worker threads could start (system limits); the image is the same"
                    ));
                }
                return Ok(pool);
            }
            Err(e) if n == 1 => {
                return Err(anyhow::anyhow!(
                    "--threads: cannot start a worker thread: {e}"
                ))
            }
            Err(_) => n /= 2,
        }
    }
}
