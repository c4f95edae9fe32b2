//! Warps from the unit square to directions and points, each with its pdf.
//!
//! Every routine takes uniform numbers in `[0,1)²` and is deterministic, so that callers may
//! feed stratified or low-discrepancy samples. Directions are in a local frame whose +z axis is
//! the normal; pdfs are per unit solid angle (directions) or per unit area (points).

use crate::math::{safe_sqrt, Point2, Vec3, INV_2PI, INV_4PI, INV_PI, PI};

/// Uniform point on the unit disk by Shirley and Chiu's concentric map (low distortion).
#[inline]
pub fn square_to_concentric_disk(u: [f32; 2]) -> Point2 {
    let ox = 2.0 * u[0] - 1.0;
    let oy = 2.0 * u[1] - 1.0;
    if ox == 0.0 && oy == 0.0 {
        return Point2::new(0.0, 0.0);
    }
    // θ = π/4·(oy/ox), or π/2 − π/4·(ox/oy) whose cosine and sine are the sine and cosine of
    // π/4·(ox/oy): both need the sine and cosine of an angle in [−π/4, π/4] only.
    if ox.abs() > oy.abs() {
        let (s, c) = sin_cos_quarter((PI / 4.0) * (oy / ox));
        Point2::new(ox * c, ox * s)
    } else {
        let (s, c) = sin_cos_quarter((PI / 4.0) * (ox / oy));
        Point2::new(oy * s, oy * c)
    }
}

/// Sine and cosine of `x` ∈ [−π/4, π/4] by the minimax polynomials of Cephes' `sinf` and
/// `cosf` (relative error below 2⁻²³ there), inline and without range reduction.
#[inline(always)]
pub(crate) fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    (s, c)
}

/// Sine and cosine of the angle 2π·`u` for `u` ∈ [0, 1]: the angle is split into a multiple
/// m of π/2 (the nearest to it) and a remainder x ∈ [−π/4, π/4] (exactly: 4u − m is exact),
/// whose sine and cosine `sin_cos_quarter` gives and a quarter turn permutes. Every step is
/// a plain IEEE operation, so that sixteen-lane code repeats it bit for bit (the path tracer's
/// microfacet lanes, `integrator/path/microfacet_lanes.rs`: change both), which `sin`/`cos`
/// of the standard library would not allow.
#[inline(always)]
pub fn sin_cos_turn(u: f32) -> (f32, f32) {
    let q = 4.0 * u;
    let m = (q >= 0.5) as u32 + (q >= 1.5) as u32 + (q >= 2.5) as u32 + (q >= 3.5) as u32;
    let (s, c) = sin_cos_quarter((q - m as f32) * (PI / 2.0));
    match m & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Cosine-weighted direction on the hemisphere z > 0 (Malley's method). The path tracer's
/// Lambert lanes repeat it on sixteen lanes (`integrator/path/surface_lanes.rs`): change both.
#[inline]
pub fn square_to_cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let d = square_to_concentric_disk(u);
    let z = safe_sqrt(1.0 - d.x * d.x - d.y * d.y);
    Vec3::new(d.x, d.y, z)
}

/// The pdf of [`square_to_cosine_hemisphere`]: cos θ / π (0 below the horizon).
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 {
        cos_theta * INV_PI
    } else {
        0.0
    }
}

/// Uniform direction on the hemisphere z ≥ 0.
#[inline]
pub fn square_to_uniform_hemisphere(u: [f32; 2]) -> Vec3 {
    let z = u[0];
    let r = safe_sqrt(1.0 - z * z);
    let (sin_phi, cos_phi) = sin_cos_turn(u[1]);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// The pdf of [`square_to_uniform_hemisphere`]: 1/(2π).
#[inline]
pub fn uniform_hemisphere_pdf() -> f32 {
    INV_2PI
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn square_to_uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = safe_sqrt(1.0 - z * z);
    let (sin_phi, cos_phi) = sin_cos_turn(u[1]);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// The pdf of [`square_to_uniform_sphere`]: 1/(4π).
#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    INV_4PI
}

/// Uniform direction in the cone around +z of half-angle θ_max (`cos_max = cos θ_max`).
#[inline]
pub fn square_to_uniform_cone(u: [f32; 2], cos_max: f32) -> Vec3 {
    let z = 1.0 - u[0] * (1.0 - cos_max);
    let r = safe_sqrt(1.0 - z * z);
    let (sin_phi, cos_phi) = sin_cos_turn(u[1]);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// The pdf of [`square_to_uniform_cone`]: 1/(2π(1 − cos θ_max)).
#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// 1 − cos θ for sin²θ = `sin2` (θ ≤ 90°), computed as sin²θ/(1 + cos θ): `1 − √(1 − sin²θ)`
/// cancels catastrophically in f32 for small angles (a sphere of radius 1 seen from 1000 away
/// has 1 − cos θ = 5e-7, below the spacing of f32 numbers near 1).
#[inline]
pub fn one_minus_cos_from_sin2(sin2: f32) -> f32 {
    let s = sin2.clamp(0.0, 1.0);
    s / (1.0 + (1.0 - s).sqrt())
}

/// Uniform direction in the cone around +z whose half-angle θ_max is given by
/// `one_minus_cos_max` = 1 − cos θ_max (see [`one_minus_cos_from_sin2`]); unlike
/// [`square_to_uniform_cone`] it stays accurate for tiny cones. (Like the sphere, hemisphere
/// and cone warps above, it takes the sine and cosine of φ = 2π·u₁ from [`sin_cos_turn`], so
/// that the path tracer's lanes repeat a sphere light's sample bit for bit.)
#[inline]
pub fn square_to_uniform_cone_narrow(u: [f32; 2], one_minus_cos_max: f32) -> Vec3 {
    // a = 1 − cos θ, uniform in [0, 1 − cos θ_max]; sin θ = √(a(2 − a)) without cancellation.
    let a = u[0] * one_minus_cos_max;
    let r = safe_sqrt(a * (2.0 - a));
    let (sin_phi, cos_phi) = sin_cos_turn(u[1]);
    Vec3::new(r * cos_phi, r * sin_phi, 1.0 - a)
}

/// The pdf of [`square_to_uniform_cone_narrow`]: 1/(2π(1 − cos θ_max)).
#[inline]
pub fn uniform_cone_pdf_narrow(one_minus_cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * one_minus_cos_max)
}

/// Uniform barycentric coordinates (b1, b2) on a triangle (the square-root parametrisation);
/// the pdf is 1/area of the triangle.
#[inline]
pub fn square_to_uniform_triangle(u: [f32; 2]) -> (f32, f32) {
    let su = u[0].sqrt();
    (1.0 - su, u[1] * su)
}

/// The power heuristic (β = 2) weight of a strategy with pdf `f` (taking `nf` samples) against
/// one with pdf `g` (taking `ng` samples) (Veach 1997).
#[inline]
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let f = nf * f_pdf;
    let g = ng * g_pdf;
    if f.is_infinite() {
        return 1.0;
    }
    if !(f > 0.0) {
        return 0.0;
    }
    // f²/(f² + g²) written so that huge densities cannot overflow.
    let r = g / f;
    1.0 / (1.0 + r * r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> impl Iterator<Item = [f32; 2]> {
        (0..n * n).map(move |i| {
            [
                ((i % n) as f32 + 0.5) / n as f32,
                ((i / n) as f32 + 0.5) / n as f32,
            ]
        })
    }

    #[test]
    fn quarter_sine_and_cosine_are_within_two_ulps() {
        for i in 0..=20_000 {
            let x = (i as f32 / 10_000.0 - 1.0) * (PI / 4.0);
            let (s, c) = sin_cos_quarter(x);
            let (es, ec) = (x as f64).sin_cos();
            assert!(
                (s as f64 - es).abs() <= 2.0 * f32::EPSILON as f64 * es.abs().max(1e-30),
                "sin {x}"
            );
            assert!(
                (c as f64 - ec).abs() <= 2.0 * f32::EPSILON as f64 * ec,
                "cos {x}"
            );
        }
        assert_eq!(sin_cos_quarter(0.0), (0.0, 1.0));
    }

    #[test]
    fn turn_sine_and_cosine_are_within_three_ulps_of_the_angle_s() {
        let ulp = |a: f32, b: f64| ((a as f64 - b).abs() / f64::from(f32::EPSILON)) as f32;
        for i in 0..=100_000u32 {
            let u = i as f32 / 100_000.0;
            let (s, c) = sin_cos_turn(u);
            let phi = 2.0 * std::f64::consts::PI * u as f64;
            // Absolute error in units of 2⁻²³ (the sine and cosine are at most 1).
            assert!(ulp(s, phi.sin()) < 3.0, "sin at {u}: {s} vs {}", phi.sin());
            assert!(ulp(c, phi.cos()) < 3.0, "cos at {u}: {c} vs {}", phi.cos());
        }
    }

    #[test]
    fn warped_directions_are_unit_and_in_their_domain() {
        for u in grid(32) {
            let d = square_to_cosine_hemisphere(u);
            assert!((d.norm() - 1.0).abs() < 1e-5 && d.z >= 0.0);
            let d = square_to_uniform_hemisphere(u);
            assert!((d.norm() - 1.0).abs() < 1e-5 && d.z >= 0.0);
            let d = square_to_uniform_sphere(u);
            assert!((d.norm() - 1.0).abs() < 1e-5);
            let d = square_to_uniform_cone(u, 0.8);
            assert!((d.norm() - 1.0).abs() < 1e-5 && d.z >= 0.8 - 1e-6);
            let (b1, b2) = square_to_uniform_triangle(u);
            assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0);
            let p = square_to_concentric_disk(u);
            assert!(p.x * p.x + p.y * p.y <= 1.0 + 1e-6);
        }
    }

    #[test]
    fn cosine_hemisphere_has_the_right_mean_cosine() {
        // E[cos θ] under pdf cos θ/π is 2/3.
        let n = 256;
        let mean: f64 = grid(n)
            .map(|u| square_to_cosine_hemisphere(u).z as f64)
            .sum::<f64>()
            / (n * n) as f64;
        assert!((mean - 2.0 / 3.0).abs() < 1e-3, "{mean}");
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        let w1 = power_heuristic(1.0, 0.3, 1.0, 0.7);
        let w2 = power_heuristic(1.0, 0.7, 1.0, 0.3);
        assert!((w1 + w2 - 1.0).abs() < 1e-6);
        assert_eq!(power_heuristic(1.0, f32::INFINITY, 1.0, 3.0), 1.0);
        assert_eq!(power_heuristic(1.0, 0.0, 1.0, 3.0), 0.0);
        // Densities whose squares overflow f32 still give a weight.
        assert!((power_heuristic(1.0, 2e21, 1.0, 1.0) - 1.0).abs() < 1e-6);
        assert!(power_heuristic(1.0, 1.0, 1.0, 2e21) < 1e-6);
    }
}
