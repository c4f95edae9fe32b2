//! Per-pixel sample generation with deterministic seeding.
//!
//! Every pixel owns its own seed, derived from the image seed and the pixel index, so the image
//! depends only on the scene and the seed, never on how pixels are spread over threads.
//!
//! Pixel samplers draw from a padded, Owen-scrambled Sobol sequence (Burley 2020, "Practical
//! Hash-based Owen Scrambling"): the d-th pair of numbers of sample i is the 2D Sobol point
//! (the van der Corput and second Sobol dimensions, a (0,2)-sequence) of a shuffled index, with
//! a nested uniform scramble seeded by the pixel and the pair. The samples of a pixel are thus
//! stratified in every pair of dimensions a path consumes (pixel position, light sample, BSDF
//! sample, …), which lowers the error at equal sample count ([`SamplerKind::Sobol`], the
//! default). One pair is drawn otherwise: the first vertex's direction, from a correlated
//! multi-jittered pattern (see [`Sampler::mark_path_start`]). [`SamplerKind::Stratified`] is
//! the classic jittered sampler: every pair of dimensions is a correlated multi-jittered
//! pattern (Kensler 2013; a jittered grid whose projections are also stratified) and every
//! single dimension is cut into `spp` strata, each dimension with its own shuffle of the
//! strata. [`SamplerKind::Independent`] draws every number
//! from the pixel's PCG32 stream. Free-standing samplers (tests, preprocessing) are plain PCG32
//! streams.

use super::pcg::{hash2, Pcg32};

/// How the samples of a pixel are placed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Owen-scrambled Sobol pairs (stratified in every pair of dimensions).
    #[default]
    Sobol,
    /// Jittered strata: correlated multi-jittered pairs, `spp` strata per single dimension.
    Stratified,
    /// Independent uniform numbers.
    Independent,
}

impl SamplerKind {
    /// The names accepted by [`SamplerKind::from_name`].
    pub const NAMES: [&'static str; 3] = ["sobol", "stratified", "independent"];

    /// The sampler called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "sobol" => Some(Self::Sobol),
            "stratified" => Some(Self::Stratified),
            "independent" => Some(Self::Independent),
            _ => None,
        }
    }
}

/// Where a sample of a pixel is: see [`Sampler::cursor`].
#[derive(Clone, Copy, Debug)]
pub struct SampleCursor {
    index: u32,
    /// `index` with its bits reversed, kept with it: a path traced beside others resumes its
    /// sample at every vertex, and x86 reverses bits in some twenty instructions.
    rindex: u32,
    dim: u32,
    rng: Pcg32,
}

/// The sample source handed to integrators: uniform numbers in `[0, 1)`.
#[derive(Clone, Debug)]
pub struct Sampler {
    rng: Pcg32,
    /// The pixel's seed (independent samplers seed each sample's stream with it).
    pixel_seed: u64,
    spp: u32,
    /// The first sample index the current pass draws (tables start there, or before).
    begin: u32,
    /// One past the last sample index the current pass draws (tables stop there).
    end: u32,
    /// How the numbers are made, with the pixel's pattern seed.
    mode: Mode,
    /// The sample being drawn, and its index with the bits reversed.
    index: u32,
    rindex: u32,
    /// The next dimension of the sample.
    dim: u32,
    /// The scrambling seeds of the first [`CACHED_DIMS`] dimensions (see [`DimSeeds`]), which
    /// depend only on the pixel and the dimension: computed by the first sample that reaches a
    /// dimension and reused by the pixel's other samples.
    seeds: [DimSeeds; CACHED_DIMS],
    /// Bit `d` set when `seeds[d]` holds the seeds of dimension `d`.
    cached: u64,
    /// The first sample of the current chunk of [`CHUNK`] samples (see [`Batch`]).
    chunk: u32,
    /// Bit `d` set when `batch[d]` holds dimension `d` of the chunk's samples from
    /// `batch_from[d]` on.
    batched: u32,
    batch_from: [u8; BATCH_DIMS],
    /// The pairs of the first [`BATCH_DIMS`] dimensions of the chunk's samples, as
    /// [`Sampler::next_2d`] returns them (the first of a pair is [`Sampler::next_1d`]'s number).
    batch: [[[f32; 2]; CHUNK]; BATCH_DIMS],
    /// The dimension of the first vertex's direction pair (see [`Sampler::mark_path_start`]),
    /// `u32::MAX` before a path has started.
    direction_dim: u32,
}

/// A sampler's way of making numbers (see [`SamplerKind`]), with the pixel's seed.
#[derive(Clone, Copy, Debug)]
enum Mode {
    Independent,
    Sobol(u32),
    Strata(u32),
}

/// Samples whose first dimensions a Sobol pixel sampler computes together.
const CHUNK: usize = 64;

/// The samples of a pixel whose numbers a Sobol pixel sampler tabulates together: samples
/// `k·TABLE_SAMPLES..(k + 1)·TABLE_SAMPLES`, drawn in any order, share the tables.
pub const TABLE_SAMPLES: usize = CHUNK;

/// Dimensions a Sobol pixel sampler computes a chunk at a time (at most 32).
const BATCH_DIMS: usize = 32;

/// Dimensions whose seeds a pixel sampler keeps.
const CACHED_DIMS: usize = 64;

/// The seeds of one dimension of a pixel: the shuffle seed and the scramble seeds of the two
/// coordinates of a pair.
#[derive(Clone, Copy, Debug, Default)]
struct DimSeeds {
    shuffle: u32,
    x: u32,
    y: u32,
}

impl DimSeeds {
    #[inline(always)]
    fn new(seed: u32, dim: u32) -> Self {
        let s = hash_u32(seed, dim);
        Self {
            shuffle: s,
            x: mix32(s ^ 0x5bd1_e995),
            y: mix32(s ^ 0x27d4_eb2f),
        }
    }
}

impl Sampler {
    /// The sampler of pixel number `pixel` (row-major index) for an image rendered with `seed`
    /// and `spp` samples per pixel.
    pub fn for_pixel(seed: u64, pixel: u64, spp: u32) -> Self {
        Self::for_pixel_with(SamplerKind::Sobol, seed, pixel, spp)
    }

    /// The sampler of kind `kind` for pixel number `pixel` (row-major index) of an image
    /// rendered with `seed` and `spp` samples per pixel.
    pub fn for_pixel_with(kind: SamplerKind, seed: u64, pixel: u64, spp: u32) -> Self {
        let mut s = Self::new(0, 0);
        s.reset_for_pixel(kind, seed, pixel, spp);
        s
    }

    /// Turns this sampler into [`Sampler::for_pixel_with`]`(kind, seed, pixel, spp)`, reusing
    /// its storage (cheaper than building a new one: the tables are not cleared).
    pub fn reset_for_pixel(&mut self, kind: SamplerKind, seed: u64, pixel: u64, spp: u32) {
        let h = hash2(seed, pixel);
        let pattern = (h >> 32) as u32 ^ h as u32;
        self.rng = Pcg32::new(h, pixel);
        self.pixel_seed = h;
        self.spp = spp.max(1);
        self.begin = 0;
        self.end = self.spp;
        self.mode = match kind {
            SamplerKind::Sobol => Mode::Sobol(pattern),
            SamplerKind::Stratified => Mode::Strata(pattern),
            SamplerKind::Independent => Mode::Independent,
        };
        self.index = 0;
        self.rindex = 0;
        self.dim = 0;
        self.cached = 0;
        self.chunk = 0;
        self.batched = 0;
        self.direction_dim = u32::MAX;
    }

    /// Says that this pixel's samples will be drawn up to index `end` (exclusive) only, so
    /// that the tables of a short pass are not filled beyond it (the values do not change).
    pub fn draw_until(&mut self, end: u32) {
        self.end = end.clamp(1, self.spp);
    }

    /// Says that this pixel's samples `first..end` will be drawn, in any order: a table is
    /// filled for all of them (from the chunk's first one on) the first time any of them
    /// needs it, so that a sample that comes to a dimension after a later one still finds it
    /// tabulated. The values do not change.
    pub fn draw_range(&mut self, first: u32, end: u32) {
        self.begin = first;
        self.draw_until(end);
    }

    /// Says that the camera's numbers of the current sample are drawn and its path starts at
    /// the next dimension. A path's first vertex draws a light pair, a lobe number and then
    /// its direction pair (see `integrator::path`); a Sobol sampler draws that direction pair,
    /// three dimensions on, from a correlated multi-jittered pattern instead of its Sobol
    /// pair. It is the pair whose stratification the image's error depends on most, and
    /// Kensler's pattern spreads the 64 points of a pixel more evenly there than the
    /// scrambled (0, 2)-net does (RMSE over 12 seeds at 64 spp: the Cornell box 0.00976 →
    /// 0.00941, the bench's meshes 0.00655 → 0.00638, the box under a sphere light 0.01636 →
    /// 0.01584; at the pixel and light pairs the Sobol pairs do better, coupled by their
    /// nested shuffles). The same for every sample of a pixel, so the numbers stay a function
    /// of the pixel, the sample index and the dimension.
    pub fn mark_path_start(&mut self) {
        if let Mode::Sobol(_) = self.mode {
            self.direction_dim = self.dim + 3;
        }
    }

    /// The current sample's point of the multi-jittered direction pair
    /// ([`Sampler::mark_path_start`]) of a Sobol sampler with seed `seed`.
    fn direction_pair(&self, seed: u32) -> [f32; 2] {
        cmj(
            self.index % self.spp,
            self.spp,
            cmj_pattern(seed, self.direction_dim),
        )
    }

    /// A free-standing independent sampler (tests, preprocessing) seeded by `seed` on stream
    /// `stream`.
    pub fn new(seed: u64, stream: u64) -> Self {
        Self {
            rng: Pcg32::new(hash2(seed, stream), stream),
            pixel_seed: hash2(seed, stream),
            spp: 1,
            begin: 0,
            end: 1,
            mode: Mode::Independent,
            index: 0,
            rindex: 0,
            dim: 0,
            seeds: [DimSeeds::default(); CACHED_DIMS],
            cached: 0,
            chunk: 0,
            batched: 0,
            batch_from: [0; BATCH_DIMS],
            batch: [[[0.0; 2]; CHUNK]; BATCH_DIMS],
            direction_dim: u32::MAX,
        }
    }

    /// Starts sample `index` of the pixel: the next numbers are its dimensions from the first.
    #[inline]
    pub fn start_sample(&mut self, index: u32) {
        self.index = index;
        self.rindex = index.reverse_bits();
        self.dim = 0;
        if let Mode::Independent = self.mode {
            // Every sample its own stream, so that a sample's numbers do not depend on how
            // many the samples before it drew.
            self.rng = Pcg32::new(hash2(self.pixel_seed, index as u64), index as u64);
        }
        let chunk = index & !(CHUNK as u32 - 1);
        if chunk != self.chunk {
            self.chunk = chunk;
            self.batched = 0;
        }
    }

    /// Where the current sample is: its index and next dimension (with an independent
    /// sampler's stream). Paths traced side by side each keep theirs and [`Sampler::resume`]
    /// it before drawing.
    #[inline]
    pub fn cursor(&self) -> SampleCursor {
        SampleCursor {
            index: self.index,
            rindex: self.rindex,
            dim: self.dim,
            rng: self.rng,
        }
    }

    /// Continues the sample at `c` (a [`Sampler::cursor`] of this pixel).
    #[inline]
    pub fn resume(&mut self, c: SampleCursor) {
        if c.index != self.index {
            self.index = c.index;
            self.rindex = c.rindex;
            let chunk = c.index & !(CHUNK as u32 - 1);
            if chunk != self.chunk {
                self.chunk = chunk;
                self.batched = 0;
            }
        }
        self.dim = c.dim;
        self.rng = c.rng;
    }

    /// The position of sample `index` inside the pixel, in `[0,1)²`: the pixel centre when the
    /// pixel takes a single sample (the course's convention), otherwise the sample's first pair
    /// of dimensions. Starts the sample.
    pub fn pixel_sample(&mut self, index: u32) -> [f32; 2] {
        self.start_sample(index);
        if self.spp == 1 {
            return [0.5, 0.5];
        }
        self.next_2d()
    }

    /// The seeds of dimension `dim` of a Sobol sampler with pixel seed `seed`.
    #[inline(always)]
    fn dim_seeds(&mut self, seed: u32, dim: u32) -> DimSeeds {
        if (dim as usize) < CACHED_DIMS {
            if self.cached & (1 << dim) != 0 {
                return self.seeds[dim as usize];
            }
            let d = DimSeeds::new(seed, dim);
            self.seeds[dim as usize] = d;
            self.cached |= 1 << dim;
            d
        } else {
            DimSeeds::new(seed, dim)
        }
    }

    /// The pair of dimension `self.dim` of the current sample (of a Sobol sampler with pixel
    /// seed `seed`) from the chunk's table, which is filled for this dimension from the current
    /// sample on the first time the chunk reaches it; `None` when the dimension is not
    /// tabulated, or (samples drawn out of order) was tabulated from a later sample.
    #[inline(always)]
    fn batched(&mut self, seed: u32) -> Option<[f32; 2]> {
        let d = self.dim as usize;
        if d >= BATCH_DIMS {
            return None;
        }
        let j = self.index.wrapping_sub(self.chunk) as usize;
        if self.batched & (1 << d) == 0 {
            self.fill(seed, d, j);
        } else if j < self.batch_from[d] as usize {
            return None;
        }
        Some(self.batch[d][j])
    }

    /// Tabulates dimension `d` of the chunk's samples from sample `j` of the chunk on.
    #[inline(never)]
    fn fill(&mut self, seed: u32, d: usize, j: usize) {
        let s = self.dim_seeds(seed, d as u32);
        let j = (self.begin.saturating_sub(self.chunk) as usize).min(j);
        let n = (self.end.saturating_sub(self.chunk) as usize).clamp(j + 1, CHUNK);
        self.batched |= 1 << d;
        self.batch_from[d] = j as u8;
        if d as u32 == self.direction_dim {
            if let Mode::Sobol(seed) = self.mode {
                crate::simd::run_auto_at(
                    crate::simd::SimdLevel::detected(),
                    CmjBatch {
                        out: &mut self.batch[d][j..n],
                        first: self.chunk + j as u32,
                        spp: self.spp,
                        pattern: cmj_pattern(seed, d as u32),
                    },
                );
                return;
            }
        }
        crate::simd::run_auto_at(
            crate::simd::SimdLevel::detected(),
            Batch {
                out: &mut self.batch[d][j..n],
                first: self.chunk + j as u32,
                seeds: s,
            },
        );
    }

    /// The tabulated pair of the current dimension of a Sobol sampler, when the chunk's table
    /// holds it (the common case, kept inline; [`Sampler::batched`] fills tables).
    #[inline(always)]
    fn tabulated(&self) -> Option<[f32; 2]> {
        if let Mode::Sobol(_) = self.mode {
            let d = self.dim as usize;
            if d < BATCH_DIMS && self.batched & (1 << d) != 0 {
                let j = self.index.wrapping_sub(self.chunk) as usize;
                if j >= self.batch_from[d] as usize && j < CHUNK {
                    return Some(self.batch[d][j]);
                }
            }
        }
        None
    }

    /// Passes over the next uniform number without computing it: the sequence goes on as after
    /// [`Sampler::next_1d`] (for a vertex that draws a number it does not need, so that the
    /// numbers after it stay where they are), but a tabulated dimension nobody reads is never
    /// tabulated.
    #[inline(always)]
    pub fn skip_1d(&mut self) {
        match self.mode {
            Mode::Independent => {
                self.rng.next_u32();
            }
            Mode::Sobol(_) | Mode::Strata(_) => self.dim += 1,
        }
    }

    /// The next uniform number.
    #[inline(always)]
    pub fn next_1d(&mut self) -> f32 {
        if let Some(p) = self.tabulated() {
            self.dim += 1;
            return p[0];
        }
        self.next_1d_general()
    }

    /// [`Sampler::next_1d`] for every case.
    #[inline(never)]
    fn next_1d_general(&mut self) -> f32 {
        match self.mode {
            Mode::Sobol(seed) => {
                if let Some(p) = self.batched(seed) {
                    self.dim += 1;
                    return p[0];
                }
                if self.dim == self.direction_dim {
                    self.dim += 1;
                    return self.direction_pair(seed)[0];
                }
                let s = self.dim_seeds(seed, self.dim);
                self.dim += 1;
                // With R the bit reversal and i = R(LK(R(index))) the shuffled index, the van
                // der Corput point R(i) scrambled is R(LK(i)).
                let r = laine_karras(self.rindex, s.shuffle);
                to_unit(laine_karras(r.reverse_bits(), s.x).reverse_bits())
            }
            Mode::Strata(pattern) => {
                let p = hash_u32(pattern, self.dim);
                self.dim += 1;
                let n = self.spp;
                let stratum = permute(self.index % n, n, p);
                ((stratum as f32 + randfloat(self.index, p ^ 0x2c1b_3c6d)) / n as f32)
                    .min(ONE_MINUS_EPSILON)
            }
            Mode::Independent => self.rng.next_f32(),
        }
    }

    /// The next pair of uniform numbers.
    #[inline(always)]
    pub fn next_2d(&mut self) -> [f32; 2] {
        if let Some(p) = self.tabulated() {
            self.dim += 2;
            return p;
        }
        self.next_2d_general()
    }

    /// [`Sampler::next_2d`] for every case.
    #[inline(never)]
    fn next_2d_general(&mut self) -> [f32; 2] {
        match self.mode {
            Mode::Sobol(seed) => {
                if let Some(p) = self.batched(seed) {
                    self.dim += 2;
                    return p;
                }
                if self.dim == self.direction_dim {
                    self.dim += 2;
                    return self.direction_pair(seed);
                }
                let s = self.dim_seeds(seed, self.dim);
                self.dim += 2;
                // The shuffled index is i = R(r) with r = LK(R(index)) (R: bit reversal). The
                // scrambled points are R(LK(R(vdc(i)))) = R(LK(i)) and R(LK(R(sobol1(i)))) =
                // R(LK(G(r))) with G = R∘sobol1∘R, i.e. G(r) = reversed_sobol_dim1(R(r)).
                let r = laine_karras(self.rindex, s.shuffle);
                let rr = r.reverse_bits();
                let x = laine_karras(rr, s.x);
                let y = laine_karras(reversed_sobol_dim1(rr), s.y);
                // Both final reversals in one: reversing the 64 bits of (x, y) gives (R(y), R(x)).
                let xy = ((x as u64) << 32 | y as u64).reverse_bits();
                [to_unit(xy as u32), to_unit((xy >> 32) as u32)]
            }
            Mode::Strata(pattern) => {
                let p = hash_u32(pattern, self.dim);
                self.dim += 2;
                cmj(self.index % self.spp, self.spp, p)
            }
            Mode::Independent => {
                let a = self.rng.next_f32();
                let b = self.rng.next_f32();
                [a, b]
            }
        }
    }

    /// The pair of the current dimension computed directly, without the chunk's tables (tests).
    #[cfg(test)]
    fn next_2d_general_direct(&mut self, seed: u32) -> [f32; 2] {
        let s = DimSeeds::new(seed, self.dim);
        self.dim += 2;
        let r = laine_karras(self.rindex, s.shuffle);
        let rr = r.reverse_bits();
        let x = laine_karras(rr, s.x).reverse_bits();
        let y = laine_karras(reversed_sobol_dim1(rr), s.y).reverse_bits();
        [to_unit(x), to_unit(y)]
    }

    /// The numbers a Lambert vertex draws, in order: a pair (the light sample), one number
    /// passed over, a pair (the direction) and, when `roulette`, one number: what
    /// [`Sampler::next_2d`], [`Sampler::skip_1d`], [`Sampler::next_2d`] and
    /// [`Sampler::next_1d`] give one after another, read from the chunk's tables at once when
    /// they hold them all.
    #[inline(always)]
    pub fn lambert_numbers(&mut self, roulette: bool) -> ([f32; 2], [f32; 2], Option<f32>) {
        let (u, _, u2, u_rr) = self.vertex_numbers::<false>(roulette);
        (u, u2, u_rr)
    }

    /// [`Sampler::lambert_numbers`] with the number passed over there: what a vertex that
    /// chooses between lobes draws (the rough plastic of the path tracer's lanes), what
    /// [`Sampler::next_2d`], [`Sampler::next_1d`], [`Sampler::next_2d`] and
    /// [`Sampler::next_1d`] give one after another.
    #[inline(always)]
    pub fn surface_numbers(&mut self, roulette: bool) -> ([f32; 2], f32, [f32; 2], Option<f32>) {
        self.vertex_numbers::<true>(roulette)
    }

    /// [`Sampler::surface_numbers`], its third number drawn only with `LOBE` (passed over, and
    /// returned as 0, without).
    #[inline(always)]
    fn vertex_numbers<const LOBE: bool>(
        &mut self,
        roulette: bool,
    ) -> ([f32; 2], f32, [f32; 2], Option<f32>) {
        if let Mode::Sobol(_) = self.mode {
            let d = self.dim as usize;
            let j = self.index.wrapping_sub(self.chunk) as usize;
            // The tables of dimensions d, d + 3, (with the roulette) d + 5 and (with the
            // lobe's number) d + 2.
            let need = (if roulette { 0b10_1001 } else { 0b1001 }) | if LOBE { 0b100 } else { 0 };
            if d + 6 <= BATCH_DIMS
                && j < CHUNK
                && (self.batched >> d) & need == need
                && j >= self.batch_from[d] as usize
                && (!LOBE || j >= self.batch_from[d + 2] as usize)
                && j >= self.batch_from[d + 3] as usize
                && (!roulette || j >= self.batch_from[d + 5] as usize)
            {
                self.dim += if roulette { 6 } else { 5 };
                let u1 = if LOBE { self.batch[d + 2][j][0] } else { 0.0 };
                let u_rr = roulette.then(|| self.batch[d + 5][j][0]);
                return (self.batch[d][j], u1, self.batch[d + 3][j], u_rr);
            }
        }
        let u = self.next_2d();
        let u1 = if LOBE {
            self.next_1d()
        } else {
            self.skip_1d();
            0.0
        };
        let u2 = self.next_2d();
        (u, u1, u2, roulette.then(|| self.next_1d()))
    }

    /// A uniform integer in `[0, n)` (`n` > 0).
    #[inline]
    pub fn next_index(&mut self, n: u32) -> u32 {
        match self.mode {
            Mode::Independent => self.rng.next_bounded(n),
            Mode::Sobol(_) | Mode::Strata(_) => ((self.next_1d() * n as f32) as u32).min(n - 1),
        }
    }
}

/// The pairs of one dimension for consecutive samples, as a kernel for
/// [`crate::simd::run`]: the same numbers as [`Sampler::next_2d`] computes one at a
/// time, but with independent samples side by side (vectorised), and off the path's
/// critical chain.
struct Batch<'a> {
    out: &'a mut [[f32; 2]],
    /// The sample index of `out[0]`.
    first: u32,
    seeds: DimSeeds,
}

impl crate::simd::Kernel for Batch<'_> {
    type Output = ();

    #[inline(always)]
    fn run<I: crate::simd::Isa>(self, _: I) {
        let s = self.seeds;
        for (k, p) in self.out.iter_mut().enumerate() {
            let index = self.first.wrapping_add(k as u32);
            let r = laine_karras(index.reverse_bits(), s.shuffle);
            let rr = r.reverse_bits();
            let x = laine_karras(rr, s.x).reverse_bits();
            let y = laine_karras(reversed_sobol_dim1(rr), s.y).reverse_bits();
            // Below 2^24, the signed conversion (vectorisable) is the unsigned one.
            *p = [
                ((x >> 8) as i32) as f32 * (1.0 / 16_777_216.0),
                ((y >> 8) as i32) as f32 * (1.0 / 16_777_216.0),
            ];
        }
    }
}

/// A correlated multi-jittered dimension ([`Sampler::mark_path_start`]) for consecutive
/// samples, as a kernel for [`crate::simd::run`]: [`cmj`] of each, without loops when `spp`
/// is a power of four (8 × 8 for 64), so that it vectorises as [`Batch`] does.
struct CmjBatch<'a> {
    out: &'a mut [[f32; 2]],
    /// The sample index of `out[0]`.
    first: u32,
    spp: u32,
    pattern: u32,
}

impl crate::simd::Kernel for CmjBatch<'_> {
    type Output = ();

    #[inline(always)]
    fn run<I: crate::simd::Isa>(self, _: I) {
        let (n, p) = (self.spp, self.pattern);
        if let Some(m) = power_of_two_columns(n) {
            for (k, o) in self.out.iter_mut().enumerate() {
                *o = cmj_grid(
                    self.first.wrapping_add(k as u32) % n,
                    n,
                    (m, n / m),
                    p,
                    permute_pow2,
                );
            }
        } else {
            // Sixteen points at a time, each step a loop over the lanes that compiles to
            // vector code: the cycle walks run until every lane has left them.
            let m = ((n as f32).sqrt() as u32).max(1);
            let nn = n.div_ceil(m);
            let (inv_n, inv_m) = (1.0 / n as f64, 1.0 / m as f64);
            for (b, out) in self.out.chunks_mut(CMJ_LANES).enumerate() {
                let base = self.first.wrapping_add((b * CMJ_LANES) as u32);
                let idx: [u32; CMJ_LANES] =
                    std::array::from_fn(|k| div_rem(base.wrapping_add(k as u32), n, inv_n).1);
                let s = permute_lanes(idx, n, p.wrapping_mul(0x51633e2d));
                let (sy_in, sx_in) = {
                    let qr: [(u32, u32); CMJ_LANES] =
                        std::array::from_fn(|k| div_rem(s[k], m, inv_m));
                    (qr.map(|x| x.0), qr.map(|x| x.1))
                };
                let sx = permute_lanes(sx_in, m, p.wrapping_mul(0x68bc21eb));
                let sy = permute_lanes(sy_in, nn, p.wrapping_mul(0x02e5be93));
                for (k, o) in out.iter_mut().enumerate() {
                    *o = cmj_point(s[k], n, (m, nn), (sx[k], sy[k]), p);
                }
            }
        }
    }
}

/// Points [`CmjBatch`] computes side by side for counts other than powers of two.
const CMJ_LANES: usize = 16;

/// `(x / d, x % d)` (d > 0) without an integer division, so that a loop over lanes
/// vectorises: the quotient as x times `inv`, d's reciprocal in f64 (within one of the
/// quotient for every u32 x and d), then corrected.
#[inline(always)]
fn div_rem(x: u32, d: u32, inv: f64) -> (u32, u32) {
    let mut q = (x as f64 * inv) as u32;
    if q as u64 * d as u64 > x as u64 {
        q -= 1;
    } else if (q as u64 + 1) * d as u64 <= x as u64 {
        q += 1;
    }
    (q, x - q * d)
}

/// [`permute`] on sixteen elements of `[0, l)` at once (the same elements, bit for bit): each
/// lane's cycle walk stops where its own would, the others going on.
#[inline(always)]
fn permute_lanes(i: [u32; CMJ_LANES], l: u32, p: u32) -> [u32; CMJ_LANES] {
    let w = walk_mask(l);
    let mut v = i.map(|x| permute_round(x, w, p));
    while v.iter().any(|&x| x >= l) {
        for x in &mut v {
            let r = permute_round(*x, w, p);
            *x = if *x >= l { r } else { *x };
        }
    }
    let inv = 1.0 / l as f64;
    v.map(|x| div_rem(x.wrapping_add(p), l, inv).1)
}

/// The pattern seed of a correlated multi-jittered dimension `dim` of a Sobol pixel sampler
/// with seed `seed`.
#[inline]
fn cmj_pattern(seed: u32, dim: u32) -> u32 {
    hash_u32(seed ^ 0x2545_f491, dim)
}

/// The second Sobol dimension of index `i`, bit-reversed: R(sobol₁(i)) is the superset sum
/// Z(i) (by Lucas' theorem, bit 31 − m of sobol₁(i) is the parity of the set bits k ⊇ m of
/// i), so G(r) = R(sobol₁(R(r))) = Z(R(r)). ALU operations only.
#[inline(always)]
fn reversed_sobol_dim1(mut x: u32) -> u32 {
    x ^= (x & 0xaaaa_aaaa) >> 1;
    x ^= (x & 0xcccc_cccc) >> 2;
    x ^= (x & 0xf0f0_f0f0) >> 4;
    x ^= (x & 0xff00_ff00) >> 8;
    x ^ (x & 0xffff_0000) >> 16
}

/// Laine and Karras' hash-based permutation, which only lets bits influence higher bits.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50b47c);
    x ^= x.wrapping_mul(0xb82f1e52);
    x ^= x.wrapping_mul(0xc7afe638);
    x ^= x.wrapping_mul(0x8d22f6e6);
    x
}

/// A 32-bit integer hash with low bias (Chris Wellons' "lowbias32").
#[inline]
fn mix32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// Combines a seed and a dimension into a new seed.
#[inline]
fn hash_u32(seed: u32, dim: u32) -> u32 {
    mix32(seed ^ mix32(dim.wrapping_mul(0x9e37_79b9).wrapping_add(0x632b_e5ab)))
}

#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Kensler's hash-based permutation of `[0, l)`: element `i` of permutation `p`.
fn permute(mut i: u32, l: u32, p: u32) -> u32 {
    let w = walk_mask(l);
    loop {
        i = permute_round(i, w, p);
        if i < l {
            break;
        }
    }
    (i.wrapping_add(p)) % l
}

/// The mask of [`permute`]'s cycle walk over `[0, l)`: all ones below l − 1's top bit and at it.
#[inline(always)]
fn walk_mask(l: u32) -> u32 {
    let mut w = l - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w | w >> 16
}

/// [`permute`] for `l` a power of two: its first round always lands in `[0, l)` then (the
/// round ends masked to l − 1, and `i ^ i >> 5` keeps the highest bit), so one round without
/// the loop gives the same element.
#[inline(always)]
fn permute_pow2(i: u32, l: u32, p: u32) -> u32 {
    permute_round(i, l - 1, p).wrapping_add(p) & (l - 1)
}

/// One round of [`permute`]'s cycle walk, within the mask `w` (all ones below l's top bit).
#[inline(always)]
fn permute_round(mut i: u32, w: u32, p: u32) -> u32 {
    i ^= p;
    i = i.wrapping_mul(0xe170893d);
    i ^= p >> 16;
    i ^= (i & w) >> 4;
    i ^= p >> 8;
    i = i.wrapping_mul(0x0929eb3f);
    i ^= p >> 23;
    i ^= (i & w) >> 1;
    i = i.wrapping_mul(1 | p >> 27);
    i = i.wrapping_mul(0x6935fa69);
    i ^= (i & w) >> 11;
    i = i.wrapping_mul(0x74dcb303);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0x9e501cc3);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0xc860a3df);
    i &= w;
    i ^ i >> 5
}

/// Kensler's hash to a float in `[0, 1)`.
fn randfloat(mut i: u32, p: u32) -> f32 {
    i ^= p;
    i ^= i >> 17;
    i ^= i >> 10;
    i = i.wrapping_mul(0xb36534e5);
    i ^= i >> 12;
    i ^= i >> 21;
    i = i.wrapping_mul(0x93fc4795);
    i ^= 0xdf6e307f;
    i ^= i >> 17;
    i = i.wrapping_mul(1 | p >> 18);
    (i >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Correlated multi-jittered sample `s` of `n` with pattern `p` (Kensler 2013, "Correlated
/// Multi-Jittered Sampling"). A power of two takes the grid of m × n/m cells with m the power of
/// two nearest √n from below (8 × 8 for 64, 8 × 16 for 128: one point per cell, row and
/// column), whose permutations need no cycle walk, so that the sampler's tables compute a
/// pixel's points many lanes at a time; other counts take the aspect-ratio-1 grid of m × ⌈n/m⌉
/// cells, m = ⌊√n⌋. (At 32 and 128 spp, the 5 × 7 and 11 × 12 grids' cycle walks took 14 % of a
/// Cornell box frame, one point at a time.)
pub fn cmj(s: u32, n: u32, p: u32) -> [f32; 2] {
    if let Some(m) = power_of_two_columns(n) {
        return cmj_grid(s, n, (m, n / m), p, permute_pow2);
    }
    let m = ((n as f32).sqrt() as u32).max(1);
    cmj_grid(s, n, (m, n.div_ceil(m)), p, permute)
}

/// [`cmj`] on the grid of `m` × `nn` cells, with `perm` for [`permute`] (or [`permute_pow2`],
/// the same elements without a loop when the counts are powers of two).
#[inline(always)]
fn cmj_grid(
    s: u32,
    n: u32,
    (m, nn): (u32, u32),
    p: u32,
    perm: impl Fn(u32, u32, u32) -> u32,
) -> [f32; 2] {
    let s = perm(s % n, n, p.wrapping_mul(0x51633e2d));
    let sx = perm(s % m, m, p.wrapping_mul(0x68bc21eb));
    let sy = perm(s / m, nn, p.wrapping_mul(0x02e5be93));
    cmj_point(s, n, (m, nn), (sx, sy), p)
}

/// The point of [`cmj_grid`] from its permuted index `s` and its column and row `(sx, sy)`.
#[inline(always)]
fn cmj_point(s: u32, n: u32, (m, nn): (u32, u32), (sx, sy): (u32, u32), p: u32) -> [f32; 2] {
    let jx = randfloat(s, p.wrapping_mul(0x967a889b));
    let jy = randfloat(s, p.wrapping_mul(0x368cc8b7));
    let x = (sx as f32 + (sy as f32 + jx) / nn as f32) / m as f32;
    let y = (s as f32 + jy) / n as f32;
    [x.min(ONE_MINUS_EPSILON), y.min(ONE_MINUS_EPSILON)]
}

/// The columns of [`cmj`]'s grid of a power of two `n`: the power of two nearest √n from
/// below (√n itself for a power of four); `None` for other counts.
#[inline(always)]
fn power_of_two_columns(n: u32) -> Option<u32> {
    n.is_power_of_two().then(|| 1 << (n.trailing_zeros() / 2))
}

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// A Lambert vertex's numbers drawn at once are the ones drawn one by one, from every
    /// dimension (tabulated or not, the tables' last ones included), with and without the
    /// roulette's, and from samples drawn out of order (their tables filled by a later sample).
    #[test]
    fn lambert_numbers_are_the_numbers_drawn_one_by_one() {
        for kind in [
            SamplerKind::Sobol,
            SamplerKind::Stratified,
            SamplerKind::Independent,
        ] {
            for (first, index) in [(0u32, 0u32), (0, 5), (0, 63), (64, 100), (40, 20)] {
                for start in 0..40 {
                    for roulette in [false, true] {
                        let mut one = Sampler::for_pixel_with(kind, 3, 17, 128);
                        one.draw_range(first.min(index), 128);
                        // A later sample fills the tables first.
                        one.pixel_sample(first);
                        for _ in 0..start + 6 {
                            one.next_1d();
                        }
                        let mut all = one.clone();
                        for s in [&mut one, &mut all] {
                            s.pixel_sample(index);
                            for _ in 0..start {
                                s.skip_1d();
                            }
                        }
                        let u = one.next_2d();
                        one.skip_1d();
                        let u2 = one.next_2d();
                        let u_rr = roulette.then(|| one.next_1d());
                        let mut other = all.clone();
                        let mut third = all.clone();
                        third.next_2d();
                        let u1 = third.next_1d();
                        let got = all.lambert_numbers(roulette);
                        // The same with the number passed over, and the same cursor after.
                        let full = other.surface_numbers(roulette);
                        assert_eq!(other.next_1d().to_bits(), all.clone().next_1d().to_bits());
                        assert_eq!(full.1.to_bits(), u1.to_bits());
                        assert_eq!(full.0.map(f32::to_bits), got.0.map(f32::to_bits));
                        assert_eq!(full.2.map(f32::to_bits), got.1.map(f32::to_bits));
                        assert_eq!(full.3.map(f32::to_bits), got.2.map(f32::to_bits));
                        let at = format!("{kind:?} {first} {index} {start} {roulette}");
                        assert_eq!(got.0.map(f32::to_bits), u.map(f32::to_bits), "{at}");
                        assert_eq!(got.1.map(f32::to_bits), u2.map(f32::to_bits), "{at}");
                        assert_eq!(got.2.map(f32::to_bits), u_rr.map(f32::to_bits), "{at}");
                        assert_eq!(one.next_1d().to_bits(), all.next_1d().to_bits(), "{at}");
                    }
                }
            }
        }
    }

    /// The first 2^k samples of every pair of dimensions form a (0, 2)-net: each of the 2^k
    /// elementary intervals of area 2^-k holds exactly one point (checked for 1 × 2^k strips
    /// and square cells).
    #[test]
    fn a_skipped_number_leaves_the_rest_of_the_sequence_in_place() {
        for kind in [
            SamplerKind::Sobol,
            SamplerKind::Stratified,
            SamplerKind::Independent,
        ] {
            for index in [0u32, 5, 63, 64, 100] {
                let mut drawn = Sampler::for_pixel_with(kind, 3, 17, 128);
                let mut skipped = drawn.clone();
                drawn.pixel_sample(index);
                skipped.pixel_sample(index);
                // Tabulated and computed dimensions alike (the tables stop at BATCH_DIMS).
                for k in 0..2 * BATCH_DIMS {
                    if k % 3 == 1 {
                        drawn.next_1d();
                        skipped.skip_1d();
                    } else {
                        let (a, b) = (drawn.next_2d(), skipped.next_2d());
                        assert_eq!(
                            a.map(f32::to_bits),
                            b.map(f32::to_bits),
                            "{kind:?} {index} {k}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn sobol_pairs_are_stratified() {
        for n in [16u32, 64, 256] {
            let mut s = Sampler::for_pixel(1, 99, n);
            let pts: Vec<[[f32; 2]; 3]> = (0..n)
                .map(|i| {
                    s.start_sample(i);
                    [s.next_2d(), s.next_2d(), s.next_2d()]
                })
                .collect();
            let k = n.trailing_zeros();
            for pair in 0..3 {
                for (cols, rows) in [(n, 1), (1, n), (1 << (k / 2), 1 << (k - k / 2))] {
                    let mut seen = vec![false; n as usize];
                    for p in &pts {
                        let [x, y] = p[pair];
                        let c = ((x * cols as f32) as u32) + cols * ((y * rows as f32) as u32);
                        assert!(!seen[c as usize], "n {n}, pair {pair}: cell {c} twice");
                        seen[c as usize] = true;
                    }
                }
            }
        }
    }

    /// The ALU form of the reversed second Sobol dimension is R(sobol₁) computed from its
    /// direction numbers v_k = v_{k−1} ⊕ v_{k−1}/2, v_0 = 2³¹ (both are linear over GF(2), so
    /// the 32 unit vectors decide).
    #[test]
    fn reversed_sobol_dim1_matches_the_direction_numbers() {
        let mut v = 1u32 << 31;
        for b in 0..32 {
            assert_eq!(reversed_sobol_dim1(1 << b), v.reverse_bits(), "bit {b}");
            v ^= v >> 1;
        }
    }

    /// The chunk tables give exactly the numbers computed one at a time, whatever the order of
    /// the samples, the sample count (chunks of 64, partial chunks) and the 1D/2D mix.
    #[test]
    fn tabulated_dimensions_match_the_direct_computation() {
        // The direct computation: dimension `dim` of sample `index`.
        let direct = |seed: u32, index: u32, dim: u32| {
            let s = DimSeeds::new(seed, dim);
            let r = laine_karras(index.reverse_bits(), s.shuffle);
            let x = laine_karras(r.reverse_bits(), s.x).reverse_bits();
            let y = laine_karras(reversed_sobol_dim1(r.reverse_bits()), s.y).reverse_bits();
            [to_unit(x), to_unit(y)]
        };
        for spp in [1u32, 5, 64, 100, 200] {
            let mut s = Sampler::for_pixel(7, 1234, spp);
            let Mode::Sobol(seed) = s.mode else {
                panic!("sobol")
            };
            let mut order: Vec<u32> = (0..spp).collect();
            // Forward, then a scrambled order (earlier samples after later ones).
            order.extend((0..spp).map(|i| (i * 37 + 11) % spp));
            for (k, &i) in order.iter().enumerate() {
                s.start_sample(i);
                let mut dim = 0;
                while dim < BATCH_DIMS as u32 + 6 {
                    if (k + dim as usize).is_multiple_of(3) {
                        assert_eq!(s.next_1d(), direct(seed, i, dim)[0], "{spp} {i} {dim}");
                        dim += 1;
                    } else {
                        assert_eq!(s.next_2d(), direct(seed, i, dim), "{spp} {i} {dim}");
                        dim += 2;
                    }
                }
            }
            // A reset sampler gives the numbers of a new one.
            let mut t = Sampler::for_pixel(7, 99, spp);
            s.reset_for_pixel(SamplerKind::Sobol, 7, 99, spp);
            for i in 0..spp.min(3) {
                s.start_sample(i);
                t.start_sample(i);
                assert_eq!(s.next_2d(), t.next_2d());
                assert_eq!(s.next_1d(), t.next_1d());
            }
        }
    }

    /// The division without a division is the division, at the ends of the range too.
    #[test]
    fn div_rem_divides() {
        let mut rng = Pcg32::new(8, 2);
        let ds = [
            1u32,
            2,
            3,
            7,
            10,
            100,
            255,
            65_537,
            1 << 31,
            u32::MAX - 1,
            u32::MAX,
        ];
        for &d in &ds {
            let xs = [0, 1, d - 1, d, d.wrapping_add(1), u32::MAX, u32::MAX - 1];
            for x in xs.into_iter().chain((0..2000).map(|_| rng.next_u32())) {
                assert_eq!(div_rem(x, d, 1.0 / d as f64), (x / d, x % d), "{x} / {d}");
            }
        }
    }

    /// Kensler's pattern through the loop-free permutation is the general one, bit for bit,
    /// for every power-of-four count (and `permute_pow2` is `permute` for powers of two).
    #[test]
    fn square_cmj_is_the_general_cmj() {
        // The general grid and permutation, with the cycle walk.
        let general = |s: u32, n: u32, p: u32| {
            let m = ((n as f32).sqrt() as u32).max(1);
            cmj_grid(s, n, (m, n.div_ceil(m)), p, permute)
        };
        let mut rng = Pcg32::new(3, 9);
        for n in [1u32, 4, 16, 64, 256, 1024] {
            for _ in 0..2000 {
                let (s, p) = (rng.next_u32() % n, rng.next_u32());
                assert_eq!(
                    cmj(s, n, p).map(f32::to_bits),
                    general(s, n, p).map(f32::to_bits)
                );
            }
        }
        for l in [1u32, 2, 8, 32, 4096] {
            for _ in 0..1000 {
                let (i, p) = (rng.next_u32() % l, rng.next_u32());
                assert_eq!(permute_pow2(i, l, p), permute(i, l, p), "{l}");
            }
        }
    }

    /// After [`Sampler::mark_path_start`], the pair three dimensions on is Kensler's pattern:
    /// the same from the tables as computed directly (samples in any order), stratified as
    /// CMJ is (one point per row; for a power of two, one per column and per cell of the
    /// m × n/m grid too), and the other dimensions
    /// are the Sobol ones still.
    #[test]
    fn the_first_direction_pair_is_multi_jittered() {
        for spp in [2u32, 16, 32, 64, 100, 128] {
            let mut s = Sampler::for_pixel(5, 321, spp);
            let mut plain = Sampler::for_pixel(5, 321, spp);
            let Mode::Sobol(seed) = s.mode else {
                panic!("sobol")
            };
            let order: Vec<u32> = (0..spp)
                .chain((0..spp).map(|i| (i * 37 + 11) % spp))
                .collect();
            let mut pts = vec![[0f32; 2]; spp as usize];
            for &i in &order {
                for t in [&mut s, &mut plain] {
                    t.pixel_sample(i);
                }
                s.mark_path_start();
                let light = s.next_2d();
                assert_eq!(light, plain.next_2d());
                s.skip_1d();
                plain.skip_1d();
                let d = s.next_2d();
                assert_ne!(d, plain.next_2d());
                assert_eq!(d, cmj(i, spp, cmj_pattern(seed, 5)), "{spp} {i}");
                assert_eq!(s.next_2d(), plain.next_2d());
                // A Lambert vertex's numbers drawn at once are these too.
                let mut again = s.clone();
                again.pixel_sample(i);
                let (u, u2, _) = again.lambert_numbers(false);
                assert_eq!((u, u2), (light, d), "{spp} {i}");
                pts[i as usize] = d;
            }
            let n = spp as usize;
            let mut rows = vec![false; n];
            let mut cols = vec![false; n];
            for p in &pts {
                rows[(p[1] * n as f32) as usize] = true;
                cols[(p[0] * n as f32) as usize] = true;
            }
            assert!(rows.iter().all(|&r| r), "{spp}: a row without a point");
            if let Some(m) = power_of_two_columns(spp) {
                // One point per column too, and per cell of the m × n/m grid.
                let nn = spp / m;
                assert!(cols.iter().all(|&c| c), "{spp}: a column without a point");
                let mut cells = vec![false; n];
                for p in &pts {
                    let c = (p[0] * m as f32) as usize + m as usize * (p[1] * nn as f32) as usize;
                    assert!(!cells[c], "{spp}: cell {c} twice");
                    cells[c] = true;
                }
            }
        }
    }

    #[test]
    fn independent_dimensions_are_decorrelated_between_pixels() {
        let mut a = Sampler::for_pixel(1, 5, 4);
        let mut b = Sampler::for_pixel(1, 6, 4);
        a.start_sample(0);
        b.start_sample(0);
        assert_ne!(a.next_2d(), b.next_2d());
        // 1D values are uniform: their mean over many samples is ½.
        let mut s = Sampler::for_pixel(3, 7, 1024);
        let mean: f64 = (0..1024)
            .map(|i| {
                s.start_sample(i);
                s.next_1d();
                s.next_1d() as f64
            })
            .sum::<f64>()
            / 1024.0;
        assert!((mean - 0.5).abs() < 0.01);
    }

    /// The tabulating kernel gives the scalar computation's bits at every instruction-set
    /// level (AVX-512 with GFNI, AVX2, SSE; a level the CPU lacks runs the next one down).
    #[test]
    fn the_tabulating_kernel_gives_the_same_bits_at_every_level() {
        use crate::simd::SimdLevel;
        let mut s = Sampler::for_pixel(3, 77, 64);
        let Mode::Sobol(seed) = s.mode else {
            panic!("sobol")
        };
        for dim in [0u32, 2, 9, 31] {
            let seeds = DimSeeds::new(seed, dim);
            let first = 0x1234_5640;
            let mut want = [[0f32; 2]; CHUNK];
            for (k, p) in want.iter_mut().enumerate() {
                s.start_sample(first + k as u32);
                s.dim = dim;
                *p = s.next_2d_general_direct(seed);
            }
            for level in [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512] {
                for len in [1, 7, 16, 17, CHUNK] {
                    let mut out = [[0f32; 2]; CHUNK];
                    crate::simd::run_auto_at(
                        level,
                        Batch {
                            out: &mut out[..len],
                            first,
                            seeds,
                        },
                    );
                    assert_eq!(out[..len], want[..len], "{level:?} dim {dim} len {len}");
                }
            }
        }
        // The multi-jittered tables too, for square, other power-of-two and other counts.
        for spp in [7u32, 32, 64, 100, 128, 200] {
            let pattern = cmj_pattern(seed, 5);
            let first = 0x1234_5640;
            let want: Vec<[f32; 2]> = (0..CHUNK as u32)
                .map(|k| cmj((first + k) % spp, spp, pattern))
                .collect();
            for level in [SimdLevel::Sse, SimdLevel::Avx2, SimdLevel::Avx512] {
                for len in [1, 7, 16, 17, CHUNK] {
                    let mut out = [[0f32; 2]; CHUNK];
                    crate::simd::run_auto_at(
                        level,
                        CmjBatch {
                            out: &mut out[..len],
                            first,
                            spp,
                            pattern,
                        },
                    );
                    assert_eq!(out[..len], want[..len], "{level:?} spp {spp} len {len}");
                }
            }
        }
    }

    #[test]
    fn one_sample_goes_through_the_pixel_centre() {
        let mut s = Sampler::for_pixel(0, 17, 1);
        assert_eq!(s.pixel_sample(0), [0.5, 0.5]);
    }

    #[test]
    fn cmj_is_stratified_in_both_projections() {
        for n in [4u32, 9, 16, 7, 10, 64] {
            let mut xs = vec![false; n as usize];
            let mut ys = vec![false; n as usize];
            for i in 0..n {
                let [x, y] = cmj(i, n, 12345);
                assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                ys[(y * n as f32) as usize] = true;
                let m = (n as f32).sqrt() as u32;
                if n == m * m {
                    xs[(x * n as f32) as usize] = true;
                }
            }
            assert!(ys.iter().all(|&b| b), "n = {n}: y strata");
            let m = (n as f32).sqrt() as u32;
            if n == m * m {
                assert!(xs.iter().all(|&b| b), "n = {n}: x strata");
            }
        }
    }

    #[test]
    fn stratified_dimensions_fill_every_stratum_once() {
        for n in [4u32, 9, 16, 7, 10] {
            let mut s = Sampler::for_pixel_with(SamplerKind::Stratified, 5, 123, n);
            // Per sample: the pixel pair, two single dimensions, another pair.
            let pts: Vec<([f32; 2], f32, f32, [f32; 2])> = (0..n)
                .map(|i| {
                    let p = s.pixel_sample(i);
                    (p, s.next_1d(), s.next_1d(), s.next_2d())
                })
                .collect();
            let once = |values: Vec<f32>| {
                let mut seen = vec![false; n as usize];
                for v in values {
                    assert!((0.0..1.0).contains(&v));
                    let c = (v * n as f32) as usize;
                    assert!(!seen[c], "n = {n}: stratum {c} twice");
                    seen[c] = true;
                }
            };
            once(pts.iter().map(|p| p.1).collect());
            once(pts.iter().map(|p| p.2).collect());
            for pair in [0, 1] {
                let xy: Vec<[f32; 2]> = pts.iter().map(|p| [p.0, p.3][pair]).collect();
                // Rows of a multi-jittered pattern: each of the n horizontal strips once.
                once(xy.iter().map(|p| p[1]).collect());
                // A square count is a jittered m × m grid.
                let m = (n as f32).sqrt() as u32;
                if m * m == n {
                    let mut seen = vec![false; n as usize];
                    for [x, y] in &xy {
                        let c = (x * m as f32) as usize + m as usize * (y * m as f32) as usize;
                        assert!(!seen[c], "n = {n}: cell {c} twice");
                        seen[c] = true;
                    }
                }
            }
            // The two single dimensions are shuffled differently.
            let a: Vec<u32> = pts.iter().map(|p| (p.1 * n as f32) as u32).collect();
            let b: Vec<u32> = pts.iter().map(|p| (p.2 * n as f32) as u32).collect();
            if n >= 9 {
                assert_ne!(a, b);
            }
        }
    }

    /// Every sampler estimates ∫∫ f over the unit square without bias; the stratified ones
    /// with a smaller error than independent numbers (f smooth, 16 samples per pixel).
    #[test]
    fn every_sampler_integrates_without_bias_and_strata_lower_the_error() {
        let f = |[x, y]: [f32; 2], z: f32| {
            let (x, y, z) = (x as f64, y as f64, z as f64);
            x * x + (3.0 * y).sin() + x * y * z
        };
        // ∫x² = 1/3, ∫sin 3y = (1 − cos 3)/3, ∫xyz = 1/8.
        let exact = 1.0 / 3.0 + (1.0 - 3f64.cos()) / 3.0 + 0.125;
        let (pixels, spp) = (4000u64, 16u32);
        let mut rmse = Vec::new();
        for kind in [
            SamplerKind::Independent,
            SamplerKind::Stratified,
            SamplerKind::Sobol,
        ] {
            let (mut sum, mut sq) = (0.0f64, 0.0f64);
            for px in 0..pixels {
                let mut s = Sampler::for_pixel_with(kind, 11, px, spp);
                let est = (0..spp)
                    .map(|i| {
                        let p = s.pixel_sample(i);
                        f(p, s.next_1d())
                    })
                    .sum::<f64>()
                    / spp as f64;
                sum += est;
                sq += (est - exact) * (est - exact);
            }
            let mean = sum / pixels as f64;
            let e = (sq / pixels as f64).sqrt();
            // The mean of 4000 pixel estimates: 5 standard errors at most.
            assert!(
                (mean - exact).abs() < 5.0 * e / (pixels as f64).sqrt(),
                "{kind:?}: {mean} vs {exact}"
            );
            rmse.push(e);
        }
        assert!(rmse[1] < 0.7 * rmse[0], "{rmse:?}");
        assert!(rmse[2] < 0.7 * rmse[0], "{rmse:?}");
    }

    #[test]
    fn sampler_names() {
        for name in SamplerKind::NAMES {
            assert!(SamplerKind::from_name(name).is_some());
        }
        assert_eq!(SamplerKind::from_name("halton"), None);
        assert_eq!(SamplerKind::default(), SamplerKind::Sobol);
    }

    #[test]
    fn pixel_streams_are_deterministic_and_distinct() {
        let mut a = Sampler::for_pixel(3, 100, 4);
        let mut b = Sampler::for_pixel(3, 100, 4);
        let mut c = Sampler::for_pixel(3, 101, 4);
        let va: Vec<f32> = (0..8).map(|_| a.next_1d()).collect();
        let vb: Vec<f32> = (0..8).map(|_| b.next_1d()).collect();
        let vc: Vec<f32> = (0..8).map(|_| c.next_1d()).collect();
        assert_eq!(va, vb);
        assert_ne!(va, vc);
    }
}
