//! Splitting camera paths at their first vertex (`PathTracer::radiance_split`,
//! `integrator::splitting`): the branches' sample values, unbiasedness (white furnace, the
//! Cornell box's mean), the noise it removes, the plan, and determinism.

mod common;

use common::is_net;

use common::scenes::{diffuse_material, emissive_material, furnace_scene, quad_mesh};
use glam::{Vec2, Vec3};
use prism::integrator::path::PathTracer;
use prism::integrator::splitting::{optimal_splits, BlockVariance, Branches, MAX_SPLITS};
use prism::lights::LightSelection;
use prism::render::{render_quiet, RenderSettings};
use prism::sampler::{ImageSampler, SamplerKind};
use prism::scene::{load_scene, Scene, SceneDesc, WorldDesc};
use std::path::Path;

#[test]
fn every_branch_and_all_branches_of_a_pixel_are_nets() {
    // 64 spp: the BSDF directions of bounce 0 (read after the split) of one branch over a
    // pixel's 64 samples are a (0, 6, 2)-net, those of the first two branches a (0, 7, 2)-net
    // and of all four a (0, 8, 2)-net; as are the light-sample points.
    let image = ImageSampler::new(SamplerKind::Sobol, 64, 11);
    for (x, y) in [(0, 0), (5, 9), (200, 31), (1023, 1000)] {
        let pixel = image.pixel(x, y, 1024);
        let points = |j: u32, light: bool| -> Vec<Vec2> {
            (0..64)
                .map(|i| {
                    let mut shared = pixel.sample(i);
                    shared.pixel_filter();
                    shared.wavelength();
                    shared.start_bounce(0);
                    shared.material_component();
                    let mut branch = shared.branch(j);
                    if light {
                        branch.light().0
                    } else {
                        branch.bsdf().1
                    }
                })
                .collect()
        };
        for light in [false, true] {
            let mut all = Vec::new();
            for j in 0..MAX_SPLITS {
                let own = points(j, light);
                assert!(is_net(&own), "branch {j} of pixel ({x}, {y})");
                all.extend(own);
                if j == 1 {
                    assert!(is_net(&all), "branches 0-1 of pixel ({x}, {y})");
                }
            }
            assert!(is_net(&all), "all branches of pixel ({x}, {y})");
        }
    }
    // The splitting pilot's branches are independent scrambles of that sequence: each branch
    // over a pixel's samples is a net, and two branches' points are not the same net.
    let pixel = image.pixel(7, 2, 1024);
    let pilot_points = |j: u32| -> Vec<Vec2> {
        (0..64)
            .map(|i| {
                let mut shared = pixel.sample(i);
                shared.start_bounce(0);
                shared.independent_branch(j).light().0
            })
            .collect()
    };
    let (first, second) = (pilot_points(0), pilot_points(1));
    assert!(is_net(&first) && is_net(&second));
    assert!(first.iter().zip(&second).all(|(a, b)| a != b));
    // The branches are not the sample's own values (a second sequence), and the sample's own
    // values do not depend on whether it splits.
    let pixel = image.pixel(3, 4, 64);
    let mut a = pixel.sample(5);
    a.start_bounce(0);
    let mut b = a.branch(0);
    assert_ne!(a.clone().bsdf(), b.bsdf());
    assert_eq!(a.bsdf(), {
        let mut c = pixel.sample(5);
        c.start_bounce(0);
        c.bsdf()
    });
}

/// A block with variance `v_s` before the split and `v_p` per continuation, costs `c_s` and
/// `c_p`, and light samples that neither vary nor cost.
fn block(v_s: f64, v_p: f64, c_s: f64, c_p: f64) -> BlockVariance {
    BlockVariance {
        shared: v_s,
        path: v_p,
        shared_cost: c_s,
        path_cost: c_p,
        ..Default::default()
    }
}

#[test]
fn the_plan_splits_where_the_variance_comes_after_the_split() {
    let paths = |k: &[Branches]| k.iter().map(|b| b.paths as u32).collect::<Vec<_>>();
    // All variance after the split: as many branches as allowed.
    let k = optimal_splits(&[block(0.0, 1.0, 1.0, 4.0); 3]);
    assert!(paths(&k).iter().all(|&k| k == MAX_SPLITS), "{k:?}");
    // None after it: no splitting.
    let k = optimal_splits(&[block(1.0, 0.0, 1.0, 4.0); 3]);
    assert!(k.iter().all(|&k| k == Branches::ONE), "{k:?}");
    // A block whose branch variance is small next to another block's unsplittable variance
    // is not split, though on its own it would be (sqrt(V_p C_s / (V_s C_p)) = 3 there).
    let k = optimal_splits(&[block(0.01, 0.36, 1.0, 0.4), block(50.0, 0.0, 1.0, 1.0)]);
    assert_eq!(k, vec![Branches::ONE; 2]);
    let k = optimal_splits(&[block(0.01, 0.36, 1.0, 0.4)]);
    assert_eq!(paths(&k), vec![MAX_SPLITS.min(4)], "{k:?}");
    // Expensive branches split less than cheap ones of the same variance.
    let k = optimal_splits(&[block(0.1, 1.0, 1.0, 0.5), block(0.1, 1.0, 1.0, 8.0)]);
    assert!(k[0].paths > k[1].paths, "{k:?}");
}

#[test]
fn light_samples_and_continuations_split_by_their_own_variance() {
    // A block whose noise is its light samples' takes more of them and one continuation, one
    // whose noise is its continuations' the opposite (splitting both alike, as `--splits k`
    // does, pays for branches that remove no noise: on a floor lit by a gold ball's caustic,
    // one light sample and four continuations were 1.1-1.3x as efficient as four of each).
    let lit = |light, path| BlockVariance {
        shared: 0.05,
        light,
        path,
        shared_cost: 2.0,
        light_cost: 1.0,
        path_cost: 3.0,
    };
    let k = optimal_splits(&[lit(1.0, 0.0), lit(0.0, 1.0), lit(0.0, 0.0)]);
    assert!(k[0].lights > 1 && k[0].paths == 1, "{:?}", k[0]);
    assert!(k[1].paths > 1 && k[1].lights == 1, "{:?}", k[1]);
    assert_eq!(k[2], Branches::ONE);
}

#[test]
fn uneven_branches_keep_the_mean() {
    // The diffuse box's paths with one light sample and four continuations at the first
    // vertex, four and one, three and two: the same mean as plain paths (within 1%, 2 x 10^5
    // samples each), though next-event estimation and the continuations' hits of the light
    // are weighted by MIS for one sample of each.
    let scene = diffuse_box();
    let tracer = PathTracer::new(&scene, 8, LightSelection::Tree);
    let camera = scene.camera_for(16, 16);
    let pixels = ImageSampler::new(SamplerKind::Sobol, 1024, 7);
    let mean = |branches: Branches| {
        let mut sum = 0f64;
        for y in 0..16u32 {
            for x in 0..16u32 {
                let pixel = pixels.pixel(x, y, 16);
                for i in 0..768 {
                    let mut sampler = pixel.sample(i);
                    let raster = Vec2::new(x as f32, y as f32) + sampler.pixel_filter();
                    let w = prism::spectrum::SampledWavelengths::sample_hero(
                        sampler.wavelength().x,
                        Default::default(),
                    );
                    let ray = camera.generate_ray(raster, Vec2::ZERO).expect("ray");
                    let path = tracer.radiance_split(ray, None, &w, &mut sampler, branches);
                    sum += prism::spectrum::spectrum_to_xyz(&path.radiance, &w).y as f64;
                }
            }
        }
        sum / (256.0 * 768.0)
    };
    let plain = mean(Branches::ONE);
    for (lights, paths) in [(1, 4), (4, 1), (3, 2)] {
        let m = mean(Branches::new(lights, paths));
        assert!(
            (m - plain).abs() < 0.01 * plain,
            "{lights} light samples, {paths} continuations: mean {m}, plain {plain}"
        );
    }
}

fn settings(size: u32, spp: u32, seed: u64, splits: Option<u32>) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 16,
        seed,
        splits,
        ..Default::default()
    }
}

#[test]
fn split_paths_keep_the_furnace_white() {
    // A white diffuse sphere in a white world: every pixel is 1 with any number of branches
    // (and in the automatic plan), so the branches' mean carries the path's weight exactly.
    let scene = Scene::build(furnace_scene(
        diffuse_material("white", Vec3::ONE),
        Vec3::ONE,
    ))
    .unwrap();
    for splits in [Some(2), Some(3), Some(4), None] {
        let rgba = common::scenes::render_rgba(&scene, &settings(32, 32, 5, splits));
        let mean = common::scenes::mean_rgb(&rgba);
        for c in mean.to_array() {
            assert!((c - 1.0).abs() < 0.01, "splits {splits:?}: mean {mean}");
        }
    }
}

/// The repository's Cornell box (diffuse walls, a metal and a glass sphere, an area light).
fn cornell() -> Scene {
    let desc = load_scene(Path::new("scenes/cornell/cornell.gltf"), None, None).unwrap();
    Scene::build(desc).unwrap()
}

/// A closed diffuse box (white, red and green walls) lit by a square light under its ceiling,
/// seen from the open front: all its noise is interreflection after the first vertex and
/// the light's direct illumination.
fn diffuse_box() -> Scene {
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let desc = SceneDesc {
        meshes: vec![
            quad_mesh("floor", -y, z, x, 0),
            quad_mesh("ceiling", y, x, z, 0),
            quad_mesh("back", -z, x, y, 0),
            quad_mesh("left", -x, y, z, 1),
            quad_mesh("right", x, z, y, 2),
            quad_mesh("light", y * 0.99, x * 0.25, z * 0.25, 3),
        ],
        instances: common::scenes::instances_in_place(&[
            "floor", "ceiling", "back", "left", "right", "light",
        ]),
        materials: vec![
            diffuse_material("white", Vec3::splat(0.75)),
            diffuse_material("red", Vec3::new(0.7, 0.1, 0.1)),
            diffuse_material("green", Vec3::new(0.1, 0.7, 0.1)),
            emissive_material("light", Vec3::splat(15.0), false),
        ],
        camera: Some(common::scenes::camera(3.4, 0.7)),
        world: WorldDesc {
            color: Vec3::ZERO,
            strength: 0.0,
            texture: None,
        },
        ..Default::default()
    };
    Scene::build(desc).unwrap()
}

/// Variance between two renders per pixel and channel over (mean^2 + 0.01), averaged, with
/// the summed rays.
fn noise(scene: &Scene, splits: Option<u32>) -> (f64, u64) {
    let (a, sa) = render_quiet(scene, &settings(48, 32, 1, splits));
    let (b, sb) = render_quiet(scene, &settings(48, 32, 2, splits));
    let (a, b) = (a.to_rgba(), b.to_rgba());
    let mut sum = 0.0;
    for (p, q) in a.iter().zip(&b) {
        for c in 0..3 {
            let m = 0.5 * (p[c] + q[c]) as f64;
            sum += ((p[c] - q[c]) as f64).powi(2) / 2.0 / (m * m + 0.01);
        }
    }
    (sum / (3 * a.len()) as f64, sa.rays + sb.rays)
}

#[test]
fn splitting_removes_the_noise_after_the_first_vertex_and_keeps_the_mean() {
    // A diffuse box's noise is mostly after the first vertex: four branches per path leave
    // 0.53x of it (48 x 48 pixels, 32 spp, one pair; the light seen directly, and its edges,
    // are the rest). The plan splits less (0.95x measured): its blocks' variances are
    // relative to the block's mean, which makes the light's edges weigh as noise no splitting
    // removes (conservative on purpose, see `integrator::splitting`). The image's mean stays
    // within 1% of the unsplit one's.
    let scene = diffuse_box();
    let (plain, plain_rays) = noise(&scene, Some(1));
    let (four, _) = noise(&scene, Some(4));
    let (auto, auto_rays) = noise(&scene, None);
    eprintln!("noise: plain {plain:.5}, 4 branches {four:.5}, planned {auto:.5}");
    assert!(four < 0.65 * plain, "4 branches: {four} against {plain}");
    assert!(auto < plain, "planned: {auto} against {plain}");
    assert!(auto_rays > plain_rays, "the plan did not split");
    let mean = |splits| {
        let (film, _) = render_quiet(&scene, &settings(32, 1024, 3, splits));
        common::scenes::mean_rgb(&film.to_rgba())
    };
    let (m1, m4) = (mean(Some(1)), mean(Some(4)));
    for c in 0..3 {
        assert!(
            (m4[c] - m1[c]).abs() < 0.01 * m1[c],
            "mean {m4} with 4 branches, {m1} without"
        );
    }
}

#[test]
fn planned_splitting_is_the_same_for_any_thread_count() {
    let scene = cornell();
    let render = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let (film, stats) = pool.install(|| render_quiet(&scene, &settings(40, 24, 9, None)));
        let bits: Vec<u32> = film
            .to_rgba()
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect();
        (bits, stats.rays)
    };
    let (one, rays_one) = render(1);
    let (two, rays_two) = render(2);
    assert!(one == two, "1-thread and 2-thread renders differ");
    assert_eq!(rays_one, rays_two);
    let (_, plain_rays) = render_quiet(&scene, &settings(40, 24, 9, Some(1)));
    let plain_rays = plain_rays.rays;
    assert!(
        rays_two > plain_rays,
        "the plan did not split ({rays_two} rays)"
    );
}

#[test]
fn a_window_takes_the_full_renders_plan_and_pixels() {
    // A crop plans from the whole image's pilot samples: every pixel of the window equals
    // the full render's, bit for bit, with planned splitting (32 spp).
    let scene = diffuse_box();
    let full = settings(40, 32, 4, None);
    let crop = RenderSettings {
        crop: Some(prism::render::Crop {
            x: 9,
            y: 5,
            width: 17,
            height: 22,
        }),
        ..full.clone()
    };
    let (a, stats) = render_quiet(&scene, &full);
    let (b, _) = render_quiet(&scene, &crop);
    let (_, plain) = render_quiet(&scene, &settings(40, 32, 4, Some(1)));
    assert!(stats.rays > plain.rays, "the plan did not split");
    let (a, b) = (a.to_rgba(), b.to_rgba());
    for y in 0..22 {
        for x in 0..17 {
            assert_eq!(
                a[(y + 5) * 40 + x + 9].map(f32::to_bits),
                b[y * 17 + x].map(f32::to_bits),
                "pixel ({x}, {y}) of the window"
            );
        }
    }
}
