//! Textured layers and glTF material slots (issues 12 and 14): `clearcoatTexture` /
//! `clearcoatRoughnessTexture`, `sheenColorTexture` / `sheenRoughnessTexture`,
//! `transmissionTexture`, `specularTexture` / `specularColorTexture` and `iridescenceTexture` /
//! `iridescenceThicknessTexture` and `clearcoatNormalTexture` are read and vary their layer
//! across a surface.
//!
//! The scene: a unit quad facing a camera in a uniform white world, its material black (with
//! no specular layer where the slot under test is not the specular layer's), so that what it
//! reflects comes from the textured layer. A 2 x 1 texture (nearest filtering) has a chosen
//! texel on the left half (black unless stated) and white on the right.

#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use gltf_builder::{png16_bytes, test_dir, GltfBuilder};
use prism::film::PixelFilter;
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, Scene};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

const SIZE: u32 = 48;

/// The quad with material extension `ext` (whose texture slots name texture 0) under a white
/// world; returns the glTF path.
fn scene(name: &str, ext_name: &str, ext: Value) -> PathBuf {
    scene_with(
        name,
        json!({ "KHR_materials_specular": { "specularFactor": 0.0 }, ext_name: ext }),
        [0, 0, 0, 65535],
    )
}

/// The quad with the material's `extensions` (and `KHR_materials_specular` declared used), its
/// texture 0 texel `left` on the left half and white on the right.
fn scene_with(name: &str, extensions: Value, left: [u16; 4]) -> PathBuf {
    scene_with_base(name, extensions, left, 0.0)
}

/// [`scene_with`] with a grey base colour of `base` (black there).
fn scene_with_base(name: &str, extensions: Value, left: [u16; 4], base: f32) -> PathBuf {
    scene_full(name, extensions, [left, [65535; 4]], base, None)
}

/// The quad with the material's `extensions`, texture 0's two texels, a grey base of `base`
/// and, with `sun` (the light node's rotation quaternion), a black world and a directional
/// light of irradiance 1 instead of the white world.
fn scene_full(
    name: &str,
    extensions: Value,
    texels: [[u16; 4]; 2],
    base: f32,
    sun: Option<[f32; 4]>,
) -> PathBuf {
    let dir = test_dir(name);
    let mut b = GltfBuilder::new();
    for ext in extensions.as_object().unwrap().keys() {
        b.use_ext(ext);
    }
    b.use_ext("KHR_materials_specular");
    let png = png16_bytes(2, 1, &texels);
    let img = b.image_embedded(&png, "image/png");
    // NEAREST: each half is one texel's value.
    b.texture(img, Some(json!({ "magFilter": 9728, "minFilter": 9728 })));
    let m = b.material(json!({
        "name": "Layered",
        "pbrMetallicRoughness": { "baseColorFactor": [base, base, base, 1.0], "metallicFactor": 0.0,
                                  "roughnessFactor": 0.0 },
        "extensions": extensions
    }));
    let pos = b.positions(&[
        [-0.5, -0.5, 0.0],
        [0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
        [-0.5, 0.5, 0.0],
    ]);
    let uv = b.vec2(&[[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]);
    let idx = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mut prim = GltfBuilder::prim(pos, Some(idx), Some(m), 4);
    prim["attributes"]["TEXCOORD_0"] = json!(uv);
    let mesh = b.mesh("Quad", vec![prim]);
    b.root(json!({ "name": "Quad", "mesh": mesh }));
    let cam = b.camera("Cam", 0.4, Some(1.0));
    b.root(json!({ "name": "Cam", "camera": cam, "translation": [0.0, 0.0, 3.0] }));
    if let Some(q) = sun {
        // 683 lux: an irradiance of 1 W/m^2 (gltf_light_intensity_to_prism).
        let light = b.light(json!({ "type": "directional", "intensity": 683.0 }));
        b.root(json!({ "name": "Sun", "rotation": q,
                       "extensions": { "KHR_lights_punctual": { "light": light } } }));
    }
    let path = b.write_gltf(&dir.join("scene.gltf"));
    let world = if sun.is_some() { 0.0 } else { 1.0 };
    std::fs::write(
        dir.join("scene.materials.json"),
        json!({ "version": 1, "world": { "color": [1.0, 1.0, 1.0], "strength": world } })
            .to_string(),
    )
    .unwrap();
    path
}

/// Mean green of the left and right thirds of the quad's middle rows.
fn halves(path: &Path) -> (f32, f32) {
    let (l, r) = halves_rgb(path);
    (l[1], r[1])
}

/// Mean RGB of the left and right thirds of the quad's middle rows.
fn halves_rgb(path: &Path) -> ([f32; 3], [f32; 3]) {
    let desc = load_scene(path, Some(&path.with_extension("materials.json")), None).expect("loads");
    assert!(
        desc.warnings.iter().all(|w| !w.contains("not supported")),
        "{:?}",
        desc.warnings
    );
    let scene = Scene::build(desc).expect("builds");
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 64,
        max_depth: 4,
        seed: 3,
        filter: PixelFilter::unit_box(),
        ..Default::default()
    };
    let (film, _) = render_quiet(&scene, &settings);
    let px = film.to_rgba();
    // The quad spans about +-0.5 / (3 tan 0.2) = +-0.82 of the half-image: columns 5..43.
    let mean = |cols: std::ops::Range<usize>| {
        let mut sum = [0.0f32; 3];
        let mut n = 0;
        for y in 18..30 {
            for x in cols.clone() {
                for (c, s) in sum.iter_mut().enumerate() {
                    *s += px[y * SIZE as usize + x][c];
                }
                n += 1;
            }
        }
        sum.map(|s| s / n as f32)
    };
    (mean(10..20), mean(28..38))
}

#[test]
fn sheen_color_texture_masks_the_sheen() {
    let path = scene(
        "sheen_texture",
        "KHR_materials_sheen",
        json!({ "sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 0.6,
                "sheenColorTexture": { "index": 0 } }),
    );
    let (left, right) = halves(&path);
    // Facing the camera the Charlie lobe (roughness 0.6) reflects E(1) ~ 0.07 of a white world.
    assert!(left < 0.005, "black texel: no sheen, got {left}");
    assert!(
        right > 0.03 && right < 0.2,
        "white texel: the sheen's albedo, got {right}"
    );
}

#[test]
fn clearcoat_texture_masks_the_coat() {
    let path = scene(
        "coat_texture",
        "KHR_materials_clearcoat",
        json!({ "clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3,
                "clearcoatTexture": { "index": 0 } }),
    );
    let (left, right) = halves(&path);
    // A coat of IOR 1.5 reflects about 4-5% of a white world at normal incidence.
    assert!(left < 0.005, "black texel: no coat, got {left}");
    assert!(
        right > 0.03 && right < 0.1,
        "white texel: the coat's reflectance, got {right}"
    );
}

#[test]
fn clearcoat_roughness_texture_scales_the_roughness() {
    // Roughness 0 where the texel is black: a mirror coat reflects its Fresnel, 0.04, of the
    // white world at normal view; roughness 1 where white: 0.0145 (a uniform roughness-1 coat
    // measures the same), its microfacets spreading the view over grazing reflections.
    let path = scene(
        "coat_roughness_texture",
        "KHR_materials_clearcoat",
        json!({ "clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 1.0,
                "clearcoatRoughnessTexture": { "index": 0 } }),
    );
    let (left, right) = halves(&path);
    assert!(
        (left - 0.04).abs() < 0.003,
        "black texel: a mirror coat, got {left}"
    );
    assert!(
        right > 0.008 && right < 0.025,
        "white texel: the rough coat, got {right}"
    );
    let desc = load_scene(&path, None, None).unwrap();
    assert!(desc.materials[0].gltf.coat_roughness_texture.is_some());
}

#[test]
fn specular_texture_masks_the_specular_layer() {
    // A black dielectric reflects its Fresnel, F0 = 0.04 at IOR 1.5, of the white world; the
    // texture's alpha multiplies the specular factor.
    let path = scene_with(
        "specular_texture",
        json!({ "KHR_materials_specular": { "specularFactor": 1.0, "specularTexture": { "index": 0 } } }),
        [65535, 65535, 65535, 0],
    );
    let (left, right) = halves(&path);
    assert!(left < 0.003, "alpha 0: no specular, got {left}");
    assert!(
        (right - 0.04).abs() < 0.005,
        "alpha 1: F0 0.04, got {right}"
    );
}

#[test]
fn specular_color_texture_tints_the_specular_layer() {
    let path = scene_with(
        "specular_color_texture",
        json!({ "KHR_materials_specular": { "specularFactor": 1.0,
                "specularColorTexture": { "index": 0 } } }),
        [65535, 0, 0, 65535],
    );
    let (left, right) = halves_rgb(&path);
    // Red texel: F0 = 0.04 x (1, 0, 0); white: 0.04 in every channel.
    assert!(
        (left[0] - 0.04).abs() < 0.006 && left[1] < 0.01 && left[2] < 0.01,
        "red texel: a red-tinted reflection, got {left:?}"
    );
    assert!(
        right.iter().all(|c| (c - 0.04).abs() < 0.006),
        "white texel: F0 0.04, got {right:?}"
    );
}

#[test]
fn transmission_texture_masks_the_transmission() {
    // A grey (0.5) base under the specular layer (F0 0.04). Where the texel is black the quad is
    // opaque: the layer's 0.04 plus the diffuse base's 0.5 of the rest, about 0.52. Where it is
    // white it transmits: the view refracts into the (one-sided) interface and sees the white
    // world tinted by the base, with the radiance scaled by 1 / eta^2 on entering IOR 1.5:
    // 0.04 + 0.96 x 0.5 / 2.25 = 0.253.
    let path = scene_with_base(
        "transmission_texture",
        json!({ "KHR_materials_transmission": { "transmissionFactor": 1.0,
                "transmissionTexture": { "index": 0 } } }),
        [0, 0, 0, 65535],
        0.5,
    );
    let (left, right) = halves(&path);
    assert!(
        (left - 0.52).abs() < 0.02,
        "black texel: opaque, got {left}"
    );
    let want = 0.04 + 0.96 * 0.5 / 2.25;
    assert!(
        (right - want).abs() < 0.01,
        "white texel: transmits, got {right} (want {want})"
    );
}

#[test]
fn iridescence_textures_vary_the_film() {
    // A black dielectric (F0 0.04) under a 300 nm film of IOR 1.33: its reflection is coloured.
    // Where iridescenceTexture is 0 there is no film, and where the thickness texture's G is 0
    // the film has the minimum thickness, here 0: the plain 0.04 in every channel.
    for (name, slot, extra) in [
        ("iridescence_texture", "iridescenceTexture", json!({})),
        (
            "iridescence_thickness_texture",
            "iridescenceThicknessTexture",
            json!({ "iridescenceThicknessMinimum": 0.0 }),
        ),
    ] {
        let mut film = json!({ "iridescenceFactor": 1.0, "iridescenceIor": 1.33,
                               "iridescenceThicknessMaximum": 300.0 });
        film[slot] = json!({ "index": 0 });
        for (k, v) in extra.as_object().unwrap() {
            film[k] = v.clone();
        }
        let path = scene_with(
            name,
            json!({ "KHR_materials_specular": { "specularFactor": 1.0 },
                    "KHR_materials_iridescence": film }),
            [0, 0, 0, 65535],
        );
        let (left, right) = halves_rgb(&path);
        assert!(
            left.iter().all(|c| (c - 0.04).abs() < 0.006),
            "{slot} 0: no film, got {left:?}"
        );
        let spread = right.iter().cloned().fold(0.0f32, f32::max)
            - right.iter().cloned().fold(1.0f32, f32::min);
        assert!(
            spread > 0.01 && right.iter().any(|c| (c - 0.04).abs() > 0.01),
            "{slot} 1: the film colours the reflection, got {right:?}"
        );
    }
}

/// The quad with the material's `extensions` under a white world, its material's shading graph
/// binding `inputs` (constants): the right half's mean RGB.
fn graph_inputs_render(name: &str, extensions: Value, inputs: Value) -> [f32; 3] {
    let path = scene_with(name, extensions, [65535, 65535, 65535, 65535]);
    let doc = json!({ "version": 1, "world": { "color": [1.0, 1.0, 1.0], "strength": 1.0 },
                      "materials": { "Layered": { "graph": { "version": 1, "nodes": {},
                                                             "inputs": inputs } } } });
    std::fs::write(path.with_extension("materials.json"), doc.to_string()).unwrap();
    halves_rgb(&path).1
}

#[test]
fn graph_specular_tint_and_thin_film_inputs() {
    // A shading graph's `specular_tint` tints the F0 of the black dielectric (0.04 in red only),
    // and its `thin_film_thickness` / `thin_film_ior` put a film on it (a coloured reflection);
    // thickness 0 is no film.
    let render = |name: &str, inputs: Value| {
        graph_inputs_render(
            name,
            json!({ "KHR_materials_specular": { "specularFactor": 1.0 } }),
            inputs,
        )
    };
    let red = render(
        "graph_specular_tint",
        json!({ "specular_tint": [1.0, 0.0, 0.0] }),
    );
    assert!(
        (red[0] - 0.04).abs() < 0.006 && red[1] < 0.005 && red[2] < 0.005,
        "specular_tint red: {red:?}"
    );
    let plain = render("graph_no_film", json!({ "thin_film_thickness": 0.0 }));
    assert!(
        plain.iter().all(|c| (c - 0.04).abs() < 0.006),
        "no film: {plain:?}"
    );
    let film = render(
        "graph_thin_film",
        json!({ "thin_film_thickness": 300.0, "thin_film_ior": 1.33 }),
    );
    assert!(
        film.iter().any(|c| (c - 0.04).abs() > 0.01),
        "a 300 nm film colours the reflection: {film:?}"
    );
}

#[test]
fn graph_coat_ior_sets_the_coat_fresnel() {
    // A black base without a specular layer under a smooth coat, seen head-on in a white
    // world, reflects the coat's F0 = ((n - 1) / (n + 1))^2: n the graph's `coat_ior` (Blender's
    // Coat IOR, also on Mix leaves), else the material's 1.5.
    let render = |name: &str, inputs: Value| {
        graph_inputs_render(
            name,
            json!({ "KHR_materials_specular": { "specularFactor": 0.0 },
                    "KHR_materials_clearcoat": { "clearcoatFactor": 1.0,
                                                 "clearcoatRoughnessFactor": 0.0 } }),
            inputs,
        )
    };
    for (name, inputs, n) in [
        (
            "graph_coat_default_ior",
            json!({ "coat_weight": 1.0 }),
            1.5f32,
        ),
        ("graph_coat_ior_2", json!({ "coat_ior": 2.0 }), 2.0),
        ("graph_coat_ior_3", json!({ "coat_ior": 3.0 }), 3.0),
    ] {
        let f0 = ((n - 1.0) / (n + 1.0)).powi(2);
        let got = render(name, inputs);
        assert!(
            got.iter().all(|c| (c - f0).abs() < 0.01 + 0.03 * f0),
            "coat IOR {n}: reflects {got:?}, F0 {f0}"
        );
    }
}

#[test]
fn clearcoat_normal_texture_tilts_the_coat() {
    // A black base under a rough (0.3) coat, lit only by a sun 40 degrees off the view axis
    // (towards +x): the coat's highlight peaks where its normal is the half vector, 20 degrees
    // towards +x. The right texel of clearcoatNormalTexture tilts the coat's normal so
    // (tangent space (sin 20, 0, cos 20); the quad's tangent is +x); the left one is flat,
    // 20 degrees off the peak, where GGX's D is 0.4% of its peak.
    let t = 20f32.to_radians();
    let texel = |v: f32| (((v + 1.0) * 0.5) * 65535.0).round() as u16;
    let flat = [texel(0.0), texel(0.0), texel(1.0), 65535];
    let tilted = [texel(t.sin()), texel(0.0), texel(t.cos()), 65535];
    // The light travels along -(sin 40, 0, cos 40): the node's -z turned 40 degrees about y.
    let half = 20f32.to_radians();
    let sun = Some([0.0, half.sin(), 0.0, half.cos()]);
    let coat = json!({ "KHR_materials_clearcoat": { "clearcoatFactor": 1.0,
                       "clearcoatRoughnessFactor": 0.3, "clearcoatNormalTexture": { "index": 0 } },
                       "KHR_materials_specular": { "specularFactor": 0.0 } });
    let path = scene_full("coat_normal_texture", coat, [flat, tilted], 0.0, sun);
    let desc = load_scene(&path, None, None).unwrap();
    assert!(desc.materials[0].gltf.coat_normal_texture.is_some());
    let (left, right) = halves(&path);
    assert!(
        right > 0.05 && right > 20.0 * left,
        "the tilted coat's highlight: left {left}, right {right}"
    );
}
