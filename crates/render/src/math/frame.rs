//! Orthonormal frames (shading frames) built from a single normal.

use super::{Normal3, Vec3};
use crate::simd::F4;

/// An orthonormal basis `(s, t, n)`: `n` is the local +z axis.
///
/// Each axis starts a 16-byte row of its own (a zero fills the rest): a frame is written
/// and copied as three whole rows, so that reading an axis back (in any pieces) is served
/// by the one store that wrote its row. Rows packed at 12-byte strides were written in
/// 16-byte pieces that cut axes in two, and the readers' loads across those cuts could not
/// be forwarded from the stores (a stall of some ten cycles each).
#[repr(C, align(16))]
#[derive(Clone, Copy, PartialEq)]
pub struct Frame {
    /// Local x axis.
    pub s: Vec3,
    pad_s: f32,
    /// Local y axis.
    pub t: Vec3,
    pad_t: f32,
    /// Local z axis (the normal).
    pub n: Vec3,
    pad_n: f32,
}

impl std::fmt::Debug for Frame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Frame")
            .field("s", &self.s)
            .field("t", &self.t)
            .field("n", &self.n)
            .finish()
    }
}

impl Frame {
    /// The frame with axes `s`, `t` and `n` (taken as they are: orthonormal, right-handed).
    /// Each row is made in one vector register (an SSE `max` of the row with itself, which
    /// keeps every bit), so that a frame computed on the fly and stored is written as three
    /// whole rows, which whole-row loads are forwarded from (written lane by lane, each
    /// row's copy into the BSDF stalled).
    #[inline(always)]
    pub fn new(s: Vec3, t: Vec3, n: Vec3) -> Self {
        let row = |v: Vec3| {
            let r = F4::load(&[v.x, v.y, v.z, 0.0]);
            r.max_keep(r).to_array()
        };
        let [s, t, n] = [row(s), row(t), row(n)];
        Self {
            s: Vec3::new(s[0], s[1], s[2]),
            pad_s: s[3],
            t: Vec3::new(t[0], t[1], t[2]),
            pad_t: t[3],
            n: Vec3::new(n[0], n[1], n[2]),
            pad_n: n[3],
        }
    }

    /// The basis around a unit normal, without branches on the normal's direction (Duff et al.,
    /// "Building an Orthonormal Basis, Revisited", JCGT 2017).
    #[inline]
    pub fn from_normal(n: Normal3) -> Self {
        let n = n.to_vec();
        let sign = 1f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self::new(s, t, n)
    }

    /// The basis with normal `n` whose first axis is `dpdu` made orthogonal to `n`
    /// (Gram–Schmidt); falls back to [`Frame::from_normal`] when `dpdu` is degenerate.
    pub fn from_normal_tangent(n: Normal3, dpdu: Vec3) -> Self {
        let nv = n.to_vec();
        let s = dpdu - nv * nv.dot(dpdu);
        let len = s.norm();
        if !(len > 1e-8) || !len.is_finite() {
            return Self::from_normal(n);
        }
        let s = s / len;
        Self::new(s, nv.cross(s), nv)
    }

    /// World → local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bases_are_orthonormal_and_right_handed() {
        let normals = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.3, -0.4, 0.5),
            Vec3::new(-0.2, 0.9, -1e-7),
            Vec3::new(1e-8, -1e-8, -1.0),
        ];
        for n in normals {
            let n = n.normalize();
            let f = Frame::from_normal(n.to_normal());
            for (a, b) in [(f.s, f.t), (f.t, f.n), (f.n, f.s)] {
                assert!(a.dot(b).abs() < 1e-6);
            }
            for a in [f.s, f.t, f.n] {
                assert!((a.norm() - 1.0).abs() < 1e-6);
            }
            assert!(f.s.cross(f.t).approx_eq(f.n, 1e-6), "{n:?}");
            let v = Vec3::new(0.1, 0.2, 0.3);
            assert!(f.to_world(f.to_local(v)).approx_eq(v, 1e-6));
        }
    }

    #[test]
    fn axes_start_rows_of_sixteen_bytes() {
        assert_eq!(std::mem::size_of::<Frame>(), 48);
        assert_eq!(std::mem::align_of::<Frame>(), 16);
        assert_eq!(std::mem::offset_of!(Frame, s), 0);
        assert_eq!(std::mem::offset_of!(Frame, t), 16);
        assert_eq!(std::mem::offset_of!(Frame, n), 32);
        let f = Frame::new(Vec3::X, Vec3::Y, Vec3::Z);
        assert_eq!((f.s, f.t, f.n), (Vec3::X, Vec3::Y, Vec3::Z));
        assert_eq!(f, Frame::from_normal(Vec3::Z.to_normal()));
        assert_eq!(format!("{f:?}").matches("pad").count(), 0);
        let odd = Vec3::new(-0.0, f32::NAN, f32::from_bits(1));
        let g = Frame::new(odd, odd, odd);
        for a in [g.s, g.t, g.n] {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                odd.to_array().map(f32::to_bits)
            );
        }
    }

    #[test]
    fn tangent_frames_keep_the_tangent_direction() {
        let f = Frame::from_normal_tangent(Normal3::new(0.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 1.0));
        assert!(f.s.approx_eq(Vec3::X, 1e-6));
        assert!(f.t.approx_eq(Vec3::Y, 1e-6));
    }
}
