//! `candela merge PART… -o OUT`: partial renders and checkpoints into the frame's image.
//!
//! The films' fixed-point sums are exact, so the merged image has the same bytes as one
//! uninterrupted render of the whole frame, whatever the split. Parts must come from the same
//! scene and settings and must not overlap (a pixel's sample index in two parts); missing
//! samples are refused unless `--allow-incomplete`, and the message lists what is missing.

use crate::args::MergeArgs;
use crate::exit::Usage;
use crate::images::{parse_aovs, tone_map, write_film, Extras, RENDER_GAMMA};
use crate::parts::{read_part, same_frame};
use anyhow::{bail, Context, Result};
use candela_imageio::partial::{encode_partial, Partial, PartialMeta};
use candela_imageio::write_atomically;
use candela_render::film::{Film, Window};
use std::path::PathBuf;

/// The extensions `merge -o` writes as a partial file (anything else must be an image).
const PARTIAL_EXTENSIONS: [&str; 5] = ["part", "partial", "cpart", "ckpt", "checkpoint"];

/// `candela merge`.
pub fn run(args: MergeArgs) -> Result<()> {
    let mut images = Vec::new();
    let mut partials = Vec::new();
    for o in &args.outputs {
        if candela_imageio::supported_extension(o) {
            images.push(o.clone());
        } else if o
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| PARTIAL_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        {
            partials.push(o.clone());
        } else {
            return Err(Usage(format!(
                "--output '{}': unknown format (an image .png, .pfm, .exr, .hdr, or a partial file .{})",
                o.display(),
                PARTIAL_EXTENSIONS.join(", .")
            ))
            .into());
        }
    }
    for o in &args.outputs {
        if args.parts.iter().any(|p| crate::outputs::same_file(p, o)) {
            return Err(Usage(format!(
                "--output '{}' is one of the parts to merge",
                o.display()
            ))
            .into());
        }
    }
    let parts: Vec<(PathBuf, Partial)> = args
        .parts
        .iter()
        .map(|p| Ok((p.clone(), read_part(p)?)))
        .collect::<Result<_>>()?;
    let (first_path, first) = &parts[0];
    for (path, part) in &parts[1..] {
        if let Err(why) = same_frame(part, &first.meta, &first.film) {
            bail!(
                "'{}' is not a part of the same render as '{}': {why}",
                path.display(),
                first_path.display()
            );
        }
    }
    for (i, (pa, a)) in parts.iter().enumerate() {
        for (pb, b) in &parts[..i] {
            let (ra, rb) = (a.meta.samples, b.meta.samples);
            let samples_meet = ra.0 < rb.1 && rb.0 < ra.1;
            if samples_meet && a.film.window().overlaps(&b.film.window()) {
                bail!(
                    "'{}' and '{}' overlap: both hold samples {}..{} of some pixels",
                    pb.display(),
                    pa.display(),
                    ra.0.max(rb.0),
                    ra.1.min(rb.1)
                );
            }
        }
    }

    let (width, height) = (first.film.width(), first.film.height());
    // The whole frame is allocated: refused, naming the file, when over the memory budget.
    let budget = crate::inputs::max_memory(None);
    if crate::inputs::render_memory(width, height, first.film.channels() as u64, budget).is_err() {
        bail!(
            "'{}': its {width}×{height} frame is more than the memory budget ({} MB) can merge (docs/limits.md)",
            first_path.display(),
            budget >> 20
        );
    }
    let spp = first.meta.spp;
    let full = Window::full(width, height);
    let mut film = Film::new(width, height, full, first.film.channels());
    for (path, part) in &parts {
        film.merge(&part.film)
            .map_err(|why| anyhow::anyhow!("'{}': {why}", path.display()))?;
    }
    // A merged partial file may be a piece of the frame; an image must be all of it.
    let missing = if images.is_empty() {
        Vec::new()
    } else {
        missing_samples(&parts, width, height, spp)
    };
    if !missing.is_empty() {
        let report = missing.join("\n  ");
        if !args.allow_incomplete {
            bail!("the parts do not cover the frame (--allow-incomplete writes what there is):\n  {report}");
        }
        eprintln!("candela: warning: incomplete merge, each pixel the mean of the samples it has:\n  {report}");
    }

    let merged_partial = if partials.is_empty() {
        None
    } else {
        Some(merged_partial(&parts, &film)?)
    };
    // The output variables the parts hold, after the radiance.
    let aov_names = first
        .meta
        .settings
        .iter()
        .find(|(k, _)| k == "aovs")
        .map(|(_, v)| v.as_str());
    let aovs =
        parse_aovs(aov_names).map_err(|e| anyhow::anyhow!("'{}': {e}", first_path.display()))?;
    if 3 + aovs.channels() != film.channels() {
        bail!(
            "'{}': {} channels do not match its output variables",
            first_path.display(),
            film.channels()
        );
    }
    // The variables' files beside the images are outputs too: never one of the parts.
    crate::outputs::check(
        &crate::outputs::with_sides(&images, aovs, false),
        &args.parts,
    )?;
    let extras = Extras {
        aovs,
        written: aovs,
        exact_emission: false,
        denoise: false,
        keep_noisy: false,
    };
    let tone = tone_map(&args.tone, RENDER_GAMMA);
    write_film(&images, &film, full, &extras, &tone)?;
    if let Some(bytes) = merged_partial {
        for path in &partials {
            write_atomically(path, &bytes)
                .with_context(|| format!("cannot write '{}'", path.display()))?;
        }
    }
    Ok(())
}

/// The parts merged into one partial file: their bounding window must hold the same
/// contiguous sample range in every pixel.
fn merged_partial(parts: &[(PathBuf, Partial)], film: &Film) -> Result<Vec<u8>> {
    let mut w = parts[0].1.film.window();
    let (mut lo, mut hi) = parts[0].1.meta.samples;
    for (_, p) in parts {
        let v = p.film.window();
        w = Window {
            x0: w.x0.min(v.x0),
            x1: w.x1.max(v.x1),
            y0: w.y0.min(v.y0),
            y1: w.y1.max(v.y1),
        };
        lo = lo.min(p.meta.samples.0);
        hi = hi.max(p.meta.samples.1);
    }
    let counts = film.counts();
    let c = film.channels();
    let mut sums = Vec::with_capacity(w.pixels() * c);
    let mut window_counts = Vec::with_capacity(w.pixels());
    for y in w.y0..w.y1 {
        for x in w.x0..w.x1 {
            let i = y * film.width() + x;
            if counts[i] != hi - lo {
                bail!(
                    "a merged partial file needs samples {lo}..{hi} in every pixel of the window {},{},{},{}; pixel ({x}, {y}) has {}",
                    w.x0, w.x1, w.y0, w.y1, counts[i]
                );
            }
            sums.extend_from_slice(&film.sums()[i * c..(i + 1) * c]);
            window_counts.push(counts[i]);
        }
    }
    let out = Film::from_parts(film.width(), film.height(), w, c, sums, window_counts)
        .context("merging the windows")?;
    let meta = &parts[0].1.meta;
    Ok(encode_partial(&Partial {
        meta: PartialMeta {
            samples: (lo, hi),
            target: (lo, hi),
            ..meta.clone()
        },
        film: out,
    }))
}

/// What the parts leave out of the frame's `0..spp` samples, one line per sample interval
/// (empty when nothing is missing).
fn missing_samples(
    parts: &[(PathBuf, Partial)],
    width: usize,
    height: usize,
    spp: u32,
) -> Vec<String> {
    let mut cuts = vec![0, spp];
    for (_, p) in parts {
        cuts.extend([p.meta.samples.0, p.meta.samples.1]);
    }
    cuts.sort_unstable();
    cuts.dedup();
    let mut lines = Vec::new();
    let mut covered = vec![false; width * height];
    for span in cuts.windows(2) {
        let (a, b) = (span[0], span[1]);
        covered.fill(false);
        for (_, p) in parts {
            let (s0, s1) = p.meta.samples;
            if s0 <= a && b <= s1 {
                let w = p.film.window();
                for y in w.y0..w.y1 {
                    covered[y * width + w.x0..y * width + w.x1].fill(true);
                }
            }
        }
        let mut n = 0usize;
        let (mut x0, mut x1, mut y0, mut y1) = (usize::MAX, 0, usize::MAX, 0);
        for (i, _) in covered.iter().enumerate().filter(|(_, &c)| !c) {
            let (x, y) = (i % width, i / width);
            n += 1;
            x0 = x0.min(x);
            x1 = x1.max(x + 1);
            y0 = y0.min(y);
            y1 = y1.max(y + 1);
        }
        if n > 0 {
            lines.push(format!(
                "samples {a}..{b}: missing in {n} of {} pixels (within x {x0}..{x1}, y {y0}..{y1}; as --crop {x0},{x1},{y0},{y1} --samples {a}..{b})",
                width * height
            ));
        }
    }
    lines
}
