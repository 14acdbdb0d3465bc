//! Adaptive sampling: converged pixels stop (a flat lit floor early, a caustic keeps
//! sampling), the expectation does not change (white furnace), and the render stays
//! deterministic for any thread count.

mod common;

use common::scenes::{
    diffuse_material, emissive_material, furnace_scene, glass_material, quad_mesh, sphere_mesh,
};
use glam::{Mat4, Vec3};
use prism::render::{render_quiet, AdaptiveSampling, RenderSettings};
use prism::scene::{InstanceDesc, IorDesc, Scene, SceneDesc};

/// A floor lit by a small square emitter through a glass ball (a caustic below the ball),
/// seen from the side and above.
fn caustic_scene() -> SceneDesc {
    let light = emissive_material("light", Vec3::splat(150.0), false);
    let mut ball = sphere_mesh(1, 64, 32);
    ball.name = "ball".into();
    let mut cam = common::scenes::camera(0.0, 0.7);
    // Looking from `eye` at `target` (the camera looks down its -z, +y up).
    let (eye, target) = (Vec3::new(0.0, 1.4, 3.0), Vec3::new(0.0, 0.2, 0.0));
    let f = (target - eye).normalize();
    let r = f.cross(Vec3::Y).normalize();
    let u = r.cross(f);
    cam.camera_to_world = Mat4::from_cols(
        r.extend(0.0),
        u.extend(0.0),
        (-f).extend(0.0),
        eye.extend(1.0),
    );
    SceneDesc {
        meshes: vec![
            quad_mesh("floor", Vec3::ZERO, Vec3::X * 4.0, Vec3::Z * -4.0, 0),
            ball,
            // Facing down (x cross z = -y).
            quad_mesh(
                "light",
                Vec3::new(0.0, 4.0, 0.0),
                Vec3::X * 0.15,
                Vec3::Z * 0.15,
                2,
            ),
        ],
        instances: vec![
            InstanceDesc {
                mesh: 0,
                object_to_world: Mat4::IDENTITY,
                name: "floor".into(),
            },
            InstanceDesc {
                mesh: 1,
                object_to_world: Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0))
                    * Mat4::from_scale(Vec3::splat(0.5)),
                name: "ball".into(),
            },
            InstanceDesc {
                mesh: 2,
                object_to_world: Mat4::IDENTITY,
                name: "light".into(),
            },
        ],
        materials: vec![
            diffuse_material("floor", Vec3::splat(0.5)),
            glass_material("glass", IorDesc::Constant(1.5), 0.0),
            light,
        ],
        camera: Some(cam),
        ..Default::default()
    }
}

/// Mean samples per pixel of a film's window `rows` x `cols`.
fn mean_samples(
    film: &prism::film::Film,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
) -> f64 {
    let w = film.width as usize;
    let n = (rows.len() * cols.len()) as f64;
    rows.flat_map(|y| cols.clone().map(move |x| y * w + x))
        .map(|i| film.pixels[i].samples as f64)
        .sum::<f64>()
        / n
}

fn settings(spp: u32, adaptive: Option<AdaptiveSampling>) -> RenderSettings {
    RenderSettings {
        width: 48,
        height: 48,
        spp,
        max_depth: 8,
        seed: 3,
        adaptive,
        // Samples of one cost: these tests are about where adaptive sampling puts them, and
        // the planned splitting (`integrator::splitting`) would make a sample's cost and
        // variance differ from pixel to pixel.
        splits: Some(1),
        ..Default::default()
    }
}

#[test]
fn flat_pixels_stop_early_and_the_caustic_keeps_sampling() {
    let scene = Scene::build(caustic_scene()).expect("scene builds");
    let adaptive = AdaptiveSampling {
        threshold: 0.02,
        min_samples: 16,
    };
    let (film, stats) = render_quiet(&scene, &settings(512, Some(adaptive)));
    assert_eq!(stats.discarded, 0);
    // Regions of the 48 x 48 image: the open floor in front (rows 40-47, lit directly, flat),
    // the caustic and the ball (rows 26-31, columns 18-29) and the black sky (top corners).
    let floor = mean_samples(&film, 40..48, 0..48);
    let caustic = mean_samples(&film, 26..32, 18..30);
    let sky = mean_samples(&film, 0..4, 0..8);
    println!(
        "mean spp: floor {floor:.1}, caustic {caustic:.1}, sky {sky:.1} (total {})",
        stats.samples
    );
    assert!(
        floor < 150.0,
        "the flat floor took {floor:.1} spp on average (max 512)"
    );
    assert!(
        caustic > 200.0 && caustic > 5.0 * floor,
        "caustic {caustic:.1} vs floor {floor:.1}"
    );
    assert_eq!(sky, 16.0, "the black sky stops at the minimum");
    // Every pixel got at least the minimum, none more than the maximum.
    assert!(film.pixels.iter().all(|p| (16..=512).contains(&p.samples)));
    assert!(
        stats.samples < 48 * 48 * 512 / 2,
        "adaptive sampling saved little"
    );
}

#[test]
fn adaptive_sampling_keeps_the_furnace_mean() {
    // A diffuse sphere of albedo 0.8 in a uniform white world: every pixel is exactly 1
    // (background) or 0.8 (sphere, white furnace); adaptive sampling must not move the mean.
    let desc = || furnace_scene(diffuse_material("grey", Vec3::splat(0.8)), Vec3::ONE);
    let scene = Scene::build(desc()).expect("scene builds");
    let adaptive = AdaptiveSampling {
        threshold: 0.01,
        min_samples: 16,
    };
    let s = RenderSettings {
        width: 32,
        height: 32,
        spp: 256,
        max_depth: 64,
        seed: 1,
        adaptive: Some(adaptive),
        ..Default::default()
    };
    let (film, stats) = render_quiet(&scene, &s);
    let fixed = render_quiet(
        &scene,
        &RenderSettings {
            adaptive: None,
            ..s.clone()
        },
    )
    .0;
    let mean = |f: &prism::film::Film| {
        f.pixels.iter().map(|p| p.rgb()).sum::<Vec3>() / f.pixels.len() as f32
    };
    let (m_adaptive, m_fixed) = (mean(&film), mean(&fixed));
    println!(
        "furnace mean adaptive {m_adaptive} ({} samples), fixed {m_fixed}",
        stats.samples
    );
    assert!(stats.samples < 32 * 32 * 256, "nothing converged");
    for c in 0..3 {
        assert!(
            (m_adaptive[c] - m_fixed[c]).abs() < 2e-3,
            "{m_adaptive} vs {m_fixed}"
        );
    }
    // Sphere pixels are 0.8, background 1 (the centre and a corner).
    assert!((film.pixels[16 * 32 + 16].rgb().y - 0.8).abs() < 0.02);
    assert!((film.pixels[0].rgb().y - 1.0).abs() < 0.01);
}

#[test]
fn adaptive_renders_are_identical_for_any_thread_count() {
    let scene = Scene::build(caustic_scene()).expect("scene builds");
    let adaptive = Some(AdaptiveSampling {
        threshold: 0.03,
        min_samples: 0,
    });
    let render = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render_quiet(&scene, &settings(128, adaptive)).0.to_rgba())
    };
    let one = render(1);
    assert!(one == render(2), "1 and 2 threads differ");
    assert!(one == render(3), "1 and 3 threads differ");
}

/// A grey floor under a white sky, seen from above, with a low wall across it: next to the
/// wall a pixel's sky rays are blocked or not (the noise of ambient occlusion), far from it
/// nearly all reach the sky (cosine sampling of a uniform sky: almost no noise). No fireflies:
/// every estimate is bounded, so an image's error is a stable measure.
fn low_wall_scene() -> SceneDesc {
    SceneDesc {
        meshes: vec![
            // Facing the camera (+z).
            quad_mesh("floor", Vec3::ZERO, Vec3::X * 3.0, Vec3::Y * 3.0, 0),
            // Across the floor at x = 0.6, 0.2 high (facing +x).
            quad_mesh(
                "wall",
                Vec3::new(0.6, 0.0, 0.1),
                Vec3::Y * 3.0,
                Vec3::Z * 0.1,
                0,
            ),
        ],
        instances: common::scenes::instances_in_place(&["floor", "wall"]),
        materials: vec![diffuse_material("grey", Vec3::splat(0.5))],
        camera: Some(common::scenes::camera(3.0, 0.9)),
        world: prism::scene::WorldDesc {
            color: Vec3::ONE,
            strength: 1.0,
            texture: None,
        },
        ..Default::default()
    }
}

/// Past the warm-up, passes go to the pixels where samples lower the error most: a render cut
/// at a budget of samples (here: cancelled after the pass that reaches it) has a lower error
/// than a fixed render with as many samples spread evenly, and the pixels beside the wall
/// hold more samples than the open floor.
#[test]
fn a_cut_adaptive_render_put_its_samples_where_the_error_falls_most() {
    let scene = Scene::build(low_wall_scene()).expect("scene builds");
    let pixels = 48 * 48;
    let reference = render_quiet(&scene, &settings(4096, None)).0.to_rgba();
    // A threshold no pixel reaches: only the order of the samples is at work.
    let adaptive = AdaptiveSampling {
        threshold: 1e-4,
        min_samples: 0,
    };
    let budget = (pixels * 32) as u64;
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let (film, _) = prism::render::render(
        &scene,
        &settings(4096, Some(adaptive)),
        &cancel,
        &|_| {},
        &mut |film, _| {
            let done: u64 = film.pixels.iter().map(|p| p.samples as u64).sum();
            if done >= budget {
                cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        },
    );
    let spent: u64 = film.pixels.iter().map(|p| p.samples as u64).sum();
    // The even film takes at least as many samples.
    let even_spp = spent.div_ceil(pixels as u64) as u32;
    let even = render_quiet(&scene, &settings(even_spp, None)).0.to_rgba();
    let (prioritised, uniform) = (
        common::scenes::rel_mse(&film.to_rgba(), &reference),
        common::scenes::rel_mse(&even, &reference),
    );
    // Columns 0-7 of the image are the floor far left of the wall (x < -1.2), 30-33 beside it.
    let (open, beside) = (
        mean_samples(&film, 8..40, 0..8),
        mean_samples(&film, 8..40, 30..34),
    );
    println!(
        "relMSE {prioritised:.3e} prioritised ({spent} samples) vs {uniform:.3e} even \
         ({even_spp} spp); spp: open floor {open:.1}, beside the wall {beside:.1}"
    );
    assert!(
        prioritised < 0.8 * uniform,
        "prioritised {prioritised:.3e} vs even {uniform:.3e}"
    );
    assert!(
        beside > 2.0 * open,
        "beside the wall {beside:.1} vs open floor {open:.1}"
    );
}
