//! Shading graphs end to end: the material JSON's `graph` drives material inputs from images,
//! vertex colours, UV sets and math, through the loader, the integrator and light sampling.
//!
//! - An emissive quad whose emission is an Image Texture (Closest) on TEXCOORD_1 renders the
//!   image the right way up (Blender's UV convention: v up), per pixel.
//! - COLOR_0 through a Mix (multiply) node: the rendered emission is the product.
//! - A diffuse sphere under a uniform white world whose base colour comes from Math and
//!   Combine Color nodes renders albedo x world (a convex object sees only the world).
//! - A missing image renders magenta with a warning naming it; a bad graph is a one-line
//!   input error naming its JSON path.
//! - A float EXR with negative texels (a signed texture, e.g. one the add-on baked with Cycles)
//!   reaches the graph with its values, as in Cycles.

mod common;
#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use common::scenes::{diffuse_material, furnace_scene, render_mean};
use glam::Vec3;
use gltf_builder::{png_bytes, test_dir, GltfBuilder, TRIANGLES};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, Scene};
use prism::shading::parse::{parse_graph, NoImages};
use serde_json::json;
use std::sync::Arc;

/// An emissive quad "Panel" filling the middle of the view, with TEXCOORD_0 (unused, all 0),
/// TEXCOORD_1 (glTF convention: (0,0) at the top-left corner) and COLOR_0.
fn panel_scene(
    dir: &std::path::Path,
    graph: serde_json::Value,
    color: [f32; 4],
) -> std::path::PathBuf {
    panel_scene_with(dir, Some(graph), color, |b| {
        b.emissive_material("Panel", 1.0)
    })
}

/// [`panel_scene`] with the material `material` builds and an optional graph.
fn panel_scene_with(
    dir: &std::path::Path,
    graph: Option<serde_json::Value>,
    color: [f32; 4],
    material: impl FnOnce(&mut GltfBuilder) -> usize,
) -> std::path::PathBuf {
    let mut b = GltfBuilder::new();
    let m = material(&mut b);
    let pos = b.positions(&[
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ]);
    let uv0 = b.vec2(&[[0.0, 0.0]; 4]);
    let uv1 = b.vec2(&[[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]);
    let col = b.vec4(&[color; 4]);
    let idx = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mut prim = GltfBuilder::prim(pos, Some(idx), Some(m), TRIANGLES);
    prim["attributes"]["TEXCOORD_0"] = json!(uv0);
    prim["attributes"]["TEXCOORD_1"] = json!(uv1);
    prim["attributes"]["COLOR_0"] = json!(col);
    let q = b.mesh("Panel", vec![prim]);
    b.root(json!({ "name": "Panel", "mesh": q }));
    // yfov 0.5 at distance 3: the view spans +-0.76, inside the +-1 panel.
    let c = b.camera("CameraData", 0.5, Some(1.0));
    b.root(json!({ "name": "Camera", "camera": c, "translation": [0.0, 0.0, 3.0] }));
    let gltf = b.write_gltf(&dir.join("panel.gltf"));
    let sidecar = dir.join("panel.materials.json");
    match graph {
        Some(graph) => std::fs::write(
            sidecar,
            json!({"version": 1, "materials": {"Panel": {"graph": graph}}}).to_string(),
        )
        .unwrap(),
        None => {
            let _ = std::fs::remove_file(sidecar);
        }
    }
    gltf
}

fn render_file(gltf: &std::path::Path, size: u32, spp: u32) -> (Vec<[f32; 4]>, Vec<String>) {
    let desc = load_scene(gltf, None, None).expect("scene loads");
    let warnings = desc.warnings.clone();
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 4,
        ..Default::default()
    };
    let (film, stats) = render_quiet(&scene, &settings);
    assert_eq!(stats.discarded, 0);
    (film.to_rgba(), warnings)
}

/// A graph from its JSON form (images are placeholders).
fn graph(v: serde_json::Value) -> Arc<prism::shading::ShadingGraph> {
    Arc::new(
        parse_graph(&v, "graph", &mut NoImages)
            .ok()
            .expect("graph parses"),
    )
}

/// Mean of the 4 x 4 centre pixels of a `size` x `size` image (the furnace sphere).
fn centre_mean(img: &[[f32; 4]], size: usize) -> Vec3 {
    let mut centre = Vec3::ZERO;
    for y in size / 2 - 2..size / 2 + 2 {
        for x in size / 2 - 2..size / 2 + 2 {
            let p = img[y * size + x];
            centre += Vec3::new(p[0], p[1], p[2]) / 16.0;
        }
    }
    centre
}

fn px(img: &[[f32; 4]], size: u32, x: u32, y: u32) -> Vec3 {
    let p = img[(y * size + x) as usize];
    Vec3::new(p[0], p[1], p[2])
}

/// Mean over the `n` x `n` pixels from (x0, y0): spectral sampling gives each pixel colour
/// noise, the mean is what the colour must match.
fn block(img: &[[f32; 4]], size: u32, x0: u32, y0: u32, n: u32) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for y in y0..y0 + n {
        for x in x0..x0 + n {
            sum += px(img, size, x, y);
        }
    }
    sum / (n * n) as f32
}

#[test]
fn image_texture_on_a_uv_set_drives_emission_upright() {
    let dir = test_dir("graph_image");
    // 2x2 image, top row: red, green; bottom row: blue, white (8-bit sRGB: 255 and 0 are exact).
    let png = png_bytes(
        2,
        2,
        &[
            [255, 0, 0, 255],
            [0, 255, 0, 255],
            [0, 0, 255, 255],
            [255, 255, 255, 255],
        ],
    );
    std::fs::write(dir.join("quad.png"), png).unwrap();
    let gltf = panel_scene(
        &dir,
        json!({"version": 1,
               "nodes": {"UV": {"type": "uv_map", "set": 1},
                         "Img": {"type": "image_texture", "image": "quad.png",
                                 "interpolation": "closest",
                                 "inputs": {"vector": {"node": "UV", "output": "uv"}}}},
               "inputs": {"emission": {"node": "Img", "output": "color"}, "emission_strength": 2.0}}),
        [1.0; 4],
    );
    let size = 16;
    let (img, warnings) = render_file(&gltf, size, 32);
    assert!(warnings.is_empty(), "{warnings:?}");
    // Image y runs down the film: the top-left quarter shows the image's top-left texel.
    // Saturated primaries are at the edge of what smooth spectra reproduce: 3% of the peak.
    assert_quadrants(&img, size, 2.0);
}

#[test]
fn signed_exr_texels_reach_the_graph_unclamped() {
    let dir = test_dir("graph_signed_exr");
    // Data, not radiance: -0.25 everywhere; 0.75 + texel = 0.5 drives the emission strength.
    exr::prelude::write_rgb_file(dir.join("signed.exr"), 2, 2, |_, _| {
        (-0.25f32, -0.25, -0.25)
    })
    .unwrap();
    let gltf = panel_scene(
        &dir,
        json!({"version": 1,
               "nodes": {"Img": {"type": "image_texture", "image": "signed.exr",
                                 "color_space": "linear"},
                         "Add": {"type": "math", "operation": "add",
                                 "inputs": {"a": {"node": "Img", "output": "color"}, "b": 0.75}}},
               "inputs": {"emission": [1.0, 1.0, 1.0],
                          "emission_strength": {"node": "Add", "output": "value"}}}),
        [1.0; 4],
    );
    let size = 8;
    let (img, warnings) = render_file(&gltf, size, 16);
    assert!(warnings.is_empty(), "{warnings:?}");
    let m = block(&img, size, 2, 2, 4);
    for c in m.to_array() {
        assert!((c - 0.5).abs() < 0.02, "0.75 - 0.25 = 0.5 per channel: {m}");
    }
}

/// The quadrants of `img` (16 x 16) hold red, green, blue and white at `peak`.
fn assert_quadrants(img: &[[f32; 4]], size: u32, peak: f32) {
    let red = block(img, size, 1, 1, 6);
    let green = block(img, size, 9, 1, 6);
    let blue = block(img, size, 1, 9, 6);
    let white = block(img, size, 9, 9, 6);
    let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 0.03 * peak;
    assert!(close(red, Vec3::new(peak, 0.0, 0.0)), "top-left {red}");
    assert!(close(green, Vec3::new(0.0, peak, 0.0)), "top-right {green}");
    assert!(close(blue, Vec3::new(0.0, 0.0, peak)), "bottom-left {blue}");
    assert!(close(white, Vec3::splat(peak)), "bottom-right {white}");
}

/// The panel lit by a 2x2 red / green / blue / white PNG as its emissive texture (strength 2),
/// read through `sampler` and the textureInfo `info` (its `index` is filled in).
fn rgbw_emissive_panel(
    name: &str,
    sampler: serde_json::Value,
    mut info: serde_json::Value,
    size: u32,
    spp: u32,
) -> (Vec<[f32; 4]>, Vec<String>) {
    let dir = test_dir(name);
    let png = png_bytes(
        2,
        2,
        &[
            [255, 0, 0, 255],
            [0, 255, 0, 255],
            [0, 0, 255, 255],
            [255, 255, 255, 255],
        ],
    );
    let gltf = panel_scene_with(&dir, None, [1.0; 4], |b| {
        let img = b.image_embedded(&png, "image/png");
        info["index"] = json!(b.texture(img, Some(sampler)));
        b.use_ext("KHR_materials_emissive_strength");
        b.use_ext("KHR_texture_transform");
        b.material(json!({"name": "Panel", "emissiveFactor": [1.0, 1.0, 1.0],
            "emissiveTexture": info,
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]},
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}}}))
    });
    render_file(&gltf, size, spp)
}

#[test]
fn gltf_texture_on_texcoord_1() {
    // A plain glTF emissive texture with texCoord 1: read from TEXCOORD_1 (TEXCOORD_0 is all 0).
    let size = 16;
    let (img, warnings) = rgbw_emissive_panel(
        "gltf_texcoord_1",
        json!({"magFilter": 9728, "minFilter": 9728}),
        json!({"texCoord": 1}),
        size,
        32,
    );
    assert!(
        !warnings.iter().any(|w| w.contains("TEXCOORD")),
        "{warnings:?}"
    );
    assert_quadrants(&img, size, 2.0);
}

#[test]
fn gltf_sampler_wraps_each_axis_mirrored_included() {
    // glTF textures are graph nodes now: MIRRORED_REPEAT along u and CLAMP_TO_EDGE along v
    // each apply on their own axis, after KHR_texture_transform, on the panel's TEXCOORD_1
    // (its TEXCOORD_0 is all 0). The offset (0.5, 0.5) puts the view's UVs (about
    // [0.17, 0.83] of the panel) at [0.67, 1.33]: texel column 1 and row 1 (white) on the
    // near side of 1; past it, mirroring reads column 1 again (repeating would read blue /
    // red) and clamping row 1 again (repeating would read green / red).
    let size = 32;
    let (img, warnings) = rgbw_emissive_panel(
        "gltf_mirrored_repeat",
        json!({"magFilter": 9728, "minFilter": 9728, "wrapS": 33648, "wrapT": 33071}),
        json!({"texCoord": 1,
               "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.5]}}}),
        size,
        16,
    );
    assert!(
        !warnings.iter().any(|w| w.contains("MIRRORED")),
        "{warnings:?}"
    );
    for (x, y) in [(6, 6), (22, 6), (6, 22), (22, 22)] {
        let got = block(&img, size, x, y, 4);
        assert!(
            (got - Vec3::splat(2.0)).abs().max_element() < 0.06,
            "pixels ({x}, {y}): {got}, want white"
        );
    }
}

#[test]
fn textured_emitters_dark_at_their_triangles_centres_are_still_chosen() {
    // Emission only where u > 0.8 (TEXCOORD_1): neither triangle's centre (u = 2/3, 1/3)
    // emits, so a centre-only power estimate would never pick the panel for next-event
    // estimation. The estimate averages points over each triangle.
    let dir = test_dir("graph_emitter_power");
    let gltf = panel_scene(
        &dir,
        json!({"version": 1,
               "nodes": {"UV": {"type": "uv_map", "set": 1},
                         "Sep": {"type": "separate_xyz",
                                 "inputs": {"vector": {"node": "UV", "output": "uv"}}},
                         "Edge": {"type": "math", "operation": "greater_than",
                                  "inputs": {"a": {"node": "Sep", "output": "x"}, "b": 0.8}}},
               "inputs": {"emission": [1.0, 1.0, 1.0],
                          "emission_strength": {"node": "Edge", "output": "value"}}}),
        [1.0; 4],
    );
    let scene = Scene::build(load_scene(&gltf, None, None).expect("scene loads")).unwrap();
    let ctx = prism::lights::ShadingContext {
        p: glam::Vec3::new(0.0, 0.0, 3.0),
        n: None,
        time: 0.5,
    };
    for selection in [
        prism::lights::LightSelection::Tree,
        prism::lights::LightSelection::Power,
    ] {
        for prim in 0..2 {
            let pmf = scene.lights.pmf(&ctx, prim, selection);
            assert!(pmf > 0.05, "triangle {prim}: pmf {pmf} ({selection:?})");
        }
    }
}

#[test]
fn vertex_colour_through_a_mix_node() {
    let dir = test_dir("graph_color_attribute");
    let gltf = panel_scene(
        &dir,
        json!({"version": 1,
               "nodes": {"Col": {"type": "color_attribute"},
                         "Mix": {"type": "mix", "blend_type": "multiply",
                                 "inputs": {"factor": 1.0, "a": [0.5, 1.0, 1.0],
                                            "b": {"node": "Col", "output": "color"}}}},
               "inputs": {"emission": {"node": "Mix", "output": "result"}}}),
        [0.2, 0.4, 0.8, 1.0],
    );
    let size = 8;
    let (img, _) = render_file(&gltf, size, 64);
    let want = Vec3::new(0.1, 0.4, 0.8);
    let got = block(&img, size, 0, 0, size);
    assert!((got - want).abs().max_element() < 0.02, "{got} vs {want}");
}

#[test]
fn graph_base_colour_on_a_convex_diffuse_object_under_a_white_world() {
    // furnace_scene: a sphere of albedo `a` in a uniform white world, seen whole.
    let world = Vec3::ONE;
    let mut desc = furnace_scene(diffuse_material("Sphere", Vec3::ONE), world);
    desc.materials[0].graph = Some(graph(json!({"version": 1,
                "nodes": {"Half": {"type": "math", "operation": "multiply", "inputs": {"a": 0.25, "b": 2.0}},
                          "RGB": {"type": "combine_color",
                                  "inputs": {"red": {"node": "Half"}, "green": 0.25, "blue": 0.75}}},
                "inputs": {"base_color": {"node": "RGB", "output": "color"}}})));
    let (_, img) = render_mean(desc, 32, 64, 8, 1);
    // The centre pixels see the sphere: radiance = albedo x world, one bounce.
    let centre = centre_mean(&img, 32);
    let want = Vec3::new(0.5, 0.25, 0.75);
    assert!(
        (centre - want).abs().max_element() < 0.02,
        "sphere centre {centre} vs {want}"
    );
}

#[test]
fn missing_image_is_magenta_with_a_warning_and_bad_graphs_are_errors() {
    let dir = test_dir("graph_missing");
    let gltf = panel_scene(
        &dir,
        json!({"version": 1,
               "nodes": {"Img": {"type": "image_texture", "image": "nowhere.png"}},
               "inputs": {"emission": {"node": "Img", "output": "color"}}}),
        [1.0; 4],
    );
    let size = 4;
    let (img, warnings) = render_file(&gltf, size, 64);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("nowhere.png") && warnings[0].contains("magenta"),
        "{}",
        warnings[0]
    );
    let c = block(&img, size, 0, 0, size);
    assert!(
        (c - Vec3::new(1.0, 0.0, 1.0)).abs().max_element() < 0.03,
        "{c}"
    );

    let bad = panel_scene(
        &dir,
        json!({"version": 1, "nodes": {"M": {"type": "math", "operation": "bogus"}},
               "inputs": {"roughness": {"node": "M"}}}),
        [1.0; 4],
    );
    let Err(e) = load_scene(&bad, None, None) else {
        panic!("bad graph accepted");
    };
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2);
    assert!(
        msg.contains("materials.Panel.graph.nodes.M.operation: unknown value 'bogus'"),
        "{msg}"
    );
    assert!(!msg.contains('\n'));
}

#[test]
fn mixed_closures_weigh_bsdfs_and_emission() {
    // Mix Shader (factor 0.3) of a white-ish diffuse BSDF (weight 0.7) and an emission
    // (weight 0.3, colour (1, 0.5, 0.25) x 2), as the add-on flattens it, on a convex sphere
    // under a white world: radiance = 0.7 x albedo + 0.3 x emission.
    let mut desc = furnace_scene(diffuse_material("Sphere", Vec3::ONE), Vec3::ONE);
    desc.materials[0].graph = Some(graph(json!({"version": 1,
                "nodes": {"Fac": {"type": "math", "operation": "add", "inputs": {"a": 0.1, "b": 0.2}},
                          "Inv": {"type": "math", "operation": "subtract",
                                  "inputs": {"a": 1.0, "b": {"node": "Fac"}}}},
                "closures": [
                    {"kind": "bsdf", "weight": {"node": "Inv"},
                     "inputs": {"base_color": [0.8, 0.6, 0.4], "metallic": 0.0, "specular": 0.0}},
                    {"kind": "emission", "weight": {"node": "Fac"},
                     "inputs": {"emission": [1.0, 0.5, 0.25], "emission_strength": 2.0}}]})));
    let (_, img) = render_mean(desc, 32, 256, 8, 1);
    let centre = centre_mean(&img, 32);
    let want = Vec3::new(0.8, 0.6, 0.4) * 0.7 + Vec3::new(1.0, 0.5, 0.25) * 2.0 * 0.3;
    assert!(
        (centre - want).abs().max_element() < 0.03 * want.max_element(),
        "sphere centre {centre} vs {want}"
    );
}

#[test]
fn translucent_sphere_in_a_white_furnace_returns_all_light() {
    // A closed sphere of lossless Lambertian transmission: every path leaves it again.
    let mut desc = furnace_scene(diffuse_material("Sphere", Vec3::ONE), Vec3::ONE);
    desc.materials[0].graph = Some(graph(json!({"version": 1, "nodes": {},
        "closures": [{"kind": "translucent", "weight": 1.0,
                      "inputs": {"base_color": [1.0, 1.0, 1.0]}}]})));
    let (_, img) = render_mean(desc, 32, 64, 64, 1);
    let centre = centre_mean(&img, 32);
    assert!(
        (centre - Vec3::ONE).abs().max_element() < 0.02,
        "translucent furnace {centre}"
    );
}
