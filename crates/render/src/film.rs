//! The film: per-pixel sums of sample values that are exact in any order.
//!
//! Each sample's value (an f32 per channel) is converted to fixed point — an integer count of
//! 2⁻⁴⁸ — and added as a 128-bit integer. Integer addition is associative, so the sum of a
//! pixel's samples has the same bits however the samples were split: over threads, over passes,
//! over separate processes whose films are merged afterwards. The conversion is exact for every
//! value from 2⁻²⁴ up (an f32 has 24 significant bits) and rounds smaller ones towards zero;
//! values beyond ±2⁶⁰ (about 10¹⁸, far beyond any radiance) are clamped so that no sum can
//! overflow. The mean of a pixel is its sum divided by its sample count, in f64.

use crate::color::Rgb;
use crate::image::Image;

/// Fixed-point scale: values are counted in units of 2⁻⁴⁸.
const FIXED_SHIFT: i32 = 48;
/// The largest magnitude converted (larger values are clamped).
const FIXED_CLAMP: f64 = (1u64 << 60) as f64;

/// Magnitudes below which an f64 converts to i64 without saturating (2⁶²).
const I64_SAFE: f64 = (1u64 << 62) as f64;

/// One channel value as a fixed-point integer (see the module doc). NaN becomes 0.
#[inline]
pub fn to_fixed(v: f32) -> i128 {
    let x = (v as f64).clamp(-FIXED_CLAMP, FIXED_CLAMP) * 2f64.powi(FIXED_SHIFT);
    // f64 → integer truncates towards zero and maps NaN to 0. Through i64 when it fits (every
    // |v| < 2¹⁵, one instruction) rather than the i128 conversion (a library call): the same
    // integer.
    if x.abs() < I64_SAFE {
        x as i64 as i128
    } else {
        x as i128
    }
}

/// A fixed-point sum back as a float.
#[inline]
pub fn from_fixed(s: i128) -> f64 {
    s as f64 * 2f64.powi(-FIXED_SHIFT)
}

/// A rectangle of pixels, `[x0, x1) × [y0, y1)`, row 0 at the top (`Default`: empty).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Window {
    /// First column.
    pub x0: usize,
    /// One past the last column.
    pub x1: usize,
    /// First row.
    pub y0: usize,
    /// One past the last row.
    pub y1: usize,
}

impl Window {
    /// The whole `width × height` image.
    pub fn full(width: usize, height: usize) -> Self {
        Self {
            x0: 0,
            x1: width,
            y0: 0,
            y1: height,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.y1 - self.y0
    }

    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width() * self.height()
    }

    /// Its pixels (x, y), in rows.
    pub fn points(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (self.y0..self.y1).flat_map(move |y| (self.x0..self.x1).map(move |x| (x, y)))
    }

    /// True when the window lies inside a `width × height` image and is not empty.
    pub fn fits(&self, width: usize, height: usize) -> bool {
        self.x0 < self.x1 && self.y0 < self.y1 && self.x1 <= width && self.y1 <= height
    }

    /// True when the two windows share a pixel.
    pub fn overlaps(&self, o: &Window) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
}

/// Exact sums of the samples of a window of an image (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Film {
    width: usize,
    height: usize,
    window: Window,
    channels: usize,
    /// Per window pixel (row-major), `channels` fixed-point sums.
    sums: Vec<i128>,
    /// Per window pixel, the samples added.
    counts: Vec<u32>,
}

impl Film {
    /// An empty film for `window` of a `width × height` image, `channels` values per sample.
    pub fn new(width: usize, height: usize, window: Window, channels: usize) -> Self {
        let n = window.pixels();
        Self {
            width,
            height,
            window,
            channels,
            sums: vec![0; n * channels],
            counts: vec![0; n],
        }
    }

    /// Image width.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The pixels this film holds.
    pub fn window(&self) -> Window {
        self.window
    }

    /// Values per sample.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The sums, `channels` per window pixel, row-major.
    pub fn sums(&self) -> &[i128] {
        &self.sums
    }

    /// The sample counts per window pixel, row-major.
    pub fn counts(&self) -> &[u32] {
        &self.counts
    }

    /// A film from its parts (as read back from a file); `None` when the sizes disagree.
    pub fn from_parts(
        width: usize,
        height: usize,
        window: Window,
        channels: usize,
        sums: Vec<i128>,
        counts: Vec<u32>,
    ) -> Option<Self> {
        let n = window.pixels();
        (window.fits(width, height) && sums.len() == n * channels && counts.len() == n).then_some(
            Self {
                width,
                height,
                window,
                channels,
                sums,
                counts,
            },
        )
    }

    /// Adds the fixed-point sums `sums` (`channels` per pixel) and counts of the pixels of
    /// `rect` (inside the window), row-major.
    pub(crate) fn add_block(&mut self, rect: Window, sums: &[i128], counts: &[u32]) {
        let c = self.channels;
        for (row, y) in (rect.y0..rect.y1).enumerate() {
            let w = rect.width();
            let at = (y - self.window.y0) * self.window.width() + (rect.x0 - self.window.x0);
            for k in 0..w {
                self.counts[at + k] += counts[row * w + k];
                for ch in 0..c {
                    self.sums[(at + k) * c + ch] += sums[(row * w + k) * c + ch];
                }
            }
        }
    }

    /// Adds the radiance sums `sums` (channels 0 to 2, one entry per pixel of `rect`, row-major)
    /// to the pixels of `rect` inside the window (splatted samples: the counts stay).
    pub(crate) fn add_radiance(&mut self, rect: Window, sums: &[[i128; 3]]) {
        let c = self.channels;
        let w = self.window;
        for y in rect.y0.max(w.y0)..rect.y1.min(w.y1) {
            for x in rect.x0.max(w.x0)..rect.x1.min(w.x1) {
                let at = ((y - w.y0) * w.width() + (x - w.x0)) * c;
                let s = &sums[(y - rect.y0) * rect.width() + (x - rect.x0)];
                for ch in 0..3 {
                    self.sums[at + ch] += s[ch];
                }
            }
        }
    }

    /// Adds another film of the same image and channels (its window inside this one's): the
    /// sums and counts of every pixel it holds.
    pub fn merge(&mut self, other: &Film) -> Result<(), String> {
        if (other.width, other.height, other.channels) != (self.width, self.height, self.channels) {
            return Err(format!(
                "a {}×{} film with {} channels cannot merge into a {}×{} one with {}",
                other.width, other.height, other.channels, self.width, self.height, self.channels
            ));
        }
        let (a, b) = (self.window, other.window);
        if !(b.x0 >= a.x0 && b.x1 <= a.x1 && b.y0 >= a.y0 && b.y1 <= a.y1) {
            return Err("the film's window lies outside this one".into());
        }
        self.add_block(b, &other.sums, &other.counts);
        Ok(())
    }

    /// The mean of channels `first..first + 3` of each pixel as an image of the whole frame
    /// (black outside the window and where no sample arrived).
    pub fn rgb(&self, first: usize) -> Image {
        let mut img = Image::new(self.width, self.height);
        for (p, v) in img
            .pixels_mut()
            .iter_mut()
            .zip(self.means(first, 3).chunks(3))
        {
            *p = Rgb::new(v[0], v[1], v[2]);
        }
        img
    }

    /// The mean of channels `first..first + n` of each pixel of the whole frame, `n` values per
    /// pixel, row-major (0 outside the window and where no sample arrived).
    pub fn means(&self, first: usize, n: usize) -> Vec<f32> {
        let mut out = vec![0.0; self.width * self.height * n];
        let c = self.channels;
        for y in self.window.y0..self.window.y1 {
            for x in self.window.x0..self.window.x1 {
                let i = (y - self.window.y0) * self.window.width() + (x - self.window.x0);
                let count = self.counts[i];
                if count == 0 {
                    continue;
                }
                for k in 0..n {
                    let s = from_fixed(self.sums[i * c + first + k]);
                    out[(y * self.width + x) * n + k] = (s / count as f64) as f32;
                }
            }
        }
        out
    }

    /// Total samples added (all pixels).
    pub fn samples(&self) -> u64 {
        self.counts.iter().map(|&n| n as u64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    #[test]
    fn fixed_point_is_exact_for_ordinary_values_and_clamps_the_rest() {
        for v in [0.0f32, 1.0, -2.5, 0.1, 3.0e-7, 12345.678, 2.0f32.powi(-24)] {
            assert_eq!(from_fixed(to_fixed(v)) as f32, v);
        }
        assert_eq!(to_fixed(f32::NAN), 0);
        assert_eq!(to_fixed(f32::INFINITY), to_fixed(1.0e19));
        // Below 2⁻⁴⁸ nothing is left.
        assert_eq!(to_fixed(1.0e-20), 0);
    }

    #[test]
    fn the_i64_shortcut_gives_the_i128_conversion() {
        let slow = |v: f32| ((v as f64).clamp(-FIXED_CLAMP, FIXED_CLAMP) * 2f64.powi(48)) as i128;
        let mut rng = Pcg32::new(3, 4);
        for _ in 0..100_000 {
            let e = (rng.next_f32() * 90.0) as i32 - 60;
            let v = (rng.next_f32() - 0.5) * 2f32.powi(e);
            assert_eq!(to_fixed(v), slow(v), "{v}");
        }
        for v in [
            2f32.powi(14),
            -2f32.powi(14),
            32767.998,
            2f32.powi(15),
            -2f32.powi(15),
            1e18,
            -1e30,
            f32::NEG_INFINITY,
        ] {
            assert_eq!(to_fixed(v), slow(v), "{v}");
        }
    }

    #[test]
    fn sums_do_not_depend_on_how_the_samples_were_split() {
        let mut rng = Pcg32::new(1, 2);
        let values: Vec<f32> = (0..1000)
            .map(|_| (rng.next_f32() - 0.3) * 10f32.powi((rng.next_f32() * 12.0) as i32 - 6))
            .collect();
        let whole: i128 = values.iter().map(|&v| to_fixed(v)).sum();
        for cut in [0, 1, 4, 333, 999, 1000] {
            let (a, b) = values.split_at(cut);
            let split: i128 = b.iter().rev().map(|&v| to_fixed(v)).sum::<i128>()
                + a.iter().map(|&v| to_fixed(v)).sum::<i128>();
            assert_eq!(split, whole);
        }
    }

    #[test]
    fn films_merge_by_windows() {
        let w = Window::full(4, 3);
        let mut whole = Film::new(4, 3, w, 3);
        let left = Window {
            x0: 0,
            x1: 2,
            y0: 0,
            y1: 3,
        };
        let mut part = Film::new(4, 3, left, 3);
        part.add_block(left, &vec![to_fixed(1.0); 6 * 3], &[2; 6]);
        whole.merge(&part).unwrap();
        let img = whole.rgb(0);
        assert_eq!(img.get(1, 2), Rgb::new(0.5, 0.5, 0.5));
        assert_eq!(img.get(3, 0), Rgb::BLACK);
        assert!(part.merge(&whole).is_err());
        assert!(whole
            .merge(&Film::new(5, 3, Window::full(5, 3), 3))
            .is_err());
    }
}
