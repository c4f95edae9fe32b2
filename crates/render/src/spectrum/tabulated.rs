//! Tabulated spectra: piecewise linear over (wavelength, value) samples, and their text forms.
//!
//! Two text forms are read (both Mitsuba's):
//! - a list `"400:0.34, 404:0.35, …"` (a `<spectrum value="…"/>` attribute): comma-separated
//!   `wavelength:value` pairs, whitespace allowed around every token;
//! - a file (`.spd`): one `wavelength value` pair per line separated by whitespace, `#` starting
//!   a comment to the end of the line, blank lines ignored.
//!
//! Wavelengths are in nm and must increase strictly; at least two samples are needed.
//! Outside the sampled range the spectrum is 0 ([`TabulatedSpectrum::eval`]), as Mitsuba 3's
//! `regular`/`irregular` spectra and its RGB conversion (`spectrum_list_to_srgb`) treat it;
//! [`TabulatedSpectrum::eval_clamped`] holds the end values instead (for an IOR).

use std::borrow::Cow;
use std::fmt;

use super::sampled::SampledSpectrum;
use super::wavelengths::SampledWavelengths;

/// Why a spectrum could not be read: the message and, for files, the 1-based line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpectrumParseError {
    /// The line of a file (1-based), `None` for a one-line list.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for SpectrumParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "line {l}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for SpectrumParseError {}

fn err(line: Option<usize>, message: String) -> SpectrumParseError {
    SpectrumParseError { line, message }
}

/// A piecewise-linear spectrum over samples (λ in nm, value) with increasing λ.
#[derive(Clone, Debug, PartialEq)]
pub struct TabulatedSpectrum {
    samples: Cow<'static, [(f32, f32)]>,
}

impl TabulatedSpectrum {
    /// From samples; errors unless there are at least two, all finite, with strictly
    /// increasing wavelengths.
    pub fn new(samples: Vec<(f32, f32)>) -> Result<Self, SpectrumParseError> {
        Self::check(&samples, None)?;
        Ok(Self {
            samples: Cow::Owned(samples),
        })
    }

    /// From static samples (built-in tables), checked like [`new`](Self::new).
    pub fn from_static(samples: &'static [(f32, f32)]) -> Result<Self, SpectrumParseError> {
        Self::check(samples, None)?;
        Ok(Self {
            samples: Cow::Borrowed(samples),
        })
    }

    fn check(s: &[(f32, f32)], line: Option<usize>) -> Result<(), SpectrumParseError> {
        if s.len() < 2 {
            return Err(err(
                line,
                format!(
                    "a tabulated spectrum needs at least two samples, got {}",
                    s.len()
                ),
            ));
        }
        if let Some(&(l, v)) = s.iter().find(|(l, v)| !l.is_finite() || !v.is_finite()) {
            return Err(err(line, format!("sample {l}:{v} is not finite")));
        }
        if let Some(w) = s.windows(2).find(|w| !(w[1].0 > w[0].0)) {
            return Err(err(
                line,
                format!(
                    "wavelengths must increase: {} nm follows {} nm",
                    w[1].0, w[0].0
                ),
            ));
        }
        Ok(())
    }

    /// Parses a `"λ:value, λ:value, …"` list.
    pub fn parse_list(text: &str) -> Result<Self, SpectrumParseError> {
        let mut samples = Vec::new();
        for item in text.split(',') {
            let item = item.trim();
            if item.is_empty() {
                return Err(err(
                    None,
                    format!("empty entry in the spectrum list \"{text}\""),
                ));
            }
            let (l, v) = item
                .split_once(':')
                .ok_or_else(|| err(None, format!("expected wavelength:value, got \"{item}\"")))?;
            let num = |s: &str| {
                s.trim().parse::<f32>().map_err(|_| {
                    err(
                        None,
                        format!("\"{}\" is not a number (in \"{item}\")", s.trim()),
                    )
                })
            };
            samples.push((num(l)?, num(v)?));
        }
        Self::new(samples)
    }

    /// Parses the text of a spectrum file (`λ value` per line, `#` comments).
    pub fn parse_spd(text: &str) -> Result<Self, SpectrumParseError> {
        let mut samples = Vec::new();
        let mut last_line = None;
        for (i, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let n = Some(i + 1);
            let fields: Vec<&str> = line.split_whitespace().collect();
            if fields.len() != 2 {
                return Err(err(
                    n,
                    format!("expected \"wavelength value\", got \"{line}\""),
                ));
            }
            let num = |s: &str| {
                s.parse::<f32>()
                    .map_err(|_| err(n, format!("\"{s}\" is not a number")))
            };
            let sample = (num(fields[0])?, num(fields[1])?);
            if let Some(&(prev, _)) = samples.last() {
                if !(sample.0 > prev) {
                    return Err(err(
                        n,
                        format!(
                            "wavelengths must increase: {} nm follows {prev} nm",
                            sample.0
                        ),
                    ));
                }
            }
            samples.push(sample);
            last_line = n;
        }
        Self::check(&samples, last_line)?;
        Ok(Self {
            samples: Cow::Owned(samples),
        })
    }

    /// The samples (λ in nm, value).
    pub fn samples(&self) -> &[(f32, f32)] {
        &self.samples
    }

    /// The sampled range [first λ, last λ] in nm.
    pub fn range(&self) -> (f32, f32) {
        (self.samples[0].0, self.samples[self.samples.len() - 1].0)
    }

    /// The interpolant at `lambda`, with `outside` below/above the range.
    #[inline]
    fn interp(&self, lambda: f32, clamp: bool) -> f32 {
        let s = &self.samples;
        let (first, last) = (s[0], s[s.len() - 1]);
        if !(lambda >= first.0) {
            return if clamp { first.1 } else { 0.0 };
        }
        if !(lambda <= last.0) {
            return if clamp { last.1 } else { 0.0 };
        }
        // The last sample with λ ≤ lambda, as the left end of the segment.
        let i = (s.partition_point(|&(l, _)| l <= lambda) - 1).min(s.len() - 2);
        let (l0, v0) = s[i];
        let (l1, v1) = s[i + 1];
        let t = (lambda - l0) / (l1 - l0);
        v0 + t * (v1 - v0)
    }

    /// The value at `lambda` nm: linear between samples, 0 outside the sampled range.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.interp(lambda, false)
    }

    /// The value at `lambda` nm, holding the first/last value outside the sampled range.
    #[inline]
    pub fn eval_clamped(&self, lambda: f32) -> f32 {
        self.interp(lambda, true)
    }

    /// [`eval`](Self::eval) at four wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        lambda.eval(|l| self.eval(l))
    }

    /// The largest sample value.
    pub fn max_value(&self) -> f32 {
        self.samples.iter().map(|s| s.1).fold(f32::MIN, f32::max)
    }

    /// True when every sample has the same value.
    pub fn is_constant(&self) -> bool {
        self.samples.iter().all(|s| s.1 == self.samples[0].1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn list_parses_and_interpolates() {
        let s = TabulatedSpectrum::parse_list(" 400:0.34, 404 : 0.35,410:0.5 ").unwrap();
        assert_eq!(s.samples(), &[(400.0, 0.34), (404.0, 0.35), (410.0, 0.5)]);
        assert_eq!(s.eval(400.0), 0.34);
        assert!((s.eval(402.0) - 0.345).abs() < 1e-6);
        assert!((s.eval(407.0) - 0.425).abs() < 1e-6);
        assert_eq!(s.eval(410.0), 0.5);
        assert_eq!(s.eval(399.9), 0.0);
        assert_eq!(s.eval(410.1), 0.0);
        assert_eq!(s.eval_clamped(300.0), 0.34);
        assert_eq!(s.eval_clamped(900.0), 0.5);
        assert_eq!(s.range(), (400.0, 410.0));
        assert_eq!(s.max_value(), 0.5);
        for bad in [
            "",
            "400:0.3",
            "400:0.3,",
            "400-0.3, 500:1",
            "400:x, 500:1",
            "500:1, 400:1",
        ] {
            assert!(TabulatedSpectrum::parse_list(bad).is_err(), "{bad}");
        }
        assert!(TabulatedSpectrum::parse_list("400:1, 400:2").is_err());
    }

    #[test]
    fn spd_parses() {
        let text = "# comment\n\n 300.5  1.5 # trailing\r\n400 2\n#600 9\n500\t4\n";
        let s = TabulatedSpectrum::parse_spd(text).unwrap();
        assert_eq!(s.samples(), &[(300.5, 1.5), (400.0, 2.0), (500.0, 4.0)]);
        assert_eq!(s.eval(450.0), 3.0);
        let e = TabulatedSpectrum::parse_spd("400 1\n500 2 3\n").unwrap_err();
        assert_eq!(e.line, Some(2));
        let e = TabulatedSpectrum::parse_spd("400 1\n\n300 2\n").unwrap_err();
        assert_eq!(e.line, Some(3));
        assert!(e.to_string().starts_with("line 3: "));
        assert!(TabulatedSpectrum::parse_spd("# nothing\n").is_err());
        assert!(TabulatedSpectrum::parse_spd("400 nan\n500 1").is_err());
    }
}
