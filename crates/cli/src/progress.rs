//! Progress on stderr: a bar for people, JSON lines for schedulers and wrappers
//! (`--progress json`, documented in docs/command-line.md), or nothing.

use anyhow::Result;
use candela_render::stats::RayStats;
use indicatif::{ProgressBar, ProgressStyle};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// An indicatif bar.
    Bar,
    /// One JSON object per line.
    Json,
    /// Nothing.
    None,
}

impl ProgressMode {
    /// From `--progress` and `--quiet`.
    pub fn from_args(progress: Option<&str>, quiet: bool) -> Result<Self> {
        Ok(match progress {
            None if quiet => Self::None,
            None | Some("bar") => Self::Bar,
            Some("json") => Self::Json,
            Some("none") => Self::None,
            Some(other) => {
                return Err(crate::exit::Usage(format!(
                "--progress '{other}': unknown progress style (expected one of: bar, json, none)"
            ))
                .into())
            }
        })
    }
}

/// JSON lines at most this often while a pass runs (every pass end prints one too).
const JSON_EVERY: Duration = Duration::from_millis(1000);

/// The progress of one frame's render.
pub struct Progress {
    mode: ProgressMode,
    bar: ProgressBar,
    frame: Option<u32>,
    /// Samples (pixel × sample) of the whole job and those done before this run (resumed).
    total: u64,
    resumed: u64,
    /// Samples done in this run.
    done: AtomicU64,
    start: Instant,
    last_line: Mutex<Instant>,
    /// Rays and samples of the finished passes, for rays/s.
    rays: AtomicU64,
    samples_traced: AtomicU64,
}

impl Progress {
    /// Progress of a job of `total` samples of which `resumed` were done before.
    pub fn new(mode: ProgressMode, total: u64, resumed: u64, frame: Option<u32>) -> Self {
        let bar = if mode == ProgressMode::Bar {
            let b = ProgressBar::new(total);
            b.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {percent}% ETA {eta}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            b.set_position(resumed);
            b.reset_eta();
            b
        } else {
            ProgressBar::hidden()
        };
        let now = Instant::now();
        Self {
            mode,
            bar,
            frame,
            total,
            resumed,
            done: AtomicU64::new(0),
            start: now,
            last_line: Mutex::new(now),
            rays: AtomicU64::new(0),
            samples_traced: AtomicU64::new(0),
        }
    }

    /// `n` more samples done (called from worker threads).
    pub fn add(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
        self.bar.inc(n);
        self.tick();
    }

    /// A pass has finished with these counters.
    pub fn pass_done(&self, stats: &RayStats) {
        self.rays.fetch_add(stats.total_rays(), Ordering::Relaxed);
        self.samples_traced
            .fetch_add(stats.samples, Ordering::Relaxed);
        self.tick();
    }

    /// A JSON `progress` line if the last was at least [`JSON_EVERY`] ago.
    fn tick(&self) {
        if self.mode != ProgressMode::Json {
            return;
        }
        let due = self
            .last_line
            .try_lock()
            .map(|mut last| {
                let due = last.elapsed() >= JSON_EVERY;
                if due {
                    *last = Instant::now();
                }
                due
            })
            .unwrap_or(false);
        if due {
            self.line("progress", "");
        }
    }

    /// A JSON event line (`extra` is more `"key": value` members, with a leading comma).
    pub fn event(&self, event: &str, extra: &str) {
        if self.mode == ProgressMode::Json {
            self.line(event, extra);
        }
    }

    /// A message for people: above the bar, or as a JSON `message` event.
    pub fn message(&self, text: &str) {
        match self.mode {
            ProgressMode::Json => self.line("message", &format!(",\"text\":{}", json_string(text))),
            _ => self.bar.suspend(|| eprintln!("candela: {text}")),
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }

    /// Rays per second and seconds to go (once known), and seconds elapsed.
    pub fn rates(&self) -> (Option<f64>, Option<f64>, f64) {
        let done = self.done.load(Ordering::Relaxed);
        let secs = self.start.elapsed().as_secs_f64();
        let rate = if secs > 0.0 { done as f64 / secs } else { 0.0 };
        let left = self.total.saturating_sub(self.resumed + done) as f64;
        let eta = (rate > 0.0).then(|| left / rate);
        let traced = self.samples_traced.load(Ordering::Relaxed);
        let rays =
            (traced > 0).then(|| self.rays.load(Ordering::Relaxed) as f64 / traced as f64 * rate);
        (rays, eta, secs)
    }

    fn line(&self, event: &str, extra: &str) {
        let done = self.done.load(Ordering::Relaxed);
        let (rays_per_s, eta, secs) = self.rates();
        let rate = if secs > 0.0 { done as f64 / secs } else { 0.0 };
        let all = self.resumed + done;
        let num =
            |v: Option<f64>, digits: usize| v.map_or("null".into(), |x| format!("{x:.digits$}"));
        let (eta, rays_per_s) = (num(eta, 3), num(rays_per_s, 0));
        let frame = self.frame.map_or("null".into(), |f| f.to_string());
        let fraction = if self.total > 0 {
            all as f64 / self.total as f64
        } else {
            1.0
        };
        eprintln!(
            "{{\"event\":{},\"frame\":{frame},\"samples_done\":{all},\"samples_total\":{},\"fraction\":{fraction:.6},\"elapsed_s\":{secs:.3},\"samples_per_s\":{rate:.0},\"rays_per_s\":{rays_per_s},\"eta_s\":{eta}{extra}}}",
            json_string(event),
            self.total
        );
    }
}

/// A JSON string literal.
pub fn json_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}
