//! Pixel reconstruction filters, and their filter importance sampling (pbrt-v4, §8.8).
//!
//! Every filter is separable, `f(x, y) = g(x) g(y)`, with `g` one of Mitsuba 3's 1D filters
//! (same names, parameters and defaults). Renders splat their samples with it
//! ([`crate::splat`]), except those with output variables, which sample it instead: a pixel's
//! sample position is drawn from the filter's distribution around the pixel centre instead of
//! uniformly over the pixel, and the sample keeps a weight: 1 for non-negative filters,
//! `sign · ∫|g| / ∫g` per axis for filters with negative lobes (Mitchell, Catmull-Rom,
//! Lanczos). Each sample then belongs to exactly one pixel, whose noise is its own (what a
//! denoiser expects), at about π times the variance of splatting for the default Gaussian. The
//! expected value of a pixel is the normalised filter's convolution of the image either way,
//! which is also what Mitsuba's splatting film converges to.
//!
//! The box is the identity on the sampler's pixel sample (one sample per pixel still goes through
//! the pixel centre); the tent is inverted in closed form; the others are tabulated as a
//! piecewise-constant function with [`BINS`] bins over `[-r, r]`, each bin holding the exact mean
//! of `g` over it, and that tabulated filter is sampled exactly (as pbrt-v4's `FilterSampler`
//! does).

/// Bins of the tabulated filters over `[-radius, radius]`.
pub const BINS: usize = 256;

/// A reconstruction filter, with Mitsuba 3's parameters.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Filter {
    /// The pixel's square (radius 0.5): the course's behaviour.
    #[default]
    Box,
    /// `max(0, 1 - |x|/radius)`; Mitsuba's default radius is 1.
    Tent {
        /// Radius in pixels.
        radius: f32,
    },
    /// `max(0, exp(-x²/2σ²) - exp(-r²/2σ²))` with radius `r = 4σ`; Mitsuba's default σ is 0.5.
    Gaussian {
        /// Standard deviation σ in pixels.
        stddev: f32,
    },
    /// Mitchell–Netravali cubic (radius 2); Mitsuba's default B = C = 1/3, Catmull-Rom is B = 0,
    /// C = 1/2.
    Mitchell {
        /// The B parameter.
        b: f32,
        /// The C parameter.
        c: f32,
    },
    /// Lanczos-windowed sinc with radius `lobes`; Mitsuba's default is 3 lobes.
    Lanczos {
        /// Number of lobes (the radius in pixels).
        lobes: u32,
    },
}

// Filters are compared by their parameters, which are never NaN (see `Filter::is_valid`).
impl Eq for Filter {}

/// The filter names accepted by [`Filter::by_name`].
pub const FILTER_NAMES: [&str; 6] = [
    "box",
    "tent",
    "gaussian",
    "mitchell",
    "catmullrom",
    "lanczos",
];

impl Filter {
    /// The filter called `name` (Mitsuba's plugin names) with Mitsuba's default parameters.
    pub fn by_name(name: &str) -> Option<Filter> {
        Some(match name {
            "box" => Filter::Box,
            "tent" => Filter::Tent { radius: 1.0 },
            "gaussian" => Filter::Gaussian { stddev: 0.5 },
            "mitchell" => Filter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            "catmullrom" => Filter::Mitchell { b: 0.0, c: 0.5 },
            "lanczos" => Filter::Lanczos { lobes: 3 },
            _ => return None,
        })
    }

    /// A short description, e.g. `gaussian (stddev 0.5)`.
    pub fn describe(&self) -> String {
        match *self {
            Filter::Box => "box".into(),
            Filter::Tent { radius } => format!("tent (radius {radius})"),
            Filter::Gaussian { stddev } => format!("gaussian (stddev {stddev})"),
            Filter::Mitchell { b, c } => format!("mitchell (B {b}, C {c})"),
            Filter::Lanczos { lobes } => format!("lanczos ({lobes} lobes)"),
        }
    }

    /// True when the parameters are usable: finite positive radius and σ (at most 64 pixels),
    /// finite B and C, 1 to 64 lobes, and a filter whose integral is positive.
    pub fn is_valid(&self) -> bool {
        let ok = match *self {
            Filter::Box => true,
            Filter::Tent { radius } => radius.is_finite() && radius > 1e-3 && radius <= 64.0,
            Filter::Gaussian { stddev } => stddev.is_finite() && stddev > 1e-3 && stddev <= 16.0,
            Filter::Mitchell { b, c } => b.is_finite() && c.is_finite(),
            Filter::Lanczos { lobes } => (1..=64).contains(&lobes),
        };
        ok && FilterSampler::new(*self).integral > 0.0
    }

    /// The radius of the filter's support in pixels (per axis).
    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box => 0.5,
            Filter::Tent { radius } => radius,
            Filter::Gaussian { stddev } => 4.0 * stddev,
            Filter::Mitchell { .. } => 2.0,
            Filter::Lanczos { lobes } => lobes as f32,
        }
    }

    /// The 1D filter `g(x)`, unnormalised (zero outside the radius).
    pub fn eval_1d(&self, x: f64) -> f64 {
        let x = x.abs();
        let r = self.radius() as f64;
        if x > r {
            return 0.0;
        }
        match *self {
            Filter::Box => 1.0,
            Filter::Tent { radius } => (1.0 - x / radius as f64).max(0.0),
            Filter::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * (stddev as f64).powi(2));
                ((alpha * x * x).exp() - (alpha * r * r).exp()).max(0.0)
            }
            Filter::Mitchell { b, c } => {
                let (b, c) = (b as f64, c as f64);
                let (x2, x3) = (x * x, x * x * x);
                let v = if x < 1.0 {
                    (12.0 - 9.0 * b - 6.0 * c) * x3
                        + (-18.0 + 12.0 * b + 6.0 * c) * x2
                        + (6.0 - 2.0 * b)
                } else {
                    (-b - 6.0 * c) * x3
                        + (6.0 * b + 30.0 * c) * x2
                        + (-12.0 * b - 48.0 * c) * x
                        + (8.0 * b + 24.0 * c)
                };
                v / 6.0
            }
            Filter::Lanczos { .. } => {
                if x < 1e-6 {
                    return 1.0;
                }
                let x1 = std::f64::consts::PI * x;
                let x2 = x1 / r;
                (x1.sin() * x2.sin()) / (x1 * x2)
            }
        }
    }

    /// The 2D filter `g(x) g(y)`, unnormalised.
    pub fn eval(&self, x: f64, y: f64) -> f64 {
        self.eval_1d(x) * self.eval_1d(y)
    }
}

/// Draws pixel sample positions from a [`Filter`]; built once per render (no allocation).
#[derive(Clone, Debug)]
pub struct FilterSampler {
    filter: Filter,
    radius: f32,
    /// CDF of |g| over the bins (tabulated filters only), `cdf[0] = 0`, `cdf[BINS] = 1`.
    cdf: [f32; BINS + 1],
    /// Per bin: `sign(bin mean) · ∫|g_tab| / ∫g_tab`, the sample weight along one axis.
    weight: [f32; BINS],
    /// `∫ g_tab` over `[-r, r]` (the exact integral of `g` for box and tent).
    integral: f64,
}

impl FilterSampler {
    /// Tabulates `filter` if it needs a table.
    pub fn new(filter: Filter) -> Self {
        let radius = filter.radius();
        let mut s = Self {
            filter,
            radius,
            cdf: [0.0; BINS + 1],
            weight: [1.0; BINS],
            integral: 2.0 * radius as f64,
        };
        match filter {
            Filter::Box => s.integral = 1.0,
            Filter::Tent { radius } => s.integral = radius as f64,
            _ => s.tabulate(),
        }
        s
    }

    /// The filter being sampled.
    pub fn filter(&self) -> Filter {
        self.filter
    }

    /// The bin means of `g` (exact to rounding: composite Simpson on 16 sub-intervals of each
    /// bin, which integrates the piecewise cubics exactly), then the CDF of their magnitudes.
    fn tabulate(&mut self) {
        let r = self.radius as f64;
        let h = 2.0 * r / BINS as f64;
        let mut means = [0f64; BINS];
        for (i, m) in means.iter_mut().enumerate() {
            let a = -r + i as f64 * h;
            const SUB: usize = 16;
            let dh = h / SUB as f64;
            let mut acc = 0.0;
            for k in 0..SUB {
                let x0 = a + k as f64 * dh;
                acc += (self.filter.eval_1d(x0)
                    + 4.0 * self.filter.eval_1d(x0 + 0.5 * dh)
                    + self.filter.eval_1d(x0 + dh))
                    * dh
                    / 6.0;
            }
            *m = acc / h;
        }
        let abs_total: f64 = means.iter().map(|m| m.abs()).sum::<f64>() * h;
        let total: f64 = means.iter().sum::<f64>() * h;
        self.integral = total;
        if !(abs_total > 0.0 && total > 0.0) {
            // Unusable parameters (rejected by `Filter::is_valid`): fall back to uniform.
            for (i, c) in self.cdf.iter_mut().enumerate() {
                *c = i as f32 / BINS as f32;
            }
            return;
        }
        let ratio = abs_total / total;
        let mut acc = 0.0;
        for i in 0..BINS {
            acc += means[i].abs() * h;
            self.cdf[i + 1] = (acc / abs_total) as f32;
            self.weight[i] = if means[i] < 0.0 { -ratio } else { ratio } as f32;
        }
        self.cdf[BINS] = 1.0;
    }

    /// The integral of the (tabulated) 1D filter over its support.
    pub fn integral_1d(&self) -> f64 {
        self.integral
    }

    /// The normalised density of the sampled 1D offset over `[a, b]` (for tests): the integral
    /// of `|g_tab| / ∫|g_tab|` over `[a, b]`.
    pub fn probability_1d(&self, a: f64, b: f64) -> f64 {
        let r = self.radius as f64;
        match self.filter {
            Filter::Box => (b.min(0.5) - a.max(-0.5)).max(0.0),
            Filter::Tent { .. } => {
                // CDF of the normalised tent.
                let cdf = |x: f64| {
                    let t = (x / r).clamp(-1.0, 1.0);
                    if t < 0.0 {
                        0.5 * (1.0 + t) * (1.0 + t)
                    } else {
                        1.0 - 0.5 * (1.0 - t) * (1.0 - t)
                    }
                };
                cdf(b) - cdf(a)
            }
            _ => {
                let cdf = |x: f64| {
                    let t = ((x + r) / (2.0 * r) * BINS as f64).clamp(0.0, BINS as f64);
                    let i = (t as usize).min(BINS - 1);
                    let c0 = self.cdf[i] as f64;
                    c0 + (self.cdf[i + 1] as f64 - c0) * (t - i as f64)
                };
                cdf(b) - cdf(a)
            }
        }
    }

    /// Maps one coordinate `u ∈ [0, 1)` of the sampler's pixel sample to an offset from the pixel
    /// centre, with its weight.
    #[inline]
    fn sample_1d(&self, u: f32) -> (f32, f32) {
        match self.filter {
            Filter::Box => (u - 0.5, 1.0),
            Filter::Tent { .. } => {
                let r = self.radius;
                let x = if u < 0.5 {
                    -r + r * (2.0 * u).sqrt()
                } else {
                    r - r * (2.0 - 2.0 * u).sqrt()
                };
                (x, 1.0)
            }
            _ => {
                // The bin holding u (binary search on the CDF), then uniform within it.
                let (mut lo, mut hi) = (0usize, BINS);
                while hi - lo > 1 {
                    let mid = (lo + hi) / 2;
                    if self.cdf[mid] <= u {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let (c0, c1) = (self.cdf[lo], self.cdf[lo + 1]);
                let t = if c1 > c0 {
                    ((u - c0) / (c1 - c0)).clamp(0.0, 1.0)
                } else {
                    0.5
                };
                let h = 2.0 * self.radius / BINS as f32;
                let x = -self.radius + (lo as f32 + t) * h;
                (x.clamp(-self.radius, self.radius), self.weight[lo])
            }
        }
    }

    /// Maps the sampler's pixel sample `[sx, sy] ∈ [0, 1)²` to a position relative to the
    /// pixel's corner (the centre is `(0.5, 0.5)`) and the sample's weight. The box returns the
    /// sample unchanged with weight 1.
    #[inline]
    pub fn sample(&self, [sx, sy]: [f32; 2]) -> ([f32; 2], f32) {
        if self.filter == Filter::Box {
            return ([sx, sy], 1.0);
        }
        let (dx, wx) = self.sample_1d(sx);
        let (dy, wy) = self.sample_1d(sy);
        ([0.5 + dx, 0.5 + dy], wx * wy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_box_keeps_the_pixel_sample_and_the_centre_maps_to_the_centre() {
        let b = FilterSampler::new(Filter::Box);
        assert_eq!(b.sample([0.25, 0.75]), ([0.25, 0.75], 1.0));
        for name in FILTER_NAMES {
            let f = FilterSampler::new(Filter::by_name(name).unwrap());
            let ([x, y], w) = f.sample([0.5, 0.5]);
            assert!(
                (x - 0.5).abs() < 1e-5 && (y - 0.5).abs() < 1e-5,
                "{name}: {x} {y}"
            );
            assert!(w > 0.0, "{name}");
        }
    }

    #[test]
    fn integrals_match_closed_forms() {
        // Tent: r; Mitchell (any B, C): 1; Gaussian: σ√(2π) erf(2√2) − 2r e^{-8}.
        assert_eq!(
            FilterSampler::new(Filter::by_name("tent").unwrap()).integral_1d(),
            1.0
        );
        for name in ["mitchell", "catmullrom"] {
            let i = FilterSampler::new(Filter::by_name(name).unwrap()).integral_1d();
            assert!((i - 1.0).abs() < 1e-9, "{name}: {i}");
        }
        let g = FilterSampler::new(Filter::Gaussian { stddev: 0.5 }).integral_1d();
        // erf(2√2) = 0.999936657516334...
        let expected = 0.5 * (2.0 * std::f64::consts::PI).sqrt() * 0.999_936_657_516_334
            - 2.0 * 2.0 * (-8.0f64).exp();
        assert!((g - expected).abs() < 1e-9, "{g} vs {expected}");
    }

    #[test]
    fn negative_lobes_get_negative_weights() {
        let f = FilterSampler::new(Filter::by_name("lanczos").unwrap());
        // x ≈ 1.5 (first negative lobe of sinc): u = CDF there.
        let (x, w) = f.sample_1d(f.probability_1d(-3.0, 1.5) as f32);
        assert!((x - 1.5).abs() < 0.05, "{x}");
        assert!(w < 0.0);
        let (_, w0) = f.sample_1d(0.5);
        assert_eq!(w0, -w);
        assert!(w0 > 1.0);
    }

    #[test]
    fn validity() {
        assert!(Filter::Gaussian { stddev: 0.5 }.is_valid());
        assert!(!Filter::Gaussian { stddev: f32::NAN }.is_valid());
        assert!(!Filter::Tent { radius: -1.0 }.is_valid());
        assert!(!Filter::Lanczos { lobes: 0 }.is_valid());
        // A Mitchell with a non-positive integral cannot be normalised… but B, C never change
        // its integral (1), so any finite B and C are valid.
        assert!(Filter::Mitchell { b: 5.0, c: -3.0 }.is_valid());
    }
}
