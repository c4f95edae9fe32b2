//! Patches as seen from outside the solver: where they are, what they reflect and emit, and
//! their radiosity.

use super::mesh::Meshing;
use crate::math::{Point3, Vec3};

/// Which side of a surface a patch is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The side the shape's normal points to.
    Front,
    /// The other side.
    Back,
}

/// A patch as seen from outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchInfo {
    /// The scene primitive it lies on.
    pub prim: u32,
    /// The primitive's face (box face, polyhedron plane; 0 otherwise).
    pub face: u32,
    /// Its side.
    pub side: Side,
    /// Area.
    pub area: f64,
    /// Centre (on the true surface).
    pub centre: Point3,
    /// Unit normal of its side.
    pub normal: Vec3,
    /// Reflectance ρ.
    pub reflectance: [f64; 3],
    /// Emitted radiosity E = π L_e.
    pub emission: [f64; 3],
    /// Radiosity B (zero before a solve).
    pub radiosity: [f64; 3],
}

/// The patches of `m` with radiosity `b` (zero where `b` is shorter).
pub(super) fn infos(m: &Meshing, b: &[[f64; 3]]) -> Vec<PatchInfo> {
    m.patches
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let s = &m.surfaces[m.elements[p.elem as usize].surface as usize];
            PatchInfo {
                prim: s.prim,
                face: s.face,
                side: if p.side == 0 { Side::Front } else { Side::Back },
                area: p.area,
                centre: p.centre,
                normal: p.normal,
                reflectance: p.rho,
                emission: p.emit,
                radiosity: b.get(i).copied().unwrap_or([0.0; 3]),
            }
        })
        .collect()
}
