//! Valid glTF that the `gltf` crate's validation or JSON model refuses, and files whose unused
//! parts are broken, render (issue 16): the corpus in tests/data/lenient/ (regenerate with
//! `python3 make_corpus.py` there) through the binary, exit 0, exactly the expected warnings,
//! and the centre pixels showing the data that must have been read. The invalid counterparts
//! (broken parts that drawn geometry uses) are in the malformed corpus (tests/malformed_input.rs).

use prism::film::read_exr_rgba;
use prism::scene::{load_scene, IorDesc, IOR_ZERO_LIMIT};
use std::path::{Path, PathBuf};
use std::process::Command;

fn corpus(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/lenient")
        .join(name)
}

/// Renders `scene` (16 x 12, 8 spp): (exit code, warning lines, pixels).
fn render(scene: &Path) -> (Option<i32>, Vec<String>, Vec<[f32; 4]>, String) {
    let out_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("lenient_gltf");
    std::fs::create_dir_all(&out_dir).unwrap();
    let out = out_dir
        .join(scene.file_stem().unwrap())
        .with_extension("exr");
    let o = Command::new(env!("CARGO_BIN_EXE_prism"))
        .arg("render")
        .arg(scene)
        .args(["--width", "16", "--height", "12", "--spp", "8"])
        .args(["--threads", "2", "--progress", "none", "-o"])
        .arg(&out)
        .output()
        .expect("prism runs");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let warnings = stderr
        .lines()
        .filter_map(|l| l.strip_prefix("prism: warning: "))
        .map(str::to_string)
        .collect();
    let px = if o.status.success() {
        read_exr_rgba(&out).expect("EXR written").2
    } else {
        Vec::new()
    };
    (o.status.code(), warnings, px, stderr)
}

/// The mean of the 4 x 2 centre pixels, which see only the quad's emission.
fn centre(px: &[[f32; 4]]) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    let mut n = 0.0;
    for y in 5..7 {
        for x in 6..10 {
            for c in 0..3 {
                sum[c] += px[y * 16 + x][c];
            }
            n += 1.0;
        }
    }
    sum.map(|s| s / n)
}

/// (file, warning fragments: one per expected warning line, in order; centre radiance).
const CASES: &[(&str, &[&str], [f32; 3])] = &[
    ("integers_as_floats.gltf", &[], [2.0, 2.0, 2.0]),
    ("zero_and_sparse_accessors.gltf", &[], [2.0, 2.0, 2.0]),
    // sRGB (51, 153, 255) in linear, times emissiveStrength 2; the PNG fallback is red.
    ("webp_texture.gltf", &[], [0.0664, 0.6370, 2.0]),
    (
        "ktx2_texture.gltf",
        &[
            "extensions not supported and ignored: KHR_texture_basisu",
            "material 'Glow': emissiveTexture: texture 0 is not used because its image is only given through KHR_texture_basisu",
        ],
        [1.0, 0.5, 2.0],
    ),
    ("ior_zero.gltf", &[], [2.0, 2.0, 2.0]),
    (
        "unknown_light_type.gltf",
        &["KHR_lights_punctual light 0 (on node 'Lamp0'): type 'area_future' is not known to this renderer; skipped"],
        [2.0, 2.0, 2.0],
    ),
    (
        "animation_pointer.gltf",
        &[
            "1 animation ignored: the scene is rendered in its rest pose",
            "extensions not supported and ignored: KHR_animation_pointer",
        ],
        [2.0, 2.0, 2.0],
    ),
    (
        "unused_broken_parts.gltf",
        &["materials[1].pbrMetallicRoughness.baseColorTexture.index: index 9 out of range (0 textures)"],
        [2.0, 2.0, 2.0],
    ),
    (
        "primitive_without_position.gltf",
        &["mesh 'Quad' primitive 1: no POSITION attribute; not rendered"],
        [2.0, 2.0, 2.0],
    ),
    ("morph_targets.gltf", &[], [2.0, 2.0, 2.0]),
    // Two half-size instances beside an empty centre (the instances are checked below).
    ("gpu_instancing.gltf", &[], [0.0, 0.0, 0.0]),
    (
        "unknown_required_extension.gltf",
        &["extensions not supported and ignored: EXT_future_material"],
        [2.0, 2.0, 2.0],
    ),
];

#[test]
fn valid_and_unused_broken_files_render_with_the_expected_warnings_and_pixels() {
    let mut failures = Vec::new();
    for (file, fragments, want) in CASES {
        let (code, warnings, px, stderr) = render(&corpus(file));
        if code != Some(0) {
            failures.push(format!("{file}: exit {code:?}: {stderr}"));
            continue;
        }
        let matched = warnings.len() == fragments.len()
            && warnings
                .iter()
                .zip(fragments.iter())
                .all(|(w, f)| w.contains(f));
        if !matched {
            failures.push(format!(
                "{file}: warnings {warnings:?}, expected {fragments:?}"
            ));
        }
        assert!(px.iter().all(|p| p.iter().all(|v| v.is_finite())));
        // Emission seen directly: exact up to the RGB -> spectrum -> RGB round trip and the
        // hero wavelengths' colour noise at 8 spp (3%, or 0.01 absolute for dark channels).
        let got = centre(&px);
        for c in 0..3 {
            if (got[c] - want[c]).abs() > 0.03 * want[c] + 0.01 {
                failures.push(format!("{file}: centre {got:?}, expected {want:?}"));
                break;
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// KHR_materials_ior `ior = 0` stays 0 for the glTF BRDF (F0 = ((0 - 1) / (0 + 1))^2 = 1) and
/// refracts as a dielectric of IOR_ZERO_LIMIT; EXT_mesh_gpu_instancing makes one instance per
/// entry; the unknown light is skipped, the point kept.
#[test]
fn ior_zero_gpu_instances_and_unknown_lights_load_as_the_extensions_say() {
    let scene = load_scene(&corpus("ior_zero.gltf"), None, None).unwrap();
    let g = &scene.materials[0].gltf;
    assert_eq!(g.ior, 0.0);
    assert!(matches!(g.ior_model(), IorDesc::Constant(n) if n == IOR_ZERO_LIMIT));

    let scene = load_scene(&corpus("gpu_instancing.gltf"), None, None).unwrap();
    let at: Vec<[f32; 4]> = scene
        .instances
        .iter()
        .map(|i| {
            let m = i.object_to_world;
            [m.w_axis.x, m.w_axis.y, m.w_axis.z, m.x_axis.x]
        })
        .collect();
    assert_eq!(at, vec![[-0.8, 0.0, 0.0, 0.5], [0.8, 0.0, 0.0, 0.5]]);

    let scene = load_scene(&corpus("unknown_light_type.gltf"), None, None).unwrap();
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(scene.lights[0].name, "Lamp1");
}
