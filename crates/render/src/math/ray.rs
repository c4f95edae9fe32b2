//! Rays and the one helper that offsets their origins off surfaces.

use super::{Normal3, Point3, Vec3};
use crate::simd::F4;

/// A ray `o + t·d` for `t` in `[tmin, tmax]`. The direction need not be normalised: shapes
/// that move the ray into their own frame keep the same `t` for the same point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: Point3,
    /// Direction.
    pub d: Vec3,
    /// Smallest accepted parameter.
    pub tmin: f32,
    /// Largest accepted parameter.
    pub tmax: f32,
}

impl Ray {
    /// A ray from `o` along `d` over `[0, ∞)`.
    #[inline]
    pub fn new(o: Point3, d: Vec3) -> Self {
        Self {
            o,
            d,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Point3 {
        self.o + self.d * t
    }

    /// A ray leaving the surface point `p` (geometric normal `n`) along `d`, its origin offset
    /// to the side of the surface that `d` points to so that it cannot re-hit that surface by
    /// round-off.
    #[inline]
    pub fn spawn(p: Point3, n: Normal3, d: Vec3) -> Self {
        Self::new(offset_ray_origin(p, n, d), d)
    }

    /// A ray from the surface point `p` (geometric normal `n`) towards the point `target`,
    /// stopping just short of it: for visibility (shadow) tests.
    #[inline]
    pub fn spawn_to(p: Point3, n: Normal3, target: Point3) -> Self {
        let d0 = target - p;
        let o = offset_ray_origin(p, n, d0);
        let d = target - o;
        Self {
            o,
            d,
            tmin: 0.0,
            tmax: 1.0 - SHADOW_EPSILON,
        }
    }

    /// [`Ray::spawn`] for a unit normal `n` (not normalised again).
    #[inline]
    pub fn spawn_unit(p: Point3, n: Normal3, d: Vec3) -> Self {
        Self::new(offset_unit(p, n, d), d)
    }

    /// Like [`Ray::spawn_to`], but with both ends on surfaces: the target is offset too.
    #[inline]
    pub fn spawn_between(p: Point3, n: Normal3, target: Point3, n_target: Normal3) -> Self {
        Self::spawn_between_unit(p, unit(n), target, unit(n_target))
    }

    /// [`Ray::spawn_between`] for unit normals `n` and `n_target` (not normalised again).
    #[inline]
    pub fn spawn_between_unit(p: Point3, n: Normal3, target: Point3, n_target: Normal3) -> Self {
        let o = offset_unit(p, n, target - p);
        let t = offset_unit(target, n_target, o - target);
        Self {
            o,
            d: t - o,
            tmin: 0.0,
            tmax: 1.0 - SHADOW_EPSILON,
        }
    }
}

/// `n` normalised (a zero normal stays zero).
#[inline(always)]
fn unit(n: Normal3) -> Normal3 {
    let len = n.to_vec().norm();
    if len > 0.0 {
        n / len
    } else {
        n
    }
}

/// Relative shortening of shadow rays, so that they stop before the surface they aim at.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// Moves `p` off its surface, along the geometric normal `n` towards the side `w` points to.
///
/// The offset is a fixed number of units in the last place of each coordinate (Wächter and
/// Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, 2019),
/// with an absolute floor near the origin where ULPs vanish. It covers the round-off of every
/// intersection routine of candela, which recompute hit points in a shape's own frame.
#[inline]
pub fn offset_ray_origin(p: Point3, n: Normal3, w: Vec3) -> Point3 {
    offset_unit(p, unit(n), w)
}

/// [`offset_ray_origin`] for a unit normal `n`: each coordinate moves by 256·n ULPs (its bits
/// moved away from zero for a positive offset), or by n/65536 near the origin (|p| < 1/32)
/// where ULPs are too small. The three coordinates are moved at once (SSE2); the result is the
/// same as coordinate by coordinate, the −0.0 case included (it is near the origin). The path
/// tracer's Lambert lanes repeat it on sixteen lanes (`integrator/path/surface_lanes.rs`).
#[inline(always)]
fn offset_unit(p: Point3, n: Normal3, w: Vec3) -> Point3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if n.dot_vec(w) < 0.0 { -n } else { n };
    let pv = F4::load(&[p.x, p.y, p.z, 0.0]);
    let nv = F4::load(&[n.x, n.y, n.z, 0.0]);
    let moved = pv.move_ulps(F4::splat(INT_SCALE).mul(nv));
    let near = pv.add(F4::splat(FLOAT_SCALE).mul(nv));
    let o = F4::select(pv.abs().lt_mask(F4::splat(ORIGIN)), near, moved).to_array();
    Point3::new(o[0], o[1], o[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The offset coordinate by coordinate, as it was written before the SIMD version (whose
    /// integer addition wrapped in release builds: at −0.0, discarded near the origin anyway).
    fn offset_scalar(p: Point3, n: Normal3, w: Vec3) -> Point3 {
        let n = if n.dot_vec(w) < 0.0 { -n } else { n };
        let off = |p: f32, n: f32| -> f32 {
            let of_i = (256.0 * n) as i32;
            let bits = p.to_bits() as i32;
            let moved =
                f32::from_bits(bits.wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32);
            if p.abs() < 1.0 / 32.0 {
                p + n / 65536.0
            } else {
                moved
            }
        };
        Point3::new(off(p.x, n.x), off(p.y, n.y), off(p.z, n.z))
    }

    #[test]
    fn the_simd_offset_is_the_scalar_one() {
        let mut rng = crate::sampling::Pcg32::new(3, 9);
        let mut u = || rng.next_f32() * 2.0 - 1.0;
        let scales = [0.0, 1e-3, 0.02, 1.0, 300.0, 1e6];
        for k in 0..20_000 {
            let s = scales[k % scales.len()];
            let mut p = Point3::new(u() * s, u() * s, u() * s);
            if k % 7 == 0 {
                p.y = -0.0;
            }
            let n = Vec3::new(u(), u(), u()).normalize().to_normal();
            let w = Vec3::new(u(), u(), u());
            let (a, b) = (offset_unit(p, n, w), offset_scalar(p, n, w));
            assert_eq!(
                [a.x.to_bits(), a.y.to_bits(), a.z.to_bits()],
                [b.x.to_bits(), b.y.to_bits(), b.z.to_bits()],
                "{p:?} {n:?}"
            );
        }
    }

    #[test]
    fn ray_points_by_hand() {
        let r = Ray::new(Point3::new(1.0, 2.0, 4.0), Vec3::new(4.0, 2.0, 1.0));
        assert_eq!(r.at(0.0), r.o);
        assert_eq!(r.at(1.0), Point3::new(5.0, 4.0, 5.0));
        assert_eq!(r.at(2.0), Point3::new(9.0, 6.0, 6.0));
        assert_eq!(r.tmin, 0.0);
        assert_eq!(r.tmax, f32::INFINITY);
    }

    #[test]
    fn offset_moves_to_the_side_of_the_direction() {
        let n = Normal3::new(0.0, 0.0, 1.0);
        for p in [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(100.0, -3.0, 7.0),
            Point3::new(0.5, 0.5, -1e4),
        ] {
            let up = offset_ray_origin(p, n, Vec3::new(0.3, 0.0, 1.0));
            let down = offset_ray_origin(p, n, Vec3::new(0.3, 0.0, -1.0));
            assert!(up.z > p.z && down.z < p.z, "{p:?}: {up:?} {down:?}");
            assert_eq!((up.x, up.y), (p.x, p.y));
        }
    }

    #[test]
    fn shadow_rays_stop_short_of_their_target() {
        let p = Point3::new(0.0, 0.0, 0.0);
        let q = Point3::new(0.0, 0.0, 2.0);
        let r = Ray::spawn_to(p, Normal3::new(0.0, 0.0, 1.0), q);
        assert!(r.at(r.tmax).z < 2.0 && r.at(r.tmax).z > 1.99);
    }
}
