//! Caustic guiding (`integrator::caustics`): the guide samples its own density (chi-square),
//! photons exist only where something focuses light, and guided renders keep the image's
//! expectation while the floor's caustic sparkle drops, bit-identical for any thread count.

mod common;
#[path = "common/stats.rs"]
mod stats;

use common::scenes::{camera, diffuse_material, material_with, quad_mesh, sphere_mesh};
use glam::{Mat2, Mat4, Vec2, Vec3};
use prism::integrator::caustics::{
    CausticGuide, CausticPhotons, GlintLobe, GUIDE_SHARE, MAX_GLINT_BLUR, MAX_UNPLANNED_GLINT_BLUR,
};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{
    GltfMaterialDesc, InstanceDesc, PunctualKind, PunctualLightDesc, Scene, SceneDesc, WorldDesc,
};
use stats::{adaptive_simpson_2d, chi2_test, Pcg32};
use std::f64::consts::PI;

#[test]
fn the_guide_samples_its_own_density() {
    // Overlapping cones of different widths and weights, one of them narrow.
    let cones = [
        (Vec3::new(0.2, 0.1, 1.0), 0.45, 2.0),
        (Vec3::new(0.35, 0.12, 1.0), 0.2, 1.0),
        (Vec3::new(-1.0, 0.3, 0.2), 0.3, 0.5),
        (Vec3::new(0.3, -1.0, -0.4), 0.6, 0.7),
    ];
    check_guide_density(
        &CausticGuide::from_cones(&cones, GUIDE_SHARE).unwrap(),
        "cones",
    );
    // Glint lobes beside cones: GGX slopes of a broad alpha (the binning's resolution)
    // through an anisotropic Jacobian onto a tilted plane of skewed edges, seen from a
    // shading point off the origin.
    let origin = Vec3::new(0.1, -0.2, 0.3);
    let lobe = GlintLobe::new(
        origin + Vec3::new(0.3, 0.2, 1.0),
        [Vec3::new(0.4, 0.0, -0.1), Vec3::new(0.1, 0.3, 0.05)],
        Mat2::from_cols(Vec2::new(2.0, 0.3), Vec2::new(-0.5, 1.2)),
        0.3,
    )
    .unwrap();
    let other = GlintLobe::new(
        origin + Vec3::new(-1.0, 0.5, -0.2),
        [Vec3::new(0.0, 0.2, 0.1), Vec3::new(0.1, 0.0, 0.3)],
        Mat2::from_cols(Vec2::new(1.0, 0.0), Vec2::new(0.2, 0.8)),
        0.15,
    )
    .unwrap();
    let guide =
        CausticGuide::from_parts(origin, &cones[2..], &[(lobe, 1.5), (other, 1.0)], 0.3).unwrap();
    check_guide_density(&guide, "cones and glint lobes");
}

/// The guide's samples against its density: 20 x 40 bins in (cos theta, phi) over the
/// sphere, expected counts from the density by adaptive Simpson integration (as
/// tests/bsdf_chi2.rs).
fn check_guide_density(guide: &CausticGuide, what: &str) {
    let (theta_bins, phi_bins) = (20usize, 40usize);
    let bin_of = |w: Vec3| {
        let c = ((w.z.clamp(-1.0, 1.0) + 1.0) * 0.5 * theta_bins as f32) as usize;
        let phi = w.y.atan2(w.x).rem_euclid(2.0 * std::f32::consts::PI);
        let p = (phi / (2.0 * std::f32::consts::PI) * phi_bins as f32) as usize;
        c.min(theta_bins - 1) * phi_bins + p.min(phi_bins - 1)
    };
    let n = 400_000;
    let mut observed = vec![0.0; theta_bins * phi_bins];
    let mut rng = Pcg32::new(7, 1);
    for _ in 0..n {
        let w = guide.sample(rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
        assert!((w.length() - 1.0).abs() < 1e-4, "{w:?}");
        assert!(guide.pdf(w) > 0.0, "a sample where the density is 0: {w:?}");
        observed[bin_of(w)] += 1.0;
    }
    let (dc, dp) = (2.0 / theta_bins as f64, 2.0 * PI / phi_bins as f64);
    let mut total = 0.0;
    let expected: Vec<f64> = (0..theta_bins * phi_bins)
        .map(|k| {
            let (c0, p0) = (
                -1.0 + (k / phi_bins) as f64 * dc,
                (k % phi_bins) as f64 * dp,
            );
            let f = |c: f64, p: f64| {
                let s = (1.0 - c * c).max(0.0).sqrt();
                let w = Vec3::new((s * p.cos()) as f32, (s * p.sin()) as f32, c as f32);
                guide.pdf(w) as f64
            };
            let prob = adaptive_simpson_2d(&f, c0, c0 + dc, p0, p0 + dp, 1e-7, 3, 12);
            total += prob;
            prob * n as f64
        })
        .collect();
    assert!(
        (total - 1.0).abs() < 2e-3,
        "{what}: the density integrates to {total}"
    );
    chi2_test(&observed, &expected, 5.0).assert_fits(1e-3, what);
}

/// A diffuse floor (the plane z = 0, seen from above), a gold ball of roughness 0.2 on it,
/// a low sun, and a dim world: the ball's sun glint lights the floor around it (the
/// everyday-scene caustic that a path tracer finds only by chance).
fn caustic_scene(ball_roughness: f32, ball_metallic: f32) -> Scene {
    Scene::build(caustic_desc(ball_roughness, ball_metallic)).unwrap()
}

fn caustic_desc(ball_roughness: f32, ball_metallic: f32) -> SceneDesc {
    let floor = diffuse_material("floor", Vec3::splat(0.7));
    let gold = material_with(
        GltfMaterialDesc {
            name: "gold".into(),
            base_color: Vec3::new(1.0, 0.78, 0.34).extend(1.0),
            metallic: ball_metallic,
            roughness: ball_roughness,
            ..Default::default()
        },
        None,
    );
    SceneDesc {
        meshes: vec![
            quad_mesh("floor", Vec3::ZERO, Vec3::X * 3.0, Vec3::Y * 3.0, 0),
            sphere_mesh(1, 48, 24),
        ],
        instances: vec![
            InstanceDesc {
                mesh: 0,
                object_to_world: Mat4::IDENTITY,
                name: "floor".into(),
            },
            InstanceDesc {
                mesh: 1,
                object_to_world: Mat4::from_translation(Vec3::new(0.3, 0.2, 0.4))
                    * Mat4::from_scale(Vec3::splat(0.4)),
                name: "ball".into(),
            },
        ],
        materials: vec![floor, gold],
        lights: vec![PunctualLightDesc {
            name: "sun".into(),
            kind: PunctualKind::Directional,
            color: Vec3::ONE,
            intensity: 3.0,
            direction: Vec3::new(-1.0, -0.3, -0.45).normalize(),
            ..Default::default()
        }],
        camera: Some(camera(4.0, 0.7)),
        world: WorldDesc {
            color: Vec3::new(0.05, 0.07, 0.1),
            strength: 1.0,
            texture: None,
        },
        ..Default::default()
    }
}

fn settings(spp: u32, seed: u64, caustic_guiding: bool) -> RenderSettings {
    RenderSettings {
        width: 40,
        height: 40,
        spp,
        seed,
        max_depth: 8,
        caustic_guiding,
        ..RenderSettings::default()
    }
}

fn luminance(film: &prism::film::Film) -> Vec<f64> {
    film.color()
        .iter()
        .map(|c| (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64)
        .collect()
}

#[test]
fn photons_are_traced_only_where_something_focuses_light() {
    let trace = |roughness: f32, metallic: f32, max_blur: f32| {
        CausticPhotons::trace(&caustic_scene(roughness, metallic), 0, max_blur)
    };
    for max_blur in [MAX_GLINT_BLUR, MAX_UNPLANNED_GLINT_BLUR] {
        assert!(trace(0.2, 1.0, max_blur).is_some_and(|p| p.len() > 1000));
        // A rough metal, a diffuse ball and a near-mirror (whose glint of the sun is smaller
        // than photons can point at) focus nothing photons can find: no photons, no guiding.
        assert!(trace(0.6, 1.0, max_blur).is_none());
        assert!(trace(0.2, 0.0, max_blur).is_none());
        assert!(trace(0.05, 1.0, max_blur).is_none());
    }
    // Roughness 0.1 (alpha 0.01): a glint far narrower than the photons' cones, which its
    // photons' patches solve for; roughness 0.3 (alpha 0.09): a glint blurred by 0.18 rad,
    // which the photons' spread draws, guided only where the splitting pilot can tell
    // whether that pays.
    let sharp = trace(0.1, 1.0, MAX_UNPLANNED_GLINT_BLUR).unwrap();
    assert!(
        sharp.glint_photons() > sharp.len() / 2,
        "{} of {}",
        sharp.glint_photons(),
        sharp.len()
    );
    let broad = trace(0.3, 1.0, MAX_GLINT_BLUR).unwrap();
    assert!(broad.len() > 1000 && broad.glint_photons() == 0);
    assert!(trace(0.3, 1.0, MAX_UNPLANNED_GLINT_BLUR).is_none());
}

/// The floor seen through a periscope of two mirrors (its vertex is the camera path's third)
/// is guided as the floor seen directly: vertices on mirrors and near-mirrors do not count
/// towards the guided depth (`Bsdf::is_sharp`). Error against a 4096-spp render, over 32
/// renders of 8 spp (no splitting pilot decides below 16; at 64 spp its first samples, which
/// see little of the caustic, turn guiding off here): guided 0.39 of unguided; counting every
/// vertex, 1.18.
#[test]
fn a_caustic_seen_in_mirrors_is_guided_as_one_seen_directly() {
    let mut desc = caustic_desc(0.2, 1.0);
    let mirror = desc.materials.len();
    desc.materials.push(material_with(
        GltfMaterialDesc {
            name: "mirror".into(),
            base_color: Vec3::splat(0.95).extend(1.0),
            metallic: 1.0,
            roughness: 0.0,
            double_sided: true,
            ..Default::default()
        },
        None,
    ));
    // The camera looks down (-z) from (0, 0, 4): the first mirror (the plane x + z = 3)
    // turns its rays to +x, the second (x + z = 4.5) turns them down again onto the floor
    // around the ball. Neither shades the floor or the ball from the low sun, and both
    // reflect it upwards.
    let (u, v) = (Vec3::new(0.7, 0.0, -0.7), Vec3::Y);
    for (k, centre) in [Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.5, 0.0, 3.0)]
        .into_iter()
        .enumerate()
    {
        desc.meshes.push(quad_mesh("mirror", centre, u, v, mirror));
        desc.instances.push(InstanceDesc {
            mesh: desc.meshes.len() - 1,
            object_to_world: Mat4::IDENTITY,
            name: format!("mirror {k}"),
        });
    }
    let scene = Scene::build(desc).unwrap();
    let reference = luminance(&render_quiet(&scene, &settings(4096, 99, false)).0);
    let reference_mean = reference.iter().sum::<f64>() / reference.len() as f64;
    let error_and_mean = |guided: bool| {
        let (mut error, mut mean) = (0.0, 0.0);
        for seed in 0..32 {
            let image = luminance(&render_quiet(&scene, &settings(8, seed, guided)).0);
            let n = image.len() as f64;
            error += image
                .iter()
                .zip(&reference)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                / n
                / 32.0;
            mean += image.iter().sum::<f64>() / n / 32.0;
        }
        (error, mean)
    };
    let (error_off, mean_off) = error_and_mean(false);
    let (error_on, mean_on) = error_and_mean(true);
    eprintln!(
        "unguided: error {error_off:.4e} mean {mean_off:.5}; guided: error {error_on:.4e} \
         mean {mean_on:.5}; reference mean {reference_mean:.5}"
    );
    assert!(
        error_on < 0.6 * error_off,
        "guided error {error_on:.4e} against {error_off:.4e}"
    );
    assert!(
        (mean_on - reference_mean).abs() < 0.01 * reference_mean,
        "guided mean {mean_on} against {reference_mean}"
    );
}

/// The splitting pilot keeps guiding on where it pays (the sun's glint in a metal ball of
/// roughness 0.2 and 0.3 on a floor) and turns it off where it does not: the same ball with
/// its caustic out of the camera's view (a close-up of the ball, whose first vertices are
/// all on the ball, where nothing is guided).
#[test]
fn the_pilot_keeps_guiding_only_where_it_pays() {
    for roughness in [0.2, 0.3] {
        let (_, stats) = render_quiet(&caustic_scene(roughness, 1.0), &settings(64, 1, true));
        assert!(
            stats.caustic_photons > 0 && stats.caustic_guided,
            "{roughness}: {stats:?}"
        );
    }
    let mut close_up = caustic_desc(0.3, 1.0);
    let mut cam = camera(4.0, 0.05);
    cam.camera_to_world = Mat4::from_translation(Vec3::new(0.3, 0.2, 4.0));
    close_up.camera = Some(cam);
    let (_, stats) = render_quiet(&Scene::build(close_up).unwrap(), &settings(64, 1, true));
    assert!(
        stats.caustic_photons > 0 && !stats.caustic_guided,
        "{stats:?}"
    );
    // Without a pilot (fewer than 16 spp) only sharper glints are guided.
    let (_, stats) = render_quiet(&caustic_scene(0.3, 1.0), &settings(8, 1, true));
    assert_eq!(stats.caustic_photons, 0);
}

#[test]
fn guiding_keeps_the_mean_and_removes_the_caustic_sparkle() {
    // Metal balls of roughness 0.2 and 0.1, whose glints (narrow against this small ball's
    // photon cones) glint lobes point at. Guided grain against unguided: 0.016 and 0.28;
    // with the photons' cones alone, 0.16 and 19 (the cones spread a near-mirror's rare
    // glint hits over the whole floor).
    for (roughness, max_ratio) in [(0.2, 0.1), (0.1, 0.5)] {
        guided_noise_and_mean(&caustic_scene(roughness, 1.0), max_ratio);
    }
}

fn guided_noise_and_mean(scene: &Scene, max_ratio: f64) {
    // Noise: the squared difference of two renders of different seeds, per pixel, over the
    // image (the grain); mean: of 8 renders' mean luminance.
    let noise_and_mean = |guided: bool| {
        let images: Vec<Vec<f64>> = (0..8)
            .map(|seed| luminance(&render_quiet(scene, &settings(64, seed, guided)).0))
            .collect();
        // The grain: the 1% of pixels with the largest differences left out (the rare
        // sparkle no guide at 64 spp removes; bench/README.md's "bulk").
        let noise: f64 = (0..4)
            .map(|k| {
                let (a, b) = (&images[2 * k], &images[2 * k + 1]);
                let mut d: Vec<f64> = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).collect();
                d.sort_by(f64::total_cmp);
                d.truncate(d.len() - d.len() / 100);
                d.iter().sum::<f64>() / d.len() as f64
            })
            .sum::<f64>()
            / 4.0;
        let means: Vec<f64> = images
            .iter()
            .map(|im| im.iter().sum::<f64>() / im.len() as f64)
            .collect();
        let mean = means.iter().sum::<f64>() / 8.0;
        let spread =
            (means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / 7.0 / 8.0).sqrt();
        (noise, mean, spread)
    };
    let (noise_off, mean_off, se_off) = noise_and_mean(false);
    let (noise_on, mean_on, se_on) = noise_and_mean(true);
    let se = (se_off * se_off + se_on * se_on).sqrt();
    eprintln!(
        "unguided: noise {noise_off:.4e} mean {mean_off:.5} +- {se_off:.5}; \
         guided: noise {noise_on:.4e} mean {mean_on:.5} +- {se_on:.5}"
    );
    assert!(
        (mean_on - mean_off).abs() < 4.0 * se + 2e-3 * mean_off,
        "guided mean {mean_on} against {mean_off} (standard error {se})"
    );
    assert!(
        noise_on < max_ratio * noise_off,
        "guided noise {noise_on:.4e} against {noise_off:.4e}"
    );
}

#[test]
fn guided_renders_are_the_same_for_any_thread_count() {
    let scene = caustic_scene(0.2, 1.0);
    let render_with = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render_quiet(&scene, &settings(16, 3, true)).0.color())
    };
    assert_eq!(render_with(1), render_with(2));
}

#[test]
fn scenes_where_nothing_focuses_light_render_as_without_guiding() {
    let scene = caustic_scene(0.6, 1.0);
    let on = render_quiet(&scene, &settings(8, 5, true)).0.color();
    let off = render_quiet(&scene, &settings(8, 5, false)).0.color();
    assert_eq!(on, off);
}
