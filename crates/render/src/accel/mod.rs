//! Acceleration structures over the bounded primitives of a scene.
//!
//! Every structure answers the same two queries, closest hit and any hit, and returns exactly
//! what the linear list returns: each calls the one intersection routine of a primitive type
//! ([`crate::geometry::Geometry::intersect_prim`]) and breaks ties in `t` by primitive id.
//! Unbounded primitives (planes) are kept outside and tested by the scene.
//!
//! The spatial subdivisions ([`KdTree`], [`Grid`], [`Octree`]) reference a primitive from every
//! cell its box overlaps, so a hit found in one cell may lie in a later one, and a computed hit
//! may lie a little outside its primitive's box. They stay exact by the same two safeguards:
//! a small `margin` (dozens of ULPs of the scene's size) by which a primitive's box reaches
//! into neighbouring cells (the grid and the octree grow the boxes before assigning them to
//! cells, inclusive of boundaries; the kd-tree, which splits at box edges, instead thickens its
//! splitting planes by it during traversal, so that triangles sharing a vertex on a plane are not
//! duplicated), and traversal continues while the next cell's entry `t` is at most `t_limit` of
//! the best hit, so hits at equal `t` in later cells are still tested and the tie goes to the
//! smaller primitive id. A recently tested primitive is not tested again (a small mailbox).
//!
//! The [`Bvh`] (the default) is the fast one: 8-wide nodes and blocks of four triangles tested
//! with SIMD (the `simd` module, AVX2 chosen at run time). With the cargo feature `embree`, Intel
//! Embree 3 is available too (`AccelKind::Embree`) for comparisons; it is not bit-identical.

mod blocks;
mod bvh;
#[cfg(feature = "embree")]
mod embree;
mod grid;
mod kdtree;
mod list;
mod octree;
mod prims;
#[cfg(test)]
mod test_scenes;
mod visit;

pub use bvh::{BatchHits, Bvh, BvhNode};
#[cfg(feature = "embree")]
pub use embree::Embree;
pub use grid::Grid;
pub use kdtree::{KdNode, KdTree};
pub use list::List;
pub use octree::{Octree, OctreeNode};
pub use prims::{build_prims, BuildPrim};

use prims::{inflate, margin, union_bounds};

use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Ray, RayBatch, BATCH};
use crate::stats::RayStats;

/// Which acceleration structure to build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AccelKind {
    /// The linear list: every ray against every primitive.
    None,
    /// The bounding volume hierarchy (default).
    #[default]
    Bvh,
    /// The kd-tree (SAH, pbrt-v3 style).
    KdTree,
    /// The uniform grid (3D-DDA).
    Grid,
    /// The octree.
    Octree,
    /// Intel Embree 3 for mesh triangles (feature `embree`; hits agree with the others up to
    /// round-off only).
    #[cfg(feature = "embree")]
    Embree,
}

/// Batches with at most this many active rays are traced ray by ray (the last path of a batch
/// still alive): from two rays on, the sixteen-lane tests of a small scene cost less than the
/// rays one by one (cornell: 0.98x the time of a threshold of three).
pub const SCALAR_LANES: u32 = 1;

impl AccelKind {
    /// The command-line names, in order.
    #[cfg(not(feature = "embree"))]
    pub const NAMES: &'static [&'static str] = &["bvh", "kdtree", "grid", "octree", "none"];
    /// The command-line names, in order.
    #[cfg(feature = "embree")]
    pub const NAMES: &'static [&'static str] =
        &["bvh", "kdtree", "grid", "octree", "none", "embree"];

    /// Parses a command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "none" => Some(AccelKind::None),
            "bvh" => Some(AccelKind::Bvh),
            "kdtree" => Some(AccelKind::KdTree),
            "grid" => Some(AccelKind::Grid),
            "octree" => Some(AccelKind::Octree),
            #[cfg(feature = "embree")]
            "embree" => Some(AccelKind::Embree),
            _ => None,
        }
    }

    /// Parses a command-line name, with a message for an unknown one (and for `embree` in a
    /// build without the `embree` feature).
    pub fn parse(name: &str) -> Result<Self, String> {
        if let Some(k) = Self::from_name(name) {
            return Ok(k);
        }
        if name == "embree" {
            return Err("built without embree (rebuild with the cargo feature `embree`)".into());
        }
        Err(format!(
            "unknown acceleration structure '{name}' (expected one of: {})",
            Self::NAMES.join(", ")
        ))
    }
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
    /// The kd-tree.
    KdTree(KdTree),
    /// The uniform grid.
    Grid(Grid),
    /// The octree.
    Octree(Octree),
    /// Embree (triangles) with candela's BVH (other primitives).
    #[cfg(feature = "embree")]
    Embree(Embree),
}

impl Accel {
    /// Builds the structure of `kind` over the bounded primitives of `geometry`.
    pub fn build(kind: AccelKind, geometry: &Geometry) -> Self {
        match kind {
            AccelKind::None => Accel::List(List::new(geometry)),
            AccelKind::Bvh => {
                // Grown boxes: a primitive may report a hit that round-off puts a hair outside
                // its exact box, which the list would still find.
                let mut prims = build_prims(geometry);
                let m = margin(&union_bounds(&prims));
                for p in &mut prims {
                    p.bounds = inflate(p.bounds, m);
                }
                Accel::Bvh(Bvh::build(geometry, &prims))
            }
            AccelKind::KdTree => Accel::KdTree(KdTree::build(&build_prims(geometry))),
            AccelKind::Grid => Accel::Grid(Grid::build(&build_prims(geometry))),
            AccelKind::Octree => Accel::Octree(Octree::build(&build_prims(geometry))),
            #[cfg(feature = "embree")]
            AccelKind::Embree => Accel::Embree(Embree::build(geometry)),
        }
    }

    /// Memory held by the structure, in bytes (for Embree: candela's part only).
    pub fn memory(&self) -> usize {
        match self {
            Accel::List(_) => 0,
            Accel::Bvh(b) => b.memory(),
            Accel::KdTree(k) => k.memory(),
            Accel::Grid(g) => g.memory(),
            Accel::Octree(o) => o.memory(),
            #[cfg(feature = "embree")]
            Accel::Embree(_) => 0,
        }
    }

    /// A one-line description of the structure's size.
    pub fn describe(&self) -> String {
        match self {
            Accel::List(_) => "linear list".into(),
            Accel::Bvh(b) => format!(
                "{} nodes, {} triangle blocks",
                b.node_count(),
                b.block_count()
            ),
            Accel::KdTree(k) => format!(
                "{} nodes, depth {}, {} refs",
                k.node_count(),
                k.depth(),
                k.reference_count()
            ),
            Accel::Grid(g) => format!("{:?} cells, {} refs", g.resolution(), g.reference_count()),
            Accel::Octree(o) => format!("{} nodes, {} refs", o.node_count(), o.reference_count()),
            #[cfg(feature = "embree")]
            Accel::Embree(_) => "Embree 3".into(),
        }
    }

    /// The closest hit in `(ray.tmin, ray.tmax)`.
    #[inline]
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        match self {
            Accel::List(l) => l.intersect(geometry, ray, stats),
            Accel::Bvh(b) => b.intersect(geometry, ray, stats),
            Accel::KdTree(k) => k.intersect(geometry, ray, stats),
            Accel::Grid(g) => g.intersect(geometry, ray, stats),
            Accel::Octree(o) => o.intersect(geometry, ray, stats),
            #[cfg(feature = "embree")]
            Accel::Embree(e) => e.intersect(geometry, ray, stats),
        }
    }

    /// True when anything is hit in `(ray.tmin, ray.tmax)`.
    #[inline]
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        match self {
            Accel::List(l) => l.occluded(geometry, ray, stats),
            Accel::Bvh(b) => b.occluded(geometry, ray, stats),
            Accel::KdTree(k) => k.occluded(geometry, ray, stats),
            Accel::Grid(g) => g.occluded(geometry, ray, stats),
            Accel::Octree(o) => o.occluded(geometry, ray, stats),
            #[cfg(feature = "embree")]
            Accel::Embree(e) => e.occluded(geometry, ray, stats),
        }
    }

    /// The closest hit of every active lane of `rays` (the same hits as [`Accel::intersect`]
    /// ray by ray). Batches of at most [`SCALAR_LANES`] rays go ray by ray: the sixteen-lane
    /// kernels cost nearly the same for one ray as for sixteen.
    pub fn intersect_batch(
        &self,
        geometry: &Geometry,
        rays: &RayBatch,
        hits: &mut BatchHits,
        stats: &mut RayStats,
    ) {
        if let Accel::Bvh(b) = self {
            if rays.active.count_ones() > SCALAR_LANES {
                return b.intersect_batch(geometry, rays, hits, stats);
            }
        }
        *hits = [None; BATCH];
        for i in rays.lanes() {
            hits[i] = self.intersect(geometry, &rays.ray(i), stats);
        }
    }

    /// True when a batch of rays costs as much with a few active lanes as with all of them
    /// (a small scene's BVH tests every primitive against every lane at once), so that a lane
    /// whose path ends is best given the next sample at once. A large scene's BVH traces a
    /// batch of coherent camera rays as one packet: its batches start together.
    pub fn refills_lanes(&self) -> bool {
        match self {
            Accel::Bvh(b) => b.is_flat(),
            _ => true,
        }
    }

    /// The active lanes of `rays` that hit anything (bit i for lane i).
    pub fn occluded_batch(
        &self,
        geometry: &Geometry,
        rays: &RayBatch,
        stats: &mut RayStats,
    ) -> u32 {
        if let Accel::Bvh(b) = self {
            if rays.active.count_ones() > SCALAR_LANES {
                return b.occluded_batch(geometry, rays, stats);
            }
        }
        let mut hit = 0;
        for i in rays.lanes() {
            if self.occluded(geometry, &rays.ray(i), stats) {
                hit |= 1 << i;
            }
        }
        hit
    }
}

/// Small hand-made geometries and the comparison with the list shared by the unit tests of
/// the structures.
#[cfg(test)]
mod tests {
    use super::AccelKind;

    #[test]
    fn names_parse_with_clear_errors() {
        for name in AccelKind::NAMES {
            assert!(AccelKind::parse(name).is_ok(), "{name}");
        }
        #[cfg(not(feature = "embree"))]
        assert!(AccelKind::parse("embree")
            .unwrap_err()
            .contains("built without embree"));
        assert!(AccelKind::parse("quadtree")
            .unwrap_err()
            .contains("unknown"));
    }
}
