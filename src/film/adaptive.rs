//! Adaptive sampling: pixels whose estimate has converged stop receiving samples.
//!
//! The per-pixel error is that of Dammertz et al. 2010 ("A Hierarchical Automatic Stopping
//! Condition for Monte Carlo Global Illumination", section 2.1), normalised as Cycles 4+ does,
//! so a threshold has the meaning of Cycles' Noise Threshold (0.01 by default): with I the mean
//! of all samples and A the mean of the odd-numbered half (linear Rec.709) and
//! s = I_r + I_g + I_b, `error = |I - A|_1 / (1e-4 + n(s))` with n(s) = sqrt(s) below 1 and s
//! above (bright pixels need less relative precision on a display). A pixel is converged when
//! its error is below the threshold; it keeps sampling while any pixel of its 3 x 3
//! neighbourhood has not converged (Cycles filters its mask the same way), which catches
//! features the first samples of a pixel missed. Unlike Cycles, a pixel that has stopped is
//! not restarted by a neighbour later: its samples stay a prefix of its sequence.
//!
//! Decisions depend only on the film after whole passes, so an adaptive render is as
//! deterministic as a fixed one (the same image for any thread count).

use super::{Film, FilmPixel};

/// The convergence error of one pixel (infinite before it has two samples).
pub fn pixel_error(px: &FilmPixel) -> f32 {
    let Some(a) = px.half_rgb() else {
        return f32::INFINITY;
    };
    let i = px.rgb();
    let diff = (i - a).abs();
    let difference = diff.x + diff.y + diff.z;
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
    fn the_half_takes_two_of_every_aligned_four() {
        for block in 0..64u32 {
            let n = (4 * block..4 * block + 4)
                .filter(|&i| crate::film::in_half(i))
                .count();
            assert_eq!(n, 2);
        }
    }

    #[test]
    fn a_constant_pixel_converges_and_a_noisy_one_does_not() {
        let mut flat = FilmPixel::default();
        let mut noisy = FilmPixel::default();
        for i in 0..16 {
            flat.add(Vec3::splat(0.5), i);
            // Samples that disagree between the two halves.
            noisy.add(
                Vec3::splat(if crate::film::in_half(i) { 4.0 } else { 0.1 }),
                i,
            );
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
                let v = if k == 12 && crate::film::in_half(i) {
                    3.0
                } else {
                    0.5
                };
                px.add(Vec3::splat(v), i);
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
