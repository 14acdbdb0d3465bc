//! Relative MSE of test renders against a reference made of two independent halves, with the
//! reference's own error estimated and removed, optionally split by image region. Used by
//! `bench/wavelengths.sh`.
//!
//! ```text
//! cargo run --release --example bench_relmse -- REF_A.exr REF_B.exr [--mask GUIDES.exr]
//!     [--clamp M] TEST.exr...
//! ```
//!
//! Why: the per-pixel relative MSE of a test image T against a reference R = (A + B) / 2 is
//! `mean (T - R)^2 / (R^2 + 0.01)` (`prism::film::metrics::rel_mse`). With T, A and B
//! independent unbiased estimates of the same pixel value, `E[(T - R)^2] = Var T + Var R`: the
//! reference's own variance adds the same amount to every strategy's relMSE and pulls their
//! ratios towards 1 ((S + R) / (H + R) instead of S / H). The two halves A and B (equal spp,
//! different seeds) give an unbiased per-pixel estimate of that variance,
//! `Var R = Var(A - B) / 4`, so `E[(A - B)^2 / 4] = Var R`, and
//!
//! ```text
//!     corrected = mean ((T - R)^2 - (A - B)^2 / 4) / (R^2 + 0.01)
//! ```
//!
//! estimates `mean Var T / (R^2 + 0.01)`, the test image's own error (same normalisation as
//! the raw metric; the noise of R in the denominator is a second-order effect). Its
//! uncertainty is that of the reference-error term, which is small next to the test images'
//! error when the reference has many more samples.
//!
//! `--mask GUIDES.exr` (a render with `--guides`) splits every number into pixels whose camera
//! ray mostly hits a transmissive (white-tinted) dielectric, recognised by its albedo guide
//! (the dielectric's transmission tint, 1 for clear glass, written at the first non-Dirac
//! surface, i.e. at the rough glass itself), and the rest. Region values are contributions
//! to the image mean (they add up to the total), with the region's pixel fraction.
//!
//! `--clamp M` clamps T, A and B to [0, M] first (so one firefly moves a pixel by a bounded
//! amount); the reference is then the mean of the clamped halves, an approximation of the
//! clamped reference.
//!
//! Prints one JSON line per test image.

use prism::film::{read_exr_channel, read_exr_rgba};
use std::path::PathBuf;

/// A pixel counts as glass when the red channel of its albedo guide exceeds this: clear glass
/// has albedo ~1, the brightest diffuse material of the bench scenes 0.75, so a pixel mixing
/// glass and floor is called glass when glass covers more than roughly 40% of it.
const GLASS_ALBEDO: f32 = 0.85;

struct Acc {
    raw: f64,
    reference: f64,
    /// The same two for the luminance Y alone (Rec.709 weights), which shows how much of the
    /// error is noise in brightness rather than in colour.
    lum_raw: f64,
    lum_reference: f64,
    pixels: usize,
}

fn luminance(p: [f64; 3]) -> f64 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

fn main() {
    let mut args = std::env::args().skip(1);
    let mut positional: Vec<PathBuf> = Vec::new();
    let mut mask_path: Option<PathBuf> = None;
    let mut clamp: Option<f32> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--mask" => mask_path = Some(args.next().expect("--mask needs a path").into()),
            "--clamp" => {
                clamp = Some(
                    args.next()
                        .and_then(|v| v.parse().ok())
                        .expect("--clamp needs a number"),
                )
            }
            _ => positional.push(a.into()),
        }
    }
    if positional.len() < 3 {
        eprintln!("usage: bench_relmse REF_A.exr REF_B.exr [--mask G.exr] [--clamp M] TEST.exr...");
        std::process::exit(2);
    }
    let read = |p: &PathBuf| {
        let (w, h, px) = read_exr_rgba(p).unwrap_or_else(|e| panic!("{e}"));
        let px: Vec<[f32; 3]> = px
            .iter()
            .map(|q| {
                let c = |v: f32| match clamp {
                    Some(m) => v.clamp(0.0, m),
                    None => v,
                };
                [c(q[0]), c(q[1]), c(q[2])]
            })
            .collect();
        ((w, h), px)
    };
    let (size, a) = read(&positional[0]);
    let (size_b, b) = read(&positional[1]);
    assert_eq!(size, size_b, "reference halves differ in size");
    let glass: Vec<bool> = match &mask_path {
        Some(p) => {
            let (w, h, r) = read_exr_channel(p, "Albedo.R").unwrap_or_else(|e| panic!("{e}"));
            assert_eq!((w, h), size, "mask size differs");
            r.iter().map(|&v| v > GLASS_ALBEDO).collect()
        }
        None => vec![false; a.len()],
    };
    let n = a.len();
    for test in &positional[2..] {
        let (size_t, t) = read(test);
        assert_eq!(
            size_t,
            size,
            "{}: size differs from the reference",
            test.display()
        );
        // [glass, rest]
        let mut acc = [0, 1].map(|_| Acc {
            raw: 0.0,
            reference: 0.0,
            lum_raw: 0.0,
            lum_reference: 0.0,
            pixels: 0,
        });
        for i in 0..n {
            let region = &mut acc[if glass[i] { 0 } else { 1 }];
            region.pixels += 1;
            for c in 0..3 {
                let (ta, ra, rb) = (t[i][c] as f64, a[i][c] as f64, b[i][c] as f64);
                let r = 0.5 * (ra + rb);
                let norm = r * r + 0.01;
                region.raw += (ta - r).powi(2) / norm;
                region.reference += 0.25 * (ra - rb).powi(2) / norm;
            }
            let y = |p: [f32; 3]| luminance(p.map(f64::from));
            let (ty, ay, by) = (y(t[i]), y(a[i]), y(b[i]));
            let ry = 0.5 * (ay + by);
            let norm = ry * ry + 0.01;
            region.lum_raw += (ty - ry).powi(2) / norm;
            region.lum_reference += 0.25 * (ay - by).powi(2) / norm;
        }
        let scale = 1.0 / (3 * n) as f64;
        let lum_scale = 1.0 / n as f64;
        let json = |g: &Acc| {
            format!(
                "{{\"raw\":{:.6e},\"reference\":{:.6e},\"corrected\":{:.6e},\"lum_corrected\":{:.6e},\"fraction\":{:.4}}}",
                g.raw * scale,
                g.reference * scale,
                (g.raw - g.reference) * scale,
                (g.lum_raw - g.lum_reference) * lum_scale,
                g.pixels as f64 / n as f64
            )
        };
        let total = Acc {
            raw: acc[0].raw + acc[1].raw,
            reference: acc[0].reference + acc[1].reference,
            lum_raw: acc[0].lum_raw + acc[1].lum_raw,
            lum_reference: acc[0].lum_reference + acc[1].lum_reference,
            pixels: n,
        };
        println!(
            "{{\"test\":\"{}\",\"total\":{},\"glass\":{},\"rest\":{}}}",
            test.display(),
            json(&total),
            json(&acc[0]),
            json(&acc[1])
        );
    }
}
