//! The BVH's memory layout: 8-wide nodes with their children's boxes in structure-of-arrays
//! form, child references, and blocks of four triangles; and the packing of triangle leaves
//! into those blocks.

use rayon::prelude::*;

use super::Bvh;
use crate::geometry::{Geometry, PrimRef as GeomPrim};

/// Children per node.
pub(super) const W: usize = 8;
/// From this depth on, the build splits ranges by count into `W` equal parts, which bounds the
/// depth at `MEDIAN_DEPTH + 11` (for up to 2³² primitives).
pub(super) const MEDIAN_DEPTH: u32 = 16;
/// Traversal stack: at most `W - 1` entries per level.
pub(super) const STACK: usize = (W - 1) * (MEDIAN_DEPTH as usize + 12);

/// A reference's kind bits: 0 for an inner node.
pub(super) const KIND_SHIFT: u32 = 30;
/// A leaf of triangles (in blocks of four).
pub(super) const TRI_LEAF: u32 = 1 << KIND_SHIFT;
/// A leaf of other primitives (a range of primitive ids).
pub(super) const OBJ_LEAF: u32 = 2 << KIND_SHIFT;
/// The primitive count of a leaf reference.
pub(super) const COUNT_MASK: u32 = (1 << KIND_SHIFT) - 1;

/// A node of `W` children.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct BvhNode {
    /// Child boxes: `b[plane][child]`, planes min x, y, z, max x, y, z.
    pub(super) b: [[f32; W]; 6],
    /// Inner child: node index; leaf: first block (triangles) or first id (others).
    pub(super) child: [u32; W],
    /// 0 for an inner child; otherwise the leaf kind and its primitive count.
    pub(super) meta: [u32; W],
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32 * W);

impl BvhNode {
    /// No children: inverted boxes, empty leaves.
    pub(super) const EMPTY: BvhNode = BvhNode {
        b: [
            [f32::INFINITY; W],
            [f32::INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::NEG_INFINITY; W],
        ],
        child: [0; W],
        meta: [OBJ_LEAF; W],
    };
}

/// Four triangles: exact copies of their vertices (`v[vertex][axis][lane]`) and their
/// primitive ids (`u32::MAX` in unused lanes).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Tri4 {
    pub(super) v: [[[f32; 4]; 3]; 3],
    pub(super) id: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<Tri4>() == 160);

/// A child reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Ref {
    /// An inner node's index, or where a leaf's data starts.
    pub(super) child: u32,
    /// 0 for an inner node, else the leaf kind and its primitive count.
    pub(super) meta: u32,
}

impl Ref {
    pub(super) const EMPTY: Ref = Ref {
        child: 0,
        meta: OBJ_LEAF,
    };
}

impl Bvh {
    /// Replaces the triangle leaves' ranges of primitive ids by blocks of four triangles, in
    /// node order.
    pub(super) fn pack_triangles(&mut self, geometry: &Geometry) {
        // Each block: the first primitive (in `ids`) and how many lanes it uses.
        let mut src: Vec<(u32, u32)> = Vec::new();
        let mut pack = |r: &mut Ref| {
            if r.meta & !COUNT_MASK == TRI_LEAF {
                let n = r.meta & COUNT_MASK;
                let first = src.len() as u32;
                for k in (0..n).step_by(4) {
                    src.push((r.child + k, (n - k).min(4)));
                }
                r.child = first;
            }
        };
        pack(&mut self.root);
        for node in &mut self.nodes {
            for i in 0..W {
                let mut r = Ref {
                    child: node.child[i],
                    meta: node.meta[i],
                };
                pack(&mut r);
                node.child[i] = r.child;
            }
        }
        let ids = &self.ids;
        let fill = |&(first, lanes): &(u32, u32)| {
            let mut t = Tri4 {
                v: [[[0.0; 4]; 3]; 3],
                id: [u32::MAX; 4],
            };
            for l in 0..lanes as usize {
                let id = ids[first as usize + l];
                let GeomPrim::Triangle { mesh, tri } = geometry.prim(id) else {
                    unreachable!("a triangle leaf holds triangles only")
                };
                let vs = geometry.meshes()[mesh as usize].vertices(tri);
                for (k, p) in vs.iter().enumerate() {
                    t.v[k][0][l] = p.x;
                    t.v[k][1][l] = p.y;
                    t.v[k][2][l] = p.z;
                }
                t.id[l] = id;
            }
            // Unused lanes repeat the first triangle (finite values) and are masked by id.
            for l in lanes as usize..4 {
                for k in 0..3 {
                    for a in 0..3 {
                        t.v[k][a][l] = t.v[k][a][0];
                    }
                }
            }
            t
        };
        self.tris = if src.len() > 4096 {
            src.par_iter().map(fill).collect()
        } else {
            src.iter().map(fill).collect()
        };
    }
}
