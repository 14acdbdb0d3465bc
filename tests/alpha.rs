//! Alpha (stochastic transparency) end to end:
//! - a half-transparent occluder (graph Alpha 0.3) between a sun and a Lambertian plane lets
//!   exactly 70% of the sun through (transparent shadows, as Cycles);
//! - seen by the camera, the same occluder shows the plane behind at 70%;
//! - glTF alphaMode MASK below the cutoff is fully transparent, BLEND is coverage;
//! - a furnace: a Transparent BSDF sphere in a white world vanishes (radiance 1 everywhere);
//! - a tinted Transparent BSDF passes its colour: in shadows, seen by the camera, and mixed.

mod common;

use common::scenes::{camera, diffuse_material, furnace_scene, render_mean};
use glam::{Mat4, Vec3, Vec4};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{
    AlphaMode, InstanceDesc, MaterialDesc, MeshDesc, PunctualKind, PunctualLightDesc, Scene,
    SceneDesc,
};
use prism::shading::parse::{parse_graph, NoImages};
use prism::spectrum::cie::{d65_normalized, integrate_xyz};
use prism::spectrum::rgb::xyz_to_linear_srgb;
use prism::spectrum::RgbAlbedoSpectrum;
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

/// A Transparent BSDF with colour c (Cycles' transparent closure weight) passes c times the
/// light, per wavelength: the shadow of a fully transparent tinted veil is the lit plane times
/// c (the grey plane's spectrum is flat, so exact up to c's RGB round trip, < 2%); seen
/// through the veil the plane in its shadow is times c's spectrum twice; mixed 50/50 with a black BSDF
/// the shadow is 0.5 c. Untinted (white) it is the untinted result bit for bit.
#[test]
fn tinted_transparent_bsdf_passes_its_colour() {
    let tint = Vec3::new(0.9, 0.5, 0.2);
    let veil = |weight: f32, colour: Option<Vec3>| {
        let mut m = diffuse_material("veil", Vec3::ZERO);
        let mut leaf = json!({"kind": "transparent", "weight": weight});
        if let Some(c) = colour {
            leaf["inputs"] = json!({"base_color": [c.x, c.y, c.z]});
        }
        let mut closures = vec![leaf];
        if weight < 1.0 {
            closures.push(json!({"kind": "bsdf", "weight": 1.0 - weight,
                "inputs": {"base_color": [0.0, 0.0, 0.0]}}));
        }
        m.graph = Some(graph(
            json!({"version": 1, "nodes": {}, "closures": closures}),
        ));
        m
    };
    let lit = plane_mean(None);
    let shadow = plane_mean(Some((veil(1.0, Some(tint)), 5.0))) / lit;
    assert!(
        ((shadow - tint) / tint).abs().max_element() < 0.02,
        "shadow ratio {shadow} vs {tint}"
    );
    // Twice through the veil is the spectrum squared, which is not the RGB squared (blue 0.025
    // against 0.04 for this tint): the expectation is the squared spectrum's colour under D65.
    let s = RgbAlbedoSpectrum::new(tint);
    let twice = xyz_to_linear_srgb(integrate_xyz(
        |l| s.eval(l) * s.eval(l) * d65_normalized(l),
        4,
    ));
    let seen = plane_mean(Some((veil(1.0, Some(tint)), 1.5))) / lit;
    assert!(
        ((seen - twice) / twice).abs().max_element() < 0.03,
        "seen through {seen} vs {twice}"
    );
    let mixed = plane_mean(Some((veil(0.5, Some(tint)), 5.0))) / lit;
    assert!(
        ((mixed - 0.5 * tint) / (0.5 * tint)).abs().max_element() < 0.03,
        "mixed {mixed} vs {}",
        0.5 * tint
    );
    let untinted = plane_mean(Some((veil(0.5, None), 1.5)));
    let white = plane_mean(Some((veil(0.5, Some(Vec3::ONE)), 1.5)));
    assert!(
        ((white - untinted) / untinted).abs().max_element() < 0.02,
        "white {white} vs untinted {untinted}"
    );
}
