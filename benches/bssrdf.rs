//! Subsurface scattering cost: the BSSRDF table build, probe sampling on a flat slab, and
//! time per camera sample of the SSS Cornell box (table and random walk) against the same
//! scene with diffuse materials (scenes/sss/cornell_{sss,walk,diffuse}.gltf).
//! Per-sample time = reported time / (64 * 64 pixels * 1 spp).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use prism::bssrdf::table::BssrdfTable;
use prism::bssrdf::SeparableBssrdf;
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, Scene};
use prism::spectrum::SampledSpectrum;
use std::path::Path;

fn scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/sss/{name}.gltf"));
    Scene::build(load_scene(&path, None, None).expect("scene loads")).expect("scene builds")
}

fn bench_bssrdf(c: &mut Criterion) {
    let mut group = c.benchmark_group("bssrdf");
    group.sample_size(10);
    group.bench_function("table_build", |b| b.iter(|| BssrdfTable::new(1.33)));
    let table = BssrdfTable::new(1.33);
    let bssrdf = SeparableBssrdf::new(
        &table,
        SampledSpectrum([0.01, 0.02, 0.04, 0.03]),
        SampledSpectrum::splat(1.0),
        4,
    );
    group.throughput(Throughput::Elements(10_000));
    group.sample_size(20);
    group.bench_function("sample_radius_10k", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for i in 0..10_000 {
                let u = (i as f32 + 0.5) / 10_000.0;
                acc += bssrdf.sample_sr(i % 4, u).unwrap_or(0.0);
                acc += bssrdf.pdf_sp(
                    Vec3::ZERO,
                    &prism::math::Frame::from_normal(Vec3::Z),
                    Vec3::new(u, 0.0, 0.0),
                    Vec3::Z,
                );
            }
            acc
        })
    });
    let settings = RenderSettings {
        width: 64,
        height: 64,
        spp: 1,
        max_depth: 16,
        seed: 0,
        ..Default::default()
    };
    group.throughput(Throughput::Elements(64 * 64));
    group.sample_size(10);
    for name in ["cornell_diffuse", "cornell_sss", "cornell_walk"] {
        let s = scene(name);
        group.bench_function(format!("render_{name}_64x64_1spp"), |b| {
            b.iter(|| render_quiet(&s, &settings).1)
        });
    }
    group.finish();
}

criterion_group!(benches, bench_bssrdf);
criterion_main!(benches);
