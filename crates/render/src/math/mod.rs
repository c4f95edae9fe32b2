//! Geometry: vectors, points, normals, transformations, rays, boxes and frames (all f32).

mod angles;
mod bounds;
mod frame;
mod ray;
mod ray_batch;
pub mod special;
mod transform;
mod vector;

pub use angles::fast_atan2;
pub use bounds::{Bounds3, GAMMA3};
pub use frame::Frame;
pub use ray::{offset_ray_origin, Ray, SHADOW_EPSILON};
pub use ray_batch::{lanes, RayBatch, BATCH};
pub use transform::{Matrix4, Transform};
pub use vector::{abs_dot, Normal3, Point2, Point3, Vec3};

/// π in f32.
pub const PI: f32 = std::f32::consts::PI;
/// 1/π in f32.
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
/// 1/(2π) in f32.
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
/// 1/(4π) in f32.
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// `x²`.
#[inline]
pub fn sqr(x: f32) -> f32 {
    x * x
}

/// `sqrt(max(x, 0))`: for quantities that are ≥ 0 up to round-off.
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// `acos` clamped to a valid argument.
#[inline]
pub fn safe_acos(x: f32) -> f32 {
    x.clamp(-1.0, 1.0).acos()
}

/// Linear interpolation `a·(1−t) + b·t`.
#[inline]
pub fn lerp(t: f32, a: f32, b: f32) -> f32 {
    a + (b - a) * t
}

/// `x.floor() as i64` without the library call `floor` is on x86-64 without SSE4.1 (the
/// same integer: truncation, one down for negative non-integers; f32 values beyond 2²⁴ are
/// integers already; NaN gives 0, and values beyond the range of i64 saturate, as the cast
/// does).
#[inline(always)]
pub fn floor_i64(x: f32) -> i64 {
    let i = x as i64;
    i.saturating_sub(((i as f32) > x) as i64)
}

#[cfg(test)]
mod tests {
    use super::floor_i64;

    /// The same integer as the library's floor and the saturating cast, on the integers, the
    /// halves, the signs of zero, huge values, infinities and NaN, and on random values of
    /// every scale.
    #[test]
    fn floor_i64_is_the_floor() {
        let mut cases = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.5,
            2.5,
            16_777_217.0,
            -16_777_217.0,
            1e19,
            -1e19,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
        ];
        let mut rng = crate::sampling::Pcg32::new(3, 5);
        for k in 0..100_000 {
            let scale = 10f32.powi(k % 12 - 4);
            cases.push((rng.next_f32() - 0.5) * scale);
        }
        for x in cases {
            assert_eq!(floor_i64(x), x.floor() as i64, "floor of {x}");
        }
    }
}
