//! The on-disk BVH cache (`geometry::bvh_cache`, `--bvh-cache`): a second build of the same
//! mesh is a hit and renders bit-identically to the built BVH; a corrupted entry is a miss that
//! rebuilds (same image, no panic); a changed mesh gets its own entry.

mod common;

use common::scenes::{diffuse_material, furnace_scene, sphere_mesh};
use glam::Vec3;
use prism::geometry::bvh_cache;
use prism::render::{render_quiet, RenderSettings};
use prism::scene::Scene;
use rayon::prelude::*;

fn render(desc: prism::scene::SceneDesc) -> Vec<[f32; 4]> {
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 4,
        max_depth: 4,
        seed: 5,
        ..Default::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let image = pool.install(|| render_quiet(&scene, &settings)).0.to_rgba();
    // Entries are written in the background; the assertions below look at the directory.
    bvh_cache::wait_for_stores();
    image
}

fn scene(segments: u32) -> prism::scene::SceneDesc {
    let mut desc = furnace_scene(diffuse_material("grey", Vec3::splat(0.5)), Vec3::ONE);
    desc.meshes[0] = sphere_mesh(0, segments, segments / 2);
    desc
}

#[test]
fn cached_bvh_renders_identically_and_corruption_rebuilds() {
    let dir = std::env::temp_dir().join(format!("prism_bvh_cache_test_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    bvh_cache::set_cache_dir(&dir).unwrap();

    let (h0, m0) = bvh_cache::counters();
    let built = render(scene(96));
    let (h1, m1) = bvh_cache::counters();
    assert_eq!((h1 - h0, m1 - m0), (0, 1), "first build is a miss");
    let entries: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().collect();
    assert_eq!(entries.len(), 1, "one entry written");

    let cached = render(scene(96));
    let (h2, m2) = bvh_cache::counters();
    assert_eq!((h2 - h1, m2 - m1), (1, 0), "second build is a hit");
    assert_eq!(built, cached, "the cached BVH renders bit-identically");

    // Corrupt the entry: a miss, rebuilt, same image.
    let path = entries[0].path();
    let mut bytes = std::fs::read(&path).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(&path, &bytes).unwrap();
    let rebuilt = render(scene(96));
    let (h3, m3) = bvh_cache::counters();
    assert_eq!((h3 - h2, m3 - m2), (0, 1), "a corrupted entry is a miss");
    assert_eq!(built, rebuilt);

    // Another mesh: its own entry.
    render(scene(64));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);

    // Many meshes at once (built in parallel, as a scene's are): one queued writer stores
    // them all; nothing is left half written.
    let meshes: Vec<prism::geometry::Mesh> = (0..30)
        .into_par_iter()
        .map(|k| {
            let (p, _, t) = prism::geometry::shapes::uv_sphere(8 + k, 6);
            prism::geometry::Mesh::new(p, None, None, t, 0)
        })
        .collect();
    bvh_cache::wait_for_stores();
    assert_eq!(meshes.len(), 30);
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 32, "{names:?}");
    assert!(names.iter().all(|n| n.ends_with(".bvh")), "{names:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
