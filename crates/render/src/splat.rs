//! Splatting: each sample's radiance spread over the pixels its filter reaches, as Mitsuba's
//! film does.
//!
//! With a filter wider than the box, the samples are placed uniformly in their pixel and each
//! adds `f(c − s)·L / C(c)` to every pixel whose centre `c` lies within the filter's radius of
//! the sample's position `s`, where `f(x, y) = g(x) g(y)` is the filter ([`Filter::eval_1d`])
//! and the normaliser `C(c) = ∫ f(c − s) ds` over the image is the weight that pixel can expect
//! per sample of each pixel (the integral over the image clips the filter at its edges, as
//! Mitsuba's division by the sum of the weights does). The film then divides the sums by the
//! pixel's own sample count, as for every other filter. The estimate is unbiased, and converges
//! to the normalised filter's convolution of the image, the same image as the filter importance
//! sampling of [`crate::filter::FilterSampler`], with about `(∫f)² / ∫f²` times less variance per
//! pixel (π for Mitsuba's default Gaussian, σ = 0.5: each sample reaches about 16 pixels),
//! at the price of noise that neighbouring pixels share. When a pixel takes a single sample it
//! goes through the pixel centre, and `C` sums the weights of the pixel centres instead.
//!
//! Every sample's shares are computed from its own value and position alone, in single
//! precision, and added to the film's exact fixed-point sums ([`crate::film`]), so a pixel's
//! value does not depend on the order of the samples, on the thread count, or on how the frame
//! was split into windows (a window is rendered with a border of the pixels whose samples reach
//! it; see `crate::render::render_pass_or_cancel`) or into sample ranges.
//!
//! `g` is read from a table of [`TABLE`] intervals over `[0, r]`, linear in between (the exact
//! function to about 10⁻⁷ of its peak for the Gaussian), and the normalisers integrate that
//! same interpolated function.

use crate::color::Rgb;
use crate::film::Window;
use crate::filter::Filter;

/// Intervals of the table of `g` over `[0, radius]`.
pub const TABLE: usize = 2048;

/// The most pixels per axis whose weights [`Splat::add`] keeps in an array (a filter of
/// radius up to 8); wider filters compute them cell by cell.
const TAPS: usize = 17;

/// The most samples [`Splat::add`] may add before a [`Splat::flush`].
pub const FLUSH_EVERY: u32 = 256;

/// The widest margin splatting supports (a Gaussian of σ = 16 reaches 64 pixels).
const MAX_MARGIN: usize = 64;

/// A filter prepared for splatting the samples of a `width × height` image.
#[derive(Clone, Debug)]
pub struct Splat {
    radius: f32,
    margin: usize,
    /// `g` at `i · radius / TABLE`, `i = 0..=TABLE` (and 0 one past the end).
    table: Box<[f32; TABLE + 2]>,
    /// `TABLE / radius`.
    scale: f32,
    /// Per column and per row, 1 / its share of the normaliser `C` (`C = Cx · Cy`).
    inv_x: Vec<f32>,
    inv_y: Vec<f32>,
    /// Every weight a sample gives is below 4 (the products of [`Splat::add`] fit in 64 bits).
    small_weights: bool,
}

impl Splat {
    /// Splatting for `filter` on a `width × height` image whose pixels take `spp` samples each
    /// (one: through the centre), or `None` for the box (each sample stays in its pixel).
    pub fn new(filter: Filter, width: usize, height: usize, spp: u32) -> Option<Self> {
        if filter == Filter::Box || !filter.is_valid() {
            return None;
        }
        let radius = filter.radius();
        // The pixels q a sample of pixel x reaches: |q + 0.5 − s| < r for some s in [x, x + 1).
        let margin = ((radius + 0.5).ceil() as usize)
            .saturating_sub(1)
            .min(MAX_MARGIN);
        let mut table = Box::new([0f32; TABLE + 2]);
        for (i, t) in table.iter_mut().enumerate().take(TABLE + 1) {
            *t = filter.eval_1d(i as f64 * radius as f64 / TABLE as f64) as f32;
        }
        let mut s = Self {
            radius,
            margin,
            table,
            scale: TABLE as f32 / radius,
            inv_x: Vec::new(),
            inv_y: Vec::new(),
            small_weights: false,
        };
        let centred = spp == 1;
        s.inv_x = (0..width)
            .map(|x| s.inverse_share(x, width, centred))
            .collect();
        s.inv_y = (0..height)
            .map(|y| s.inverse_share(y, height, centred))
            .collect();
        let peak = s.table.iter().fold(0f32, |m, v| m.max(v.abs()));
        let most = |v: &[f32]| v.iter().fold(0f32, |m, v| m.max(v.abs()));
        s.small_weights = peak * peak * most(&s.inv_x) * most(&s.inv_y) < 3.99;
        Some(s)
    }

    /// How many pixels beyond its own, per side, a sample reaches.
    pub fn margin(&self) -> usize {
        self.margin
    }

    /// `g(d)` from the table (0 beyond the radius).
    #[inline(always)]
    fn g(&self, d: f32) -> f32 {
        let x = d.abs() * self.scale;
        if !(x < TABLE as f32) {
            return 0.0;
        }
        let i = floor(x).min(TABLE);
        let f = x - i as f32;
        let (a, b) = (self.table[i], self.table[i + 1]);
        a + (b - a) * f
    }

    /// 1 / the weight pixel `p` of an axis of `n` pixels expects from one sample of each pixel:
    /// `∫ g(p + 0.5 − s) ds` over `[0, n]`, or with samples at the centres the sum of `g` over
    /// the centres.
    fn inverse_share(&self, p: usize, n: usize, centred: bool) -> f32 {
        let c = p as f64 + 0.5;
        let r = self.radius as f64;
        let g = |d: f64| self.g(d as f32) as f64;
        let share = if centred {
            let lo = p.saturating_sub(self.margin);
            let hi = (p + self.margin + 1).min(n);
            (lo..hi).map(|q| g(c - (q as f64 + 0.5))).sum::<f64>()
        } else {
            // Simpson's rule between the table's knots (where g is linear, so exact up to
            // rounding), over the part of [c − r, c + r] inside the axis.
            let (a, b) = ((c - r).max(0.0), (c + r).min(n as f64));
            let steps = 2 * TABLE;
            let h = (b - a) / steps as f64;
            let mut acc = 0.0;
            for k in 0..steps {
                let x0 = a + k as f64 * h;
                acc += (g(c - x0) + 4.0 * g(c - x0 - 0.5 * h) + g(c - x0 - h)) * h / 6.0;
            }
            acc
        };
        if share > 1e-6 {
            (1.0 / share) as f32
        } else {
            0.0
        }
    }

    /// Adds the shares of the sample of value `l` at `offset` (from the corner, in `[0, 1)²`)
    /// in pixel `(x, y)` to the sums of the pixels of `rect` (row-major); pixels outside
    /// `rect` get nothing. The sums are `wide`, plus what `quick` holds until
    /// [`Splat::flush`] moves it there, which must come after at most [`FLUSH_EVERY`] samples.
    ///
    /// In fixed point as integers, not through [`crate::film::to_fixed`] per share: the value
    /// in units of 2⁻²⁴ (clamped at ±2³⁸) times the share's weight in units of 2⁻²⁴ is the
    /// share in the film's units of 2⁻⁴⁸, one integer product per channel (the conversions
    /// took a third of a Cornell box's frame). Both factors are functions of the sample alone,
    /// so the sums stay exact in any order; the rounding of the weight to 2⁻²⁴ is unbiased
    /// over the sample's position. Values below 32 with weights below 4 (nearly all) give
    /// shares below 2⁵⁵, which `quick` sums in 64 bits ([`FLUSH_EVERY`] of them at most
    /// before a flush); the others go to `wide` in 128 bits.
    #[inline]
    pub fn add(
        &self,
        (wide, quick): (&mut [[i128; 3]], &mut [[i64; 3]]),
        rect: Window,
        (x, y): (usize, usize),
        offset: [f32; 2],
        l: Rgb,
    ) {
        const UNIT: f32 = (1u32 << 24) as f32;
        const MAX: f32 = (1u64 << 38) as f32;
        let r = self.radius;
        let (sx, sy) = (x as f32 + offset[0], y as f32 + offset[1]);
        // The pixels q with |q + 0.5 − s| < r (a few more at worst, whose weight is 0), at
        // most `margin` from the sample's own, within `rect`.
        let m = self.margin;
        let span = |c: usize, s: f32, lo: usize, hi: usize| {
            let t = s - 0.5 - r;
            let a = if t > 0.0 { floor(t) } else { 0 };
            let b = floor(s - 0.5 + r) + 1;
            let a = a.max(c.saturating_sub(m)).max(lo);
            (a, b.min(c + m + 1).min(hi).max(a))
        };
        let (x0, x1) = span(x, sx, rect.x0, rect.x1);
        let (y0, y1) = span(y, sy, rect.y0, rect.y1);
        let n = x1 - x0;
        let fixed = |v: f32| (v.clamp(-MAX, MAX) * UNIT) as i64;
        let lf = [fixed(l.r), fixed(l.g), fixed(l.b)];
        let small = self.small_weights && lf.iter().all(|v| v.unsigned_abs() < 1 << 29);
        let width = rect.width();
        if n > TAPS || !small {
            // Wide filters, large values: weights computed cell by cell, 128-bit sums.
            for q in y0..y1 {
                let wy = self.g(q as f32 + 0.5 - sy) * self.inv_y[q];
                let row = (q - rect.y0) * width - rect.x0;
                for p in x0..x1 {
                    let wx = self.g(p as f32 + 0.5 - sx) * self.inv_x[p] * UNIT;
                    let w = round(wx * wy) as i128;
                    let sum = &mut wide[row + p];
                    for c in 0..3 {
                        sum[c] += lf[c] as i128 * w;
                    }
                }
            }
            return;
        }
        let mut wx = [0f32; TAPS];
        for k in 0..n {
            let p = x0 + k;
            wx[k] = self.g(p as f32 + 0.5 - sx) * self.inv_x[p] * UNIT;
        }
        for q in y0..y1 {
            let wy = self.g(q as f32 + 0.5 - sy) * self.inv_y[q];
            let row = (q - rect.y0) * width + x0 - rect.x0;
            let cells = &mut quick[row..row + n];
            for k in 0..n {
                let w = round(wx[k] * wy);
                let sum = &mut cells[k];
                sum[0] += lf[0] * w;
                sum[1] += lf[1] * w;
                sum[2] += lf[2] * w;
            }
        }
    }

    /// Moves the 64-bit sums of [`Splat::add`] into the 128-bit ones (and clears them).
    pub fn flush(wide: &mut [[i128; 3]], quick: &mut [[i64; 3]]) {
        for (w, q) in wide.iter_mut().zip(quick.iter_mut()) {
            for c in 0..3 {
                w[c] += q[c] as i128;
            }
            *q = [0; 3];
        }
    }
}

/// ⌊x⌋ for 0 ≤ x < 2²¹, or ⌊x⌋ − 1 when x is an integer: x − ½ rounded to the nearest
/// integer, read from the bits of x − ½ + 1.5·2²³ (where floats are the integers), without
/// the branches of a saturating conversion. Either serves [`Splat::g`]'s interpolation (the
/// fraction is then 1: the next knot's value) and the spans of [`Splat::add`] (a pixel more,
/// of weight 0).
#[inline(always)]
fn floor(x: f32) -> usize {
    (((x - 0.5 + 12_582_912.0).to_bits() & 0x7f_ffff) as usize).wrapping_sub(1 << 22)
}

/// `x` rounded to the nearest integer (ties to even), for |x| < 2⁵¹: through the bits of
/// `x + 1.5·2⁵²` in double precision, without the branches of a saturating conversion.
#[inline(always)]
fn round(x: f32) -> i64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    ((x as f64 + MAGIC).to_bits() as i64).wrapping_sub(MAGIC.to_bits() as i64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::from_fixed;

    /// A constant image comes out constant, borders included: the expected weight of every
    /// pixel is 1 (uniform samples), exactly 1 with samples at the centres.
    #[test]
    fn a_constant_image_stays_constant_to_its_borders() {
        let (w, h) = (9, 7);
        let rect = Window::full(w, h);
        for name in crate::filter::FILTER_NAMES {
            let filter = Filter::by_name(name).unwrap();
            let Some(s) = Splat::new(filter, w, h, 1) else {
                assert_eq!(name, "box");
                continue;
            };
            let mut buf = vec![[0i128; 3]; w * h];
            let mut quick = vec![[0i64; 3]; w * h];
            for (x, y) in rect.points() {
                s.add(
                    (&mut buf, &mut quick),
                    rect,
                    (x, y),
                    [0.5, 0.5],
                    Rgb::new(1.0, 1.0, 1.0),
                );
            }
            Splat::flush(&mut buf, &mut quick);
            for v in &buf {
                assert!(
                    (from_fixed(v[0]) - 1.0).abs() < 1e-5,
                    "{name}: {}",
                    from_fixed(v[0])
                );
            }
            // Uniform samples: 1 in expectation. A 32 × 32 grid of midpoints in every pixel
            // (the midpoint rule converges to the integral the normaliser holds).
            let s = Splat::new(filter, w, h, 64).unwrap();
            let mut buf = vec![[0i128; 3]; w * h];
            let mut quick = vec![[0i64; 3]; w * h];
            let k = 32;
            for (x, y) in rect.points() {
                for i in 0..k * k {
                    let o = [(i % k) as f32 + 0.5, (i / k) as f32 + 0.5].map(|v| v / k as f32);
                    s.add(
                        (&mut buf, &mut quick),
                        rect,
                        (x, y),
                        o,
                        Rgb::new(1.0, 1.0, 1.0),
                    );
                    if i % FLUSH_EVERY as usize == FLUSH_EVERY as usize - 1 {
                        Splat::flush(&mut buf, &mut quick);
                    }
                }
            }
            for (i, v) in buf.iter().enumerate() {
                let mean = from_fixed(v[0]) / (k * k) as f64;
                assert!((mean - 1.0).abs() < 2e-3, "{name}: pixel {i}: {mean}");
            }
        }
    }

    /// The table and the filter agree, and a sample reaches exactly the pixels within the
    /// radius of its position.
    #[test]
    fn weights_follow_the_filter_within_its_radius() {
        let f = Filter::Gaussian { stddev: 0.5 };
        let s = Splat::new(f, 64, 64, 16).unwrap();
        assert_eq!(s.margin(), 2);
        for k in 0..=1000 {
            let d = k as f32 * 0.0025;
            assert!((s.g(d) as f64 - f.eval_1d(d as f64)).abs() < 1e-6, "{d}");
        }
        let rect = Window::full(64, 64);
        let mut buf = vec![[0i128; 3]; 64 * 64];
        let mut quick = vec![[0i64; 3]; 64 * 64];
        s.add(
            (&mut buf, &mut quick),
            rect,
            (30, 30),
            [0.1, 0.9],
            Rgb::new(1.0, 0.0, 0.0),
        );
        // A value of 32 or more goes straight to the wide sums, and adds the same.
        let mut wide = vec![[0i128; 3]; 64 * 64];
        s.add(
            (&mut wide, &mut quick),
            rect,
            (30, 30),
            [0.1, 0.9],
            Rgb::new(128.0, 0.0, 0.0),
        );
        Splat::flush(&mut buf, &mut quick);
        for (x, y) in rect.points() {
            let i = y * 64 + x;
            assert_eq!(wide[i][0], 128 * buf[i][0], "({x}, {y})");
            let (dx, dy) = (x as f32 + 0.5 - 30.1, y as f32 + 0.5 - 30.9);
            let reached = dx.abs() < 2.0 && dy.abs() < 2.0;
            assert_eq!(buf[y * 64 + x][0] != 0, reached, "({x}, {y})");
        }
    }
}
