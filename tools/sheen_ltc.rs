//! `prism-sheen-ltc`: simulates the fibre layer of `prism::bsdf::fibre_sheen` at every node of
//! its table and fits the linearly transformed cosine there, then writes the table.
//!
//! ```text
//! cargo run --release --bin prism-sheen-ltc -- src/bsdf/data/sheen_ltc.bin [--walks 1048576]
//! ```
//!
//! Per node (view cosine x roughness, 32 x 32): `walks` random walks through the layer give
//! its albedo R (the fraction leaving the top) and a histogram of the exit directions, which
//! estimates `f cos = R D` per bin. The LTC's `a` and `b` minimise the squared difference
//! between `R D_ltc` (at the bin centres) and that estimate, weighted by the bins' solid
//! angles (an L2 distance between the two distributions), by Nelder-Mead from the fit of the
//! next rougher node (rows are fitted from roughness 1 down, as the lobes change smoothly
//! that way; a node whose albedo is below 1e-5 keeps the rougher node's shape, as too few
//! walks reflect to fit it). The default takes a few minutes on two cores.

use prism::bsdf::fibre_sheen::{
    bin_centre, bin_solid_angle, ltc_density, node_value, simulate_layer, FibreLobe, FibreTable,
    LayerStats, N_COS, N_PHI, N_ROUGHNESS, N_THETA,
};
use rayon::prelude::*;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut out = None;
    let mut walks = 1u64 << 20;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--walks" => {
                walks = it
                    .next()
                    .and_then(|s| s.parse().ok())
                    .filter(|&n| n > 0)
                    .unwrap_or_else(|| usage("--walks needs a positive integer"))
            }
            s if !s.starts_with('-') && out.is_none() => out = Some(s.to_string()),
            s => usage(&format!("unexpected argument {s}")),
        }
    }
    let out = out.unwrap_or_else(|| usage("missing output path"));
    let t0 = Instant::now();
    let stats: Vec<LayerStats> = (0..N_ROUGHNESS * N_COS)
        .into_par_iter()
        .map(|k| {
            let (j, i) = (k / N_COS, k % N_COS);
            simulate_layer(
                node_value(i, N_COS),
                node_value(j, N_ROUGHNESS),
                walks,
                k as u64,
            )
        })
        .collect();
    let truncated: u64 = stats.iter().map(|s| s.truncated).sum();
    println!(
        "simulated {} walks per node in {:.1} s ({} truncated after the scattering limit)",
        walks,
        t0.elapsed().as_secs_f32(),
        truncated
    );
    let mut nodes = vec![FibreLobe::default(); N_ROUGHNESS * N_COS];
    let rows: Vec<Vec<FibreLobe>> = (0..N_COS)
        .into_par_iter()
        .map(|i| {
            let mut row = vec![FibreLobe::default(); N_ROUGHNESS];
            let mut start = [1.0f64, 0.0];
            for j in (0..N_ROUGHNESS).rev() {
                let st = &stats[j * N_COS + i];
                let albedo = st.albedo();
                if albedo >= 1e-5 {
                    start = fit(st, albedo, start);
                }
                row[j] = FibreLobe {
                    a: start[0] as f32,
                    b: start[1] as f32,
                    albedo: albedo as f32,
                };
            }
            row
        })
        .collect();
    for (i, row) in rows.iter().enumerate() {
        for (j, lobe) in row.iter().enumerate() {
            nodes[j * N_COS + i] = *lobe;
        }
    }
    let table = FibreTable { nodes };
    std::fs::write(&out, table.to_bytes()).unwrap_or_else(|e| {
        eprintln!("prism-sheen-ltc: cannot write {out}: {e}");
        std::process::exit(1)
    });
    println!("wrote {out} in {:.1} s", t0.elapsed().as_secs_f32());
    println!("roughness: albedo at mu = 0.15 / 0.35 / 0.55 / 0.75 / 0.95");
    for r in [0.2f32, 0.3, 0.5, 0.7, 1.0] {
        let e: Vec<String> = [0.15f32, 0.35, 0.55, 0.75, 0.95]
            .iter()
            .map(|&mu| format!("{:.3}", table.lookup(r, mu).albedo))
            .collect();
        println!("{r:.1}: {}", e.join(" / "));
    }
}

/// The fit's loss: the solid-angle-weighted squared difference between `R D_ltc` and the
/// histogram's estimate of `R D`.
fn loss(st: &LayerStats, albedo: f64, a: f64, b: f64) -> f64 {
    if !(a > 1e-3) {
        return f64::INFINITY;
    }
    let mut sum = 0.0;
    for t in 0..N_THETA {
        let omega = bin_solid_angle(t);
        for p in 0..N_PHI {
            let model = albedo * f64::from(ltc_density(a as f32, b as f32, bin_centre(t, p)));
            let d = model - st.density(t, p);
            sum += d * d * omega;
        }
    }
    sum
}

/// Nelder-Mead over (a, b) from `start`.
fn fit(st: &LayerStats, albedo: f64, start: [f64; 2]) -> [f64; 2] {
    let f = |x: [f64; 2]| loss(st, albedo, x[0], x[1]);
    let mut simplex = [
        start,
        [start[0] + 0.1, start[1]],
        [start[0], start[1] + 0.1],
    ];
    let mut values = simplex.map(f);
    for _ in 0..2000 {
        let mut order = [0usize, 1, 2];
        order.sort_by(|&x, &y| values[x].total_cmp(&values[y]));
        let [best, mid, worst] = order;
        if (values[worst] - values[best]).abs() <= 1e-12 * values[best].abs().max(1e-30) {
            break;
        }
        let centroid = [
            0.5 * (simplex[best][0] + simplex[mid][0]),
            0.5 * (simplex[best][1] + simplex[mid][1]),
        ];
        let towards = |t: f64| {
            [
                centroid[0] + t * (simplex[worst][0] - centroid[0]),
                centroid[1] + t * (simplex[worst][1] - centroid[1]),
            ]
        };
        let reflected = towards(-1.0);
        let fr = f(reflected);
        if fr < values[best] {
            let expanded = towards(-2.0);
            let fe = f(expanded);
            if fe < fr {
                (simplex[worst], values[worst]) = (expanded, fe);
            } else {
                (simplex[worst], values[worst]) = (reflected, fr);
            }
        } else if fr < values[mid] {
            (simplex[worst], values[worst]) = (reflected, fr);
        } else {
            let contracted = if fr < values[worst] {
                towards(-0.5)
            } else {
                towards(0.5)
            };
            let fc = f(contracted);
            if fc < values[worst].min(fr) {
                (simplex[worst], values[worst]) = (contracted, fc);
            } else {
                // Shrink towards the best vertex.
                for k in [mid, worst] {
                    simplex[k] = [
                        0.5 * (simplex[k][0] + simplex[best][0]),
                        0.5 * (simplex[k][1] + simplex[best][1]),
                    ];
                    values[k] = f(simplex[k]);
                }
            }
        }
    }
    let best = (0..3)
        .min_by(|&x, &y| values[x].total_cmp(&values[y]))
        .unwrap();
    simplex[best]
}

fn usage(msg: &str) -> ! {
    eprintln!("prism-sheen-ltc: {msg}\nusage: prism-sheen-ltc OUT.bin [--walks N]");
    std::process::exit(2)
}
