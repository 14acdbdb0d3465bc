//! BVH build and traversal throughput on a dense sphere (closest hit and shadow rays).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Affine3A, Vec3};
use prism::geometry::{Geometry, Instance, Mesh, Ray};
use prism::sampler::Sampler;

fn sphere(segments: u32, rings: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (p, _, t) = prism::geometry::shapes::uv_sphere(segments, rings);
    (p, t)
}

fn geometry(instances: usize) -> Geometry {
    let (p, idx) = sphere(400, 200); // ~160k triangles
    let mesh = Mesh::new(p, None, None, idx, 0);
    let insts = (0..instances)
        .map(|i| {
            Instance::new(
                0,
                Affine3A::from_translation(Vec3::new(2.5 * i as f32, 0.0, 0.0)),
            )
        })
        .collect();
    Geometry::new(vec![mesh], insts)
}

fn rays(n: usize, spread: f32) -> Vec<Ray> {
    let mut s = Sampler::new(1, 2, 3);
    (0..n)
        .map(|_| {
            let o = Vec3::new((s.next_1d() - 0.5) * spread, (s.next_1d() - 0.5) * 2.0, 5.0);
            let target = Vec3::new((s.next_1d() - 0.5) * spread, (s.next_1d() - 0.5) * 2.0, 0.0);
            Ray::new(o, (target - o).normalize())
        })
        .collect()
}

fn bench_bvh(c: &mut Criterion) {
    let mut group = c.benchmark_group("bvh");
    let (p, idx) = sphere(400, 200);
    group.sample_size(10);
    group.bench_function("build_160k_tris", |b| {
        b.iter(|| Mesh::new(p.clone(), None, None, idx.clone(), 0))
    });
    let g = geometry(1);
    let rs = rays(10_000, 3.0);
    group.throughput(Throughput::Elements(rs.len() as u64));
    group.sample_size(20);
    group.bench_function("closest_hit_10k_rays", |b| {
        b.iter(|| {
            rs.iter()
                .filter(|r| g.intersect(r, f32::INFINITY).is_some())
                .count()
        })
    });
    group.bench_function("shadow_10k_rays", |b| {
        b.iter(|| rs.iter().filter(|r| g.occluded(r, 100.0)).count())
    });
    let g4 = geometry(4);
    let rs4 = rays(10_000, 12.0);
    group.bench_function("closest_hit_10k_rays_4_instances", |b| {
        b.iter(|| {
            rs4.iter()
                .filter(|r| g4.intersect(r, f32::INFINITY).is_some())
                .count()
        })
    });
    group.finish();
}

criterion_group!(benches, bench_bvh);
criterion_main!(benches);
