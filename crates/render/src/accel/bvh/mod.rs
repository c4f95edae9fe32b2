//! Bounding volume hierarchy: an 8-wide tree built by binned SAH, with triangles stored in leaf
//! order, four to a block. [`layout`] holds the node and block formats, [`build`] the binned
//! SAH build, [`traverse`] the closest-hit and any-hit traversals.
//!
//! Layout: a node holds the boxes of its eight children in structure-of-arrays form (`b[plane]
//! [child]`, planes min x, y, z then max x, y, z) and a reference per child: an inner node's
//! index, or a leaf (its kind, its primitive count and where its data starts), 256 bytes in all.
//! Triangle leaves point into [`Tri4`] blocks that hold exact copies of the vertex positions of
//! four triangles (one lane each) with their primitive ids, 160 bytes; other leaves point into
//! the list of primitive ids in leaf order and go through [`Geometry::intersect_prim`]. A leaf
//! is never mixed. Nodes and triangle blocks are [`HugeSlice`]s: on huge pages when large, since
//! incoherent rays read them at random and would otherwise miss the TLB. Unused child slots hold an inverted box and an empty leaf, so that even a
//! NaN ray, which "hits" every box, only visits real nodes.
//!
//! Build (Wald 2007; Embree): primitives are binned by centroid ([`BINS`] bins on each axis) and
//! the split of lowest surface-area cost is taken, or a leaf when that is cheaper (cost of a
//! triangle range: its number of 4-blocks; of other primitives: [`OBJ_COST`] each; of a node:
//! [`TRAVERSAL_COST`]). A node is widened by splitting its child of largest area until it has
//! eight. Subtrees of more than [`build::PARALLEL_THRESHOLD`] primitives are built in parallel, each
//! into its own node array that the parent appends (inner references shifted); binning of large
//! ranges is parallel too; build records are 32 bytes and partitioned in place (no allocation
//! per node). Below [`MEDIAN_DEPTH`] splits are by count, which bounds the depth and so the
//! traversal stack (a fixed array on the kernel's frame, [`crate::mem::Stack`], not cleared
//! for each ray).
//!
//! Traversal: the eight boxes of a node are tested at once ([`crate::simd`]: one AVX register,
//! or two SSE ones), hit children are visited nearest entry first with the others on the stack
//! with their entry distance; entries beyond the current closest hit are dropped when popped.
//! Shadow rays take the hit children in sequence, as Embree's any-hit traversal does (the last
//! next, the others pushed, no distances compared, and none dropped when popped: their far end
//! never moves), and stop at the first hit. Every child about to be visited, and every child a closest-hit query pushes, is
//! prefetched, all of it (the four cache lines of a node, every block of a leaf), so that its
//! lines load at once rather than one after another as the box test, then the child
//! references, reach them: this matters for incoherent rays, which miss the caches. The
//! children a shadow ray pushes are not: it often stops before it comes back to them (camera
//! rays' any-hit queries 1.05× faster, random rays' 0.95×). A batch's rays that go one by one
//! share one choice of instruction set (`Bvh::traverse_lanes`); a single ray's query is made
//! inside the kernel compiled for that instruction set. Two of them
//! interleaved step by step, so that one's loads overlap the other's tests, made random rays
//! 1.28× faster but a pixel's first-bounce rays 0.88× and a meshes frame 0.89×. (On the rays
//! of a frame of the bench's meshes, dumped and traced back to back on one thread: a
//! first-bounce ray 127 ns here against 119 ns in Embree's `rtcIntersect1`; the first
//! vertices' shadow rays 67 ns in packets against 49 ns in `rtcOccluded16`; deeper shadow rays
//! 213 ns against 190 ns. In the frame a bounce ray takes 1.06× its time back to back. A
//! first-bounce ray of the accelerator bench's bumpy sphere takes about 1300 instructions
//! here against 890 in Embree. Embree as the frame's accelerator made that frame 1.14× as
//! long; in Mitsuba's own render of it, Embree takes 4.3 s of 6.0 on one thread, against
//! 4.7 s of traversal here.)
//! A block of four triangles is tested at once by the same arithmetic as
//! [`crate::shape::intersect_triangle`], lane by lane, so that `t` and the barycentrics are
//! bit-identical to [`crate::shape::Mesh::intersect`]. The ray's `tmax` is one ULP above the
//! closest hit so far, so hits at equal `t` are still tested and go to the smaller id, exactly
//! as in the list. The sheared ray of the triangle test and the reciprocal direction are
//! computed once per ray (and not at all for scenes without triangles).
//!
//! Batches of rays ([`batch`]): each group of coherent rays (a pixel's camera rays, its shadow
//! rays towards a small light) goes down the tree together as one packet ([`packet`]), with the
//! same hits as ray by ray; parallelograms, spheres and boxes are tested sixteen rays at a time
//! by lane-exact tests ([`lanes`]).

mod batch;
mod build;
mod lanes;
mod layout;
mod packet;
mod traverse;

pub use batch::BatchHits;
pub use layout::{BvhNode, Tri4};

use lanes::FlatPrim;

use super::blocks::{Box4, Quad4, Sphere4};
use crate::mem::HugeSlice;
use layout::Ref;

/// An 8-wide BVH over the bounded primitives of a geometry.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// Nodes and triangle blocks, read at random: on huge pages when large.
    nodes: HugeSlice<BvhNode>,
    root: Ref,
    tris: HugeSlice<Tri4>,
    /// Blocks of four parallelograms, spheres and boxes, with their lanes' primitive ids.
    quads: Vec<(Quad4, [u32; 4])>,
    spheres: Vec<(Sphere4, [u32; 4])>,
    boxes: Vec<(Box4, [u32; 4])>,
    /// When every child of the root is a leaf (small scenes): those leaves, tested one after
    /// the other without box tests or a stack.
    flat: Vec<Ref>,
    /// For batches of rays through a flat tree: its parallelograms, spheres, boxes and
    /// triangles in id order (tested sixteen rays at a time), and its other leaves (tested
    /// ray by ray).
    flat_prims: Vec<FlatPrim>,
    flat_rest: Vec<Ref>,
    /// Some of `flat_prims` are triangles (the batch then makes the rays' shears).
    flat_triangles: bool,
    /// Primitive ids in leaf order (other leaves index it).
    ids: Vec<u32>,
}

impl Default for Bvh {
    fn default() -> Self {
        Self {
            nodes: HugeSlice::default(),
            root: Ref::EMPTY,
            tris: HugeSlice::default(),
            quads: Vec::new(),
            spheres: Vec::new(),
            boxes: Vec::new(),
            flat: Vec::new(),
            flat_prims: Vec::new(),
            flat_rest: Vec::new(),
            flat_triangles: false,
            ids: Vec::new(),
        }
    }
}

impl Bvh {
    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of blocks of four primitives (triangles, parallelograms, spheres, boxes).
    pub fn block_count(&self) -> usize {
        self.tris.len() + self.quads.len() + self.spheres.len() + self.boxes.len()
    }

    /// Memory used by nodes, triangle blocks and the primitive order, in bytes.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<BvhNode>()
            + self.tris.len() * std::mem::size_of::<Tri4>()
            + self.quads.len() * std::mem::size_of::<(Quad4, [u32; 4])>()
            + self.spheres.len() * std::mem::size_of::<(Sphere4, [u32; 4])>()
            + self.boxes.len() * std::mem::size_of::<(Box4, [u32; 4])>()
            + self.ids.len() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::traverse::{RayBox, TriRay};
    use super::*;
    use crate::accel::build_prims;
    use crate::accel::prims::{inflate, margin};
    use crate::accel::test_scenes::{check_against_list, parallelogram_scene, triangles};
    use crate::accel::BuildPrim;
    use crate::geometry::Geometry;
    use crate::math::Ray;
    use crate::math::{Point3, Vec3};
    use crate::shape::ShearedRay;
    use crate::stats::RayStats;

    fn bvh(g: &Geometry) -> Bvh {
        let m = margin(&g.bounds());
        let prims: Vec<BuildPrim> = build_prims(g)
            .into_iter()
            .map(|p| BuildPrim {
                bounds: inflate(p.bounds, m),
                ..p
            })
            .collect();
        Bvh::build(g, &prims)
    }

    fn check(g: &Geometry) {
        let b = bvh(g);
        check_against_list(
            g,
            |g, r, s| b.intersect(g, r, s),
            |g, r, s| b.occluded(g, r, s),
        );
    }

    #[test]
    fn agrees_with_the_list_on_flat_and_duplicated_shapes() {
        check(&parallelogram_scene());
    }

    #[test]
    fn agrees_with_the_list_on_a_triangle_soup() {
        let mut rng = crate::sampling::Pcg32::new(3, 4);
        let mut tris = Vec::new();
        for _ in 0..500 {
            let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
            let p = |rng: &mut crate::sampling::Pcg32| {
                (c + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).to_point()
            };
            let t = [p(&mut rng), p(&mut rng), p(&mut rng)];
            tris.push(t);
            if tris.len() % 7 == 0 {
                // Exact duplicates: equal t, the smaller id must win.
                tris.push(t);
            }
        }
        let g = triangles(&tris);
        let b = bvh(&g);
        assert!(b.node_count() > 1 && b.block_count() >= tris.len() / 4);
        check(&g);
    }

    /// The single-ray kernels compiled for each instruction set (SSE, AVX2, AVX2 with the
    /// AVX-512VL registers: the CPU's best below each cap) find the same hits.
    #[test]
    fn every_instruction_set_traverses_alike() {
        use crate::simd::SimdLevel;
        let mut rng = crate::sampling::Pcg32::new(5, 9);
        let mut tris = Vec::new();
        for _ in 0..3000 {
            let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0;
            let mut p =
                || (c + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())).to_point();
            tris.push([p(), p(), p()]);
        }
        let g = triangles(&tris);
        let b = bvh(&g);
        assert!(b.node_count() > 1 && b.flat.is_empty());
        let mut st = RayStats::default();
        let mut hits = 0;
        for i in 0..2000 {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 30.0;
            let o = o - Vec3::new(5.0, 5.0, 5.0);
            let target = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 21.0;
            let mut r = Ray::new(o.to_point(), target - o);
            if i % 3 == 0 {
                r.tmax = 4.0;
            }
            let want = (b.intersect(&g, &r, &mut st), b.occluded(&g, &r, &mut st));
            hits += want.0.is_some() as u32;
            for level in [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512] {
                assert_eq!(b.hits_at(level, &g, &r), want, "{level:?} {r:?}");
            }
        }
        assert!(hits > 500 && hits < 1900, "{hits}");
    }

    #[test]
    fn ray_precomputations_match_the_scalar_ones() {
        let mut rng = crate::sampling::Pcg32::new(8, 1);
        for i in 0..10_000 {
            let mut c = || (rng.next_f32() - 0.5) * 10f32.powi((i % 7) - 3);
            let mut d = Vec3::new(c(), c(), c());
            if i % 5 == 0 {
                d.y = 0.0;
            }
            if i % 11 == 0 {
                d.x = -0.0;
            }
            let r = Ray::new(Point3::new(c(), c(), c()), d);
            let (a, b) = (TriRay::new(&r, true).sr, ShearedRay::new(&r));
            assert_eq!(a.k, b.k);
            assert_eq!(a.s.map(f32::to_bits), b.s.map(f32::to_bits), "{r:?}");
            let rb = RayBox::new(&r, crate::simd::Sse);
            let inv = rb.inv.map(|x| x[0].to_array()[0]);
            assert_eq!(
                inv.map(f32::to_bits),
                [1.0 / d.x, 1.0 / d.y, 1.0 / d.z].map(f32::to_bits)
            );
        }
    }

    #[test]
    fn single_leaf_and_empty_trees() {
        let g = triangles(&[[
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ]]);
        assert_eq!(bvh(&g).node_count(), 0);
        check(&g);
        let empty = Geometry::new(Vec::new(), Vec::new());
        let b = bvh(&empty);
        let mut st = RayStats::default();
        let r = Ray::new(Point3::ORIGIN, Vec3::X);
        assert!(b.intersect(&empty, &r, &mut st).is_none());
        assert!(!b.occluded(&empty, &r, &mut st));
    }

    #[test]
    fn large_builds_are_parallel_and_agree() {
        // Enough triangles for the parallel build and binning paths, on a coarse lattice so
        // that many centroids coincide.
        let mut tris = Vec::new();
        for i in 0..70_000u32 {
            let (x, y, z) = (
                (i % 41) as f32,
                ((i / 41) % 37) as f32,
                (i / (41 * 37)) as f32,
            );
            let o = Point3::new(x, y, z);
            tris.push([
                o,
                o + Vec3::new(0.9, 0.0, 0.0),
                o + Vec3::new(0.0, 0.9, 0.3),
            ]);
        }
        let g = triangles(&tris);
        let b = bvh(&g);
        let mut seen = vec![false; tris.len()];
        for t in b.tris.iter() {
            for &id in &t.id {
                if id != u32::MAX {
                    assert!(!seen[id as usize]);
                    seen[id as usize] = true;
                }
            }
        }
        assert!(
            seen.iter().all(|&s| s),
            "every triangle is in exactly one block"
        );
        // Against the list on a few hundred rays (the full check would be slow here).
        let list = super::super::List::new(&g);
        let mut rng = crate::sampling::Pcg32::new(1, 2);
        let mut st = RayStats::default();
        for i in 0..300 {
            let o = Point3::new(
                rng.next_f32() * 60.0 - 10.0,
                rng.next_f32() * 60.0 - 10.0,
                rng.next_f32() * 60.0 - 10.0,
            );
            let d = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            );
            let mut r = Ray::new(
                o,
                if i % 3 == 0 {
                    Vec3::new(0.0, 0.0, d.z)
                } else {
                    d
                },
            );
            if i % 4 == 0 {
                r.tmax = 5.0;
            }
            assert_eq!(
                list.intersect(&g, &r, &mut st),
                b.intersect(&g, &r, &mut st),
                "{r:?}"
            );
            assert_eq!(
                list.occluded(&g, &r, &mut st),
                b.occluded(&g, &r, &mut st),
                "{r:?}"
            );
        }
    }

    #[test]
    fn deep_degenerate_inputs_keep_the_stack_bounded() {
        // Nested triangles of geometrically shrinking size: SAH would peel one at a time.
        let mut tris = Vec::new();
        let mut s = 1.0f32;
        for _ in 0..3000 {
            tris.push([
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(s, 0.0, 0.0),
                Point3::new(0.0, s, 0.0),
            ]);
            s *= 0.97;
        }
        check(&triangles(&tris));
    }
}
