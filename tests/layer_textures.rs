//! Textured coat and sheen (issue 14): `clearcoatTexture` / `clearcoatRoughnessTexture` and
//! `sheenColorTexture` / `sheenRoughnessTexture` are read and vary the layer across a surface.
//!
//! The scene: a unit quad facing a camera in a uniform white world, its material black with no
//! specular layer, so all that it reflects comes from the textured layer. A 2 x 1 texture
//! (nearest filtering) is black on the left half and white on the right: the layer exists on
//! the right half only.

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
    let dir = test_dir(name);
    let mut b = GltfBuilder::new();
    b.use_ext(ext_name);
    b.use_ext("KHR_materials_specular");
    let png = png16_bytes(2, 1, &[[0, 0, 0, 65535], [65535, 65535, 65535, 65535]]);
    let img = b.image_embedded(&png, "image/png");
    // NEAREST: each half is one texel's value.
    b.texture(img, Some(json!({ "magFilter": 9728, "minFilter": 9728 })));
    let m = b.material(json!({
        "name": "Layered",
        "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0 },
        "extensions": {
            "KHR_materials_specular": { "specularFactor": 0.0 },
            ext_name: ext
        }
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
    let path = b.write_gltf(&dir.join("scene.gltf"));
    std::fs::write(
        dir.join("scene.materials.json"),
        r#"{ "version": 1, "world": { "color": [1.0, 1.0, 1.0], "strength": 1.0 } }"#,
    )
    .unwrap();
    path
}

/// Mean green of the left and right thirds of the quad's middle rows.
fn halves(path: &Path) -> (f32, f32) {
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
        let mut sum = 0.0;
        let mut n = 0;
        for y in 18..30 {
            for x in cols.clone() {
                sum += px[y * SIZE as usize + x][1];
                n += 1;
            }
        }
        sum / n as f32
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
