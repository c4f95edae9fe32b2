//! The arctangent by polynomial, for the hot paths that turn directions into angles (an
//! environment map's lat-long coordinates of every escaped ray and light-sample density): no
//! library call, no branch on the argument's range beyond a few selects, and an error below
//! 4·10⁻⁷ rad (under two units in the last place of π) against correctly rounded results.

use super::PI;

/// Coefficients of atan(a) ≈ a·P(a²) on [0, 1] (a least-maximum-error fit of degree 7 in a²:
/// 1.9·10⁻⁷ rad at most, evaluated in f32).
const ATAN: [f32; 8] = [
    0.999_999_94,
    -0.333_320_95,
    0.199_713_81,
    -0.140_294_6,
    0.099_428_87,
    -0.059_906_77,
    0.024_558_744,
    -0.004_780_952_4,
];

/// `y.atan2(x)`: the angle of (x, y) in [−π, π], by one division and a polynomial (error
/// below 4·10⁻⁷ rad; ±0 for the origin).
#[inline]
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = if hi > 0.0 { lo / hi } else { 0.0 };
    // Estrin's scheme: the eight terms in three levels of products rather than Horner's seven
    // in a row, for the latency (an escaped ray's lookup waits on this chain).
    let t = a * a;
    let (t2, c) = (t * t, &ATAN);
    let low = (c[0] + c[1] * t) + t2 * (c[2] + c[3] * t);
    let high = (c[4] + c[5] * t) + t2 * (c[6] + c[7] * t);
    let mut r = a * (low + (t2 * t2) * high);
    if ay > ax {
        r = 0.5 * PI - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    // The sign of y, negative zero included (as the library's).
    r.copysign(y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// Against f64's correctly rounded functions, over angles all around and arguments of
    /// every scale (4·10⁻⁷ rad is 1.7 ulp of π: the polynomial's 1.9·10⁻⁷ and the rounding
    /// of π − r).
    #[test]
    fn atan2_is_within_4e_7_rad() {
        let mut rng = Pcg32::new(7, 11);
        let mut worst = 0f64;
        for k in 0..400_000 {
            let angle = (rng.next_f32() as f64 - 0.5) * 2.0 * std::f64::consts::PI;
            let scale = 10f64.powi((k % 13) - 6);
            let (x, y) = ((angle.cos() * scale) as f32, (angle.sin() * scale) as f32);
            let exact = (y as f64).atan2(x as f64);
            worst = worst.max((fast_atan2(y, x) as f64 - exact).abs());
        }
        assert!(worst < 4e-7, "atan2: {worst}");
        // acos(z) as atan2(sin θ, z), as an environment map's v is made.
        let mut worst = 0f64;
        for _ in 0..400_000 {
            let z = rng.next_f32() * 2.0 - 1.0;
            let acos = fast_atan2(((1.0 - z) * (1.0 + z)).sqrt(), z);
            worst = worst.max((acos as f64 - (z as f64).acos()).abs());
        }
        assert!(worst < 4e-7, "acos: {worst}");
    }

    /// The axes, the signs of zero and the quadrant boundaries, as the library gives them.
    #[test]
    fn special_arguments_match_the_library() {
        for (y, x) in [
            (0.0f32, 1.0f32),
            (1.0, 0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (-1.0, 0.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (1.0, -1.0),
            (0.0, 0.0),
            (3.0, 3.0),
        ] {
            let (f, l) = (fast_atan2(y, x), y.atan2(x));
            assert!((f - l).abs() <= 4e-7, "atan2({y}, {x}): {f} against {l}");
        }
    }
}
