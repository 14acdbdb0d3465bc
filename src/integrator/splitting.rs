//! How many branches a camera path takes at its first vertex (`PathTracer::radiance_split`),
//! chosen per block of pixels from the render's first samples.
//!
//! A split path shares its camera ray and first hit's shading (cost `C_s`, variance `V_s`:
//! what the pixel's footprint sees) and traces k branches of light sample, BSDF sample and
//! rest of the path (cost `C_b` and variance `V_b` each). The sample then has variance
//! `V_s + V_b / k` for cost `C_s + k C_b`, whose product is least at
//! `k* = sqrt((V_b / V_s) (C_s / C_b))` (Rath et al. 2022, "EARS: Efficiency-Aware Russian
//! Roulette and Splitting", eq. 7 with one splitting factor per image region).
//!
//! The first [`PILOT_SPP`] samples of every pixel are split in two. Per pixel they give the
//! variance of the samples, `Var(X) = V_s + V_b / 2`, and the spread between the two branches,
//! `E[(b_1 - b_2)^2] / 2 = V_b`; per block of [`BLOCK`] x [`BLOCK`] pixels the relative
//! variances (each pixel's over its mean^2 + 0.01, the benchmark's measure) are summed, and the
//! rays traced before and after the split stand for the costs. Pixels above the 99th
//! percentile of the varying pixels' relative variance enter at it (`outlier_cap`): a rare
//! bright path seen by a few pilot samples must not decide the plan for the whole image.
//! Everything is a function of the samples, so the plan, and the image, are the same for
//! any thread count.
//!
//! Where most of a pixel's variance comes after its first vertex (a Cornell box's
//! interreflections, subsurface scattering) blocks take up to [`MAX_SPLITS`] branches; where
//! it is in what the camera sees (a thousand small lights seen directly, texture and
//! silhouette edges) they take one, and cost what they cost without splitting.

use super::PathSample;
use crate::render::Crop;

/// Samples per pixel traced with two branches to measure the variances.
pub const PILOT_SPP: u32 = 4;
/// Renders with fewer samples per pixel than this do not split (too few to plan from).
pub const MIN_SPP: u32 = 16;
/// Most branches per camera path.
pub const MAX_SPLITS: u32 = crate::sampler::MAX_BRANCHES;
/// Side of a block of pixels that share one splitting factor.
pub const BLOCK: u32 = 8;
/// The cost of a sample's set-up (camera ray generation, wavelengths, film, the first hit's
/// shading) in rays.
const SETUP_RAYS: f64 = 0.5;
/// Pixels whose pilot variance is above this quantile of the varying pixels' enter the plan
/// at it (`outlier_cap`).
const OUTLIER_QUANTILE: f64 = 0.99;

/// Splitting factors per block, from each block's `[V_s, V_b, C_s, C_b]` (summed over its
/// pixels), that minimise the image's total variance times its total cost: setting the
/// derivative of (sum V_s + V_b / k_b) (sum C_s + k_b C_b) by k_b to zero gives
/// k_b = sqrt((V_b / C_b) (C / V)) with C and V the image's totals at that plan, a fixed point
/// found by iterating from k = 1. (Each block's own optimum, sqrt((V_b / V_s) (C_s / C_b)),
/// splits a block whose variance is small next to the image's as much as one that holds most
/// of it: with a thousand small lights seen directly, the floor's blocks split 2-4 times for
/// noise that was not the image's.)
pub fn optimal_splits(blocks: &[[f64; 4]]) -> Vec<u8> {
    let mut k = vec![1f64; blocks.len()];
    for _ in 0..32 {
        let (mut v, mut c) = (0.0, 0.0);
        for (b, &kb) in blocks.iter().zip(&k) {
            v += b[0] + b[1] / kb;
            c += b[2] + kb * b[3];
        }
        // The variance before the split is at least a small share of the whole (the
        // estimate is a difference of two noisy sums).
        v = v.max(0.02 * blocks.iter().map(|b| b[0] + b[1] / 2.0).sum::<f64>());
        if !(v > 0.0 && c > 0.0) {
            break;
        }
        for (b, kb) in blocks.iter().zip(k.iter_mut()) {
            *kb = if b[1] > 0.0 && b[3] > 0.0 {
                ((b[1] / b[3]) * (c / v))
                    .sqrt()
                    .clamp(1.0, MAX_SPLITS as f64)
            } else {
                1.0
            };
        }
    }
    k.iter().map(|&kb| kb.round() as u8).collect()
}

/// The largest relative variance a pixel's pilot samples enter the plan with: the
/// [`OUTLIER_QUANTILE`] of the pixels' that vary (of all pixels', an object covering a few
/// percent of the image in front of a plain background would have its noise capped). Four
/// samples see a rare bright path (a sun's glint through a chrome ball) in a few pixels only,
/// as one huge sample each; uncapped, those estimates outweighed the rest of the image, whose
/// plan then split nowhere (the everyday scene: bulk noise x time 1.27x better with the cap).
fn outlier_cap(variances: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = variances.filter(|&v| v > 0.0 && v.is_finite()).collect();
    if v.is_empty() {
        return f64::INFINITY;
    }
    let i = ((v.len() - 1) as f64 * OUTLIER_QUANTILE) as usize;
    *v.select_nth_unstable_by(i, f64::total_cmp).1
}

/// One pixel's pilot samples: sums for the variance of the samples and of the branches, and
/// the rays before and after the split.
#[derive(Clone, Copy, Debug, Default)]
pub struct SplitStats {
    /// Pilot samples that reached a path, and those of them that split.
    n: u16,
    split_samples: u16,
    sum: f32,
    sum_sq: f32,
    /// Sum of (first branch - second branch)^2 over the samples that split.
    sum_diff_sq: f32,
    /// Rays before the split (all of an unsplit sample's) and after it.
    shared_rays: u32,
    branch_rays: u32,
}

impl SplitStats {
    /// Adds a pilot sample whose film luminance is `y`; `difference` gives the luminance of
    /// the branches' difference (computed only for samples that split).
    pub fn add(&mut self, sample: &PathSample, y: f32, difference: impl FnOnce() -> f32) {
        if !y.is_finite() || self.n == u16::MAX {
            return;
        }
        self.n += 1;
        self.sum += y;
        self.sum_sq += y * y;
        if sample.split {
            let d = difference();
            if d.is_finite() {
                self.sum_diff_sq += d * d;
            }
            self.shared_rays = self.shared_rays.saturating_add(sample.shared_rays);
            self.branch_rays = self
                .branch_rays
                .saturating_add(sample.rays - sample.shared_rays);
            self.split_samples += 1;
        } else {
            self.shared_rays = self.shared_rays.saturating_add(sample.rays);
        }
    }
}

/// The render's splitting plan.
#[derive(Clone, Copy, Debug)]
pub struct SplitPlanner {
    enabled: bool,
    forced: Option<u32>,
    window: Crop,
}

impl SplitPlanner {
    /// `splits`: None plans them (from [`MIN_SPP`] spp on), Some(k) takes k everywhere (1: no
    /// splitting).
    pub fn new(spp: u32, window: Crop, splits: Option<u32>) -> Self {
        let forced = splits.map(|k| k.clamp(1, MAX_SPLITS));
        SplitPlanner {
            enabled: spp >= MIN_SPP || forced.is_some(),
            forced,
            window,
        }
    }

    /// Branches of the pilot samples.
    pub fn pilot_splits(&self) -> u8 {
        match (self.enabled, self.forced) {
            (false, _) => 1,
            (true, Some(k)) => k as u8,
            (true, None) => 2,
        }
    }

    /// Samples per pixel before the plan (0: no pilot).
    pub fn pilot_end(&self) -> u32 {
        if self.enabled && self.forced.is_none() {
            PILOT_SPP
        } else {
            0
        }
    }

    /// Sets every pixel's branches from the pilot's statistics (`stats`, `splits`: the
    /// window's pixels in rows), and the cost of its samples relative to unsplit ones
    /// (C_s + k C_b) / (C_s + C_b) (`costs`, for adaptive sampling's passes).
    pub fn plan(&self, stats: &[SplitStats], splits: &mut [u8], costs: &mut [f32]) {
        if self.pilot_end() == 0 {
            return;
        }
        let (w, h) = (self.window.width as usize, self.window.height as usize);
        let block = BLOCK as usize;
        let (x0, y0) = (self.window.x as usize, self.window.y as usize);
        // Blocks aligned in the full image, so a crop plans its pixels as the full render.
        let (bx0, by0) = (x0 / block, y0 / block);
        let bw = (x0 + w).div_ceil(block) - bx0;
        let bh = (y0 + h).div_ceil(block) - by0;
        let mut sums = vec![[0f64; 5]; bw * bh];
        let mut means = vec![[0f64; 2]; bw * bh];
        for y in 0..h {
            for x in 0..w {
                let s = &stats[y * w + x];
                if s.n >= 2 {
                    let b = ((y + y0) / block - by0) * bw + (x + x0) / block - bx0;
                    means[b][0] += s.sum as f64 / s.n as f64;
                    means[b][1] += 1.0;
                }
            }
        }
        // Each pixel's relative variance of its samples and of a branch, over its block's mean.
        let mut pixels = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let s = &stats[y * w + x];
                if s.n < 2 {
                    continue;
                }
                let n = s.n as f64;
                let (sum, sum_sq) = (s.sum as f64, s.sum_sq as f64);
                let mean = sum / n;
                let var = ((sum_sq - sum * mean) / (n - 1.0)).max(0.0);
                let b = ((y + y0) / block - by0) * bw + (x + x0) / block - bx0;
                // Relative to the block's mean, not the pixel's own: four samples rarely see
                // the small bright things a pixel's footprint covers (a thousand small lights
                // seen directly), and when they do the pixel's mean rises with them, so its
                // own mean hid that variance, which no splitting removes, and the many-light
                // scene split its floor for 0.61x the efficiency (1.0 with the block's mean).
                let m = means[b][0] / means[b][1];
                let norm = 1.0 / (m * m + 1e-2);
                let v_b = if s.split_samples > 0 {
                    s.sum_diff_sq as f64 / (2.0 * s.split_samples as f64)
                } else {
                    0.0
                };
                pixels.push((b, var * norm, v_b * norm * (s.split_samples as f64 / n), s));
            }
        }
        let cap = outlier_cap(pixels.iter().map(|p| p.1));
        for &(b, var, v_b, s) in &pixels {
            let n = s.n as f64;
            let keep = if var > cap { cap / var } else { 1.0 };
            sums[b][0] += var * keep;
            sums[b][1] += v_b * keep;
            sums[b][2] += s.shared_rays as f64 / n;
            sums[b][3] += s.branch_rays as f64 / (2.0 * n);
            sums[b][4] += 1.0;
        }
        // Per block: the variance before the split and a branch's, and their costs.
        let blocks: Vec<[f64; 4]> = sums
            .iter()
            .map(|&[var, v_b, shared, branch, pixels]| {
                // Var(X) = V_s + V_b / 2 for the pilot's two branches.
                // Not clamped at 0: only the image's total of V_s enters the plan, and the
                // blocks' estimates from four samples scatter around their means (clamping
                // them made the SSS box's V_s 12% of its variance, where splitting shows it
                // is about 0).
                let v_s = var - 0.5 * v_b;
                [v_s, v_b.max(0.0), shared + SETUP_RAYS * pixels, branch]
            })
            .collect();
        let factors = optimal_splits(&blocks);
        for y in 0..h {
            for x in 0..w {
                let b = ((y + y0) / block - by0) * bw + (x + x0) / block - bx0;
                splits[y * w + x] = factors[b];
                let [_, _, c_s, c_b] = blocks[b];
                let k = factors[b] as f64;
                costs[y * w + x] = if c_s + c_b > 0.0 {
                    ((c_s + k * c_b) / (c_s + c_b)) as f32
                } else {
                    1.0
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pixel's pilot of four split samples `1 + 0.5 s` (s = +1, -1, +1, -1) whose two
    /// branches differ by 1 (most of the variance after the split: V_s = 1/12, V_b = 1/2), each
    /// with 2 rays before the split and 4 per branch; `outlier` adds `y` to the first sample,
    /// in both branches (variance before the split).
    fn pilot(outlier: f32) -> SplitStats {
        let mut s = SplitStats::default();
        for j in 0..4 {
            let y = 1.0 + if j % 2 == 0 { 0.5 } else { -0.5 } + if j == 0 { outlier } else { 0.0 };
            s.n += 1;
            s.split_samples += 1;
            s.sum += y;
            s.sum_sq += y * y;
            s.sum_diff_sq += 1.0;
            s.shared_rays += 2;
            s.branch_rays += 8;
        }
        s
    }

    fn plan(stats: &[SplitStats], size: u32) -> Vec<u8> {
        let window = Crop {
            x: 0,
            y: 0,
            width: size,
            height: size,
        };
        let n = (size * size) as usize;
        let (mut splits, mut costs) = (vec![0u8; n], vec![0f32; n]);
        SplitPlanner::new(64, window, None).plan(stats, &mut splits, &mut costs);
        splits
    }

    /// One pixel whose pilot caught a rare bright path (one sample 10^4 brighter, as a sun's
    /// glint through a chrome ball) does not switch splitting off for the whole image: without
    /// the outlier cap its variance outweighed the other 4095 pixels' together and the plan
    /// was 1 everywhere.
    #[test]
    fn a_rare_bright_pilot_sample_does_not_switch_splitting_off() {
        let size = 64;
        let mut stats = vec![pilot(0.0); (size * size) as usize];
        let clean = plan(&stats, size);
        assert!(
            clean.iter().all(|&k| k == 2),
            "the clean image splits in two"
        );
        stats[5 * size as usize + 5] = pilot(1e4);
        let with_outlier = plan(&stats, size);
        // Only the outlier's own block may differ (its variance is before the split).
        let changed = (0..stats.len())
            .filter(|&i| with_outlier[i] != clean[i])
            .map(|i| (i % size as usize / 8, i / size as usize / 8))
            .collect::<std::collections::BTreeSet<_>>();
        assert!(
            changed.iter().all(|&b| b == (0, 0)),
            "blocks planned differently: {changed:?}"
        );
    }
}
