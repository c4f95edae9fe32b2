//! Reconstruction filters: χ² goodness of fit of every filter's pixel-sample distribution against
//! its normalised |filter| (computed here by independent quadrature), and the weighted samples'
//! means against the normalised signed filter.

mod support;

use candela_render::filter::{Filter, FilterSampler, FILTER_NAMES};
use candela_render::sampling::Pcg32;
use support::chi2::{chi2_survival, sidak};

const SAMPLES: usize = 400_000;
/// Cells per axis of the 2D histogram (each covers whole table bins).
const CELLS: usize = 32;

/// ∫ g over [a, b] by composite Simpson with many sub-intervals (in f64), of |g| when `abs`.
fn integral(f: &Filter, a: f64, b: f64, abs: bool) -> f64 {
    let n = 2000;
    let h = (b - a) / n as f64;
    let g = |x: f64| {
        let v = f.eval_1d(x);
        if abs {
            v.abs()
        } else {
            v
        }
    };
    let mut s = g(a) + g(b);
    for i in 1..n {
        s += g(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

#[test]
fn every_filter_samples_its_normalised_magnitude() {
    let alpha = sidak(0.01, FILTER_NAMES.len());
    for name in FILTER_NAMES {
        let filter = Filter::by_name(name).unwrap();
        let sampler = FilterSampler::new(filter);
        let r = filter.radius() as f64;
        let edges: Vec<f64> = (0..=CELLS)
            .map(|i| -r + 2.0 * r * i as f64 / CELLS as f64)
            .collect();
        // Per-cell probability of one axis under |g| / ∫|g|, and signed mass of g / ∫g.
        let total_abs = integral(&filter, -r, r, true);
        let total = integral(&filter, -r, r, false);
        let p1: Vec<f64> = edges
            .windows(2)
            .map(|w| integral(&filter, w[0], w[1], true) / total_abs)
            .collect();
        let m1: Vec<f64> = edges
            .windows(2)
            .map(|w| integral(&filter, w[0], w[1], false) / total)
            .collect();
        let mut counts = vec![0u64; CELLS * CELLS];
        let mut weights = vec![0f64; CELLS * CELLS];
        let mut rng = Pcg32::new(7, 11);
        let cell = |v: f32| {
            let t = (v as f64 - 0.5 + r) / (2.0 * r) * CELLS as f64;
            (t.max(0.0) as usize).min(CELLS - 1)
        };
        for _ in 0..SAMPLES {
            let u = [rng.next_f32(), rng.next_f32()];
            let ([x, y], w) = sampler.sample(u);
            assert!(
                (x - 0.5).abs() as f64 <= r + 1e-5 && (y - 0.5).abs() as f64 <= r + 1e-5,
                "{name}: sample ({x}, {y}) outside the support"
            );
            let k = cell(y) * CELLS + cell(x);
            counts[k] += 1;
            weights[k] += w as f64;
        }
        // χ² with cells of small expectation pooled.
        let (mut chi2, mut dof) = (0.0, 0usize);
        let (mut pool_o, mut pool_e) = (0.0, 0.0);
        for j in 0..CELLS {
            for i in 0..CELLS {
                let e = p1[i] * p1[j] * SAMPLES as f64;
                let o = counts[j * CELLS + i] as f64;
                if e < 5.0 {
                    pool_o += o;
                    pool_e += e;
                } else {
                    chi2 += (o - e) * (o - e) / e;
                    dof += 1;
                }
            }
        }
        if pool_e > 0.0 {
            chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(1e-9);
            dof += 1;
        }
        let p = chi2_survival(chi2, (dof - 1) as f64);
        assert!(
            p > alpha,
            "{name}: χ² = {chi2:.1}, {dof} cells, p = {p:.3e}"
        );
        // Weighted means: the estimator of the normalised signed filter's cell masses, within
        // 5 standard errors (the weight's magnitude is constant, so the count's error scales).
        let wmax = weights
            .iter()
            .zip(&counts)
            .filter(|(_, &c)| c > 0)
            .map(|(w, &c)| (w / c as f64).abs())
            .fold(0.0, f64::max);
        for j in 0..CELLS {
            for i in 0..CELLS {
                let expected = m1[i] * m1[j];
                let got = weights[j * CELLS + i] / SAMPLES as f64;
                let var_p = p1[i] * p1[j];
                let sigma = wmax * (var_p / SAMPLES as f64).sqrt();
                assert!(
                    (got - expected).abs() <= 5.0 * sigma + 1e-4,
                    "{name}: cell ({i}, {j}): {got} vs {expected} (σ {sigma})"
                );
            }
        }
        // Non-negative filters have weight 1.
        if matches!(name, "box" | "tent" | "gaussian") {
            assert_eq!(wmax, 1.0, "{name}");
        }
    }
}
