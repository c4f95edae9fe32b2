//! The course's tone mapping from HDR [`Image`]s to 8-bit RGB, and the sRGB transfer curves.
//!
//! [`ToneMap::apply`] follows the course step by step:
//!
//! 1. per-pixel luminosity `l = (max + min) / 2` of the channels;
//! 2. average luminosity `⟨l⟩ = 10^(mean of log10(δ + l))` over the pixels, with `δ = 1e-10`
//!    ([`DELTA`]), computed in f64 — or the user's value instead;
//! 3. every channel multiplied by `a / ⟨l⟩` (`a` = [`ToneMap::factor`], 0.18 by default);
//! 4. every channel squashed into `[0, 1)` by `x → x / (1 + x)`;
//! 5. every channel encoded to a byte: `floor(255 · x^(1/γ))` for [`Encoding::Gamma`] (exactly the
//!    course's `int(...)`), or `round(255 · srgb_oetf(x))` for [`Encoding::Srgb`].
//!
//! Out-of-range input never panics: negative and NaN channels count as 0 (+∞ becomes 255), and
//! pixels with a non-finite channel are left out of the average so they cannot poison it.

use candela_render::Image;

/// The course's `δ`, which keeps `log10(δ + l)` finite for black pixels.
pub const DELTA: f64 = 1e-10;

/// How tone-mapped values in `[0, 1]` become bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Encoding {
    /// The course's `floor(255 · x^(1/γ))`; `γ = 1` (the default) stores `x` linearly.
    /// `γ` should be positive.
    Gamma(f32),
    /// `round(255 · srgb_oetf(x))`: the standard sRGB curve that image viewers assume.
    Srgb,
}

impl Default for Encoding {
    fn default() -> Self {
        Encoding::Gamma(1.0)
    }
}

/// The parameters of the course's tone mapping; see the [module docs](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMap {
    /// The key `a` that the average luminosity is mapped to (default 0.18).
    pub factor: f32,
    /// The average luminosity `⟨l⟩` to use instead of the image's own (default: computed).
    pub luminosity: Option<f32>,
    /// How the result becomes bytes (default: γ = 1).
    pub encoding: Encoding,
}

impl Default for ToneMap {
    fn default() -> Self {
        Self {
            factor: 0.18,
            luminosity: None,
            encoding: Encoding::default(),
        }
    }
}

impl ToneMap {
    /// Tone-maps `img` into 8-bit RGB triplets, row-major, top row first (`3 · w · h` bytes).
    pub fn apply(&self, img: &Image) -> Vec<u8> {
        let average = self
            .luminosity
            .map_or_else(|| average_luminosity(img, DELTA), f64::from);
        let scale = (f64::from(self.factor) / average) as f32;
        let encode = |c: f32| {
            let x = squash(c * scale);
            match self.encoding {
                Encoding::Gamma(gamma) => (255.0 * x.powf(1.0 / gamma)) as u8,
                Encoding::Srgb => (255.0 * srgb_oetf(x)).round() as u8,
            }
        };
        img.pixels()
            .iter()
            .flat_map(|p| p.to_array())
            .map(encode)
            .collect()
    }
}

/// The course's average luminosity `10^(mean of log10(delta + l))`, in f64.
///
/// Negative and NaN channels count as 0, pixels with a non-finite channel are skipped, and an
/// image without any finite pixel averages to `delta` (like an all-black one).
pub fn average_luminosity(img: &Image, delta: f64) -> f64 {
    let (sum, count) =
        img.pixels()
            .iter()
            .filter(|p| p.is_finite())
            .fold((0.0, 0u64), |(sum, count), p| {
                let p = p.map(|c| c.max(0.0));
                // (max + min) / 2 in f64, which cannot overflow.
                let l = (f64::from(p.max_component()) + f64::from(p.min_component())) / 2.0;
                (sum + (delta + l).log10(), count + 1)
            });
    if count == 0 {
        delta
    } else {
        10f64.powf(sum / count as f64)
    }
}

/// The course's `x / (1 + x)`, with NaN and negatives mapped to 0 and +∞ to 1.
fn squash(x: f32) -> f32 {
    if x == f32::INFINITY {
        return 1.0;
    }
    let x = x.max(0.0);
    x / (1.0 + x)
}

/// The sRGB OETF: linear `x` in `[0, 1]` to its encoded value in `[0, 1]`.
pub fn srgb_oetf(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The sRGB EOTF (inverse of [`srgb_oetf`]): encoded `c` in `[0, 1]` to linear.
pub fn srgb_eotf(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use candela_render::Rgb;

    use super::*;

    /// (5, 10, 15) and (500, 1000, 1500): l = 10 and 1000, so ⟨l⟩ = 10^((1 + 3) / 2) = 100.
    fn two_pixels() -> Image {
        let pixels = vec![Rgb::new(5.0, 10.0, 15.0), Rgb::new(500.0, 1000.0, 1500.0)];
        Image::from_pixels(2, 1, pixels).unwrap()
    }

    fn map(factor: f32, luminosity: Option<f32>, encoding: Encoding, img: &Image) -> Vec<u8> {
        ToneMap {
            factor,
            luminosity,
            encoding,
        }
        .apply(img)
    }

    #[test]
    fn average_luminosity_is_the_geometric_mean() {
        let avg = average_luminosity(&two_pixels(), DELTA);
        assert!((avg - 100.0).abs() < 1e-9, "{avg}");
        assert_eq!(average_luminosity(&Image::new(3, 2), DELTA), DELTA);
        assert_eq!(average_luminosity(&Image::new(0, 0), DELTA), DELTA);
    }

    #[test]
    fn defaults_are_the_course_values() {
        let t = ToneMap::default();
        assert_eq!(
            (t.factor, t.luminosity, t.encoding),
            (0.18, None, Encoding::Gamma(1.0))
        );
    }

    #[test]
    fn gamma_one_by_hand() {
        // a = 1: channels × 1/100 → (0.05, 0.1, 0.15), (5, 10, 15); x/(1+x) →
        // 0.047619, 0.090909, 0.130435, 0.833333, 0.909091, 0.9375; × 255 →
        // 12.14, 23.18, 33.26, 212.5, 231.82, 239.06.
        let bytes = map(1.0, None, Encoding::Gamma(1.0), &two_pixels());
        assert_eq!(bytes, [12, 23, 33, 212, 231, 239]);
    }

    #[test]
    fn gamma_2_2_by_hand() {
        // The same x^(1/2.2) → 0.25061, 0.33623, 0.39619, 0.92047, 0.95760, 0.97109; × 255 →
        // 63.90, 85.74, 101.03, 234.72, 244.19, 247.63.
        let bytes = map(1.0, None, Encoding::Gamma(2.2), &two_pixels());
        assert_eq!(bytes, [63, 85, 101, 234, 244, 247]);
    }

    #[test]
    fn srgb_by_hand() {
        // 1.055 x^(1/2.4) − 0.055, × 255, rounded: 61.64, 85.03, 101.11, 235.32, 244.53, 247.86.
        let bytes = map(1.0, None, Encoding::Srgb, &two_pixels());
        assert_eq!(bytes, [62, 85, 101, 235, 245, 248]);
    }

    #[test]
    fn user_luminosity_replaces_the_average() {
        // a = 0.18, ⟨l⟩ = 1: (0.9, 1.8, 2.7), (90, 180, 270); x/(1+x) × 255 →
        // 120.79, 163.93, 186.08, 252.20, 253.59, 254.06.
        let bytes = map(0.18, Some(1.0), Encoding::Gamma(1.0), &two_pixels());
        assert_eq!(bytes, [120, 163, 186, 252, 253, 254]);
    }

    #[test]
    fn black_stays_black() {
        let img = Image::new(4, 3);
        for encoding in [Encoding::Gamma(1.0), Encoding::Gamma(2.2), Encoding::Srgb] {
            assert_eq!(map(0.18, None, encoding, &img), vec![0; 36]);
        }
        assert!(ToneMap::default().apply(&Image::new(0, 5)).is_empty());
    }

    #[test]
    fn bad_values_neither_panic_nor_poison_the_average() {
        let good = Image::from_pixels(1, 1, vec![Rgb::new(5.0, 10.0, 15.0)]).unwrap();
        let mut bad = Image::new(3, 1);
        bad.set(0, 0, Rgb::new(5.0, 10.0, 15.0));
        bad.set(1, 0, Rgb::new(f32::NAN, -3.0, f32::INFINITY));
        bad.set(2, 0, Rgb::new(-1.0, -2.0, -3.0));
        let t = ToneMap::default();
        // The negative pixel counts as black; the NaN/∞ one is skipped.
        let expected = 10f64.powf(((10.0 + DELTA).log10() + DELTA.log10()) / 2.0);
        assert!((average_luminosity(&bad, DELTA) / expected - 1.0).abs() < 1e-12);
        let bytes = t.apply(&bad);
        assert_eq!(bytes[3..], [0, 0, 255, 0, 0, 0]);
        let alone = ToneMap {
            luminosity: Some(expected as f32),
            ..t
        }
        .apply(&good);
        assert_eq!(bytes[..3], alone);
        // Degenerate parameters.
        for t in [
            ToneMap {
                luminosity: Some(0.0),
                ..t
            },
            ToneMap {
                luminosity: Some(f32::NAN),
                ..t
            },
            ToneMap {
                encoding: Encoding::Gamma(0.0),
                ..t
            },
            ToneMap {
                encoding: Encoding::Gamma(-1.0),
                ..t
            },
        ] {
            assert_eq!(t.apply(&bad).len(), 9);
        }
        let all_nan = Image::from_pixels(1, 1, vec![Rgb::splat(f32::NAN)]).unwrap();
        assert_eq!(t.apply(&all_nan), [0, 0, 0]);
    }

    #[test]
    fn srgb_curves() {
        assert!((srgb_eotf(0.5) - 0.214_041).abs() < 1e-6);
        assert!((srgb_oetf(0.214_041) - 0.5).abs() < 1e-6);
        assert_eq!((srgb_oetf(0.0), srgb_eotf(0.0)), (0.0, 0.0));
        assert!((srgb_oetf(1.0) - 1.0).abs() < 1e-6 && (srgb_eotf(1.0) - 1.0).abs() < 1e-6);
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            assert!((srgb_eotf(srgb_oetf(x)) - x).abs() < 1e-5, "{x}");
        }
        // Both pieces meet at the thresholds.
        assert!(
            (srgb_oetf(0.003_130_8) - (1.055 * 0.003_130_8f32.powf(1.0 / 2.4) - 0.055)).abs()
                < 1e-6
        );
        assert!((srgb_eotf(0.040_45) - ((0.040_45f32 + 0.055) / 1.055).powf(2.4)).abs() < 1e-6);
    }
}
