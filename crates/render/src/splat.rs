//! Splatting: each sample's radiance spread over the pixels its filter reaches, as Mitsuba's
//! film does.
//!
//! With a filter wider than the box, the samples are placed uniformly in their pixel and each
//! adds `f(c − s)·L / C(c)` to every pixel whose centre `c` lies within the filter's radius of
//! the sample's position `s`, where `f(x, y) = g(x) g(y)` is the filter ([`Filter::eval_1d`])
//! and the normaliser `C(c) = ∫ f(c − s) ds` over the image is the weight that pixel can expect
//! per sample of each pixel (the integral over the image clips the filter at its edges, as
//! Mitsuba's division by the sum of the weights does). The film then divides the sums by the
//! pixel's own sample count, as for every other filter. The estimate is unbiased (up to the
//! rounding of positions and weights below, which moves the expected image by less than 10⁻⁵),
//! and converges to the normalised filter's convolution of the image, the same image as the
//! filter importance
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

/// The most samples [`Splat::add`] may add before a [`SplatSums::flush`].
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
    /// Every weight a sample gives is below 2 along each axis (the products of [`Splat::add`]
    /// fit in 64 bits).
    small_weights: bool,
    /// Samples away from the image's edges (see [`Splat::interior`]): per position in the
    /// pixel rounded to 1/[`STEPS`], the offset of the first pixel reached (from the sample's
    /// own) and the weights along the axis of the pixels reached, in units of 2⁻¹⁴ (0 past
    /// the last one), from the normaliser of the pixels away from the edges.
    steps: Vec<(isize, [i32; 8])>,
    /// How many pixels per axis a sample away from the edges reaches at most (0: no such
    /// samples are taken from `steps`).
    step_taps: usize,
}

/// Positions per pixel (per axis) of the table of samples away from the image's edges: a
/// sample's position is rounded to the nearest (1/512 of a pixel at most, on either side
/// alike), which changes the expected image by about 10⁻⁶ of the filter's curvature.
pub const STEPS: usize = 256;

impl Splat {
    /// Splatting for `filter` on a `width × height` image whose pixels take `spp` samples each
    /// (one: through the centre), or `None` for the box (each sample stays in its pixel) and
    /// for a filter whose weights would leave the fixed point's range (none of the valid ones
    /// does; it would be importance-sampled).
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
            steps: Vec::new(),
            step_taps: 0,
        };
        let centred = spp == 1;
        // (Only the pixels the filter's edge can reach from outside the image differ from
        // the ones in the middle.)
        let shares = |n: usize| -> Vec<f32> {
            let inner = s.inverse_share(n / 2, n, centred);
            (0..n)
                .map(|p| {
                    if p <= margin || p + margin + 1 >= n {
                        s.inverse_share(p, n, centred)
                    } else {
                        inner
                    }
                })
                .collect()
        };
        (s.inv_x, s.inv_y) = (shares(width), shares(height));
        s.tabulate_steps(s.inverse_share(width / 2, width, centred));
        let peak = s.table.iter().fold(0f32, |m, v| m.max(v.abs()));
        let most = |v: &[f32]| v.iter().fold(0f32, |m, v| m.max(v.abs()));
        s.small_weights = peak * most(&s.inv_x) < 1.99 && peak * most(&s.inv_y) < 1.99;
        if peak * most(&s.inv_x).max(most(&s.inv_y)) >= 255.0 {
            // (Weights beyond `axis_weight`'s range: no such filter is valid.)
            return None;
        }
        Some(s)
    }

    /// The table of samples away from the edges (see [`Splat::steps`]), for pixels whose
    /// normaliser's share is 1 / `inner` along each axis.
    fn tabulate_steps(&mut self, inner: f32) {
        let r = self.radius as f64;
        let mut taps = 0;
        self.steps = (0..=STEPS)
            .map(|i| {
                let o = i as f64 / STEPS as f64;
                // The pixels j (from the sample's own) with |j + 0.5 − o| < r.
                let first = (o - 0.5 - r).floor() as isize + 1;
                let mut w = [0i32; 8];
                let mut n = 0;
                for (k, w) in w.iter_mut().enumerate() {
                    let j = first + k as isize;
                    if (j as f64 + 0.5 - o).abs() < r {
                        *w = axis_weight(self.g((j as f64 + 0.5 - o) as f32) * inner);
                        n = k + 1;
                    }
                }
                taps = taps.max(n);
                (first, w)
            })
            .collect();
        // (Filters reaching more than eight pixels per axis take the general path.)
        self.step_taps = if taps <= 8 && (-self.steps[0].0) as usize <= self.margin {
            taps
        } else {
            0
        };
    }

    /// True when a sample in column or row `c` of an axis of `n` pixels reaches only pixels
    /// whose normaliser is the one of the middle (see [`Splat::new`]).
    #[inline(always)]
    fn interior(&self, c: usize, n: usize) -> bool {
        let m = self.margin;
        c > 2 * m && c + 2 * m + 2 <= n
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

    /// Adds the shares of `samples` (each its pixel, its position in it from the corner, in
    /// `[0, 1)²`, and its value) to the sums `wide` of the pixels of `sums`' window
    /// (row-major, three channels); pixels outside the window get nothing.
    ///
    /// In fixed point as integers, not through [`crate::film::to_fixed`] per share: the value
    /// rounded to units of 2⁻²⁰ (clamped at ±2³⁸) times the share's weight in units of 2⁻²⁸
    /// (the product of its weights along x and y, each rounded to 2⁻¹⁴) is the share in the
    /// film's units of 2⁻⁴⁸, one integer product per channel. Both factors
    /// are functions of the sample alone, so the sums stay exact in any order. Values below 32
    /// with weights below 4 (nearly all samples) give shares below 2⁵⁵, which `sums` adds up
    /// in 64 bits, a row of four or eight pixels at a time (the compiler vectorises it, with
    /// the widest instructions the CPU has: integer arithmetic gives the same bits at every
    /// width), and moves to `wide` every [`FLUSH_EVERY`] samples; other samples go to `wide`
    /// directly, in 128 bits.
    pub fn add<I: Iterator<Item = ((usize, usize), [f32; 2], Rgb)>>(
        &self,
        sums: &mut SplatSums,
        wide: &mut [[i128; 3]],
        samples: I,
    ) {
        crate::simd::run_auto_at(
            crate::simd::SimdLevel::detected(),
            AddKernel {
                splat: self,
                sums,
                wide,
                samples,
            },
        );
    }

    /// [`Splat::add`] for one sample.
    #[inline(always)]
    fn add_one(
        &self,
        sums: &mut SplatSums,
        wide: &mut [[i128; 3]],
        (x, y): (usize, usize),
        offset: [f32; 2],
        l: Rgb,
    ) {
        const MAX: f32 = (1u64 << 38) as f32;
        let rect = sums.rect;
        // The pixels reached (columns x0.., rows y0..) and their weights along each axis:
        // from the table away from the image's edges, else from the filter.
        let (mut wx, mut wy) = ([0i32; 8], [0i32; 8]);
        let (x0, y0, nx, ny);
        if self.step_taps != 0
            && self.interior(x, self.inv_x.len())
            && self.interior(y, self.inv_y.len())
        {
            let step = |o: f32| &self.steps[(round(o * STEPS as f32) as usize).min(STEPS)];
            let ((fx, tx), (fy, ty)) = (step(offset[0]), step(offset[1]));
            (wx, wy) = (*tx, *ty);
            (x0, y0) = (x.wrapping_add_signed(*fx), y.wrapping_add_signed(*fy));
            (nx, ny) = (self.step_taps, self.step_taps);
        } else {
            // The pixels q with |q + 0.5 − s| < r (one more at worst, of weight 0), at most
            // `margin` from the sample's own, within `rect`.
            let r = self.radius;
            let (sx, sy) = (x as f32 + offset[0], y as f32 + offset[1]);
            let m = self.margin;
            let span = |c: usize, s: f32, lo: usize, hi: usize| {
                let t = s - 0.5 - r;
                let a = if t > 0.0 { floor(t) + 1 } else { 0 };
                let b = floor(s - 0.5 + r) + 1;
                let a = a.max(c.saturating_sub(m)).max(lo);
                (a, b.min(c + m + 1).min(hi).max(a))
            };
            let (xa, xb) = span(x, sx, rect.x0, rect.x1);
            let (ya, yb) = span(y, sy, rect.y0, rect.y1);
            let weight_x = |p: usize| axis_weight(self.g(p as f32 + 0.5 - sx) * self.inv_x[p]);
            let weight_y = |q: usize| axis_weight(self.g(q as f32 + 0.5 - sy) * self.inv_y[q]);
            if xb - xa > 8 || yb - ya > 8 {
                // Filters reaching more than eight pixels per axis: cell by cell, in 128 bits.
                let lf = [l.r, l.g, l.b].map(|v| (v.clamp(-MAX, MAX) * UNIT).round() as i128);
                for q in ya..yb {
                    let row = (q - rect.y0) * rect.width() - rect.x0;
                    let wq = weight_y(q) as i128;
                    for p in xa..xb {
                        let w = weight_x(p) as i128 * wq;
                        for (sum, &v) in wide[row + p].iter_mut().zip(&lf) {
                            *sum += v * w;
                        }
                    }
                }
                return;
            }
            for (k, w) in wx.iter_mut().enumerate().take(xb - xa) {
                *w = weight_x(xa + k);
            }
            for (k, w) in wy.iter_mut().enumerate().take(yb - ya) {
                *w = weight_y(ya + k);
            }
            (x0, y0, nx, ny) = (xa, ya, xb - xa, yb - ya);
        }
        let fixed = |v: f32| (v.clamp(-MAX, MAX) * UNIT).round() as i64;
        let lf = [fixed(l.r), fixed(l.g), fixed(l.b)];
        let (x0, y0) = (x0 - rect.x0, y0 - rect.y0);
        if self.small_weights && lf.iter().all(|v| v.unsigned_abs() < 1 << 25) {
            let lf = lf.map(|v| v as i32);
            if nx <= 4 {
                sums.add_rows::<4>((x0, y0), (&wx, &wy[..ny]), lf);
            } else {
                sums.add_rows::<8>((x0, y0), (&wx, &wy[..ny]), lf);
            }
        } else {
            // Large values: 128-bit sums.
            for (j, &wq) in wy[..ny].iter().enumerate() {
                let row = (y0 + j) * rect.width() + x0;
                for (k, &wp) in wx[..nx].iter().enumerate() {
                    let w = wp as i128 * wq as i128;
                    for (sum, &v) in wide[row + k].iter_mut().zip(&lf) {
                        *sum += v as i128 * w;
                    }
                }
            }
        }
    }
}

/// The 64-bit splat sums of a window (see [`Splat::add`]): one plane per channel, each row
/// padded by eight columns; and the samples added since they were last moved to the 128-bit
/// sums.
#[derive(Clone, Debug, Default)]
pub struct SplatSums {
    rect: Window,
    stride: usize,
    quick: Vec<i64>,
    pending: u32,
}

impl SplatSums {
    /// Empty sums for the pixels of `rect` (reusing the memory of earlier windows).
    pub fn reset(&mut self, rect: Window) {
        self.rect = rect;
        self.stride = rect.width() + 8;
        self.quick.clear();
        self.quick.resize(3 * self.plane(), 0);
        self.pending = 0;
    }

    /// Adds the shares of a sample of value `lf` (fixed point) with weights `wx` along x
    /// (columns `x0..`, 0 past the last pixel reached) and `wy` along y (rows `y0..`) to the
    /// 64-bit sums, `N` columns at a time (the rows' padding takes those past the window).
    #[inline(always)]
    fn add_rows<const N: usize>(
        &mut self,
        (x0, y0): (usize, usize),
        (wx, wy): (&[i32; 8], &[i32]),
        lf: [i32; 3],
    ) {
        let plane = self.plane();
        for (j, &wq) in wy.iter().enumerate() {
            let mut w = [0i32; N];
            for k in 0..N {
                w[k] = wx[k] * wq;
            }
            let at = (y0 + j) * self.stride + x0;
            for (c, &v) in lf.iter().enumerate() {
                let cells: &mut [i64; N] = (&mut self.quick[c * plane + at..c * plane + at + N])
                    .try_into()
                    .expect("rows are padded by eight columns");
                for k in 0..N {
                    cells[k] += v as i64 * w[k] as i64;
                }
            }
        }
    }

    /// Values per channel plane.
    fn plane(&self) -> usize {
        self.rect.height() * self.stride
    }

    /// Moves the 64-bit sums into `wide` (the 128-bit sums of the window's pixels, row-major)
    /// and clears them.
    pub fn flush(&mut self, wide: &mut [[i128; 3]]) {
        let (width, plane) = (self.rect.width(), self.plane());
        for (r, row) in wide.chunks_exact_mut(width).enumerate() {
            for (k, sum) in row.iter_mut().enumerate() {
                for (c, s) in sum.iter_mut().enumerate() {
                    let q = &mut self.quick[c * plane + r * self.stride + k];
                    *s += *q as i128;
                    *q = 0;
                }
            }
        }
        self.pending = 0;
    }
}

/// [`Splat::add`] as a kernel.
struct AddKernel<'a, I> {
    splat: &'a Splat,
    sums: &'a mut SplatSums,
    wide: &'a mut [[i128; 3]],
    samples: I,
}

impl<I: Iterator<Item = ((usize, usize), [f32; 2], Rgb)>> crate::simd::Kernel for AddKernel<'_, I> {
    type Output = ();

    #[inline(always)]
    fn run<S: crate::simd::Isa>(self, _: S) {
        let AddKernel {
            splat,
            sums,
            wide,
            samples,
        } = self;
        for (pixel, offset, l) in samples {
            splat.add_one(sums, wide, pixel, offset, l);
            sums.pending += 1;
            if sums.pending == FLUSH_EVERY {
                sums.flush(wide);
            }
        }
    }
}

/// Fixed point of values: units of 2⁻²⁰.
const UNIT: f32 = (1u32 << 20) as f32;

/// Units of the weights along one axis: 2⁻¹⁴ (a share's weight, the product of two, in units
/// of 2⁻²⁸, is below 2³⁰ when each is below 2).
pub const AXIS_UNIT: f32 = (1u32 << 14) as f32;

/// `x` rounded to the nearest integer (ties to even), for |x| < 2²²: read from the bits of
/// `x + 1.5·2²³`, where floats are the integers, without the branches of a saturating
/// conversion.
#[inline(always)]
fn round(x: f32) -> i32 {
    ((x + 12_582_912.0).to_bits() & 0x7f_ffff) as i32 - (1 << 22)
}

/// A sample's weight along one axis in units of 2⁻¹⁴ (|w| < 256), rounded to the nearest
/// integer. (The rounding errors, a function of the sample's position, average out over it;
/// with samples at the pixel centres, each weight is off by 2⁻¹⁵ at most.)
#[inline(always)]
fn axis_weight(w: f32) -> i32 {
    round(w * AXIS_UNIT)
}

/// ⌊x⌋ for 0 ≤ x < 2²¹, or ⌊x⌋ − 1 when x is an integer (x − ½ rounded). Either serves
/// [`Splat::g`]'s interpolation (the fraction is then 1: the next knot's value) and the spans
/// of [`Splat::add`] (a pixel more, of weight 0).
#[inline(always)]
fn floor(x: f32) -> usize {
    round(x - 0.5) as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::from_fixed;

    /// Splats `samples` over a `rect` window: the 128-bit sums.
    fn splat_all(
        s: &Splat,
        rect: Window,
        samples: &[((usize, usize), [f32; 2], Rgb)],
    ) -> Vec<[i128; 3]> {
        let mut sums = SplatSums::default();
        sums.reset(rect);
        let mut wide = vec![[0i128; 3]; rect.pixels()];
        s.add(&mut sums, &mut wide, samples.iter().copied());
        sums.flush(&mut wide);
        wide
    }

    /// A constant image comes out constant, borders included: the expected weight of every
    /// pixel is 1 (uniform samples), exactly 1 with samples at the centres (up to the
    /// rounding of the weights). On a small image, where every sample is near an edge, and a
    /// larger one, whose middle samples read their weights from the table.
    #[test]
    fn a_constant_image_stays_constant_to_its_borders() {
        for (w, h) in [(9, 7), (31, 26)] {
            constant_image(w, h);
        }
    }

    fn constant_image(w: usize, h: usize) {
        let rect = Window::full(w, h);
        let one = Rgb::new(1.0, 1.0, 1.0);
        for name in crate::filter::FILTER_NAMES {
            let filter = Filter::by_name(name).unwrap();
            let Some(s) = Splat::new(filter, w, h, 1) else {
                assert_eq!(name, "box");
                continue;
            };
            let centres: Vec<_> = rect.points().map(|p| (p, [0.5, 0.5], one)).collect();
            // Each weight along an axis is rounded to 2⁻¹⁴: the sums of the 2m + 1 weights
            // along each axis may be off by (2m + 1)·2⁻¹⁵ each.
            let taps = (2 * s.margin() + 1) as f64;
            let bound = 2.0 * taps * 2f64.powi(-15) * 1.01;
            for v in splat_all(&s, rect, &centres) {
                let v = from_fixed(v[0]);
                assert!((v - 1.0).abs() < bound, "{name}: {v}");
            }
            // Uniform samples: 1 in expectation. A 32 × 32 grid of midpoints in every pixel
            // (the midpoint rule converges to the integral the normaliser holds), more
            // samples than a flush takes.
            let s = Splat::new(filter, w, h, 64).unwrap();
            let k = if w > 16 { 16 } else { 32 };
            let grid: Vec<_> = rect
                .points()
                .flat_map(|p| {
                    (0..k * k).map(move |i| {
                        let o = [(i % k) as f32 + 0.5, (i / k) as f32 + 0.5];
                        (p, o.map(|v| v / k as f32), one)
                    })
                })
                .collect();
            for (i, v) in splat_all(&s, rect, &grid).iter().enumerate() {
                let mean = from_fixed(v[0]) / (k * k) as f64;
                assert!((mean - 1.0).abs() < 2e-3, "{name}: pixel {i}: {mean}");
            }
        }
    }

    /// The table and the filter agree, and a sample reaches exactly the pixels within the
    /// radius of its position, with the same shares whatever way they are summed (64 or 128
    /// bits, four or eight columns at a time).
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
        let at = |l: f32| splat_all(&s, rect, &[((30, 30), [0.1, 0.9], Rgb::new(l, 0.0, 0.0))]);
        let (small, large) = (at(1.0), at(128.0));
        // Five columns (an integer edge, whose extra pixel has weight 0): eight at a time.
        let edge = splat_all(&s, rect, &[((30, 30), [0.5, 0.5], Rgb::new(1.0, 0.0, 0.0))]);
        let large_edge = splat_all(
            &s,
            rect,
            &[((30, 30), [0.5, 0.5], Rgb::new(128.0, 0.0, 0.0))],
        );
        for (x, y) in rect.points() {
            let i = y * 64 + x;
            assert_eq!(large[i][0], 128 * small[i][0], "({x}, {y})");
            assert_eq!(large_edge[i][0], 128 * edge[i][0], "({x}, {y})");
            let (dx, dy) = (x as f32 + 0.5 - 30.1, y as f32 + 0.5 - 30.9);
            let reached = dx.abs() < 2.0 && dy.abs() < 2.0;
            assert_eq!(small[i][0] != 0, reached, "({x}, {y})");
        }
    }
}
