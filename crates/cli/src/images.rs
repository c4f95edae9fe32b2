//! A film written as image files: the beauty (denoised on request, the noisy one kept beside
//! it), and the output variables as OpenEXR layers or `NAME.VARIABLE.pfm` files beside other
//! formats. Also `candela denoise`.

use crate::args::DenoiseArgs;
use crate::args::ToneArgs;
pub use crate::inputs::parse_aovs;
use anyhow::{bail, Context, Result};
use candela_denoise::Auxiliaries;
use candela_imageio::exr::{read_exr_channels_within, write_exr_layers, AovLayer};
use candela_imageio::{Encoding, Format, ToneMap};
use candela_render::aov::AovSet;
use candela_render::film::{Film, Window};
use candela_render::{Image, Rgb};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The display gamma of rendered LDR images unless `--gamma` says otherwise.
pub const RENDER_GAMMA: f32 = 2.2;

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

/// What to write besides the beauty.
pub struct Extras {
    /// The output variables in the film (channels 3 and up).
    pub aovs: AovSet,
    /// Those of them to write (the others only help the denoiser).
    pub written: AovSet,
    /// Denoise the beauty.
    pub denoise: bool,
    /// With `denoise`: also write the noisy beauty as `NAME.noisy.EXT`.
    pub keep_noisy: bool,
    /// With `denoise`: the beauty holds the `emission` variable as is (a path tracer's first
    /// vertex), so it is left out of the denoising and added back exactly.
    pub exact_emission: bool,
}

/// Writes `window` of `film` to every path of `outputs`; returns the image written (denoised
/// when asked).
pub fn write_film(
    outputs: &[PathBuf],
    film: &Film,
    window: Window,
    extras: &Extras,
    tone: &ToneMap,
) -> Result<Image> {
    let beauty = crop(&film.rgb(0), window);
    let mut layers = Vec::new();
    let mut first = 3;
    for aov in extras.aovs.iter() {
        let n = aov.channels().len();
        let all = film.means(first, n);
        let mut data = Vec::with_capacity(window.pixels() * n);
        for y in window.y0..window.y1 {
            let row = (y * film.width() + window.x0) * n;
            data.extend_from_slice(&all[row..row + window.width() * n]);
        }
        layers.push(AovLayer {
            name: aov.name().to_string(),
            channels: aov.channels().iter().map(|c| c.to_string()).collect(),
            data,
        });
        first += n;
    }
    let image = if extras.denoise {
        let layer = |name: &str| layers.iter().find(|l| l.name == name).map(|l| &l.data[..]);
        let aux = match (layer("albedo"), layer("normal")) {
            (Some(albedo), Some(normal)) => Some(Auxiliaries { albedo, normal }),
            _ => None,
        };
        let clean = match layer("emission").filter(|_| extras.exact_emission) {
            None => denoise_image(&beauty, aux)?,
            Some(e) => {
                // Added back antialiased at the edges of lights when it was traced so.
                let back = layer("emission_aa").unwrap_or(e);
                // Lights seen directly stay exact: the emission of the first hit (the same
                // rays as the beauty's) is left out of the denoising and added back.
                let mut rest = beauty.clone();
                for (p, v) in rest.pixels_mut().iter_mut().zip(e.chunks(3)) {
                    *p = Rgb::new(p.r - v[0], p.g - v[1], p.b - v[2]);
                }
                let mut clean = denoise_image(&rest, aux)?;
                for (p, v) in clean.pixels_mut().iter_mut().zip(back.chunks(3)) {
                    *p = Rgb::new(p.r + v[0], p.g + v[1], p.b + v[2]);
                }
                clean
            }
        };
        if extras.keep_noisy {
            let noisy: Vec<PathBuf> = outputs
                .iter()
                .filter(|p| !crate::outputs::is_stdout(p))
                .map(|p| crate::outputs::noisy_name(p))
                .collect();
            crate::outputs::write_all(&noisy, &beauty, tone)?;
        }
        clean
    } else {
        beauty
    };
    layers.retain(|l| extras.written.iter().any(|a| a.name() == l.name));
    if layers.is_empty() {
        // All files or none, `-` on standard output.
        crate::outputs::write_all(outputs, &image, tone)?;
        return Ok(image);
    }
    // The images and the variables' files beside them: all written or none.
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let mut stdout = Vec::new();
    for path in outputs {
        if crate::outputs::is_stdout(path) {
            stdout.push(path.clone());
        } else {
            encode_one(path, &image, &layers, tone, &mut files)?;
        }
    }
    let refs: Vec<(&Path, &[u8])> = files
        .iter()
        .map(|(p, b)| (p.as_path(), b.as_slice()))
        .collect();
    candela_imageio::write_all_atomically(&refs).map_err(|(i, e)| {
        crate::exit::Output(format!(
            "cannot write '{}' ({}: {e}); no output was written",
            refs[i].0.display(),
            e.stage
        ))
    })?;
    crate::outputs::write_all(&stdout, &image, tone)?;
    Ok(image)
}

/// One output encoded into `files`: the layers inside an OpenEXR file, or as
/// `NAME.VARIABLE.pfm` beside others.
fn encode_one(
    path: &Path,
    image: &Image,
    layers: &[AovLayer],
    tone: &ToneMap,
    files: &mut Vec<(PathBuf, Vec<u8>)>,
) -> Result<()> {
    let context = || format!("writing '{}'", path.display());
    let format = Format::from_path(path).with_context(context)?;
    if format == Format::Exr {
        files.push((
            path.to_path_buf(),
            write_exr_layers(image, layers).with_context(context)?,
        ));
        return Ok(());
    }
    files.push((
        path.to_path_buf(),
        format.encode(image, tone).with_context(context)?,
    ));
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    for layer in layers {
        let beside = path.with_file_name(format!("{stem}.{}.pfm", layer.name));
        let c = layer.channels.len();
        let mut img = Image::new(image.width(), image.height());
        for (p, v) in img.pixels_mut().iter_mut().zip(layer.data.chunks(c)) {
            *p = match *v {
                [a] => Rgb::splat(a),
                [a, b] => Rgb::new(a, b, 0.0),
                [a, b, c, ..] => Rgb::new(a, b, c),
                [] => Rgb::BLACK,
            };
        }
        if files.iter().any(|(p, _)| *p == beside) {
            continue; // beside another output of the same name
        }
        let bytes = Format::Pfm
            .encode(&img, tone)
            .with_context(|| format!("writing '{}'", beside.display()))?;
        files.push((beside, bytes));
    }
    Ok(())
}

/// The beauty denoised by OIDN, timing printed.
fn denoise_image(beauty: &Image, aux: Option<Auxiliaries<'_>>) -> Result<Image> {
    let color: Vec<f32> = beauty
        .pixels()
        .iter()
        .flat_map(|p| [p.r, p.g, p.b])
        .collect();
    let start = Instant::now();
    let out = candela_denoise::denoise(&color, aux, beauty.width(), beauty.height())
        .map_err(|e| anyhow::anyhow!("--denoise: {e}"))?;
    eprintln!(
        "candela: denoised {}×{} in {:.3} s (Intel Open Image Denoise)",
        beauty.width(),
        beauty.height(),
        start.elapsed().as_secs_f64()
    );
    let mut img = Image::new(beauty.width(), beauty.height());
    for (p, v) in img.pixels_mut().iter_mut().zip(out.chunks(3)) {
        *p = Rgb::new(v[0], v[1], v[2]);
    }
    Ok(img)
}

/// The pixels of `window` of a frame-sized image (the image itself for the whole frame).
pub fn crop(image: &Image, window: Window) -> Image {
    if window == Window::full(image.width(), image.height()) {
        return image.clone();
    }
    let mut out = Image::new(window.width(), window.height());
    for y in window.y0..window.y1 {
        for x in window.x0..window.x1 {
            out.set(x - window.x0, y - window.y0, image.get(x, y));
        }
    }
    out
}

/// `candela denoise IN -o OUT`.
pub fn denoise_command(a: DenoiseArgs) -> Result<()> {
    if !candela_imageio::supported_extension(&a.output) {
        bail!(
            "--output '{}': unknown image format (use .png, .pfm, .exr or .hdr)",
            a.output.display()
        );
    }
    let is_exr = Format::from_path(&a.input).ok() == Some(Format::Exr);
    // An input file as any other: a regular file within the memory budget's limits.
    let limits = candela_imageio::Limits::from_memory(crate::inputs::max_memory(None));
    let (beauty, albedo, normal) = if is_exr {
        let bytes = candela_imageio::input::read_file(&a.input, limits.max_file_bytes)
            .map_err(|e| anyhow::anyhow!("'{}': {e}", a.input.display()))?;
        let (w, h, channels) = read_exr_channels_within(&bytes, &limits)
            .map_err(|e| anyhow::anyhow!("'{}': {e}", a.input.display()))?;
        let find = |names: [&str; 3]| -> Option<Vec<f32>> {
            let cs: Vec<&Vec<f32>> = names
                .iter()
                .map(|n| channels.iter().find(|(c, _)| c == n).map(|(_, v)| v))
                .collect::<Option<_>>()?;
            Some(
                (0..w * h)
                    .flat_map(|i| [cs[0][i], cs[1][i], cs[2][i]])
                    .collect(),
            )
        };
        let rgb = find(["R", "G", "B"])
            .with_context(|| format!("'{}': no R, G, B channels", a.input.display()))?;
        let mut img = Image::new(w, h);
        for (p, v) in img.pixels_mut().iter_mut().zip(rgb.chunks(3)) {
            *p = Rgb::new(v[0], v[1], v[2]);
        }
        (
            img,
            find(["albedo.R", "albedo.G", "albedo.B"]),
            find(["normal.X", "normal.Y", "normal.Z"]),
        )
    } else {
        let img = candela_imageio::read_image_within(&a.input, &limits)
            .map_err(|e| anyhow::anyhow!("'{}': {e}", a.input.display()))?;
        (img, None, None)
    };
    let aux = match (&albedo, &normal) {
        (Some(albedo), Some(normal)) => Some(Auxiliaries { albedo, normal }),
        _ => {
            eprintln!("candela: note: no albedo and normal layers in the input: denoising the colour alone");
            None
        }
    };
    let clean = denoise_image(&beauty, aux)?;
    let tone = tone_map(&a.tone, RENDER_GAMMA);
    candela_imageio::write_image(&a.output, &clean, &tone)
        .with_context(|| format!("writing '{}'", a.output.display()))
}
