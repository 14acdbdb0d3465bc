//! What the film writes besides colour, as Blender's pipeline expects it: Film > Transparent
//! and holdouts (alpha is coverage, the world is not seen by camera rays but still lights the
//! scene, a holdout object is a transparent hole) and the render border (a window of the
//! image, each pixel exactly as in the full render).

mod common;

use common::scenes::{diffuse_material, furnace_scene};
use glam::Vec3;
use prism::render::{render_quiet, Crop, RenderSettings};
use prism::scene::{InstanceVisibility, Scene, SceneDesc};

const SIZE: u32 = 32;

fn render(desc: SceneDesc, film_transparent: bool) -> Vec<[f32; 4]> {
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 16,
        max_depth: 4,
        film_transparent,
        ..Default::default()
    };
    let (film, stats) = render_quiet(&scene, &settings);
    assert_eq!(stats.discarded, 0);
    film.to_rgba()
}

/// The unit sphere seen from distance 3 with a 0.8 rad field of view: the centre is on the
/// sphere, the corners on the world.
fn at(px: &[[f32; 4]], x: u32, y: u32) -> [f32; 4] {
    px[(y * SIZE + x) as usize]
}

#[test]
fn transparent_background_has_zero_alpha_and_no_world() {
    let world = Vec3::new(0.4, 0.5, 0.6);
    let scene = || furnace_scene(diffuse_material("grey", Vec3::splat(0.5)), world);
    let opaque = render(scene(), false);
    let clear = render(scene(), true);
    for (x, y) in [(0, 0), (SIZE - 1, 0), (0, SIZE - 1), (SIZE - 1, SIZE - 1)] {
        let (o, c) = (at(&opaque, x, y), at(&clear, x, y));
        assert_eq!(o[3], 1.0, "opaque film: alpha 1 everywhere");
        assert!(
            (o[0] - world.x).abs() < 0.01,
            "opaque film sees the world: {o:?}"
        );
        assert_eq!(
            c,
            [0.0, 0.0, 0.0, 0.0],
            "transparent film: corner ({x}, {y})"
        );
    }
    // The sphere is still lit by the world, identically, and opaque.
    let (o, c) = (at(&opaque, 16, 16), at(&clear, 16, 16));
    assert_eq!(c[3], 1.0);
    assert_eq!(&o[..3], &c[..3], "the world still lights the sphere");
    assert!(c[1] > 0.1);
    // Partial coverage at the silhouette, between 0 and 1, and the mean alpha is the
    // sphere's share of the image (radius 1 at distance 3: angular radius asin(1/3)).
    let mean_alpha: f32 = clear.iter().map(|p| p[3]).sum::<f32>() / clear.len() as f32;
    let half = (1.0f32 / 3.0).asin().tan() / 0.4f32.tan(); // disc radius over image half-height
    let share = std::f32::consts::PI * half * half / 4.0;
    assert!(
        (mean_alpha - share).abs() < 0.02,
        "mean alpha {mean_alpha} vs {share}"
    );
    assert!(
        clear.iter().any(|p| p[3] > 0.05 && p[3] < 0.95),
        "no partial coverage"
    );
}

#[test]
fn holdout_object_is_a_transparent_hole() {
    let world = Vec3::new(0.4, 0.5, 0.6);
    let mut desc = furnace_scene(diffuse_material("grey", Vec3::splat(0.5)), world);
    desc.instance_visibility = vec![InstanceVisibility {
        holdout: true,
        light_visibility: Default::default(),
        ..Default::default()
    }];
    let px = render(desc, false);
    assert_eq!(at(&px, 16, 16), [0.0, 0.0, 0.0, 0.0], "the holdout sphere");
    let corner = at(&px, 0, 0);
    assert_eq!(
        corner[3], 1.0,
        "the world around it stays opaque without Film Transparent"
    );
    assert!((corner[2] - world.z).abs() < 0.01);
}

#[test]
fn crop_window_matches_the_full_render_exactly() {
    let scene = Scene::build(furnace_scene(
        diffuse_material("grey", Vec3::splat(0.5)),
        Vec3::new(0.4, 0.5, 0.6),
    ))
    .expect("scene builds");
    let full_settings = RenderSettings {
        width: 40,
        height: 24,
        spp: 8,
        max_depth: 4,
        ..Default::default()
    };
    let (full, _) = render_quiet(&scene, &full_settings);
    let crop = Crop {
        x: 13,
        y: 5,
        width: 17,
        height: 11,
    };
    let (window, _) = render_quiet(
        &scene,
        &RenderSettings {
            crop: Some(crop),
            ..full_settings
        },
    );
    assert_eq!((window.width, window.height), (17, 11));
    let (a, b) = (full.to_rgba(), window.to_rgba());
    for y in 0..crop.height {
        for x in 0..crop.width {
            let f = a[((y + crop.y) * 40 + x + crop.x) as usize];
            assert_eq!(
                b[(y * crop.width + x) as usize],
                f,
                "pixel ({x}, {y}) of the window"
            );
        }
    }
}
