//! Geometry: vectors, points, normals, transformations, rays, boxes and frames (all f32).

mod angles;
mod bounds;
mod frame;
mod ray;
mod ray_batch;
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
