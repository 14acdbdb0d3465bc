//! Image comparison metrics used by the image tests and `prism compare`.

/// Mean of each RGB channel.
pub fn channel_means(px: &[[f32; 4]]) -> [f64; 3] {
    let mut m = [0f64; 3];
    for p in px {
        for c in 0..3 {
            m[c] += p[c] as f64;
        }
    }
    m.map(|v| v / px.len().max(1) as f64)
}

/// Averages k x k blocks (the last partial blocks are dropped): removes most per-pixel noise
/// while keeping the image's structure, so a metric measures bias rather than variance.
pub fn box_downsample(
    px: &[[f32; 4]],
    width: usize,
    height: usize,
    k: usize,
) -> (usize, usize, Vec<[f32; 4]>) {
    let (w, h) = (width / k, height / k);
    let mut out = vec![[0f32; 4]; w * h];
    let norm = 1.0 / (k * k) as f32;
    for y in 0..h * k {
        for x in 0..w * k {
            let o = &mut out[(y / k) * w + x / k];
            for c in 0..4 {
                o[c] += px[y * width + x][c] * norm;
            }
        }
    }
    (w, h, out)
}

/// Clamps RGB to [0, max]: a firefly (a rare, very bright sample) then moves a block average
/// by a bounded amount, which keeps metrics on noisy renders stable. Clamp both images alike.
pub fn clamp_pixels(px: &[[f32; 4]], max: f32) -> Vec<[f32; 4]> {
    px.iter()
        .map(|p| {
            [
                p[0].clamp(0.0, max),
                p[1].clamp(0.0, max),
                p[2].clamp(0.0, max),
                p[3],
            ]
        })
        .collect()
}

/// Relative MSE over RGB: mean of (a - b)^2 / (b^2 + epsilon), b the reference. The epsilon
/// (0.01) keeps near-black pixels from dominating.
pub fn rel_mse(test: &[[f32; 4]], reference: &[[f32; 4]]) -> f64 {
    let mut sum = 0.0f64;
    for (p, q) in test.iter().zip(reference) {
        for c in 0..3 {
            let d = (p[c] - q[c]) as f64;
            sum += d * d / ((q[c] as f64).powi(2) + 0.01);
        }
    }
    sum / (test.len().max(1) * 3) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_on_known_images() {
        let a = vec![[1.0, 2.0, 3.0, 1.0]; 16];
        let b = vec![[1.0, 2.0, 3.3, 1.0]; 16];
        assert_eq!(channel_means(&a), [1.0, 2.0, 3.0]);
        assert_eq!(rel_mse(&a, &a), 0.0);
        let e = rel_mse(&a, &b);
        assert!((e - (0.09 / (3.3f64 * 3.3 + 0.01)) / 3.0).abs() < 1e-6);
        let (w, h, d) = box_downsample(&a, 4, 4, 2);
        assert_eq!((w, h, d.len()), (2, 2, 4));
        assert_eq!(d[0], [1.0, 2.0, 3.0, 1.0]);
    }
}
