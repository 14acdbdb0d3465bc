//! Alpha (stochastic transparency) end to end:
//! - a half-transparent occluder (graph Alpha 0.3) between a sun and a Lambertian plane lets
//!   exactly 70% of the sun through (transparent shadows, as Cycles);
//! - seen by the camera, the same occluder shows the plane behind at 70%;
//! - glTF alphaMode MASK below the cutoff is fully transparent, BLEND is coverage;
//! - a furnace: a Transparent BSDF sphere in a white world vanishes (radiance 1 everywhere).

mod common;

use common::scenes::{camera, diffuse_material, furnace_scene, render_mean};
use glam::{Mat4, Vec3, Vec4};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{
    AlphaMode, InstanceDesc, MaterialDesc, MeshDesc, PunctualKind, PunctualLightDesc, Scene,
    SceneDesc,
};
use prism::shading::parse::{parse_graph, NoImages};
use serde_json::json;
use std::sync::Arc;

fn quad(name: &str, half: f32, material: usize) -> MeshDesc {
    MeshDesc {
        name: name.into(),
        positions: vec![
            Vec3::new(-half, 0.0, -half),
            Vec3::new(half, 0.0, -half),
            Vec3::new(half, 0.0, half),
            Vec3::new(-half, 0.0, half),
        ],
        normals: Some(vec![Vec3::Y; 4]),
        indices: vec![0, 2, 1, 0, 3, 2],
        material: Some(material),
        ..Default::default()
    }
}

fn graph(v: serde_json::Value) -> Arc<prism::shading::ShadingGraph> {
    Arc::new(
        parse_graph(&v, "graph", &mut NoImages)
            .ok()
            .expect("graph parses"),
    )
}

/// Mean radiance of a grey plane seen from above, under a sun, with `occluder` (a black
/// material) at height `y` (5: above the camera, only shadow rays meet it; 1.5: in front).
fn plane_mean(occluder: Option<(MaterialDesc, f32)>) -> Vec3 {
    let mut cam = camera(0.0, 0.05);
    cam.camera_to_world = Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let mut instances = vec![InstanceDesc {
        mesh: 0,
        object_to_world: Mat4::IDENTITY,
        name: "plane".into(),
    }];
    let mut materials = vec![diffuse_material("grey", Vec3::splat(0.5))];
    let mut meshes = vec![quad("plane", 10.0, 0)];
    if let Some((m, y)) = occluder {
        materials.push(m);
        meshes.push(quad("occluder", 20.0, 1));
        instances.push(InstanceDesc {
            mesh: 1,
            object_to_world: Mat4::from_translation(Vec3::new(0.0, y, 0.0)),
            name: "occluder".into(),
        });
    }
    let desc = SceneDesc {
        meshes,
        instances,
        materials,
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
        ..Default::default()
    };
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 256,
        max_depth: 4,
        seed: 3,
        ..Default::default()
    };
    let (film, stats) = render_quiet(&scene, &settings);
    assert_eq!(stats.discarded, 0);
    let px = film.to_rgba();
    px.iter().map(|p| Vec3::new(p[0], p[1], p[2])).sum::<Vec3>() / px.len() as f32
}

fn black_with_alpha(alpha: f32) -> MaterialDesc {
    let mut m = diffuse_material("veil", Vec3::ZERO);
    m.graph = Some(graph(
        json!({"version": 1, "nodes": {}, "inputs": {"alpha": alpha}}),
    ));
    m
}

#[test]
fn transparent_shadows_and_camera_rays() {
    let lit = plane_mean(None);
    assert!(lit.min_element() > 0.3, "{lit}");
    let shadow = plane_mean(Some((black_with_alpha(0.3), 5.0)));
    let ratio = shadow / lit;
    assert!(
        (ratio - Vec3::splat(0.7)).abs().max_element() < 0.01,
        "shadow ratio {ratio}"
    );
    // In front of the camera: 70% of the camera rays pass, and see the plane in its shadow.
    let seen = plane_mean(Some((black_with_alpha(0.3), 1.5)));
    let ratio = seen / lit;
    assert!(
        (ratio - Vec3::splat(0.49)).abs().max_element() < 0.03,
        "seen through {ratio}"
    );
    // Opaque (alpha 1) blocks everything.
    let opaque = plane_mean(Some((black_with_alpha(1.0), 5.0)));
    assert!(opaque.max_element() < 1e-4, "{opaque}");
}

#[test]
fn gltf_alpha_modes() {
    let lit = plane_mean(None);
    let with_mode = |mode: AlphaMode, a: f32| {
        let mut m = diffuse_material("veil", Vec3::ZERO);
        m.gltf.base_color = Vec4::new(0.0, 0.0, 0.0, a);
        m.gltf.alpha_mode = mode;
        m.gltf.alpha_cutoff = 0.5;
        plane_mean(Some((m, 5.0)))
    };
    let masked_out = with_mode(AlphaMode::Mask, 0.2) / lit;
    assert!(
        (masked_out - Vec3::ONE).abs().max_element() < 0.01,
        "{masked_out}"
    );
    let masked_in = with_mode(AlphaMode::Mask, 0.6);
    assert!(masked_in.max_element() < 1e-4, "{masked_in}");
    let blend = with_mode(AlphaMode::Blend, 0.25) / lit;
    assert!(
        (blend - Vec3::splat(0.75)).abs().max_element() < 0.01,
        "{blend}"
    );
    let opaque = with_mode(AlphaMode::Opaque, 0.25);
    assert!(opaque.max_element() < 1e-4, "{opaque}");
}

#[test]
fn furnace_transparent_bsdf_vanishes() {
    let mut m = diffuse_material("glassless", Vec3::splat(0.5));
    m.graph = Some(graph(json!({"version": 1, "nodes": {},
        "closures": [{"kind": "transparent", "weight": 1.0}]})));
    let (mean, img) = render_mean(furnace_scene(m, Vec3::ONE), 16, 16, 8, 1);
    assert!((mean - Vec3::ONE).abs().max_element() < 0.01, "{mean}");
    for p in &img {
        assert!(
            (p[0] - 1.0).abs() < 0.03 && (p[2] - 1.0).abs() < 0.03,
            "{p:?}"
        );
    }
}
