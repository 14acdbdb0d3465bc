//! Integer hashes for seeding (not for sample values themselves).

/// 64-bit finaliser of SplitMix64 (Steele et al. 2014): decorrelates nearby inputs.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A 32-bit avalanche hash (two multiply-xorshift rounds; constants from Wellons' hash
/// prospector search, "lowbias32", bias 0.17).
#[inline]
pub const fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}
