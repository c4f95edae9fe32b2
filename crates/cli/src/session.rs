//! The render loop of whole sample passes: every pass adds the same samples to every pixel of
//! the film, so after each one the film is a complete, smaller render. Between passes it saves
//! checkpoints, stops at a time limit, and gives up cleanly on SIGINT/SIGTERM (the pass in
//! flight is dropped, the film keeps every finished pass).

use crate::progress::Progress;
use anyhow::Result;
use candela_render::film::Film;
use candela_render::integrator::Integrator;
use candela_render::render::{render_pass_or_cancel, RenderSettings};
use candela_render::stats::RayStats;
use candela_render::Scene;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::Instant;

/// Set by SIGINT and SIGTERM.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// True until the run has work to save (the render loop starts): an interruption before then
/// ends the process at once, since loading a scene or solving radiosity does not poll
/// [`INTERRUPTED`] and nothing would be lost (no output is written yet).
pub static NOTHING_TO_SAVE: AtomicBool = AtomicBool::new(true);

/// Makes SIGINT and SIGTERM set [`INTERRUPTED`]; the process ends at once on a second one, or
/// on the first while there is [`NOTHING_TO_SAVE`].
pub fn catch_signals() {
    static SIGNALS: AtomicU32 = AtomicU32::new(0);
    // Only the first call of a process installs the handler; later calls fail harmlessly.
    let _ = ctrlc::set_handler(|| {
        INTERRUPTED.store(true, Ordering::SeqCst);
        let again = SIGNALS.fetch_add(1, Ordering::SeqCst) > 0;
        if NOTHING_TO_SAVE.load(Ordering::SeqCst) {
            eprintln!("candela: interrupted before rendering began: nothing written");
            std::process::exit(EXIT_INTERRUPTED);
        }
        if again {
            std::process::exit(EXIT_INTERRUPTED);
        }
    });
}

/// The exit status of an interrupted render (128 + SIGINT, as shells report it).
pub const EXIT_INTERRUPTED: i32 = 130;

/// The error of an interrupted render (its message says what was saved).
#[derive(Debug)]
pub struct Interrupted(pub String);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Interrupted {}

/// When to stop early and when to save.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// Save a checkpoint at least this often (seconds), if any.
    pub checkpoint_every: Option<f64>,
    /// Stop starting passes once this many seconds have passed, if any.
    pub time_limit: Option<f64>,
    /// Show the image after every pass (the preview): passes of a few seconds at most.
    pub progressive: bool,
}

/// How the loop ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ending {
    /// Every sample of the range is in the film.
    Complete,
    /// The time limit came first.
    TimeUp,
    /// SIGINT or SIGTERM came first.
    Interrupted,
}

/// The longest a pass should take when progress matters (checkpoints, time limits), so that
/// an interruption loses little.
const LONGEST_PASS: f64 = 30.0;
/// The most samples a pass takes.
const MOST_SAMPLES: u32 = 64;
/// The most samples a pass of a preview (without checkpoints or time limit) takes.
const MOST_PREVIEW_SAMPLES: u32 = 1024;
/// The length of a preview's second pass (the first has one sample); each next one is twice
/// as long.
const FIRST_PREVIEW_PASS: f64 = 0.5;

/// What a frame is rendered from.
#[derive(Clone, Copy)]
pub struct Job<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// The integrator.
    pub integrator: &'a dyn Integrator,
    /// Image size, spp, seed, sampler.
    pub settings: &'a RenderSettings,
}

/// Renders samples `first..last` into `film` in passes, calling `save(film, done)` for
/// checkpoints (every `plan.checkpoint_every` seconds). Returns how it ended, the first sample
/// index not yet in the film, and the counters of the passes.
pub fn run_passes(
    job: Job<'_>,
    film: &mut Film,
    (first, last): (u32, u32),
    plan: Plan,
    progress: &Progress,
    save: &mut dyn FnMut(&Film, u32) -> Result<()>,
    after_pass: &mut dyn FnMut(&Film, u32),
) -> Result<(Ending, u32, RayStats)> {
    let start = Instant::now();
    let mut last_save = (Instant::now(), first);
    let mut stats = RayStats::default();
    let mut done = first;
    let stepwise = plan.checkpoint_every.is_some() || plan.time_limit.is_some() || plan.progressive;
    // Seconds per sample of every pixel, from the last pass.
    let mut per_sample: Option<f64> = None;
    let mut passes: i32 = 0;
    while done < last {
        if INTERRUPTED.load(Ordering::SeqCst) {
            return Ok((Ending::Interrupted, done, stats));
        }
        let mut n = last - done;
        if stepwise {
            // A soft length (passes of whole batches of 16 samples trace fastest, so a pass
            // takes 16 when they fit in a hard length, but no more than the soft one allows).
            // A preview's passes double in length (a first image at once, then ever fewer
            // pass boundaries), up to the longest pass.
            let mut soft = if plan.progressive {
                (FIRST_PREVIEW_PASS * 2f64.powi(passes.min(30))).min(LONGEST_PASS)
            } else {
                LONGEST_PASS
            };
            let mut hard = f64::INFINITY;
            if let Some(every) = plan.checkpoint_every {
                soft = soft.min(every / 2.0);
                hard = hard.min(every);
            }
            if let Some(limit) = plan.time_limit {
                let left = limit - start.elapsed().as_secs_f64();
                // One pass always runs, so that a time-limited render has an image.
                if done > first && per_sample.is_some_and(|t| t > left) {
                    return Ok((Ending::TimeUp, done, stats));
                }
                soft = soft.min(left);
                hard = hard.min(left);
            }
            n = match per_sample {
                // A first pass that measures the time per sample: one sample when a time
                // limit or a checkpoint interval must be kept, else one batch of 16 (the
                // preview's first image; shorter passes trace less efficiently).
                None if plan.time_limit.is_none() && plan.checkpoint_every.is_none() => 16,
                None => 1,
                Some(t) => {
                    // Checkpoints and time limits keep passes short; a preview alone lets
                    // them grow (fewer boundaries, each costing a little).
                    let most = if plan.checkpoint_every.is_none() && plan.time_limit.is_none() {
                        MOST_PREVIEW_SAMPLES
                    } else {
                        MOST_SAMPLES
                    };
                    let fit = |secs: f64| (secs / t.max(1e-9)).floor().min(most as f64) as u32;
                    let mut k = fit(soft);
                    if k < 16 {
                        k = fit(hard).min(16);
                    }
                    if k >= 16 {
                        // End on a multiple of 16: whole batches, and the sampler's tables
                        // (chunks of 64 samples) filled once.
                        k = (done + k) / 16 * 16 - done;
                    }
                    k.max(1)
                }
            }
            .min(last - done);
            // Save before a pass that would end more than one interval after the last save,
            // so that a kill loses at most about one interval.
            if let (Some(every), Some(t)) = (plan.checkpoint_every, per_sample) {
                let since = last_save.0.elapsed().as_secs_f64();
                if done > last_save.1 && since + t * n as f64 > every {
                    save(film, done)?;
                    last_save = (Instant::now(), done);
                }
            }
        }
        let t0 = Instant::now();
        let pass = render_pass_or_cancel(
            job.scene,
            job.integrator,
            job.settings,
            film,
            (done, done + n),
            &|k| progress.add(k),
            &INTERRUPTED,
        );
        let Some(s) = pass else {
            return Ok((Ending::Interrupted, done, stats));
        };
        per_sample = Some(t0.elapsed().as_secs_f64() / n as f64);
        done += n;
        passes += 1;
        stats += s;
        progress.pass_done(&s);
        after_pass(film, done);
    }
    Ok((Ending::Complete, done, stats))
}
