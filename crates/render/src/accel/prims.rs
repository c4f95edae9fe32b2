//! The primitives as the builders see them (box, centre, id) and the margin by which the
//! spatial subdivisions grow boxes so that no hit slips between cells.

use crate::geometry::Geometry;
use crate::math::{Bounds3, Point3, Vec3};

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
    let prim = |id| {
        let bounds = geometry.prim_bounds(id);
        (!bounds.is_empty()).then(|| BuildPrim {
            bounds,
            centroid: bounds.centroid(),
            id,
        })
    };
    let n = geometry.bounded_count();
    if n > 65536 {
        use rayon::prelude::*;
        (0..n).into_par_iter().filter_map(prim).collect()
    } else {
        (0..n).filter_map(prim).collect()
    }
}

/// The union of the boxes of `prims`.
pub(crate) fn union_bounds(prims: &[BuildPrim]) -> Bounds3 {
    prims.iter().fold(Bounds3::EMPTY, |b, p| b.union(p.bounds))
}

/// The margin by which the spatial subdivisions grow primitive boxes and their own bounds:
/// 2⁻¹⁶ of the largest extent of `scene` plus 2⁻²⁰ of its largest coordinate (dozens of ULPs,
/// so the grown box is strictly larger than the box on every axis), at least 10⁻³⁰.
pub(crate) fn margin(scene: &Bounds3) -> f32 {
    if scene.is_empty() {
        return 0.0;
    }
    let d = scene.diagonal();
    let ext = d.x.max(d.y).max(d.z);
    let mag = scene.min.to_vec().abs().max(scene.max.to_vec().abs());
    let mag = mag.x.max(mag.y).max(mag.z);
    (ext * (1.0 / 65536.0) + mag * (1.0 / 1_048_576.0)).max(1e-30)
}

/// `b` grown by `m` on every side.
#[inline]
pub(crate) fn inflate(b: Bounds3, m: f32) -> Bounds3 {
    let v = Vec3::new(m, m, m);
    Bounds3 {
        min: b.min - v,
        max: b.max + v,
    }
}
