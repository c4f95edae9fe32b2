//! PCG32 (O'Neill 2014): 64-bit state, 32-bit output, selectable stream.
//!
//! Seeded exactly like the reference `pcg32_srandom_r(initstate, initseq)`, so that
//! `Pcg32::new(42, 54)` reproduces the reference implementation's sequence.

/// The PCG32 generator (XSH RR output function).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

const MULTIPLIER: u64 = 6364136223846793005;

impl Pcg32 {
    /// A generator on stream `initseq`, started from `initstate` (the reference seeding).
    pub fn new(initstate: u64, initseq: u64) -> Self {
        let mut r = Pcg32 {
            state: 0,
            inc: (initseq << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(initstate);
        r.next_u32();
        r
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in `[0, 1)` (24 random bits, so exactly representable and never 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// A uniform integer in `[0, bound)` without modulo bias; `bound` must be > 0.
    pub fn next_bounded(&mut self, bound: u32) -> u32 {
        let threshold = bound.wrapping_neg() % bound;
        loop {
            let r = self.next_u32();
            if r >= threshold {
                return r % bound;
            }
        }
    }

    /// Advances the generator by `delta` steps in O(log delta) (Brown, "Random number
    /// generation with arbitrary stride").
    pub fn advance(&mut self, delta: u64) {
        let (mut cur_mult, mut cur_plus) = (MULTIPLIER, self.inc);
        let (mut acc_mult, mut acc_plus) = (1u64, 0u64);
        let mut d = delta;
        while d > 0 {
            if d & 1 == 1 {
                acc_mult = acc_mult.wrapping_mul(cur_mult);
                acc_plus = acc_plus.wrapping_mul(cur_mult).wrapping_add(cur_plus);
            }
            cur_plus = cur_mult.wrapping_add(1).wrapping_mul(cur_plus);
            cur_mult = cur_mult.wrapping_mul(cur_mult);
            d >>= 1;
        }
        self.state = acc_mult.wrapping_mul(self.state).wrapping_add(acc_plus);
    }
}

/// A 64-bit mixing function (the SplitMix64 / MurmurHash3 finaliser): decorrelates seeds built
/// from small integers such as pixel coordinates.
#[inline]
pub fn mix64(mut x: u64) -> u64 {
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58476d1ce4e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d049bb133111eb);
    x ^ (x >> 31)
}

/// Hashes two values into one 64-bit seed.
#[inline]
pub fn hash2(a: u64, b: u64) -> u64 {
    mix64(a ^ mix64(b.wrapping_add(0x9e3779b97f4a7c15)))
}

/// Two uniform numbers in [0, 1) from the two halves of a hash (24 bits each).
#[inline]
pub fn unit_pair(h: u64) -> [f32; 2] {
    let unit = |bits: u64| (bits & 0xff_ffff) as f32 / (1 << 24) as f32;
    [unit(h), unit(h >> 32)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_the_reference_pcg32_demo() {
        // pcg32-demo of the reference C implementation, seeded with (42, 54).
        let mut r = Pcg32::new(42, 54);
        let expected = [
            0xa15c02b7u32,
            0x7b47f409,
            0xba1d3330,
            0x83d2f293,
            0xbfa4784b,
            0xcbed606e,
        ];
        for e in expected {
            assert_eq!(r.next_u32(), e);
        }
    }

    #[test]
    fn floats_are_in_the_unit_interval_and_bounded_ints_in_range() {
        let mut r = Pcg32::new(1, 2);
        let mut sum = 0.0f64;
        for _ in 0..100_000 {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        assert!((sum / 100_000.0 - 0.5).abs() < 0.005);
        for _ in 0..1000 {
            assert!(r.next_bounded(7) < 7);
        }
    }

    #[test]
    fn advance_skips_ahead_exactly() {
        let mut a = Pcg32::new(7, 11);
        let mut b = a;
        for _ in 0..1000 {
            a.next_u32();
        }
        b.advance(1000);
        assert_eq!(a, b);
        assert_eq!(a.next_u32(), b.next_u32());
    }
}
