//! The low-discrepancy sampler: stratification of every pixel's points, uniformity and
//! decorrelation of all dimensions, and what it buys on a render (a diffuse plane under an
//! area light at 16 spp against independent random numbers).

mod common;

use common::is_net;

use common::scenes::{diffuse_material, emissive_material, quad_mesh};
use glam::{Mat4, Vec2, Vec3};
use prism::render::{render_quiet, RenderSettings};
use prism::sampler::{ImageSampler, Sampler, SamplerKind};
use prism::scene::{InstanceDesc, Scene, SceneDesc};

const SPP: u32 = 64;

/// Every 2D point of one path that the layout defines (camera, then bounces 0 and 5).
fn points_2d(s: &mut Sampler) -> Vec<Vec2> {
    let mut out = vec![s.pixel_filter(), s.lens()];
    for depth in [0, 5] {
        s.start_bounce(depth);
        out.push(s.light().0);
        out.push(s.bsdf().1);
        out.push(s.subsurface_probe().1);
        out.push(s.exit_light().0);
        out.push(s.exit_lobe());
    }
    out
}

/// Every 1D value of one path that the layout defines.
fn values_1d(s: &mut Sampler) -> Vec<f32> {
    let wl = s.wavelength();
    let mut out = vec![wl.x, wl.y];
    for depth in [0, 3] {
        s.start_bounce(depth);
        out.push(s.light().1);
        out.push(s.material_component());
        out.push(s.bsdf().0);
        out.push(s.russian_roulette());
        let (axis, _, hit) = s.subsurface_probe();
        out.extend([axis, hit]);
        out.push(s.exit_light().1);
    }
    out
}

#[test]
fn every_prefix_of_every_pixel_is_a_net_in_every_2d_group() {
    let image = ImageSampler::new(SamplerKind::Sobol, SPP, 3);
    for (x, y) in [(0, 0), (1, 0), (17, 5), (255, 254), (1000, 3)] {
        let pixel = image.pixel(x, y, 1024);
        let paths: Vec<Vec<Vec2>> = (0..SPP).map(|s| points_2d(&mut pixel.sample(s))).collect();
        for k in 0..=6 {
            let n = 1usize << k;
            for dim in 0..paths[0].len() {
                let pts: Vec<Vec2> = paths[..n].iter().map(|p| p[dim]).collect();
                assert!(
                    is_net(&pts),
                    "pixel ({x}, {y}), 2D point {dim}, first {n} samples"
                );
            }
        }
    }
    // Independent numbers are not nets (the test can fail).
    let image = ImageSampler::new(SamplerKind::Independent, SPP, 3);
    let pixel = image.pixel(4, 4, 16);
    let pts: Vec<Vec2> = (0..16).map(|s| pixel.sample(s).pixel_filter()).collect();
    assert!(!is_net(&pts));
}

#[test]
fn a_prefix_of_a_larger_render_is_as_stratified() {
    // spp need not be a power of two: a 100-spp render's pixel block holds 128 indices, and
    // its first 64 samples are still a (0, 6, 2)-net.
    let image = ImageSampler::new(SamplerKind::Sobol, 100, 0);
    let pixel = image.pixel(9, 9, 64);
    let pts: Vec<Vec2> = (0..64).map(|s| pixel.sample(s).pixel_filter()).collect();
    assert!(is_net(&pts));
}

#[test]
fn every_dimension_is_uniform() {
    // Chi-square over 32 bins of all values of 64 x 64 pixels x 16 samples, per dimension.
    let image = ImageSampler::new(SamplerKind::Sobol, 16, 11);
    let mut ones: Vec<Vec<f32>> = Vec::new();
    let mut twos: Vec<Vec<f32>> = Vec::new();
    for y in 0..64 {
        for x in 0..64 {
            let pixel = image.pixel(x, y, 64);
            for s in 0..16 {
                let v1 = values_1d(&mut pixel.sample(s));
                let v2: Vec<f32> = points_2d(&mut pixel.sample(s))
                    .iter()
                    .flat_map(|p| [p.x, p.y])
                    .collect();
                for (store, v) in [(&mut ones, v1), (&mut twos, v2)] {
                    store.resize(v.len(), Vec::new());
                    for (d, x) in v.into_iter().enumerate() {
                        store[d].push(x);
                    }
                }
            }
        }
    }
    for (d, values) in ones.iter().chain(twos.iter()).enumerate() {
        let bins = 32usize;
        let mut hist = vec![0f64; bins];
        for &v in values {
            assert!((0.0..1.0).contains(&v), "dimension {d}: {v}");
            hist[(v * bins as f32) as usize] += 1.0;
        }
        let expected = values.len() as f64 / bins as f64;
        let chi2: f64 = hist.iter().map(|h| (h - expected).powi(2) / expected).sum();
        // 31 degrees of freedom: p = 1e-4 at 66. Stratified points give far less.
        assert!(chi2 < 66.0, "dimension {d}: chi2 {chi2:.1}");
    }
}

fn correlation(a: &[f32], b: &[f32]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (
        a.iter().map(|&x| x as f64).sum::<f64>() / n,
        b.iter().map(|&x| x as f64).sum::<f64>() / n,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (dx, dy) = (x as f64 - ma, y as f64 - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    sab / (saa * sbb).sqrt()
}

#[test]
fn dimensions_and_pixels_are_decorrelated() {
    let image = ImageSampler::new(SamplerKind::Sobol, 16, 5);
    // All values of each path, over 32 x 32 pixels x 16 samples.
    let mut paths: Vec<Vec<f32>> = Vec::new();
    for y in 0..32 {
        for x in 0..32 {
            let pixel = image.pixel(x, y, 32);
            for s in 0..16 {
                let mut v = values_1d(&mut pixel.sample(s));
                v.extend(
                    points_2d(&mut pixel.sample(s))
                        .iter()
                        .flat_map(|p| [p.x, p.y]),
                );
                paths.push(v);
            }
        }
    }
    let dims = paths[0].len();
    let column = |d: usize| -> Vec<f32> { paths.iter().map(|p| p[d]).collect() };
    // n = 16384: an independent pair has |r| < 0.04 with probability 1 - 1e-6.
    let mut worst = 0.0f64;
    for a in 0..dims {
        for b in a + 1..dims {
            let r = correlation(&column(a), &column(b));
            worst = worst.max(r.abs());
            assert!(r.abs() < 0.04, "dimensions {a} and {b}: r = {r:.3}");
        }
    }
    println!("largest |r| between dimensions: {worst:.4}");
    // The same dimension in neighbouring and distant pixels, sample by sample.
    for (p, q) in [((3, 3), (4, 3)), ((3, 3), (3, 4)), ((0, 0), (20, 17))] {
        for d in [0usize, 3, dims - 1] {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for s in 0..16 {
                // Pixels as seen through many seeds: the correlation over seeds and samples.
                for seed in 0..64 {
                    let image = ImageSampler::new(SamplerKind::Sobol, 16, seed);
                    let mut va = values_1d(&mut image.pixel(p.0, p.1, 32).sample(s));
                    let mut vb = values_1d(&mut image.pixel(q.0, q.1, 32).sample(s));
                    va.extend(
                        points_2d(&mut image.pixel(p.0, p.1, 32).sample(s))
                            .iter()
                            .flat_map(|v| [v.x, v.y]),
                    );
                    vb.extend(
                        points_2d(&mut image.pixel(q.0, q.1, 32).sample(s))
                            .iter()
                            .flat_map(|v| [v.x, v.y]),
                    );
                    a.push(va[d]);
                    b.push(vb[d]);
                }
            }
            let r = correlation(&a, &b);
            // n = 1024: |r| < 0.15 with probability 1 - 1e-6 for independent values.
            assert!(
                r.abs() < 0.15,
                "pixels {p:?} and {q:?}, dimension {d}: r = {r:.3}"
            );
        }
    }
}

/// A 4 x 4 diffuse plane at y = 0 lit by a 1 x 1 emitter at height 1.5, tilted towards it,
/// seen from above; direct light only.
fn area_light_scene() -> SceneDesc {
    let light = emissive_material("light", Vec3::splat(4.0), true);
    let mut cam = common::scenes::camera(0.0, 0.9);
    cam.camera_to_world = Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    SceneDesc {
        meshes: vec![
            quad_mesh("plane", Vec3::ZERO, Vec3::X * 2.0, Vec3::Z * -2.0, 0),
            // Outside the camera's view (x from 2.2 to 3.2).
            quad_mesh(
                "light",
                Vec3::new(2.7, 1.5, 0.0),
                Vec3::new(0.35, 0.35, 0.0),
                Vec3::Z * 0.5,
                1,
            ),
        ],
        instances: (0..2)
            .map(|i| InstanceDesc {
                mesh: i,
                object_to_world: Mat4::IDENTITY,
                name: format!("i{i}"),
            })
            .collect(),
        materials: vec![diffuse_material("grey", Vec3::splat(0.5)), light],
        camera: Some(cam),
        ..Default::default()
    }
}

#[test]
fn sobol_beats_independent_numbers_on_an_area_light() {
    let scene = Scene::build(area_light_scene()).expect("scene builds");
    let render = |sampler: SamplerKind, spp: u32, seed: u64| -> Vec<[f32; 4]> {
        let settings = RenderSettings {
            width: 24,
            height: 24,
            spp,
            max_depth: 1,
            seed,
            sampler,
            ..Default::default()
        };
        let (film, stats) = render_quiet(&scene, &settings);
        assert_eq!(stats.discarded, 0);
        film.to_rgba()
    };
    let reference = render(SamplerKind::Sobol, 4096, 99);
    let rel_mse = |img: &[[f32; 4]]| common::scenes::rel_mse(img, &reference);
    // Averaged over 4 seeds so the ratio is stable.
    let mean = |kind| (1..=4).map(|s| rel_mse(&render(kind, 16, s))).sum::<f64>() / 4.0;
    let (sobol, independent) = (mean(SamplerKind::Sobol), mean(SamplerKind::Independent));
    let gain = independent / sobol;
    println!("16 spp relMSE: sobol {sobol:.3e}, independent {independent:.3e}, ratio {gain:.2}");
    assert!(
        gain >= 3.0,
        "sobol {sobol:.3e} vs independent {independent:.3e}: {gain:.2}x"
    );
}

#[test]
fn pixel_errors_are_blue_noise() {
    // Estimate a discontinuous integrand (a visibility edge across the light's square) with 4
    // samples per pixel over 64 x 64 pixels. White-noise errors average over a 2 x 2 block to
    // a quarter of the per-pixel variance; blue-noise errors (neighbours negatively
    // correlated, the error pushed to high frequencies) to less. One image shares one
    // scramble, so one render is one draw of the error pattern (from 0.1 to 1.4 here): the
    // ratio is averaged over 16 seeds and 4 dimension groups.
    let f = |u: Vec2| if u.x < 0.3 + 0.4 * u.y { 1.0f64 } else { 0.0 };
    let exact = 0.5f64;
    let block_ratio = |kind: SamplerKind| -> f64 {
        let mut ratios = Vec::new();
        for seed in 0..16 {
            for group in 0..4u32 {
                let image = ImageSampler::new(kind, 4, seed);
                let n = 64usize;
                let mut err = vec![0.0f64; n * n];
                for y in 0..n {
                    for x in 0..n {
                        let pixel = image.pixel(x as u32, y as u32, n as u32);
                        let mean = (0..4)
                            .map(|s| {
                                let mut smp = pixel.sample(s);
                                smp.start_bounce(group / 2);
                                f(if group % 2 == 0 {
                                    smp.light().0
                                } else {
                                    smp.bsdf().1
                                })
                            })
                            .sum::<f64>()
                            / 4.0;
                        err[y * n + x] = mean - exact;
                    }
                }
                let var = err.iter().map(|e| e * e).sum::<f64>() / err.len() as f64;
                let mut block = Vec::new();
                for by in 0..n / 2 {
                    for bx in 0..n / 2 {
                        let i = 2 * by * n + 2 * bx;
                        block.push((err[i] + err[i + 1] + err[i + n] + err[i + n + 1]) / 4.0);
                    }
                }
                let block_var = block.iter().map(|e| e * e).sum::<f64>() / block.len() as f64;
                ratios.push(block_var / (var / 4.0));
            }
        }
        ratios.iter().sum::<f64>() / ratios.len() as f64
    };
    let (sobol, independent) = (
        block_ratio(SamplerKind::Sobol),
        block_ratio(SamplerKind::Independent),
    );
    println!(
        "2x2 block variance / (pixel variance / 4): sobol {sobol:.3}, independent {independent:.3}"
    );
    assert!(
        (0.85..1.15).contains(&independent),
        "independent {independent:.3}"
    );
    // A 16-point net over the block: (16^-1.5) / (4^-1.5 / 4) = 0.5 for an edge integrand.
    assert!(sobol < 0.7, "sobol {sobol:.3}");
}
