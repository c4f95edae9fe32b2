//! Counters gathered while rendering (per thread, then summed).

use std::ops::AddAssign;

/// Ray and sample counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayStats {
    /// Closest-hit rays traced.
    pub rays: u64,
    /// Any-hit (shadow) rays traced.
    pub shadow_rays: u64,
    /// Acceleration-structure nodes visited.
    pub nodes: u64,
    /// Ray–primitive tests.
    pub prim_tests: u64,
    /// Samples rejected because their radiance was NaN or infinite.
    pub rejected_samples: u64,
    /// Camera samples taken.
    pub samples: u64,
}

impl RayStats {
    /// All rays traced.
    pub fn total_rays(&self) -> u64 {
        self.rays + self.shadow_rays
    }
}

impl AddAssign for RayStats {
    fn add_assign(&mut self, o: RayStats) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.nodes += o.nodes;
        self.prim_tests += o.prim_tests;
        self.rejected_samples += o.rejected_samples;
        self.samples += o.samples;
    }
}
