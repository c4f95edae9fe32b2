//! Uniform grid (`--accel grid`): the scene box cut into equal cells, traversed by 3D-DDA.
//!
//! Build: the resolution follows the primitive count, about [`CELLS_PER_PRIM`] cells per
//! primitive (λ), with cells as close to cubes as the box allows (an axis with too little
//! extent gets one cell and the others share the budget), at most [`MAX_RES`] per axis and
//! [`MAX_CELLS`] in all. Primitives on a surface crowd a thin shell of cells; when the occupied
//! cells then average more than [`DENSE_CELL`] references, the resolution is raised once, by
//! the square root of the excess (the count per occupied cell falls with the square of the
//! resolution), within [`MAX_CELLS`]. When the references would exceed [`MAX_REFS_PER_PRIM`]
//! per primitive (many huge primitives), the resolution is halved until they do not.
//!
//! Every primitive is referenced from each cell its box, grown by the margin (`accel::margin`),
//! overlaps (inclusive, so a primitive touching a cell boundary goes into both cells). The cell
//! lists are stored in CSR form: `offsets[c]..offsets[c + 1]` indexes `prims`, with one
//! occupancy bit per cell so that empty cells are skipped without reading the offsets.
//!
//! Traversal: the 3D digital differential analyser of Amanatides and Woo ("A Fast Voxel
//! Traversal Algorithm for Ray Tracing", Eurographics 1987) walks the cells pierced by the ray
//! from its entry into the grid, in order. The parameter of the next boundary on each axis is
//! recomputed from the boundary's coordinate at every step (no accumulated increments). A hit
//! found in a cell may lie in a later cell, so the walk only stops once the next cell starts
//! beyond `t_limit` of the best hit; shadow rays stop at the first hit.

use super::{
    clip, inflate, inv_dir, margin, t_limit, union_bounds, AnyVisitor, BuildPrim, CellVisitor,
    ClosestVisitor,
};
use crate::interaction::Hit;
use crate::math::{Bounds3, Ray, Vec3};
use crate::scene::Geometry;
use crate::stats::RayStats;

/// Target number of cells per primitive (λ).
pub const CELLS_PER_PRIM: f32 = 4.0;
/// Largest resolution along one axis.
pub const MAX_RES: u32 = 512;
/// Largest number of cells (64 MiB of offsets).
pub const MAX_CELLS: u64 = 1 << 24;
/// Target number of references per occupied cell when refining.
pub const DENSE_CELL: f64 = 4.0;
/// When the cell references exceed this many per primitive (plus a constant), the resolution
/// is halved.
pub const MAX_REFS_PER_PRIM: u64 = 32;

/// A uniform grid over the bounded primitives of a geometry.
#[derive(Clone, Debug, Default)]
pub struct Grid {
    bounds: Bounds3,
    res: [u32; 3],
    width: [f32; 3],
    inv_width: [f32; 3],
    offsets: Vec<u32>,
    prims: Vec<u32>,
    /// One bit per cell, set when the cell is not empty (small enough to stay in cache, so
    /// that the walk through empty cells does not touch `offsets`).
    occupied: Vec<u64>,
}

impl Grid {
    /// Builds over `prims` (boxes and ids).
    pub fn build(prims: &[BuildPrim]) -> Self {
        if prims.is_empty() {
            return Self::default();
        }
        let scene = union_bounds(prims);
        let m = margin(&scene);
        let bounds = inflate(scene, 2.0 * m);
        let boxes: Vec<Bounds3> = prims.iter().map(|p| inflate(p.bounds, m)).collect();
        let mut res = resolution(&bounds, prims.len());
        let mut refined = false;
        loop {
            let mut g = Self::empty(bounds, res);
            let refs: u64 = boxes
                .iter()
                .map(|b| {
                    g.range(b)
                        .iter()
                        .map(|&(lo, hi)| (hi - lo + 1) as u64)
                        .product::<u64>()
                })
                .sum();
            let cells: u64 = res.iter().map(|&r| r as u64).product();
            if refs > MAX_REFS_PER_PRIM * prims.len() as u64 + (1 << 20) && cells > 1 {
                res = res.map(|r| (r / 2).max(1));
                refined = true;
                continue;
            }
            let count = g.count(&boxes, cells as usize);
            if !refined {
                refined = true;
                // Primitives on a surface crowd a thin shell of cells: refine once so that the
                // occupied cells hold about DENSE_CELL references (the count there falls with
                // the square of the resolution), within the cell budget.
                let occupied = count.iter().filter(|&&c| c > 0).count().max(1);
                let per_cell = refs as f64 / occupied as f64;
                if per_cell > DENSE_CELL {
                    let room = (MAX_CELLS as f64 / cells as f64).cbrt();
                    let f = (per_cell / DENSE_CELL).sqrt().min(room);
                    let finer = res.map(|r| ((r as f64 * f) as u32).clamp(1, MAX_RES));
                    if finer != res && f > 1.1 {
                        res = finer;
                        continue;
                    }
                }
            }
            g.fill(prims, &boxes, count, refs as usize);
            return g;
        }
    }

    fn empty(bounds: Bounds3, res: [u32; 3]) -> Self {
        let d = bounds.diagonal();
        let d = [d.x, d.y, d.z];
        Self {
            bounds,
            res,
            width: std::array::from_fn(|a| d[a] / res[a] as f32),
            inv_width: std::array::from_fn(|a| res[a] as f32 / d[a]),
            offsets: Vec::new(),
            prims: Vec::new(),
            occupied: Vec::new(),
        }
    }

    /// The number of references of each cell, shifted by one (`count[c + 1]` for cell `c`).
    fn count(&self, boxes: &[Bounds3], cells: usize) -> Vec<u32> {
        let mut count = vec![0u32; cells + 1];
        for b in boxes {
            self.for_each_cell(b, |c| count[c + 1] += 1);
        }
        count
    }

    /// Fills the CSR lists from the counts: prefix sums, then scatter.
    fn fill(&mut self, prims: &[BuildPrim], boxes: &[Bounds3], mut count: Vec<u32>, refs: usize) {
        let cells = count.len() - 1;
        self.occupied = vec![0u64; cells.div_ceil(64)];
        for c in 0..cells {
            if count[c + 1] > 0 {
                self.occupied[c / 64] |= 1 << (c % 64);
            }
        }
        for c in 0..cells {
            count[c + 1] += count[c];
        }
        let mut cursor = count.clone();
        let mut list = vec![0u32; refs];
        for (p, b) in prims.iter().zip(boxes) {
            self.for_each_cell(b, |c| {
                list[cursor[c] as usize] = p.id;
                cursor[c] += 1;
            });
        }
        self.offsets = count;
        self.prims = list;
    }

    /// The inclusive cell range of a box on each axis.
    fn range(&self, b: &Bounds3) -> [(u32, u32); 3] {
        std::array::from_fn(|a| (self.cell(a, b.min[a]), self.cell(a, b.max[a])))
    }

    fn for_each_cell(&self, b: &Bounds3, mut f: impl FnMut(usize)) {
        let [(x0, x1), (y0, y1), (z0, z1)] = self.range(b);
        for z in z0..=z1 {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    f(self.index([x, y, z]));
                }
            }
        }
    }

    /// The cell holding coordinate `x` on axis `a`, clamped to the grid (NaN gives 0).
    #[inline(always)]
    fn cell(&self, a: usize, x: f32) -> u32 {
        let c = ((x - self.bounds.min[a]) * self.inv_width[a]).floor() as i64;
        c.clamp(0, self.res[a] as i64 - 1) as u32
    }

    #[inline(always)]
    fn index(&self, c: [u32; 3]) -> usize {
        (c[0] + self.res[0] * (c[1] + self.res[1] * c[2])) as usize
    }

    /// The resolution on each axis.
    pub fn resolution(&self) -> [u32; 3] {
        self.res
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of primitive references (a primitive counts once per cell).
    pub fn reference_count(&self) -> usize {
        self.prims.len()
    }

    /// Memory used by the cell offsets and primitive lists, in bytes.
    pub fn memory(&self) -> usize {
        (self.offsets.len() + self.prims.len()) * 4 + self.occupied.len() * 8
    }

    /// The primitives of cell `c` (linear index).
    #[inline(always)]
    fn cell_prims(&self, c: usize) -> &[u32] {
        &self.prims[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }

    /// Walks the cells pierced by `ray` in order while `v` wants to go on; returns the number
    /// of cells visited.
    #[inline(always)]
    fn traverse(&self, ray: &Ray, v: &mut impl CellVisitor) -> u64 {
        if self.prims.is_empty() {
            return 0;
        }
        let inv = inv_dir(ray.d);
        let Some((t0, t1)) = clip(&self.bounds, ray, inv) else {
            return 0;
        };
        let end = t_limit(t1);
        let mut dda = Dda::new(self, ray, inv, t0);
        let mut visited = 0u64;
        loop {
            visited += 1;
            let c = dda.linear;
            if self.occupied[c / 64] >> (c % 64) & 1 == 1 && !v.cell(self.cell_prims(c)) {
                break;
            }
            if !dda.advance(self, ray, inv, v.limit().min(end)) {
                break;
            }
        }
        visited
    }

    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        ClosestVisitor::run(geometry, ray, stats, |v| self.traverse(ray, v))
    }

    /// True when any primitive is hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        AnyVisitor::run(geometry, ray, stats, |v| self.traverse(ray, v))
    }
}

/// The state of the 3D-DDA walk: the current cell and the parameter of the next boundary on
/// each axis.
struct Dda {
    cell: [u32; 3],
    linear: usize,
    /// −1, 0 or +1 per axis.
    step: [i32; 3],
    next: [f32; 3],
}

impl Dda {
    /// Starts in the cell holding the ray's point at `t0`.
    #[inline(always)]
    fn new(g: &Grid, ray: &Ray, inv: Vec3, t0: f32) -> Self {
        let p = ray.at(t0);
        let cell: [u32; 3] = std::array::from_fn(|a| g.cell(a, p[a]));
        let step: [i32; 3] = std::array::from_fn(|a| {
            if ray.d[a] > 0.0 {
                1
            } else if ray.d[a] < 0.0 {
                -1
            } else {
                0
            }
        });
        let mut d = Self {
            cell,
            linear: g.index(cell),
            step,
            next: [f32::INFINITY; 3],
        };
        for a in 0..3 {
            d.next[a] = d.boundary(g, ray, inv, a);
        }
        d
    }

    /// The parameter where the ray leaves the current cell through its boundary on axis `a`.
    #[inline(always)]
    fn boundary(&self, g: &Grid, ray: &Ray, inv: Vec3, a: usize) -> f32 {
        if self.step[a] == 0 {
            return f32::INFINITY;
        }
        let k = self.cell[a] + (self.step[a] > 0) as u32;
        let x = g.bounds.min[a] + k as f32 * g.width[a];
        (x - ray.o[a]) * inv[a]
    }

    /// Moves to the next cell when it starts at or before `stop`; false when the walk ends
    /// (beyond `stop`, out of the grid, or nowhere to go).
    #[inline(always)]
    fn advance(&mut self, g: &Grid, ray: &Ray, inv: Vec3, stop: f32) -> bool {
        let a = if self.next[0] < self.next[1] {
            if self.next[0] < self.next[2] {
                0
            } else {
                2
            }
        } else if self.next[1] < self.next[2] {
            1
        } else {
            2
        };
        let exit = self.next[a];
        // NaN and infinity end the walk as well.
        if !(exit <= stop) || exit == f32::INFINITY || self.step[a] == 0 {
            return false;
        }
        let c = self.cell[a] as i32 + self.step[a];
        if c < 0 || c >= g.res[a] as i32 {
            return false;
        }
        self.cell[a] = c as u32;
        self.linear = g.index(self.cell);
        self.next[a] = self.boundary(g, ray, inv, a);
        true
    }
}

/// About `CELLS_PER_PRIM · n` cells, as cubic as the extents allow: axes shorter than the
/// cell side get one cell and the budget is shared by the others.
fn resolution(bounds: &Bounds3, n: usize) -> [u32; 3] {
    let d = bounds.diagonal();
    let d = [d.x, d.y, d.z];
    let target = (CELLS_PER_PRIM * n as f32).min(MAX_CELLS as f32);
    let mut active = [true; 3];
    let mut side = 0.0f32;
    for _ in 0..3 {
        let k = active.iter().filter(|&&x| x).count();
        if k == 0 {
            break;
        }
        let vol: f64 = (0..3).filter(|&a| active[a]).map(|a| d[a] as f64).product();
        side = (vol / target as f64).powf(1.0 / k as f64) as f32;
        let mut changed = false;
        for a in 0..3 {
            if active[a] && d[a] < side {
                active[a] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    std::array::from_fn(|a| {
        if !active[a] || !(side > 0.0) {
            return 1;
        }
        let r = (d[a] / side).round();
        if r.is_finite() {
            (r as u32).clamp(1, MAX_RES)
        } else {
            MAX_RES
        }
    })
}

#[cfg(test)]
mod tests {
    use super::super::test_scenes::{self, agrees_with_list, triangles};
    use super::*;
    use crate::math::Point3;

    fn grid(g: &Geometry) -> Grid {
        Grid::build(&super::super::build_prims(g))
    }

    #[test]
    fn resolution_follows_the_count_and_flat_boxes() {
        let cube = Bounds3::new(Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 1.0, 1.0));
        assert_eq!(resolution(&cube, 250), [10, 10, 10]);
        let flat = Bounds3::new(Point3::new(0.0, 0.0, 0.0), Point3::new(2.0, 1.0, 1e-6));
        let r = resolution(&flat, 200);
        assert_eq!(r[2], 1);
        assert!(
            r[0] * r[1] >= 600 && r[0] * r[1] <= 1000 && r[0] > r[1],
            "{r:?}"
        );
        assert_eq!(resolution(&cube, 100_000_000), [256; 3]);
    }

    #[test]
    fn two_triangles_in_different_cells() {
        let g = test_scenes::two_triangles();
        let gr = grid(&g);
        assert!(gr.cell_count() > 1);
        let mut st = RayStats::default();
        let r = Ray::new(Point3::new(9.2, 0.2, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let h = gr.intersect(&g, &r, &mut st).unwrap();
        assert_eq!((h.prim, h.t), (1, 4.0));
        let r = Ray::new(Point3::new(0.2, 0.2, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(gr.intersect(&g, &r, &mut st).unwrap().prim, 0);
        // A ray along x at z = 0.5 misses both.
        let r = Ray::new(Point3::new(-5.0, 0.2, 0.5), Vec3::X);
        assert!(gr.intersect(&g, &r, &mut st).is_none());
        assert!(st.nodes > 0 && st.prim_tests > 0);
        agrees_with_list(&g, &gr);
    }

    #[test]
    fn flat_primitives_rays_inside_and_parallel() {
        test_scenes::flat_primitives_rays_inside_and_parallel(grid);
    }

    #[test]
    fn a_primitive_spanning_many_cells_is_found_at_the_nearer_cell() {
        // A long thin triangle along x, and small ones behind it: the long one must win where
        // it is in front, though it is also listed in every later cell.
        let mut tris = vec![[
            Point3::new(-10.0, -1.0, 0.0),
            Point3::new(10.0, -1.0, 0.0),
            Point3::new(-10.0, 1.0, 0.0),
        ]];
        for i in 0..20 {
            let x = -10.0 + i as f32;
            tris.push([
                Point3::new(x, -1.0, -1.0),
                Point3::new(x + 1.0, -1.0, -1.0),
                Point3::new(x, 1.0, -1.0),
            ]);
        }
        let g = triangles(&tris);
        let gr = grid(&g);
        assert!(gr.reference_count() > tris.len());
        let mut st = RayStats::default();
        let r = Ray::new(Point3::new(-9.0, -0.5, 3.0), Vec3::new(0.1, 0.0, -1.0));
        assert_eq!(gr.intersect(&g, &r, &mut st).unwrap().prim, 0);
        agrees_with_list(&g, &gr);
    }

    #[test]
    fn empty_single_and_identical() {
        test_scenes::empty_single_and_identical(grid, &[1, 7, 300]);
    }
}
