//! Throughput of BSDF sampling and evaluation (one `sample` + one `eval` + one `pdf` per
//! iteration, as a path vertex with light sampling needs) for each surface model.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Vec2, Vec3};
use prism::bsdf::{Bsdf, DielectricBsdf, DiffuseBsdf, MetallicRoughnessBsdf};
use prism::spectrum::SampledSpectrum;
use std::hint::black_box;

/// A fixed table of (wo, uc, u, wi), pseudo-random directions (below the surface too for
/// transmissive models).
fn inputs(n: usize, allow_below: bool) -> Vec<(Vec3, f32, Vec2, Vec3)> {
    let mut state = 0x853c_49e6_748f_ea9bu64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    let mut dir = |below: bool| {
        let z = next().max(0.02);
        let phi = 2.0 * std::f32::consts::PI * next();
        let r = (1.0 - z * z).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), if below { -z } else { z })
    };
    (0..n)
        .map(|i| {
            let wo = dir(allow_below && i % 2 == 1);
            let wi = dir(allow_below && i % 3 == 0);
            // Additive recurrences (golden-ratio family) for the sampling inputs.
            let k = i as f32 + 0.5;
            let uc = (k * 0.618_034).fract();
            let u = Vec2::new((k * 0.754_877_7).fract(), (k * 0.569_840_3).fract());
            (wo, uc, u, wi)
        })
        .collect()
}

fn bench_bsdf(c: &mut Criterion) {
    let color = SampledSpectrum([0.8, 0.6, 0.4, 0.7]);
    let cases: Vec<(&str, Bsdf, bool)> = vec![
        (
            "diffuse",
            Bsdf::Diffuse(DiffuseBsdf { reflectance: color }),
            false,
        ),
        (
            "metallic_roughness",
            Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
                base_color: color,
                metallic: 0.5,
                alpha: 0.25,
                specular: 1.0,
                specular_color: SampledSpectrum::ONE,
                ior: 1.5,
                energy_compensation: true,
                principled_v1: false,
                coat: prism::bsdf::Coat::NONE,
                sheen: prism::bsdf::Sheen::NONE,
                iridescence: None,
                view: None,
            }),
            false,
        ),
        (
            "dielectric_smooth",
            Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum::splat(1.5),
                alpha: 0.0,
                transmission_tint: SampledSpectrum::ONE,
                iridescence: None,
                refraction_only: false,
                energy_compensation: true,
            }),
            true,
        ),
        (
            "dielectric_rough",
            Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum::splat(1.5),
                alpha: 0.09,
                transmission_tint: SampledSpectrum::ONE,
                iridescence: None,
                refraction_only: false,
                energy_compensation: true,
            }),
            true,
        ),
        (
            "dielectric_rough_dispersive",
            Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum([1.5, 1.51, 1.52, 1.53]),
                alpha: 0.09,
                transmission_tint: SampledSpectrum::ONE,
                iridescence: None,
                refraction_only: false,
                energy_compensation: true,
            }),
            true,
        ),
    ];
    let mut group = c.benchmark_group("bsdf_sample_eval_pdf");
    const N: usize = 1024;
    group.throughput(Throughput::Elements(N as u64));
    for (name, bsdf, below) in cases {
        let data = inputs(N, below);
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for &(wo, uc, u, wi) in &data {
                    let bsdf = black_box(bsdf);
                    if let Some(s) = bsdf.sample(wo, uc, u) {
                        acc += s.f[0] * s.pdf;
                    }
                    acc += bsdf.eval(wo, wi)[0] + bsdf.pdf(wo, wi);
                }
                black_box(acc)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_bsdf);
criterion_main!(benches);
