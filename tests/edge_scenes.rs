//! Valid scenes at the edges render, with a warning, instead of being refused (as Blender
//! renders them): a scene without geometry shows the world (an HDRI look-development render),
//! and a scene without any light is black. Through the binary: exit 0, the warning on stderr,
//! the image checked pixel by pixel.

#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use gltf_builder::{test_dir, GltfBuilder};
use prism::film::read_exr_rgba;
use serde_json::json;
use std::path::Path;
use std::process::Command;

/// Renders `scene` (16 x 12, 8 spp) and returns (exit code, stderr, pixels).
fn render(scene: &Path, out: &Path) -> (Option<i32>, String, Vec<[f32; 4]>) {
    let o = Command::new(env!("CARGO_BIN_EXE_prism"))
        .arg("render")
        .arg(scene)
        .args([
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "8",
            "--threads",
            "2",
        ])
        .args(["--progress", "none", "-o"])
        .arg(out)
        .output()
        .expect("prism runs");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let px = if o.status.success() {
        read_exr_rgba(out).expect("EXR written").2
    } else {
        Vec::new()
    };
    (o.status.code(), stderr, px)
}

fn warnings(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.starts_with("prism: warning: "))
        .collect()
}

#[test]
fn a_world_without_geometry_renders_the_world() {
    let dir = test_dir("edge_world_only");
    let mut b = GltfBuilder::new();
    let c = b.camera("CameraData", 0.7, Some(16.0 / 12.0));
    b.root(json!({ "name": "Camera", "camera": c }));
    let gltf = b.write_gltf(&dir.join("world.gltf"));
    std::fs::write(
        dir.join("world.materials.json"),
        r#"{"version": 1, "world": {"color": [0.2, 0.3, 0.4], "strength": 1.5}}"#,
    )
    .unwrap();
    let (code, stderr, px) = render(&gltf, &dir.join("world.exr"));
    assert_eq!(code, Some(0), "{stderr}");
    let w = warnings(&stderr);
    assert!(
        w.len() == 1 && w[0].contains("no renderable geometry"),
        "{stderr}"
    );
    // Every pixel sees the world: radiance 1.5 x (0.2, 0.3, 0.4). Each pixel's colour carries
    // spectral noise; the image mean is exact to the RGB round trip (< 1%).
    let want = [0.3f32, 0.45, 0.6];
    for c in 0..3 {
        let mean = px.iter().map(|p| p[c]).sum::<f32>() / px.len() as f32;
        assert!(
            (mean - want[c]).abs() < 0.01 * want[c],
            "channel {c}: {mean} vs {}",
            want[c]
        );
        assert!(px.iter().all(|p| (p[c] - want[c]).abs() < 0.15 * want[c]));
    }
    assert!(px.iter().all(|p| p[3] == 1.0));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scenes_without_light_or_geometry_are_black_with_a_warning() {
    let edge = Path::new("tests/data/edge");
    let dir = test_dir("edge_black");
    // Only degenerate triangles (an emissive material on them): no geometry and no light.
    let (code, stderr, px) = render(&edge.join("degenerate_only.gltf"), &dir.join("d.exr"));
    assert_eq!(code, Some(0), "{stderr}");
    let w = warnings(&stderr);
    assert_eq!(w.len(), 2, "{stderr}");
    assert!(w.iter().any(|l| l.contains("no renderable geometry")));
    assert!(w.iter().any(|l| l.contains("no light")));
    assert!(px.len() == 16 * 12 && px.iter().all(|p| p[..3] == [0.0; 3] && p[3] == 1.0));
    // Geometry, but nothing emits and the world is black.
    let (code, stderr, px) = render(&edge.join("zero_lights.gltf"), &dir.join("z.exr"));
    assert_eq!(code, Some(0), "{stderr}");
    let w = warnings(&stderr);
    assert!(
        w.len() == 1 && w[0].contains("the image is black"),
        "{stderr}"
    );
    assert!(px.len() == 16 * 12 && px.iter().all(|p| p[..3] == [0.0; 3]));
    std::fs::remove_dir_all(&dir).ok();
}
