//! The error function and its inverse in single precision, for the Beckmann distribution
//! (Smith's exact masking term, and the sampling of its visible normals).

/// 1/√π.
pub const FRAC_1_SQRT_PI: f32 = 0.564_189_6;

/// e^(x²)·erfc(x) for x ≥ 0: the rational factor of Abramowitz and Stegun's approximation
/// 7.1.26 (Hastings), erfc(x) ≈ t·P(t)·e^(−x²) with t = 1/(1 + p·x), within 1.5·10⁻⁷ of erfc
/// (absolute, in exact arithmetic). Kept apart from e^(−x²) so that callers that need that
/// factor too compute it once, and so that differences with other terms of that factor
/// (Smith's Λ) keep their meaning at large x.
#[inline]
pub fn erfc_scaled(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    t * (0.254_829_6 + t * (-0.284_496_74 + t * (1.421_413_8 + t * (-1.453_152 + t * 1.061_405_4))))
}

/// The complementary error function erfc(x) = 1 − erf(x) for x ≥ 0 ([`erfc_scaled`]·e^(−x²));
/// evaluated in f32, within 5·10⁻⁷.
#[inline]
pub fn erfc_positive(x: f32) -> f32 {
    erfc_scaled(x) * (-x * x).exp()
}

/// erf(x) for any x, to within 5·10⁻⁷ ([`erfc_positive`] and erf(−x) = −erf(x)).
#[inline]
pub fn erf(x: f32) -> f32 {
    let e = 1.0 - erfc_positive(x.abs());
    if x < 0.0 {
        -e
    } else {
        e
    }
}

/// The inverse error function on (−1, 1) (±∞ at ±1): M. Giles' single-precision
/// approximation ("Approximating the erfinv function", GPU Computing Gems, 2011), a
/// polynomial in w = −ln(1 − x²) on two ranges, relative error a few units of 10⁻⁷.
#[inline]
pub fn erf_inv(x: f32) -> f32 {
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        let w = w - 2.5;
        let mut p = 2.810_226_4e-8;
        p = 3.432_739_4e-7 + p * w;
        p = -3.523_387_7e-6 + p * w;
        p = -4.391_506_5e-6 + p * w;
        p = 2.185_808_7e-4 + p * w;
        p = -1.253_725e-3 + p * w;
        p = -4.177_681_6e-3 + p * w;
        p = 0.246_640_73 + p * w;
        1.501_409_4 + p * w
    } else {
        let w = w.sqrt() - 3.0;
        let mut p = -2.002_142_6e-4;
        p = 1.009_505_6e-4 + p * w;
        p = 1.349_343_2e-3 + p * w;
        p = -3.673_428_4e-3 + p * w;
        p = 5.739_507_7e-3 + p * w;
        p = -7.622_461_3e-3 + p * w;
        p = 9.438_870_5e-3 + p * w;
        p = 1.001_674 + p * w;
        2.832_976_8 + p * w
    };
    p * x
}

/// Smith's Λ for the Beckmann distribution, Λ(a) = (e^(−a²)/(a√π) − erfc(a)) / 2, where
/// a = 1/(α tan θ): G1 = 1/(1 + Λ). 0 for a ≥ 4 (below 10⁻⁹ there), ∞ at a = 0 (grazing).
#[inline]
pub fn beckmann_lambda(a: f32) -> f32 {
    if a >= 4.0 {
        return 0.0;
    }
    let p = erfc_scaled(a);
    let e = (-a * a).exp();
    (0.5 * e * (FRAC_1_SQRT_PI / a - p)).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// erf in double precision to about 1e-15: its Taylor series for |x| < 3, the continued
    /// fraction of erfc beyond (Lentz's method).
    fn erf64(x: f64) -> f64 {
        let s = x.signum();
        let x = x.abs();
        if x < 3.0 {
            let (mut term, mut sum, mut n) = (x, x, 0.0);
            while term.abs() > 1e-17 * sum.abs() {
                n += 1.0;
                term *= -x * x / n;
                sum += term / (2.0 * n + 1.0);
            }
            s * sum * 2.0 / std::f64::consts::PI.sqrt()
        } else {
            // erfc(x) = e^(−x²)/√π · 1/(x + (1/2)/(x + 1/(x + (3/2)/(x + 2/(x + …))))).
            let mut f = x;
            for k in (1..200).rev() {
                f = x + (k as f64 / 2.0) / f;
            }
            s * (1.0 - (-x * x).exp() / std::f64::consts::PI.sqrt() / f)
        }
    }

    #[test]
    fn erf_is_within_its_bound() {
        for i in -4000..=4000 {
            let x = i as f32 / 800.0;
            let e = erf64(x as f64);
            assert!(
                (erf(x) as f64 - e).abs() < 5e-7,
                "erf({x}) = {} vs {e}",
                erf(x)
            );
            if x >= 0.0 {
                let c = erfc_positive(x) as f64;
                assert!((c - (1.0 - e)).abs() < 5e-7, "erfc({x})");
            }
        }
    }

    /// erf(erf_inv(y)) = y to within f32 rounding, from the middle to the tails, and erf_inv
    /// is odd and increasing.
    #[test]
    fn erf_inv_inverts_erf() {
        let mut last = f32::NEG_INFINITY;
        for i in -99_999..=99_999 {
            let y = i as f32 / 100_000.0;
            let x = erf_inv(y);
            assert!(x >= last, "not increasing at {y}");
            last = x;
            let back = erf64(x as f64);
            // The error allowed is that of rounding x: |dy/dx| · ulp(x), plus y's own.
            let slope = 2.0 / std::f64::consts::PI.sqrt() * (-(x as f64) * (x as f64)).exp();
            let tol = 8.0 * slope * (x.abs().max(1e-3) as f64) * f32::EPSILON as f64 + 1e-7;
            assert!((back - y as f64).abs() < tol, "erf(erf_inv({y})) = {back}");
            assert_eq!(erf_inv(-y), -x);
        }
        // Deep in the tails (w ≥ 5).
        for y in [0.999, 0.9999, 0.99999, 0.999_999] {
            let x = erf_inv(y);
            let back = erf64(x as f64);
            assert!(
                ((1.0 - back) / (1.0 - y as f64) - 1.0).abs() < 1e-3,
                "tail {y}: {x}"
            );
        }
    }

    /// Λ against its definition in double precision, over the range where it matters.
    #[test]
    fn beckmann_lambda_matches_its_definition() {
        for i in 1..=4000 {
            let a = i as f64 / 1000.0;
            let exact =
                0.5 * ((-a * a).exp() / (a * std::f64::consts::PI.sqrt()) - (1.0 - erf64(a)));
            let got = beckmann_lambda(a as f32) as f64;
            assert!(
                (got - exact).abs() < 2e-7 + 1e-6 * exact,
                "Λ({a}) = {got} vs {exact}"
            );
        }
        assert_eq!(beckmann_lambda(0.0), f32::INFINITY);
    }
}
