//! Sample values for one camera path: a pure function of (pixel, sample index, seed) and the
//! render's maximum spp, so an image is bit-identical for any thread count or tile order.
//!
//! # The low-discrepancy sampler (default)
//!
//! **Points.** Owen-scrambled Sobol points in four dimensions (`sobol`: Burley 2020,
//! "Practical Hash-based Owen Scrambling"). A path's values come in *groups* of up to four
//! dimensions (table below); each group is the same four-dimensional sequence with its own
//! nested-uniform shuffle of the point index and its own value scrambles, which decorrelates
//! the groups (Burley's padding) while every group stays a stratified sequence. The 2D
//! quantities (pixel position, light position, BSDF direction, disk point) sit in dimensions
//! 0 and 1 of their group, which form a (0, 2)-sequence.
//!
//! **Pixels.** All pixels of a tile share one sequence and one scramble: pixel p gets the
//! aligned block of indices `rank(p) * 2^m ..` where `2^m >= max spp`, so its first 2^k
//! samples (k <= m) are an aligned block of 2^k points, a (0, k, 2)-net in every group's
//! dimensions 0-1: progressive passes (1, 1, 2, 4, ...) and adaptive sampling stop at
//! stratified prefixes. `rank` orders the pixels along a Z (Morton) curve with a random
//! permutation of the four quadrants at every level of the hierarchy (Ahmed and Wonka 2020,
//! "Screen-Space Blue-Noise Diffusion of Monte Carlo Sampling Error via Hierarchical Ordering
//! of Pixels"; the ordering of pbrt-v4's ZSobolSampler): the blocks of the four pixels of any
//! aligned 2 x 2 (4 x 4, ...) square together form a finer net, so neighbouring pixels' errors
//! are negatively correlated and the error is distributed as blue noise. A tile is as large as
//! the 32-bit index allows (2^((32 - m) / 2) pixels square: 8192 at 64 spp); tiles get their
//! own scramble seeds.
//!
//! **Layout of the dimensions** (group: dims 0-1 / dim 2 / dim 3):
//!
//! | group | 0-1 | 2 | 3 |
//! | --- | --- | --- | --- |
//! | camera | pixel filter offset | shutter time (scenes with motion only) | - |
//! | lens | point on the lens | - | - |
//! | wavelength | hero wavelength: position within a quarter / which quarter | - | - |
//! | per bounce `light` | point on the light | light choice | material component |
//! | per bounce `bsdf` | BSDF direction | BSDF lobe | Russian roulette |
//! | per bounce `probe` | BSSRDF disk point (angle, radius) | projection axis, then wavelength | probe hit choice |
//! | per bounce `exit light` | point on the light | light choice | - |
//! | per bounce `exit lobe` | exit direction | - | - |
//!
//! Bounce groups exist for the first `SOBOL_BOUNCES` bounces; past them, and for consumers of
//! an unbounded number of values (the random walk's free flights and phase-function samples,
//! `Sampler::next_1d`), values come from an independent PCG stream hashed from (pixel, sample,
//! seed).
//!
//! # The independent sampler
//!
//! `SamplerKind::Independent` draws every value from the PCG stream in call order: what Prism
//! did before, kept to measure the gain and for tests.

mod hash;
mod pcg;
pub mod sobol;

pub use hash::{hash32, mix64};
pub use pcg::Pcg32;

use glam::Vec2;

/// Index bits of a split sample's branch (`Sampler::branch`).
const BRANCH_BITS: u32 = 2;
/// Most branches per split sample.
pub const MAX_BRANCHES: u32 = 1 << BRANCH_BITS;
/// Xor-ed with a tile's scramble seed for the sequence of split samples.
const SPLIT_SCRAMBLE: u32 = 0x2c1b_3c6d;

/// Bounces with their own low-discrepancy dimension groups.
pub const SOBOL_BOUNCES: u32 = 64;

/// Uniform in [0, 1) from 32 random bits (24 mantissa bits: exact, never rounds up to 1).
#[inline]
pub fn to_unit_float(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Owen-scrambled Sobol with blue-noise pixel ordering.
    #[default]
    Sobol,
    /// Independent PCG random numbers.
    Independent,
}

impl SamplerKind {
    pub const NAMES: &'static [&'static str] = &["sobol", "independent"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "sobol" => Some(Self::Sobol),
            "independent" => Some(Self::Independent),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Sobol => "sobol",
            Self::Independent => "independent",
        }
    }
}

/// The sampler of one render: what is shared by all pixels.
#[derive(Clone, Copy, Debug)]
pub struct ImageSampler {
    kind: SamplerKind,
    seed: u64,
    /// m: each pixel owns 2^m consecutive indices (2^m >= max spp).
    block_bits: u32,
    /// Levels of the pixel hierarchy in a tile (tiles are 2^levels pixels square).
    levels: u32,
}

/// The sampler of one pixel.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    kind: SamplerKind,
    /// First index of the pixel's block in its tile's sequence.
    base: u32,
    /// Scramble seed of the pixel's tile.
    tile_seed: u32,
    pixel_index: u64,
    seed: u64,
    block_bits: u32,
    /// First index of the pixel's block of split samples.
    split_base: u32,
}

/// All 24 permutations of a base-4 digit.
const QUADRANT_PERMUTATIONS: [[u8; 4]; 24] = {
    let mut out = [[0u8; 4]; 24];
    let mut n = 0;
    let mut a = 0;
    while a < 4 {
        let mut b = 0;
        while b < 4 {
            let mut c = 0;
            while c < 4 {
                if a != b && b != c && a != c {
                    out[n] = [a, b, c, 6 - a - b - c];
                    n += 1;
                }
                c += 1;
            }
            b += 1;
        }
        a += 1;
    }
    out
};

/// Spreads the low 16 bits of `v` to the even bit positions.
#[inline]
fn part_1_by_1(v: u32) -> u32 {
    let mut x = v & 0xffff;
    x = (x | (x << 8)) & 0x00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333;
    (x | (x << 1)) & 0x5555_5555
}

/// The pixel's position in its tile's randomised Z order: the Morton code of (x, y) with the
/// base-4 digit of every level replaced by a random permutation of it, chosen by hashing the
/// digits above (the pixel's enclosing square), so every square's four sub-squares take the
/// four sub-blocks of its index block in a random order.
fn hierarchical_rank(x: u32, y: u32, levels: u32, seed: u32) -> u32 {
    let morton = part_1_by_1(x) | (part_1_by_1(y) << 1);
    let mut rank = 0u32;
    for level in (0..levels).rev() {
        let shift = 2 * level;
        let digit = (morton >> shift) & 3;
        let square = if shift + 2 >= 32 {
            0
        } else {
            morton >> (shift + 2)
        };
        let p = hash32(square ^ hash32(seed ^ level.wrapping_mul(0x9e37_79b9))) % 24;
        rank |= (QUADRANT_PERMUTATIONS[p as usize][digit as usize] as u32) << shift;
    }
    rank
}

impl ImageSampler {
    pub fn new(kind: SamplerKind, max_spp: u32, seed: u64) -> Self {
        // ceil(log2(max_spp)), 0 for one sample.
        let block_bits = 32 - (max_spp.max(1) - 1).leading_zeros();
        ImageSampler {
            kind,
            seed,
            block_bits,
            levels: ((32 - block_bits) / 2).min(15),
        }
    }

    pub fn pixel(&self, x: u32, y: u32, width: u32) -> PixelSampler {
        let pixel_index = y as u64 * width as u64 + x as u64;
        let mask = (1u32 << self.levels) - 1;
        let (tx, ty) = (x >> self.levels, y >> self.levels);
        let tile_seed = (mix64(
            self.seed
                .wrapping_mul(0x9e37_79b9_7f4a_7c15)
                .wrapping_add(((ty as u64) << 32) | tx as u64),
        ) >> 32) as u32;
        let rank = hierarchical_rank(x & mask, y & mask, self.levels, tile_seed);
        let base = if self.block_bits >= 32 {
            0
        } else {
            rank << self.block_bits
        };
        // Split samples' block (`Sampler::branch`): 2^BRANCH_BITS x 2^block_bits indices per
        // pixel, in the same Z order (the hierarchy's top level dropped to make room).
        let split_rank =
            rank & (1u32 << (2 * self.levels).saturating_sub(BRANCH_BITS)).wrapping_sub(1);
        let split_base = split_rank
            .checked_shl(self.block_bits + BRANCH_BITS)
            .unwrap_or(0);
        PixelSampler {
            kind: self.kind,
            base,
            tile_seed,
            pixel_index,
            seed: self.seed,
            block_bits: self.block_bits,
            split_base,
        }
    }
}

impl PixelSampler {
    /// The sampler of sample `sample` (< the render's max spp) of this pixel.
    pub fn sample(&self, sample: u32) -> Sampler {
        Sampler {
            rev_index: self.base.wrapping_add(sample).reverse_bits(),
            seed: self.tile_seed,
            group_base: 0,
            shuffled: (NO_GROUP, 0),
            independent: self.kind == SamplerKind::Independent,
            rng: None,
            stream: (self.pixel_index, sample as u64, self.seed),
            split_index: self.split_base.wrapping_add(sample),
            block_bits: self.block_bits,
        }
    }
}

/// Groups of the layout (see the module documentation).
const GROUP_CAMERA: u32 = 0;
const GROUP_LENS: u32 = 1;
const GROUP_WAVELENGTH: u32 = 2;
const FIRST_BOUNCE_GROUP: u32 = 3;
const GROUPS_PER_BOUNCE: u32 = 5;
const LIGHT: u32 = 0;
const BSDF: u32 = 1;
const PROBE: u32 = 2;
const EXIT_LIGHT: u32 = 3;
const EXIT_LOBE: u32 = 4;
/// `group_base` past the bounce table: values come from the PCG stream.
const NO_GROUP: u32 = u32::MAX;
const GROUPS: usize = (FIRST_BOUNCE_GROUP + GROUPS_PER_BOUNCE * SOBOL_BOUNCES) as usize;

/// Per group: the salt of its index shuffle and of its four value scrambles (random words,
/// xor-ed with the tile's seed at run time: no hashing per sample).
static GROUP_SALTS: [[u32; 5]; GROUPS] = {
    let mut t = [[0u32; 5]; GROUPS];
    let mut g = 0;
    while g < GROUPS {
        let mut k = 0;
        while k < 5 {
            t[g][k] = hash32(
                hash32(g as u32 ^ 0x632b_e5ab).wrapping_add((k as u32).wrapping_mul(0x9e37_79b9)),
            );
            k += 1;
        }
        g += 1;
    }
    t
};

/// The values of one camera path.
#[derive(Clone, Debug)]
pub struct Sampler {
    /// Index of this sample in its tile's sequence, bit-reversed (see `sobol`).
    rev_index: u32,
    seed: u32,
    /// First group of the current bounce.
    group_base: u32,
    /// The last group read and its shuffle of the index: a bounce reads its light and BSDF
    /// groups twice each (light then material component, direction then roulette), and the
    /// shuffle is the costlier half of a value.
    shuffled: (u32, u32),
    independent: bool,
    /// The independent stream, created at its first use (most paths never need it).
    rng: Option<Pcg32>,
    /// What seeds it: (pixel, sample, seed).
    stream: (u64, u64, u64),
    /// The sample's index in the pixel's block of split samples (`branch`), not reversed.
    split_index: u32,
    block_bits: u32,
}

impl Sampler {
    /// A sampler whose every value is independent (PCG; `next_1d`/`next_2d`), for consumers
    /// that draw an unbounded number of values and for tests.
    pub fn new(pixel_index: u64, sample_index: u64, seed: u64) -> Self {
        Sampler {
            rev_index: 0,
            seed: 0,
            group_base: 0,
            shuffled: (NO_GROUP, 0),
            independent: true,
            rng: Some(Pcg32::new(pixel_index, sample_index, seed)),
            stream: (pixel_index, sample_index, seed),
            split_index: 0,
            block_bits: 0,
        }
    }

    /// Branch `j` (< [`MAX_BRANCHES`]) of this sample split at its current bounce, for the
    /// groups read after the split (the bounce's light and BSDF groups on: a path's branches
    /// after a shared first vertex, `PathTracer::radiance_split`); every branch of a split
    /// sample, the first included, comes from here.
    ///
    /// Split samples read those groups from a second sequence (another scramble), in which
    /// each pixel owns 2^BRANCH_BITS times its block: branch j of sample i takes index
    /// i + j 2^m (2^m >= max spp) of it, so every branch's samples and all of a pixel's
    /// branches together are nets, and the branches of one sample are stratified against each
    /// other (independent scrambles per branch measured 3% (two branches) to 8-11% (four) more
    /// noise on the SSS Cornell box). The camera's, lens' and wavelengths' groups, and every
    /// sample that does not split, keep the one sequence, whose pixels' blocks are what makes
    /// neighbouring pixels' errors blue noise (a pixel block grown for branches would break
    /// that: four pixels' first quarters are no finer net).
    pub fn branch(&self, j: u32) -> Sampler {
        let index = self
            .split_index
            .wrapping_add(j.checked_shl(self.block_bits).unwrap_or(0));
        self.branch_at(j, index, self.seed ^ SPLIT_SCRAMBLE)
    }

    /// Branch `j` as [`Sampler::branch`], but independent of the sample's other branches: its
    /// own scramble of the sample's index, so that branch j of a pixel's samples is one
    /// randomisation of the sequence and branch j' another (the splitting pilot's: the spread
    /// between the two branches' means over the pilot measures the sequence's own variance,
    /// `integrator::splitting::sequence_gain`).
    pub fn independent_branch(&self, j: u32) -> Sampler {
        self.branch_at(
            j,
            self.split_index,
            self.seed ^ SPLIT_SCRAMBLE ^ hash::hash32(j.wrapping_add(0x9e37_79b9)),
        )
    }

    fn branch_at(&self, j: u32, index: u32, seed: u32) -> Sampler {
        let (pixel, sample, stream_seed) = self.stream;
        Sampler {
            rev_index: index.reverse_bits(),
            seed,
            group_base: self.group_base,
            shuffled: (NO_GROUP, 0),
            independent: self.independent,
            rng: None,
            stream: (pixel, sample | ((j as u64 + 1) << 40), stream_seed),
            split_index: self.split_index,
            block_bits: self.block_bits,
        }
    }

    /// Independent value (the PCG stream), whatever the sampler kind.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        self.stream().next_1d()
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        self.stream().next_2d()
    }

    #[inline]
    fn stream(&mut self) -> &mut Pcg32 {
        let (pixel, sample, seed) = self.stream;
        self.rng
            .get_or_insert_with(|| Pcg32::new(pixel, sample, seed))
    }

    /// Dimensions `D` of `group` starting at `first`: the group's shuffle of the sample's index
    /// and each dimension's value scramble, seeded by the tile's seed and per-group salts.
    /// Always inlined, and plain loops rather than `array::from_fn`: every caller passes
    /// constants, so each public method gets a straight-line body with its dimensions and
    /// table rows folded in (the closure of `from_fn` was left as an out-of-line call per
    /// value).
    #[inline(always)]
    fn dims<const D: usize>(&mut self, group: u32, first: usize) -> [f32; D] {
        if self.independent || group == NO_GROUP {
            return self.stream_dims();
        }
        let salts = &GROUP_SALTS[group as usize];
        let rev_index = if self.shuffled.0 == group {
            self.shuffled.1
        } else {
            let r = sobol::shuffle_reversed(self.rev_index, self.seed ^ salts[0]);
            self.shuffled = (group, r);
            r
        };
        let mut out = [0.0; D];
        for (k, o) in out.iter_mut().enumerate() {
            let d = first + k;
            *o = to_unit_float(sobol::owen_sobol_reversed(
                rev_index,
                d,
                self.seed ^ salts[d + 1],
            ));
        }
        out
    }

    /// `D` values of the independent stream, in order (kept out of line: the rare path of
    /// `dims`).
    #[inline(never)]
    fn stream_dims<const D: usize>(&mut self) -> [f32; D] {
        let stream = self.stream();
        let mut out = [0.0; D];
        for o in &mut out {
            *o = stream.next_1d();
        }
        out
    }

    #[inline]
    fn bounce_group(&self, which: u32) -> u32 {
        if self.group_base == NO_GROUP {
            NO_GROUP
        } else {
            self.group_base + which
        }
    }

    /// Pixel filter offset (in [0, 1)^2).
    pub fn pixel_filter(&mut self) -> Vec2 {
        let [a, b] = self.dims::<2>(GROUP_CAMERA, 0);
        Vec2::new(a, b)
    }

    /// Point on the lens (in [0, 1)^2). Its own group, so a pinhole camera need not draw it.
    pub fn lens(&mut self) -> Vec2 {
        let [c, d] = self.dims::<2>(GROUP_LENS, 0);
        Vec2::new(c, d)
    }

    /// The camera path's shutter time in [0, 1) (motion blur).
    pub fn shutter_time(&mut self) -> f32 {
        self.dims::<1>(GROUP_CAMERA, 2)[0]
    }

    /// The hero wavelength's primary samples: (position, choice) — see
    /// `integrator::wavelengths` for how they make the hero's sample.
    pub fn wavelength(&mut self) -> Vec2 {
        let [a, b] = self.dims::<2>(GROUP_WAVELENGTH, 0);
        Vec2::new(a, b)
    }

    /// Selects the dimension groups of bounce `depth` (0 = the camera ray's hit).
    pub fn start_bounce(&mut self, depth: u32) {
        self.group_base = if depth < SOBOL_BOUNCES {
            FIRST_BOUNCE_GROUP + depth * GROUPS_PER_BOUNCE
        } else {
            NO_GROUP
        };
    }

    /// Next-event estimation: (point on the light, light choice).
    pub fn light(&mut self) -> (Vec2, f32) {
        let [a, b, c] = self.dims::<3>(self.bounce_group(LIGHT), 0);
        (Vec2::new(a, b), c)
    }

    /// Choice between the components of a mixed material.
    pub fn material_component(&mut self) -> f32 {
        self.dims::<1>(self.bounce_group(LIGHT), 3)[0]
    }

    /// BSDF sampling: (lobe choice, direction).
    pub fn bsdf(&mut self) -> (f32, Vec2) {
        let [a, b, c] = self.dims::<3>(self.bounce_group(BSDF), 0);
        (c, Vec2::new(a, b))
    }

    pub fn russian_roulette(&mut self) -> f32 {
        self.dims::<1>(self.bounce_group(BSDF), 3)[0]
    }

    /// BSSRDF probe: (projection axis and wavelength, disk point (angle, radius), probe hit
    /// choice).
    pub fn subsurface_probe(&mut self) -> (f32, Vec2, f32) {
        let [a, b, c, d] = self.dims::<4>(self.bounce_group(PROBE), 0);
        (c, Vec2::new(a, b), d)
    }

    /// Next-event estimation at a subsurface exit point: (point on the light, light choice).
    pub fn exit_light(&mut self) -> (Vec2, f32) {
        let [a, b, c] = self.dims::<3>(self.bounce_group(EXIT_LIGHT), 0);
        (Vec2::new(a, b), c)
    }

    /// Direction of the subsurface exit lobe.
    pub fn exit_lobe(&mut self) -> Vec2 {
        let [a, b] = self.dims::<2>(self.bounce_group(EXIT_LOBE), 0);
        Vec2::new(a, b)
    }
}

/// Van der Corput radical inverse in base 2: the first N values of successive indices are
/// stratified over [0, 1) for every N.
#[inline]
pub fn radical_inverse_base2(index: u32) -> f32 {
    to_unit_float(index.reverse_bits())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadrant_permutations_are_distinct_permutations() {
        let mut all = QUADRANT_PERMUTATIONS.to_vec();
        for p in &all {
            let mut s = *p;
            s.sort();
            assert_eq!(s, [0, 1, 2, 3]);
        }
        all.sort();
        all.dedup();
        assert_eq!(all.len(), 24);
    }

    #[test]
    fn hierarchical_rank_is_a_bijection_of_the_tile() {
        for levels in [0u32, 1, 3, 5] {
            let n = 1u32 << levels;
            let mut seen = vec![false; (n * n) as usize];
            for y in 0..n {
                for x in 0..n {
                    let r = hierarchical_rank(x, y, levels, 42) as usize;
                    assert!(!seen[r]);
                    seen[r] = true;
                }
            }
        }
    }

    #[test]
    fn block_size_covers_the_spp() {
        for (spp, bits) in [
            (1u32, 0u32),
            (2, 1),
            (3, 2),
            (4, 2),
            (64, 6),
            (65, 7),
            (100, 7),
        ] {
            assert_eq!(
                ImageSampler::new(SamplerKind::Sobol, spp, 0).block_bits,
                bits
            );
        }
    }
}
