//! Spectra: `spectrum(λ:v, …)`, `spectrum("file")` and `blackbody(T [, scale])` (pigments and
//! light colours), the dispersive indices of refraction of `glass` (`sellmeier("name")`,
//! `cauchy(A, B)`, `spectrum(λ:n, …)`) and the named metals of `metal("name", …)`.

use super::{Args, PResult, Parser};
use crate::error::Pos;
use crate::lang::ast::*;
use crate::lang::lexer::TokenKind;
use candela_render::material::REFERENCE_WAVELENGTH;
use candela_render::spectrum::{
    metal, metal_names, Ior, RgbRole, Spectrum, TabulatedSpectrum, LAMBDA_MAX, LAMBDA_MIN,
};
use candela_render::Rgb;

/// The syntax of `spectrum(…)`, quoted in argument-count errors.
const SPECTRUM_SYNTAX: &str =
    "spectrum(wavelength:value, wavelength:value, …) or spectrum(\"file\")";

/// True when `s` is finite at every nanometre of the visible range and so is its colour
/// (values too large overflow; Planck's law at absurd temperatures is not a number).
fn is_finite(s: &Spectrum) -> bool {
    (LAMBDA_MIN as u32..=LAMBDA_MAX as u32).all(|l| s.eval(l as f32).is_finite())
        && s.to_rgb(RgbRole::Emission).is_finite()
}

impl Parser<'_> {
    /// True when the current token is the word `keyword` used as a keyword where a number could
    /// also be written: a `float` variable of that name wins.
    fn number_keyword(&self, keyword: &str) -> bool {
        self.tok.ident() == Some(keyword) && !self.desc.floats.contains_key(keyword)
    }

    /// True when the current token starts a spectrum (`spectrum` or `blackbody`).
    pub(super) fn at_spectrum(&self) -> bool {
        matches!(self.tok.ident(), Some("spectrum" | "blackbody"))
    }

    /// `spectrum(λ:v, …)`, `spectrum("file")` or `blackbody(T [, scale])`, at its keyword.
    pub(super) fn spectrum_def(&mut self) -> PResult<SpectrumDef> {
        let pos = self.tok.pos;
        match self.tok.ident() {
            Some("spectrum") => {
                self.advance()?;
                self.args(SPECTRUM_SYNTAX, |p, a| {
                    if matches!(p.tok.kind, TokenKind::Str(_)) {
                        return Ok(SpectrumDef::File(p.arg(a, Self::file)?));
                    }
                    let t = p.samples(
                        a,
                        pos,
                        |v| v >= 0.0,
                        "a spectrum value must not be negative",
                    )?;
                    let s = Spectrum::Tabulated(t);
                    if !is_finite(&s) {
                        return Err(p.error(
                            pos,
                            "the spectrum's values are too large (its colour is not finite)",
                        ));
                    }
                    Ok(SpectrumDef::Inline(s))
                })
            }
            Some("blackbody") => {
                self.advance()?;
                let (temperature, scale) =
                    self.args("blackbody(temperature [, scale])", |p, a| {
                        let t = p.arg(a, |p| {
                            p.checked_number(
                                |x| x > 0.0,
                                "the temperature must be positive (kelvin)",
                            )
                        })?;
                        let mut scale = 1.0;
                        if p.more(a)? {
                            scale = p.arg(a, |p| {
                                p.checked_number(|x| x >= 0.0, "the scale must not be negative")
                            })?;
                        }
                        Ok((t, scale))
                    })?;
                let s = Spectrum::blackbody(temperature, scale);
                if !is_finite(&s) {
                    return Err(self.error(
                        pos,
                        "the blackbody's radiance is not finite (the temperature or the scale is too large)",
                    ));
                }
                Ok(SpectrumDef::Inline(s))
            }
            _ => Err(self.unexpected("'spectrum(…)' or 'blackbody(…)'")),
        }
    }

    /// The `wavelength:value` pairs of a spectrum (at least two, at most
    /// [`MAX_SPECTRUM_SAMPLES`], wavelengths positive and increasing, values satisfying `ok`).
    /// `pos` is the keyword's position.
    fn samples(
        &mut self,
        a: &mut Args,
        pos: Pos,
        ok: fn(f32) -> bool,
        message: &str,
    ) -> PResult<TabulatedSpectrum> {
        let mut samples: Vec<(f32, f32)> = Vec::new();
        loop {
            let at = self.tok.pos;
            let (lambda, value) = self.arg(a, |p| {
                let lambda = p.checked_number(|x| x > 0.0, "a wavelength must be positive (nm)")?;
                if !p.tok.is_symbol(':') {
                    return Err(p.unexpected("':' (a spectrum is wavelength:value pairs)"));
                }
                p.advance()?;
                let value = p.checked_number(ok, message)?;
                Ok((lambda, value))
            })?;
            if let Some(&(previous, _)) = samples.last() {
                if !(lambda > previous) {
                    return Err(self.error(
                        at,
                        format!("wavelengths must increase: {lambda} nm follows {previous} nm"),
                    ));
                }
            }
            if samples.len() == MAX_SPECTRUM_SAMPLES {
                return Err(self.error(
                    at,
                    format!("a spectrum has at most {MAX_SPECTRUM_SAMPLES} samples"),
                ));
            }
            samples.push((lambda, value));
            if !self.more(a)? {
                break;
            }
        }
        if samples.len() < 2 {
            return Err(self.error(
                pos,
                format!(
                    "a spectrum needs at least two wavelength:value samples (found {})",
                    samples.len()
                ),
            ));
        }
        TabulatedSpectrum::new(samples).map_err(|e| self.error(pos, e.message))
    }

    /// A light's intensity: `<r, g, b>`, or a spectrum with its RGB emission conversion (black
    /// for a file, which the builder reads).
    pub(super) fn light_colour(&mut self) -> PResult<(Rgb, Option<SpectrumDef>)> {
        if !self.at_spectrum() {
            return Ok((self.color()?, None));
        }
        let def = self.spectrum_def()?;
        let rgb = match &def {
            SpectrumDef::Inline(s) => s.to_rgb(RgbRole::Emission),
            SpectrumDef::File(_) => Rgb::BLACK,
        };
        Ok((rgb, Some(def)))
    }

    /// The index of refraction of `glass`: a positive number, `sellmeier("name")`,
    /// `cauchy(A, B)` or `spectrum(λ:n, …)`; returns the index at the reference wavelength and
    /// the dispersion when the index varies.
    pub(super) fn glass_ior(&mut self) -> PResult<(f32, Option<Ior>)> {
        let pos = self.tok.pos;
        let ior = if self.number_keyword("sellmeier") {
            self.advance()?;
            self.args("sellmeier(\"glass name\")", |p, a| {
                p.arg(a, |p| {
                    let TokenKind::Str(name) = &p.tok.kind else {
                        return Err(p.unexpected("a glass name string"));
                    };
                    let ior = Ior::glass(name).ok_or_else(|| {
                        let known: Vec<String> =
                            Ior::glass_names().map(|n| format!("\"{n}\"")).collect();
                        p.error(
                            p.tok.pos,
                            format!("unknown glass '{name}' (known: {})", known.join(", ")),
                        )
                    })?;
                    p.advance()?;
                    Ok(ior)
                })
            })?
        } else if self.number_keyword("cauchy") {
            self.advance()?;
            self.args("cauchy(A, B) with B in µm²", |p, a| {
                Ok(Ior::Cauchy {
                    a: p.arg(a, Self::number)?,
                    b: p.arg(a, Self::number)?,
                })
            })?
        } else if self.number_keyword("spectrum") {
            self.advance()?;
            self.args("spectrum(wavelength:index, wavelength:index, …)", |p, a| {
                if matches!(p.tok.kind, TokenKind::Str(_)) {
                    return Err(p.unexpected(
                        "wavelength:index pairs (a glass's index is written in the scene, not read from a file)",
                    ));
                }
                p.samples(
                    a,
                    pos,
                    |n| n > 0.0,
                    "the index of refraction must be positive",
                )
                .map(Ior::Tabulated)
            })?
        } else {
            let n = self.checked_number(|x| x > 0.0, "the index of refraction must be positive")?;
            return Ok((n, None));
        };
        // Cauchy's index is monotonic in λ, a tabulated one is checked at its samples (above)
        // and named glasses are positive: the ends and the reference cover the visible range.
        for lambda in [LAMBDA_MIN, REFERENCE_WAVELENGTH, LAMBDA_MAX] {
            let n = ior.eval(lambda);
            if !(n > 0.0 && n.is_finite()) {
                return Err(self.error(
                    pos,
                    format!(
                        "the index of refraction must be positive over the visible range (it is {n} at {lambda} nm)"
                    ),
                ));
            }
        }
        let n_d = ior.eval(REFERENCE_WAVELENGTH);
        Ok((n_d, ior.is_dispersive().then_some(ior)))
    }

    /// `metal("name" [, roughness [, distribution]])`, after the keyword.
    pub(super) fn metal(&mut self) -> PResult<BrdfKind> {
        self.args(
            "metal(\"name\" [, roughness [, \"beckmann\"|\"ggx\"]])",
            |p, a| {
                let name = p.arg(a, |p| {
                    let TokenKind::Str(name) = &p.tok.kind else {
                        return Err(p.unexpected("a metal name string such as \"Au\""));
                    };
                    if metal(name).is_none() {
                        let known: Vec<&str> = metal_names().collect();
                        return Err(p.error(
                            p.tok.pos,
                            format!(
                                "unknown metal '{name}' (names are case-sensitive; known: {})",
                                known.join(", ")
                            ),
                        ));
                    }
                    let name = name.clone();
                    p.advance()?;
                    Ok(name)
                })?;
                let mut roughness = 0.0;
                let mut distribution = Distribution::Ggx;
                if p.more(a)? {
                    roughness = p.arg(a, |p| {
                        p.checked_number(|x| x >= 0.0, "the roughness must not be negative")
                    })?;
                    if p.more(a)? {
                        distribution = p.arg(a, Self::distribution)?;
                    }
                }
                Ok(BrdfKind::Metal {
                    name,
                    roughness,
                    distribution,
                })
            },
        )
    }
}
