//! BVH build and traversal throughput on a dense sphere (closest hit and shadow rays), and
//! the binary -> wide BVH collapse alone (obvhs' and `geometry::wide_bvh`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Affine3A, Vec3, Vec3A};
use obvhs::{
    aabb::Aabb, bvh2::reinsertion::ReinsertionOptimizer, cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh,
    ploc::PlocBuilder, BvhBuildParams,
};
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
    // The binary -> wide BVH step alone, on the same binary BVH: obvhs' converter and ours
    // (`geometry::wide_bvh`, which builds the same tree).
    let boxes: Vec<Aabb> = idx
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| Vec3A::from(p[i as usize]));
            Aabb::new(a.min(b).min(c), a.max(b).max(c))
        })
        .collect();
    let params = BvhBuildParams::very_fast_build();
    let mut bvh2 = PlocBuilder::with_capacity(boxes.len()).build(
        params.ploc_search_distance,
        &boxes,
        (0..boxes.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    group.bench_function("collapse_160k_tris_obvhs", |b| {
        b.iter(|| bvh2_to_cwbvh(&bvh2, 3, true, false))
    });
    group.bench_function("collapse_160k_tris_wide_bvh", |b| {
        b.iter(|| prism::geometry::wide_bvh::collapse(&bvh2, 3))
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
