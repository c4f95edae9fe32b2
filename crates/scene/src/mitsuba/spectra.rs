//! `<spectrum>` properties: Mitsuba 3's spectrum forms, read into candela's [`Spectrum`].
//!
//! | XML | spectrum |
//! |---|---|
//! | `<spectrum name="…" value="0.5"/>` | constant (`uniform`) |
//! | `<spectrum name="…" value="400:0.1, 500:0.4, …"/>` | tabulated, piecewise linear |
//! | `<spectrum name="…" filename="f.spd"/>` | tabulated from a file of `λ value` lines |
//! | `<spectrum type="uniform"><float name="value" …/></spectrum>` | constant |
//! | `<spectrum type="blackbody"><float name="temperature" …/></spectrum>` | Planck's law (Mitsuba's units) |
//! | `<spectrum type="regular">` with `wavelength_min`, `wavelength_max`, `values` | tabulated, evenly spaced |
//! | `<spectrum type="irregular">` with `wavelengths`, `values` | tabulated |
//! | `<spectrum type="d65">` (optional `scale`) | D65 with luminance `scale` |
//! | `<spectrum type="srgb">` with `<rgb name="color">` | the RGB colour |
//!
//! In RGB renders a spectrum becomes the colour Mitsuba's RGB variants give it (see
//! [`Spectrum::to_rgb`]); in spectral renders it is used as is. A spectrum file is read when
//! the property is used (its path is resolved like every other file of the scene).

use super::xml::Element;
use crate::error::{Pos, SceneError, SourceFile};
use candela_render::spectrum::Spectrum;
use candela_render::Rgb;

/// The most samples a tabulated spectrum may have (Mitsuba's data files have a few hundred).
pub(super) const MAX_SPECTRUM_SAMPLES: usize = 100_000;

/// What a `<spectrum>` element gives.
pub(super) enum SpectrumValue<'t> {
    /// A spectrum.
    Spectrum(Spectrum),
    /// A spectrum file's name (read when the property is used) and its position.
    File(&'t str, Pos),
    /// An RGB colour (`type="srgb"`).
    Rgb([f64; 3]),
}

/// The value of a `<spectrum>` element `c`.
pub(super) fn spectrum_value<'t>(
    src: &SourceFile,
    c: &'t Element,
) -> Result<SpectrumValue<'t>, SceneError> {
    let err = |pos, msg: String| src.error(pos, msg);
    let Some(kind) = c.attr("type") else {
        if let Some(f) = c.attr("filename") {
            if c.attr("value").is_some() {
                return Err(err(
                    f.pos,
                    "give either 'value' or 'filename', not both".into(),
                ));
            }
            return Ok(SpectrumValue::File(&f.value, f.pos));
        }
        let a = c.attr("value").ok_or_else(|| {
            err(
                c.pos,
                "<spectrum> needs 'value', 'filename' or 'type'".into(),
            )
        })?;
        return parse_text(&a.value)
            .map(SpectrumValue::Spectrum)
            .map_err(|m| err(a.pos, m));
    };
    // A plugin: its parameters are nested elements.
    let param = |name: &str| c.children.iter().find(|e| e.get("name") == Some(name));
    let number = |name: &str, default: Option<f64>| -> Result<f64, SceneError> {
        match param(name) {
            None => default.ok_or_else(|| {
                err(
                    c.pos,
                    format!("<spectrum type=\"{}\"> needs '{name}'", kind.value),
                )
            }),
            Some(e) => {
                let a = e
                    .attr("value")
                    .ok_or_else(|| err(e.pos, format!("'{name}' needs a value")))?;
                a.value
                    .trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| err(a.pos, format!("'{}' is not a finite number", a.value)))
            }
        }
    };
    let list = |name: &str| -> Result<Vec<f64>, SceneError> {
        let e = param(name).ok_or_else(|| {
            err(
                c.pos,
                format!("<spectrum type=\"{}\"> needs '{name}'", kind.value),
            )
        })?;
        let a = e
            .attr("value")
            .ok_or_else(|| err(e.pos, format!("'{name}' needs a value")))?;
        a.value
            .split(|ch: char| ch == ',' || ch.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                t.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| err(a.pos, format!("'{t}' is not a finite number")))
            })
            .collect()
    };
    let tabulated = |samples: Vec<(f32, f32)>| -> Result<SpectrumValue<'t>, SceneError> {
        if samples.len() > MAX_SPECTRUM_SAMPLES {
            return Err(err(
                c.pos,
                format!("a spectrum has at most {MAX_SPECTRUM_SAMPLES} samples"),
            ));
        }
        candela_render::spectrum::TabulatedSpectrum::new(samples)
            .map(|t| SpectrumValue::Spectrum(Spectrum::Tabulated(t)))
            .map_err(|e| err(c.pos, e.message))
    };
    match kind.value.as_str() {
        "uniform" => Ok(SpectrumValue::Spectrum(Spectrum::Constant(
            number("value", Some(1.0))? as f32,
        ))),
        "blackbody" => {
            let t = number("temperature", None)?;
            if !(t > 0.0) {
                return Err(err(
                    c.pos,
                    format!("the temperature must be positive, not {t}"),
                ));
            }
            let scale = number("scale", Some(1.0))?;
            Ok(SpectrumValue::Spectrum(Spectrum::blackbody(t as f32, scale as f32)))
        }
        "regular" => {
            let (lo, hi) = (
                number("wavelength_min", None)?,
                number("wavelength_max", None)?,
            );
            let v = list("values")?;
            if v.len() < 2 || !(hi > lo) {
                return Err(err(
                    c.pos,
                    "a regular spectrum needs at least two values and wavelength_min < wavelength_max"
                        .into(),
                ));
            }
            let n = (v.len() - 1) as f64;
            tabulated(
                v.iter()
                    .enumerate()
                    .map(|(i, &y)| ((lo + (hi - lo) * i as f64 / n) as f32, y as f32))
                    .collect(),
            )
        }
        "irregular" => {
            let (l, v) = (list("wavelengths")?, list("values")?);
            if l.len() != v.len() {
                return Err(err(
                    c.pos,
                    format!(
                        "an irregular spectrum needs as many values as wavelengths ({} and {})",
                        v.len(),
                        l.len()
                    ),
                ));
            }
            tabulated(
                l.iter()
                    .zip(&v)
                    .map(|(&a, &b)| (a as f32, b as f32))
                    .collect(),
            )
        }
        "d65" => {
            let scale = number("scale", Some(1.0))? as f32;
            Ok(SpectrumValue::Spectrum(Spectrum::rgb_illuminant(Rgb::splat(scale))))
        }
        "srgb" => {
            let e = param("color")
                .ok_or_else(|| err(c.pos, "<spectrum type=\"srgb\"> needs 'color'".into()))?;
            let a = e
                .attr("value")
                .ok_or_else(|| err(e.pos, "'color' needs a value".into()))?;
            let v: Vec<f64> = a
                .value
                .split(|ch: char| ch == ',' || ch.is_whitespace())
                .filter(|t| !t.is_empty())
                .map(|t| t.parse::<f64>().ok().filter(|v| v.is_finite()))
                .collect::<Option<_>>()
                .ok_or_else(|| err(a.pos, format!("'{}' is not a colour", a.value)))?;
            match v.as_slice() {
                [g] => Ok(SpectrumValue::Rgb([*g; 3])),
                [r, g, b] => Ok(SpectrumValue::Rgb([*r, *g, *b])),
                _ => Err(err(a.pos, "a colour has one or three values".into())),
            }
        }
        other => Err(err(
            kind.pos,
            format!(
                "unknown spectrum type '{other}' (known: uniform, blackbody, regular, irregular, d65, srgb)"
            ),
        )),
    }
}

/// A spectrum from the text of a `value`: one number, or `λ:value` pairs.
fn parse_text(text: &str) -> Result<Spectrum, String> {
    let s = Spectrum::parse(text).map_err(|e| format!("bad spectrum: {}", e.message))?;
    if let Spectrum::Tabulated(t) = &s {
        if t.samples().len() > MAX_SPECTRUM_SAMPLES {
            return Err(format!(
                "a spectrum has at most {MAX_SPECTRUM_SAMPLES} samples"
            ));
        }
    }
    Ok(s)
}
