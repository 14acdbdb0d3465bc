//! `prism-ggx-energy`: computes the GGX energy-compensation tables of `prism::bsdf::energy`
//! (directional and average albedos of the reflection lobe, albedo of rough dielectric
//! interfaces from both sides) and writes them.
//!
//! ```text
//! cargo run --release --bin prism-ggx-energy -- src/bsdf/data/ggx_energy.bin [--samples 192]
//! ```
//!
//! Every entry integrates `samples`^2 stratified visible normals with the renderer's own GGX
//! (`prism::bsdf::energy::reflection_albedo`, `dielectric_albedo`); the default takes about
//! a minute and a half on two cores. The program then prints how far the table's interpolation lies from
//! a direct evaluation at points between the nodes.

use prism::bsdf::energy::{
    dielectric_albedo, ggx_dielectric_albedo, ggx_reflection_albedo, reflection_albedo,
    EnergyTables,
};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut out = None;
    let mut samples = 192usize;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--samples" => {
                samples = it
                    .next()
                    .and_then(|s| s.parse().ok())
                    .filter(|&n| n > 0)
                    .unwrap_or_else(|| usage("--samples needs a positive integer"))
            }
            s if !s.starts_with('-') && out.is_none() => out = Some(s.to_string()),
            s => usage(&format!("unexpected argument {s}")),
        }
    }
    let out = out.unwrap_or_else(|| usage("missing output path"));
    let t0 = Instant::now();
    let tables = EnergyTables::compute(samples);
    std::fs::write(&out, tables.to_bytes()).unwrap_or_else(|e| {
        eprintln!("prism-ggx-energy: cannot write {out}: {e}");
        std::process::exit(1)
    });
    println!("wrote {out} in {:.1} s", t0.elapsed().as_secs_f32());
    // Interpolation error between nodes (only meaningful once the written table is the
    // embedded one, i.e. after a rebuild).
    let (mut worst_r, mut worst_d) = (0.0f32, 0.0f32);
    for &(alpha, mu) in &[
        (0.05f32, 0.37f32),
        (0.2, 0.11),
        (0.45, 0.63),
        (0.8, 0.05),
        (1.0, 0.9),
    ] {
        let direct = reflection_albedo(alpha, mu, samples).0;
        worst_r = worst_r.max((direct - ggx_reflection_albedo(alpha, mu).e).abs());
        for &eta in &[1.05f32, 1.33, 1.5, 2.4, 1.0 / 1.5] {
            let direct = dielectric_albedo(alpha, mu, eta, samples);
            worst_d = worst_d.max((direct - ggx_dielectric_albedo(alpha, mu, eta)).abs());
        }
    }
    println!(
        "embedded table vs direct (off-node): reflection {worst_r:.4}, dielectric {worst_d:.4}"
    );
}

fn usage(msg: &str) -> ! {
    eprintln!("prism-ggx-energy: {msg}\nusage: prism-ggx-energy OUT.bin [--samples N]");
    std::process::exit(2)
}
