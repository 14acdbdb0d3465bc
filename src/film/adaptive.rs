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
//! Decisions depend only on the film after whole passes, so an adaptive render is as
//! deterministic as a fixed one (the same image for any thread count).

use super::{Film, FilmPixel};

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

/// Marks the pixels that keep sampling: unconverged ones and their 8 neighbours. Returns
/// their number.
pub fn update_active(film: &Film, threshold: f32, active: &mut [bool]) -> usize {
    let (w, h) = (film.width as usize, film.height as usize);
    let unconverged: Vec<bool> = film
        .pixels
        .iter()
        .map(|p| !(pixel_error(p) < threshold))
        .collect();
    let mut count = 0;
    for y in 0..h {
        for x in 0..w {
            let near = (y.saturating_sub(1)..(y + 2).min(h))
                .any(|ny| (x.saturating_sub(1)..(x + 2).min(w)).any(|nx| unconverged[ny * w + nx]));
            active[y * w + x] = near;
            count += near as usize;
        }
    }
    count
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
    fn neighbours_of_unconverged_pixels_stay_active() {
        let mut film = Film::new(5, 5);
        for (k, px) in film.pixels.iter_mut().enumerate() {
            for i in 0..8 {
                let v = if k == 12 && i >= 4 { 3.0 } else { 0.5 };
                px.add(Vec3::splat(v));
            }
        }
        let mut active = vec![true; 25];
        assert_eq!(update_active(&film, 0.01, &mut active), 9);
        for y in 0..5 {
            for x in 0..5 {
                let inside = (1..4).contains(&x) && (1..4).contains(&y);
                assert_eq!(active[y * 5 + x], inside, "({x}, {y})");
            }
        }
    }
}
