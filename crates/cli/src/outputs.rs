//! The output files of a run: checked before any work (format, target, not an input), then
//! written all or none. `-` writes a PNG to standard output, `pfm:-`, `exr:-`, `hdr:-` and
//! `png:-` that format: the way to write to a pipe or a device (a file target is only ever a
//! regular file, replaced atomically).

use crate::exit::{Output, Usage};
use anyhow::Result;
use candela_imageio::{Format, ToneMap};
use candela_render::aov::AovSet;
use candela_render::Image;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The outputs of a run: the `-o` list, or `default` when it is empty.
pub fn resolve(list: &[PathBuf], default: &str) -> Vec<PathBuf> {
    if list.is_empty() {
        vec![PathBuf::from(default)]
    } else {
        list.to_vec()
    }
}

/// The format of standard output when `path` names it (`-` or `EXT:-`).
/// True when `path` names standard output (`-` or `FORMAT:-`).
pub fn is_stdout(path: &Path) -> bool {
    stdout_format(path).is_some()
}

fn stdout_format(path: &Path) -> Option<Result<Format, Usage>> {
    let s = path.to_str()?;
    if s == "-" {
        return Some(Ok(Format::Png));
    }
    let ext = s.strip_suffix(":-")?;
    Some(
        Format::ALL
            .into_iter()
            .find(|f| f.extension().eq_ignore_ascii_case(ext))
            .ok_or_else(|| {
                Usage(format!(
                    "--output '{s}': unknown image format ({})",
                    FORMATS
                ))
            }),
    )
}

/// The formats, as listed in messages.
const FORMATS: &str =
    "use .png, .pfm, .exr or .hdr, or - (PNG) or pfm:-, exr:-, hdr:- for standard output";

/// Checks the outputs before any work: known formats, at most one on standard output, no file
/// twice, each a regular file or nothing in an existing folder, none of them one of `inputs`.
pub fn check(outputs: &[PathBuf], inputs: &[PathBuf]) -> Result<(), Usage> {
    let mut stdout = 0;
    for (i, o) in outputs.iter().enumerate() {
        if let Some(format) = stdout_format(o) {
            format?;
            stdout += 1;
            if stdout > 1 {
                return Err(Usage("--output: standard output (-) given twice".into()));
            }
            continue;
        }
        if !candela_imageio::supported_extension(o) {
            return Err(Usage(format!(
                "--output '{}': unknown image format ({FORMATS})",
                o.display()
            )));
        }
        if outputs[..i].iter().any(|p| p == o || same_file(p, o)) {
            return Err(Usage(format!("--output '{}' is given twice", o.display())));
        }
        candela_imageio::check_target(o)
            .map_err(|e| Usage(format!("--output '{}': {e}", o.display())))?;
    }
    not_inputs(outputs, inputs)
}

/// Fails when an output is one of `inputs` (a scene, mesh, image or cache file).
pub fn not_inputs(outputs: &[PathBuf], inputs: &[PathBuf]) -> Result<(), Usage> {
    for o in outputs {
        if let Some(i) = inputs.iter().find(|i| *i == o || same_file(o, i)) {
            return Err(Usage(format!(
                "--output '{}' is an input of this run ('{}'): refusing to overwrite it",
                o.display(),
                i.display()
            )));
        }
    }
    Ok(())
}

/// Checks a partial file a render writes (`--partial`, `--checkpoint`, given as `option`)
/// before any work, as an output: a regular file or nothing in an existing folder, not one of
/// the image `outputs`, not one of `inputs`.
pub fn check_partial_target(
    option: &str,
    path: &Path,
    outputs: &[PathBuf],
    inputs: &[PathBuf],
) -> Result<(), Usage> {
    candela_imageio::check_target(path)
        .map_err(|e| Usage(format!("{option} '{}': {e}", path.display())))?;
    if let Some(o) = outputs.iter().find(|o| *o == path || same_file(o, path)) {
        return Err(Usage(format!(
            "{option} '{}' is also given as --output '{}'",
            path.display(),
            o.display()
        )));
    }
    if let Some(i) = inputs.iter().find(|i| *i == path || same_file(i, path)) {
        return Err(Usage(format!(
            "{option} '{}' is an input of this run ('{}'): refusing to overwrite it",
            path.display(),
            i.display()
        )));
    }
    Ok(())
}

/// The files beside `path` that hold the output variables `written` (`NAME.VARIABLE.pfm`,
/// except in an OpenEXR output, which holds them as layers) and, with `noisy`, the image
/// before denoising (`NAME.noisy.EXT`): checked like outputs before any work.
pub fn side_outputs(path: &Path, written: AovSet, noisy: bool) -> Vec<PathBuf> {
    if is_stdout(path) {
        return Vec::new();
    }
    let mut out = Vec::new();
    if noisy {
        out.push(noisy_name(path));
    }
    if Format::from_path(path).ok() != Some(Format::Exr) {
        let stem = path.file_stem().unwrap_or_default().to_string_lossy();
        for aov in written.iter() {
            out.push(path.with_file_name(format!("{stem}.{}.pfm", aov.name())));
        }
    }
    out
}

/// `outputs` and the files beside them ([`side_outputs`]), each named once.
pub fn with_sides(outputs: &[PathBuf], written: AovSet, noisy: bool) -> Vec<PathBuf> {
    let mut all = outputs.to_vec();
    let mut sides: Vec<PathBuf> = Vec::new();
    for o in outputs {
        for side in side_outputs(o, written, noisy) {
            // `-o a.png -o a.pfm` both have `a.albedo.pfm` beside them: the same file.
            if !sides.contains(&side) {
                sides.push(side);
            }
        }
    }
    all.extend(sides);
    all
}

/// `NAME.noisy.EXT` beside `path`.
pub fn noisy_name(path: &Path) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let ext = path.extension().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!("{stem}.noisy.{ext}"))
}

/// True when `a` and `b` name the same existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// Encodes `img` for every output, then writes them all or none (files beside their targets
/// first, renamed together; standard output last).
pub fn write_all(outputs: &[PathBuf], img: &Image, tone: &ToneMap) -> Result<()> {
    let mut files: Vec<(&Path, Vec<u8>)> = Vec::new();
    let mut stdout = None;
    for o in outputs {
        let format = match stdout_format(o) {
            Some(f) => f?,
            None => Format::from_path(o).map_err(|e| Usage(e.to_string()))?,
        };
        let bytes = format
            .encode(img, tone)
            .map_err(|e| Output(format!("'{}': {e}", o.display())))?;
        if stdout_format(o).is_some() {
            stdout = Some(bytes);
        } else {
            files.push((o.as_path(), bytes));
        }
    }
    let refs: Vec<(&Path, &[u8])> = files.iter().map(|(p, b)| (*p, b.as_slice())).collect();
    candela_imageio::write_all_atomically(&refs).map_err(|(i, e)| {
        Output(format!(
            "cannot write '{}' ({}: {e}); no output was written",
            refs[i].0.display(),
            e.stage
        ))
    })?;
    if let Some(bytes) = stdout {
        let mut out = std::io::stdout().lock();
        out.write_all(&bytes)
            .and_then(|()| out.flush())
            .map_err(|e| Output(format!("cannot write to standard output: {e}")))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_output_forms() {
        assert!(matches!(
            stdout_format(Path::new("-")),
            Some(Ok(Format::Png))
        ));
        assert!(matches!(
            stdout_format(Path::new("PFM:-")),
            Some(Ok(Format::Pfm))
        ));
        assert!(matches!(stdout_format(Path::new("bmp:-")), Some(Err(_))));
        assert!(stdout_format(Path::new("a.png")).is_none());
        let e = check(&["-".into(), "exr:-".into()], &[]).unwrap_err();
        assert!(e.0.contains("twice"), "{e}");
        let e = check(&["x.bmp".into()], &[]).unwrap_err();
        assert!(e.0.contains(".hdr"), "{e}");
        let e = check(&["/nonexistent-dir/x.png".into()], &[]).unwrap_err();
        assert!(e.0.contains("--output"), "{e}");
    }
}
