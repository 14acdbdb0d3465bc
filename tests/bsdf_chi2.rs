//! Statistical and physical tests of every BSDF in `prism::bsdf`:
//!
//! - chi-square goodness of fit of each sampling routine against its own `pdf` (in the spirit
//!   of Mitsuba's chi2 test: 20 x 40 bins in (cos theta, phi) over the whole sphere, expected
//!   counts by adaptive Simpson integration of the pdf, sparse cells pooled, Sidak-corrected
//!   significance), plus `sample().f/pdf == eval()/pdf()` consistency;
//! - white-furnace energy bounds, exact smooth-dielectric R + T = 1, Fresnel/Snell directions;
//! - reciprocity (and the generalized reciprocity of refraction);
//! - degenerate inputs never produce NaN/Inf.

#[path = "common/stats.rs"]
mod stats;

use glam::{Vec2, Vec3};
use prism::bsdf::microfacet::TrowbridgeReitz;
use prism::bsdf::{
    fresnel_dielectric, Bsdf, DielectricBsdf, DiffuseBsdf, MetallicRoughnessBsdf, TranslucentBsdf,
};
use prism::spectrum::SampledSpectrum;
use rayon::prelude::*;
use stats::{adaptive_simpson_2d, chi2_test, Pcg32};
use std::f64::consts::PI;

const THETA_BINS: usize = 20;
const PHI_BINS: usize = 40;
const SAMPLES: usize = 500_000; // multiple of CHUNKS
/// Absolute error goal of each bin's probability (1e-7 = 0.1 expected samples).
const INTEGRATION_EPS: f64 = 1e-7;
/// Every CHECK_EVERY-th sample is compared with eval()/pdf().
const CHECK_EVERY: usize = 4;
/// Sampling runs in this many independent streams (in parallel).
const CHUNKS: usize = 8;
/// Family-wise significance level of all chi-square tests together.
const ALPHA: f64 = 0.01;

fn color() -> SampledSpectrum {
    SampledSpectrum([0.9, 0.55, 0.25, 0.7])
}

/// Unit direction with the given cos(theta) and azimuth.
fn dir(cos_theta: f32, phi: f32) -> Vec3 {
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), cos_theta)
}

fn wo_at(cos_theta: f32) -> Vec3 {
    dir(cos_theta, 0.9)
}

fn diffuse(r: SampledSpectrum) -> Bsdf {
    Bsdf::Diffuse(DiffuseBsdf { reflectance: r })
}

fn metallic_roughness(base: SampledSpectrum, metallic: f32, roughness: f32, specular: f32) -> Bsdf {
    Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
        base_color: base,
        metallic,
        alpha: roughness * roughness,
        specular,
        specular_color: SampledSpectrum([1.0, 0.9, 0.8, 1.0]),
        ior: 1.5,
        energy_compensation: true,
        principled_v1: false,
        coat: prism::bsdf::Coat::NONE,
        sheen: prism::bsdf::Sheen::NONE,
        iridescence: None,
        view: None,
    })
}

/// Energy-compensated (the renderer's default) rough glass.
fn dielectric(eta: f32, roughness: f32) -> Bsdf {
    Bsdf::Dielectric(DielectricBsdf {
        eta: SampledSpectrum::splat(eta),
        alpha: roughness * roughness,
        transmission_tint: SampledSpectrum::ONE,
        iridescence: None,
        refraction_only: false,
        energy_compensation: true,
    })
}

/// Walter et al.'s single-scattering rough glass, uncompensated.
fn single_scattering_dielectric(eta: f32, roughness: f32) -> Bsdf {
    match dielectric(eta, roughness) {
        Bsdf::Dielectric(d) => Bsdf::Dielectric(DielectricBsdf {
            energy_compensation: false,
            ..d
        }),
        _ => unreachable!(),
    }
}

/// A metallic-roughness material under a clear coat (`prism::bsdf::coat`).
fn coated(base: Bsdf, weight: f32, roughness: f32, tint: SampledSpectrum) -> Bsdf {
    match base {
        Bsdf::MetallicRoughness(b) => Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
            coat: prism::bsdf::Coat {
                weight,
                alpha: roughness * roughness,
                ior: 1.5,
                tint,
                normal: Vec3::Z,
                additive: false,
            },
            ..b
        }),
        _ => unreachable!(),
    }
}

/// `coated` with the coat's own normal `n` (local frame): a smooth coat over a bumped base.
fn coated_tilted(base: Bsdf, weight: f32, roughness: f32, n: Vec3) -> Bsdf {
    match coated(base, weight, roughness, SampledSpectrum::ONE) {
        Bsdf::MetallicRoughness(mut b) => {
            b.coat.normal = n.normalize();
            Bsdf::MetallicRoughness(b)
        }
        _ => unreachable!(),
    }
}

/// A material under a sheen of colour `color` (max component `scale`) and `roughness`
/// (`prism::bsdf::sheen`): Cycles' microfibre sheen over an energy-conserving base, the
/// Charlie sheen of `KHR_materials_sheen` over the glTF BRDF, Blender 3.x's Disney sheen over
/// its Principled (as `scene::material` pairs them).
fn sheened(base: Bsdf, color: SampledSpectrum, roughness: f32) -> Bsdf {
    match base {
        Bsdf::MetallicRoughness(b) => Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
            sheen: prism::bsdf::Sheen {
                color,
                scale: color.max_component(),
                roughness,
                model: if b.principled_v1 {
                    prism::bsdf::SheenModel::Disney
                } else if b.energy_compensation {
                    prism::bsdf::SheenModel::Microfibre
                } else {
                    prism::bsdf::SheenModel::Charlie
                },
            },
            ..b
        }),
        _ => unreachable!(),
    }
}

/// A 350 nm soap film (IOR 1.33) at four visible wavelengths.
fn soap_film() -> Option<prism::bsdf::Iridescence> {
    Some(prism::bsdf::Iridescence {
        film: prism::bsdf::ThinFilm {
            thickness_nm: 350.0,
            ior: 1.33,
        },
        weight: 1.0,
        lambda: SampledSpectrum([420.0, 500.0, 580.0, 660.0]),
        averages: None,
    })
}

/// A metallic-roughness material whose specular layer carries the soap film.
fn filmed(b: Bsdf) -> Bsdf {
    match b {
        Bsdf::MetallicRoughness(b) => Bsdf::MetallicRoughness(
            MetallicRoughnessBsdf {
                iridescence: soap_film(),
                ..b
            }
            .with_film_averages(),
        ),
        _ => unreachable!(),
    }
}

/// Glass (IOR 1.5) under the soap film.
fn thin_film_glass(roughness: f32) -> Bsdf {
    Bsdf::Dielectric(DielectricBsdf {
        iridescence: soap_film(),
        ..match dielectric(1.5, roughness) {
            Bsdf::Dielectric(d) => d,
            _ => unreachable!(),
        }
    })
}

/// The glTF 2.0 spec's BRDF as written (`"model": "gltf"`), single scattering.
fn gltf_metallic_roughness(base: SampledSpectrum, metallic: f32, roughness: f32) -> Bsdf {
    match metallic_roughness(base, metallic, roughness, 1.0) {
        Bsdf::MetallicRoughness(b) => Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
            energy_compensation: false,
            ..b
        }),
        _ => unreachable!(),
    }
}

/// Blender 3.x's Principled BSDF as Cycles 3.x renders it (`principled_v1`): Burley's diffuse
/// under an additive single-scattering specular layer.
fn principled_v1(base: SampledSpectrum, metallic: f32, roughness: f32, specular: f32) -> Bsdf {
    match metallic_roughness(base, metallic, roughness, specular) {
        Bsdf::MetallicRoughness(b) => Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
            energy_compensation: false,
            principled_v1: true,
            specular_color: SampledSpectrum::ONE,
            ..b
        }),
        _ => unreachable!(),
    }
}

fn relative_eq(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()) || (a - b).abs() < 1e-30
}

// ---------------------------------------------------------------------------------------------
// Chi-square machinery
// ---------------------------------------------------------------------------------------------

/// What is being tested: a BSDF's `sample` against its `pdf` for a fixed `wo`, or the GGX
/// visible-normal sampler against `d_visible` (anisotropic alphas, not reachable via `Bsdf`).
/// (A test's few values: the size difference does not matter.)
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)]
enum Target {
    Bsdf(Bsdf),
    Vndf(TrowbridgeReitz),
}

#[derive(Clone, Copy, Debug)]
struct Chi2Case {
    family: &'static str,
    name: &'static str,
    target: Target,
    wo: Vec3,
    /// Extra labels for the message.
    params: [f32; 3],
}

fn chi2_cases() -> Vec<Chi2Case> {
    let mut cases = Vec::new();
    let mut push = |family, name, target, wo, params| {
        cases.push(Chi2Case {
            family,
            name,
            target,
            wo,
            params,
        })
    };
    for c in [0.1, 0.7] {
        push(
            "diffuse",
            "diffuse",
            Target::Bsdf(diffuse(color())),
            wo_at(c),
            [c, 0.0, 0.0],
        );
    }
    // Lambertian transmission from either side.
    for c in [0.2f32, -0.7] {
        push(
            "diffuse",
            "translucent(cos_o)",
            Target::Bsdf(Bsdf::Translucent(TranslucentBsdf {
                transmittance: color(),
            })),
            wo_at(c.abs()) * Vec3::new(1.0, 1.0, c.signum()),
            [c, 0.0, 0.0],
        );
    }
    for metallic in [0.0, 0.5, 1.0] {
        for roughness in [0.1, 0.5, 1.0] {
            for specular in [0.0, 1.0] {
                for c in [0.1, 0.5, 0.95] {
                    let b = metallic_roughness(color(), metallic, roughness, specular);
                    push(
                        "metallic_roughness",
                        "metallic_roughness(metallic, roughness, specular)",
                        Target::Bsdf(b),
                        wo_at(c),
                        [metallic, roughness, specular],
                    );
                }
            }
        }
    }
    // The glTF spec's layering (no multiple-scattering lobe, different lobe choice).
    for (metallic, roughness) in [(0.0, 0.5), (0.5, 1.0)] {
        push(
            "metallic_roughness",
            "gltf-model metallic_roughness(metallic, roughness, specular)",
            Target::Bsdf(gltf_metallic_roughness(color(), metallic, roughness)),
            wo_at(0.4),
            [metallic, roughness, 1.0],
        );
    }
    // Blender 3.x's Principled under its Disney sheen (cosine-weighted).
    push(
        "metallic_roughness",
        "sheened principled-v1 metallic_roughness(metallic, roughness, specular)",
        Target::Bsdf(sheened(
            principled_v1(color(), 0.3, 0.5, 1.0),
            SampledSpectrum([0.9, 0.6, 0.8, 0.7]),
            0.5,
        )),
        wo_at(0.3),
        [0.3, 0.5, 1.0],
    );
    // Blender 3.x's Principled (Burley's diffuse, Cycles 3.x's Fresnel, added layers).
    for (metallic, roughness) in [(0.0, 0.5), (0.3, 0.9), (1.0, 0.3)] {
        push(
            "metallic_roughness",
            "principled-v1 metallic_roughness(metallic, roughness, specular)",
            Target::Bsdf(principled_v1(color(), metallic, roughness, 1.0)),
            wo_at(0.4),
            [metallic, roughness, 1.0],
        );
    }
    // Clear coats: rough over a rough base (both models), and rough over a smooth metal (the
    // coat's multiple scattering is then sampled by the cosine branch alone).
    for (metallic, roughness, coat_roughness) in [(0.0, 0.5, 0.3), (1.0, 0.7, 0.6), (1.0, 0.0, 0.8)]
    {
        for gltf in [false, true] {
            let base = if gltf {
                gltf_metallic_roughness(color(), metallic, roughness)
            } else {
                metallic_roughness(color(), metallic, roughness, 1.0)
            };
            push(
                "metallic_roughness",
                "coated metallic_roughness(metallic, roughness, coat roughness)",
                Target::Bsdf(coated(base, 0.8, coat_roughness, color())),
                wo_at(0.45),
                [metallic, roughness, coat_roughness],
            );
        }
    }
    // A coat whose normal is not the base's (a bumped base under a smooth coat; Coat Normal).
    for (metallic, roughness, coat_roughness) in [(0.0f32, 0.5f32, 0.3f32), (1.0, 0.4, 0.6)] {
        push(
            "metallic_roughness",
            "tilted-coat metallic_roughness(metallic, roughness, coat roughness)",
            Target::Bsdf(coated_tilted(
                metallic_roughness(color(), metallic, roughness, 1.0),
                0.8,
                coat_roughness,
                Vec3::new(0.3, -0.2, 0.93),
            )),
            wo_at(0.5),
            [metallic, roughness, coat_roughness],
        );
    }
    // Sheen over a rough dielectric base, a smooth metal (Dirac samples under the sheen) and a
    // coated base, at a near-normal and a grazing view.
    for (metallic, roughness, sheen_roughness) in
        [(0.0, 0.5, 0.3), (1.0, 0.0, 0.8), (0.0, 0.3, 1.0)]
    {
        for c in [0.8f32, 0.2] {
            let base = metallic_roughness(color(), metallic, roughness, 1.0);
            let base = if sheen_roughness == 1.0 {
                coated(base, 0.6, 0.3, color())
            } else {
                base
            };
            push(
                "metallic_roughness",
                "sheened metallic_roughness(metallic, roughness, sheen roughness)",
                Target::Bsdf(sheened(
                    base,
                    SampledSpectrum([0.9, 0.6, 0.8, 0.7]),
                    sheen_roughness,
                )),
                wo_at(c),
                [metallic, roughness, sheen_roughness],
            );
        }
    }
    // A thin film on the specular layer of an opaque material.
    for roughness in [0.2f32, 0.6] {
        push(
            "metallic_roughness",
            "thin-film metallic_roughness(metallic, roughness, specular)",
            Target::Bsdf(filmed(metallic_roughness(color(), 0.0, roughness, 1.0))),
            wo_at(0.5),
            [0.0, roughness, 1.0],
        );
    }
    // ... and on the conductor (Principled Thin Film on the metallic part), alone and mixed.
    for (metallic, roughness) in [(1.0f32, 0.3f32), (0.5, 0.6)] {
        push(
            "metallic_roughness",
            "thin-film metallic_roughness(metallic, roughness, specular)",
            Target::Bsdf(filmed(metallic_roughness(
                color(),
                metallic,
                roughness,
                1.0,
            ))),
            wo_at(0.6),
            [metallic, roughness, 1.0],
        );
    }
    // Smooth GGX limit: Dirac mirror lobe + diffuse; only the diffuse part has a density.
    for c in [0.3, 0.9] {
        let b = metallic_roughness(color(), 0.3, 0.0, 1.0);
        push(
            "metallic_roughness",
            "smooth metallic_roughness(metallic, roughness, specular)",
            Target::Bsdf(b),
            wo_at(c),
            [0.3, 0.0, 1.0],
        );
    }
    for eta in [1.5, 1.0 / 1.5] {
        for roughness in [0.1, 0.3, 0.7] {
            for side in [1.0f32, -1.0] {
                for c in [0.1, 0.5, 0.95] {
                    push(
                        "dielectric",
                        "rough dielectric(eta, roughness, cos_o)",
                        Target::Bsdf(dielectric(eta, roughness)),
                        wo_at(c) * Vec3::new(1.0, 1.0, side),
                        [eta, roughness, side * c],
                    );
                }
            }
        }
    }
    // Blender's Refraction BSDF: the transmission lobe alone (no Fresnel split).
    for (eta, roughness) in [(1.5, 0.3), (1.33, 0.7)] {
        for side in [1.0f32, -1.0] {
            let b = Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum::splat(eta),
                alpha: roughness * roughness,
                transmission_tint: SampledSpectrum::ONE,
                iridescence: None,
                refraction_only: true,
                energy_compensation: true,
            });
            push(
                "dielectric",
                "rough refraction-only dielectric(eta, roughness, cos_o)",
                Target::Bsdf(b),
                wo_at(0.5) * Vec3::new(1.0, 1.0, side),
                [eta, roughness, side * 0.5],
            );
        }
    }
    // Dispersive glass: the hero wavelength's lobes.
    for side in [1.0f32, -1.0] {
        let b = Bsdf::Dielectric(DielectricBsdf {
            eta: SampledSpectrum([1.5, 1.52, 1.54, 1.56]),
            alpha: 0.09,
            transmission_tint: color(),
            iridescence: None,
            refraction_only: false,
            energy_compensation: true,
        });
        push(
            "dielectric",
            "dispersive rough dielectric(eta0, alpha, cos_o)",
            Target::Bsdf(b),
            wo_at(0.6) * Vec3::new(1.0, 1.0, side),
            [1.5, 0.09, side * 0.6],
        );
    }
    // A thin film (soap film on glass): each wavelength's own Fresnel split.
    for (roughness, side) in [(0.3f32, 1.0f32), (0.3, -1.0)] {
        push(
            "dielectric",
            "thin-film rough dielectric(eta, roughness, cos_o)",
            Target::Bsdf(thin_film_glass(roughness)),
            wo_at(0.6) * Vec3::new(1.0, 1.0, side),
            [1.5, roughness, side * 0.6],
        );
    }
    for (ax, ay) in [(0.5, 0.1), (0.05, 0.4), (1.0, 0.3)] {
        for c in [0.1, 0.7] {
            push(
                "vndf",
                "GGX visible normals(alpha_x, alpha_y, cos_o)",
                Target::Vndf(TrowbridgeReitz::new(ax, ay)),
                wo_at(c),
                [ax, ay, c],
            );
        }
    }
    cases
}

/// Per-test significance so that all chi-square tests together have level ALPHA (Sidak).
fn per_test_significance() -> f64 {
    let n = chi2_cases().len() as f64;
    1.0 - (1.0 - ALPHA).powf(1.0 / n)
}

fn bin_of(w: Vec3) -> usize {
    let c = ((w.z as f64 + 1.0) * 0.5 * THETA_BINS as f64).floor() as isize;
    let c = c.clamp(0, THETA_BINS as isize - 1) as usize;
    let mut phi = (w.y as f64).atan2(w.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let p = (phi / (2.0 * PI) * PHI_BINS as f64).floor() as isize;
    let p = p.clamp(0, PHI_BINS as isize - 1) as usize;
    c * PHI_BINS + p
}

fn case_pdf(case: &Chi2Case, w: Vec3) -> f64 {
    match case.target {
        Target::Bsdf(b) => b.pdf(case.wo, w) as f64,
        Target::Vndf(m) => m.d_visible(case.wo, w) as f64,
    }
}

struct SampleStats {
    observed: Vec<f64>,
    /// Samples that produced no continuous direction (None, or a Dirac lobe).
    failures: usize,
    /// sample().f / pdf disagreeing with eval() / pdf().
    inconsistent: usize,
    first_inconsistency: Option<String>,
}

fn draw_samples(case: &Chi2Case, seed: u64) -> SampleStats {
    (0..CHUNKS)
        .into_par_iter()
        .map(|chunk| draw_chunk(case, seed, chunk as u64, SAMPLES / CHUNKS))
        .reduce_with(|mut a, b| {
            for (x, y) in a.observed.iter_mut().zip(&b.observed) {
                *x += y;
            }
            a.failures += b.failures;
            a.inconsistent += b.inconsistent;
            a.first_inconsistency = a.first_inconsistency.or(b.first_inconsistency);
            a
        })
        .unwrap()
}

fn draw_chunk(case: &Chi2Case, seed: u64, stream: u64, n: usize) -> SampleStats {
    let mut rng = Pcg32::new(seed, stream);
    let mut observed = vec![0.0; THETA_BINS * PHI_BINS];
    let mut failures = 0;
    let mut inconsistent = 0;
    let mut first_inconsistency = None;
    for k in 0..n {
        let uc = rng.next_f32();
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let wi = match case.target {
            Target::Vndf(m) => Some(m.sample_visible(case.wo, u)),
            Target::Bsdf(b) => match b.sample(case.wo, uc, u) {
                Some(s) if !s.is_specular() && k % CHECK_EVERY != 0 => Some(s.wi),
                Some(s) if !s.is_specular() => {
                    let f = b.eval(case.wo, s.wi);
                    let pdf = b.pdf(case.wo, s.wi);
                    let (_, pdfs) = b.eval_pdf_wavelengths(case.wo, s.wi);
                    let ok = relative_eq(s.pdf, pdf, 1e-3)
                        && (0..4).all(|i| relative_eq(s.f[i], f[i], 1e-3))
                        && (0..4).all(|i| relative_eq(s.pdf_wavelengths[i], pdfs[i], 1e-3))
                        && (s.wi.length() - 1.0).abs() < 1e-4;
                    if !ok {
                        inconsistent += 1;
                        first_inconsistency.get_or_insert_with(|| {
                            format!(
                                "wi {:?}: sample f {:?} pdf {} vs eval {:?} pdf {}",
                                s.wi, s.f, s.pdf, f, pdf
                            )
                        });
                    }
                    Some(s.wi)
                }
                _ => None,
            },
        };
        match wi {
            Some(w) => observed[bin_of(w)] += 1.0,
            None => failures += 1,
        }
    }
    SampleStats {
        observed,
        failures,
        inconsistent,
        first_inconsistency,
    }
}

/// Expected probability of each bin: the pdf integrated over the bin (dw = dcos dphi).
fn integrate_bins(case: &Chi2Case) -> Vec<f64> {
    let dc = 2.0 / THETA_BINS as f64;
    let dp = 2.0 * PI / PHI_BINS as f64;
    (0..THETA_BINS * PHI_BINS)
        .into_par_iter()
        .map(|k| {
            let (ci, pi) = (k / PHI_BINS, k % PHI_BINS);
            let (c0, p0) = (-1.0 + ci as f64 * dc, pi as f64 * dp);
            let f = |c: f64, p: f64| {
                let s = (1.0 - c * c).max(0.0).sqrt();
                let w = Vec3::new((s * p.cos()) as f32, (s * p.sin()) as f32, c as f32);
                case_pdf(case, w)
            };
            adaptive_simpson_2d(&f, c0, c0 + dc, p0, p0 + dp, INTEGRATION_EPS, 3, 14)
        })
        .collect()
}

/// Runs the chi-square test of one case; returns (p-value, message).
fn run_chi2(case: &Chi2Case, seed: u64) -> (f64, String) {
    let t0 = std::time::Instant::now();
    let s = draw_samples(case, seed);
    let t1 = t0.elapsed();
    let probs = integrate_bins(case);
    let t2 = t0.elapsed() - t1;
    let total: f64 = probs.iter().sum();
    let n = SAMPLES as f64;
    let mut expected: Vec<f64> = probs.iter().map(|p| p * n).collect();
    let mut observed = s.observed;
    // The mass the pdf does not cover must match the failed / Dirac samples.
    expected.push(((1.0 - total) * n).max(0.0));
    observed.push(s.failures as f64);
    let r = chi2_test(&observed, &expected, 5.0);
    let msg = format!(
        "{} {:?} wo {:?}: chi2 {:.1} dof {} p {:.3e} (pdf integral {:.5}, failures {}, \
         inconsistent f/pdf {}; sampling {:.2?}, integration {:.2?})",
        case.name,
        case.params,
        case.wo,
        r.chi2,
        r.dof,
        r.p_value,
        total,
        s.failures,
        s.inconsistent,
        t1,
        t2
    );
    assert_eq!(
        s.inconsistent, 0,
        "{msg}: sample() disagrees with eval()/pdf(): {:?}",
        s.first_inconsistency
    );
    assert!(total <= 1.0 + 1e-3, "{msg}: pdf integrates above 1");
    (r.p_value, msg)
}

fn chi2_family(family: &str) {
    let threshold = per_test_significance();
    let mut min_p: f64 = 1.0;
    let mut failures = Vec::new();
    for (i, case) in chi2_cases().iter().enumerate() {
        if case.family != family {
            continue;
        }
        let (p, msg) = run_chi2(case, 1000 + i as u64);
        println!("{msg}");
        min_p = min_p.min(p);
        if !(p > threshold) {
            failures.push(msg);
        }
    }
    println!("{family}: min p-value {min_p:.3e} (threshold {threshold:.3e})");
    assert!(
        failures.is_empty(),
        "chi-square test rejected (p <= {threshold:.3e}):\n{}",
        failures.join("\n")
    );
}

#[test]
fn chi2_diffuse() {
    chi2_family("diffuse");
}

#[test]
fn chi2_metallic_roughness() {
    chi2_family("metallic_roughness");
}

#[test]
fn chi2_rough_dielectric() {
    chi2_family("dielectric");
}

#[test]
fn chi2_ggx_visible_normals() {
    chi2_family("vndf");
}

/// The test can detect a wrong sampler: a pdf that is off by a mild factor must be rejected.
#[test]
fn chi2_rejects_a_mismatched_pdf() {
    let b = metallic_roughness(color(), 0.5, 0.5, 1.0);
    let wo = wo_at(0.5);
    // Sample from roughness 0.5 but test against the pdf of roughness 0.55.
    let wrong = metallic_roughness(color(), 0.5, 0.55, 1.0);
    let mut rng = Pcg32::new(7, 1);
    let mut observed = vec![0.0; THETA_BINS * PHI_BINS];
    for _ in 0..SAMPLES {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        if let Some(s) = b.sample(wo, rng.next_f32(), u) {
            observed[bin_of(s.wi)] += 1.0;
        }
    }
    let case = Chi2Case {
        family: "",
        name: "",
        target: Target::Bsdf(wrong),
        wo,
        params: [0.0; 3],
    };
    let expected: Vec<f64> = integrate_bins(&case)
        .iter()
        .map(|p| p * SAMPLES as f64)
        .collect();
    let r = chi2_test(&observed, &expected, 5.0);
    assert!(r.p_value < 1e-6, "mismatch not detected: p = {}", r.p_value);
}

// ---------------------------------------------------------------------------------------------
// Smooth dielectric: exact Fresnel probabilities, Snell directions, R + T = 1
// ---------------------------------------------------------------------------------------------

#[test]
fn smooth_dielectric_fresnel_snell_and_energy() {
    for eta in [1.5f32, 1.0 / 1.5, 2.4] {
        let b = dielectric(eta, 0.0);
        assert!(b.is_specular());
        for c in [1.0f32, 0.9, 0.6, 0.3, 0.1, 0.02] {
            for side in [1.0f32, -1.0] {
                let wo = dir(c, 0.4) * Vec3::new(1.0, 1.0, side);
                assert_eq!(b.eval(wo, -wo), SampledSpectrum::ZERO);
                assert_eq!(b.pdf(wo, -wo), 0.0);
                let fr = fresnel_dielectric(wo.z, eta);
                // Reflection branch: uc below F.
                let mut energy = 0.0f64;
                if fr > 0.0 {
                    let r = b.sample(wo, fr * 0.5, Vec2::new(0.3, 0.3)).unwrap();
                    assert!(r.is_specular() && !r.is_transmission() && !r.hero_only());
                    assert_eq!(r.wi, Vec3::new(-wo.x, -wo.y, wo.z));
                    assert!(relative_eq(r.pdf, fr, 1e-6), "{} vs {fr}", r.pdf);
                    // Weight f |cos| / pdf of the reflected branch is exactly 1.
                    let weight = r.f[0] * r.wi.z.abs() / r.pdf;
                    assert!((weight - 1.0).abs() < 1e-5, "reflection weight {weight}");
                    energy += (r.pdf * weight) as f64;
                }
                if fr < 1.0 {
                    let t = b
                        .sample(wo, fr + (1.0 - fr) * 0.5, Vec2::new(0.3, 0.3))
                        .unwrap();
                    assert!(t.is_specular() && t.is_transmission() && !t.hero_only());
                    assert!(relative_eq(t.pdf, 1.0 - fr, 1e-6));
                    assert!(t.wi.z * wo.z < 0.0);
                    assert!((t.wi.length() - 1.0).abs() < 1e-5);
                    // Snell: n_o sin_o = n_i sin_i, opposite azimuth, in the plane of incidence.
                    let (n_o, n_i) = if wo.z > 0.0 { (1.0, eta) } else { (eta, 1.0) };
                    let etap = n_i / n_o;
                    let tangential = Vec2::new(t.wi.x, t.wi.y) * etap + Vec2::new(wo.x, wo.y);
                    assert!(tangential.length() < 1e-5, "Snell violated: {tangential:?}");
                    // Radiance weight carries 1/etap^2; undone, the branch weight is 1.
                    let weight = t.f[0] * t.wi.z.abs() / t.pdf * etap * etap;
                    assert!((weight - 1.0).abs() < 1e-5, "transmission weight {weight}");
                    energy += (t.pdf * weight) as f64;
                } else {
                    // Total internal reflection: every sample reflects.
                    let r = b.sample(wo, 0.999_999, Vec2::ZERO).unwrap();
                    assert!(!r.is_transmission() && r.pdf == 1.0);
                }
                assert!((energy - 1.0).abs() < 1e-5, "R + T = {energy}");
            }
        }
    }
    // Frequencies of the two branches follow F exactly under uniform uc.
    let b = dielectric(1.5, 0.0);
    let wo = dir(0.25, 1.0);
    let fr = fresnel_dielectric(0.25, 1.5) as f64;
    let mut rng = Pcg32::new(3, 3);
    let n = 200_000;
    let reflected = (0..n)
        .filter(|_| {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            !b.sample(wo, rng.next_f32(), u).unwrap().is_transmission()
        })
        .count() as f64;
    let sigma = (fr * (1.0 - fr) / n as f64).sqrt();
    assert!((reflected / n as f64 - fr).abs() < 5.0 * sigma);
}

#[test]
fn fresnel_reference_values() {
    assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
    assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
    // cos < 0 means inside: equals the outside value with 1/eta.
    for c in [0.1f32, 0.5, 0.9] {
        assert_eq!(
            fresnel_dielectric(-c, 1.5),
            fresnel_dielectric(c, 1.0 / 1.5)
        );
    }
    // Critical angle from inside glass: sin = 1/1.5.
    let crit_cos = (1.0f32 - 1.0 / 2.25).sqrt();
    assert_eq!(fresnel_dielectric(-(crit_cos - 1e-3), 1.5), 1.0);
    assert!(fresnel_dielectric(-(crit_cos + 1e-3), 1.5) < 1.0);
    // Both polarisations (Born & Wolf 1.5.2, eqs. 21a/b), reference values computed in f64:
    // 60 degrees, and Brewster's angle (tan = eta) where only the s-part reflects.
    assert!((fresnel_dielectric(0.5, 1.5) - 0.089_186_71).abs() < 1e-6);
    assert!((fresnel_dielectric(0.554_700_2, 1.5) - 0.073_964_5).abs() < 1e-6);
    // Grazing incidence reflects everything; eta = 1 nothing.
    assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0);
    assert_eq!(fresnel_dielectric(0.7, 1.0), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Energy (white furnace)
// ---------------------------------------------------------------------------------------------

/// Mean over samples of f |cos| / pdf, with transmission multiplied by `flux_scale(wo, wi)`.
fn albedo(b: &Bsdf, wo: Vec3, n: usize, seed: u64, undo_eta2: bool) -> (f64, f32) {
    let mut rng = Pcg32::new(seed, 11);
    let mut sum = 0.0f64;
    let mut max_weight = 0.0f32;
    let eta = match b {
        Bsdf::Dielectric(d) => d.eta[0],
        _ => 1.0,
    };
    for _ in 0..n {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        if let Some(s) = b.sample(wo, rng.next_f32(), u) {
            let mut w = s.f[0] * s.wi.z.abs() / s.pdf;
            if s.is_transmission() && undo_eta2 {
                let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
                w *= etap * etap;
            }
            assert!(w.is_finite() && w >= 0.0, "weight {w} for {b:?} wo {wo:?}");
            max_weight = max_weight.max(w);
            sum += w as f64;
        }
    }
    (sum / n as f64, max_weight)
}

/// White-furnace checks of a family of BSDFs: each albedo (`albedo` with `n` samples and
/// `seed`) must lie in `range`; `worst` keeps the largest |E - 1| seen.
struct Furnace {
    n: usize,
    seed: u64,
    undo_eta2: bool,
    range: std::ops::RangeInclusive<f64>,
    worst: f64,
}

impl Furnace {
    fn new(n: usize, seed: u64, undo_eta2: bool, range: std::ops::RangeInclusive<f64>) -> Self {
        Furnace {
            n,
            seed,
            undo_eta2,
            range,
            worst: 0.0,
        }
    }

    /// The albedo of `b` at `wo`, asserted in range (`what` names the case).
    fn check(&mut self, b: &Bsdf, wo: Vec3, what: impl Fn() -> String) -> f64 {
        let (e, _) = albedo(b, wo, self.n, self.seed, self.undo_eta2);
        self.worst = self.worst.max((e - 1.0).abs());
        assert!(self.range.contains(&e), "E = {e}: {}", what());
        e
    }
}

#[test]
fn lambertian_white_furnace() {
    let b = diffuse(SampledSpectrum::ONE);
    for c in [0.05f32, 0.5, 1.0] {
        let wo = wo_at(c);
        let (e, _) = albedo(&b, wo, 100_000, 5, false);
        assert!((e - 1.0).abs() < 0.01, "albedo {e}");
        // Independent of the sampler: uniform-hemisphere estimate of the integral of f cos.
        let mut rng = Pcg32::new(9, 9);
        let n = 400_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let z = rng.next_f32();
            let wi = dir(z, 2.0 * std::f32::consts::PI * rng.next_f32());
            sum += (b.eval(wo, wi)[0] * wi.z) as f64 * 2.0 * PI;
        }
        let e2 = sum / n as f64;
        assert!((e2 - 1.0).abs() < 0.01, "uniform-sampled albedo {e2}");
    }
}

#[test]
fn rough_dielectric_energy_is_bounded() {
    let mut min_e: f64 = 1.0;
    for eta in [1.5f32, 1.0 / 1.5] {
        for roughness in [0.1f32, 0.3, 0.5, 0.7, 1.0] {
            let b = single_scattering_dielectric(eta, roughness);
            for c in [0.05f32, 0.1, 0.3, 0.6, 0.95] {
                for side in [1.0f32, -1.0] {
                    let wo = wo_at(c) * Vec3::new(1.0, 1.0, side);
                    let (e, max_w) = albedo(&b, wo, 200_000, 17, true);
                    println!(
                        "eta {eta:.3} roughness {roughness} cos_o {:+.2}: E = {e:.4}",
                        wo.z
                    );
                    // Single-scattering microfacets lose energy, never create it; each
                    // importance weight is G2/G1 <= 1.
                    assert!(
                        e <= 1.01,
                        "energy gain {e} eta {eta} r {roughness} wo {wo:?}"
                    );
                    assert!(max_w <= 1.0 + 1e-3, "weight {max_w} > 1");
                    // ...and loses no more than single-scattering GGX does (measured minima
                    // with margin; catches a vanishing lobe).
                    let floor = match roughness {
                        r if r <= 0.1 => 0.97,
                        r if r <= 0.3 => 0.85,
                        r if r <= 0.5 => 0.75,
                        r if r <= 0.7 => 0.6,
                        _ => 0.4,
                    };
                    assert!(e > floor, "energy {e} eta {eta} r {roughness} wo {wo:?}");
                    // ...and the loss stays that of single scattering (catches zeroed lobes).

                    min_e = min_e.min(e);
                }
            }
        }
    }
    println!("min rough-dielectric albedo {min_e:.4}");
    // Nearly smooth: practically all energy is kept.
    let (e, _) = albedo(
        &single_scattering_dielectric(1.5, 0.1),
        wo_at(0.8),
        200_000,
        3,
        true,
    );
    assert!(e > 0.99, "near-smooth albedo {e}");
}

/// Energy-compensated rough glass (the default) is a white furnace: reflection plus
/// refraction return all the energy, from outside and inside, for plain and strongly
/// dispersive IORs (each wavelength divided by its own albedo), at every roughness.
#[test]
fn rough_dielectric_white_furnace() {
    let mut furnace = Furnace::new(200_000, 19, true, 0.99..=1.01);
    for eta in [1.5f32, 1.0 / 1.5, 1.33, 2.4] {
        for roughness in [0.2f32, 0.5, 0.8, 1.0] {
            let b = dielectric(eta, roughness);
            for c in [0.05f32, 0.2, 0.5, 0.9] {
                for side in [1.0f32, -1.0] {
                    let wo = wo_at(c) * Vec3::new(1.0, 1.0, side);
                    furnace.check(&b, wo, || {
                        format!("eta {eta} roughness {roughness} cos_o {}", wo.z)
                    });
                }
            }
        }
    }
    println!(
        "compensated rough glass: worst |E - 1| = {:.4}",
        furnace.worst
    );
    // A dispersive glass: every wavelength's own albedo is 1 (slot i of f holds eta[i]).
    let d = DielectricBsdf {
        eta: SampledSpectrum([1.45, 1.5, 1.6, 1.75]),
        alpha: 0.36,
        transmission_tint: SampledSpectrum::ONE,
        iridescence: None,
        refraction_only: false,
        energy_compensation: true,
    };
    for i in 0..4 {
        // Wavelength i's albedo: sample with it as the hero (its IOR in slot 0).
        let mut eta = d.eta;
        eta.0.swap(0, i);
        let b = Bsdf::Dielectric(DielectricBsdf { eta, ..d });
        let (e, _) = albedo(&b, wo_at(0.4), 200_000, 29, true);
        assert!((e - 1.0).abs() < 0.01, "wavelength {i}: E = {e}");
    }
}

/// The tabulated albedos (`prism::bsdf::energy`) against Monte Carlo integrals of the BSDFs'
/// own sampling, between the table's nodes: E with a white single-scattering conductor, B
/// with a black one (F = (1 - wo.h)^5), E_T with single-scattering glass. Tolerance 0.006:
/// the estimates' standard error is below 0.001, the bilinear interpolation error up to 0.005
/// (measured by the generator).
#[test]
fn energy_tables_match_monte_carlo() {
    use prism::bsdf::energy::{
        ggx_dielectric_albedo, ggx_reflection_albedo, ggx_reflection_average,
    };
    let mut worst = [0.0f64; 3];
    let close = |what: String, integral: f64, table: f32, tol: f64| {
        assert!(
            (integral - table as f64).abs() < tol,
            "{what}: integral {integral} table {table}"
        );
    };
    for (roughness, c) in [
        (0.13f32, 0.37f32),
        (0.35, 0.08),
        (0.61, 0.55),
        (0.83, 0.21),
        (0.97, 0.93),
    ] {
        let alpha = roughness * roughness;
        let table = ggx_reflection_albedo(alpha, c);
        let (e, _) = albedo(
            &gltf_metallic_roughness(SampledSpectrum::ONE, 1.0, roughness),
            wo_at(c),
            200_000,
            7,
            false,
        );
        let (b, _) = albedo(
            &gltf_metallic_roughness(SampledSpectrum::ZERO, 1.0, roughness),
            wo_at(c),
            200_000,
            7,
            false,
        );
        worst[0] = worst[0].max((e - table.e as f64).abs());
        worst[1] = worst[1].max((b - table.b as f64).abs());
        close(format!("E({roughness}, {c})"), e, table.e, 0.006);
        close(format!("B({roughness}, {c})"), b, table.b, 0.006);
        for eta in [1.05f32, 1.33, 1.7, 1.0 / 1.45] {
            for side in [1.0f32, -1.0] {
                let wo = wo_at(c) * Vec3::new(1.0, 1.0, side);
                let (mc, _) = albedo(
                    &single_scattering_dielectric(eta, roughness),
                    wo,
                    200_000,
                    13,
                    true,
                );
                let t = ggx_dielectric_albedo(alpha, wo.z, eta);
                worst[2] = worst[2].max((mc - t as f64).abs());
                close(format!("E_T({roughness}, {}, {eta})", wo.z), mc, t, 0.006);
            }
        }
        // The averages are 2 int E mu dmu of the directional table (fine midpoint rule).
        let n = 512;
        let (mut ea, mut ba) = (0.0f64, 0.0f64);
        for j in 0..n {
            let mu = (j as f32 + 0.5) / n as f32;
            let a = ggx_reflection_albedo(alpha, mu);
            ea += 2.0 * (a.e * mu) as f64 / n as f64;
            ba += 2.0 * (a.b * mu) as f64 / n as f64;
        }
        let avg = ggx_reflection_average(alpha);
        close(format!("E_avg({roughness})"), ea, avg.e, 0.004);
        close(format!("B_avg({roughness})"), ba, avg.b, 0.004);
    }
    println!(
        "table vs Monte Carlo, worst |difference|: E {:.4} B {:.4} E_T {:.4}",
        worst[0], worst[1], worst[2]
    );
}

/// Blender's Refraction BSDF (`refraction_only`): smooth, every sample refracts by Snell with
/// probability 1 and unit weight (radiance's 1/etap^2 undone), and total internal reflection is
/// absorbed; rough, the transmission lobe keeps what single scattering keeps (no energy
/// gain, at least the Fresnel-split dielectric's transmitted share) and never reflects.
#[test]
fn refraction_only_transmits_everything_it_can() {
    let refraction = |eta: f32, roughness: f32| {
        Bsdf::Dielectric(DielectricBsdf {
            eta: SampledSpectrum::splat(eta),
            alpha: roughness * roughness,
            transmission_tint: SampledSpectrum::ONE,
            iridescence: None,
            refraction_only: true,
            energy_compensation: true,
        })
    };
    let b = refraction(1.5, 0.0);
    for c in [1.0f32, 0.6, 0.1] {
        let wo = dir(c, 0.4);
        for uc in [0.0f32, 0.5, 0.999] {
            let t = b.sample(wo, uc, Vec2::new(0.3, 0.3)).unwrap();
            assert!(t.is_specular() && t.is_transmission() && t.pdf == 1.0);
            let weight = t.f[0] * t.wi.z.abs() / t.pdf * 1.5 * 1.5;
            assert!((weight - 1.0).abs() < 1e-5, "weight {weight}");
        }
    }
    // From inside beyond the critical angle (cos < sqrt(1 - 1/2.25) = 0.745): absorbed.
    assert!(b.sample(-dir(0.5, 0.4), 0.5, Vec2::new(0.3, 0.3)).is_none());
    for roughness in [0.3f32, 0.7] {
        for c in [0.3f32, 0.8] {
            let wo = wo_at(c);
            let (e, max_w) = albedo(&refraction(1.5, roughness), wo, 100_000, 5, true);
            let (full, _) = albedo(&dielectric(1.5, roughness), wo, 100_000, 5, true);
            println!(
                "refraction only: roughness {roughness} cos_o {c}: E = {e:.4} (glass {full:.4})"
            );
            assert!(
                e <= 1.01 && max_w <= 1.0 + 1e-3,
                "energy {e}, weight {max_w}"
            );
            assert!(e > 0.8 * full, "refraction-only {e} vs glass {full}");
            let mut rng = Pcg32::new(9, 1);
            for _ in 0..1000 {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                if let Some(s) = refraction(1.5, roughness).sample(wo, rng.next_f32(), u) {
                    assert!(s.is_transmission() && s.wi.z < 0.0);
                }
            }
        }
    }
}

/// White furnace of the glTF BRDF with base colour 1 (specular colour 1, ior 1.5).
///
/// The conductor (metallic = 1) and the specular = 0 cases conserve energy: E <= 1. The
/// dielectric layer *as the glTF spec defines it* (diffuse weighted by 1 - F(wo.h), specular by
/// F(wo.h)) does not: at grazing wo the GGX layer reflects ~F(cos_o) while the diffuse layer
/// barely loses anything (measured E = 1.55 at cos_o = 0.1, roughness 0.05; 1.15 at 0.3;
/// <= 1.01 from cos_o = 0.6 up). For it we assert conservation at normal incidence and the
/// structural bound E <= 1 + F_d(cos_o) (diffuse <= 1, specular layer <= its Fresnel).
#[test]
fn metallic_roughness_energy_is_bounded() {
    let white = SampledSpectrum::ONE;
    for metallic in [0.0f32, 0.5, 1.0] {
        for roughness in [0.05f32, 0.3, 0.6, 1.0] {
            for specular in [0.0f32, 1.0] {
                let b = Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
                    base_color: white,
                    metallic,
                    alpha: roughness * roughness,
                    specular,
                    specular_color: white,
                    ior: 1.5,
                    energy_compensation: false,
                    principled_v1: false,
                    coat: prism::bsdf::Coat::NONE,
                    sheen: prism::bsdf::Sheen::NONE,
                    iridescence: None,
                    view: None,
                });
                for c in [0.1f32, 0.3, 0.6, 1.0] {
                    let (e, _) = albedo(&b, wo_at(c), 200_000, 23, false);
                    println!(
                        "metallic {metallic} roughness {roughness} specular {specular} \
                         cos_o {c}: E = {e:.4}"
                    );
                    let msg =
                        format!("E = {e}: metallic {metallic} r {roughness} s {specular} cos {c}");
                    let fd = 0.04 + 0.96 * (1.0 - c as f64).powi(5);
                    if metallic == 1.0 || specular == 0.0 || c == 1.0 {
                        assert!(e <= 1.01, "energy gain: {msg}");
                    } else {
                        assert!(e <= 1.01 + (1.0 - metallic as f64) * fd, "{msg}");
                    }
                    // Lambert is exact; a smooth conductor keeps everything; nothing vanishes.
                    if metallic == 0.0 && specular == 0.0 {
                        assert!((e - 1.0).abs() < 1e-4, "{msg}");
                    }
                    if metallic == 1.0 && roughness <= 0.05 {
                        assert!(e > 0.99, "{msg}");
                    }
                    assert!(e > 0.3, "{msg}");
                }
            }
        }
    }
}

/// White furnace of the energy-conserving Principled layering (the default model): a white
/// conductor (F0 = 1) and a white base under the dielectric specular layer reflect all the
/// light at every roughness and angle; metallic mixes of the two as well; the specular layer
/// alone (black base) reflects no more than it did before compensation plus what
/// interreflection adds. Tolerance: MC error < 0.002, table error < 0.005, and 0.015 low: the
/// dielectric layer's albedo with Cycles' real Fresnel curve is its Fresnel at an effective
/// cosine times E (`film_albedo`), a little high for rough layers at grazing views (0.989 at
/// roughness 0.8, cos_o 0.05; the base gets that much less).
#[test]
fn principled_white_furnace() {
    let white = SampledSpectrum::ONE;
    let mut furnace = Furnace::new(200_000, 31, false, 0.985..=1.007);
    for metallic in [0.0f32, 0.5, 1.0] {
        for roughness in [0.0f32, 0.1, 0.3, 0.6, 0.8, 1.0] {
            for c in [0.05f32, 0.2, 0.5, 0.9] {
                let b = metallic_roughness(white, metallic, roughness, 1.0);
                furnace.check(&b, wo_at(c), || {
                    format!("metallic {metallic} roughness {roughness} cos_o {c}")
                });
            }
        }
    }
    println!(
        "energy-conserving Principled, white: worst |E - 1| = {:.4}",
        furnace.worst
    );
    // A coloured conductor loses energy to absorption between the facets: darker than the
    // compensated white one, brighter than single scattering.
    let gold = SampledSpectrum([1.0, 0.8, 0.4, 0.9]);
    for roughness in [0.5f32, 1.0] {
        let wo = wo_at(0.5);
        let full = metallic_roughness(gold, 1.0, roughness, 1.0);
        let single = gltf_metallic_roughness(gold, 1.0, roughness);
        let (mut e_full, mut e_single) = (0.0f64, 0.0f64);
        let mut rng = Pcg32::new(3, 3);
        for _ in 0..100_000 {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let uc = rng.next_f32();
            if let Some(s) = full.sample(wo, uc, u) {
                e_full += (s.f[2] * s.wi.z / s.pdf) as f64 / 1e5;
            }
            if let Some(s) = single.sample(wo, uc, u) {
                e_single += (s.f[2] * s.wi.z / s.pdf) as f64 / 1e5;
            }
        }
        assert!(
            e_full > e_single && e_full < 0.4 + 0.6 / 21.0 + 0.05,
            "{e_full} vs {e_single}"
        );
    }
}

/// A clear coat over a white base (Principled Coat): with a white tint the energy-conserving
/// layering reflects all the light (the coat's albedo plus the base's share of the rest); a
/// coloured tint absorbs, never adds (the bound: <= 1); the glTF spec's layering
/// (`KHR_materials_clearcoat`) stays within the same bound plus its own base's excess. The
/// low bound, 0.975: the coat's albedo with the exact Fresnel is its Fresnel at the lobe's
/// effective cosine times E (`energy::effective_cosine`), a little high for rough coats at
/// grazing views (0.980 at coat roughness 1, cos_o 0.1), so the base gets that much less.
#[test]
fn coat_over_white_base_conserves_energy() {
    let white = SampledSpectrum::ONE;
    let mut furnace = Furnace::new(200_000, 37, false, 0.975..=1.007);
    for metallic in [0.0f32, 1.0] {
        for roughness in [0.2f32, 0.8] {
            for (weight, coat_roughness) in [(1.0f32, 0.0f32), (1.0, 0.1), (0.5, 0.5), (1.0, 1.0)] {
                for c in [0.1f32, 0.5, 0.9] {
                    let base = metallic_roughness(white, metallic, roughness, 1.0);
                    let b = coated(base, weight, coat_roughness, white);
                    let msg = format!("metallic {metallic} roughness {roughness} coat {weight} coat roughness {coat_roughness} cos_o {c}");
                    let e = furnace.check(&b, wo_at(c), || msg.clone());
                    let tinted = coated(
                        base,
                        weight,
                        coat_roughness,
                        SampledSpectrum([0.5, 0.7, 0.9, 1.0]),
                    );
                    let (et, _) = albedo(&tinted, wo_at(c), 200_000, 37, false);
                    assert!(
                        et <= e + 1e-3 && et < 0.995,
                        "tinted E = {et} vs {e}: {msg}"
                    );
                }
            }
        }
    }
    println!("coated white base: worst |E - 1| = {:.4}", furnace.worst);
}

/// A coat whose normal is tilted from the base's (a bumped base under a smooth or rough coat)
/// over a white base: what the coat reflects plus what the base gets is still at most what
/// arrives, and near it (the layering is evaluated with each layer's own cosines).
#[test]
fn tilted_coat_over_white_base_is_bounded() {
    let white = SampledSpectrum::ONE;
    let mut furnace = Furnace::new(200_000, 53, false, 0.985..=1.005);
    for (metallic, roughness) in [(0.0f32, 0.3f32), (1.0, 0.6)] {
        for coat_roughness in [0.0f32, 0.3] {
            for n in [Vec3::new(0.2, 0.0, 0.98), Vec3::new(-0.3, 0.4, 0.87)] {
                for c in [0.3f32, 0.8] {
                    let b = coated_tilted(
                        metallic_roughness(white, metallic, roughness, 1.0),
                        1.0,
                        coat_roughness,
                        n,
                    );
                    furnace.check(&b, wo_at(c), || {
                        format!("metallic {metallic} roughness {roughness} coat roughness {coat_roughness} n {n} cos {c}")
                    });
                }
            }
        }
    }
    println!(
        "tilted coat over a white base: worst |E - 1| = {:.4}",
        furnace.worst
    );
}

/// A white sheen over a white base. Energy-conserving model: the base is dimmed by exactly what
/// the sheen reflects at `wo`, so the whole reflects 1 (as the base alone does). The glTF
/// model's reciprocal scaling (by the brighter of the two directions) stays at most 1.
#[test]
fn sheen_over_white_base_is_bounded() {
    let white = SampledSpectrum::ONE;
    let mut worst = 0.0f64;
    for roughness in [0.2f32, 0.8] {
        for sheen_roughness in [0.1f32, 0.5, 1.0] {
            for c in [0.1f32, 0.5, 0.9] {
                let base = metallic_roughness(white, 0.0, roughness, 1.0);
                let b = sheened(base, white, sheen_roughness);
                let (e, _) = albedo(&b, wo_at(c), 200_000, 43, false);
                worst = worst.max((e - 1.0).abs());
                assert!(
                    (0.985..=1.007).contains(&e),
                    "roughness {roughness} sheen roughness {sheen_roughness} cos_o {c}: E = {e}"
                );
                // The glTF spec's base itself reflects more than 1 at grazing views
                // (`metallic_roughness_energy_is_bounded`): its sheen adds nothing to that.
                let gltf_base = gltf_metallic_roughness(white, 0.0, roughness);
                let (eb, _) = albedo(&gltf_base, wo_at(c), 200_000, 43, false);
                let gltf = sheened(gltf_base, white, sheen_roughness);
                let (eg, _) = albedo(&gltf, wo_at(c), 200_000, 43, false);
                assert!(
                    eg <= eb.max(1.0) + 0.007 && eg > 0.75,
                    "glTF model: E = {eg} (base alone {eb}): roughness {roughness} sheen roughness {sheen_roughness} cos_o {c}"
                );
                // A coloured sheen (the base dimmed by its largest component) stays below 1 in
                // every channel too.
                let tinted = sheened(base, SampledSpectrum([0.2, 0.5, 0.8, 0.4]), sheen_roughness);
                let (et, _) = albedo(&tinted, wo_at(c), 200_000, 43, false);
                assert!(et <= 1.005, "tinted E = {et} (white {e})");
            }
        }
    }
    println!("sheen over a white base: worst |E - 1| = {worst:.4}");
}

/// The sheens' own albedo tables against Monte Carlo integration of their lobes through the
/// BSDF's sampling (a black base: what is reflected is the sheen alone): the fibre layer's
/// fitted LTC (whose samples weigh exactly its albedo if eval, pdf and sampling agree) and
/// the Charlie lobe (sampled uniformly).
#[test]
fn sheen_albedo_matches_monte_carlo() {
    let black = SampledSpectrum::ZERO;
    for sheen_roughness in [0.1f32, 0.3, 0.6, 1.0] {
        for c in [0.1f32, 0.6, 1.0] {
            let fibre = sheened(
                metallic_roughness(black, 0.0, 0.5, 0.0),
                SampledSpectrum::ONE,
                sheen_roughness,
            );
            let (e, _) = albedo(&fibre, wo_at(c), 100_000, 47, false);
            let table = prism::bsdf::fibre_sheen::FibreLobe::at(sheen_roughness, c).albedo as f64;
            assert!(
                (e - table).abs() < 1e-3 + 1e-3 * table,
                "fibre sheen roughness {sheen_roughness} cos_o {c}: Monte Carlo {e}, table {table}"
            );
            let charlie = match metallic_roughness(black, 0.0, 0.5, 0.0) {
                Bsdf::MetallicRoughness(b) => Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
                    energy_compensation: false,
                    ..b
                }),
                _ => unreachable!(),
            };
            let charlie = sheened(charlie, SampledSpectrum::ONE, sheen_roughness);
            let (e, _) = albedo(&charlie, wo_at(c), 400_000, 47, false);
            let table = prism::bsdf::sheen::lobe_albedo(sheen_roughness, c) as f64;
            assert!(
                (e - table).abs() < 0.01 + 0.03 * table,
                "Charlie sheen roughness {sheen_roughness} cos_o {c}: Monte Carlo {e}, table {table}"
            );
        }
    }
}

/// The committed fibre-sheen table (`tools/sheen_ltc.rs`) against a fresh simulation of the
/// fibre layer between its nodes: the albedo within 0.01 + 3% (interpolation and the
/// simulations' noise), and the fitted lobe's share of light scattered back towards the view
/// (azimuth within 90 degrees of it) and its mean exit cosine within 0.03 of the walks'.
#[test]
fn fibre_sheen_table_matches_a_fresh_simulation() {
    use prism::bsdf::fibre_sheen::{bin_centre, bin_solid_angle, simulate_layer, FibreLobe};
    use prism::bsdf::fibre_sheen::{N_PHI, N_THETA};
    for (roughness, mu) in [(0.37f64, 0.23f64), (0.55, 0.61), (0.83, 0.12), (0.95, 0.9)] {
        let st = simulate_layer(mu, roughness, 400_000, 99);
        let lobe = FibreLobe::at(roughness as f32, mu as f32);
        let r = st.albedo();
        assert!(
            (f64::from(lobe.albedo) - r).abs() < 0.01 + 0.03 * r,
            "roughness {roughness} mu {mu}: table {} simulated {r}",
            lobe.albedo
        );
        // Moments of the exit distribution: walks' histogram against the LTC's density.
        let (mut back_w, mut cos_w, mut back_l, mut cos_l, mut total_l) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for t in 0..N_THETA {
            let omega = 2.0 * bin_solid_angle(t);
            for p in 0..N_PHI {
                let w = bin_centre(t, p);
                let walks = st.density(t, p) * omega / r;
                let fitted = f64::from(lobe.density(w)) * omega;
                let back = if p < N_PHI / 2 { 1.0 } else { 0.0 };
                back_w += back * walks;
                cos_w += f64::from(w.z) * walks;
                back_l += back * fitted;
                cos_l += f64::from(w.z) * fitted;
                total_l += fitted;
            }
        }
        let (back_l, cos_l) = (back_l / total_l, cos_l / total_l);
        println!(
            "roughness {roughness} mu {mu}: albedo {} / {r:.4}, back {back_l:.3} / {back_w:.3}, mean cos {cos_l:.3} / {cos_w:.3}",
            lobe.albedo
        );
        assert!(
            (back_l - back_w).abs() < 0.03,
            "back-scattered share {back_l} vs {back_w}"
        );
        assert!(
            (cos_l - cos_w).abs() < 0.03,
            "mean exit cosine {cos_l} vs {cos_w}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Exact special cases, reciprocity, dispersion flags, robustness
// ---------------------------------------------------------------------------------------------

#[test]
fn specular_zero_is_exactly_lambertian() {
    let base = color();
    for roughness in [0.1f32, 0.5, 1.0] {
        let b = metallic_roughness(base, 0.0, roughness, 0.0);
        let mut rng = Pcg32::new(31, 2);
        for _ in 0..10_000 {
            let wo = dir(rng.next_f32().max(1e-3), 6.3 * rng.next_f32());
            let wi = dir(rng.next_f32().max(1e-3), 6.3 * rng.next_f32());
            assert_eq!(b.eval(wo, wi), base * std::f32::consts::FRAC_1_PI);
            assert_eq!(b.pdf(wo, wi), wi.z * std::f32::consts::FRAC_1_PI);
        }
    }
}

#[test]
fn reflection_lobes_are_reciprocal() {
    let mut rng = Pcg32::new(41, 4);
    let mut bsdfs = vec![diffuse(color())];
    // The energy-conserving Principled is Cycles' and not reciprocal (see
    // `principled_base_is_dimmed_by_the_layer_albedo_at_wo_as_in_cycles` and
    // `ggx_multiple_scattering_keeps_the_lobe_shape_as_in_cycles`); a smooth metal is.
    bsdfs.push(metallic_roughness(color(), 1.0, 0.0, 1.0));
    for metallic in [0.0, 0.5, 1.0] {
        for roughness in [0.1, 0.5, 1.0] {
            bsdfs.push(gltf_metallic_roughness(color(), metallic, roughness));
        }
        // The glTF spec's clear coat (1 - F(wo.h) on the base) is reciprocal.
        let base = gltf_metallic_roughness(color(), metallic, 0.5);
        bsdfs.push(coated(base, 0.7, 0.4, SampledSpectrum::ONE));
        // Blender 3.x's Principled: Burley's diffuse and the Fresnel at wo.h are symmetric.
        bsdfs.push(principled_v1(color(), metallic, 0.5, 1.0));
        // The glTF model's sheen dims the base reciprocally (min over both directions).
        let base = gltf_metallic_roughness(color(), metallic, 0.5);
        bsdfs.push(sheened(base, color(), 0.4));
    }
    for b in &bsdfs {
        for _ in 0..20_000 {
            let wo = dir(rng.next_f32().max(1e-3), 6.3 * rng.next_f32());
            let wi = dir(rng.next_f32().max(1e-3), 6.3 * rng.next_f32());
            let (a, r) = (b.eval(wo, wi), b.eval(wi, wo));
            for i in 0..4 {
                assert!(relative_eq(a[i], r[i], 1e-4), "{b:?}: {a:?} vs {r:?}");
            }
        }
    }
}

/// The Principled BSDF layers its dielectric specular over the diffuse base as Cycles 4.x/5.x
/// does (`closure_layering_weight`): the Lambertian base is scaled by one minus the specular
/// layer's albedo at the view direction alone. So the diffuse part does not depend on `wi`, and
/// it is base/pi (1 - A(wo)), A(wo) the albedo of the same BSDF over a black base (Monte
/// Carlo). The reciprocal coupling (1 - A(mu_o)) (1 - A(mu_i)) / (1 - A_avg), which Prism used
/// before, varies with `wi` by up to 40% at grazing light and made sunlit Principled surfaces
/// 2.5-3.4% brighter than in Cycles.
#[test]
fn principled_base_is_dimmed_by_the_layer_albedo_at_wo_as_in_cycles() {
    let base = SampledSpectrum([0.8, 0.5, 0.3, 0.6]);
    let mut rng = Pcg32::new(47, 6);
    for roughness in [0.0f32, 0.2, 0.5, 1.0] {
        let b = metallic_roughness(base, 0.0, roughness, 1.0);
        let black = metallic_roughness(SampledSpectrum::ZERO, 0.0, roughness, 1.0);
        for cos_o in [0.15f32, 0.5, 0.95] {
            let wo = wo_at(cos_o);
            let (layer, _) = albedo(&black, wo, 400_000, 29, false);
            let want = base[0] as f64 * std::f64::consts::FRAC_1_PI * (1.0 - layer);
            let first = b.diffuse_part(wo, Vec3::Z)[0];
            assert!(
                (first as f64 - want).abs() < 0.01 * want,
                "roughness {roughness} cos_o {cos_o}: diffuse {first} vs base/pi (1 - {layer}) = \
                 {want}"
            );
            for _ in 0..2_000 {
                let wi = dir(rng.next_f32().max(1e-3), 6.3 * rng.next_f32());
                let d = b.diffuse_part(wo, wi)[0];
                assert!(
                    relative_eq(d, first, 1e-6),
                    "roughness {roughness} cos_o {cos_o}: the base varies with wi ({d} vs {first})"
                );
            }
        }
    }
}

/// The energy-conserving GGX reflection keeps the single-scattering lobe's shape, scaled at
/// `wo` by what it misses (Cycles' `microfacet_ggx_preserve_energy`): for a white metal,
/// f / f_single = 1 / E(mu_o) for every `wi`, E(mu_o) the single-scattering lobe's albedo
/// (Monte Carlo). Kulla & Conty's added cosine-shaped lobe, which Prism used before, fails
/// this (its share grows away from the highlight) and made a rough metal under a sun 1.06x
/// Cycles.
#[test]
fn ggx_multiple_scattering_keeps_the_lobe_shape_as_in_cycles() {
    let white = SampledSpectrum::ONE;
    let mut rng = Pcg32::new(53, 7);
    for roughness in [0.3f32, 0.6, 1.0] {
        let full = metallic_roughness(white, 1.0, roughness, 1.0);
        let single = gltf_metallic_roughness(white, 1.0, roughness);
        for cos_o in [0.2f32, 0.6, 0.95] {
            let wo = wo_at(cos_o);
            let (e, _) = albedo(&single, wo, 400_000, 37, false);
            let want = (1.0 / e) as f32;
            let mut checked = 0;
            for _ in 0..2_000 {
                let wi = dir(rng.next_f32().max(1e-3), 6.3 * rng.next_f32());
                let (f, f1) = (full.eval(wo, wi)[0], single.eval(wo, wi)[0]);
                if f1 > 1e-4 {
                    checked += 1;
                    assert!(
                        relative_eq(f / f1, want, 0.01),
                        "roughness {roughness} cos_o {cos_o}: f / f_single {} vs 1 / E {want}",
                        f / f1
                    );
                }
            }
            assert!(checked > 500, "{checked} directions checked");
        }
    }
}

/// Blender 3.x's Principled without a specular layer is Burley's diffuse (2015, section 5.3):
/// base/pi at normal view and light; base/pi (1/2 + roughness) with a grazing view and the
/// light along the normal (retro-reflection grows with roughness); and with a specular layer
/// the Fresnel runs from F0 = 0.04 at normal incidence (added to the undimmed base) to 1 at
/// grazing.
#[test]
fn principled_v1_is_burleys_diffuse_plus_cycles_3x_fresnel() {
    let base = SampledSpectrum::splat(0.5);
    let inv_pi = std::f32::consts::FRAC_1_PI;
    for roughness in [0.2f32, 0.5, 1.0] {
        let b = principled_v1(base, 0.0, roughness, 0.0);
        let n = Vec3::Z;
        let f = b.eval(n, n)[0];
        assert!((f - 0.5 * inv_pi).abs() < 1e-5, "normal: {f}");
        let grazing = Vec3::new(1.0, 0.0, 1e-4).normalize();
        let f = b.eval(grazing, n)[0];
        let want = 0.5 * inv_pi * (0.5 + roughness);
        assert!(
            (f - want).abs() < 2e-3 * want,
            "grazing view, roughness {roughness}: {f} vs {want}"
        );
        assert!(relative_eq(f, b.eval(n, grazing)[0], 1e-5));
    }
    // Rough specular layer of F0 0.04: at normal incidence (wo = wi = n, h = n) the GGX term
    // adds F0 D G / 4 to the undimmed base's base/pi.
    let b = principled_v1(base, 0.0, 0.5, 1.0);
    let g = principled_v1(base, 0.0, 0.5, 0.0);
    let n = Vec3::Z;
    let spec = b.eval(n, n)[0] - g.eval(n, n)[0];
    let d = 1.0 / (std::f32::consts::PI * 0.25 * 0.25); // GGX D(n) = 1 / (pi alpha^2)
    let want = 0.04 * d / 4.0;
    assert!(
        (spec - want).abs() < 1e-3 * want,
        "specular at normal incidence {spec} vs {want}"
    );
    // The Disney sheen adds colour x (1 - wi.h)^5 (not over pi) to the undimmed base, on the
    // dielectric part only (1 - metallic).
    let wo = Vec3::new(0.8, 0.0, 0.6);
    let wi = Vec3::new(-0.6, 0.0, 0.8);
    let cos_d = wi.dot((wo + wi).normalize());
    for metallic in [0.0f32, 0.25] {
        let plain = principled_v1(base, metallic, 0.5, 1.0);
        let sheen = sheened(plain, SampledSpectrum::splat(0.8), 0.5);
        let added = sheen.eval(wo, wi)[0] - plain.eval(wo, wi)[0];
        let want = 0.8 * (1.0 - cos_d).powi(5) * (1.0 - metallic);
        assert!(
            (added - want).abs() < 1e-5,
            "Disney sheen {added} vs {want}"
        );
    }
    // A metal's Fresnel reaches 1 at grazing: its grazing mirror-like reflection is white.
    let metal = principled_v1(SampledSpectrum::splat(0.2), 1.0, 0.05, 1.0);
    let wo = Vec3::new(0.999, 0.0, 0.0447).normalize();
    let wi = Vec3::new(-wo.x, 0.0, wo.z);
    let white = principled_v1(SampledSpectrum::splat(1.0), 1.0, 0.05, 1.0);
    let ratio = metal.eval(wo, wi)[0] / white.eval(wo, wi)[0];
    assert!(
        ratio > 0.75 && ratio <= 1.0,
        "grazing metal / white metal {ratio}"
    );
}

/// Rough dielectric: reflection is symmetric; for refraction the radiance BTDF satisfies
/// f(wo, wi) / n(wo)^2 == f(wi, wo) / n(wi)^2, n(w) = 1 above the surface and eta below
/// (Veach 1997, eq. 5.14; Walter et al. 2007, eq. 21 carries n_o^2).
#[test]
fn rough_dielectric_generalized_reciprocity() {
    let mut rng = Pcg32::new(43, 5);
    let mut checked = [0usize; 2];
    for eta in [1.5f32, 1.0 / 1.5, 1.33] {
        for roughness in [0.2f32, 0.5, 1.0] {
            let b = single_scattering_dielectric(eta, roughness);
            let compensated = dielectric(eta, roughness);
            let n = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
            for _ in 0..20_000 {
                let wo = dir(2.0 * rng.next_f32() - 1.0, 6.3 * rng.next_f32());
                let wi = dir(2.0 * rng.next_f32() - 1.0, 6.3 * rng.next_f32());
                if wo.z.abs() < 1e-2 || wi.z.abs() < 1e-2 {
                    continue;
                }
                // Skip microfacets seen at grazing angles, where f32 cancellation in
                // wo.wm, wi.wm dominates (their contribution is negligible anyway).
                let wm = (wo * n(wo) + wi * n(wi)).normalize();
                if wo.dot(wm).abs() < 0.02 || wi.dot(wm).abs() < 0.02 {
                    continue;
                }
                let lhs = b.eval(wo, wi)[0] / (n(wo) * n(wo));
                let rhs = b.eval(wi, wo)[0] / (n(wi) * n(wi));
                // Near total internal reflection 1 - F loses relative precision: absolute floor.
                assert!(
                    (lhs - rhs).abs() <= 1e-3 * lhs.max(rhs) + 1e-5,
                    "eta {eta} r {roughness} wo {wo:?} wi {wi:?}: {lhs} vs {rhs}"
                );
                if lhs > 0.0 {
                    checked[(wo.z * wi.z < 0.0) as usize] += 1;
                }
                // The energy compensation (Turquin 2019) divides by the albedo seen from the
                // outgoing direction only: reciprocal up to exactly the ratio of the albedos.
                let e = |w: Vec3| {
                    prism::bsdf::energy::ggx_dielectric_albedo(roughness * roughness, w.z, eta)
                };
                let lhs_c = compensated.eval(wo, wi)[0] / (n(wo) * n(wo)) * e(wo);
                let rhs_c = compensated.eval(wi, wo)[0] / (n(wi) * n(wi)) * e(wi);
                assert!(
                    (lhs_c - rhs_c).abs() <= 1e-3 * lhs_c.max(rhs_c) + 1e-5,
                    "compensated: eta {eta} r {roughness}: {lhs_c} vs {rhs_c}"
                );
            }
        }
    }
    // Both reflection and refraction pairs were actually exercised.
    assert!(checked[0] > 10_000 && checked[1] > 10_000, "{checked:?}");
}

#[test]
fn dispersion_terminates_secondaries_on_smooth_refraction_only() {
    let eta = SampledSpectrum([1.5, 1.52, 1.54, 1.56]);
    let mut rng = Pcg32::new(51, 6);
    for alpha in [0.0f32, 0.09] {
        let disp = Bsdf::Dielectric(DielectricBsdf {
            eta,
            alpha,
            transmission_tint: SampledSpectrum::ONE,
            iridescence: None,
            refraction_only: false,
            energy_compensation: true,
        });
        let hero = Bsdf::Dielectric(DielectricBsdf {
            eta: SampledSpectrum::splat(1.5),
            alpha,
            transmission_tint: SampledSpectrum::ONE,
            iridescence: None,
            refraction_only: false,
            energy_compensation: true,
        });
        let mut seen = [0usize; 2];
        for _ in 0..20_000 {
            let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
            let wo =
                dir(0.05 + 0.95 * rng.next_f32(), 6.3 * rng.next_f32()) * Vec3::new(1.0, 1.0, side);
            let (uc, u) = (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
            let (Some(s), Some(h)) = (disp.sample(wo, uc, u), hero.sample(wo, uc, u)) else {
                continue;
            };
            // Only a smooth refraction leaves the hero alone; a rough one keeps every
            // wavelength with its own density (hero MIS).
            assert_eq!(s.hero_only(), s.is_transmission() && alpha == 0.0);
            assert!(!h.hero_only());
            if alpha > 0.0 {
                let (f, pdfs) = disp.eval_pdf_wavelengths(wo, s.wi);
                // Each slot is exactly that wavelength's own non-dispersive BSDF and density.
                for i in 0..4 {
                    let own = Bsdf::Dielectric(DielectricBsdf {
                        eta: SampledSpectrum::splat(eta[i]),
                        alpha,
                        transmission_tint: SampledSpectrum::ONE,
                        iridescence: None,
                        refraction_only: false,
                        energy_compensation: true,
                    });
                    let (fi, pi) = own.eval_pdf(wo, s.wi);
                    assert!(
                        relative_eq(f[i], fi[0], 1e-4) && relative_eq(pdfs[i], pi, 1e-4),
                        "slot {i}: {} {} vs own {} {pi} (wo {wo:?} wi {:?})",
                        f[i],
                        pdfs[i],
                        fi[0],
                        s.wi
                    );
                }
                for i in 0..4 {
                    assert!(relative_eq(s.f[i], f[i], 1e-4), "{:?} vs {f:?}", s.f);
                    assert!(relative_eq(s.pdf_wavelengths[i], pdfs[i], 1e-4));
                    // Wherever a wavelength carries light its density is positive (MIS support).
                    assert!(f[i] == 0.0 || pdfs[i] > 0.0, "{f:?} {pdfs:?}");
                }
            } else if s.is_transmission() {
                assert_eq!(&s.f.0[1..], &[0.0; 3]);
            }
            // Directions and the hero slot follow eta[0] exactly.
            assert_eq!(s.wi, h.wi);
            assert!(relative_eq(s.f[0], h.f[0], 1e-5) && relative_eq(s.pdf, h.pdf, 1e-5));
            if !s.is_transmission() {
                // Reflection keeps every wavelength, each with its own Fresnel.
                let expect = if alpha == 0.0 {
                    SampledSpectrum::from_fn(|i| fresnel_dielectric(wo.z, eta[i]) / wo.z.abs())
                } else {
                    disp.eval(wo, s.wi)
                };
                for i in 0..4 {
                    assert!(
                        relative_eq(s.f[i], expect[i], 1e-4),
                        "{:?} vs {expect:?}",
                        s.f
                    );
                }
                if alpha == 0.0 && s.f[0] < 1.0 / wo.z.abs() {
                    // Outside total internal reflection, denser glass reflects more.
                    assert!(s.f[3] > s.f[0], "{:?}", s.f);
                }
            }
            seen[s.is_transmission() as usize] += 1;
        }
        assert!(seen[0] > 100 && seen[1] > 100, "{seen:?}");
    }
}

#[test]
fn degenerate_inputs_are_finite() {
    let mut bsdfs = vec![
        diffuse(color()),
        metallic_roughness(color(), 0.5, 0.0, 1.0),
        metallic_roughness(color(), 0.5, 1e-6, 1.0),
        metallic_roughness(color(), f32::NAN, f32::NAN, 1.0),
        metallic_roughness(color(), 1.0, 0.0, 1.0),
    ];
    for eta in [1.5f32, 1.0, 1.0 / 1.5, 1e-3, 1e3] {
        for alpha in [0.0f32, 1e-4, 1e-3, 0.3, 1.0] {
            bsdfs.push(Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum::splat(eta),
                alpha,
                transmission_tint: SampledSpectrum::ONE,
                iridescence: None,
                refraction_only: false,
                energy_compensation: true,
            }));
        }
    }
    let dirs = [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(0.0, 1.0, 1e-8).normalize(),
        Vec3::new(1.0, 0.0, -1e-7).normalize(),
        dir(0.5, 1.0),
        dir(-0.5, 4.0),
        Vec3::ZERO,
        Vec3::splat(f32::NAN),
    ];
    let us = [0.0f32, 0.5, 0.999_999_94];
    for b in &bsdfs {
        for &wo in &dirs {
            for &wi in &dirs {
                assert!(b.eval(wo, wi).is_finite(), "{b:?} {wo:?} {wi:?}");
                assert!(b.pdf(wo, wi).is_finite());
                assert!(b.eval(wo, -wo).is_finite());
            }
            for &uc in &us {
                for &u0 in &us {
                    for &u1 in &us {
                        if let Some(s) = b.sample(wo, uc, Vec2::new(u0, u1)) {
                            assert!(s.f.is_finite() && s.pdf.is_finite() && s.pdf > 0.0);
                            assert!(s.wi.is_finite() && (s.wi.length() - 1.0).abs() < 1e-3);
                        }
                    }
                }
            }
        }
    }
    // Reflection models give nothing below the surface or across it.
    for b in &bsdfs[..3] {
        assert!(b.sample(-Vec3::Z, 0.5, Vec2::splat(0.5)).is_none());
        assert!(b.eval(dir(0.5, 0.0), dir(-0.5, 1.0)).is_black());
        assert_eq!(b.pdf(dir(-0.5, 0.0), dir(0.5, 1.0)), 0.0);
    }
}

#[test]
fn eval_pdf_matches_eval_and_pdf() {
    let bsdfs = [
        diffuse(color()),
        metallic_roughness(color(), 0.4, 0.5, 1.0),
        dielectric(1.5, 0.4),
        Bsdf::Dielectric(DielectricBsdf {
            eta: SampledSpectrum([1.5, 1.52, 1.54, 1.56]),
            alpha: 0.2,
            transmission_tint: color(),
            iridescence: None,
            refraction_only: false,
            energy_compensation: true,
        }),
    ];
    let mut rng = Pcg32::new(61, 7);
    for b in &bsdfs {
        let mut nonzero = 0;
        for _ in 0..5_000 {
            let wo = dir(2.0 * rng.next_f32() - 1.0, 6.3 * rng.next_f32());
            let wi = dir(2.0 * rng.next_f32() - 1.0, 6.3 * rng.next_f32());
            let (f, pdf) = b.eval_pdf(wo, wi);
            assert_eq!(f, b.eval(wo, wi));
            assert_eq!(pdf, b.pdf(wo, wi));
            nonzero += (pdf > 0.0) as usize;
        }
        assert!(nonzero > 1_000, "{b:?}");
    }
}

/// A thin film on smooth glass: the mirror sample's per-wavelength weights are the Airy
/// reflectance of each wavelength (`prism::bsdf::ThinFilm`, itself checked against the
/// closed form), the refraction's are 1 - R (radiance's 1/eta^2 undone), both directions
/// shared by every wavelength; rough, the white furnace holds per wavelength.
#[test]
fn thin_film_splits_each_wavelength_by_its_airy_reflectance() {
    let film = prism::bsdf::ThinFilm {
        thickness_nm: 350.0,
        ior: 1.33,
    };
    let lambda = [420.0f32, 500.0, 580.0, 660.0];
    let b = thin_film_glass(0.0);
    for c in [1.0f32, 0.7, 0.3, -0.9, -0.5] {
        let wo = wo_at(c.abs()) * Vec3::new(1.0, 1.0, c.signum());
        let r = b.sample(wo, 0.0, Vec2::new(0.5, 0.5)).unwrap();
        let t = b.sample(wo, 0.9999, Vec2::new(0.5, 0.5));
        for (k, &lambda_k) in lambda.iter().enumerate() {
            let want = film.reflectance(wo.z, 1.5, lambda_k);
            let got = r.f[k] * wo.z.abs();
            assert!(
                (got - want).abs() < 1e-3,
                "cos {c} k {k}: R {got} vs {want}"
            );
            assert!((r.pdf_wavelengths[k] - want).abs() < 1e-5);
            // (Under total internal reflection the last branch reflects too.)
            if let Some(t) = t.filter(|t| t.is_transmission()) {
                assert!(!t.hero_only(), "a film does not split directions");
                let etap = t.eta[k];
                let got_t = t.f[k] * t.wi.z.abs() * etap * etap;
                assert!(
                    (got_t - (1.0 - want)).abs() < 1e-3,
                    "cos {c} k {k}: T {got_t}"
                );
            }
        }
    }
    // Rough: every wavelength keeps its energy (its own Fresnel split, same directions).
    for i in 0..4 {
        let Bsdf::Dielectric(d) = thin_film_glass(0.5) else {
            unreachable!()
        };
        let mut ir = d.iridescence.unwrap();
        ir.lambda.0.swap(0, i);
        let b = Bsdf::Dielectric(DielectricBsdf {
            iridescence: Some(ir),
            ..d
        });
        let (e, _) = albedo(&b, wo_at(0.5), 200_000, 41, true);
        assert!((e - 1.0).abs() < 0.012, "wavelength {i}: E = {e}");
    }
}

/// A thin film on an opaque material's specular layer (white base): the diffuse base is coupled
/// to a Schlick-equivalent of the film's reflectance (its normal-incidence value, F90 = 1), so
/// energy is conserved only approximately; bound the gain and the loss per wavelength.
#[test]
fn thin_film_on_a_white_base_stays_near_one() {
    let mut furnace = Furnace::new(100_000, 43, false, 0.97..=1.03);
    for roughness in [0.0f32, 0.3, 0.7] {
        for c in [0.1f32, 0.5, 0.9] {
            let Bsdf::MetallicRoughness(b) = filmed(metallic_roughness(
                SampledSpectrum::ONE,
                0.0,
                roughness,
                1.0,
            )) else {
                unreachable!()
            };
            let b = MetallicRoughnessBsdf {
                specular_color: SampledSpectrum::ONE,
                ..b
            };
            for i in 0..4 {
                let mut film = b.iridescence.unwrap();
                film.lambda.0.swap(0, i);
                let bi = Bsdf::MetallicRoughness(MetallicRoughnessBsdf {
                    iridescence: Some(film),
                    ..b
                });
                furnace.check(&bi, wo_at(c), || {
                    format!("roughness {roughness} cos {c} wavelength {i}")
                });
            }
        }
    }
    println!(
        "thin film on a white base: worst |E - 1| = {:.4}",
        furnace.worst
    );
}

/// A thin film on a conductor (F82 tint white and coloured): the metal's complex IOR from F0
/// and F82 (Gulbrandsen) under a lossless film, with the multiple-scattering term from the
/// film's average Fresnel, reflects at most what arrives.
#[test]
fn thin_film_on_a_metal_conserves_energy() {
    let mut furnace = Furnace::new(100_000, 47, false, 0.0..=1.01);
    for roughness in [0.0f32, 0.3, 0.7] {
        for tint in [SampledSpectrum::ONE, SampledSpectrum([1.0, 0.7, 0.5, 1.0])] {
            let Bsdf::MetallicRoughness(b) = filmed(metallic_roughness(
                SampledSpectrum([0.95, 0.8, 0.4, 0.9]),
                1.0,
                roughness,
                1.0,
            )) else {
                unreachable!()
            };
            let b = MetallicRoughnessBsdf {
                specular_color: tint,
                ..b
            };
            for c in [0.2f32, 0.6, 1.0] {
                furnace.check(&Bsdf::MetallicRoughness(b), wo_at(c), || {
                    format!("roughness {roughness} tint {tint:?} cos {c}")
                });
            }
        }
    }
    println!("thin film on a metal: worst |E - 1| = {:.4}", furnace.worst);
}

/// Light ray visibility (`Bsdf::visible_part`): the Diffuse, Glossy and Transmission parts of
/// an evaluation add up to the whole, each part is non-negative, and a light no kind sees
/// lights nothing. Principled (diffuse base + specular layer), rough glass (reflection +
/// transmission) and Lambertian.
#[test]
fn visible_parts_add_up_to_the_whole() {
    use prism::scene::desc::RayVisibility;
    let only = |d, g, t| RayVisibility {
        volume: true,
        diffuse: d,
        glossy: g,
        transmission: t,
    };
    let bsdfs = [
        metallic_roughness(SampledSpectrum::splat(0.6), 0.3, 0.4, 1.0),
        dielectric(1.5, 0.3),
        diffuse(SampledSpectrum::splat(0.7)),
        sheened(
            metallic_roughness(SampledSpectrum::splat(0.6), 0.3, 0.4, 1.0),
            SampledSpectrum::splat(0.5),
            0.5,
        ),
    ];
    for b in &bsdfs {
        for (cos_o, cos_i, phi) in [
            (0.8, 0.6, 2.0),
            (0.5, 0.9, 3.0),
            (0.7, -0.5, 3.1),
            (0.3, -0.9, 0.4),
        ] {
            let (wo, wi) = (wo_at(cos_o), dir(cos_i, phi));
            let f = b.eval(wo, wi);
            let parts = [
                b.visible_part(wo, wi, f, only(true, false, false)),
                b.visible_part(wo, wi, f, only(false, true, false)),
                b.visible_part(wo, wi, f, only(false, false, true)),
            ];
            let sum = parts[0] + parts[1] + parts[2];
            for k in 0..4 {
                assert!(
                    (sum[k] - f[k]).abs() <= 1e-5 * f[k].max(1.0),
                    "{b:?}: {sum:?} vs {f:?}"
                );
                assert!(parts.iter().all(|p| p[k] >= 0.0));
            }
            assert!(b
                .visible_part(wo, wi, f, only(false, false, false))
                .is_black());
            assert_eq!(b.visible_part(wo, wi, f, RayVisibility::ALL), f);
        }
    }
    // The glass's transmission is Transmission, its reflection Glossy; the Principled base is
    // Diffuse.
    let glass = &bsdfs[1];
    let (wo, wt) = (wo_at(0.8), dir(-0.7, 3.0));
    let ft = glass.eval(wo, wt);
    assert!(!ft.is_black());
    assert_eq!(
        glass.visible_part(wo, wt, ft, only(false, true, false)),
        SampledSpectrum::ZERO
    );
    let p = &bsdfs[0];
    let (wo, wr) = (wo_at(0.8), dir(0.6, 2.0));
    let d = p.visible_part(wo, wr, p.eval(wo, wr), only(true, false, false));
    assert_eq!(d, p.diffuse_part(wo, wr));
}

/// `with_film_averages` (what material construction calls) only stores the terms each
/// evaluation of a filmed layer would compute: eval, pdf and sample are bit-identical with and
/// without it, for filmed dielectric, metallic and mixed bases, rough and smooth.
#[test]
fn cached_film_averages_change_nothing() {
    let mut rng = Pcg32::new(77, 3);
    for (metallic, roughness) in [(0.0, 0.3), (1.0, 0.4), (0.5, 0.0), (0.3, 0.8)] {
        let Bsdf::MetallicRoughness(b) = metallic_roughness(color(), metallic, roughness, 1.0)
        else {
            unreachable!()
        };
        let plain = MetallicRoughnessBsdf {
            iridescence: soap_film(),
            ..b
        };
        let cached = plain.with_film_averages();
        assert!(cached.iridescence.is_some_and(|i| i.averages.is_some()));
        let (plain, cached) = (
            Bsdf::MetallicRoughness(plain),
            Bsdf::MetallicRoughness(cached),
        );
        for _ in 0..200 {
            let wo = dir(rng.next_f32(), rng.next_f32() * std::f32::consts::TAU);
            let wi = dir(rng.next_f32(), rng.next_f32() * std::f32::consts::TAU);
            let (a, b) = (plain.eval_pdf(wo, wi), cached.eval_pdf(wo, wi));
            assert_eq!(a.0 .0, b.0 .0, "eval ({metallic}, {roughness})");
            assert_eq!(a.1, b.1, "pdf ({metallic}, {roughness})");
            let (uc, u) = (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
            let (sa, sb) = (plain.sample(wo, uc, u), cached.sample(wo, uc, u));
            assert_eq!(
                sa.map(|s| (s.wi, s.f.0, s.pdf)),
                sb.map(|s| (s.wi, s.f.0, s.pdf))
            );
        }
    }
}

/// Mirrors, near-mirrors and the metals and glass that focus light reflect sharply
/// (`Bsdf::is_sharp`: caustic guiding does not count such vertices when it decides how deep
/// into a path it guides, so a floor seen in a chrome ball is guided as the floor seen
/// directly); rougher ones, plastics and diffuse surfaces do not.
#[test]
fn mirrors_near_mirrors_and_focusing_interfaces_are_sharp() {
    let grey = SampledSpectrum::splat(0.8);
    for roughness in [0.0, 0.05, 0.1, 0.3] {
        assert!(
            metallic_roughness(grey, 1.0, roughness, 0.5).is_sharp(),
            "metal {roughness}"
        );
        assert!(dielectric(1.5, roughness).is_sharp(), "glass {roughness}");
    }
    for roughness in [0.35, 0.6] {
        assert!(
            !metallic_roughness(grey, 1.0, roughness, 0.5).is_sharp(),
            "metal {roughness}"
        );
        assert!(!dielectric(1.5, roughness).is_sharp(), "glass {roughness}");
    }
    assert!(
        !metallic_roughness(grey, 0.0, 0.05, 0.5).is_sharp(),
        "plastic"
    );
    assert!(!diffuse(grey).is_sharp());
    // Of the sharp ones, those rough enough for photons to find their glints focus light.
    assert!(metallic_roughness(grey, 1.0, 0.2, 0.5).focuses_light());
    assert!(!metallic_roughness(grey, 1.0, 0.05, 0.5).focuses_light());
    // Glass from roughness 0.03: a ball refracts a light into a caustic broad enough for
    // photons to point at; smooth glass does not focus (photons start at focusing surfaces
    // by next-event estimation).
    assert!(dielectric(1.5, 0.05).focuses_light());
    assert!(dielectric(1.5, 0.2).focuses_light());
    assert!(!dielectric(1.5, 0.02).focuses_light());
    assert!(!dielectric(1.5, 0.0).focuses_light());
}
