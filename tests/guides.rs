//! Denoising guides / Blender passes (`--guides`): albedo, normal and depth of the first
//! non-Dirac surface, checked against the analytic values of a sphere seen head-on, through
//! the EXR file the binary writes.

mod common;

use common::scenes::{diffuse_material, furnace_scene, glass_material};
use glam::Vec3;
use prism::film::{read_exr_channel, read_exr_rgba, BACKGROUND_DEPTH};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{IorDesc, Scene, SceneDesc};

const SIZE: u32 = 32;

fn render_guides(desc: SceneDesc, name: &str) -> std::path::PathBuf {
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 64,
        max_depth: 8,
        seed: 1,
        guides: true,
        ..Default::default()
    };
    let (mut film, _) = render_quiet(&scene, &settings);
    film.write_guides = true;
    let path = std::env::temp_dir().join(format!("prism_guides_{}_{name}.exr", std::process::id()));
    film.write_exr(&path).expect("EXR written");
    path
}

fn channel(path: &std::path::Path, name: &str) -> Vec<f32> {
    let (w, h, data) = read_exr_channel(path, name).expect(name);
    assert_eq!((w, h), (SIZE, SIZE));
    data
}

fn at(data: &[f32], x: u32, y: u32) -> f32 {
    data[(y * SIZE + x) as usize]
}

#[test]
fn sphere_guides_match_geometry() {
    // Unit sphere at the origin, camera at z = 3 looking down -z, yfov 0.8.
    let albedo = Vec3::new(0.6, 0.3, 0.15);
    let path = render_guides(
        furnace_scene(diffuse_material("clay", albedo), Vec3::splat(0.5)),
        "diffuse",
    );
    let (ar, ag, ab) = (
        channel(&path, "Albedo.R"),
        channel(&path, "Albedo.G"),
        channel(&path, "Albedo.B"),
    );
    let (nx, ny, nz) = (
        channel(&path, "Normal.X"),
        channel(&path, "Normal.Y"),
        channel(&path, "Normal.Z"),
    );
    let depth = channel(&path, "Depth.Z");
    let c = SIZE / 2;
    // Centre: the sphere's front pole, depth 3 - 1 = 2, normal +z, albedo = base colour
    // (upsampled and integrated under white light: within the round trip error of 1%).
    // Spectral noise of one pixel is a few percent: average the central 4x4 block (the
    // sphere's colour is uniform there).
    let block = |data: &[f32]| -> f32 {
        let mut sum = 0.0;
        for y in c - 2..c + 2 {
            for x in c - 2..c + 2 {
                sum += at(data, x, y);
            }
        }
        sum / 16.0
    };
    for (got, want) in [
        (block(&ar), albedo.x),
        (block(&ag), albedo.y),
        (block(&ab), albedo.z),
    ] {
        assert!((got - want).abs() < 0.015, "albedo {got} vs {want}");
    }
    assert!(
        (at(&depth, c, c) - 2.0).abs() < 0.01,
        "depth {}",
        at(&depth, c, c)
    );
    let n = Vec3::new(at(&nx, c, c), at(&ny, c, c), at(&nz, c, c));
    assert!(n.dot(Vec3::Z) > 0.99, "normal {n}");
    // A pixel on the sphere off-centre: the normal of the visible point, and depth along the
    // view axis (not the ray length).
    let (px, py) = (c + 6, c);
    let tan_half = (0.4f32).tan();
    let ndc_x = 2.0 * (px as f32 + 0.5) / SIZE as f32 - 1.0;
    let dir = Vec3::new(ndc_x * tan_half, 0.0, -1.0).normalize();
    let origin = Vec3::new(0.0, 0.0, 3.0);
    // Ray-sphere intersection.
    let b = origin.dot(dir);
    let t = -b - (b * b - (origin.length_squared() - 1.0)).sqrt();
    let hit = origin + dir * t;
    let n = Vec3::new(at(&nx, px, py), at(&ny, px, py), at(&nz, px, py));
    assert!(
        n.dot(hit.normalize()) > 0.995,
        "normal {n} vs {}",
        hit.normalize()
    );
    let z = 3.0 - hit.z;
    assert!(
        (at(&depth, px, py) - z).abs() < 0.02,
        "depth {} vs {z}",
        at(&depth, px, py)
    );
    // Corner: background.
    assert_eq!(at(&depth, 0, 0), BACKGROUND_DEPTH);
    assert_eq!(at(&ar, 0, 0), 0.0);
    assert_eq!(
        Vec3::new(at(&nx, 0, 0), at(&ny, 0, 0), at(&nz, 0, 0)),
        Vec3::ZERO
    );
    // The beauty pass is unchanged by the extra channels.
    let (_, _, rgba) = read_exr_rgba(&path).expect("rgba");
    assert!(rgba[(c * SIZE + c) as usize][0] > 0.0);
    std::fs::remove_file(&path).ok();
}

#[test]
fn glass_guides_see_through_to_the_next_surface() {
    // A smooth glass sphere: the guides follow the Dirac refraction and find nothing behind
    // (the world), so the albedo is 0 and the normal 0, while the depth is the glass itself.
    let glass = glass_material("glass", IorDesc::Constant(1.5), 0.0);
    let path = render_guides(furnace_scene(glass, Vec3::ONE), "glass");
    let c = SIZE / 2;
    assert!((at(&channel(&path, "Depth.Z"), c, c) - 2.0).abs() < 0.01);
    assert!(at(&channel(&path, "Albedo.G"), c, c).abs() < 1e-6);
    std::fs::remove_file(&path).ok();
}
