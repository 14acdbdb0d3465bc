//! Random numbers for one camera path, derived only from (pixel, sample index, seed): the image
//! is therefore identical for any thread count or tile order.

use glam::Vec2;

/// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
/// Algorithms for Random Number Generation"), seeded by hashing the path's coordinates.
#[derive(Clone, Debug)]
pub struct Sampler {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 6_364_136_223_846_793_005;

/// 64-bit finaliser of SplitMix64 (Steele et al. 2014): decorrelates nearby inputs.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Sampler {
    pub fn new(pixel_index: u64, sample_index: u64, seed: u64) -> Self {
        let stream = mix64(pixel_index ^ mix64(seed.wrapping_add(0x9e37_79b9_7f4a_7c15)));
        let start = mix64(sample_index.wrapping_add(mix64(stream)));
        let mut s = Sampler {
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
        // 24 random mantissa bits: exactly representable, never rounds up to 1.
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

/// Van der Corput radical inverse in base 2: the first N values of successive indices are
/// stratified over [0, 1) for every N.
#[inline]
pub fn radical_inverse_base2(index: u32) -> f32 {
    (index.reverse_bits() >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A value in [0, 1) for sample `sample_index` of a pixel, stratified over that pixel's
/// successive samples (van der Corput) and decorrelated between pixels by a random rotation
/// (Cranley & Patterson 1976). Used for the hero wavelength: it turns most of the colour noise
/// of spectral rendering into stratification error, which falls much faster with the spp.
pub fn stratified_per_pixel(pixel_index: u64, sample_index: u64, seed: u64, dimension: u64) -> f32 {
    let rotation = (mix64(pixel_index ^ mix64(seed ^ mix64(dimension.wrapping_add(0x5bd1_e995))))
        >> 40) as f32
        * (1.0 / 16_777_216.0);
    let v = radical_inverse_base2(sample_index as u32) + rotation;
    if v >= 1.0 {
        v - 1.0
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stratified_values_cover_strata() {
        for n in [4u64, 16, 64] {
            let mut strata = vec![0; n as usize];
            for i in 0..n {
                let v = stratified_per_pixel(3, i, 1, 0);
                assert!((0.0..1.0).contains(&v));
                strata[(v * n as f32) as usize] += 1;
            }
            // A rotated (0,1)-sequence puts at most 2 points in each of n strata.
            assert!(strata.iter().all(|&c| c <= 2), "{strata:?}");
        }
    }

    #[test]
    fn deterministic_and_uniform() {
        let mut a = Sampler::new(7, 3, 1);
        let mut b = Sampler::new(7, 3, 1);
        let mut c = Sampler::new(7, 4, 1);
        let va: Vec<f32> = (0..16).map(|_| a.next_1d()).collect();
        let vb: Vec<f32> = (0..16).map(|_| b.next_1d()).collect();
        let vc: Vec<f32> = (0..16).map(|_| c.next_1d()).collect();
        assert_eq!(va, vb);
        assert_ne!(va, vc);
        let mut s = Sampler::new(1, 2, 3);
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
