//! The BVH's memory layout: 8-wide nodes with their children's boxes in structure-of-arrays
//! form, child references, and blocks of four triangles; and the packing of triangle leaves
//! into those blocks.

use super::Bvh;
use crate::accel::blocks::{Box4, Quad4, Sphere4};
use crate::geometry::{Geometry, PrimRef as GeomPrim};
use crate::mem::HugeSlice;
use crate::shape::Shape;

/// Children per node.
pub(super) const W: usize = 8;
/// From this depth on, the build splits ranges by count into `W` equal parts, which bounds the
/// depth at `MEDIAN_DEPTH + 11` (for up to 2³² primitives).
pub(super) const MEDIAN_DEPTH: u32 = 16;
/// Traversal stack: at most `W - 1` entries per level.
pub(super) const STACK: usize = (W - 1) * (MEDIAN_DEPTH as usize + 12);

/// A reference's kind bits: 0 for an inner node, else the leaf's [`Kind`] + 1.
pub(super) const KIND_SHIFT: u32 = 28;
/// A leaf of triangles (in blocks of four).
pub(super) const TRI_LEAF: u32 = (Kind::Tri as u32 + 1) << KIND_SHIFT;
/// A leaf of other primitives (a range of primitive ids, tested one by one).
pub(super) const OBJ_LEAF: u32 = (Kind::Other as u32 + 1) << KIND_SHIFT;
/// A leaf of parallelograms (in blocks of four).
pub(super) const QUAD_LEAF: u32 = (Kind::Quad as u32 + 1) << KIND_SHIFT;
/// A leaf of spheres (in blocks of four).
pub(super) const SPHERE_LEAF: u32 = (Kind::Sphere as u32 + 1) << KIND_SHIFT;
/// A leaf of boxes (in blocks of four).
pub(super) const BOX_LEAF: u32 = (Kind::Box as u32 + 1) << KIND_SHIFT;
/// The primitive count of a leaf reference.
pub(super) const COUNT_MASK: u32 = (1 << KIND_SHIFT) - 1;

/// What a leaf holds: primitives of one kind. Triangles, parallelograms, spheres and boxes
/// (those whose placement is affine) are packed into blocks of four tested at once; the
/// others are tested one by one through [`Geometry::intersect_prim`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(super) enum Kind {
    Other = 0,
    Tri = 1,
    Quad = 2,
    Sphere = 3,
    Box = 4,
}

/// Number of [`Kind`]s.
pub(super) const KINDS: usize = 5;

impl Kind {
    /// The kind of primitive `id`.
    pub(super) fn of(geometry: &Geometry, id: u32) -> Kind {
        match geometry.prim(id) {
            GeomPrim::Triangle { .. } => Kind::Tri,
            GeomPrim::Object(o) => match &geometry.objects()[o as usize].shape {
                Shape::Parallelogram(_) => Kind::Quad,
                Shape::Sphere(s) if s.has_affine_inverse() => Kind::Sphere,
                Shape::Cube(c) if c.is_affine() => Kind::Box,
                _ => Kind::Other,
            },
        }
    }

    /// The kind numbered `b` (as stored in build records).
    pub(super) fn from_bits(b: u32) -> Kind {
        match b {
            1 => Kind::Tri,
            2 => Kind::Quad,
            3 => Kind::Sphere,
            4 => Kind::Box,
            _ => Kind::Other,
        }
    }

    /// Leaves of this kind go into blocks of four.
    pub(super) fn blocked(self) -> bool {
        self != Kind::Other
    }
}

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
    pub(super) fn pack_triangles(&mut self, nodes: &mut [BvhNode], geometry: &Geometry) {
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
        for node in nodes.iter_mut() {
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
            HugeSlice::from_fn_par(src.len(), |i| fill(&src[i]))
        } else {
            HugeSlice::new(&src.iter().map(fill).collect::<Vec<_>>())
        };
    }

    /// Replaces the ranges of primitive ids of parallelogram, sphere and box leaves by blocks
    /// of four of their kind, in node order (unused lanes repeat the leaf's first primitive and
    /// have the id `u32::MAX`).
    pub(super) fn pack_objects(&mut self, nodes: &mut [BvhNode], geometry: &Geometry) {
        let objects = geometry.objects();
        let object = |id: u32| match geometry.prim(id) {
            GeomPrim::Object(o) => &objects[o as usize].shape,
            GeomPrim::Triangle { .. } => unreachable!("an object leaf holds no triangles"),
        };
        let mut refs: Vec<(usize, usize)> = vec![(usize::MAX, 0)];
        refs.extend((0..nodes.len()).flat_map(|n| (0..W).map(move |c| (n, c))));
        for (n, c) in refs {
            let r = if n == usize::MAX {
                self.root
            } else {
                Ref {
                    child: nodes[n].child[c],
                    meta: nodes[n].meta[c],
                }
            };
            let kind = r.meta & !COUNT_MASK;
            if r.meta == 0 || !(kind == QUAD_LEAF || kind == SPHERE_LEAF || kind == BOX_LEAF) {
                continue;
            }
            let count = (r.meta & COUNT_MASK) as usize;
            let first = r.child as usize;
            let start = match kind {
                QUAD_LEAF => self.quads.len(),
                SPHERE_LEAF => self.spheres.len(),
                _ => self.boxes.len(),
            };
            for chunk in self.ids[first..first + count].chunks(4) {
                let mut lane_ids = [u32::MAX; 4];
                lane_ids[..chunk.len()].copy_from_slice(chunk);
                match kind {
                    QUAD_LEAF => {
                        let qs: Vec<_> = chunk
                            .iter()
                            .map(|&id| match object(id) {
                                Shape::Parallelogram(p) => p,
                                _ => unreachable!("a parallelogram leaf"),
                            })
                            .collect();
                        self.quads.push((Quad4::new(&qs), lane_ids));
                    }
                    SPHERE_LEAF => {
                        let ss: Vec<_> = chunk
                            .iter()
                            .map(|&id| match object(id) {
                                Shape::Sphere(s) => s,
                                _ => unreachable!("a sphere leaf"),
                            })
                            .collect();
                        self.spheres.push((Sphere4::new(&ss), lane_ids));
                    }
                    _ => {
                        let cs: Vec<_> = chunk
                            .iter()
                            .map(|&id| match object(id) {
                                Shape::Cube(c) => c,
                                _ => unreachable!("a box leaf"),
                            })
                            .collect();
                        self.boxes.push((Box4::new(&cs), lane_ids));
                    }
                }
            }
            if n == usize::MAX {
                self.root.child = start as u32;
            } else {
                nodes[n].child[c] = start as u32;
            }
        }
    }
}
