//! Shadow rays of infinite length (directional and world lights) are blocked by instanced
//! geometry: a Lambertian plane under a large occluder, lit by a directional light from straight
//! above, is black. (Regression: the instance-level occlusion test returned 0.5 * t_max, which is
//! not < t_max when t_max is infinite, so sun shadows were missing; found by the Blender add-on's
//! sun parity check against Cycles.)

mod common;

use common::scenes::{camera, diffuse_material};
use glam::{Mat4, Vec3};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{
    InstanceDesc, InstanceVisibility, MeshDesc, PunctualKind, PunctualLightDesc, Scene, SceneDesc,
};

fn quad(name: &str, half: f32) -> MeshDesc {
    MeshDesc {
        name: name.into(),
        positions: vec![
            Vec3::new(-half, 0.0, -half),
            Vec3::new(half, 0.0, -half),
            Vec3::new(half, 0.0, half),
            Vec3::new(-half, 0.0, half),
        ],
        normals: Some(vec![Vec3::Y; 4]),
        uvs: None,
        tangents: None,
        indices: vec![0, 2, 1, 0, 3, 2],
        material: Some(0),
        ..Default::default()
    }
}

/// Where an extra quad goes and how it is seen.
#[derive(Clone, Copy)]
enum Occluder {
    None,
    /// Above the camera (y = 5): only shadow rays can meet it.
    Above(InstanceVisibility),
    /// Between the camera (y = 3) and the plane, at y = 1.5: camera rays meet it first.
    InFront(InstanceVisibility),
}

fn mean_rgb(with_occluder: bool) -> Vec3 {
    render_mean(if with_occluder {
        Occluder::Above(InstanceVisibility::default())
    } else {
        Occluder::None
    })
}

fn render_mean(occluder: Occluder) -> Vec3 {
    let mut cam = camera(0.0, 0.05);
    cam.camera_to_world = Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let mut instances = vec![InstanceDesc {
        mesh: 0,
        object_to_world: Mat4::IDENTITY,
        name: "plane".into(),
    }];
    let mut instance_visibility = Vec::new();
    if let Occluder::Above(vis) | Occluder::InFront(vis) = occluder {
        let y = if matches!(occluder, Occluder::Above(_)) {
            5.0
        } else {
            1.5
        };
        instances.push(InstanceDesc {
            mesh: 1,
            object_to_world: Mat4::from_translation(Vec3::new(0.0, y, 0.0)),
            name: "occluder".into(),
        });
        instance_visibility = vec![InstanceVisibility::default(), vis];
    }
    let desc = SceneDesc {
        meshes: vec![
            quad("plane", 10.0),
            MeshDesc {
                material: Some(1),
                ..quad("occluder", 20.0)
            },
        ],
        instances,
        // The occluder is black so that it changes the plane only through visibility.
        materials: vec![
            diffuse_material("grey", Vec3::splat(0.5)),
            diffuse_material("black", Vec3::ZERO),
        ],
        lights: vec![PunctualLightDesc {
            name: "sun".into(),
            kind: PunctualKind::Directional,
            color: Vec3::ONE,
            intensity: 3.0,
            position: Vec3::ZERO,
            direction: -Vec3::Y,
            angle: 0.0,
            ..Default::default()
        }],
        camera: Some(cam),
        instance_visibility,
        ..Default::default()
    };
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 16,
        max_depth: 4,
        seed: 3,
        ..Default::default()
    };
    let (film, _) = render_quiet(&scene, &settings);
    let px = film.to_rgba();
    px.iter().map(|p| Vec3::new(p[0], p[1], p[2])).sum::<Vec3>() / px.len() as f32
}

#[test]
fn directional_light_is_blocked_by_another_instance() {
    let lit = mean_rgb(false);
    assert!(lit.min_element() > 0.4, "unoccluded plane is lit: {lit}");
    let shadowed = mean_rgb(true);
    assert!(
        shadowed.max_element() < 1e-3 * lit.max_element(),
        "plane under the occluder is in shadow: {shadowed} (lit {lit})"
    );
}

/// A mesh standing for a Blender area light (glTF node extras `prism_area_light`) is not
/// geometry in Blender: it casts no shadow and camera rays pass through it.
#[test]
fn light_only_meshes_cast_no_shadow_and_hide_from_the_camera() {
    let lit = render_mean(Occluder::None);
    let light_only = InstanceVisibility {
        casts_shadows: false,
        camera_visible: false,
        light_only: true,
        holdout: false,
        light_visibility: Default::default(),
    };
    let above = render_mean(Occluder::Above(light_only));
    assert!(
        (above - lit).abs().max_element() < 0.02 * lit.max_element(),
        "a shadowless quad above must not shadow the plane: {above} vs {lit}"
    );
    // In front of the camera the black quad fills the image when it is visible.
    let seen = render_mean(Occluder::InFront(InstanceVisibility::default()));
    assert!(seen.max_element() < 1e-3, "visible quad {seen}");
    let hidden = render_mean(Occluder::InFront(light_only));
    assert!(
        (hidden - lit).abs().max_element() < 0.02 * lit.max_element(),
        "camera rays pass a hidden quad: {hidden} vs {lit}"
    );
}
