//! Pixel reconstruction filters (src/film/filter.rs):
//! - chi-square goodness of fit of every filter's offset sampling against its density;
//! - the tabulated density is the filter it claims to be: Blender Cycles' Gaussian and
//!   Blackman–Harris with Cycles' width convention, written out independently here;
//! - an analytic image: a straight emitter edge through the image centre renders, column by
//!   column, as the filter's cumulative distribution evaluated at the edge's distance from
//!   the pixel centre (box: a hard step; Blackman–Harris 1.5 px: a 3-pixel ramp).

#[path = "common/stats.rs"]
mod stats;

mod common;

use common::scenes::camera;
use glam::{Mat4, Vec3};
use prism::film::{FilterKind, PixelFilter};
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{GltfMaterialDesc, InstanceDesc, MaterialDesc, MeshDesc, Scene, SceneDesc};
use stats::{chi2_test, Pcg32};

const KINDS: [(FilterKind, f32); 6] = [
    (FilterKind::Box, 1.0),
    (FilterKind::Box, 2.0),
    (FilterKind::Gaussian, 1.5),
    (FilterKind::Gaussian, 0.7),
    (FilterKind::BlackmanHarris, 1.5),
    (FilterKind::BlackmanHarris, 3.0),
];

/// Blender Cycles' filter profiles (scene/film.cpp: the table builder scales the user width by
/// 3 for the Gaussian and by 2 for Blackman–Harris and tabulates over half that span), as
/// functions of the offset `x` from the pixel centre for the user width `w`.
fn cycles_profile(kind: FilterKind, w: f64, x: f64) -> f64 {
    match kind {
        FilterKind::Box => {
            if x.abs() <= 0.5 * w {
                1.0
            } else {
                0.0
            }
        }
        FilterKind::Gaussian => {
            let span = 3.0 * w;
            if x.abs() > 0.5 * span {
                return 0.0;
            }
            let v = x * 6.0 / span;
            (-2.0 * v * v).exp()
        }
        FilterKind::BlackmanHarris => {
            let span = 2.0 * w;
            if x.abs() > 0.5 * span {
                return 0.0;
            }
            let v = std::f64::consts::TAU * (x / span + 0.5);
            0.35875 - 0.48829 * v.cos() + 0.14128 * (2.0 * v).cos() - 0.01168 * (3.0 * v).cos()
        }
    }
}

/// Cumulative distribution of the normalised Cycles profile at `x` (midpoint rule, 20k steps).
fn cycles_cdf(kind: FilterKind, w: f64, x: f64) -> f64 {
    let r = match kind {
        FilterKind::Box => 0.5 * w,
        FilterKind::Gaussian => 1.5 * w,
        FilterKind::BlackmanHarris => w,
    };
    let n = 20_000;
    let h = 2.0 * r / n as f64;
    let (mut below, mut total) = (0.0, 0.0);
    for i in 0..n {
        let t = -r + (i as f64 + 0.5) * h;
        let f = cycles_profile(kind, w, t);
        total += f;
        if t < x {
            below += f;
        }
    }
    below / total
}

#[test]
fn filter_sampling_matches_its_density_chi_square() {
    let samples = 400_000;
    for (case, &(kind, width)) in KINDS.iter().enumerate() {
        let f = PixelFilter::new(kind, width).unwrap();
        let r = f.radius();
        // 128 histogram bins over [-r, r], the expected counts by midpoint quadrature of the
        // density (piecewise constant between the inverse CDF's knots) at 64 points per bin.
        let bins = 128;
        let mut observed = vec![0.0f64; bins];
        let mut rng = Pcg32::new(17, case as u64);
        for _ in 0..samples {
            let x = f.sample_1d(rng.next_f32());
            assert!(x.abs() <= r, "{kind:?} {width}: offset {x} outside +-{r}");
            let b = (((x + r) / (2.0 * r)) * bins as f32) as usize;
            observed[b.min(bins - 1)] += 1.0;
        }
        let sub = 64;
        let mut total = 0.0;
        let expected: Vec<f64> = (0..bins)
            .map(|b| {
                let lo = -r as f64 + 2.0 * r as f64 * b as f64 / bins as f64;
                let h = 2.0 * r as f64 / (bins * sub) as f64;
                let p: f64 = (0..sub)
                    .map(|k| f.pdf_1d((lo + (k as f64 + 0.5) * h) as f32) as f64 * h)
                    .sum();
                total += p;
                p * samples as f64
            })
            .collect();
        assert!(
            (total - 1.0).abs() < 1e-4,
            "{kind:?} {width}: pdf integrates to {total}"
        );
        chi2_test(&observed, &expected, 5.0).assert_fits(1e-4, format!("{kind:?} {width}"));
    }
}

#[test]
fn tabulated_density_is_the_cycles_filter() {
    for &(kind, width) in &KINDS {
        let f = PixelFilter::new(kind, width).unwrap();
        let r = f.radius() as f64;
        // Normalise Cycles' profile numerically, then compare densities across the support
        // (away from the very edge, where the tabulated bin straddles the cut-off).
        let n = 20_000;
        let h = 2.0 * r / n as f64;
        let norm: f64 = (0..n)
            .map(|i| cycles_profile(kind, width as f64, -r + (i as f64 + 0.5) * h) * h)
            .sum();
        let peak = cycles_profile(kind, width as f64, 0.0) / norm;
        for i in 0..200 {
            let x = -0.98 * r + 1.96 * r * (i as f64 + 0.5) / 200.0;
            let want = cycles_profile(kind, width as f64, x) / norm;
            let got = f.pdf_1d(x as f32) as f64;
            assert!(
                (got - want).abs() < 0.01 * peak,
                "{kind:?} {width}: density at {x:.3} is {got:.5}, Cycles' {want:.5}"
            );
        }
    }
}

/// An emissive quad covering x < 0 of the plane z = 0 (tall enough to fill the view), seen by
/// the test camera at (0, 0, 2): its right edge projects onto the image's centre column line.
fn edge_scene() -> Scene {
    let (l, t) = (-50.0, 50.0);
    let positions = vec![
        Vec3::new(l, -t, 0.0),
        Vec3::new(0.0, -t, 0.0),
        Vec3::new(0.0, t, 0.0),
        Vec3::new(l, t, 0.0),
    ];
    let emitter = MaterialDesc {
        gltf: GltfMaterialDesc {
            name: "emitter".into(),
            base_color: glam::Vec4::new(0.0, 0.0, 0.0, 1.0),
            emissive: Vec3::ONE,
            ..Default::default()
        },
        sidecar: None,
        graph: None,
        ..Default::default()
    };
    let desc = SceneDesc {
        meshes: vec![MeshDesc {
            name: "edge".into(),
            positions,
            normals: None,
            uvs: None,
            tangents: None,
            indices: vec![0, 1, 2, 0, 2, 3],
            material: Some(0),
            ..Default::default()
        }],
        instances: vec![InstanceDesc {
            mesh: 0,
            object_to_world: Mat4::IDENTITY,
            name: "edge".into(),
        }],
        materials: vec![emitter],
        camera: Some(camera(2.0, 0.5)),
        ..Default::default()
    };
    Scene::build(desc).expect("edge scene builds")
}

#[test]
fn emitter_edge_renders_as_the_filter_cdf() {
    let scene = edge_scene();
    let (w, h) = (16u32, 4u32);
    for (kind, width) in [
        (FilterKind::Box, 1.0),
        (FilterKind::BlackmanHarris, 1.5),
        (FilterKind::Gaussian, 1.5),
    ] {
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 4096,
            max_depth: 1,
            seed: 3,
            filter: PixelFilter::new(kind, width).unwrap(),
            ..Default::default()
        };
        let (film, _) = render_quiet(&scene, &settings);
        let rgba = film.to_rgba();
        // Column means of the green channel, normalised by the columns far inside the emitter.
        let column = |x: usize| -> f64 {
            (0..h as usize)
                .map(|y| rgba[y * w as usize + x][1] as f64)
                .sum::<f64>()
                / h as f64
        };
        let inside = (column(0) + column(1)) / 2.0;
        assert!(inside > 0.5, "{kind:?}: emitter renders ({inside})");
        let edge = w as f64 / 2.0;
        let mut report = String::new();
        for x in (w as usize / 2 - 4)..(w as usize / 2 + 4) {
            let got = column(x) / inside;
            // The pixel covers the emitter where centre + offset < edge.
            let want = cycles_cdf(kind, width as f64, edge - (x as f64 + 0.5));
            report += &format!(" x{x}: {got:.3}/{want:.3}");
            assert!(
                (got - want).abs() < 0.03,
                "{kind:?} {width}: column {x} is {got:.3}, the filter's CDF gives {want:.3};{report}"
            );
        }
        eprintln!("{kind:?} {width}:{report}");
    }
}
