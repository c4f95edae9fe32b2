//! Warps from the unit square to directions and points, each with its pdf.
//!
//! Every routine takes uniform numbers in `[0,1)²` and is deterministic, so that callers may
//! feed stratified or low-discrepancy samples. Directions are in a local frame whose +z axis is
//! the normal; pdfs are per unit solid angle (directions) or per unit area (points).

use crate::math::{safe_sqrt, Point2, Point3, Vec3, INV_2PI, INV_4PI, INV_PI, PI};

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
fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    (s, c)
}

/// Cosine-weighted direction on the hemisphere z > 0 (Malley's method).
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
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
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
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
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
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
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
/// [`square_to_uniform_cone`] it stays accurate for tiny cones.
#[inline]
pub fn square_to_uniform_cone_narrow(u: [f32; 2], one_minus_cos_max: f32) -> Vec3 {
    // a = 1 − cos θ, uniform in [0, 1 − cos θ_max]; sin θ = √(a(2 − a)) without cancellation.
    let a = u[0] * one_minus_cos_max;
    let r = safe_sqrt(a * (2.0 - a));
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), 1.0 - a)
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

/// Smallest solid angle (sr) that [`SphericalRectangle`] samples; below it (and for points in
/// the rectangle's plane) area sampling is as good, and callers fall back to it.
pub const MIN_SPHERICAL_RECTANGLE: f64 = 1e-4;

/// A rectangle as seen from a point, sampled uniformly by solid angle with the area-preserving
/// parametrisation of Ureña, Fajardo and King (2013), "An Area-Preserving Parametrization for
/// Spherical Rectangles". Computed in f64: the solid angle is a difference of angles near π,
/// which f32 would cancel away. The density of [`SphericalRectangle::sample`] is
/// 1 / [`SphericalRectangle::solid_angle`] over the directions to the rectangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphericalRectangle {
    x0: f64,
    y0: f64,
    z0: f64,
    x1: f64,
    y1: f64,
    lx: f64,
    ly: f64,
    b0: f64,
    b1: f64,
    k: f64,
    s: f64,
}

#[inline(always)]
fn dot64(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn unit64(a: [f64; 3]) -> [f64; 3] {
    let l = dot64(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

impl SphericalRectangle {
    /// The rectangle with corner `corner` and orthogonal edges `v`, `w` seen from `o`; `None`
    /// when `o` lies in its plane, when the solid angle is below [`MIN_SPHERICAL_RECTANGLE`] or
    /// when anything is not finite.
    #[inline]
    pub fn new(o: Point3, corner: Point3, v: Vec3, w: Vec3) -> Option<Self> {
        let f = |a: Vec3| [a.x as f64, a.y as f64, a.z as f64];
        let (v, w) = (f(v), f(w));
        let (lx, ly) = (dot64(v, v).sqrt(), dot64(w, w).sqrt());
        let ex = [v[0] / lx, v[1] / lx, v[2] / lx];
        let ey = [w[0] / ly, w[1] / ly, w[2] / ly];
        let ez = [
            ex[1] * ey[2] - ex[2] * ey[1],
            ex[2] * ey[0] - ex[0] * ey[2],
            ex[0] * ey[1] - ex[1] * ey[0],
        ];
        let d = [
            corner.x as f64 - o.x as f64,
            corner.y as f64 - o.y as f64,
            corner.z as f64 - o.z as f64,
        ];
        let (x0, y0) = (dot64(d, ex), dot64(d, ey));
        // The rectangle below the point (z0 < 0): the axis z is flipped when it is above.
        let z0 = -dot64(d, ez).abs();
        if !(z0 < 0.0) {
            return None;
        }
        let (x1, y1) = (x0 + lx, y0 + ly);
        // The normals of the planes through the point and each edge.
        let n0 = unit64([0.0, z0, -y0]);
        let n1 = unit64([-z0, 0.0, x1]);
        let n2 = unit64([0.0, -z0, y1]);
        let n3 = unit64([z0, 0.0, -x0]);
        let angle = |a: [f64; 3], b: [f64; 3]| (-dot64(a, b)).clamp(-1.0, 1.0).acos();
        let (g0, g1, g2, g3) = (angle(n0, n1), angle(n1, n2), angle(n2, n3), angle(n3, n0));
        let k = 2.0 * std::f64::consts::PI - g2 - g3;
        let s = g0 + g1 - k;
        (s >= MIN_SPHERICAL_RECTANGLE && s.is_finite()).then_some(Self {
            x0,
            y0,
            z0,
            x1,
            y1,
            lx,
            ly,
            b0: n0[2],
            b1: n2[2],
            k,
            s,
        })
    }

    /// The solid angle the rectangle subtends.
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        self.s as f32
    }

    /// The rectangle's point (as fractions (s, t) ∈ [0, 1]² of the edges `v`, `w`) whose
    /// direction is uniform over the solid angle; `None` when not finite.
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> Option<(f32, f32)> {
        let Self {
            x0,
            y0,
            z0,
            x1,
            y1,
            b0,
            b1,
            ..
        } = *self;
        // The x coordinate from the area of the spherical polygon left of it.
        let au = u[0] as f64 * self.s + self.k;
        let (sin_au, cos_au) = au.sin_cos();
        let fu = (cos_au * b0 - b1) / sin_au;
        let cu = (1.0 / (fu * fu + b0 * b0).sqrt())
            .copysign(fu)
            .clamp(-1.0 + 1e-15, 1.0 - 1e-15);
        let xu = (-(cu * z0) / (1.0 - cu * cu).sqrt()).clamp(x0, x1);
        // The y coordinate uniform in the sine of its elevation along that line.
        let dd = (xu * xu + z0 * z0).sqrt();
        let h0 = y0 / (dd * dd + y0 * y0).sqrt();
        let h1 = y1 / (dd * dd + y1 * y1).sqrt();
        let hv = h0 + u[1] as f64 * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-12 {
            (hv * dd / (1.0 - hv2).sqrt()).clamp(y0, y1)
        } else {
            y1
        };
        let s = ((xu - x0) / self.lx).clamp(0.0, 1.0) as f32;
        let t = ((yv - y0) / self.ly).clamp(0.0, 1.0) as f32;
        (s.is_finite() && t.is_finite()).then_some((s, t))
    }
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
