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
//! with SIMD ([`crate::simd`], AVX2 chosen at run time). With the cargo feature `embree`, Intel
//! Embree 3 is available too ([`AccelKind::Embree`]) for comparisons; it is not bit-identical.

mod bvh;
#[cfg(feature = "embree")]
mod embree;
mod grid;
mod kdtree;
mod list;
mod octree;

pub use bvh::{Bvh, BvhNode};
#[cfg(feature = "embree")]
pub use embree::Embree;
pub use grid::Grid;
pub use kdtree::{KdNode, KdTree};
pub use list::List;
pub use octree::{Octree, OctreeNode};

use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Bounds3, Point3, Ray, Vec3};
use crate::shape::ShearedRay;
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

/// Relative slack of `t_limit`.
const T_SLACK: f32 = 1.0 / 65536.0;

/// The largest cell-entry parameter that may still hold a hit at `t` or closer: `t` plus a
/// relative slack that covers the round-off of the cell-boundary parameters.
#[inline(always)]
pub(crate) fn t_limit(t: f32) -> f32 {
    t + t.abs() * T_SLACK
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
}

/// Small hand-made geometries and the comparison with the list shared by the unit tests of
/// the structures.
#[cfg(test)]
pub(crate) mod test_scenes {
    use super::List;
    use crate::geometry::{Geometry, Object};
    use crate::interaction::{Hit, SurfaceProps};
    use crate::math::{Point3, Ray, Transform, Vec3};
    use crate::sampling::Pcg32;
    use crate::shape::{Mesh, Parallelogram, Shape, Sphere};
    use crate::stats::RayStats;

    /// One mesh of the given triangles (ids in order).
    pub fn triangles(tris: &[[Point3; 3]]) -> Geometry {
        let mut mesh = Mesh::default();
        for t in tris {
            let k = mesh.positions.len() as u32;
            mesh.positions.extend_from_slice(t);
            mesh.indices.push([k, k + 1, k + 2]);
        }
        let meshes = if mesh.is_empty() {
            Vec::new()
        } else {
            vec![mesh]
        };
        Geometry::new(Vec::new(), meshes)
    }

    /// Two unit triangles facing +z, far apart along x: id 0 at z = 0 from the origin, id 1 at
    /// z = 1 from x = 9.
    pub fn two_triangles() -> Geometry {
        triangles(&[
            [
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            [
                Point3::new(9.0, 0.0, 1.0),
                Point3::new(10.0, 0.0, 1.0),
                Point3::new(9.0, 1.0, 1.0),
            ],
        ])
    }

    /// A row of `n` small triangles along x, facing +z.
    pub fn row(n: usize) -> Vec<[Point3; 3]> {
        (0..n)
            .map(|i| {
                let x = i as f32;
                [
                    Point3::new(x, 0.0, 0.0),
                    Point3::new(x + 0.5, 0.0, 0.0),
                    Point3::new(x, 0.5, 0.0),
                ]
            })
            .collect()
    }

    /// A [`row`] of `n` with a long triangle (id `n`) in front of the whole row, so listed in
    /// many cells (`references` of the structure exceed the triangles): a ray near the row's
    /// start hits the long one; then the comparison with the list.
    pub fn a_long_primitive_in_front_of_a_row<S: Structure>(
        build: impl Fn(&Geometry) -> S,
        n: usize,
        references: impl Fn(&S) -> usize,
    ) {
        let mut tris = row(n);
        tris.push([
            Point3::new(-1.0, -1.0, 1.0),
            Point3::new(n as f32 + 5.0, -1.0, 1.0),
            Point3::new(-1.0, 2.0, 1.0),
        ]);
        let g = triangles(&tris);
        let s = build(&g);
        assert!(references(&s) > tris.len());
        let mut st = RayStats::default();
        let h = s
            .hit(
                &g,
                &Ray::new(Point3::new(0.2, 0.1, 3.0), Vec3::new(0.05, 0.0, -1.0)),
                &mut st,
            )
            .unwrap();
        assert_eq!(h.prim as usize, n);
        agrees_with_list(&g, &s);
    }

    /// Flat parallelograms (zero thickness on an axis, some on cell-like boundaries, one
    /// duplicated) and a few spheres: the wall at x = 4 spans y, z in [-2, 2].
    pub fn parallelogram_scene() -> Geometry {
        let obj = |shape| Object {
            shape,
            props: SurfaceProps::new(0),
        };
        let pg = |p: Point3, v: Vec3, w: Vec3| {
            obj(Shape::Parallelogram(Parallelogram::new(p, v, w).unwrap()))
        };
        let sphere = |c: Vec3, r: f32| {
            obj(Shape::Sphere(Sphere::new(
                Transform::translation(c) * Transform::scaling(Vec3::new(r, r, r)),
            )))
        };
        let objects = vec![
            pg(
                Point3::new(4.0, -2.0, -2.0),
                Vec3::new(0.0, 4.0, 0.0),
                Vec3::new(0.0, 0.0, 4.0),
            ),
            pg(
                Point3::new(-4.0, -4.0, 0.0),
                Vec3::new(8.0, 0.0, 0.0),
                Vec3::new(0.0, 8.0, 0.0),
            ),
            pg(
                Point3::new(-4.0, 0.0, -4.0),
                Vec3::new(8.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 8.0),
            ),
            pg(
                Point3::new(-4.0, 0.0, -4.0),
                Vec3::new(8.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 8.0),
            ),
            pg(
                Point3::new(-1.0, -1.0, 1.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 2.0, 0.0),
            ),
            sphere(Vec3::new(2.0, 2.0, 2.0), 0.5),
            sphere(Vec3::new(-2.0, -2.0, -2.0), 1.5),
            sphere(Vec3::new(-2.0, -2.0, -2.0), 1.5),
            sphere(Vec3::new(0.0, 0.0, 0.0), 0.25),
        ];
        Geometry::new(objects, Vec::new())
    }

    /// What the shared tests need of a structure.
    pub trait Structure {
        /// The closest hit.
        fn hit(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> Option<Hit>;
        /// Any hit.
        fn occ(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> bool;
    }

    macro_rules! structures {
        ($($t:ty),*) => {$(
            impl Structure for $t {
                fn hit(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> Option<Hit> {
                    self.intersect(g, r, st)
                }
                fn occ(&self, g: &Geometry, r: &Ray, st: &mut RayStats) -> bool {
                    self.occluded(g, r, st)
                }
            }
        )*};
    }
    structures!(
        super::Bvh,
        super::KdTree,
        super::Grid,
        super::Octree,
        List,
        super::Accel
    );

    /// [`check_against_list`] for a structure.
    pub fn agrees_with_list(g: &Geometry, s: &impl Structure) {
        check_against_list(g, |g, r, st| s.hit(g, r, st), |g, r, st| s.occ(g, r, st));
    }

    /// [`parallelogram_scene`]: a ray from inside, parallel to x, hits the wall at x = 4 (and
    /// not when it stops short); then the comparison with the list.
    pub fn flat_primitives_rays_inside_and_parallel<S: Structure>(build: impl Fn(&Geometry) -> S) {
        let g = parallelogram_scene();
        let s = build(&g);
        let mut st = RayStats::default();
        let r = Ray::new(Point3::new(0.5, 0.5, 0.5), Vec3::X);
        assert_eq!(s.hit(&g, &r, &mut st).unwrap().t, 3.5);
        assert!(s.occ(&g, &r, &mut st));
        let short = Ray { tmax: 3.0, ..r };
        assert!(s.hit(&g, &short, &mut st).is_none());
        assert!(!s.occ(&g, &short, &mut st));
        agrees_with_list(&g, &s);
    }

    /// An empty scene, then `counts` copies of one triangle: the first copy wins the tie.
    pub fn empty_single_and_identical<S: Structure>(
        build: impl Fn(&Geometry) -> S,
        counts: &[usize],
    ) {
        let g = triangles(&[]);
        let s = build(&g);
        let mut st = RayStats::default();
        assert!(s
            .hit(&g, &Ray::new(Point3::ORIGIN, Vec3::X), &mut st)
            .is_none());
        assert!(!s.occ(&g, &Ray::new(Point3::ORIGIN, Vec3::X), &mut st));
        let t = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        ];
        for &n in counts {
            let g = triangles(&vec![t; n]);
            let s = build(&g);
            let h = s
                .hit(&g, &Ray::new(Point3::new(0.1, 0.1, 1.0), -Vec3::Z), &mut st)
                .unwrap();
            assert_eq!((h.prim, h.t), (0, 1.0));
            agrees_with_list(&g, &s);
        }
    }

    /// Compares `intersect` and `occluded` with the list on many rays: random, along the axes
    /// from points on a lattice (through edges, vertices and flat primitives), and aimed at
    /// the corners of the primitives' boxes.
    pub fn check_against_list(
        g: &Geometry,
        intersect: impl Fn(&Geometry, &Ray, &mut RayStats) -> Option<Hit>,
        occluded: impl Fn(&Geometry, &Ray, &mut RayStats) -> bool,
    ) {
        let list = List::new(g);
        let b = g.bounds();
        let (c, r) = if b.is_empty() {
            (Point3::ORIGIN, 1.0)
        } else {
            let d = b.diagonal();
            (b.centroid(), d.x.max(d.y).max(d.z).max(1.0))
        };
        let mut rng = Pcg32::new(7, 3);
        let mut pt = |s: f32| {
            c + Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            ) * (2.0 * s * r)
        };
        let mut rays = Vec::new();
        for i in 0..3000 {
            let o = pt(if i % 3 == 0 { 0.4 } else { 1.5 });
            let target = pt(0.5);
            let mut ray = Ray::new(o, target - o);
            if i % 7 == 0 {
                ray.tmax = 0.7;
            }
            rays.push(ray);
        }
        for ix in -8..=8 {
            for iy in -8..=8 {
                let (u, v) = (ix as f32 * 0.5, iy as f32 * 0.5);
                for (o, d) in [
                    (Point3::new(u, v, -30.0), Vec3::Z),
                    (Point3::new(u, v, 30.0), -Vec3::Z),
                    (Point3::new(-30.0, u, v), Vec3::X),
                    (Point3::new(30.0, u, v), -Vec3::X),
                    (Point3::new(u, -30.0, v), Vec3::Y),
                    (Point3::new(u, 30.0, v), -Vec3::Y),
                    (Point3::new(u, v, 0.0), Vec3::new(1.0, 1.0, 0.0)),
                ] {
                    rays.push(Ray::new(c + o.to_vec(), d));
                }
            }
        }
        for id in 0..g.bounded_count() {
            let pb = g.prim_bounds(id);
            for k in 0..8 {
                let corner = Point3::new(
                    if k & 1 == 0 { pb.min.x } else { pb.max.x },
                    if k & 2 == 0 { pb.min.y } else { pb.max.y },
                    if k & 4 == 0 { pb.min.z } else { pb.max.z },
                );
                let o = pt(1.5);
                rays.push(Ray::new(o, corner - o));
            }
        }
        let mut st = RayStats::default();
        for ray in &rays {
            let a = list.intersect(g, ray, &mut st);
            let h = intersect(g, ray, &mut st);
            assert_eq!(a, h, "{ray:?}");
            assert_eq!(
                list.occluded(g, ray, &mut st),
                occluded(g, ray, &mut st),
                "{ray:?}"
            );
        }
    }
}

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
