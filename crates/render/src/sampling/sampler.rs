//! Per-pixel sample generation with deterministic seeding.
//!
//! Every pixel owns its own PCG32 stream, derived from the image seed and the pixel index, so
//! the image depends only on the scene and the seed, never on how pixels are spread over threads.
//! The position of sample `i` inside its pixel comes from correlated multi-jittered sampling
//! (Kensler 2013): stratified in 2D and in each 1D projection, for any sample count.

use super::pcg::{hash2, Pcg32};

/// The sample source handed to integrators: uniform numbers in `[0, 1)`.
#[derive(Clone, Debug)]
pub struct Sampler {
    rng: Pcg32,
    pattern: u32,
    spp: u32,
}

impl Sampler {
    /// The sampler of pixel number `pixel` (row-major index) for an image rendered with `seed`
    /// and `spp` samples per pixel.
    pub fn for_pixel(seed: u64, pixel: u64, spp: u32) -> Self {
        let h = hash2(seed, pixel);
        Self {
            rng: Pcg32::new(h, pixel),
            pattern: (h >> 32) as u32,
            spp: spp.max(1),
        }
    }

    /// A free-standing sampler (tests, preprocessing) seeded by `seed` on stream `stream`.
    pub fn new(seed: u64, stream: u64) -> Self {
        Self {
            rng: Pcg32::new(hash2(seed, stream), stream),
            pattern: 0,
            spp: 1,
        }
    }

    /// The position of sample `index` inside the pixel, in `[0,1)²`: the pixel centre when the
    /// pixel takes a single sample (the course's convention), otherwise a correlated
    /// multi-jittered point.
    pub fn pixel_sample(&mut self, index: u32) -> [f32; 2] {
        if self.spp == 1 {
            return [0.5, 0.5];
        }
        cmj(index, self.spp, self.pattern)
    }

    /// The next uniform number.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        self.rng.next_f32()
    }

    /// The next pair of uniform numbers.
    #[inline]
    pub fn next_2d(&mut self) -> [f32; 2] {
        let a = self.rng.next_f32();
        let b = self.rng.next_f32();
        [a, b]
    }

    /// A uniform integer in `[0, n)`.
    #[inline]
    pub fn next_index(&mut self, n: u32) -> u32 {
        self.rng.next_bounded(n)
    }
}

/// Kensler's hash-based permutation of `[0, l)`: element `i` of permutation `p`.
fn permute(mut i: u32, l: u32, p: u32) -> u32 {
    let mut w = l - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
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
        i ^= i >> 5;
        if i < l {
            break;
        }
    }
    (i.wrapping_add(p)) % l
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
/// Multi-Jittered Sampling", with the aspect-ratio-1 grid of m × ⌈n/m⌉ cells).
pub fn cmj(s: u32, n: u32, p: u32) -> [f32; 2] {
    let m = ((n as f32).sqrt() as u32).max(1);
    let nn = n.div_ceil(m);
    let s = permute(s % n, n, p.wrapping_mul(0x51633e2d));
    let sx = permute(s % m, m, p.wrapping_mul(0x68bc21eb));
    let sy = permute(s / m, nn, p.wrapping_mul(0x02e5be93));
    let jx = randfloat(s, p.wrapping_mul(0x967a889b));
    let jy = randfloat(s, p.wrapping_mul(0x368cc8b7));
    let x = (sx as f32 + (sy as f32 + jx) / nn as f32) / m as f32;
    let y = (s as f32 + jy) / n as f32;
    [x.min(ONE_MINUS_EPSILON), y.min(ONE_MINUS_EPSILON)]
}

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;

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
