//! Up to [`BATCH`] rays traced together, in structure-of-arrays form: the path tracer advances
//! that many paths at once so that small scenes can test each primitive against all of them
//! with one SIMD operation per step.

use super::{Point3, Ray, Vec3};

/// Rays per batch.
pub const BATCH: usize = 16;

/// Up to [`BATCH`] rays; lanes whose bit is clear in `active` are ignored.
#[derive(Clone, Copy, Debug)]
pub struct RayBatch {
    /// Origins, by axis.
    pub o: [[f32; BATCH]; 3],
    /// Directions, by axis.
    pub d: [[f32; BATCH]; 3],
    /// Smallest accepted parameters.
    pub tmin: [f32; BATCH],
    /// Largest accepted parameters.
    pub tmax: [f32; BATCH],
    /// Bit i set when lane i holds a ray.
    pub active: u32,
    /// Bit i set when lane i may go down a deep tree in a packet with other such lanes of
    /// the same direction octant (a pixel's camera rays, the shadow rays of its first hits):
    /// the caller's hint, clear for rays from scattered points, which a packet would take
    /// through the union of their nodes. The hits are the same either way. All set by default.
    pub coherent: u32,
}

impl Default for RayBatch {
    fn default() -> Self {
        Self {
            o: [[0.0; BATCH]; 3],
            d: [[0.0; BATCH]; 3],
            tmin: [0.0; BATCH],
            tmax: [0.0; BATCH],
            active: 0,
            coherent: u32::MAX,
        }
    }
}

impl RayBatch {
    /// Puts `ray` in lane `i` and marks the lane active.
    #[inline]
    pub fn set(&mut self, i: usize, ray: &Ray) {
        self.o[0][i] = ray.o.x;
        self.o[1][i] = ray.o.y;
        self.o[2][i] = ray.o.z;
        self.d[0][i] = ray.d.x;
        self.d[1][i] = ray.d.y;
        self.d[2][i] = ray.d.z;
        self.tmin[i] = ray.tmin;
        self.tmax[i] = ray.tmax;
        self.active |= 1 << i;
    }

    /// The ray of lane `i`.
    #[inline]
    pub fn ray(&self, i: usize) -> Ray {
        Ray {
            o: Point3::new(self.o[0][i], self.o[1][i], self.o[2][i]),
            d: Vec3::new(self.d[0][i], self.d[1][i], self.d[2][i]),
            tmin: self.tmin[i],
            tmax: self.tmax[i],
        }
    }

    /// The active lanes, in order.
    #[inline]
    pub fn lanes(&self) -> impl Iterator<Item = usize> {
        lanes(self.active)
    }
}

/// The lanes of the mask `m` (bit i for lane i), lowest first.
#[inline(always)]
pub fn lanes(mut m: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            i
        })
    })
}
