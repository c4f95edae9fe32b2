//! Everything checked before any work (docs/command-line.md, docs/limits.md): option values
//! and combinations, the memory budget (`--max-memory`) and what a render of a given size needs,
//! and the radiosity cache file. A failure here is a usage error (exit status 2) naming the
//! option.

use crate::args::{Command, RenderArgs};
use crate::exit::Usage;
use candela_imageio::Limits;
use candela_render::accel::AccelKind;
use candela_render::aov::{Aov, AovSet};
use candela_render::integrator::{branching_depth, whitted_depth, IntegratorKind};
use candela_render::radiosity::{FormFactorMethod, SolverKind};
use candela_render::sampling::SamplerKind;
use std::path::{Path, PathBuf};

/// Bytes a rendered pixel takes per film channel (3 for the radiance, more for output
/// variables): the film's 128-bit sum, a copy of it for a checkpoint, and the encoded partial
/// file, for the estimate made before rendering.
pub const RENDER_BYTES_PER_CHANNEL: u64 = 40;
/// Bytes a rendered pixel takes besides its channels: the sample count, the image, its crop and
/// the encoded outputs.
pub const RENDER_BYTES_PER_PIXEL: u64 = 48;

/// Parses `--aov LIST`.
pub fn parse_aovs(list: Option<&str>) -> Result<AovSet, Usage> {
    let mut set = AovSet::NONE;
    for name in list
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
    {
        let aov = Aov::from_name(name).ok_or_else(|| {
            let names: Vec<&str> = Aov::ALL.iter().map(|a| a.name()).collect();
            Usage(format!(
                "--aov '{name}': unknown output variable (expected some of: {})",
                names.join(", ")
            ))
        })?;
        set = set.with(aov);
    }
    Ok(set)
}

/// Film channels of a render with these options: the radiance and the output variables
/// (`--aov`, and those `--denoise` adds).
fn film_channels(a: &RenderArgs) -> u64 {
    let mut aovs = parse_aovs(a.aov.as_deref()).unwrap_or_default();
    if a.denoise {
        for v in [Aov::Albedo, Aov::Normal, Aov::Emission, Aov::EmissionAa] {
            aovs = aovs.with(v);
        }
    }
    3 + aovs.channels() as u64
}

/// The memory budget: `--max-memory`, or 2 GiB, or half the address-space limit when that is
/// lower (`ulimit -v`).
pub fn max_memory(option: Option<u64>) -> u64 {
    option.unwrap_or_else(|| {
        let default = candela_imageio::input::DEFAULT_MAX_MEMORY;
        address_space_limit().map_or(default, |l| default.min(l / 2))
    })
}

pub use crate::bytes::address_space_limit;

/// The limits of readers for these options.
pub fn limits(args: &RenderArgs) -> Limits {
    Limits::from_memory(max_memory(args.max_memory))
}

/// Checks a command's options before any file is read.
pub fn validate(command: &Command) -> Result<(), Usage> {
    match command {
        Command::Demo(a) => {
            render_args(a, false)?;
            let outputs = crate::outputs::resolve(&a.outputs, "demo.png");
            crate::outputs::check(&with_side_outputs(&outputs, a), &[])?;
            partial_targets(a, &[])
        }
        Command::Render(s) => {
            let stdin = is_stdin(&s.scene);
            if stdin && std::io::IsTerminal::is_terminal(&std::io::stdin()) {
                return Err(Usage(
                    "the scene '-' is standard input, which is a terminal: pipe or redirect a scene into it (candela render - < scene.txt)".into(),
                ));
            }
            // The language of standard input is known once it is read: what depends on it is
            // checked after loading, as for XML files.
            let xml = stdin
                || s.scene
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("xml"));
            render_args(&s.render, xml)?;
            // Standard input redirected from a file is that file (Linux: /dev/stdin links to it).
            let scene = if stdin {
                PathBuf::from("/dev/stdin")
            } else {
                s.scene.clone()
            };
            if let Some(cache) = &s.render.radiosity_cache {
                if crate::outputs::same_file(cache, &scene) {
                    return Err(Usage(format!(
                        "--radiosity-cache '{}' is the scene file",
                        cache.display()
                    )));
                }
            }
            let outputs = crate::outputs::resolve(&s.render.outputs, &default_output(&s.scene));
            let mut inputs = vec![scene];
            inputs.extend(s.render.radiosity_cache.iter().cloned());
            crate::outputs::check(&with_side_outputs(&outputs, &s.render), &inputs)?;
            partial_targets(&s.render, &inputs)
        }
        Command::Convert(c) => crate::outputs::check(
            std::slice::from_ref(&c.output),
            std::slice::from_ref(&c.input),
        ),
        Command::Denoise(d) => crate::outputs::check(
            std::slice::from_ref(&d.output),
            std::slice::from_ref(&d.input),
        ),
        Command::Merge(m) => {
            // Image outputs as any other; partial-file outputs (their extensions are checked
            // by `merge`) must be usable targets too, so that nothing is written when one is not.
            let (images, partials): (Vec<PathBuf>, Vec<PathBuf>) = m
                .outputs
                .iter()
                .cloned()
                .partition(|o| candela_imageio::supported_extension(o));
            crate::outputs::check(&images, &m.parts)?;
            for p in &partials {
                if !crate::outputs::is_stdout(p) {
                    crate::outputs::check_partial_target("--output", p, &images, &[])?;
                }
            }
            Ok(())
        }
    }
}

/// True when the scene argument is `-`: the scene is read from standard input.
pub fn is_stdin(scene: &Path) -> bool {
    scene.as_os_str() == "-"
}

/// The image outputs of a render and the files written beside them (output variables as
/// `NAME.VARIABLE.pfm`, the noisy image of `--denoise`), all checked like outputs.
pub fn with_side_outputs(outputs: &[PathBuf], a: &RenderArgs) -> Vec<PathBuf> {
    let written = parse_aovs(a.aov.as_deref()).unwrap_or_default();
    let noisy = a.denoise && !a.no_keep_noisy;
    crate::outputs::with_sides(outputs, written, noisy)
}

/// Checks the partial files a render writes (`--partial`, `--checkpoint`) like outputs: each a
/// regular file or nothing, neither an image output nor an input, not the same file twice.
fn partial_targets(a: &RenderArgs, inputs: &[PathBuf]) -> Result<(), Usage> {
    if let Some(p) = &a.partial {
        crate::outputs::check_partial_target("--partial", p, &a.outputs, inputs)?;
    }
    if let Some(c) = &a.checkpoint {
        let mut others = a.outputs.clone();
        others.extend(a.partial.iter().cloned());
        crate::outputs::check_partial_target("--checkpoint", c, &others, inputs)?;
    }
    Ok(())
}

/// The default output of `render SCENE`: the scene's name with `.png`, in the current folder
/// (`stdin.png` for `-`, standard input).
pub fn default_output(scene: &Path) -> String {
    if is_stdin(scene) {
        return "stdin.png".to_string();
    }
    let stem = scene.file_stem().unwrap_or_default().to_string_lossy();
    format!("{stem}.png")
}

/// `--spectral` with an integrator that computes colours (radiosity, the preview views) is a
/// usage error.
pub fn spectral_integrator(a: &RenderArgs, kind: IntegratorKind, name: &str) -> Result<(), Usage> {
    if a.spectral && !kind.spectral() {
        return Err(Usage(format!(
            "--spectral: the {name} integrator computes colours, not radiance per wavelength (spectral rendering is for path, direct, local and whitted)"
        )));
    }
    Ok(())
}

fn render_args(a: &RenderArgs, xml: bool) -> Result<(), Usage> {
    let integrator = match &a.integrator {
        None => None,
        Some(name) => Some(IntegratorKind::from_name(name).ok_or_else(|| {
            Usage(format!(
                "--integrator '{name}': unknown integrator (expected one of: {})",
                IntegratorKind::NAMES.join(", ")
            ))
        })?),
    };
    if let Some(name) = &a.sampler {
        SamplerKind::from_name(name).ok_or_else(|| {
            Usage(format!(
                "--sampler '{name}': unknown sampler (expected one of: {})",
                SamplerKind::NAMES.join(", ")
            ))
        })?;
    }
    if let Some(name) = &a.accel {
        AccelKind::parse(name).map_err(|e| Usage(format!("--accel '{name}': {e}")))?;
    }
    if let Some(name) = &a.form_factors {
        FormFactorMethod::from_name(name).ok_or_else(|| {
            Usage(format!(
                "--form-factors '{name}': unknown form-factor method (expected one of: {})",
                FormFactorMethod::NAMES.join(", ")
            ))
        })?;
    }
    if let Some(name) = &a.solver {
        SolverKind::from_name(name).ok_or_else(|| {
            Usage(format!(
                "--solver '{name}': unknown radiosity solver (expected one of: {})",
                SolverKind::NAMES.join(", ")
            ))
        })?;
    }
    for d in &a.defines {
        let (name, _) = d
            .split_once('=')
            .or_else(|| d.split_once(':'))
            .ok_or_else(|| Usage(format!("--define '{d}': expected NAME=VALUE or NAME:VALUE")))?;
        if name.trim().is_empty() {
            return Err(Usage(format!("--define '{d}': the name is empty")));
        }
    }
    if let (Some(kind), Some(name)) = (integrator, &a.integrator) {
        spectral_integrator(a, kind, name)?;
    }
    // Depths: an XML scene may set the integrator and its depth, checked when it is loaded.
    let kind = integrator.or((!xml).then_some(IntegratorKind::Path));
    match kind {
        Some(IntegratorKind::Whitted) => {
            whitted_depth(a.max_depth).map_err(Usage)?;
        }
        Some(IntegratorKind::Path) => {
            let n = a.num_of_rays.unwrap_or(1);
            if n > 1 && (a.max_depth.is_some() || !xml) {
                branching_depth(n, a.max_depth).map_err(Usage)?;
            }
        }
        _ => {}
    }
    // The image: the command line's size, or the default one (an XML film is checked after
    // loading).
    if !xml || (a.width.is_some() && a.height.is_some()) {
        let w = a.width.unwrap_or(640);
        let h = a.height.unwrap_or(480);
        render_memory(
            w as usize,
            h as usize,
            film_channels(a),
            max_memory(a.max_memory),
        )?;
    }
    if let Some(cache) = &a.radiosity_cache {
        candela_imageio::check_target(cache)
            .map_err(|e| Usage(format!("--radiosity-cache '{}': {e}", cache.display())))?;
    }
    Ok(())
}

/// Fails unless a `width`×`height` render with `channels` film channels fits in the memory
/// budget `max_memory`.
pub fn render_memory(
    width: usize,
    height: usize,
    channels: u64,
    max_memory: u64,
) -> Result<(), Usage> {
    let per_pixel = RENDER_BYTES_PER_PIXEL + RENDER_BYTES_PER_CHANNEL * channels;
    let need = (width as u64)
        .saturating_mul(height as u64)
        .saturating_mul(per_pixel);
    if need > max_memory {
        return Err(Usage(format!(
            "--width/--height: a {width}×{height} image needs about {} MB ({per_pixel} bytes per pixel with {channels} film channels), more than --max-memory {} MB; raise --max-memory or render a smaller image",
            need.div_ceil(1 << 20),
            max_memory >> 20
        )));
    }
    Ok(())
}

/// Checks what the loaded scene decided (an XML film's size) against the memory budget.
pub fn check_render(width: usize, height: usize, args: &RenderArgs) -> anyhow::Result<()> {
    render_memory(
        width,
        height,
        film_channels(args),
        max_memory(args.max_memory),
    )
    .map_err(anyhow::Error::new)
}

/// Reads the radiosity cache: a regular file of at most a quarter of the memory budget.
pub fn read_cache(path: &Path, args: &RenderArgs) -> std::io::Result<Vec<u8>> {
    use candela_imageio::input::{read_file, InputError};
    read_file(path, limits(args).max_file_bytes).map_err(|e| match e {
        InputError::Io(e) => e,
        e => std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_images_are_refused_naming_the_option() {
        let e = render_memory(32768, 32768, 3, 2 << 30).unwrap_err();
        assert!(e.0.contains("--max-memory"), "{e}");
        assert!(render_memory(640, 480, 3, 2 << 30).is_ok());
    }
}
