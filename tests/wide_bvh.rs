//! `geometry::wide_bvh`, our parallel BVH2 -> compressed wide BVH collapse, against obvhs'
//! sequential converter (`bvh2_to_cwbvh`), which it must reproduce exactly from the same
//! binary BVH: node by node in depth-first order (origin, exponents, masks, child metadata,
//! quantised child boxes, each node's primitives), then as whole arrays (same memory
//! layout); plus obvhs' validation, traversal results on random rays, and independence of
//! the thread count.

use glam::Vec3A;
use obvhs::{
    bvh2::{reinsertion::ReinsertionOptimizer, Bvh2},
    cwbvh::{bvh2_to_cwbvh::bvh2_to_cwbvh, node::CwBvhNode, CwBvh},
    ploc::PlocBuilder,
    ray::{Ray, RayHit},
    triangle::Triangle,
    Boundable, BvhBuildParams,
};
use prism::geometry::wide_bvh;

/// Deterministic uniform numbers in [0, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    fn point(&mut self, scale: f32) -> Vec3A {
        Vec3A::new(self.next(), self.next(), self.next()) * scale
    }
}

fn tri(v0: Vec3A, v1: Vec3A, v2: Vec3A) -> Triangle {
    Triangle { v0, v1, v2 }
}

fn sphere(segments: u32, rings: u32) -> Vec<Triangle> {
    let (p, _, idx) = prism::geometry::shapes::uv_sphere(segments, rings);
    idx.iter()
        .map(|&[a, b, c]| {
            tri(
                p[a as usize].into(),
                p[b as usize].into(),
                p[c as usize].into(),
            )
        })
        .collect()
}

/// `n` random triangles with corners in the unit cube (long, overlapping slivers).
fn soup(n: usize, seed: u64) -> Vec<Triangle> {
    let mut r = Lcg(seed);
    (0..n)
        .map(|_| tri(r.point(1.0), r.point(1.0), r.point(1.0)))
        .collect()
}

/// `n` triangles of size ~1e-4 scattered in the unit cube.
fn tiny(n: usize, seed: u64) -> Vec<Triangle> {
    let mut r = Lcg(seed);
    (0..n)
        .map(|_| {
            let c = r.point(1.0);
            tri(c, c + r.point(1e-4), c + r.point(1e-4))
        })
        .collect()
}

/// `n` copies of one triangle: every box, centre and cost ties.
fn identical(n: usize) -> Vec<Triangle> {
    let t = tri(
        Vec3A::new(0.1, 0.2, 0.3),
        Vec3A::new(0.9, 0.25, 0.3),
        Vec3A::new(0.4, 0.8, 0.35),
    );
    vec![t; n]
}

/// Degenerate boxes: a few distinct points, each repeated (zero-area boxes, zero costs),
/// and flat triangles in the plane z = 0.5 (zero-thickness boxes).
fn degenerate(n: usize, seed: u64) -> Vec<Triangle> {
    let mut r = Lcg(seed);
    let points: Vec<Vec3A> = (0..7).map(|_| r.point(1.0)).collect();
    (0..n)
        .map(|i| {
            if i % 2 == 0 {
                let p = points[i % points.len()];
                tri(p, p, p)
            } else {
                let flat = |r: &mut Lcg| Vec3A::new(r.next(), r.next(), 0.5);
                tri(flat(&mut r), flat(&mut r), flat(&mut r))
            }
        })
        .collect()
}

/// The binary BVH exactly as `obvhs::cwbvh::builder::build_cwbvh` makes it.
fn bvh2<T: Boundable>(prims: &[T], params: &BvhBuildParams) -> Bvh2 {
    let mut bvh2 = PlocBuilder::with_capacity(prims.len()).build(
        params.ploc_search_distance,
        prims,
        (0..prims.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    bvh2
}

/// A node's fields that do not depend on where things are stored.
fn node_shape(n: &CwBvhNode) -> impl PartialEq + std::fmt::Debug {
    (
        n.p.to_array().map(f32::to_bits),
        n.e,
        n.imask,
        n.child_meta,
        [
            n.child_min_x,
            n.child_max_x,
            n.child_min_y,
            n.child_max_y,
            n.child_min_z,
            n.child_max_z,
        ],
    )
}

/// The primitives of each child slot of a node (empty for internal and absent children).
fn slot_prims(bvh: &CwBvh, n: &CwBvhNode) -> Vec<Vec<u32>> {
    (0..8)
        .map(|slot| {
            let meta = n.child_meta[slot];
            if n.imask & (1 << slot) != 0 || meta == 0 {
                return Vec::new();
            }
            let count = (meta >> 5).count_ones() as usize;
            let first = n.primitive_base_idx as usize + (meta & 0b1_1111) as usize;
            bvh.primitive_indices[first..first + count].to_vec()
        })
        .collect()
}

/// Walks both trees depth-first (internal children in slot order) and asserts every node
/// has the same shape and the same primitives per slot; returns the number of nodes.
fn assert_same_tree(ours: &CwBvh, reference: &CwBvh, case: &str) -> usize {
    assert_eq!(
        ours.nodes.len(),
        reference.nodes.len(),
        "{case}: node count"
    );
    assert_eq!(
        ours.primitive_indices.len(),
        reference.primitive_indices.len(),
        "{case}: primitive count"
    );
    assert_eq!(ours.total_aabb, reference.total_aabb, "{case}: total box");
    let mut stack = vec![(0usize, 0usize, String::from("root"))];
    let mut visited = 0;
    while let Some((a, b, path)) = stack.pop() {
        let (na, nb) = (&ours.nodes[a], &reference.nodes[b]);
        assert_eq!(
            node_shape(na),
            node_shape(nb),
            "{case}: node at {path}\nours {na:?}\nobvhs {nb:?}"
        );
        assert_eq!(
            slot_prims(ours, na),
            slot_prims(reference, nb),
            "{case}: primitives of node at {path}"
        );
        visited += 1;
        let mut k = 0;
        for slot in 0..8 {
            if na.imask & (1 << slot) != 0 {
                stack.push((
                    na.child_base_idx as usize + k,
                    nb.child_base_idx as usize + k,
                    format!("{path}/{slot}"),
                ));
                k += 1;
            }
        }
    }
    assert_eq!(visited, reference.nodes.len(), "{case}: reachable nodes");
    visited
}

/// Wide levels below node `n`, counting `n`'s own.
fn depth(bvh: &CwBvh, n: usize) -> u32 {
    let node = &bvh.nodes[n];
    1 + (0..node.imask.count_ones() as usize)
        .map(|k| depth(bvh, node.child_base_idx as usize + k))
        .max()
        .unwrap_or(0)
}

/// Collapses `prims`' binary BVH both ways and checks structure, layout and validity.
fn check<T: Boundable>(prims: &[T], params: &BvhBuildParams, case: &str) -> (CwBvh, CwBvh) {
    let (ours, reference) = compare(prims, params, case);
    ours.validate(prims, false);
    (ours, reference)
}

/// [`check`] without obvhs' validation, which also bounds the depth (< 32 wide levels): PLOC
/// trees over thousands of coincident boxes are deeper than that.
fn compare<T: Boundable>(prims: &[T], params: &BvhBuildParams, case: &str) -> (CwBvh, CwBvh) {
    let b = bvh2(prims, params);
    let leaf_limit = params.max_prims_per_leaf.clamp(1, 3);
    let reference = bvh2_to_cwbvh(&b, leaf_limit, true, false);
    let ours = wide_bvh::collapse(&b, leaf_limit);
    assert_same_tree(&ours, &reference, case);
    // Same depth-first layout too: the trees are equal as arrays.
    assert!(ours == reference, "{case}: layouts differ");
    (ours, reference)
}

fn presets() -> [(BvhBuildParams, &'static str); 3] {
    [
        (BvhBuildParams::very_fast_build(), "very fast"),
        (BvhBuildParams::medium_build(), "medium"),
        (
            BvhBuildParams::fastest_build(),
            "fastest (1 primitive per leaf)",
        ),
    ]
}

/// The dense sphere of the benchmarks (the parallel paths run on it).
#[test]
fn dense_sphere_matches_obvhs_node_for_node() {
    let tris = sphere(320, 160);
    assert_eq!(tris.len(), 101_760);
    for (params, name) in presets() {
        check(&tris, &params, &format!("sphere, {name}"));
    }
}

#[test]
fn random_soup_matches_obvhs_node_for_node() {
    for (n, seed) in [(20_000, 1), (3_000, 2), (300, 3)] {
        let tris = soup(n, seed);
        for (params, name) in presets() {
            check(&tris, &params, &format!("soup of {n}, {name}"));
        }
    }
}

#[test]
fn tiny_triangles_match_obvhs_node_for_node() {
    for n in [300, 301, 302] {
        let tris = tiny(n, n as u64);
        for (params, name) in presets() {
            check(&tris, &params, &format!("{n} tiny triangles, {name}"));
        }
    }
}

#[test]
fn very_small_inputs_match_obvhs() {
    for (params, _) in presets() {
        let empty = bvh2::<Triangle>(&[], &params);
        assert!(wide_bvh::collapse(&empty, 3) == bvh2_to_cwbvh(&empty, 3, true, false));
        assert!(wide_bvh::build::<Triangle>(&[], params) == CwBvh::default());
    }
    let all = soup(9, 7);
    for n in 1..=9 {
        for (params, name) in presets() {
            let (ours, _) = check(&all[..n], &params, &format!("{n} triangles, {name}"));
            let mut prims = ours.primitive_indices.clone();
            prims.sort_unstable();
            assert_eq!(prims, (0..n as u32).collect::<Vec<_>>());
        }
    }
}

/// All costs and slot-ordering scores tie: the first-minimum rules decide everything.
#[test]
fn coincident_and_degenerate_primitives_match_obvhs() {
    let mut validated = 0;
    let mut check_some = |prims: &[Triangle], params: &BvhBuildParams, case: String| {
        let (ours, _) = compare(prims, params, &case);
        if depth(&ours, 0) < 32 {
            ours.validate(prims, false);
            validated += 1;
        }
    };
    for n in [2, 3, 4, 5, 17, 500, 2_000] {
        for (params, name) in presets() {
            check_some(&identical(n), &params, format!("{n} identical, {name}"));
        }
    }
    for n in [40, 5_000, 20_000] {
        let params = BvhBuildParams::very_fast_build();
        check_some(&degenerate(n, 11), &params, format!("{n} degenerate"));
    }
    assert!(validated >= 15, "{validated} validated");
}

/// Closest hits of random rays through both trees: same distance and primitive.
#[test]
fn closest_hits_agree_with_obvhs() {
    let mut tris = sphere(320, 160);
    tris.extend(soup(5_000, 21));
    let params = BvhBuildParams::very_fast_build();
    let (ours, reference) = check(&tris, &params, "sphere + soup");
    let mut r = Lcg(99);
    // The traversal reports positions in `primitive_indices`.
    let closest = |bvh: &CwBvh, ray: Ray| {
        let mut hit = RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |ray, id| {
            tris[bvh.primitive_indices[id] as usize].intersect(ray)
        });
        let prim =
            (hit.t < f32::INFINITY).then(|| bvh.primitive_indices[hit.primitive_id as usize]);
        (hit.t, prim)
    };
    let mut hits = 0;
    for _ in 0..10_000 {
        let origin = r.point(4.0) - Vec3A::splat(2.0);
        let target = r.point(2.0) - Vec3A::splat(1.0);
        let ray = Ray::new_inf(origin, (target - origin).normalize());
        let a = closest(&ours, ray);
        assert_eq!(a, closest(&reference, ray), "ray {ray:?}");
        hits += (a.0 < f32::INFINITY) as usize;
    }
    assert!(hits > 5_000, "only {hits} rays hit");
}

/// The parallel collapse gives the same tree whatever the thread count (also through
/// `wide_bvh::build`, PLOC and reinsertion included).
#[test]
fn result_does_not_depend_on_thread_count() {
    let tris = sphere(320, 160);
    let soup = soup(30_000, 5);
    let params = BvhBuildParams::very_fast_build();
    let b = bvh2(&tris, &params);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                (
                    wide_bvh::collapse(&b, 3),
                    wide_bvh::build(&soup, BvhBuildParams::medium_build()),
                )
            })
    };
    let (one, soup_one) = run(1);
    for threads in [2, 3] {
        let (many, soup_many) = run(threads);
        assert!(one == many, "sphere, {threads} threads");
        assert!(soup_one == soup_many, "soup, {threads} threads");
    }
    let reference = bvh2_to_cwbvh(&b, 3, true, false);
    assert!(one == reference);
}

/// 40,000 coincident triangles: PLOC chains them into a binary tree 40,000 levels deep,
/// deeper than obvhs' recursive converter survives on a 2 MiB stack. The collapse walks it
/// with explicit stacks (1 and 2 threads, 2 MiB stacks): every primitive once, every node
/// reachable.
#[test]
fn deep_degenerate_tree_needs_no_deep_stack() {
    let tris = identical(40_000);
    let b = bvh2(&tris, &BvhBuildParams::very_fast_build());
    for threads in [1, 2] {
        let bvh = std::thread::Builder::new()
            .stack_size(2 << 20)
            .spawn({
                let b = b.clone();
                move || {
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .stack_size(2 << 20)
                        .build()
                        .unwrap()
                        .install(|| wide_bvh::collapse(&b, 3))
                }
            })
            .unwrap()
            .join()
            .expect("no stack overflow");
        let mut prims = bvh.primitive_indices.clone();
        prims.sort_unstable();
        assert_eq!(prims, (0..40_000).collect::<Vec<u32>>());
        let mut reachable = 1;
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = &bvh.nodes[n];
            for k in 0..node.imask.count_ones() as usize {
                stack.push(node.child_base_idx as usize + k);
                reachable += 1;
            }
        }
        assert_eq!(reachable, bvh.nodes.len());
        assert!(bvh.nodes.len() > 5_000, "{} nodes", bvh.nodes.len());
    }
}
