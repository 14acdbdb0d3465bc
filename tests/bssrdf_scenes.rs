//! The committed subsurface scenes (scenes/sss/) load with their sidecars, build every
//! subsurface material without warnings and render finite images (both methods).

use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, Scene};
use std::path::Path;

#[test]
fn sss_scenes_load_and_render_finite() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sss");
    for (name, subsurface_materials) in [
        ("cornell_sss", 3),
        ("cornell_walk", 3),
        ("cornell_diffuse", 0),
        ("skin_pair", 1),
        ("media_trio", 3),
    ] {
        let desc = load_scene(&dir.join(format!("{name}.gltf")), None, None)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let scene = Scene::build(desc).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(scene.warnings.is_empty(), "{name}: {:?}", scene.warnings);
        let n = scene.materials.iter().filter(|m| m.is_subsurface()).count();
        assert_eq!(n, subsurface_materials, "{name}");
        let settings = RenderSettings {
            width: 24,
            height: 24,
            spp: 4,
            max_depth: 16,
            seed: 3,
            ..Default::default()
        };
        let (film, stats) = render_quiet(&scene, &settings);
        assert_eq!(stats.discarded, 0, "{name}");
        let rgba = film.to_rgba();
        assert!(rgba.iter().flatten().all(|v| v.is_finite()), "{name}");
        let mean: f32 = rgba.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / rgba.len() as f32;
        assert!(mean > 0.01, "{name}: black image");
    }
}
