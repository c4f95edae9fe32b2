//! What the spatial subdivisions (grid, kd-tree, octree) share: clipping a ray to a box, the
//! limit up to which later cells may still hold the closest hit, a mailbox against testing a
//! primitive twice, and the closest-hit and any-hit visitors called with each cell's primitives.

use super::closest;
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Bounds3, Ray, Vec3};
use crate::shape::ShearedRay;
use crate::stats::RayStats;

/// Relative slack of `t_limit`.
const T_SLACK: f32 = 1.0 / 65536.0;

/// The largest cell-entry parameter that may still hold a hit at `t` or closer: `t` plus a
/// relative slack that covers the round-off of the cell-boundary parameters.
#[inline(always)]
pub(crate) fn t_limit(t: f32) -> f32 {
    t + t.abs() * T_SLACK
}

/// The parameter interval `[t0, t1]` where `ray` is inside `b`, clipped to the ray's own
/// interval; `None` when it misses. Unlike a plain slab test it never lets `0·∞ = NaN` decide:
/// an axis the ray is parallel to (`d = ±0`) only checks that the origin lies in the slab, and
/// an origin exactly on a slab plane gives parameter 0 there. The far parameter grows by 2γ₃
/// (pbrt) to cover round-off.
#[inline]
pub(crate) fn clip(b: &Bounds3, ray: &Ray, inv: Vec3) -> Option<(f32, f32)> {
    let mut t0 = ray.tmin;
    let mut t1 = ray.tmax;
    for a in 0..3 {
        let o = ray.o[a];
        if ray.d[a] == 0.0 {
            if !(o >= b.min[a] && o <= b.max[a]) {
                return None;
            }
            continue;
        }
        let ta = if b.min[a] == o {
            0.0
        } else {
            (b.min[a] - o) * inv[a]
        };
        let tb = if b.max[a] == o {
            0.0
        } else {
            (b.max[a] - o) * inv[a]
        };
        let (near, far) = if ta <= tb { (ta, tb) } else { (tb, ta) };
        let far = far * (1.0 + 2.0 * crate::math::GAMMA3);
        t0 = if near > t0 { near } else { t0 };
        t1 = if far < t1 { far } else { t1 };
    }
    (t0 <= t1).then_some((t0, t1))
}

/// The reciprocal of each component of `d`.
#[inline]
pub(crate) fn inv_dir(d: Vec3) -> Vec3 {
    Vec3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z)
}

/// The ids of the last [`MAILBOX`] primitives tested by one ray (a ring, on the stack):
/// spatial subdivisions list a primitive in several cells, and a neighbouring cell need not
/// test it again. Skipping is exact: a second test with the ray's interval since shortened
/// cannot produce a closer hit than the first.
struct Mailbox {
    ids: [u32; MAILBOX],
    next: usize,
}

/// Size of the mailbox.
const MAILBOX: usize = 8;

impl Mailbox {
    #[inline(always)]
    fn new() -> Self {
        Self {
            ids: [u32::MAX; MAILBOX],
            next: 0,
        }
    }

    /// True when `id` was tested recently; otherwise records it.
    #[inline(always)]
    fn seen(&mut self, id: u32) -> bool {
        if self.ids.contains(&id) {
            return true;
        }
        self.ids[self.next % MAILBOX] = id;
        self.next += 1;
        false
    }
}

/// What a spatial subdivision does with the primitive list of each cell (leaf) it visits,
/// front to back.
pub(crate) trait CellVisitor {
    /// Tests the primitives of a cell; false to stop the traversal.
    fn cell(&mut self, prims: &[u32]) -> bool;
    /// The largest entry parameter of a cell still worth visiting.
    fn limit(&self) -> f32;
}

/// What both visitors share: the geometry, the sheared ray, the mailbox and the test count.
struct Tester<'a> {
    geometry: &'a Geometry,
    sr: ShearedRay,
    tests: u64,
    mailbox: Mailbox,
}

impl<'a> Tester<'a> {
    #[inline(always)]
    fn new(geometry: &'a Geometry, ray: &Ray) -> Self {
        Self {
            geometry,
            sr: ShearedRay::new(ray),
            tests: 0,
            mailbox: Mailbox::new(),
        }
    }

    /// Intersects primitive `id` with `ray`, unless the mailbox says it was just tested.
    #[inline(always)]
    fn test(&mut self, id: u32, ray: &Ray) -> Option<Hit> {
        if self.mailbox.seen(id) {
            return None;
        }
        self.tests += 1;
        self.geometry.intersect_prim(id, ray, &self.sr)
    }

    /// Adds the counters to `stats`.
    #[inline(always)]
    fn count(&self, visited: u64, stats: &mut RayStats) {
        stats.nodes += visited;
        stats.prim_tests += self.tests;
    }
}

/// Closest-hit queries: keeps the best hit, shortens the ray to one ULP past it (so ties at the
/// same `t` are still tested and go to the smaller id), and asks for cells entered up to
/// `t_limit` of it.
pub(crate) struct ClosestVisitor<'a> {
    tester: Tester<'a>,
    ray: Ray,
    best: Option<Hit>,
}

impl<'a> ClosestVisitor<'a> {
    /// The closest hit of `ray` found by `traverse` (which returns the number of nodes it
    /// visited), with the counters added to `stats`.
    #[inline(always)]
    pub(crate) fn run(
        geometry: &'a Geometry,
        ray: &Ray,
        stats: &mut RayStats,
        traverse: impl FnOnce(&mut Self) -> u64,
    ) -> Option<Hit> {
        let mut v = Self {
            tester: Tester::new(geometry, ray),
            ray: *ray,
            best: None,
        };
        let visited = traverse(&mut v);
        v.tester.count(visited, stats);
        v.best
    }
}

impl CellVisitor for ClosestVisitor<'_> {
    #[inline(always)]
    fn cell(&mut self, prims: &[u32]) -> bool {
        for &id in prims {
            if let Some(h) = self.tester.test(id, &self.ray) {
                if closest(&mut self.best, h) {
                    self.ray.tmax = h.t.next_up();
                }
            }
        }
        true
    }

    #[inline(always)]
    fn limit(&self) -> f32 {
        match &self.best {
            Some(b) => t_limit(b.t),
            None => f32::INFINITY,
        }
    }
}

/// Any-hit queries: stops at the first hit.
pub(crate) struct AnyVisitor<'a> {
    tester: Tester<'a>,
    ray: &'a Ray,
    found: bool,
}

impl<'a> AnyVisitor<'a> {
    /// Whether `traverse` (which returns the number of nodes it visited) found anything along
    /// `ray`, with the counters added to `stats`.
    #[inline(always)]
    pub(crate) fn run(
        geometry: &'a Geometry,
        ray: &'a Ray,
        stats: &mut RayStats,
        traverse: impl FnOnce(&mut Self) -> u64,
    ) -> bool {
        let mut v = Self {
            tester: Tester::new(geometry, ray),
            ray,
            found: false,
        };
        let visited = traverse(&mut v);
        v.tester.count(visited, stats);
        v.found
    }
}

impl CellVisitor for AnyVisitor<'_> {
    #[inline(always)]
    fn cell(&mut self, prims: &[u32]) -> bool {
        for &id in prims {
            if self.tester.test(id, self.ray).is_some() {
                self.found = true;
                return false;
            }
        }
        true
    }

    #[inline(always)]
    fn limit(&self) -> f32 {
        f32::INFINITY
    }
}
