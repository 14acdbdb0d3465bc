//! Firefly clamps (`--clamp-direct`, `--clamp-indirect`), tested on the estimator with the
//! same random numbers clamped and unclamped, in the Cornell box (whose glass sphere throws a
//! caustic: fireflies of indirect light).
//!
//! - Every pixel's luminance is at most clamp_direct + clamp_indirect (each sample's is, and a
//!   pixel is the mean of its samples: the filter is importance-sampled, weight 1).
//! - Clamping only lowers: per pixel, the clamped luminance <= the unclamped one, and the mean
//!   drops (the clamp bites: the unclamped image has pixels far above the bound).
//! - The split between direct and indirect is Cycles': with max depth 1 (only direct light)
//!   Clamp Indirect changes nothing, bit for bit, and Clamp Direct limits everything.
//! - Clamps of 0 are off: the image is bit-identical to one rendered without them.

use prism::film::{Film, SampleClamp};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, Scene};
use std::path::Path;

const SIZE: u32 = 48;

fn cornell() -> Scene {
    let desc = load_scene(Path::new("scenes/cornell/cornell.gltf"), None, None).unwrap();
    Scene::build(desc).unwrap()
}

fn render(scene: &Scene, spp: u32, max_depth: u32, clamp: SampleClamp) -> Film {
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        max_depth,
        seed: 5,
        clamp,
        ..Default::default()
    };
    render_quiet(scene, &settings).0
}

/// Rec.709 luminance of each pixel (the Y of the film's XYZ).
fn luminance(film: &Film) -> Vec<f64> {
    film.to_rgba()
        .iter()
        .map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64)
        .collect()
}

fn bits(film: &Film) -> Vec<u32> {
    film.to_rgba()
        .iter()
        .flat_map(|p| p.map(f32::to_bits))
        .collect()
}

#[test]
fn clamped_pixels_stay_under_the_bound_and_only_lose_energy() {
    let scene = cornell();
    let (direct, indirect) = (4.0, 1.0);
    let clamp = SampleClamp::new(direct, indirect).unwrap();
    let plain = luminance(&render(&scene, 64, 16, SampleClamp::default()));
    let clamped = luminance(&render(&scene, 64, 16, clamp));
    let bound = (direct + indirect) as f64;
    let max = clamped.iter().cloned().fold(0.0, f64::max);
    let plain_max = plain.iter().cloned().fold(0.0, f64::max);
    eprintln!("max pixel luminance: clamped {max:.3} (bound {bound}), unclamped {plain_max:.3}");
    // 1e-4 relative: the film's XYZ -> Rec.709 -> luminance round trip in f32.
    assert!(max <= bound * (1.0 + 1e-4), "pixel above the bound: {max}");
    assert!(
        plain_max > 2.0 * bound,
        "the scene has no firefly to clamp: {plain_max}"
    );
    for (i, (c, p)) in clamped.iter().zip(&plain).enumerate() {
        assert!(
            *c <= p * (1.0 + 1e-4) + 1e-7,
            "pixel {i}: {c} > unclamped {p}"
        );
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (mc, mp) = (mean(&clamped), mean(&plain));
    eprintln!("mean luminance: clamped {mc:.4}, unclamped {mp:.4}");
    assert!(mc < mp, "clamping removed no energy");
}

#[test]
fn direct_and_indirect_split_as_in_cycles() {
    let scene = cornell();
    // Max depth 1: direct light only (emission seen, one bounce to a light, and next-event
    // estimation at the first hit): all of it is "direct".
    let plain = render(&scene, 16, 1, SampleClamp::default());
    let indirect_clamped = render(&scene, 16, 1, SampleClamp::new(0.0, 1e-6).unwrap());
    assert_eq!(bits(&plain), bits(&indirect_clamped));
    let direct_clamped = luminance(&render(&scene, 16, 1, SampleClamp::new(1e-3, 0.0).unwrap()));
    let max = direct_clamped.iter().cloned().fold(0.0, f64::max);
    assert!(
        max <= 1e-3 * (1.0 + 1e-4),
        "direct light above its clamp: {max}"
    );
    // With more bounces, a tiny direct clamp leaves the indirect light: the image is not black.
    let indirect_only = luminance(&render(
        &scene,
        16,
        16,
        SampleClamp::new(1e-6, 0.0).unwrap(),
    ));
    let mean = indirect_only.iter().sum::<f64>() / indirect_only.len() as f64;
    assert!(mean > 0.02, "indirect light missing: mean {mean}");
}

#[test]
fn zero_clamps_change_nothing() {
    let scene = cornell();
    let plain = render(&scene, 8, 16, SampleClamp::default());
    let zero = render(&scene, 8, 16, SampleClamp::new(0.0, 0.0).unwrap());
    assert_eq!(bits(&plain), bits(&zero));
    // Through the binary too: the same EXR bytes with and without "--clamp-* 0".
    let dir = std::env::temp_dir();
    let run = |name: &str, extra: &[&str]| -> Vec<u8> {
        let out = dir.join(format!("prism_clamp_{}_{name}.exr", std::process::id()));
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_prism"))
            .args([
                "render",
                "scenes/cornell/cornell.gltf",
                "--width",
                "24",
                "--height",
                "24",
            ])
            .args([
                "--spp",
                "4",
                "--progress",
                "none",
                "-o",
                out.to_str().unwrap(),
            ])
            .args(extra)
            .status()
            .unwrap();
        assert!(status.success());
        let bytes = std::fs::read(&out).unwrap();
        std::fs::remove_file(&out).ok();
        bytes
    };
    assert_eq!(
        run("plain", &[]),
        run("zero", &["--clamp-direct", "0", "--clamp-indirect", "0"])
    );
    assert_ne!(run("plain2", &[]), run("on", &["--clamp-indirect", "0.05"]));
}
