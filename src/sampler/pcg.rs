//! Independent random numbers: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast
//! Space-Efficient Statistically Good Algorithms for Random Number Generation"), seeded by
//! hashing the path's coordinates. Used where a path needs an unbounded number of values (the
//! random walk's free flights), for the `independent` sampler the low-discrepancy one is
//! measured against, and by tests.

use super::hash::mix64;
use glam::Vec2;

#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 6_364_136_223_846_793_005;

impl Pcg32 {
    /// A stream determined by (`pixel_index`, `sample_index`, `seed`) alone.
    pub fn new(pixel_index: u64, sample_index: u64, seed: u64) -> Self {
        let stream = mix64(pixel_index ^ mix64(seed.wrapping_add(0x9e37_79b9_7f4a_7c15)));
        let start = mix64(sample_index.wrapping_add(mix64(stream)));
        let mut s = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        s.next_u32();
        s.state = s.state.wrapping_add(start);
        s.next_u32();
        s
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        super::to_unit_float(self.next_u32())
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_uniform() {
        let mut a = Pcg32::new(7, 3, 1);
        let mut b = Pcg32::new(7, 3, 1);
        let mut c = Pcg32::new(7, 4, 1);
        let va: Vec<f32> = (0..16).map(|_| a.next_1d()).collect();
        let vb: Vec<f32> = (0..16).map(|_| b.next_1d()).collect();
        let vc: Vec<f32> = (0..16).map(|_| c.next_1d()).collect();
        assert_eq!(va, vb);
        assert_ne!(va, vc);
        let mut s = Pcg32::new(1, 2, 3);
        let n = 200_000;
        let mut hist = [0u32; 10];
        for _ in 0..n {
            let x = s.next_1d();
            assert!((0.0..1.0).contains(&x));
            hist[(x * 10.0) as usize] += 1;
        }
        for h in hist {
            assert!((h as f32 / n as f32 - 0.1).abs() < 0.005);
        }
    }
}
