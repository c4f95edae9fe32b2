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
//! overlaps (inclusive, so a primitive touching a cell boundary goes into both cells). The cells
//! are numbered in blocks of [`BLOCK`]³ (a block is a *macro cell*; the grid is padded to whole
//! blocks), block after block, x fastest both between and within blocks. One occupancy bit per
//! cell (the bits of a block fill one 64-byte line) lets empty cells be skipped, and one bit
//! per block (a few KiB, so it stays in L1) lets empty blocks be crossed at once. Only the
//! non-empty cells have lists, in CSR form in that order: the `r`-th non-empty cell lists
//! `prims[offsets[r]..offsets[r + 1]]`, where `r` is the count of non-empty cells in earlier
//! blocks plus the set bits before the cell's own in its block (so most of the grid, empty,
//! costs little more than a bit a cell, not a 4-byte offset).
//!
//! Traversal: the 3D digital differential analyser of Amanatides and Woo ("A Fast Voxel
//! Traversal Algorithm for Ray Tracing", Eurographics 1987) walks the cells pierced by the ray
//! from its entry into the grid, in order. The parameter of the next boundary on each axis is
//! recomputed from the boundary's coordinate at every step (no accumulated increments), so it
//! is a function of the boundary alone. An empty block is left in one move: its exit is the
//! first of its three far faces (boundaries of cells too), and on the other axes the walk
//! jumps to the cell it would have reached by then, comparing the same boundary parameters
//! the cell-by-cell walk compares, with its tie order; the non-empty cells are thus visited
//! exactly as by the cell-by-cell walk. A hit found in a cell may lie in a later cell, so the
//! walk only stops once the next cell starts beyond `t_limit` of the best hit; shadow rays stop
//! at the first hit.

use super::prims::{inflate, margin, union_bounds, BuildPrim};
use super::visit::{clip, inv_dir, t_limit, AnyVisitor, CellVisitor, ClosestVisitor};
use crate::geometry::Geometry;
use crate::interaction::Hit;
use crate::math::{Bounds3, Ray, Vec3};
use crate::stats::RayStats;

/// Target number of cells per primitive (λ).
pub const CELLS_PER_PRIM: f32 = 4.0;
/// Largest resolution along one axis.
pub const MAX_RES: u32 = 512;
/// Largest number of cells (the build counts the references of each cell in 4 bytes).
pub const MAX_CELLS: u64 = 1 << 24;
/// Target number of references per occupied cell when refining.
pub const DENSE_CELL: f64 = 4.0;
/// When the cell references exceed this many per primitive (plus a constant), the resolution
/// is halved.
pub const MAX_REFS_PER_PRIM: u64 = 32;
/// Side of a block (macro cell), in cells.
pub const BLOCK: u32 = 8;
/// log2 of [`BLOCK`].
const BLOCK_SHIFT: u32 = 3;
/// log2 of the number of cells in a block.
const BLOCK_CELLS_SHIFT: u32 = 3 * BLOCK_SHIFT;

/// The occupancy bits of one block, aligned to a cache line: bit `i` of word `w` for the cell
/// at place `64 w + i` in the block.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct BlockBits([u64; 8]);

/// Where the lists of a block's non-empty cells start among all non-empty cells.
#[derive(Clone, Copy, Debug, Default)]
struct BlockRank {
    /// The number of non-empty cells in earlier blocks.
    base: u32,
    /// The number of non-empty cells of the block before each word of its [`BlockBits`].
    prefix: [u16; 8],
}

/// A uniform grid over the bounded primitives of a geometry.
#[derive(Clone, Debug, Default)]
pub struct Grid {
    bounds: Bounds3,
    res: [u32; 3],
    /// The resolution in blocks.
    blocks: [u32; 3],
    width: [f32; 3],
    inv_width: [f32; 3],
    /// Where the list of each non-empty cell starts in `prims`, and the end of the last one.
    offsets: Vec<u32>,
    prims: Vec<u32>,
    /// One bit per cell (by block), set when the cell is not empty.
    occupied: Vec<BlockBits>,
    /// The rank of each block's first non-empty cell, for `offsets`.
    ranks: Vec<BlockRank>,
    /// One bit per block, set when any of its cells is not empty.
    block_occupied: Vec<u64>,
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
            let count = g.count(&boxes);
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
            blocks: res.map(|r| r.div_ceil(BLOCK)),
            width: std::array::from_fn(|a| d[a] / res[a] as f32),
            inv_width: std::array::from_fn(|a| res[a] as f32 / d[a]),
            offsets: Vec::new(),
            prims: Vec::new(),
            occupied: Vec::new(),
            ranks: Vec::new(),
            block_occupied: Vec::new(),
        }
    }

    /// The number of blocks.
    fn block_count(&self) -> usize {
        self.blocks.iter().map(|&b| b as usize).product()
    }

    /// The number of references of each cell (by linear index, padding included), shifted by
    /// one (`count[c + 1]` for cell `c`).
    fn count(&self, boxes: &[Bounds3]) -> Vec<u32> {
        let mut count = vec![0u32; (self.block_count() << BLOCK_CELLS_SHIFT) + 1];
        for b in boxes {
            self.for_each_cell(b, |c| count[c + 1] += 1);
        }
        count
    }

    /// Fills the occupancy bits, and the CSR lists of the non-empty cells from the counts:
    /// prefix sums, scatter, then the starts of the non-empty cells' lists.
    fn fill(&mut self, prims: &[BuildPrim], boxes: &[Bounds3], mut count: Vec<u32>, refs: usize) {
        let cells = count.len() - 1;
        self.occupied = vec![BlockBits::default(); self.block_count()];
        self.ranks = vec![BlockRank::default(); self.block_count()];
        self.block_occupied = vec![0u64; self.block_count().div_ceil(64)];
        let mut offsets = Vec::new();
        for c in 0..cells {
            let (b, w) = (c >> BLOCK_CELLS_SHIFT, (c >> 6) & 7);
            if c % 64 == 0 {
                let rank = offsets.len() as u32;
                if w == 0 {
                    self.ranks[b].base = rank;
                }
                self.ranks[b].prefix[w] = (rank - self.ranks[b].base) as u16;
            }
            if count[c + 1] > 0 {
                self.occupied[b].0[w] |= 1 << (c % 64);
                self.block_occupied[b / 64] |= 1 << (b % 64);
                offsets.push(count[c]);
            }
            count[c + 1] += count[c];
        }
        offsets.push(count[cells]);
        // The lists, in the order of the cells, at the starts just recorded.
        let mut cursor = count;
        let mut list = vec![0u32; refs];
        for (p, b) in prims.iter().zip(boxes) {
            self.for_each_cell(b, |c| {
                list[cursor[c] as usize] = p.id;
                cursor[c] += 1;
            });
        }
        self.offsets = offsets;
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
        // Truncation is the floor for the non-negative values the clamp keeps (and saturates,
        // with NaN to 0).
        let c = ((x - self.bounds.min[a]) * self.inv_width[a]) as i64;
        c.clamp(0, self.res[a] as i64 - 1) as u32
    }

    /// The linear index of cell `c`: its block's index (x fastest) times the cells of a block,
    /// plus its place in the block (x fastest).
    #[inline(always)]
    fn index(&self, c: [u32; 3]) -> usize {
        let b = |a: usize| c[a] >> BLOCK_SHIFT;
        let l = |a: usize| c[a] & (BLOCK - 1);
        let block = b(0) + self.blocks[0] * (b(1) + self.blocks[1] * b(2));
        ((block as usize) << BLOCK_CELLS_SHIFT)
            | (l(0) | l(1) << BLOCK_SHIFT | l(2) << (2 * BLOCK_SHIFT)) as usize
    }

    /// The primitives of cell `c` (linear index), `None` when it is empty.
    #[inline(always)]
    fn cell_prims(&self, c: usize) -> Option<&[u32]> {
        let (b, w) = (c >> BLOCK_CELLS_SHIFT, (c >> 6) & 7);
        let bits = self.occupied[b].0[w];
        if bits >> (c % 64) & 1 == 0 {
            return None;
        }
        let below = bits & ((1u64 << (c % 64)) - 1);
        let rank = &self.ranks[b];
        let r = (rank.base + rank.prefix[w] as u32 + below.count_ones()) as usize;
        Some(&self.prims[self.offsets[r] as usize..self.offsets[r + 1] as usize])
    }

    /// True when the block of cell `c` (linear index) is not empty.
    #[inline(always)]
    fn block_of_occupied(&self, c: usize) -> bool {
        let b = c >> BLOCK_CELLS_SHIFT;
        self.block_occupied[b / 64] >> (b % 64) & 1 == 1
    }

    /// The resolution on each axis.
    pub fn resolution(&self) -> [u32; 3] {
        self.res
    }

    /// Number of cells (without the padding to whole blocks).
    pub fn cell_count(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    /// Number of primitive references (a primitive counts once per cell).
    pub fn reference_count(&self) -> usize {
        self.prims.len()
    }

    /// Memory used by the cell offsets, primitive lists, occupancy bits and block ranks, in
    /// bytes.
    pub fn memory(&self) -> usize {
        (self.offsets.len() + self.prims.len()) * 4
            + std::mem::size_of_val(self.occupied.as_slice())
            + std::mem::size_of_val(self.ranks.as_slice())
            + self.block_occupied.len() * 8
    }

    /// Walks the cells pierced by `ray` in order while `v` wants to go on; returns the number
    /// of cells visited (an empty block crossed at once counts as one). Empty blocks are
    /// crossed at once only when `blocks` (the tests compare with the cell-by-cell walk).
    #[inline(always)]
    fn traverse(&self, ray: &Ray, v: &mut impl CellVisitor, blocks: bool) -> u64 {
        if self.prims.is_empty() {
            return 0;
        }
        let inv = inv_dir(ray.d);
        let Some((t0, t1)) = clip(&self.bounds, ray, inv) else {
            return 0;
        };
        let end = t_limit(t1);
        let mut dda = Dda::new(self, ray, inv, t0);
        dda.blockwise &= blocks;
        let mut visited = 0u64;
        loop {
            visited += 1;
            let c = self.index(dda.cell.map(|x| x as u32));
            if !self.block_of_occupied(c) {
                match dda.leave_block(v.limit().min(end)) {
                    Leave::Moved => continue,
                    Leave::End => break,
                    Leave::Step => {}
                }
            } else if let Some(prims) = self.cell_prims(c) {
                if !v.cell(prims) {
                    break;
                }
            }
            if !dda.advance(v.limit().min(end)) {
                break;
            }
        }
        visited
    }

    /// The closest hit.
    pub fn intersect(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        ClosestVisitor::run(geometry, ray, stats, |v| self.traverse(ray, v, true))
    }

    /// True when any primitive is hit.
    pub fn occluded(&self, geometry: &Geometry, ray: &Ray, stats: &mut RayStats) -> bool {
        AnyVisitor::run(geometry, ray, stats, |v| self.traverse(ray, v, true))
    }
}

/// What [`Dda::leave_block`] did.
enum Leave {
    /// Moved to the first cell after the block.
    Moved,
    /// The walk ends within the block or at its exit.
    End,
    /// Nothing (parameters might be NaN): take one cell-by-cell step instead.
    Step,
}

/// The state of the 3D-DDA walk: the current cell, the parameter of the next boundary on each
/// axis, and the ray's terms of the boundary parameters.
struct Dda {
    cell: [i32; 3],
    /// −1, 0 or +1 per axis.
    step: [i32; 3],
    next: [f32; 3],
    /// The cell index just outside the grid in the step direction, per axis.
    out: [i32; 3],
    /// Resolution per axis.
    res: [i32; 3],
    lo: [f32; 3],
    width: [f32; 3],
    o: [f32; 3],
    inv: [f32; 3],
    /// True when no boundary parameter can be NaN: the grid's terms and the origin are finite,
    /// and so is the reciprocal direction on each axis the ray moves along (then it is not 0
    /// either, and a product is NaN only as 0 · ∞).
    blockwise: bool,
}

impl Dda {
    /// Starts in the cell holding the ray's point at `t0`.
    #[inline(always)]
    fn new(g: &Grid, ray: &Ray, inv: Vec3, t0: f32) -> Self {
        let p = ray.at(t0);
        let cell: [i32; 3] = std::array::from_fn(|a| g.cell(a, p[a]) as i32);
        let step: [i32; 3] = std::array::from_fn(|a| {
            if ray.d[a] > 0.0 {
                1
            } else if ray.d[a] < 0.0 {
                -1
            } else {
                0
            }
        });
        let res = g.res.map(|r| r as i32);
        let mut d = Self {
            cell,
            step,
            next: [f32::INFINITY; 3],
            out: std::array::from_fn(|a| if step[a] > 0 { res[a] } else { -1 }),
            res,
            lo: [g.bounds.min.x, g.bounds.min.y, g.bounds.min.z],
            width: g.width,
            o: [ray.o.x, ray.o.y, ray.o.z],
            inv: [inv.x, inv.y, inv.z],
            blockwise: false,
        };
        d.blockwise = (0..3).all(|a| {
            d.lo[a].is_finite()
                && d.width[a].is_finite()
                && d.o[a].is_finite()
                && (step[a] == 0 || d.inv[a].is_finite())
        });
        for a in 0..3 {
            d.next[a] = d.boundary(a);
        }
        d
    }

    /// The parameter of the boundary of index `k` (coordinate `min + k · width`) on axis `a`.
    #[inline(always)]
    fn param(&self, a: usize, k: i32) -> f32 {
        let x = self.lo[a] + k as f32 * self.width[a];
        (x - self.o[a]) * self.inv[a]
    }

    /// The parameter where the ray leaves the current cell through its boundary on axis `a`.
    #[inline(always)]
    fn boundary(&self, a: usize) -> f32 {
        if self.step[a] == 0 {
            return f32::INFINITY;
        }
        self.param(a, self.cell[a] + (self.step[a] > 0) as i32)
    }

    /// Moves to the next cell when it starts at or before `stop`; false when the walk ends
    /// (beyond `stop`, out of the grid, or nowhere to go). The next cell is across the nearest
    /// boundary, ties to the later axis; the axis is a constant in each branch so that the
    /// state stays in registers.
    #[inline(always)]
    fn advance(&mut self, stop: f32) -> bool {
        let n = self.next;
        if n[0] < n[1] {
            if n[0] < n[2] {
                self.cross::<0>(stop)
            } else {
                self.cross::<2>(stop)
            }
        } else if n[1] < n[2] {
            self.cross::<1>(stop)
        } else {
            self.cross::<2>(stop)
        }
    }

    /// [`Dda::advance`] across the boundary on axis `A`.
    #[inline(always)]
    fn cross<const A: usize>(&mut self, stop: f32) -> bool {
        let exit = self.next[A];
        // NaN and infinity end the walk as well (an axis the ray does not move along has an
        // infinite parameter).
        if !(exit <= stop) || exit == f32::INFINITY {
            return false;
        }
        let c = self.cell[A] + self.step[A];
        if c == self.out[A] {
            return false;
        }
        self.cell[A] = c;
        self.next[A] = self.boundary(A);
        true
    }

    /// Leaves the current block, which is empty, in one move, ending where the cell-by-cell
    /// walk (`advance` with the same `stop`) would enter the next block.
    ///
    /// That walk crosses the boundaries of all axes in the order of their parameters, ties to
    /// the later axis, so it leaves the block through the first of the block's far faces in
    /// that order (axis `a`, parameter `t`); by then it has crossed exactly the boundaries of
    /// each other axis `b` that come before (`< t`, or `= t` when `b > a`), all inside the
    /// block since its far face on `b` does not. The cells of the block are empty, so
    /// nothing is missed; where the walk ends in the block or at its exit, so does this. The
    /// order needs parameters that are never NaN: unless `blockwise`, nothing is done.
    #[inline(always)]
    fn leave_block(&mut self, stop: f32) -> Leave {
        if !self.blockwise {
            return Leave::Step;
        }
        let k: [i32; 3] = std::array::from_fn(|b| {
            let first = self.cell[b] >> BLOCK_SHIFT << BLOCK_SHIFT;
            if self.step[b] > 0 {
                (first + BLOCK as i32).min(self.res[b])
            } else {
                first
            }
        });
        let far: [f32; 3] = std::array::from_fn(|b| {
            if self.step[b] == 0 {
                f32::INFINITY
            } else {
                self.param(b, k[b])
            }
        });
        if far[0] < far[1] {
            if far[0] < far[2] {
                self.leave_through::<0>(far[0], k[0], stop)
            } else {
                self.leave_through::<2>(far[2], k[2], stop)
            }
        } else if far[1] < far[2] {
            self.leave_through::<1>(far[1], k[1], stop)
        } else {
            self.leave_through::<2>(far[2], k[2], stop)
        }
    }

    /// [`Dda::leave_block`] through the block's far face on axis `A`, boundary `k` at `t`.
    #[inline(always)]
    fn leave_through<const A: usize>(&mut self, t: f32, k: i32, stop: f32) -> Leave {
        if !(t <= stop) || t == f32::INFINITY {
            return Leave::End;
        }
        let c = if self.step[A] > 0 { k } else { k - 1 };
        if c == self.out[A] {
            return Leave::End;
        }
        if A != 0 {
            self.catch_up::<0>(t, false);
        }
        if A != 1 {
            self.catch_up::<1>(t, A < 1);
        }
        if A != 2 {
            self.catch_up::<2>(t, A < 2);
        }
        self.cell[A] = c;
        self.next[A] = self.boundary(A);
        Leave::Moved
    }

    /// Crosses the boundaries on axis `B` (not the exit axis) that come before `t`, and those
    /// at `t` when `ties`; an infinite `next` (no motion on `B`) is never crossed.
    #[inline(always)]
    fn catch_up<const B: usize>(&mut self, t: f32, ties: bool) {
        while self.next[B] < t || (ties && self.next[B] == t) {
            self.cell[B] += self.step[B];
            self.next[B] = self.boundary(B);
        }
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
        Grid::build(&crate::accel::build_prims(g))
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

    /// Records the lists of the non-empty cells visited; stops after `stop_after` of them and
    /// visits cells entered up to `limit`.
    struct Recorder {
        cells: Vec<(usize, usize)>,
        limit: f32,
        stop_after: usize,
    }

    impl CellVisitor for Recorder {
        fn cell(&mut self, prims: &[u32]) -> bool {
            self.cells.push((prims.as_ptr() as usize, prims.len()));
            self.cells.len() < self.stop_after
        }
        fn limit(&self) -> f32 {
            self.limit
        }
    }

    #[test]
    fn crossing_empty_blocks_visits_the_same_cells() {
        // A bumpy shell of triangles (empty blocks inside and around it) and two flat ones
        // across it, at z = 0 and x = 1.
        let mut tris = vec![
            [
                Point3::new(-2.0, -2.0, 0.0),
                Point3::new(2.0, -2.0, 0.0),
                Point3::new(0.0, 2.0, 0.0),
            ],
            [
                Point3::new(1.0, -1.0, -1.0),
                Point3::new(1.0, 1.0, -1.0),
                Point3::new(1.0, 0.0, 1.0),
            ],
        ];
        let n = 40;
        for i in 0..n {
            for j in 0..n {
                let p = |i: usize, j: usize| {
                    let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                    let (th, ph) = (u * std::f32::consts::TAU, v * std::f32::consts::PI);
                    let r = 3.0 + 0.2 * (5.0 * th).sin() * (3.0 * ph).cos();
                    Point3::new(
                        r * ph.sin() * th.cos(),
                        r * ph.sin() * th.sin(),
                        r * ph.cos(),
                    )
                };
                tris.push([p(i, j), p(i + 1, j), p(i, j + 1)]);
                tris.push([p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
        {
            let g = triangles(&tris);
            let gr = grid(&g);
            assert!(gr.res.iter().all(|&r| r > 2 * BLOCK), "{:?}", gr.res);
            let mut rng = crate::sampling::Pcg32::new(3, 9);
            let mut f = |s: f32| (rng.next_f32() - 0.5) * s;
            let mut walked = 0;
            for i in 0..6000 {
                let mut o = Point3::new(f(12.0), f(12.0), f(12.0));
                let mut d = Vec3::new(f(2.0), f(2.0), f(2.0));
                // Some rays along an axis or a diagonal, from corners of cells (boundaries
                // crossed at equal parameters).
                if i % 2 == 0 {
                    let k = [0, 1, 2].map(|_| (f(2.0).abs() * gr.res[0] as f32) as i32);
                    o = Point3::new(
                        gr.bounds.min.x + k[0] as f32 * gr.width[0],
                        gr.bounds.min.y + k[1] as f32 * gr.width[1],
                        gr.bounds.min.z + k[2] as f32 * gr.width[2],
                    );
                    let s = |b: usize| if i >> b & 1 == 1 { 1.0 } else { -1.0 };
                    d = [
                        Vec3::new(s(2), s(3), 0.0),
                        Vec3::new(s(2), 0.0, s(3)),
                        Vec3::new(0.0, s(2), s(3)),
                        Vec3::new(s(2), s(3), s(4)),
                        Vec3::X * s(2),
                    ][i / 32 % 5];
                }
                let ray = Ray::new(o, d);
                for (limit, stop_after) in [(f32::INFINITY, usize::MAX), (f(20.0).abs(), 3)] {
                    let [by_block, by_cell] = [true, false].map(|blocks| {
                        let mut v = Recorder {
                            cells: Vec::new(),
                            limit,
                            stop_after,
                        };
                        gr.traverse(&ray, &mut v, blocks);
                        v.cells
                    });
                    walked += by_cell.len();
                    assert_eq!(by_block, by_cell, "{ray:?}");
                }
            }
            assert!(walked > 1000, "{walked}");
        }
    }

    #[test]
    fn empty_single_and_identical() {
        test_scenes::empty_single_and_identical(grid, &[1, 7, 300]);
    }
}
