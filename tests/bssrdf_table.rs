//! Known-answer tests of the photon-beam-diffusion table (`prism::bssrdf`):
//!
//! - rho_eff per albedo equals a direct adaptive quadrature of the PBD profile
//!   (2 pi r (multiple + single scattering)) within 1e-3;
//! - the Catmull-Rom-interpolated profile integrates to the interpolated rho_eff between nodes;
//! - the inversion reflectance -> albedo -> rho_eff round-trips within 1e-3, and
//!   (reflectance, mfp) -> coefficients gives sigma_t' = 1 / mfp;
//! - chi-square of the radius sampling against the profile pdf, and the probe pdf integrates
//!   to the probability of the normal axis over a plane;
//! - presets are Jensen et al. 2001's values scaled by `scale`.

#[path = "common/stats.rs"]
mod stats;

use glam::Vec3;
use prism::bssrdf::media::{coefficients, invert_reflectance, preset};
use prism::bssrdf::table::{pbd_multiple, pbd_single, Boundary, BssrdfTable, N_ALBEDO};
use prism::bssrdf::SeparableBssrdf;
use prism::math::Frame;
use prism::scene::{SubsurfaceCoefficients, SubsurfaceDesc};
use prism::spectrum::SampledSpectrum;
use stats::{adaptive_simpson, chi2_test, Pcg32};
use std::f64::consts::PI;

const ETA: f32 = 1.33;

/// \int_a^b f over the table's own radius segments (the profile is steep near 0 and has a long
/// tail: integrating segment by segment keeps the adaptive quadrature honest).
fn integrate_over_radii(radii: &[f32], f: &mut dyn FnMut(f64) -> f64) -> f64 {
    radii
        .windows(2)
        .map(|w| adaptive_simpson(f, w[0] as f64, w[1] as f64, 1e-9, 4, 30))
        .sum()
}

#[test]
fn rho_eff_matches_direct_integral_of_profile() {
    let table = BssrdfTable::new(ETA);
    let b = Boundary::new(ETA);
    for i in [5usize, 20, 40, 60, 75, 85, 92, 96, 99] {
        let rho = table.albedos[i] as f64;
        let direct = integrate_over_radii(&table.radii, &mut |r| {
            2.0 * PI * r * (pbd_multiple(rho, 1.0 - rho, &b, r) + pbd_single(rho, 1.0 - rho, &b, r))
        });
        let tab = table.rho_eff[i] as f64;
        assert!(
            (direct - tab).abs() < 1e-3,
            "albedo {rho}: table rho_eff {tab} vs direct integral {direct}"
        );
    }
}

#[test]
fn interpolated_profile_integrates_to_interpolated_rho_eff() {
    let table = BssrdfTable::new(ETA);
    for rho in [0.3f32, 0.77, 0.951, 0.9937, 0.99971] {
        let direct = integrate_over_radii(&table.radii, &mut |r| {
            2.0 * PI * r * table.eval(rho, r as f32).0 as f64
        });
        let eff = table.rho_eff_at(rho) as f64;
        assert!(
            (direct - eff).abs() < 1e-3,
            "albedo {rho}: rho_eff {eff} vs integral {direct}"
        );
    }
}

#[test]
fn inversion_round_trip() {
    let table = BssrdfTable::new(ETA);
    let lo = table.rho_eff[1];
    let hi = table.rho_eff[N_ALBEDO - 1];
    for k in 0..=40 {
        let target = 0.01 + 0.024 * k as f32;
        if target <= lo || target >= hi {
            continue;
        }
        let rho = table.invert_rho_eff(target);
        let back = table.rho_eff_at(rho);
        assert!(
            (back - target).abs() < 1e-3,
            "{target} -> albedo {rho} -> {back}"
        );
    }
    // Through the material path: reflectance + mfp -> coefficients -> rho_eff.
    let refl = Vec3::new(0.8, 0.5, 0.2);
    let mfp = Vec3::new(0.01, 0.005, 0.0025);
    let c = invert_reflectance(&table, refl, mfp);
    for ch in 0..3 {
        let st = c.sigma_a[ch] + c.sigma_s_reduced[ch];
        assert!((st * mfp[ch] - 1.0).abs() < 1e-4);
        let eff = table.rho_eff_at(c.sigma_s_reduced[ch] / st);
        assert!((eff - refl[ch]).abs() < 1e-3, "channel {ch}: {eff}");
    }
    let desc = SubsurfaceDesc {
        coefficients: SubsurfaceCoefficients::Reflectance {
            reflectance: refl,
            mfp,
        },
        scale: 1.0,
        eta: ETA,
        ior: None,
        g: 0.0,
        roughness: 0.0,
        method: "table".into(),
        boundary: "dielectric".into(),
        weight: 1.0,
    };
    assert_eq!(coefficients(&desc, &table), c);
}

#[test]
fn presets_and_similarity() {
    let table = BssrdfTable::new(ETA);
    // Jensen et al. 2001, Figure 5: Skin1 sigma_s' = (0.74, 0.88, 1.01), sigma_a = (0.032, 0.17,
    // 0.48) mm^-1; scale 1000 converts to m^-1.
    let (sp, sa) = preset("Skin1").unwrap();
    assert_eq!(sp, Vec3::new(0.74, 0.88, 1.01));
    assert_eq!(sa, Vec3::new(0.032, 0.17, 0.48));
    let desc = |c: SubsurfaceCoefficients, g: f32| SubsurfaceDesc {
        coefficients: c,
        scale: 1000.0,
        eta: ETA,
        ior: None,
        g,
        roughness: 0.0,
        method: "table".into(),
        boundary: "dielectric".into(),
        weight: 1.0,
    };
    let c = coefficients(
        &desc(SubsurfaceCoefficients::Preset("Skin1".into()), 0.5),
        &table,
    );
    assert!((c.sigma_s_reduced - sp * 1000.0).abs().max_element() < 1e-2);
    assert!((c.sigma_a - sa * 1000.0).abs().max_element() < 1e-3);
    // Explicit sigma_s with g: reduced by (1 - g).
    let c = coefficients(
        &desc(
            SubsurfaceCoefficients::Explicit {
                sigma_a: Vec3::splat(0.1),
                sigma_s: Vec3::splat(2.0),
            },
            0.75,
        ),
        &table,
    );
    assert!((c.sigma_s_reduced - Vec3::splat(500.0)).abs().max_element() < 1e-3);
    assert!((c.sigma_s(0.75) - Vec3::splat(2000.0)).abs().max_element() < 1e-2);
    for name in prism::scene::materials_json::SUBSURFACE_PRESETS {
        assert!(preset(name).is_some(), "{name}");
    }
}

#[test]
fn radius_sampling_chi_square() {
    let table = BssrdfTable::new(ETA);
    // Different albedo per wavelength, sigma_t != 1 (scene units).
    let sigma_a = SampledSpectrum([0.05, 0.5, 0.002, 1.0]);
    let sigma_s = SampledSpectrum([2.0, 1.5, 3.0, 0.5]);
    let b = SeparableBssrdf::new(&table, sigma_a, sigma_s, 4);
    for ch in 0..4 {
        let r_max = b.r_max(ch) as f64;
        let r_end = *table.radii.last().unwrap() as f64 / (sigma_a[ch] + sigma_s[ch]) as f64;
        // Bins uniform in sqrt(r) up to the probe radius (resolves both the peak near 0 and the
        // tail), plus one bin for the rest of the table's range.
        const BINS: usize = 61;
        let edge = |k: usize| {
            if k == BINS {
                r_end
            } else {
                r_max * (k as f64 / (BINS - 1) as f64).powi(2)
            }
        };
        let n = 200_000;
        let mut rng = Pcg32::new(11, ch as u64);
        let mut observed = vec![0.0f64; BINS];
        for _ in 0..n {
            let r = b.sample_sr(ch, rng.next_f32()).expect("radius") as f64;
            assert!(r >= 0.0 && r <= r_end);
            let k = ((r / r_max).sqrt() * (BINS - 1) as f64) as usize;
            observed[k.min(BINS - 1)] += 1.0;
        }
        let mut total = 0.0;
        let expected: Vec<f64> = (0..BINS)
            .map(|k| {
                let p = adaptive_simpson(
                    &mut |r| 2.0 * PI * r * b.pdf_sr(ch, r as f32) as f64,
                    edge(k),
                    edge(k + 1),
                    1e-8,
                    3,
                    25,
                );
                total += p;
                p * n as f64
            })
            .collect();
        assert!(
            (total - 1.0).abs() < 2e-3,
            "channel {ch}: pdf integrates to {total}"
        );
        // r_max holds 99.9% of the profile (interpolated between albedo nodes).
        let tail = expected[BINS - 1] / n as f64;
        assert!(
            tail > 2e-4 && tail < 2e-3,
            "channel {ch}: mass beyond r_max {tail}"
        );
        chi2_test(&observed, &expected, 5.0).assert_fits(1e-3, format!("channel {ch}"));
    }
}

#[test]
fn probe_pdf_over_a_plane_is_the_normal_axis_probability() {
    let table = BssrdfTable::new(ETA);
    let b = SeparableBssrdf::new(
        &table,
        SampledSpectrum([0.05, 0.5, 0.002, 1.0]),
        SampledSpectrum([2.0, 1.5, 3.0, 0.5]),
        4,
    );
    let frame = Frame::from_normal(Vec3::Z);
    let r_max = (0..4).map(|c| b.r_max(c)).fold(0.0f32, f32::max) as f64;
    // \int_plane pdf_sp dA in polar coordinates: tangent probes never reach a plane.
    let total = adaptive_simpson(
        &mut |r| {
            2.0 * PI
                * r
                * b.pdf_sp(Vec3::ZERO, &frame, Vec3::new(r as f32, 0.0, 0.0), Vec3::Z) as f64
        },
        0.0,
        r_max,
        1e-7,
        6,
        30,
    );
    let normal = prism::bssrdf::AXIS_PROB[2] as f64;
    assert!((total - normal).abs() < 2e-3, "{total} vs {normal}");
}
