//! Ray traversal edge cases of the BVH wrapper.

use glam::{Affine3A, Vec3};
use prism::geometry::{Geometry, Instance, Mesh, Ray};

/// A 2x2 quad in the plane y = 0, centred at the origin, as one instance (optionally moved).
fn plane(transform: Affine3A) -> Geometry {
    let positions = vec![
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
    ];
    let mesh = Mesh::new(positions, None, None, vec![[0, 2, 1], [0, 3, 2]], 0);
    Geometry::new(vec![mesh], vec![Instance::new(0, transform)])
}

/// Axis-aligned directions with negative-zero components (what an orthographic camera looking
/// straight down, or a mirror reflection off an axis-aligned face, produces) must hit. obvhs
/// turns -0.0 into a -inf inverse direction; the wrapper normalises it.
#[test]
fn negative_zero_direction_components_hit() {
    for transform in [
        Affine3A::IDENTITY,
        Affine3A::from_translation(Vec3::new(0.3, -0.5, 0.2)),
        Affine3A::from_scale(Vec3::new(2.0, 1.0, 2.0)),
    ] {
        let g = plane(transform);
        for dir in [
            Vec3::new(-0.0, -1.0, -0.0),
            Vec3::new(0.0, -1.0, -0.0),
            Vec3::new(-0.0, -1.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
        ] {
            for origin in [Vec3::new(0.1, 3.0, 0.2), Vec3::new(-0.4, 3.0, -0.7)] {
                let ray = Ray::new(origin, dir);
                let hit = g.intersect(&ray, f32::INFINITY);
                assert!(hit.is_some(), "{origin} {dir:?} {transform:?}: missed");
                assert!(
                    g.occluded(&ray, f32::INFINITY),
                    "{origin} {dir:?}: not occluded"
                );
            }
        }
    }
}

/// A mesh without UVs reads texture coordinate (0, 0) everywhere (Cycles' behaviour for a
/// missing UV map), not its barycentrics.
#[test]
fn meshes_without_uvs_have_zero_texture_coordinates() {
    let g = plane(Affine3A::IDENTITY);
    for origin in [Vec3::new(0.3, 2.0, 0.6), Vec3::new(-0.8, 2.0, 0.1)] {
        let hit = g
            .intersect(&Ray::new(origin, Vec3::NEG_Y), f32::INFINITY)
            .expect("hits the plane");
        let sp = g.surface_point_at(hit.instance, hit.prim, hit.b1, hit.b2, hit.time);
        assert_eq!(sp.uv, glam::Vec2::ZERO, "{origin}");
    }
}

/// Instances whose mesh no other instance uses are traced in one flattened world-space BVH,
/// the shared ones through the two-level BVH (`Geometry::new`). Both must report what a
/// brute-force test of every triangle of every instance in world space finds: the same
/// instance and mesh triangle, the same distance and barycentrics, and shadow rays that ignore
/// instances which cast no shadows, whichever level they are in. The scene mixes single-use
/// meshes (one mirrored and non-uniformly scaled, one not casting shadows) with a mesh placed
/// twice.
fn mixed_instances() -> (Vec<Mesh>, Vec<Instance>) {
    use glam::Quat;
    use prism::geometry::shapes::uv_sphere;
    let sphere = |segments, rings| {
        let (p, n, t) = uv_sphere(segments, rings);
        Mesh::new(p, Some(n), None, t, 0)
    };
    let meshes = vec![sphere(12, 6), sphere(16, 8), sphere(9, 5)];
    let at = |s: Vec3, r: f32, t: Vec3| {
        Affine3A::from_scale_rotation_translation(s, Quat::from_rotation_y(r), t)
    };
    let instances = vec![
        Instance::new(0, at(Vec3::splat(1.0), 0.3, Vec3::new(-2.0, 0.0, 0.0))),
        Instance::new(1, at(Vec3::splat(0.8), 0.0, Vec3::new(0.5, 0.2, 0.0))),
        Instance::new(1, at(Vec3::splat(0.6), 1.0, Vec3::new(1.6, -0.3, 0.5))),
        Instance::new(
            2,
            at(Vec3::new(-1.2, 0.7, 1.0), 0.7, Vec3::new(0.0, 1.5, -0.4)),
        ),
        Instance::new(0, at(Vec3::splat(0.5), 0.0, Vec3::new(0.0, -1.5, 0.3)))
            .with_visibility(false, true),
    ];
    // Mesh 0 is used twice above; make the last instance single-use with its own mesh copy so
    // that a non-shadow-casting instance sits in the flattened level as well.
    let mut meshes = meshes;
    meshes.push(sphere(12, 6));
    let mut instances = instances;
    instances[4].mesh = 3;
    instances.push(Instance::new(
        1,
        at(Vec3::splat(0.3), 0.0, Vec3::new(-1.0, 1.0, 1.0)),
    ));
    (meshes, instances)
}

#[test]
fn flattened_and_instanced_levels_agree_with_brute_force() {
    let (meshes, instances) = mixed_instances();
    agrees_with_brute_force(&Geometry::new(meshes, instances));
}

/// The viewport's layout (every instance under the top level), and moving instances in either
/// layout (`Geometry::set_transforms`: a top-level rebuild, plus the flattened level when one of
/// its instances moves), traces what brute force finds at the new places.
#[test]
fn two_level_layout_and_moved_instances_agree_with_brute_force() {
    use prism::geometry::BvhLayout;
    let moves = [
        // Single-use (flattened in the default layout), mirrored and scaled.
        (
            3u32,
            Affine3A::from_scale_rotation_translation(
                Vec3::new(1.1, -0.6, 0.9),
                glam::Quat::from_rotation_x(0.4),
                Vec3::new(-0.5, 0.8, 0.2),
            ),
        ),
        // Shared mesh (top level in both layouts).
        (2u32, Affine3A::from_translation(Vec3::new(-1.2, -0.9, 0.4))),
    ];
    for layout in [BvhLayout::TwoLevel, BvhLayout::Flattened] {
        let (meshes, instances) = mixed_instances();
        let mut geometry = Geometry::with_layout(meshes, instances, layout);
        agrees_with_brute_force(&geometry);
        geometry.set_transforms(&moves);
        assert_eq!(geometry.instances[2].placement.object_to_world, moves[1].1);
        agrees_with_brute_force(&geometry);
    }
}

fn agrees_with_brute_force(geometry: &Geometry) {
    use prism::geometry::intersect_triangle;
    let brute = |origin: Vec3, dir: Vec3, t_max: f32, shadow: bool| {
        let mut best: Option<(f32, u32, u32, f32, f32)> = None;
        for (i, inst) in geometry.instances.iter().enumerate() {
            if shadow && !inst.casts_shadows {
                continue;
            }
            let mesh = &geometry.meshes[inst.mesh as usize];
            for p in 0..mesh.triangle_count() {
                let [a, b, c] = mesh
                    .vertices(p)
                    .map(|v| inst.placement.object_to_world.transform_point3(v));
                let limit = best.map_or(t_max, |h| h.0);
                if let Some((t, b1, b2)) = intersect_triangle(origin, dir, a, b - a, c - a, limit) {
                    best = Some((t, i as u32, p as u32, b1, b2));
                }
            }
        }
        best
    };
    // Every intersection below t_max, sorted by distance (what `Geometry::for_each_hit` finds,
    // in its own order).
    let brute_all = |origin: Vec3, dir: Vec3, t_max: f32| {
        let mut all = Vec::new();
        for (i, inst) in geometry.instances.iter().enumerate() {
            let mesh = &geometry.meshes[inst.mesh as usize];
            for p in 0..mesh.triangle_count() {
                let [a, b, c] = mesh
                    .vertices(p)
                    .map(|v| inst.placement.object_to_world.transform_point3(v));
                if let Some((t, ..)) = intersect_triangle(origin, dir, a, b - a, c - a, t_max) {
                    all.push((t, i as u32, p as u32));
                }
            }
        }
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        all
    };
    let mut rng = prism::sampler::Pcg32::new(7, 0, 0);
    let mut rnd = || rng.next_1d();
    let (mut hits, mut near_ties, mut passed_through) = (0, 0, 0);
    let (mut multi_hits, mut edge_mismatches) = (0, 0);
    for _ in 0..4000 {
        let origin = Vec3::new(rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0, 5.0);
        let target = Vec3::new(rnd() * 5.0 - 2.5, rnd() * 5.0 - 2.5, rnd() - 0.5);
        let dir = target - origin;
        let ray = Ray::new(origin, dir);
        let got = geometry.intersect(&ray, f32::INFINITY);
        let want = brute(origin, dir, f32::INFINITY, false);
        match (got, want) {
            (None, None) => {}
            (Some(h), Some((t, inst, prim, b1, b2))) => {
                hits += 1;
                assert!((h.t - t).abs() <= 1e-4 * t, "t {} vs {t}", h.t);
                if (h.instance, h.prim) == (inst, prim) {
                    assert!((h.b1 - b1).abs() < 1e-3 && (h.b2 - b2).abs() < 1e-3);
                } else {
                    // Two triangles at the same distance (a shared edge): either is right.
                    near_ties += 1;
                }
            }
            (g, w) => panic!("origin {origin} dir {dir}: {g:?} vs brute force {w:?}"),
        }
        let t_max = 0.6 + 0.6 * rnd();
        let mut all = Vec::new();
        geometry.for_each_hit(&ray, t_max, |h| all.push((h.t, h.instance, h.prim)));
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        let want_all = brute_all(origin, dir, t_max);
        multi_hits += (want_all.len() > 1) as u32;
        let same = all.len() == want_all.len()
            && all.iter().zip(&want_all).all(|(g, w)| {
                (g.0 - w.0).abs() <= 1e-4 * w.0 && (g.1 == w.1 && g.2 == w.2 || g.0 == w.0)
            });
        if !same {
            // A ray through a shared edge may meet one, both or neither of its triangles,
            // differently in world and object space: allowed, rarely.
            assert!(
                all.len().abs_diff(want_all.len()) <= 1,
                "all hits from {origin} along {dir} to t {t_max}: {all:?} vs {want_all:?}"
            );
            edge_mismatches += 1;
        }
        let blocked = brute(origin, dir, t_max, true).is_some();
        assert_eq!(
            geometry.occluded(&ray, t_max),
            blocked,
            "shadow ray from {origin} along {dir} to t {t_max}"
        );
        if !blocked && brute(origin, dir, t_max, false).is_some() {
            passed_through += 1;
        }
    }
    assert!(
        hits > 1000 && near_ties * 100 < hits,
        "{hits} hits, {near_ties} ties"
    );
    assert!(
        passed_through > 20,
        "{passed_through} shadow rays met the non-casting instance"
    );
    assert!(
        multi_hits > 200 && edge_mismatches * 100 < multi_hits,
        "{multi_hits} rays through several surfaces, {edge_mismatches} differing at an edge"
    );
}

/// `Geometry::misses_bounds` (the camera rays' test before a traversal) never claims a miss
/// for a ray that hits, including rays that graze the plane's edges and rays along its plane
/// (a flat box), and does find rays that pass beside the geometry.
#[test]
fn a_bounds_miss_is_never_a_hit() {
    let mut rng = prism::sampler::Pcg32::new(11, 0, 0);
    let mut rnd = || rng.next_1d();
    for transform in [
        Affine3A::IDENTITY,
        Affine3A::from_translation(Vec3::new(0.3, -0.5, 0.2)),
        Affine3A::from_rotation_x(0.7),
    ] {
        let g = plane(transform);
        let (mut hits, mut culled) = (0, 0);
        for i in 0..20_000 {
            let origin = Vec3::new(rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0, rnd() * 8.0 - 4.0);
            // Aim at points on, just inside and just outside the quad's edges, and in its plane.
            let (s, t) = (
                rnd() * 2.2 - 1.1,
                if i % 2 == 0 { 1.0 } else { rnd() * 2.0 - 1.0 },
            );
            let local = if i % 3 == 0 {
                Vec3::new(s, 0.0, t)
            } else {
                Vec3::new(t, 0.0, s)
            };
            let target = transform.transform_point3(local);
            let origin = if i % 7 == 0 {
                transform.transform_point3(Vec3::new(origin.x, 0.0, origin.z))
            } else {
                origin
            };
            let ray = Ray::new(origin, (target - origin).normalize());
            let hit = g.intersect(&ray, f32::INFINITY);
            if g.misses_bounds(&ray) {
                culled += 1;
                assert!(hit.is_none(), "{ray:?}: culled but hits {hit:?}");
            }
            hits += usize::from(hit.is_some());
        }
        assert!(hits > 5_000 && culled > 500, "{hits} hits, {culled} culled");
    }
    assert!(Geometry::new(Vec::new(), Vec::new()).misses_bounds(&Ray::new(Vec3::ZERO, Vec3::X)));
}
