//! A Blender area light is no geometry: the mesh the add-on writes for it (an emitter with
//! transmission 1 and IOR 1, node extras `prism_area_light`) casts no shadow, and a ray that
//! meets it takes its emission and goes on from the vertex it left. Regression: the mesh was a
//! vertex of its own, a smooth pass-through after which what lay behind it counted at full
//! weight besides the last vertex's light samples (whose shadow rays passed the mesh). A sun
//! behind a softbox then lit the floor twice, through rare BSDF samples of its disc: fireflies
//! 700 times the pixel and 7% too much light where the softbox stood between the floor and
//! the sun (found on a Blender scene against Cycles).

#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use gltf_builder::*;
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, Scene};
use serde_json::json;

/// A grey glossy floor (z = 0) seen from straight above, lit by a sun of Blender's default
/// 0.53-degree disc from straight above; with `softbox`, an area light's mesh at z = 2 between
/// the floor and the sun, facing away from the floor (its emission does not reach it).
/// Returns the floor's pixels (RGB).
fn floor_pixels(softbox: bool, seed: u64) -> Vec<[f32; 3]> {
    let mut b = GltfBuilder::new();
    let floor = b.material(json!({
        "name": "Floor",
        "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.35
        }
    }));
    let q = b.quad_mesh("Floor", Some(floor));
    b.root(json!({ "name": "Floor", "mesh": q, "scale": [20.0, 20.0, 1.0] }));
    if softbox {
        // As the add-on exports a Blender area light.
        b.use_ext("KHR_materials_emissive_strength");
        b.use_ext("KHR_materials_transmission");
        b.use_ext("KHR_materials_ior");
        let light = b.material(json!({
            "name": "PrismAreaLight_Softbox",
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0
            },
            "emissiveFactor": [1.0, 1.0, 1.0],
            "extensions": {
                "KHR_materials_emissive_strength": { "emissiveStrength": 50.0 },
                "KHR_materials_transmission": { "transmissionFactor": 1.0 },
                "KHR_materials_ior": { "ior": 1.0 }
            },
            "doubleSided": false
        }));
        let m = b.quad_mesh("Softbox", Some(light));
        b.root(json!({
            "name": "Softbox", "mesh": m, "translation": [0.0, 0.0, 2.0], "scale": [6.0, 6.0, 1.0],
            "extras": { "prism_area_light": true, "prism_visible_camera": false }
        }));
    }
    let sun = b.light(json!({
        "type": "directional", "color": [1.0, 1.0, 1.0], "intensity": 2049.0,
        "extras": { "prism_angle": 0.00918 }
    }));
    // glTF directional lights shine along -z of their node: straight down here.
    b.root(json!({ "name": "Sun", "extensions": { "KHR_lights_punctual": { "light": sun } } }));
    let c = b.camera("CameraData", 0.5, Some(1.0));
    b.root(json!({ "name": "Camera", "camera": c, "translation": [0.0, 0.0, 4.0] }));
    let dir = test_dir("area_light_pass");
    let path = b.write_gltf(&dir.join(format!("scene_{softbox}.gltf")));
    let desc = load_scene(&path, None, None).expect("scene loads");
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 64,
        max_depth: 4,
        seed,
        ..Default::default()
    };
    let (film, _) = render_quiet(&scene, &settings);
    film.to_rgba().iter().map(|p| [p[0], p[1], p[2]]).collect()
}

fn mean(px: &[[f32; 3]]) -> f64 {
    px.iter()
        .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
        .sum::<f64>()
        / px.len() as f64
}

#[test]
fn an_area_light_between_a_floor_and_the_sun_neither_shadows_nor_adds_to_it() {
    let (mut with, mut without) = (0.0, 0.0);
    let mut brightest = 0f32;
    for seed in 1..=4 {
        let px = floor_pixels(true, seed);
        brightest = px.iter().flatten().fold(brightest, |m, &v| m.max(v));
        with += mean(&px) / 4.0;
        without += mean(&floor_pixels(false, seed)) / 4.0;
    }
    assert!(without > 0.05, "the sun lights the floor: {without}");
    assert!(
        (with / without - 1.0).abs() < 0.01,
        "the floor under the softbox {with} against without it {without}"
    );
    assert!(
        (brightest as f64) < 3.0 * without,
        "no fireflies under the softbox: brightest pixel {brightest}, floor mean {without}"
    );
}
