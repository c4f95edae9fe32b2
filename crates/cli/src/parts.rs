//! Partial files as a render reads them: read and checked, and compared with the job at hand
//! (the same scene, settings and frame).

use anyhow::Result;
use candela_imageio::partial::{decode_partial, Partial, PartialMeta};
use candela_render::film::Film;
use std::path::Path;

/// Reads and checks a partial file; errors name the file.
pub fn read_part(path: &Path) -> Result<Partial> {
    // A regular file (never a FIFO or device), at most a quarter of the memory budget: the
    // decoded sums take about twice the file's size.
    let limit = crate::inputs::max_memory(None) / 4;
    let bytes = candela_imageio::input::read_file(path, limit)
        .map_err(|e| anyhow::anyhow!("'{}': {e}", path.display()))?;
    decode_partial(&bytes).map_err(|why| anyhow::anyhow!("'{}': {why}", path.display()))
}

/// Why `part` is not a piece of the job described by `meta` and `film`, if it is not.
pub fn same_job(part: &Partial, meta: &PartialMeta, film: &Film) -> Result<(), String> {
    same_frame(part, meta, film)?;
    if part.film.window() != film.window() {
        let w = part.film.window();
        return Err(format!(
            "it holds the window {},{},{},{}",
            w.x0, w.x1, w.y0, w.y1
        ));
    }
    if part.meta.target != meta.target {
        return Err(format!(
            "it renders samples {}..{}, not {}..{}",
            part.meta.target.0, part.meta.target.1, meta.target.0, meta.target.1
        ));
    }
    Ok(())
}

/// Why `part` is not of the same frame (scene, settings, size, spp, channels), if it is not.
pub fn same_frame(part: &Partial, meta: &PartialMeta, film: &Film) -> Result<(), String> {
    let (a, b) = (&part.film, film);
    if (a.width(), a.height()) != (b.width(), b.height()) {
        return Err(format!(
            "its image is {}×{}, not {}×{}",
            a.width(),
            a.height(),
            b.width(),
            b.height()
        ));
    }
    if part.meta.spp != meta.spp {
        return Err(format!(
            "its frame has {} samples per pixel, not {}",
            part.meta.spp, meta.spp
        ));
    }
    if a.channels() != b.channels() {
        return Err(format!(
            "it has {} channels, not {}",
            a.channels(),
            b.channels()
        ));
    }
    if part.meta.scene != meta.scene {
        return Err("its scene (or a file the scene loads) is different".into());
    }
    if part.meta.settings != meta.settings {
        for (k, v) in &meta.settings {
            let other = part.meta.settings.iter().find(|(k2, _)| k2 == k);
            match other {
                Some((_, v2)) if v2 == v => {}
                Some((_, v2)) => return Err(format!("its {k} is {v2}, not {v}")),
                None => return Err(format!("it has no {k} setting")),
            }
        }
        return Err("it has settings the others do not".into());
    }
    Ok(())
}
