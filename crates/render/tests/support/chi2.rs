//! A χ² goodness-of-fit test of a direction sampler against its density, in the spirit of
//! Mitsuba's `ChiSquareTest` and pbrt-v4's `bsdfs_test`, shared by the statistical tests of the
//! render core (BSDFs, lights).
//!
//! Directions are binned on a spherical grid around an axis: rows in s ∈ [0, 1] with
//! cos θ = 1 − 2 s^p (p = 1: equal-area rows; p = 2: s = sin(θ/2), rows nearly uniform in θ,
//! which resolves narrow lobes around the axis), columns uniform in φ. The expected count of a
//! cell is N times the integral of the density over it, by adaptive Gauss–Legendre cubature
//! (cells are split until the 4 × 4 and 3 × 3 rules agree within a small fraction of one
//! standard deviation of their count, and at least three times where they may straddle a step
//! of the density; cells whose counts are far from expectation are integrated again 16 × 16
//! times finer before judging). Cells expecting fewer than 5 samples are pooled (in ascending
//! order of expectation, Mitsuba's procedure), the statistic is compared with the χ²
//! distribution of (cells − 1) degrees of freedom (p-value by the regularised incomplete gamma
//! function) and the hypothesis is rejected below the significance level 1 − (1 − α)^(1/m)
//! (Šidák's correction for m tests at overall level α).
//!
//! Samples may return no direction (`None`): a microfacet sample below the horizon, the delta
//! part of a BSDF that the caller excludes, an emitter's hidden side. The fraction of samples
//! that return a direction must equal ∫ pdf dω (5 binomial standard deviations + 1e-3 for the
//! cubature), and the mass the caller intends when it states one (e.g. exactly 1). The density
//! reported with the samples (every 4th) must equal the density function (relative 1e-3, or
//! within what f32 rounding of the direction changes at ill-conditioned points; at most 2e-4 of
//! them may disagree, at numerically ambiguous points), and no density may be negative or NaN.
#![allow(dead_code)]

use candela_render::math::{Frame, Vec3};
use candela_render::sampling::Pcg32;

/// The overall significance level of a suite.
pub const ALPHA: f64 = 0.01;

/// The per-test significance level of `tests` tests at overall level `alpha` (Šidák).
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests.max(1) as f64)
}

/// A spherical grid around an axis.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    /// The polar axis (unit).
    pub axis: Vec3,
    /// cos θ = 1 − 2 s^power.
    pub power: f64,
    /// Rows in s.
    pub rows: usize,
    /// Columns in φ.
    pub cols: usize,
}

impl Grid {
    /// A grid of `rows × 2·rows` cells around `axis`.
    pub fn new(axis: Vec3, power: f64, rows: usize) -> Self {
        Self {
            axis: axis.normalize(),
            power,
            rows,
            cols: 2 * rows,
        }
    }

    fn frame(&self) -> Frame {
        Frame::from_normal(self.axis.to_normal())
    }

    fn cell(&self, frame: &Frame, d: Vec3) -> usize {
        let l = frame.to_local(d);
        let (x, y, z) = (l.x as f64, l.y as f64, l.z as f64);
        let n = (x * x + y * y + z * z).sqrt();
        let c = (z / n).clamp(-1.0, 1.0);
        let s = ((1.0 - c) * 0.5).max(0.0).powf(1.0 / self.power);
        let mut phi = y.atan2(x);
        if phi < 0.0 {
            phi += 2.0 * std::f64::consts::PI;
        }
        let row = ((s * self.rows as f64) as usize).min(self.rows - 1);
        let col =
            ((phi / (2.0 * std::f64::consts::PI) * self.cols as f64) as usize).min(self.cols - 1);
        row * self.cols + col
    }
}

/// Whether a value computed by another route (`reported`, e.g. the density a sampler returns
/// with direction `d`) equals `f(d)` within the relative tolerance `rel`, or within what the f32
/// rounding of the direction can change `f` at `d`: the spread of `f` over perturbations of `d`
/// by 2e-6 (~30 ulp). Only ill-conditioned points profit from the second clause: near a
/// critical angle (the Fresnel term has an infinite slope), for a half vector of nearly opposite
/// directions, at the edge of the support.
pub fn agrees_up_to_rounding(reported: f32, d: Vec3, rel: f32, f: impl Fn(Vec3) -> f32) -> bool {
    let q = f(d);
    if (reported - q).abs() <= rel * reported.abs().max(q.abs()) {
        return true;
    }
    let spread = rounding_spread(d, &f);
    (reported - q).abs() <= rel * reported.abs().max(q.abs()) + 2.0 * spread
}

/// The largest change of `f` over perturbations of the unit direction `d` by 2e-6.
pub fn rounding_spread(d: Vec3, f: impl Fn(Vec3) -> f32) -> f32 {
    let q = f(d);
    let e = 2e-6;
    [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z]
        .iter()
        .map(|&a| (f((d + a * e).normalize()) - q).abs())
        .fold(0.0, f32::max)
}

/// What a χ² run found.
#[derive(Clone, Debug)]
pub struct Report {
    /// The statistic.
    pub chi2: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// P(χ² ≥ statistic).
    pub p_value: f64,
    /// The per-test significance level.
    pub level: f64,
    /// Fraction of samples that returned a direction.
    pub sampled_mass: f64,
    /// ∫ pdf dω over the sphere.
    pub pdf_integral: f64,
}

/// One χ² test.
pub struct Chi2<'a> {
    /// What is tested (model, parameters, incident direction), for the failure message.
    pub name: &'a str,
    /// The binning.
    pub grid: Grid,
    /// Number of samples.
    pub samples: usize,
    /// Seed of the uniform numbers.
    pub seed: u64,
    /// The mass the density must have (fraction of samples returning a direction), when the
    /// sampler is meant to return a direction with a known probability (e.g. 1).
    pub expected_mass: Option<f64>,
    /// The per-test significance level (see [`sidak`]).
    pub level: f64,
}

/// 4- and 3-point Gauss–Legendre nodes and weights on [-1, 1].
const GL_X: [f64; 4] = [
    -0.861_136_311_594_052_6,
    -0.339_981_043_584_856_3,
    0.339_981_043_584_856_3,
    0.861_136_311_594_052_6,
];
const GL3_X: [f64; 3] = [-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4];
const GL3_W: [f64; 3] = [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0];
const GL_W: [f64; 4] = [
    0.347_854_845_137_453_8,
    0.652_145_154_862_546_1,
    0.652_145_154_862_546_1,
    0.347_854_845_137_453_8,
];

impl Chi2<'_> {
    /// Runs the test: `sample(u)` maps three uniform numbers to a direction and the density the
    /// sampler reports for it (or `None`), `pdf(d)` is the density per unit solid angle.
    pub fn run(
        &self,
        sample: impl Fn([f32; 3]) -> Option<(Vec3, f32)>,
        pdf: impl Fn(Vec3) -> f32,
    ) -> Result<Report, String> {
        let g = self.grid;
        let frame = g.frame();
        let cells = g.rows * g.cols;
        let n = self.samples;
        let fail = |what: String| Err(format!("χ² test of {}: {what}", self.name));

        // Observed counts; the sampler's own pdf must agree with the density function.
        let mut observed = vec![0f64; cells + 1];
        let mut rng = Pcg32::new(self.seed, 0x5eed);
        let mut pdf_mismatch: Option<(Vec3, f32, f32)> = None;
        let mut mismatches = 0usize;
        let mut checked = 0usize;
        for i in 0..n {
            let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
            match sample(u) {
                Some((d, p)) => {
                    let valid = d.is_finite() && p.is_finite() && p > 0.0;
                    if !valid || (d.norm() - 1.0).abs() > 1e-3 {
                        return fail(format!(
                            "sample({u:?}) returned the direction {d:?} with density {p}"
                        ));
                    }
                    // The reported density is checked on every 4th sample (the others only
                    // cost time).
                    if i % 4 == 0 {
                        checked += 1;
                        if !agrees_up_to_rounding(p, d, 1e-3, &pdf) {
                            mismatches += 1;
                            if pdf_mismatch.is_none() {
                                pdf_mismatch = Some((d, p, pdf(d)));
                            }
                        }
                    }
                    observed[g.cell(&frame, d)] += 1.0;
                }
                None => observed[cells] += 1.0,
            }
        }
        // Rare mismatches remain at numerically ambiguous points (a ray grazing a silhouette
        // misses the emitter, a direction on the edge of a texel maps back to its neighbour);
        // a wrong density disagrees on a large fraction.
        if mismatches as f64 > 2e-4 * checked as f64 + 1.0 {
            let (d, p, q) = pdf_mismatch.unwrap();
            return fail(format!(
                "{mismatches} of {checked} samples report a density different from pdf(); e.g. {d:?}: sample says {p}, pdf says {q}"
            ));
        }

        // Expected counts by adaptive cubature of the density over each cell.
        let two_pi = 2.0 * std::f64::consts::PI;
        let (ds, dphi) = (1.0 / g.rows as f64, two_pi / g.cols as f64);
        let mut bad_density: Option<(Vec3, f32)> = None;
        let integrand = |s: f64, phi: f64, bad: &mut Option<(Vec3, f32)>| -> f64 {
            let c = 1.0 - 2.0 * s.powf(g.power);
            let st = (1.0 - c * c).max(0.0).sqrt();
            let l = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, c as f32);
            let d = frame.to_world(l).normalize();
            let v = pdf(d);
            if !(v >= 0.0) || !v.is_finite() {
                if bad.is_none() {
                    *bad = Some((d, v));
                }
                return 0.0;
            }
            // dω = |d cos θ/ds| ds dφ.
            v as f64 * 2.0 * g.power * s.powf(g.power - 1.0)
        };
        // 4 × 4 and 3 × 3 Gauss–Legendre on a rectangle of (s, φ) (their difference estimates
        // the error), and whether it may straddle a step of the density (the edge of its
        // support, a jump by more than 8× such as a texel's edge).
        let gauss = |r: Rect, bad: &mut Option<(Vec3, f32)>| -> Quad {
            let Rect { s0, s1, p0, p1 } = r;
            let (hs, hp) = (0.5 * (s1 - s0), 0.5 * (p1 - p0));
            let (ms, mp) = (0.5 * (s1 + s0), 0.5 * (p1 + p0));
            let (mut g4, mut g3, mut lo, mut hi) = (0.0, 0.0, f64::INFINITY, 0f64);
            let mut node = |x: f64, y: f64, bad: &mut Option<(Vec3, f32)>| {
                let v = integrand(ms + hs * x, mp + hp * y, bad);
                lo = lo.min(v);
                hi = hi.max(v);
                v
            };
            for i in 0..4 {
                for j in 0..4 {
                    g4 += GL_W[i] * GL_W[j] * node(GL_X[i], GL_X[j], bad);
                }
            }
            for i in 0..3 {
                for j in 0..3 {
                    g3 += GL3_W[i] * GL3_W[j] * node(GL3_X[i], GL3_X[j], bad);
                }
            }
            Quad {
                g4: g4 * hs * hp,
                g3: g3 * hs * hp,
                step: hi > 0.0 && hi > 8.0 * lo,
            }
        };
        // The cubature of a rectangle of (s, φ), split into k × k parts refined adaptively.
        let cubature =
            |s0: f64, s1: f64, p0: f64, p1: f64, k: usize, bad: &mut Option<(Vec3, f32)>| -> f64 {
                let (hs, hp) = ((s1 - s0) / k as f64, (p1 - p0) / k as f64);
                let mut sum = 0.0;
                for i in 0..k {
                    for j in 0..k {
                        let (a, b) = (s0 + i as f64 * hs, s0 + (i + 1) as f64 * hs);
                        let (c, d) = (p0 + j as f64 * hp, p0 + (j + 1) as f64 * hp);
                        let rect = Rect {
                            s0: a,
                            s1: b,
                            p0: c,
                            p1: d,
                        };
                        let whole = gauss(rect, bad);
                        // Tolerance on the count: 5 % of its standard deviation, at least 1e-3
                        // samples.
                        let tol = (0.05 * (whole.g4.abs() * n as f64).sqrt()).max(1e-3) / n as f64;
                        sum += adaptive(&gauss, rect, whole, tol, 0, bad);
                    }
                }
                sum
            };
        let rect = |cell: usize| {
            let (row, col) = (cell / g.cols, cell % g.cols);
            let (s0, p0) = (row as f64 * ds, col as f64 * dphi);
            (s0, s0 + ds, p0, p0 + dphi)
        };
        let mut expected = vec![0f64; cells + 1];
        for (cell, e) in expected.iter_mut().enumerate().take(cells) {
            let (s0, s1, p0, p1) = rect(cell);
            *e = cubature(s0, s1, p0, p1, 1, &mut bad_density) * n as f64;
        }
        // Adaptive cubature can miss a thin feature (a lobe's sliver cut by the horizon at the
        // edge of a cell): integrate again, 16 × 16 times finer, the cells whose counts are far
        // from their expectation before judging. (The expectation is a property of the density
        // alone; computing it better cannot favour a wrong sampler.)
        let mut suspicious: Vec<usize> = (0..cells)
            .filter(|&c| (observed[c] - expected[c]).abs() > 3.0 * expected[c].sqrt() + 3.0)
            .collect();
        suspicious.sort_by(|&a, &b| {
            let dev = |c: usize| (observed[c] - expected[c]).abs() / (expected[c] + 1.0).sqrt();
            dev(b).total_cmp(&dev(a))
        });
        for &cell in suspicious.iter().take(256) {
            let (s0, s1, p0, p1) = rect(cell);
            expected[cell] = cubature(s0, s1, p0, p1, 16, &mut bad_density) * n as f64;
        }
        let total = expected[..cells].iter().sum::<f64>() / n as f64;
        if let Some((d, v)) = bad_density {
            return fail(format!("pdf({d:?}) = {v} (negative or not finite)"));
        }

        // The sampled mass and the density's integral must agree (the cubature is good to
        // ~1e-3 of the total: support edges cut across cells), and both must equal the
        // intended mass when there is one.
        let sampled_mass = 1.0 - observed[cells] / n as f64;
        let binomial = |m: f64| (m.clamp(0.0, 1.0) * (1.0 - m.clamp(0.0, 1.0)) / n as f64).sqrt();
        if (sampled_mass - total).abs() > 5.0 * binomial(total) + 1e-3 {
            return fail(format!(
                "the sampler returns a direction with probability {sampled_mass:.5} but the density integrates to {total:.5}"
            ));
        }
        if let Some(m) = self.expected_mass {
            if (total - m).abs() > 1e-3 {
                return fail(format!(
                    "the density integrates to {total:.5}, not to the intended mass {m}"
                ));
            }
            if (sampled_mass - m).abs() > 5.0 * binomial(m) + 1e-5 {
                return fail(format!(
                    "the sampler returns a direction with probability {sampled_mass:.6}, not with the intended {m}"
                ));
            }
        }

        // Pool the cells expecting < 5 samples, in ascending order of expectation.
        // (The "no direction" cell is left out: its expectation N·(1 − ∫pdf) inherits the
        // cubature's error on the whole sphere; it was judged above.)
        let mut order: Vec<usize> = (0..cells).collect();
        order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
        let (mut chi2, mut dof_cells) = (0.0, 0usize);
        let (mut pool_obs, mut pool_exp) = (0.0, 0.0);
        for &i in &order {
            let (o, e) = (observed[i], expected[i]);
            if e < 1e-9 * n as f64 {
                // Samples where the density is zero: tolerate a handful on edges (f32 round-off).
                if o > 1e-5 * n as f64 + 2.0 {
                    return fail(format!(
                        "{o} samples fell in cell {i} where the density integrates to {:.3e}",
                        e / n as f64
                    ));
                }
                pool_obs += o;
                continue;
            }
            if e < 5.0 || (pool_exp > 0.0 && pool_exp < 5.0) {
                pool_obs += o;
                pool_exp += e;
            } else {
                chi2 += (o - e) * (o - e) / e;
                dof_cells += 1;
            }
        }
        if pool_exp > 0.0 {
            chi2 += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
            dof_cells += 1;
        }
        let dof = dof_cells.saturating_sub(1).max(1);
        let p_value = chi2_survival(chi2, dof as f64);
        let report = Report {
            chi2,
            dof,
            p_value,
            level: self.level,
            sampled_mass,
            pdf_integral: total,
        };
        if !(p_value >= self.level) {
            return fail(format!(
                "rejected: χ² = {chi2:.1} with {dof} degrees of freedom, p-value {p_value:.3e} < {:.3e} (Šidák-corrected 0.01); sampled mass {sampled_mass:.5}, ∫pdf {total:.5}",
                self.level
            ));
        }
        Ok(report)
    }
}

/// A rectangle of the (s, φ) domain: s in [s0, s1], φ in [p0, p1].
#[derive(Clone, Copy)]
struct Rect {
    s0: f64,
    s1: f64,
    p0: f64,
    p1: f64,
}

/// The two cubatures of a rectangle and whether it may straddle a step.
#[derive(Clone, Copy)]
struct Quad {
    g4: f64,
    g3: f64,
    step: bool,
}

/// Refines the cubature of a rectangle until its 4 × 4 and 3 × 3 rules agree within `tol`,
/// splitting it in four otherwise (each quarter gets half the tolerance: along a discontinuity
/// the error halves per level). Rectangles that may straddle a step of the density are split at
/// least three times: there the two rules can agree by chance (both are staircases of the step).
fn adaptive(
    gauss: &impl Fn(Rect, &mut Option<(Vec3, f32)>) -> Quad,
    r: Rect,
    q: Quad,
    tol: f64,
    depth: u32,
    bad: &mut Option<(Vec3, f32)>,
) -> f64 {
    if depth >= 7 || ((q.g4 - q.g3).abs() <= tol && !(q.step && depth < 3)) {
        return q.g4;
    }
    let Rect { s0, s1, p0, p1 } = r;
    let (sm, pm) = (0.5 * (s0 + s1), 0.5 * (p0 + p1));
    [
        (s0, sm, p0, pm),
        (sm, s1, p0, pm),
        (s0, sm, pm, p1),
        (sm, s1, pm, p1),
    ]
    .iter()
    .map(|&(s0, s1, p0, p1)| {
        let r = Rect { s0, s1, p0, p1 };
        let q = gauss(r, bad);
        adaptive(gauss, r, q, 0.5 * tol, depth + 1, bad)
    })
    .sum()
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms; ~1e-15 relative).
pub fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularised upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a): by its series for
/// x < a + 1 (Q = 1 − P), by Lentz's continued fraction otherwise (Numerical Recipes §6.2).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_pre = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut ap, mut del) = (a, 1.0 / a);
        let mut sum = del;
        for _ in 0..100_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * ln_pre.exp()).max(0.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (ln_pre.exp() * h).clamp(0.0, 1.0)
    }
}

/// P(X ≥ x) for X ~ χ²(dof).
pub fn chi2_survival(x: f64, dof: f64) -> f64 {
    gamma_q(0.5 * dof, 0.5 * x)
}

/// The mean and the standard error of the mean of `n` values.
pub fn mean_and_error(sum: f64, sum2: f64, n: usize) -> (f64, f64) {
    let n = n as f64;
    let mean = sum / n;
    let var = (sum2 / n - mean * mean).max(0.0) * n / (n - 1.0);
    (mean, (var / n).sqrt())
}
