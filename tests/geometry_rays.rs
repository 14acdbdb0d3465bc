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
        let sp = g.surface_point_at(hit.instance, hit.prim, hit.b1, hit.b2);
        assert_eq!(sp.uv, glam::Vec2::ZERO, "{origin}");
    }
}
