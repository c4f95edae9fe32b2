//! The linear list (`--accel none`): tests every primitive.

use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::Ray;
use crate::shape::ShearedRay;
use crate::stats::RayStats;

/// No structure at all: the reference every other structure must match.
#[derive(Clone, Debug)]
pub struct List {
    count: u32,
}

impl List {
    /// The list of all bounded primitives of `geometry`.
    pub fn new(geometry: &Geometry) -> Self {
        Self {
            count: geometry.bounded_count(),
        }
    }

    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        let sr = ShearedRay::new(ray);
        let mut r = *ray;
        let mut best: Option<Hit> = None;
        for id in 0..self.count {
            stats.prim_tests += 1;
            if let Some(h) = geometry.intersect_prim(id, &r, &sr) {
                if super::closest(&mut best, h) {
                    r.tmax = h.t.next_up();
                }
            }
        }
        best
    }

    /// Any hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        let sr = ShearedRay::new(ray);
        (0..self.count).any(|id| {
            stats.prim_tests += 1;
            geometry.intersect_prim(id, ray, &sr).is_some()
        })
    }
}
