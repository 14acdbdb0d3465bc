//! Hero-wavelength MIS on a rough dispersive interface, checked without the renderer.
//!
//! The quantity is a spectrally weighted directional albedo of a rough dispersive dielectric,
//! T = (1 / range) \int c(lambda) A(lambda) dlambda with A(lambda) = \int f(wo, wi, lambda)
//! |cos wi| dwi and c a colour-matching-like bump (so that the wavelength matters to the noise).
//! Two estimators must agree:
//! * single wavelength: lambda ~ the visible-band density, wi sampled with eta(lambda),
//!   f |cos| / pdf;
//! * hero: lambda_h ~ the same density, with 3 rotations, wi sampled with the hero's eta,
//!   every member's own f, weighted by `SpectralMis` exactly as the path tracer does
//!   (Wilkie et al. 2014).
//!
//! With strong dispersion (eta 1.52 at 830 nm to 1.89 at 360 nm) and directions from inside
//! the glass (total internal reflection differs per wavelength), a wrong weight shows up as a
//! bias; terminating the secondaries or weighting them by the hero's density alone shows up
//! as extra variance.

#[path = "common/stats.rs"]
mod stats;

use glam::{Vec2, Vec3};
use prism::bsdf::{Bsdf, DielectricBsdf};
use prism::integrator::spectral_mis::SpectralMis;
use prism::spectrum::{SampledSpectrum, SampledWavelengths, WavelengthPdf, N_WAVELENGTHS};
use stats::Pcg32;

fn cauchy(lambda_nm: f32) -> f32 {
    let um = lambda_nm * 1e-3;
    1.45 + 0.05 / (um * um)
}

/// A bump around 600 nm, like one lobe of a colour-matching function.
fn weight(lambda_nm: f32) -> f64 {
    (-((lambda_nm as f64 - 600.0) / 40.0).powi(2)).exp()
}

fn bsdf(w: &SampledWavelengths, alpha: f32) -> Bsdf {
    Bsdf::Dielectric(DielectricBsdf {
        eta: SampledSpectrum::from_fn(|i| cauchy(w.lambda[i])),
        alpha,
        transmission_tint: SampledSpectrum::ONE,
        iridescence: None,
        refraction_only: false,
        energy_compensation: true,
    })
}

struct Estimate {
    mean: f64,
    std_err: f64,
}

fn estimate(samples: impl Iterator<Item = f64>) -> Estimate {
    let (mut n, mut sum, mut sum2) = (0f64, 0f64, 0f64);
    for x in samples {
        n += 1.0;
        sum += x;
        sum2 += x * x;
    }
    let mean = sum / n;
    Estimate {
        mean,
        std_err: ((sum2 / n - mean * mean).max(0.0) / n).sqrt(),
    }
}

/// `better`'s standard error is below `max_ratio` times `worse`'s.
fn assert_less_noisy(better: &Estimate, b: &str, worse: &Estimate, w: &str, max_ratio: f64) {
    println!(
        "std err {b} {:.6}, {w} {:.6}",
        better.std_err, worse.std_err
    );
    assert!(
        better.std_err < max_ratio * worse.std_err,
        "{b} {} vs {w} {}",
        better.std_err,
        worse.std_err
    );
}

/// One sample of T with one wavelength per path.
fn single_sample(rng: &mut Pcg32, wo: Vec3, alpha: f32) -> f64 {
    let w = SampledWavelengths::sample_single(rng.next_f32(), WavelengthPdf::Visible);
    let b = bsdf(&w, alpha);
    let (uc, u) = (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
    match b.sample(wo, uc, u) {
        Some(s) => {
            (s.f[0] * s.wi.z.abs() / s.pdf) as f64 * weight(w.lambda[0])
                / (w.hero_pdf[0] as f64 * 470.0)
        }
        None => 0.0,
    }
}

/// One sample of T with hero wavelength sampling and the path tracer's MIS weights; also
/// returns the member weights' sum (must be 1).
fn hero_sample(rng: &mut Pcg32, wo: Vec3, alpha: f32) -> (f64, f32) {
    hero_sample_with(rng, wo, alpha, true)
}

/// `use_mis == false`: every member weighted by the hero's density alone (f_j / p_h), which is
/// unbiased wherever the supports agree but ignores how well the other members would have
/// sampled the direction.
fn hero_sample_with(rng: &mut Pcg32, wo: Vec3, alpha: f32, use_mis: bool) -> (f64, f32) {
    let w = SampledWavelengths::sample_hero(rng.next_f32(), WavelengthPdf::Visible);
    let b = bsdf(&w, alpha);
    let (uc, u) = (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
    let Some(s) = b.sample(wo, uc, u) else {
        return (0.0, 1.0);
    };
    let mut mis = SpectralMis::new(&w);
    mis.scatter(s.pdf, s.pdf_wavelengths);
    let beta = s.f * (s.wi.z.abs() / s.pdf);
    let contrib = if use_mis {
        beta / mis.denominator()
    } else {
        beta
    };
    // Film: (1/N) sum_j contrib_j c(lambda_j) / pdf_j with pdf_j the mean hero density
    // (what `spectrum_to_xyz` does), then / range.
    let value = (0..N_WAVELENGTHS)
        .map(|j| contrib[j] as f64 * weight(w.lambda[j]) / (w.pdf[j] as f64 * 470.0))
        .sum::<f64>()
        / N_WAVELENGTHS as f64;
    (value, mis.member_weights().iter().sum())
}

#[test]
fn hero_mis_matches_single_wavelength_on_rough_dispersive_glass() {
    const N: usize = 400_000;
    let mut checked = 0;
    for (case, (cos_o, inside, alpha)) in [
        (0.9f32, false, 0.2f32),
        (0.3, false, 0.2),
        (0.9, true, 0.2),
        // From inside near the critical angle: TIR depends on the wavelength.
        (0.75, true, 0.2),
        (0.5, true, 0.5),
        (0.6, false, 0.05),
    ]
    .into_iter()
    .enumerate()
    {
        let sin_o = (1.0 - cos_o * cos_o).sqrt();
        let wo = Vec3::new(sin_o, 0.0, if inside { -cos_o } else { cos_o });
        let mut rng = Pcg32::new(17, case as u64);
        let single = estimate((0..N).map(|_| single_sample(&mut rng, wo, alpha)));
        let mut rng = Pcg32::new(29, case as u64);
        let mut worst_weight_sum = 0.0f32;
        let hero = estimate((0..N).map(|_| {
            let (v, sum) = hero_sample(&mut rng, wo, alpha);
            worst_weight_sum = worst_weight_sum.max((sum - 1.0).abs());
            v
        }));
        let sigma = (single.std_err.powi(2) + hero.std_err.powi(2)).sqrt();
        let diff = (hero.mean - single.mean).abs();
        println!(
            "case {case}: cos_o {cos_o} inside {inside} alpha {alpha}: single {:.5} +- {:.5}, hero {:.5} +- {:.5}",
            single.mean, single.std_err, hero.mean, hero.std_err
        );
        assert!(
            diff < 4.0 * sigma + 1e-4,
            "case {case}: hero {} vs single {} (sigma {sigma})",
            hero.mean,
            single.mean
        );
        assert!(
            worst_weight_sum < 1e-5,
            "member weights sum off by {worst_weight_sum}"
        );
        assert!(single.mean > 0.01, "nothing measured: {}", single.mean);
        checked += 1;
    }
    assert_eq!(checked, 6);
}

/// The hero estimator carries 4 wavelengths through a rough dispersive interface, so its
/// spectral noise is far below one wavelength per path (with the secondaries terminated at
/// the interface, as pbrt-v4 does, it would be no better than `single`).
#[test]
fn hero_mis_reduces_variance_of_the_spectral_average() {
    const N: usize = 200_000;
    let wo = Vec3::new(0.6, 0.0, 0.8);
    let mut rng = Pcg32::new(3, 1);
    let single = estimate((0..N).map(|_| single_sample(&mut rng, wo, 0.2)));
    let mut rng = Pcg32::new(5, 1);
    let hero = estimate((0..N).map(|_| hero_sample(&mut rng, wo, 0.2).0));
    assert_less_noisy(&hero, "hero", &single, "single", 0.6);
}

/// At low roughness the members' lobes barely overlap: weighting by the hero's density alone
/// gives the secondaries huge weights where the hero lobe's tail happens to reach them. The
/// balance heuristic over the members removes that.
#[test]
fn hero_mis_beats_hero_density_alone_at_low_roughness() {
    const N: usize = 200_000;
    let wo = Vec3::new(0.6, 0.0, 0.8);
    let mut rng = Pcg32::new(7, 2);
    let mis = estimate((0..N).map(|_| hero_sample_with(&mut rng, wo, 0.03, true).0));
    let mut rng = Pcg32::new(7, 2);
    let naive = estimate((0..N).map(|_| hero_sample_with(&mut rng, wo, 0.03, false).0));
    assert_less_noisy(&mis, "mis", &naive, "hero density alone", 0.7);
}

/// A dispersive rough interface evaluates all its wavelengths in one pass, sharing the terms
/// that do not depend on the IOR (Smith G and G1(wo), and for reflection the half vector and
/// D). Each slot must equal what a non-dispersive interface with that wavelength's IOR gives
/// alone, for the BSDF value and for the density with that wavelength as the hero, in
/// reflection and transmission, from both sides, including total internal reflection.
#[test]
fn per_wavelength_evaluation_matches_each_ior_alone() {
    let mut rng = Pcg32::new(41, 3);
    let etas = SampledSpectrum([1.52, 1.61, 1.74, 1.89]);
    let tint = SampledSpectrum([0.9, 0.8, 1.0, 0.7]);
    let (mut reflections, mut transmissions) = (0, 0);
    for _ in 0..20_000 {
        let mut dir = || {
            let z = 2.0 * rng.next_f32() - 1.0;
            let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
            let s = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(s * phi.cos(), s * phi.sin(), z)
        };
        let (wo, wi) = (dir(), dir());
        let alpha = 0.05 + 0.5 * rng.next_f32();
        let all = DielectricBsdf {
            eta: etas,
            alpha,
            transmission_tint: tint,
            iridescence: None,
            refraction_only: false,
            energy_compensation: true,
        };
        let (f, pdf) = all.eval_pdf_wavelengths(wo, wi);
        for i in 0..N_WAVELENGTHS {
            let one = DielectricBsdf {
                eta: SampledSpectrum::splat(etas[i]),
                alpha,
                transmission_tint: tint,
                iridescence: None,
                refraction_only: false,
                energy_compensation: true,
            };
            let (f1, p1) = one.eval_pdf_wavelengths(wo, wi);
            let close = |a: f32, b: f32| (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + 1e-12;
            assert!(
                close(f[i], f1[i]) && close(pdf[i], p1[0]),
                "slot {i}: wo {wo} wi {wi} alpha {alpha}: f {} vs {}, pdf {} vs {}",
                f[i],
                f1[i],
                pdf[i],
                p1[0]
            );
        }
        if pdf[0] > 0.0 {
            if wo.z * wi.z > 0.0 {
                reflections += 1;
            } else {
                transmissions += 1;
            }
        }
    }
    assert!(
        reflections > 1000 && transmissions > 1000,
        "{reflections} {transmissions}"
    );
}

/// The hero's companions are placed by rotating the hero's primary sample (u + k/N), so every
/// member is distributed by the visible-band density, one per quartile of it. The previous
/// placement rotated the wavelength (lambda + k/N of the range; members weighted by the
/// balance heuristic over their hero densities): about one member per path then fell in the
/// far tails, where it carries almost nothing. Both are unbiased (checked against quadrature);
/// the primary-space rotation must be clearly less noisy on a spectral average.
#[test]
fn primary_space_rotation_is_unbiased_and_beats_wavelength_rotation() {
    const N: usize = 200_000;
    let range = 470.0f64;
    // A reflectance with some structure, seen through the colour-matching-like bump.
    let reflectance = |l: f32| 0.5 + 0.4 * ((l as f64 - 360.0) / 37.0).sin();
    let integrand = |l: f32| weight(l) * reflectance(l);
    let exact = {
        let n = 47_000;
        let h = range / n as f64;
        (0..n)
            .map(|i| integrand((360.0 + (i as f64 + 0.5) * h) as f32) * h)
            .sum::<f64>()
    };
    let film = |w: &SampledWavelengths| {
        let mis = SpectralMis::new(w);
        (0..N_WAVELENGTHS)
            .map(|j| integrand(w.lambda[j]) / (mis.denominator() * w.pdf[j]) as f64)
            .sum::<f64>()
            / N_WAVELENGTHS as f64
    };
    let mut rng = Pcg32::new(11, 4);
    let primary = estimate((0..N).map(|_| {
        film(&SampledWavelengths::sample_hero(
            rng.next_f32(),
            WavelengthPdf::Visible,
        ))
    }));
    let mut rng = Pcg32::new(13, 4);
    let density = WavelengthPdf::Visible;
    let rotated = estimate((0..N).map(|_| {
        let hero = density.sample(rng.next_f32());
        let lambda: [f32; N_WAVELENGTHS] = std::array::from_fn(|k| {
            360.0 + (hero - 360.0 + 470.0 * k as f32 / N_WAVELENGTHS as f32).rem_euclid(470.0)
        });
        let hero_pdf = lambda.map(|l| density.pdf(l));
        let mean = hero_pdf.iter().sum::<f32>() / N_WAVELENGTHS as f32;
        film(&SampledWavelengths {
            lambda,
            pdf: [mean; N_WAVELENGTHS],
            hero_pdf,
        })
    }));
    println!(
        "exact {exact:.6}, primary {:.6} +- {:.6}, wavelength rotation {:.6} +- {:.6}",
        primary.mean, primary.std_err, rotated.mean, rotated.std_err
    );
    for e in [&primary, &rotated] {
        assert!(
            (e.mean - exact).abs() < 4.0 * e.std_err + 1e-6,
            "{} vs {exact}",
            e.mean
        );
    }
    assert_less_noisy(&primary, "primary", &rotated, "wavelength rotation", 0.8);
}
