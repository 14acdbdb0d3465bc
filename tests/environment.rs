//! The world environment map and the camera's new projections, end to end:
//!
//! - chi-square goodness of fit of `Lights::sample` for an environment map against
//!   `Lights::environment_pdf` (bins = quarters of the map's texels, where the pdf is exactly
//!   known), the
//!   pdf's integral over the sphere, and sample-by-sample agreement of the returned pdf and
//!   radiance with `environment_pdf` / `environment_radiance`;
//! - a furnace-style check: a constant-colour environment texture renders the same image as the
//!   uniform world colour;
//! - images load from `.exr`, `.hdr` and `.png` through the sidecar; bad references are one-line
//!   input errors;
//! - orthographic and thin-lens cameras reach the renderer from glTF + sidecar.

#[path = "common/stats.rs"]
mod stats;

mod common;
#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use common::scenes::{diffuse_material, furnace_scene};
use glam::{Mat4, Vec2, Vec3};
use gltf_builder::{test_dir, GltfBuilder};
use prism::lights::envmap::EnvironmentMap;
use prism::lights::{LightSelection, ShadingContext};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, EnvironmentTextureDesc, Scene, SceneDesc, WorldDesc};
use prism::spectrum::{SampledSpectrum, SampledWavelengths};
use serde_json::json;
use stats::{chi2_test, Pcg32};
use std::f64::consts::PI;

/// A shading point at the origin that receives from every direction.
const ORIGIN: ShadingContext = ShadingContext {
    p: Vec3::ZERO,
    n: None,
    time: 0.5,
};

/// Density with which light sampling at the origin produces the escaping direction `d`
/// through the world (the world is the scene's last light).
fn environment_pdf(lights: &prism::lights::Lights, d: Vec3) -> f32 {
    lights.infinite_pdf(&ORIGIN, lights.len() - 1, d, LightSelection::Tree)
}

/// A 32 x 16 map with a bright spot, a gradient, a black band and strong colour differences.
fn test_texture(rotation_z: f32) -> EnvironmentTextureDesc {
    let (w, h) = (32u32, 16u32);
    let mut texels = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let mut c = Vec3::new(
                0.2 + 0.8 * i as f32 / w as f32,
                0.5,
                0.1 + j as f32 / h as f32,
            );
            if j == 11 {
                c = Vec3::ZERO; // a black band (zero-probability rows must stay consistent)
            }
            if (i, j) == (5, 4) || (i, j) == (6, 4) {
                c = Vec3::new(2000.0, 1500.0, 800.0);
            }
            texels.push(c);
        }
    }
    EnvironmentTextureDesc {
        name: "test".into(),
        width: w,
        height: h,
        texels,
        rotation_z,
    }
}

/// A small non-emissive triangle far away plus the world (only the world emits).
fn env_scene(texture: EnvironmentTextureDesc) -> Scene {
    let mut desc = furnace_scene(diffuse_material("grey", Vec3::splat(0.5)), Vec3::ONE);
    desc.instances[0].object_to_world =
        Mat4::from_translation(Vec3::new(0.0, -100.0, 0.0)) * Mat4::from_scale(Vec3::splat(0.01));
    desc.world = WorldDesc {
        color: Vec3::new(1.0, 0.9, 0.8),
        strength: 1.5,
        texture: Some(texture),
    };
    Scene::build(desc).expect("scene builds")
}

fn dir(cos_theta: f64, phi: f64) -> Vec3 {
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    // Polar axis = world up (+Y).
    Vec3::new(
        (s * phi.cos()) as f32,
        cos_theta as f32,
        (s * phi.sin()) as f32,
    )
}

/// The sampled directions, binned by quarters of the map's texels (the pdf is constant in (u, t)
/// on each texel cell, so a bin's expected probability is exactly pdf x 2π² sin θ x its (u, t)
/// area, evaluated at its centre),
/// against `Lights::environment_pdf`. The pdf is also integrated over the sphere (midpoint rule in
/// (θ, φ) about the world's up axis) and compared with `Lights::sample`'s pdf sample by sample.
#[test]
fn environment_sampling_matches_its_pdf_chi_square() {
    const SAMPLES: usize = 400_000;
    let tex = test_texture(0.7);
    // The same map the scene builds (colour x strength as in env_scene), for its (u, t) mapping.
    let map = EnvironmentMap::new(
        tex.width,
        tex.height,
        &tex.texels,
        Vec3::new(1.5, 1.35, 1.2),
        tex.rotation_z,
    );
    // Bins: every texel cell split SUB x SUB (so the placement inside a cell is tested too).
    const SUB: usize = 2;
    let (w_bins, h_bins) = (SUB * tex.width as usize, SUB * tex.height as usize);
    let scene = env_scene(tex);
    let lights = &scene.lights;
    let w = SampledWavelengths::sample_hero(0.3, Default::default());
    let mut rng = Pcg32::new(17, 3);
    let mut observed = vec![0.0f64; w_bins * h_bins];
    let mut failures = 0usize;
    for k in 0..SAMPLES {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let [Some(ls), ..] = lights.sample(
            &scene.geometry,
            &scene.materials,
            &ORIGIN,
            rng.next_f32(),
            u,
            &w,
            LightSelection::Tree,
        ) else {
            failures += 1;
            continue;
        };
        if k % 16 == 0 {
            let p = environment_pdf(lights, ls.wi);
            assert!(
                (p - ls.pdf).abs() <= 2e-3 * p.max(ls.pdf),
                "sample pdf {} vs environment_pdf {p} at {}",
                ls.pdf,
                ls.wi
            );
            let mut le = SampledSpectrum::ZERO;
            lights.for_each_at_infinity(ls.wi, &w, |_, l| le += l);
            for i in 0..4 {
                assert!((le.0[i] - ls.li.0[i]).abs() <= 1e-5 * le.0[i].max(1e-3));
            }
            assert!(ls.distance.is_infinite() && !ls.delta);
        }
        let uv = map.direction_to_uv(ls.wi);
        let i = ((uv.x * w_bins as f32) as usize).min(w_bins - 1);
        let j = ((uv.y * h_bins as f32) as usize).min(h_bins - 1);
        observed[j * w_bins + i] += 1.0;
    }
    let mut expected = Vec::with_capacity(w_bins * h_bins);
    for j in 0..h_bins {
        for i in 0..w_bins {
            let uv = Vec2::new(
                (i as f32 + 0.5) / w_bins as f32,
                (j as f32 + 0.5) / h_bins as f32,
            );
            let d = map.uv_to_direction(uv);
            let sin_theta = (PI * uv.y as f64).sin();
            let prob = environment_pdf(lights, d) as f64 * 2.0 * PI * PI * sin_theta
                / (w_bins * h_bins) as f64;
            expected.push(prob * SAMPLES as f64);
        }
    }
    let total: f64 = expected.iter().sum::<f64>() / SAMPLES as f64;
    expected.push(((1.0 - total) * SAMPLES as f64).max(0.0));
    observed.push(failures as f64);
    let r = chi2_test(&observed, &expected, 5.0);
    println!(
        "environment map chi2 {:.1} dof {} p {:.3e} (cell-sum of the pdf {total:.5}, failures {failures})",
        r.chi2, r.dof, r.p_value
    );
    r.assert_fits(1e-3, "environment map");
    // Independent of the texel cells: the pdf integrates to 1 over the sphere.
    let n = 2000;
    let mut integral = 0.0f64;
    for a in 0..n {
        for b in 0..n {
            let theta = PI * (a as f64 + 0.5) / n as f64;
            let phi = 2.0 * PI * (b as f64 + 0.5) / n as f64;
            integral += environment_pdf(lights, dir(theta.cos(), phi)) as f64 * theta.sin();
        }
    }
    integral *= 2.0 * PI * PI / (n * n) as f64;
    println!("pdf integral over the sphere {integral:.5}");
    assert!(
        (integral - 1.0).abs() < 2e-3,
        "pdf integrates to {integral}"
    );
}

/// The bright spot dominates: most samples must land near it (importance sampling works).
#[test]
fn environment_samples_concentrate_on_the_bright_spot() {
    let tex = test_texture(0.0);
    let scene = env_scene(tex);
    let lights = &scene.lights;
    let w = SampledWavelengths::sample_hero(0.5, Default::default());
    // Spot texel (5.5, 4) of 32 x 16: u = 6/32, t = 4.5/16 -> Blender φ = π (1 - 2u), θ = π t;
    // glTF = (b.x, b.z, -b.y).
    let (u, t) = (6.0 / 32.0, 4.5 / 16.0);
    let (theta, phi) = (
        std::f32::consts::PI * t,
        std::f32::consts::PI * (1.0 - 2.0 * u),
    );
    let b = Vec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    );
    let spot = Vec3::new(b.x, b.z, -b.y);
    let mut rng = Pcg32::new(5, 1);
    let (mut near, n) = (0, 20_000);
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        if let [Some(ls), ..] = lights.sample(
            &scene.geometry,
            &scene.materials,
            &ORIGIN,
            0.5,
            u,
            &w,
            LightSelection::Tree,
        ) {
            if ls.wi.dot(spot) > 0.9 {
                near += 1;
            }
        }
    }
    let frac = near as f32 / n as f32;
    assert!(frac > 0.6, "only {frac} of the samples near the spot");
}

fn render_mean(desc: SceneDesc, spp: u32) -> Vec3 {
    common::scenes::render_mean(desc, 32, spp, 8, 11).0
}

/// A constant-colour environment texture is the uniform world: same image (means within the
/// noise), and both equal the analytic value (background = L, diffuse convex sphere = ρ L).
#[test]
fn constant_texture_renders_like_the_uniform_world() {
    let colour = Vec3::new(0.3, 0.6, 0.9);
    let albedo = Vec3::splat(0.5);
    let uniform = furnace_scene(diffuse_material("grey", albedo), colour);
    let mut textured = furnace_scene(diffuse_material("grey", albedo), Vec3::ONE);
    textured.world.texture = Some(EnvironmentTextureDesc {
        name: "constant".into(),
        width: 8,
        height: 4,
        texels: vec![colour; 32],
        rotation_z: 0.4,
    });
    let a = render_mean(uniform, 64);
    let b = render_mean(textured, 64);
    let ratio = b / a;
    println!("uniform {a}, constant texture {b}, ratio {ratio}");
    for c in ratio.to_array() {
        assert!(
            (c - 1.0).abs() < 0.01,
            "constant texture / uniform world = {ratio}"
        );
    }
    // The sphere (radius 1 at distance 3, yfov 0.8) covers a known fraction of the image.
    let pixels_on_sphere = {
        let scene = Scene::build(furnace_scene(diffuse_material("g", albedo), colour)).unwrap();
        let cam = scene.camera_for(32, 32);
        let mut n = 0;
        for y in 0..32 {
            for x in 0..32 {
                let r = cam
                    .generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), Vec2::ZERO)
                    .unwrap();
                if scene.geometry.intersect(&r, f32::INFINITY).is_some() {
                    n += 1;
                }
            }
        }
        n as f32 / 1024.0
    };
    let want = colour * (1.0 - pixels_on_sphere) + colour * albedo * pixels_on_sphere;
    for (got, w) in b.to_array().iter().zip(want.to_array()) {
        assert!((got / w - 1.0).abs() < 0.03, "mean {b} vs analytic {want}");
    }
}

// ------------------------------------------------------------------ files through the sidecar

fn write_exr(path: &std::path::Path, w: usize, h: usize, f: impl Fn(usize, usize) -> Vec3 + Sync) {
    exr::prelude::write_rgb_file(path, w, h, |x, y| {
        let c = f(x, y);
        (c.x, c.y, c.z)
    })
    .unwrap();
}

fn scene_with_sidecar(dir: &std::path::Path, sidecar: serde_json::Value) -> std::path::PathBuf {
    let b = GltfBuilder::basic();
    let gltf = b.write_gltf(&dir.join("s.gltf"));
    std::fs::write(dir.join("s.materials.json"), sidecar.to_string()).unwrap();
    gltf
}

#[test]
fn environment_images_load_from_exr_hdr_and_png() {
    let dir = test_dir("envmap_files");
    let f = |x: usize, y: usize| Vec3::new(x as f32 * 0.5, y as f32 * 2.0, 3.0);
    write_exr(&dir.join("sky.exr"), 4, 2, f);
    let hdr = image::Rgb32FImage::from_fn(4, 2, |x, y| {
        let c = f(x as usize, y as usize);
        image::Rgb([c.x, c.y, c.z])
    });
    image::DynamicImage::ImageRgb32F(hdr)
        .save(dir.join("sky.hdr"))
        .unwrap();
    let png = image::RgbImage::from_fn(4, 2, |x, y| {
        image::Rgb([(x * 60) as u8, (y * 200) as u8, 255])
    });
    png.save(dir.join("sky.png")).unwrap();
    for (file, tol, srgb) in [
        ("sky.exr", 0.0, false),
        ("sky.hdr", 0.01, false),
        ("sky.png", 1e-6, true),
    ] {
        let gltf = scene_with_sidecar(
            &dir,
            json!({"version": 1, "world": {"texture": file, "strength": 2.0, "rotation_z": 0.25},
                   "camera": {"aperture_radius": 0.1, "focus_distance": 2.5}}),
        );
        let s = load_scene(&gltf, None, None).unwrap();
        let t = s.world.texture.as_ref().expect("texture loaded");
        assert_eq!((t.width, t.height, t.rotation_z), (4, 2, 0.25), "{file}");
        assert_eq!(s.world.strength, 2.0);
        assert_eq!(s.world.color, Vec3::ONE);
        for y in 0..2 {
            for x in 0..4 {
                let got = t.texels[y * 4 + x];
                let want = if srgb {
                    let e = |v: u32| prism::spectrum::rgb::srgb_to_linear(v as f32 / 255.0);
                    Vec3::new(e(x as u32 * 60), e(y as u32 * 200), 1.0)
                } else {
                    f(x, y)
                };
                assert!(
                    (got - want).abs().max_element() <= tol * want.max_element() + 1e-6,
                    "{file} ({x},{y}): {got} vs {want}"
                );
            }
        }
        let lens = s.camera.as_ref().unwrap().lens.unwrap();
        assert_eq!((lens.aperture_radius, lens.focus_distance), (0.1, 2.5));
        // And it renders.
        let scene = Scene::build(s).unwrap();
        let (film, _) = render_quiet(
            &scene,
            &RenderSettings {
                width: 8,
                height: 8,
                spp: 2,
                ..Default::default()
            },
        );
        assert!(film
            .to_rgba()
            .iter()
            .all(|p| p.iter().all(|v| v.is_finite())));
    }
}

#[test]
fn bad_environment_references_are_one_line_errors() {
    let dir = test_dir("envmap_bad");
    std::fs::write(dir.join("garbage.exr"), b"not an exr").unwrap();
    write_exr(&dir.join("nan.exr"), 2, 2, |x, _| {
        if x == 1 {
            Vec3::new(f32::NAN, 0.0, 0.0)
        } else {
            Vec3::ONE
        }
    });
    write_exr(&dir.join("neg.exr"), 2, 2, |_, _| Vec3::new(-1.0, 0.0, 0.0));
    for (file, want) in [
        ("missing.exr", "world.texture: "),
        ("garbage.exr", "cannot read EXR"),
        ("nan.exr", "pixel (1, 0) is not finite"),
        ("neg.exr", "negative values"),
    ] {
        let gltf = scene_with_sidecar(&dir, json!({"version": 1, "world": {"texture": file}}));
        let e = load_scene(&gltf, None, None).expect_err(file).to_string();
        assert!(e.contains(want), "{file}: {e}");
        assert!(
            e.contains("s.materials.json: world.texture: "),
            "{file}: {e}"
        );
        assert!(e.contains(file), "{file}: {e}");
        assert!(!e.contains('\n'), "{e}");
    }
    let gltf = scene_with_sidecar(
        &dir,
        json!({"version": 1, "world": {"texture": "missing.exr"}}),
    );
    let e = load_scene(&gltf, None, None).err().unwrap().to_string();
    assert!(e.contains("No such file or directory"), "{e}");
}

#[test]
fn orthographic_camera_and_lens_render_from_files() {
    let dir = test_dir("ortho_lens_files");
    let mut b = GltfBuilder::basic();
    b.cameras[0] = json!({ "type": "orthographic",
        "orthographic": { "xmag": 1.0, "ymag": 0.25, "znear": 0.01, "zfar": 100.0 } });
    let gltf = b.write_gltf(&dir.join("o.gltf"));
    std::fs::write(
        dir.join("o.materials.json"),
        json!({"version": 1, "camera": {"aperture_radius": 0.05, "focus_distance": 3.0}})
            .to_string(),
    )
    .unwrap();
    let s = load_scene(&gltf, None, None).unwrap();
    let scene = Scene::build(s).unwrap();
    let cam = scene.camera_for(40, 20);
    assert!(cam.is_orthographic());
    // ymag 0.25 with a 2:1 image: the view is 1 x 0.5 units; the emissive quad fills it.
    let r0 = cam
        .generate_ray(Vec2::new(0.0, 0.0), Vec2::splat(0.5))
        .unwrap();
    let r1 = cam
        .generate_ray(Vec2::new(40.0, 20.0), Vec2::splat(0.5))
        .unwrap();
    let extent = r1.origin - r0.origin;
    assert!(
        (extent.x - 1.0).abs() < 1e-5 && (extent.y + 0.5).abs() < 1e-5,
        "{extent}"
    );
    assert!((r0.dir - r1.dir).length() < 1e-6);
}

/// Through the CLI: a bad world texture or camera block is exit code 2 with one line on stderr.
#[test]
fn cli_reports_bad_world_and_camera_blocks() {
    let dir = test_dir("envmap_cli");
    for (sidecar, want) in [
        (
            json!({"version": 1, "world": {"texture": "nowhere.hdr"}}),
            "s.materials.json: world.texture: ",
        ),
        (
            json!({"version": 1, "camera": {"aperture_radius": 0.1, "focus_distance": -1}}),
            "s.materials.json: camera.focus_distance: must be positive, got -1",
        ),
    ] {
        let gltf = scene_with_sidecar(&dir, sidecar);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_prism"))
            .args(["render", gltf.to_str().unwrap(), "-o"])
            .arg(dir.join("out.exr"))
            .args([
                "--spp",
                "1",
                "--width",
                "4",
                "--height",
                "4",
                "--progress",
                "none",
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.starts_with("prism: error: ") && err.contains(want),
            "{err}"
        );
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
}

// ------------------------------------------------------------------ the world seen directly

/// The camera sees a uniform world with its exact colour (`PathSample::world_exact`): every
/// pure-background pixel is the same value, with no colour noise from sampling wavelengths,
/// and that value is what the spectral estimate averages to (so the swap keeps the image's
/// expectation) and the world's RGB within the RGB-to-spectrum table's round trip.
#[test]
fn uniform_world_seen_directly_has_its_exact_colour() {
    let colour = Vec3::new(0.3, 0.6, 0.9);
    let (_, rgba) = common::scenes::render_mean(
        furnace_scene(diffuse_material("grey", Vec3::splat(0.5)), colour),
        32,
        4,
        8,
        3,
    );
    // The corners are far from the sphere (radius 1 at distance 3, yfov 0.8).
    let corners = [0usize, 31, 32 * 31, 32 * 32 - 1, 1, 32];
    let first = rgba[corners[0]];
    for &i in &corners {
        assert_eq!(rgba[i], first, "background pixel {i} differs from pixel 0");
    }
    let got = Vec3::new(first[0], first[1], first[2]);
    for (g, want) in got.to_array().iter().zip(colour.to_array()) {
        assert!(
            (g / want - 1.0).abs() < 0.01,
            "background {got} vs world {colour}"
        );
    }
    // The spectral estimate of the same world (what paths that bounce see), averaged over
    // 2^16 stratified hero wavelengths, against the exact value.
    let spectrum = prism::spectrum::RgbIlluminantSpectrum::new(colour);
    let n = 1 << 16;
    let mut mean = glam::DVec3::ZERO;
    for i in 0..n {
        let w = SampledWavelengths::sample_hero(
            (i as f32 + 0.5) / n as f32,
            prism::integrator::WavelengthPdf::Visible,
        );
        mean += prism::spectrum::spectrum_to_xyz(&spectrum.sample(&w), &w).as_dvec3();
    }
    let estimate = prism::spectrum::rgb::xyz_to_linear_srgb((mean / n as f64).as_vec3());
    println!("background {got}, spectral estimate {estimate}, world {colour}");
    for (e, g) in estimate.to_array().iter().zip(got.to_array()) {
        assert!(
            (e / g - 1.0).abs() < 2e-3,
            "spectral {estimate} vs exact {got}"
        );
    }
}

/// Camera rays that escape to a background the film takes exactly (`PathTracer::camera_ray`'s
/// `Background`: a uniform world, a black one, a transparent film) skip the path and the
/// wavelengths; the film must get bit for bit what the path gives (`render.rs` turns a path
/// into its film value this way). Rays that hit keep their closest hit; a textured world is
/// never taken as a background.
#[test]
fn background_camera_rays_give_the_film_what_their_path_gives() {
    use prism::integrator::{CameraRay, PathTracer};
    use prism::sampler::{ImageSampler, SamplerKind};
    let uniform = furnace_scene(
        diffuse_material("grey", Vec3::splat(0.5)),
        Vec3::new(0.3, 0.6, 0.9),
    );
    let mut black = uniform.clone();
    black.world.color = Vec3::ZERO;
    // A sun whose disc (0.9 rad across) the camera, looking down -z from z = 3, sees around
    // the sphere: its rays need the path.
    let mut sun = uniform.clone();
    sun.lights.push(prism::scene::PunctualLightDesc {
        name: "sun".into(),
        kind: prism::scene::PunctualKind::Directional,
        color: Vec3::ONE,
        intensity: 3.0,
        direction: Vec3::Z,
        angle: 0.9,
        ..Default::default()
    });
    let scenes = [
        (
            "uniform",
            Scene::build(uniform).expect("scene builds"),
            false,
        ),
        ("black", Scene::build(black).expect("scene builds"), false),
        (
            "transparent",
            Scene::build(furnace_scene(
                diffuse_material("grey", Vec3::splat(0.5)),
                Vec3::ONE,
            ))
            .expect("scene builds"),
            true,
        ),
        ("map", env_scene(test_texture(0.0)), false),
        ("sun", Scene::build(sun).expect("scene builds"), false),
    ];
    for (name, scene, transparent) in &scenes {
        let tracer = PathTracer::new(scene, 8, LightSelection::Tree)
            .with_transparent_background(*transparent);
        let pixels = ImageSampler::new(SamplerKind::Sobol, 4, 3);
        let camera = scene.camera_for(32, 32);
        let (mut background, mut paths, mut escaped) = (0, 0, 0);
        for y in 0..16u32 {
            for x in 0..16u32 {
                let raster = Vec2::new(x as f32 * 2.0 + 0.5, y as f32 * 2.0 + 0.5);
                let ray = camera.generate_ray(raster, Vec2::ZERO).expect("ray");
                let mut sampler = pixels.pixel(x, y, 16).sample(0);
                let w = SampledWavelengths::sample_hero(sampler.wavelength().x, Default::default());
                let path = tracer.radiance(ray, &w, &mut sampler);
                match tracer.camera_ray(&ray, true) {
                    CameraRay::Background { xyz, alpha } => {
                        background += 1;
                        assert!(*name != "map", "{name}: a textured world needs the path");
                        let (world, world_xyz) = path
                            .world_exact
                            .unwrap_or((SampledSpectrum::ZERO, Vec3::ZERO));
                        let film = prism::spectrum::spectrum_to_xyz(&(path.radiance - world), &w)
                            + world_xyz;
                        assert_eq!(film, xyz, "{name}: pixel ({x}, {y})");
                        assert_eq!(path.alpha, alpha, "{name}: pixel ({x}, {y})");
                    }
                    CameraRay::Path { first_hit } => {
                        paths += 1;
                        escaped += usize::from(matches!(first_hit, Some(None)));
                        let hit = scene.geometry.intersect(&ray, f32::INFINITY);
                        assert_eq!(
                            first_hit.map(|h| h.map(|h| (h.t, h.prim, h.instance))),
                            Some(hit.map(|h| (h.t, h.prim, h.instance))),
                            "{name}: pixel ({x}, {y})"
                        );
                    }
                }
            }
        }
        println!("{name}: {background} background rays, {paths} paths ({escaped} escaping)");
        // (The textured-world scene has moved its object out of view.)
        assert!(
            *name == "map" || paths > escaped,
            "{name}: the sphere is in view"
        );
        // Escaping rays that need the path: the textured world everywhere, the sun's disc.
        assert_eq!(
            escaped > 0,
            matches!(*name, "map" | "sun"),
            "{name}: {escaped} escaping paths"
        );
        assert_eq!(
            background > 0,
            *name != "map",
            "{name}: {background} background rays"
        );
    }
}
