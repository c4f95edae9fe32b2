//! Acceleration structures over the bounded primitives of a scene.
//!
//! Every structure answers the same two queries, closest hit and any hit, and returns exactly
//! what the linear list returns: each calls the one intersection routine of a primitive type
//! ([`crate::scene::Geometry::intersect_prim`]) and breaks ties in `t` by primitive id.
//! Unbounded primitives (planes) are kept outside and tested by the scene.

mod bvh;
mod list;

pub use bvh::{Bvh, BvhNode};
pub use list::List;

use crate::interaction::Hit;
use crate::math::{Bounds3, Point3, Ray};
use crate::scene::Geometry;
use crate::stats::RayStats;

/// Which acceleration structure to build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AccelKind {
    /// The linear list: every ray against every primitive.
    None,
    /// The bounding volume hierarchy (default).
    #[default]
    Bvh,
}

impl AccelKind {
    /// The command-line names, in order.
    pub const NAMES: &'static [&'static str] = &["bvh", "none"];

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "none" => Some(AccelKind::None),
            "bvh" => Some(AccelKind::Bvh),
            _ => None,
        }
    }
}

/// A primitive as the builders see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildPrim {
    /// Its box.
    pub bounds: Bounds3,
    /// The box's centre.
    pub centroid: Point3,
    /// Its primitive id.
    pub id: u32,
}

/// The build records of all bounded primitives of `geometry` (empty boxes left out).
pub fn build_prims(geometry: &Geometry) -> Vec<BuildPrim> {
    (0..geometry.bounded_count())
        .filter_map(|id| {
            let bounds = geometry.prim_bounds(id);
            (!bounds.is_empty()).then(|| BuildPrim {
                bounds,
                centroid: bounds.centroid(),
                id,
            })
        })
        .collect()
}

/// Keeps `h` in `best` when it is closer (ties to the smaller id); true when it was kept.
#[inline]
pub(crate) fn closest(best: &mut Option<Hit>, h: Hit) -> bool {
    if best.is_none_or(|b| h.closer_than(&b)) {
        *best = Some(h);
        true
    } else {
        false
    }
}

/// A built acceleration structure.
#[derive(Clone, Debug)]
pub enum Accel {
    /// The linear list.
    List(List),
    /// The BVH.
    Bvh(Bvh),
}

impl Accel {
    /// Builds the structure of `kind` over the bounded primitives of `geometry`.
    pub fn build(kind: AccelKind, geometry: &Geometry) -> Self {
        match kind {
            AccelKind::None => Accel::List(List::new(geometry)),
            AccelKind::Bvh => Accel::Bvh(Bvh::build(build_prims(geometry))),
        }
    }

    /// The closest hit in `(ray.tmin, ray.tmax)`.
    #[inline]
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        match self {
            Accel::List(l) => l.intersect(geometry, ray, stats),
            Accel::Bvh(b) => b.intersect(geometry, ray, stats),
        }
    }

    /// True when anything is hit in `(ray.tmin, ray.tmax)`.
    #[inline]
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        match self {
            Accel::List(l) => l.occluded(geometry, ray, stats),
            Accel::Bvh(b) => b.occluded(geometry, ray, stats),
        }
    }
}
