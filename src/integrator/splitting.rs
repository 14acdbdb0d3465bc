//! How many branches a camera path takes at its first vertex (`PathTracer::radiance_split`),
//! chosen per block of pixels from the render's first samples.
//!
//! A split path shares its camera ray and first hit's shading (cost `C_s`, variance `V_s`:
//! what the pixel's footprint sees) and traces `k_l` light samples (cost `C_l` and variance
//! `V_l` each) and `k_p` continuations: BSDF sample and rest of the path (`C_p`, `V_p`). Given
//! the vertex the two are independent, so the sample has variance
//! `V_s + V_l / k_l + V_p / k_p` for cost `C_s + k_l C_l + k_p C_p`, whose product is least at
//! `k_l = sqrt((V_l / C_l) (C / V))` and `k_p = sqrt((V_p / C_p) (C / V))` with C and V the
//! totals (Rath et al. 2022, "EARS: Efficiency-Aware Russian Roulette and Splitting", eq. 7,
//! one factor per image region and per kind of branch). Splitting both by one factor wastes
//! light samples where the noise comes from the continuation (a sun's caustic from a gold
//! ball on a floor: 1.1-1.3x the efficiency with one light sample and four continuations) and
//! continuations where it comes from the light sample.
//!
//! The first [`PILOT_SPP`] samples of every pixel take two of each. Per pixel they give the
//! variance of the samples, `Var(X) = V_s + V_l / 2 + V_p / 2`, and the spreads between the
//! two light samples and the two continuations, `E[(b_1 - b_2)^2] / 2 = V_l` and `V_p`; per
//! block of [`BLOCK`] x [`BLOCK`] pixels the relative variances (each pixel's over its
//! mean^2 + 0.01, the benchmark's measure) are summed, and the rays traced before the split,
//! by the light samples and by the continuations stand for the costs. Pixels above the 99th
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

/// Samples per pixel traced with two branches of each kind to measure the variances.
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
/// The least `sequence_gain` (one pilot's estimate is noisy; no estimate says a kind of branch
/// is free of noise).
const MIN_SEQUENCE_GAIN: f64 = 0.05;
/// Caustic guiding goes on after the pilot only where it removes at least this share of the
/// image's variance (its pilot estimate, `PathSample::guide_gain`, over the variance of the
/// guided samples): it costs 30-60% more time where it is on (the photons' gathers, more
/// continuations planned). Measured at 64 spp: the gain is 1.8-5.5 where guiding paid (sun
/// glints in metal balls of roughness 0.1-0.3, 1.6-2.5x the efficiency) and at most 0.11
/// where it did not (the Cornell box's metal ball under its ceiling light, the rough glass
/// scene, the studio everyday3).
const MIN_GUIDE_GAIN: f64 = 0.5;
/// Where guiding does not pay for the whole image, a block keeps it where, with its eight
/// neighbours, it removes more of the image's variance than this many times its share of the
/// image's cost (`guided_blocks`): a glass ball's caustics on the floor beside it are a few
/// percent of the image. Four samples per pixel estimate a block's gain far less well than the
/// image's, and picking the blocks whose estimate came out high picks some by chance: at 1
/// (0.5) the Cornell box lost 4% (11%) of its efficiency where the pilot's blocks promised
/// more than they gave; at 2 it keeps one block there, and glass3 gains 1.16-1.27x / 0.98-1.08x
/// (full / bulk; two runs of 5 pairs, bench/README.md).
const MIN_BLOCK_GUIDE_GAIN: f64 = 2.0;
/// Pixels whose pilot variance is above this quantile of the varying pixels' enter the plan
/// at it (`outlier_cap`).
const OUTLIER_QUANTILE: f64 = 0.99;

/// How a camera path branches at its first vertex: light samples and continuations there,
/// each kind averaged (`PathTracer::radiance_split`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Branches {
    pub lights: u8,
    pub paths: u8,
    /// The branches take independent scrambles (`Sampler::independent_branch`): the pilot's,
    /// whose spreads estimate the variance of one branch.
    pub independent: bool,
    /// Continuations are guided towards caustics where photons found some
    /// (`integrator::caustics`), at every guided vertex of the path; the plan turns it off
    /// where the pilot says it does not pay.
    pub caustic_guiding: bool,
}

impl Branches {
    /// Plain path tracing.
    pub const ONE: Branches = Branches::new(1, 1);

    pub const fn new(lights: u8, paths: u8) -> Branches {
        Branches {
            lights,
            paths,
            independent: false,
            caustic_guiding: true,
        }
    }

    pub fn split(self) -> bool {
        self.lights > 1 || self.paths > 1
    }
}

/// One block's sums over its pixels: the variance before the split, of a light sample and of a
/// continuation, and their costs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BlockVariance {
    pub shared: f64,
    pub light: f64,
    pub path: f64,
    pub shared_cost: f64,
    pub light_cost: f64,
    pub path_cost: f64,
}

/// Branches per block, from each block's variances and costs, that minimise the image's total
/// variance times its total cost: setting the derivatives of
/// (sum V_s + V_l / k_l + V_p / k_p) (sum C_s + k_l C_l + k_p C_p) by k_l and k_p to zero gives
/// k = sqrt((V / C)_kind (C / V)) with C and V the image's totals at that plan, a fixed point
/// found by iterating from 1. (Each block's own optimum, sqrt((V_p / V_s) (C_s / C_p)), splits a
/// block whose variance is small next to the image's as much as one that holds most of it:
/// with a thousand small lights seen directly, the floor's blocks split 2-4 times for noise
/// that was not the image's.)
pub fn optimal_splits(blocks: &[BlockVariance]) -> Vec<Branches> {
    let mut k = vec![(1f64, 1f64); blocks.len()];
    // The variance before the split is at least a small share of the whole (the estimate is a
    // difference of noisy sums).
    let floor = 0.02
        * blocks
            .iter()
            .map(|b| b.shared + (b.light + b.path) / 2.0)
            .sum::<f64>();
    let factor = |v: f64, c: f64, scale: f64| {
        if v > 0.0 && c > 0.0 {
            ((v / c) * scale).sqrt().clamp(1.0, MAX_SPLITS as f64)
        } else {
            1.0
        }
    };
    for _ in 0..32 {
        let (mut v, mut c) = (0.0, 0.0);
        for (b, &(kl, kp)) in blocks.iter().zip(&k) {
            v += b.shared + b.light / kl + b.path / kp;
            c += b.shared_cost + kl * b.light_cost + kp * b.path_cost;
        }
        let v = v.max(floor);
        if !(v > 0.0 && c > 0.0) {
            break;
        }
        for (b, kb) in blocks.iter().zip(k.iter_mut()) {
            *kb = (
                factor(b.light, b.light_cost, c / v),
                factor(b.path, b.path_cost, c / v),
            );
        }
    }
    k.iter()
        .map(|&(kl, kp)| Branches::new(kl.round() as u8, kp.round() as u8))
        .collect()
}

/// How much less a kind of branch's error is at `spp` samples than independent samples' would
/// be (variance over variance). The samples are an Owen-scrambled net, whose variance falls
/// faster than N^-1 (Owen 1997, "Monte Carlo variance of scrambled net quadrature": o(1/N)
/// for any square-integrable integrand); for a two-dimensional one with edges, as a light
/// sample's shadows, as about N^-3/2 (Christensen et al. 2018, "Progressive Multi-Jittered
/// Sample Sequences", measured on discontinuous test functions), and for the high-dimensional
/// rest of a path hardly faster than N^-1. Each pilot sample's two branches
/// take independent scrambles of one sequence (`Sampler::independent_branch`), so over the
/// pilot's n samples the difference of the two branches' means has the sequence's variance at
/// n, `sum_seq` = sum (sum d)^2 / n^2, where independent samples would give `sum_mc` =
/// sum sum d^2 / n^2. Their ratio g(n) is extrapolated as a power law, g(N) = g(n)^(ln N / ln n):
/// the light samples of the scenes measured gain 0.43-0.65 at n = 4 (N^-3/2 predicts 0.5), their
/// continuations 0.8-0.96. Without it the plan took the light samples' variance at its
/// independent value, two to ten times what 64 samples leave of it, and split too little
/// (a gold ball's caustic on a floor under a sun: one light sample and four continuations
/// were 1.27x as efficient as the plan).
fn sequence_gain(sum_mc: f64, sum_seq: f64, spp: u32) -> f64 {
    if !(sum_mc > 0.0 && sum_seq >= 0.0) {
        return 1.0;
    }
    let at_pilot = (sum_seq / sum_mc).clamp(MIN_SEQUENCE_GAIN, 1.0);
    let exponent = (spp.max(PILOT_SPP) as f64).ln() / (PILOT_SPP as f64).ln();
    at_pilot.powf(exponent).max(MIN_SEQUENCE_GAIN)
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
    /// Sums of (first - second)^2 over the samples that split: of their light samples and of
    /// their continuations.
    light_diff_sq: f32,
    path_diff_sq: f32,
    light_diff_sum: f32,
    path_diff_sum: f32,
    /// Rays before the split (all of an unsplit sample's), of the light samples and of the
    /// continuations.
    shared_rays: u32,
    light_rays: u32,
    path_rays: u32,
    /// Sum of `PathSample::guide_gain` over the samples that split.
    guide_gain: f32,
}

impl SplitStats {
    /// Adds a pilot sample whose film luminance is `y`.
    pub fn add(&mut self, sample: &PathSample, y: f32) {
        if !y.is_finite() || self.n == u16::MAX {
            return;
        }
        self.n += 1;
        self.sum += y;
        self.sum_sq += y * y;
        if sample.split {
            let [dl, dp] = sample.branch_differences;
            if dl.is_finite() && dp.is_finite() {
                self.light_diff_sq += dl * dl;
                self.path_diff_sq += dp * dp;
                self.light_diff_sum += dl;
                self.path_diff_sum += dp;
            }
            if sample.guide_gain.is_finite() {
                self.guide_gain += sample.guide_gain;
            }
            self.shared_rays = self.shared_rays.saturating_add(sample.shared_rays);
            self.light_rays = self.light_rays.saturating_add(sample.light_rays);
            self.path_rays = self
                .path_rays
                .saturating_add(sample.rays - sample.shared_rays - sample.light_rays);
            self.split_samples += 1;
        } else {
            self.shared_rays = self.shared_rays.saturating_add(sample.rays);
        }
    }
}

/// The render's splitting plan.
#[derive(Clone, Copy, Debug)]
pub struct SplitPlanner {
    spp: u32,
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
            spp,
            enabled: spp >= MIN_SPP || forced.is_some(),
            forced,
            window,
        }
    }

    /// Branches of the pilot samples.
    pub fn pilot_splits(&self) -> Branches {
        match (self.enabled, self.forced) {
            (false, _) => Branches::ONE,
            (true, Some(k)) => Branches::new(k as u8, k as u8),
            (true, None) => Branches {
                independent: true,
                ..Branches::new(2, 2)
            },
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
    /// (C_s + k_l C_l + k_p C_p) / (C_s + C_l + C_p) (`costs`, for adaptive sampling's passes).
    pub fn plan(&self, stats: &[SplitStats], splits: &mut [Branches], costs: &mut [f32]) {
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
        let mut blocks = vec![BlockVariance::default(); bw * bh];
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
        // Each pixel's relative variance of its samples, of a light sample and of a
        // continuation, over its block's mean.
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
                // A branch's variance, over all of the pixel's samples (those that did not
                // split have none after their first vertex).
                let branch_variance = |diff_sq: f32| {
                    if s.split_samples > 0 {
                        diff_sq as f64 / (2.0 * n)
                    } else {
                        0.0
                    }
                };
                pixels.push((
                    b,
                    var * norm,
                    branch_variance(s.light_diff_sq) * norm,
                    branch_variance(s.path_diff_sq) * norm,
                    norm,
                    s,
                ));
            }
        }
        let cap = outlier_cap(pixels.iter().map(|p| p.1));
        // Sums over the image of each kind's squared differences' mean (Monte Carlo) and of
        // the square of their mean (the pilot's own sequence), for `sequence_gain`.
        let mut gain_sums = [[0f64; 2]; 2];
        // The image's variance and what caustic guiding removes of it.
        let (mut variance, mut guide_gain) = (0f64, 0f64);
        let mut block_gains = vec![0f64; blocks.len()];
        for &(b, var, v_l, v_p, norm, s) in &pixels {
            let n = s.n as f64;
            let keep = if var > cap { cap / var } else { 1.0 };
            if s.split_samples > 0 {
                let m2 = (s.split_samples as f64).powi(2);
                let w = norm * keep / m2;
                for (sums, (sq, sum)) in gain_sums.iter_mut().zip([
                    (s.light_diff_sq, s.light_diff_sum),
                    (s.path_diff_sq, s.path_diff_sum),
                ]) {
                    sums[0] += w * sq as f64;
                    sums[1] += w * (sum as f64).powi(2);
                }
            }
            let sum = &mut blocks[b];
            // Var(X) = V_s + V_l / 2 + V_p / 2 for the pilot's two branches of each kind.
            // Not clamped at 0: only the image's total of V_s enters the plan, and the blocks'
            // estimates from four samples scatter around their means (clamping them made the
            // SSS box's V_s 12% of its variance, where splitting shows it is about 0).
            sum.shared += (var - 0.5 * (v_l + v_p)) * keep;
            sum.light += v_l * keep;
            sum.path += v_p * keep;
            // An unsplit sample's: V_s + V_l + V_p.
            variance += (var + 0.5 * (v_l + v_p)) * keep;
            // Per continuation, over all of the pixel's samples (as `v_p`).
            let gain = s.guide_gain as f64 / (2.0 * n) * norm * keep;
            guide_gain += gain;
            block_gains[b] += gain;
            sum.shared_cost += s.shared_rays as f64 / n + SETUP_RAYS;
            sum.light_cost += s.light_rays as f64 / (2.0 * n);
            sum.path_cost += s.path_rays as f64 / (2.0 * n);
        }
        let [light_gain, path_gain] = gain_sums.map(|[mc, seq]| sequence_gain(mc, seq, self.spp));
        for b in &mut blocks {
            // The camera's share gains at least what the continuation does (its dimensions
            // are fewer); taking the continuation's gain for it errs towards splitting less.
            b.shared *= path_gain;
            b.light *= light_gain;
            b.path *= path_gain;
        }
        let factors = optimal_splits(&blocks);
        // Guiding everywhere where it pays for the image (a chrome ball's glints reach the
        // far floor, whose blocks' own estimates are small: guided by blocks there, a ball of
        // roughness 0.15 under the sun lost 18% of its full figure), else where it pays
        // locally.
        let guided = if guide_gain > MIN_GUIDE_GAIN * variance {
            vec![true; blocks.len()]
        } else {
            guided_blocks(&blocks, &factors, &block_gains, variance, bw)
        };
        for y in 0..h {
            for x in 0..w {
                let b = ((y + y0) / block - by0) * bw + (x + x0) / block - bx0;
                let k = Branches {
                    caustic_guiding: guided[b],
                    ..factors[b]
                };
                splits[y * w + x] = k;
                let v = &blocks[b];
                let unsplit = v.shared_cost + v.light_cost + v.path_cost;
                costs[y * w + x] = if unsplit > 0.0 {
                    ((v.shared_cost
                        + k.lights as f64 * v.light_cost
                        + k.paths as f64 * v.path_cost)
                        / unsplit) as f32
                } else {
                    1.0
                };
            }
        }
    }
}

/// The blocks that keep caustic guiding where the image as a whole does not. Guiding a
/// block removes `g_b` of the image's variance `V` (the pilot's estimate,
/// `PathSample::guide_gain`) and adds about its cost `C_b` to the image's `C`; the product
/// `V C` falls where `g_b / V > C_b / C`, here with the margin `MIN_BLOCK_GUIDE_GAIN` and each
/// block judged with its eight neighbours (a caustic spans several; one block's estimate from
/// four samples per pixel is noisy).
fn guided_blocks(
    blocks: &[BlockVariance],
    factors: &[Branches],
    gains: &[f64],
    variance: f64,
    width: usize,
) -> Vec<bool> {
    let cost = |b: usize| {
        let (v, k) = (&blocks[b], &factors[b]);
        v.shared_cost + k.lights as f64 * v.light_cost + k.paths as f64 * v.path_cost
    };
    let costs: Vec<f64> = (0..blocks.len()).map(cost).collect();
    let total_cost: f64 = costs.iter().sum();
    if !(variance > 0.0) || !(total_cost > 0.0) || width == 0 {
        return vec![false; blocks.len()];
    }
    let height = blocks.len() / width;
    (0..blocks.len())
        .map(|b| {
            let (bx, by) = (b % width, b / width);
            let (mut gain, mut cost) = (0.0, 0.0);
            for y in by.saturating_sub(1)..(by + 2).min(height) {
                for x in bx.saturating_sub(1)..(bx + 2).min(width) {
                    gain += gains[y * width + x];
                    cost += costs[y * width + x];
                }
            }
            gain / variance > MIN_BLOCK_GUIDE_GAIN * cost / total_cost
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pixel's pilot of four split samples `1 + 0.5 s` (s = +1, -1, +1, -1) whose two
    /// continuations differ by 1 and whose light samples agree (the variance is the
    /// continuations': V_s = 1/12, V_l = 0, V_p = 1/2), each with 2 rays before the split, 1 per
    /// light sample and 4 per continuation; `outlier` adds `y` to the first sample, in all its
    /// branches (variance before the split).
    fn pilot(outlier: f32) -> SplitStats {
        let mut s = SplitStats::default();
        for j in 0..4 {
            let y = 1.0 + if j % 2 == 0 { 0.5 } else { -0.5 } + if j == 0 { outlier } else { 0.0 };
            s.n += 1;
            s.split_samples += 1;
            s.sum += y;
            s.sum_sq += y * y;
            s.path_diff_sq += 1.0;
            s.shared_rays += 2;
            s.light_rays += 2;
            s.path_rays += 8;
        }
        s
    }

    fn plan(stats: &[SplitStats], size: u32) -> Vec<Branches> {
        let window = Crop {
            x: 0,
            y: 0,
            width: size,
            height: size,
        };
        let n = (size * size) as usize;
        let (mut splits, mut costs) = (vec![Branches::ONE; n], vec![0f32; n]);
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
            clean.iter().all(|&k| (k.lights, k.paths) == (1, 2)),
            "the clean image takes two continuations and one light sample: {:?}",
            clean[0]
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

    /// Caustic guiding stays on after the pilot only where the pilot's continuations say it
    /// removes at least `MIN_GUIDE_GAIN` of the image's variance: here the variance of an
    /// unsplit sample is V_s + V_l + V_p = 1/12 + 0 + 1/2 (relative to the mean 1, over
    /// 1.01 for both), and the guide's gain per continuation is varied around that share of it.
    #[test]
    fn the_pilot_keeps_caustic_guiding_only_where_it_removes_enough_noise() {
        let size = 16;
        let with_gain = |gain_per_continuation: f32| {
            let mut s = pilot(0.0);
            // Summed over the two continuations of each of the 4 samples.
            s.guide_gain = gain_per_continuation * 2.0 * 4.0;
            plan(&vec![s; (size * size) as usize], size)
        };
        let threshold = (MIN_GUIDE_GAIN * 7.0 / 12.0) as f32;
        assert!(with_gain(1.2 * threshold).iter().all(|k| k.caustic_guiding));
        assert!(with_gain(0.8 * threshold)
            .iter()
            .all(|k| !k.caustic_guiding));
        assert!(with_gain(-1.0).iter().all(|k| !k.caustic_guiding));
        // The branches planned do not depend on it.
        let strip = |k: &Branches| (k.lights, k.paths);
        assert_eq!(
            with_gain(1.0).iter().map(strip).collect::<Vec<_>>(),
            with_gain(0.0).iter().map(strip).collect::<Vec<_>>()
        );
    }

    /// Where guiding does not pay for the whole image, a block whose own gain, with its
    /// neighbours', exceeds `MIN_BLOCK_GUIDE_GAIN` times their share of the cost keeps it (the
    /// floor beside a glass ball), and only that block: 64 x 64 pixels (8 x 8 blocks of equal
    /// cost), the gain in block (0, 0) alone. Its neighbourhood is 4 of the 64 blocks, so it
    /// is guided from a gain of 2 x 4 / 64 of the image's variance, 64 x 7/12 x 8 / 64 per
    /// pixel and continuation in the units above (at 10 x 7/12 the image's rule, 1/2 of its
    /// variance, is not met); its neighbours, judged over 6 or 9 blocks, are not.
    #[test]
    fn a_block_keeps_caustic_guiding_where_it_pays_locally() {
        let size = 64;
        let with_hot_block = |gain_per_continuation: f32| {
            let mut stats = vec![pilot(0.0); (size * size) as usize];
            for y in 0..8 {
                for x in 0..8 {
                    stats[y * size as usize + x].guide_gain = gain_per_continuation * 2.0 * 4.0;
                }
            }
            plan(&stats, size)
        };
        let unit = 7.0 / 12.0;
        let in_hot_block = |i: usize| i % size as usize / 8 == 0 && i / size as usize / 8 == 0;
        let guided = with_hot_block(10.0 * unit);
        assert!(guided
            .iter()
            .enumerate()
            .all(|(i, k)| k.caustic_guiding == in_hot_block(i)));
        assert!(with_hot_block(6.0 * unit)
            .iter()
            .all(|k| !k.caustic_guiding));
    }

    /// Light samples and continuations that vary alike and cost alike are planned by how the
    /// sequence converges for each: light samples whose two branches' means agree over the
    /// pilot (differences 0.3 x (+1, -1, +1, -1): the sequence stratifies them) take fewer
    /// branches than continuations whose means differ as independent samples' would
    /// (0.3 x (+1, +1, -1, +1)).
    /// Without `sequence_gain` both would take the same number.
    #[test]
    fn the_plan_weighs_each_kind_by_the_sequences_gain() {
        let mut s = SplitStats::default();
        for (j, sign) in [1.0f32, 1.0, -1.0, 1.0].into_iter().enumerate() {
            let alternate = if j % 2 == 0 { 1.0 } else { -1.0 };
            let (dl, dp) = (0.3 * alternate, 0.3 * sign);
            let y = 1.0 + 0.2 * alternate;
            s.n += 1;
            s.split_samples += 1;
            s.sum += y;
            s.sum_sq += y * y;
            s.light_diff_sq += dl * dl;
            s.light_diff_sum += dl;
            s.path_diff_sq += dp * dp;
            s.path_diff_sum += dp;
            s.shared_rays += 2;
            s.light_rays += 2;
            s.path_rays += 2;
        }
        let k = plan(&vec![s; 64 * 64], 64);
        assert!(
            k.iter().all(|b| b.paths > b.lights),
            "continuations {} light samples {}",
            k[0].paths,
            k[0].lights
        );
    }

    /// The sequence's gain at the pilot is carried to the render's samples as a power law
    /// (a light sample at 0.5 with 4 samples, N^-3/2, is at 1/8 with 64), never above 1 (a
    /// pilot whose branches happened to differ more than independent ones would) and never
    /// below `MIN_SEQUENCE_GAIN`.
    #[test]
    fn the_sequence_gain_follows_a_power_law_from_the_pilot() {
        assert!((sequence_gain(2.0, 1.0, 64) - 0.125).abs() < 1e-9);
        assert!((sequence_gain(2.0, 1.0, PILOT_SPP) - 0.5).abs() < 1e-9);
        assert_eq!(sequence_gain(1.0, 3.0, 64), 1.0);
        assert_eq!(sequence_gain(1.0, 0.0, 64), MIN_SEQUENCE_GAIN);
        assert_eq!(sequence_gain(0.0, 0.0, 64), 1.0);
    }
}
