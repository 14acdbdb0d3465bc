//! The diffusion table against the random walk, radially resolved.
//!
//! A unit-flux pencil beam enters a thick slab (index 1.33, smooth boundary) normally at the
//! origin; `prism::bssrdf::random_walk::walk` follows it inside the slab mesh, Fresnel decides
//! escape or internal reflection at the top face, and escaping weight is tallied by radius.
//! The photon-beam-diffusion profile Sr(r) of the table must give the same radial exitance
//! \int Sr 2 pi r dr per annulus. The walk is exact Monte Carlo transport; the table is a
//! diffusion model, so the tolerance is the diffusion error (see the comments on each bound).

mod common;

use common::scenes::{slab_geometry, slab_walk_exit};
use prism::bssrdf::table::BssrdfTable;
use prism::bssrdf::SeparableBssrdf;
use prism::sampler::Sampler;
use prism::spectrum::SampledSpectrum;
use rayon::prelude::*;

const ETA: f32 = 1.33;
/// Annulus edges in mean free paths (sigma_t' = 1).
const EDGES: [f32; 9] = [0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0];

/// Radial exitance per annulus from `n` random walks (sigma_s, sigma_a per unit length).
fn walk_exitance(sigma_s: f32, sigma_a: f32, n: usize) -> Vec<f64> {
    let geometry = slab_geometry(300.0, 150.0);
    let chunks = 16;
    let per = n / chunks;
    let tallies: Vec<Vec<f64>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut bins = vec![0.0f64; EDGES.len() - 1];
            for k in 0..per {
                let mut sampler = Sampler::new(c as u64, k as u64, 99);
                let exit = slab_walk_exit(&geometry, sigma_a, sigma_s, Some(ETA), 64, &mut sampler);
                if let Some((p, weight)) = exit {
                    let r = (p.x * p.x + p.y * p.y).sqrt();
                    if let Some(b) = EDGES.windows(2).position(|e| r >= e[0] && r < e[1]) {
                        bins[b] += weight as f64;
                    }
                }
            }
            bins
        })
        .collect();
    let total = (per * chunks) as f64;
    (0..EDGES.len() - 1)
        .map(|b| tallies.iter().map(|t| t[b]).sum::<f64>() / total)
        .collect()
}

/// \int Sr 2 pi r dr over each annulus (midpoint rule on a fine grid).
fn table_exitance(sigma_s: f32, sigma_a: f32) -> Vec<f64> {
    let table = BssrdfTable::new(ETA);
    let b = SeparableBssrdf::new(
        &table,
        SampledSpectrum::splat(sigma_a),
        SampledSpectrum::splat(sigma_s),
        1,
    );
    EDGES
        .windows(2)
        .map(|e| {
            let n = 4000;
            let h = (e[1] - e[0]) as f64 / n as f64;
            (0..n)
                .map(|i| {
                    let r = e[0] as f64 + (i as f64 + 0.5) * h;
                    2.0 * std::f64::consts::PI * r * b.sr(r as f32)[0] as f64 * h
                })
                .sum()
        })
        .collect()
}

fn compare(
    sigma_s: f32,
    sigma_a: f32,
    n: usize,
    total_tol: f64,
    annuli: std::ops::Range<usize>,
    annulus_tol: f64,
) {
    let w = walk_exitance(sigma_s, sigma_a, n);
    let t = table_exitance(sigma_s, sigma_a);
    let (wt, tt) = (w.iter().sum::<f64>(), t.iter().sum::<f64>());
    eprintln!(
        "albedo {}: total walk {wt:.4} table {tt:.4}",
        sigma_s / (sigma_s + sigma_a)
    );
    for b in 0..w.len() {
        eprintln!(
            "  r in [{}, {}) mfp: walk {:.5} table {:.5} ratio {:.3}",
            EDGES[b],
            EDGES[b + 1],
            w[b],
            t[b],
            t[b] / w[b]
        );
    }
    assert!(
        (tt / wt - 1.0).abs() < total_tol,
        "total reflectance: table {tt} vs walk {wt}"
    );
    for b in annuli {
        assert!(
            (t[b] / w[b] - 1.0).abs() < annulus_tol,
            "annulus [{}, {}) mfp: table {} vs walk {}",
            EDGES[b],
            EDGES[b + 1],
            t[b],
            w[b]
        );
    }
}

// Tolerances. The walk is unbiased transport (its noise at 256k walks is < 1% per annulus
// here); the table is photon beam diffusion, whose error against transport Habel et al. 2013
// (figs. 6-7) and d'Eon 2014 show to be a few percent in total reflectance, largest a few mfp
// from the beam, and growing in the far tail as the albedo drops (diffusion's decay rate
// sigma_tr differs from the exact transport asymptote away from albedo 1). Measured here
// (256k walks): albedo 0.99 total +4.3%, annuli 1-16 mfp +1.7..+6.2%; albedo 0.9 total +5.0%,
// annuli 1-8 mfp +5..+13%, 8-16 mfp +22%. The bounds are those errors with ~50% margin, and
// only cover the range where diffusion is meant to hold (1-16 mfp at albedo 0.99, 1-8 mfp at
// 0.9): a wrong Fresnel moment, boundary or albedo changes these by 10-50%.

#[test]
fn table_matches_random_walk_high_albedo() {
    compare(0.99, 0.01, 256_000, 0.065, 3..7, 0.11);
}

#[test]
fn table_matches_random_walk_medium_albedo() {
    compare(0.9, 0.1, 256_000, 0.075, 3..6, 0.2);
}
