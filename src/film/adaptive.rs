//! Adaptive sampling: pixels whose estimate has converged stop receiving samples.
//!
//! The per-pixel error is that of Dammertz et al. 2010 ("A Hierarchical Automatic Stopping
//! Condition for Monte Carlo Global Illumination", section 2.1), normalised as Cycles 4+ does,
//! so a threshold has the meaning of Cycles' Noise Threshold (0.01 by default): for two
//! independent estimates A and B of the pixel from n/2 samples each, and I = (A + B) / 2,
//! `error = |I - A|_1 / (1e-4 + n(s))` with s = I_r + I_g + I_b and n(s) = sqrt(s) below 1, s
//! above (bright pixels need less relative precision on a display). A pixel is converged when
//! its error is below the threshold; it keeps sampling while any pixel of its 3 x 3
//! neighbourhood has not converged (Cycles filters its mask the same way), which catches
//! features the first samples of a pixel missed. Unlike Cycles, a pixel that has stopped is
//! not restarted by a neighbour later: its samples stay a prefix of its sequence.
//!
//! **The halves.** Cycles compares with a "class A" half of the samples picked by the sample
//! index's bits. With Prism's sampler every dimension group shuffles the index its own way
//! (`crate::sampler`), so any interleaved subset of a pixel's samples is, in most dimensions, a
//! random half, much less stratified than the whole: its mean differed from the full mean by
//! many times the full mean's error (a grey background pixel's half was 2.6% off at 256 spp)
//! and pixels never converged. Here A and B are the two halves of the largest power-of-two
//! prefix of the pixel's samples: aligned blocks of its sequence, which every shuffle maps to
//! aligned blocks, so both are stratified estimates. Their difference estimates the error of
//! an estimate of n samples; for the N >= n samples of the pixel it is scaled by sqrt(n / N)
//! (the independent-sampling rate: stratified estimates converge faster, so the estimate
//! errs on the side of more samples).
//!
//! **Which pixels sample first.** Past a short warm-up (`PRIORITY_WARM_UP` samples, or the
//! minimum if smaller) every pass goes to the pixels where samples lower the image's error
//! most (`plan_pass`), not to every unconverged pixel alike as in Cycles. A pixel of N samples
//! whose per-sample deviation is s has a squared error s^2 / N; for a total of samples fixed,
//! the sum of the pixels' squared errors is least when N_i is proportional to s_i (Lagrange),
//! that is when every pixel's gain per extra sample, p_i = s_i^2 / N_i^2, is the same. So each
//! pass samples the pixels whose p_i is at least the median over the pixels still sampling, each
//! with the samples that bring its p_i down to that median (between a quarter of N_i and N_i).
//! With a time limit the render stops where the samples did the most good; without one every
//! pixel still ends converged (past the minimum) or at the maximum, as before. s_i^2 is
//! e_i^2 N_i averaged over the pixel's 3 x 3 neighbourhood: one pixel's two halves are too
//! noisy an estimate to rank pixels on. A pixel that has converged but is kept sampling by a
//! neighbour advances in every pass, as in Cycles.
//!
//! Decisions depend only on the film after whole passes, so an adaptive render is as
//! deterministic as a fixed one (the same image for any thread count).

use super::{Film, FilmPixel};
use rayon::prelude::*;

/// The convergence error of one pixel (infinite before it has two samples).
pub fn pixel_error(px: &FilmPixel) -> f32 {
    let Some((a, b, n)) = px.prefix_halves() else {
        return f32::INFINITY;
    };
    let i = px.rgb();
    // |I_n - A| = |B - A| / 2, for the n-sample prefix; scaled to the pixel's N samples.
    let diff = (b - a).abs() * 0.5;
    let difference = (diff.x + diff.y + diff.z) * (n as f32 / px.samples.max(1) as f32).sqrt();
    let intensity = (i.x + i.y + i.z).max(0.0);
    let normalise = if intensity < 1.0 {
        intensity.sqrt()
    } else {
        intensity
    };
    difference / (1e-4 + normalise)
}

/// Every pixel's `pixel_error`, in pixel order (in parallel: a 4K frame has 8 M pixels and a
/// render dozens of passes). Computed once per pass for `update_active` and `plan_pass`.
pub fn pixel_errors(film: &Film) -> Vec<f32> {
    film.pixels.par_iter().map(pixel_error).collect()
}

/// The indices of pixel `i`'s 3 x 3 neighbourhood (itself included) in a `w` x `h` image.
fn neighbourhood(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    (y.saturating_sub(1)..(y + 2).min(h))
        .flat_map(move |ny| (x.saturating_sub(1)..(x + 2).min(w)).map(move |nx| ny * w + nx))
}

/// Marks the pixels that keep sampling: unconverged ones (and those below `min_samples`,
/// which are never tested) and their 8 neighbours. `errors` are the film's `pixel_errors`.
/// Returns their number.
pub fn update_active(
    film: &Film,
    errors: &[f32],
    threshold: f32,
    min_samples: u32,
    active: &mut [bool],
) -> usize {
    let (w, h) = (film.width as usize, film.height as usize);
    let unconverged: Vec<bool> = film
        .pixels
        .iter()
        .zip(errors)
        .map(|(p, &e)| p.samples < min_samples || !(e < threshold))
        .collect();
    let mut count = 0;
    for (i, a) in active.iter_mut().enumerate().take(w * h) {
        *a = neighbourhood(i, w, h).any(|j| unconverged[j]);
        count += *a as usize;
    }
    count
}

/// Samples every pixel takes before passes are prioritised (`plan_pass`): 8 + 8 for the two
/// halves of its error estimate.
pub const PRIORITY_WARM_UP: u32 = 16;

/// What bounds a planned pass: the noise threshold, the samples a pixel takes before it may
/// stop, the maximum spp and the most samples a pixel takes in one pass.
#[derive(Clone, Copy, Debug)]
pub struct PassLimits {
    pub threshold: f32,
    pub min_samples: u32,
    pub spp: u32,
    pub cap: u32,
}

/// Plans the next pass of an adaptive render (module documentation): sets `pass_end[i]` to
/// the sample count pixel i is to reach in it (at most its count now: it waits) and returns
/// the pass's number of samples. Pixels not `active` wait; active pixels that have converged
/// themselves (kept active by a neighbour) advance by a quarter of their samples; none goes
/// past `spp`, nor by more than `cap` samples in one pass.
pub fn plan_pass(
    film: &Film,
    errors: &[f32],
    active: &[bool],
    limits: PassLimits,
    pass_end: &mut [u32],
) -> u64 {
    plan_pass_with_costs(film, errors, active, None, limits, pass_end)
}

/// `plan_pass` where a sample of pixel i costs `costs[i]` (relative: the planned splitting,
/// `integrator::splitting`, makes a split pixel's samples dearer): a pixel's gain is per unit
/// of cost, s^2 / (N^2 c), so that, for a fixed time, the image's summed squared error is
/// least (N proportional to s / sqrt(c)). With equal costs this is `plan_pass`. Measured on
/// the SSS Cornell box at equal time (4 s, threshold 0.01): planned splitting with
/// cost-blind passes was 15% noisier than no splitting.
pub fn plan_pass_with_costs(
    film: &Film,
    errors: &[f32],
    active: &[bool],
    costs: Option<&[f32]>,
    limits: PassLimits,
    pass_end: &mut [u32],
) -> u64 {
    let PassLimits {
        threshold,
        min_samples,
        spp,
        cap,
    } = limits;
    let (w, h) = (film.width as usize, film.height as usize);
    // e^2 N: the pixel's squared per-sample deviation (infinite before two samples).
    let deviation2: Vec<f32> = film
        .pixels
        .par_iter()
        .zip(errors)
        .map(|(p, &e)| {
            if e.is_finite() {
                e * e * p.samples as f32
            } else {
                f32::INFINITY
            }
        })
        .collect();
    let gains: Vec<f32> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            if !active[i] {
                return 0.0;
            }
            let (sum, n) = neighbourhood(i, w, h)
                .fold((0.0f32, 0.0f32), |(s, n), j| (s + deviation2[j], n + 1.0));
            let samples = film.pixels[i].samples.max(1) as f32;
            let cost = costs.map_or(1.0, |c| c[i].max(1e-3));
            sum / n / (samples * samples * cost)
        })
        .collect();
    let mut positive: Vec<f32> = (0..w * h)
        .filter(|&i| active[i] && gains[i] > 0.0)
        .map(|i| gains[i])
        .collect();
    // The median gain of the pixels still sampling (0: none has a measured error yet).
    let level = if positive.is_empty() {
        0.0
    } else {
        let mid = positive.len() / 2;
        *positive.select_nth_unstable_by(mid, f32::total_cmp).1
    };
    let mut total = 0u64;
    for i in 0..w * h {
        let n = film.pixels[i].samples;
        pass_end[i] = n;
        if !active[i] || n >= spp {
            continue;
        }
        let quarter = (n / 4).max(1);
        let converged = n >= min_samples && errors[i] < threshold;
        let mut step = if converged {
            // Kept sampling by an unconverged neighbour: it advances every pass, as every
            // active pixel does in Cycles. That is the hedge against a converged estimate that
            // was luck; without it, threshold-only renders lost 10% of their efficiency.
            quarter
        } else if gains[i] < level {
            continue;
        } else if level > 0.0 {
            // The samples that bring this pixel's gain down to the level: N sqrt(p / level).
            let target = n as f32 * (gains[i] / level).sqrt();
            ((target - n as f32).ceil() as u32).clamp(quarter, n.max(1))
        } else {
            quarter
        };
        // Not past where its error is predicted to meet the threshold (e falls as 1/sqrt N).
        let e = errors[i];
        if e.is_finite() && threshold > 0.0 {
            let to_converge = (n as f32 * ((e / threshold).powi(2) - 1.0)).ceil();
            step = step.min((to_converge.max(0.0) as u32).max(quarter));
        }
        let step = step.min(cap.max(1)).min(spp - n);
        pass_end[i] = n + step;
        total += step as u64;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_halves_are_the_two_halves_of_the_largest_power_of_two_prefix() {
        let mut px = FilmPixel::default();
        for i in 0..12u32 {
            px.add(Vec3::splat(i as f32));
        }
        // Prefix of 8: samples 0-3 (mean 1.5) and 4-7 (mean 5.5), in Rec.709 of a grey XYZ.
        let (a, b, n) = px.prefix_halves().unwrap();
        assert_eq!(n, 8);
        let grey = |v: f32| crate::spectrum::rgb::xyz_to_linear_srgb(Vec3::splat(v));
        assert!((a - grey(1.5)).abs().max_element() < 1e-5, "{a}");
        assert!((b - grey(5.5)).abs().max_element() < 1e-5, "{b}");
    }

    #[test]
    fn a_constant_pixel_converges_and_a_noisy_one_does_not() {
        let mut flat = FilmPixel::default();
        let mut noisy = FilmPixel::default();
        for i in 0..16 {
            flat.add(Vec3::splat(0.5));
            // The second half of the 16 disagrees with the first.
            noisy.add(Vec3::splat(if i >= 8 { 4.0 } else { 0.1 }));
        }
        assert!(pixel_error(&flat) < 1e-3);
        assert!(pixel_error(&noisy) > 0.1);
        assert_eq!(pixel_error(&FilmPixel::default()), f32::INFINITY);
    }

    #[test]
    fn passes_go_to_the_noisiest_pixels_and_converged_ones_only_advance() {
        // A 12 x 1 film of 16 samples per pixel: pixels 0-3 very noisy, 4-7 a little noisy
        // (both unconverged at 0.01), 8-11 flat (converged).
        let mut film = Film::new(12, 1);
        for (k, px) in film.pixels.iter_mut().enumerate() {
            for i in 0..16 {
                let v = match k {
                    0..=3 => 0.5 + if i >= 8 { 0.4 } else { -0.4 },
                    4..=7 => 0.5 + if i >= 8 { 0.04 } else { -0.04 },
                    _ => 0.5,
                };
                px.add(Vec3::splat(v));
            }
        }
        let active = vec![true; 12];
        let errors = pixel_errors(&film);
        let limits = |spp| PassLimits {
            threshold: 0.01,
            min_samples: 16,
            spp,
            cap: 64,
        };
        let mut end = vec![0u32; 12];
        let total = plan_pass(&film, &errors, &active, limits(1024), &mut end);
        assert_eq!(total, end.iter().map(|&e| (e - 16) as u64).sum::<u64>());
        // Gains (3 x 3 means): pixels 0-2 the highest, 3 and 4 (beside the noisy block) next;
        // pixel 4's is the median of the positive gains. The noisiest take the most samples
        // (N sqrt(gain / median) - N: 12 of at most 16), the median pixel a quarter, the mildly
        // noisy ones below the median wait.
        assert!(end[0] == end[1] && end[1] == end[2], "{end:?}");
        assert!(end[0] > end[3] && end[3] > 20 && end[0] <= 32, "{end:?}");
        assert_eq!(end[4], 20, "{end:?}");
        for k in 5..8 {
            assert_eq!(end[k], 16, "pixel {k}: {end:?}");
        }
        // Converged pixels kept active advance by a quarter.
        for k in 8..12 {
            assert_eq!(end[k], 20, "pixel {k}: {end:?}");
        }
        // Pixels not active, or at the maximum, take nothing.
        let mut end2 = vec![0u32; 12];
        plan_pass(&film, &errors, &[false; 12], limits(1024), &mut end2);
        assert_eq!(end2, vec![16; 12]);
        plan_pass(&film, &errors, &active, limits(16), &mut end2);
        assert_eq!(end2, vec![16; 12]);
    }

    #[test]
    fn dearer_samples_are_planned_as_a_smaller_gain_per_cost() {
        // A 24 x 1 film, every pixel equally noisy; the samples of pixels 0-11 cost 4x. The
        // cheap half's gain per cost is the level and the dear half's a quarter of it: the
        // dear pixels wait while the cheap ones sample. Equal costs give every pixel the same.
        let mut film = Film::new(24, 1);
        for px in film.pixels.iter_mut() {
            for i in 0..16 {
                px.add(Vec3::splat(0.5 + if i >= 8 { 0.3 } else { -0.3 }));
            }
        }
        let active = vec![true; 24];
        let errors = pixel_errors(&film);
        let limits = PassLimits {
            threshold: 0.01,
            min_samples: 16,
            spp: 1024,
            cap: 64,
        };
        let costs: Vec<f32> = (0..24).map(|i| if i < 12 { 4.0 } else { 1.0 }).collect();
        let mut end = vec![0u32; 24];
        plan_pass_with_costs(&film, &errors, &active, Some(&costs), limits, &mut end);
        // Pixels 11 and 12 see both halves in their 3 x 3 mean; the others only their own.
        for k in 0..11 {
            assert_eq!(end[k], 16, "dear pixel {k}: {end:?}");
        }
        for k in 13..24 {
            assert!(end[k] > 16, "cheap pixel {k}: {end:?}");
        }
        let mut even = vec![0u32; 24];
        plan_pass_with_costs(&film, &errors, &active, None, limits, &mut even);
        assert!(even.iter().all(|&e| e == even[0] && e > 16), "{even:?}");
    }

    #[test]
    fn neighbours_of_unconverged_pixels_stay_active() {
        let mut film = Film::new(5, 5);
        for (k, px) in film.pixels.iter_mut().enumerate() {
            for i in 0..8 {
                let v = if k == 12 && i >= 4 { 3.0 } else { 0.5 };
                px.add(Vec3::splat(v));
            }
        }
        let mut active = vec![true; 25];
        assert_eq!(
            update_active(&film, &pixel_errors(&film), 0.01, 1, &mut active),
            9
        );
        for y in 0..5 {
            for x in 0..5 {
                let inside = (1..4).contains(&x) && (1..4).contains(&y);
                assert_eq!(active[y * 5 + x], inside, "({x}, {y})");
            }
        }
    }
}
