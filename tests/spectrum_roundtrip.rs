//! End-to-end checks of the RGB <-> spectrum conversions: sRGB -> upsampled spectrum -> CIE XYZ
//! (by deterministic quadrature, and by the renderer's Monte Carlo estimator) -> sRGB.

#[path = "common/stats.rs"]
mod stats;

use glam::Vec3;
use prism::spectrum::{
    cie, rgb, spectrum_to_xyz, RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum,
    SampledWavelengths, WavelengthPdf, LAMBDA_MAX, LAMBDA_MIN,
};

/// XYZ of `f` over 360-830 nm, normalised so a constant 1 has Y = 1: composite Simpson with 8
/// panels per nm, in f64. (Written independently of `cie::integrate_xyz`.)
fn quad_xyz(f: impl Fn(f32) -> f32) -> Vec3 {
    const PANELS_PER_NM: usize = 8;
    let n = (LAMBDA_MAX - LAMBDA_MIN) as usize * PANELS_PER_NM;
    let h = 1.0 / PANELS_PER_NM as f64;
    let mut acc = [0.0f64; 3];
    for k in 0..=n {
        let w = match k {
            0 => 1.0,
            _ if k == n => 1.0,
            _ if k % 2 == 1 => 4.0,
            _ => 2.0,
        };
        let l = (LAMBDA_MIN as f64 + k as f64 * h) as f32;
        let v = f(l) as f64 * w;
        let cmf = cie::cie_xyz_bar(l);
        for (a, c) in acc.iter_mut().zip(cmf.to_array()) {
            *a += v * c as f64;
        }
    }
    let s = h / 3.0 / cie::CIE_Y_INTEGRAL as f64;
    Vec3::new(
        (acc[0] * s) as f32,
        (acc[1] * s) as f32,
        (acc[2] * s) as f32,
    )
}

/// Linear sRGB of a reflectance lit by the renderer's white light, RGB (1, 1, 1) emission.
fn reflected_rgb(s: &RgbAlbedoSpectrum) -> Vec3 {
    let white = RgbIlluminantSpectrum::new(Vec3::ONE);
    rgb::xyz_to_linear_srgb(quad_xyz(|l| s.eval(l) * white.eval(l)))
}

/// Deterministic uniform numbers in [0, 1) (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn colour(&mut self) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next())
    }
}

/// A 17^3 grid over [0, 1]^3 (nodes at multiples of 1/16, mostly off the table's nodes),
/// random colours, and colours near the cube's faces, edges and corners.
fn test_colours() -> Vec<Vec3> {
    let mut out = vec![];
    let g = 17;
    for b in 0..g {
        for gg in 0..g {
            for r in 0..g {
                out.push(Vec3::new(r as f32, gg as f32, b as f32) / (g - 1) as f32);
            }
        }
    }
    let mut rng = Rng(42);
    out.extend((0..3000).map(|_| rng.colour()));
    let ends = [0.0, 0.003, 0.02, 0.49, 0.51, 0.98, 0.997, 1.0];
    for _ in 0..1000 {
        let pick = |rng: &mut Rng| ends[(rng.next() * ends.len() as f32) as usize];
        let mut c = rng.colour();
        for k in 0..3 {
            if rng.next() < 0.6 {
                c[k] = (pick(&mut rng) + 0.01 * (rng.next() - 0.5)).clamp(0.0, 1.0);
            }
        }
        out.push(c);
    }
    out
}

#[test]
fn albedo_roundtrip_within_1e3() {
    let mut worst = (0.0f32, Vec3::ZERO, Vec3::ZERO);
    let colours = test_colours();
    for &c in &colours {
        let back = reflected_rgb(&RgbAlbedoSpectrum::new(c));
        let err = (back - c).abs().max_element();
        if err > worst.0 {
            worst = (err, c, back);
        }
    }
    println!(
        "albedo round trip over {} colours: max error {:.2e} at {} -> {}",
        colours.len(),
        worst.0,
        worst.1,
        worst.2
    );
    assert!(worst.0 < 1e-3, "{worst:?}");
}

#[test]
fn illuminant_roundtrip_within_1e3() {
    let mut worst = 0.0f32;
    for (n, &c) in test_colours().iter().enumerate() {
        // Emission of any magnitude; errors relative to the brightest channel.
        let m = [1.0, 0.01, 40.0][n % 3];
        let e = RgbIlluminantSpectrum::new(c * m);
        let back = rgb::xyz_to_linear_srgb(quad_xyz(|l| e.eval(l)));
        let err = (back - c * m).abs().max_element() / (c.max_element() * m).max(1e-30);
        worst = worst.max(err);
        assert!(err < 1e-3, "{c} x {m} -> {back}");
    }
    println!("illuminant round trip: max error / max component {worst:.2e}");
}

#[test]
fn d65_normalised_white_is_rgb_one() {
    let white = RgbIlluminantSpectrum::new(Vec3::ONE);
    let xyz = quad_xyz(|l| white.eval(l));
    let rgb = rgb::xyz_to_linear_srgb(xyz);
    println!("white: XYZ {xyz}, RGB {rgb}");
    assert!((rgb - Vec3::ONE).abs().max_element() < 1e-3, "{rgb}");
    assert!((xyz.y - 1.0).abs() < 1e-4, "{xyz}");
    // The same as the normalised CIE D65, and Y = 1 through the public helper too.
    for l in [380.0, 460.0, 560.0, 700.0] {
        assert!((white.eval(l) - cie::d65_normalized(l)).abs() < 1e-6);
    }
    assert!((cie::integrate_xyz(cie::d65_normalized, 2).y - 1.0).abs() < 1e-5);
    // A flat reflectance under it is exactly grey.
    let grey = reflected_rgb(&RgbAlbedoSpectrum::new(Vec3::splat(0.18)));
    assert!(
        (grey - Vec3::splat(0.18)).abs().max_element() < 1e-5,
        "{grey}"
    );
}

#[test]
fn monte_carlo_estimator_converges_to_quadrature() {
    const N: usize = 1_000_000;
    let white = RgbIlluminantSpectrum::new(Vec3::ONE);
    let albedos = [
        Vec3::new(0.8, 0.1, 0.05),
        Vec3::new(0.1, 0.6, 0.3),
        Vec3::new(0.2, 0.3, 0.9),
        Vec3::splat(0.5),
    ];
    let mut rng = Rng(7);
    for c in albedos {
        let s = RgbAlbedoSpectrum::new(c);
        let exact = quad_xyz(|l| s.eval(l) * white.eval(l));
        // Independent uniform hero wavelengths, the renderer's per-path estimator, averaged.
        let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
        for _ in 0..N {
            let w = SampledWavelengths::sample_hero(rng.next(), WavelengthPdf::Visible);
            let xyz = spectrum_to_xyz(&(s.sample(&w) * white.sample(&w)), &w);
            for k in 0..3 {
                sum[k] += xyz[k] as f64;
                sum2[k] += (xyz[k] as f64).powi(2);
            }
        }
        let mean = sum.map(|v| v / N as f64);
        let std_err: [f64; 3] =
            std::array::from_fn(|k| ((sum2[k] / N as f64 - mean[k] * mean[k]) / N as f64).sqrt());
        let mc = Vec3::from_array(mean.map(|v| v as f32));
        let rel = ((mc - exact).abs() / exact).max_element();
        let sigmas = (0..3)
            .map(|k| (mean[k] - exact[k] as f64).abs() / std_err[k])
            .fold(0.0, f64::max);
        println!(
            "{c}: MC {mc} vs quadrature {exact}, relative error {rel:.1e} ({sigmas:.1} standard errors)"
        );
        assert!(rel < 5e-3, "{c}: {mc} vs {exact}");
        assert!(
            sigmas < 5.0,
            "{c}: {mc} vs {exact}: {sigmas} standard errors"
        );
    }
    // An emitter, straight into the estimator, with stratified hero wavelengths: converges much
    // faster, which checks that the estimator's normalisation matches the quadrature closely.
    let e = RgbIlluminantSpectrum::new(Vec3::new(3.0, 1.0, 0.2));
    let exact = quad_xyz(|l| e.eval(l));
    let mut sum = Vec3::ZERO.as_dvec3();
    for i in 0..N {
        let w = SampledWavelengths::sample_hero(
            (i as f32 + rng.next()) / N as f32,
            WavelengthPdf::Visible,
        );
        sum += spectrum_to_xyz(&e.sample(&w), &w).as_dvec3();
    }
    let mc = (sum / N as f64).as_vec3();
    let rel = ((mc - exact).abs() / exact).max_element();
    println!("emitter: stratified MC {mc} vs quadrature {exact}, relative error {rel:.1e}");
    assert!(rel < 1e-4, "{mc} vs {exact}");
}

#[test]
fn albedo_spectra_stay_in_unit_interval() {
    let mut rng = Rng(3);
    let mut colours = test_colours();
    colours.extend((0..500).map(|_| rng.colour() * 4.0 - Vec3::splat(1.0))); // clamped
    for c in colours {
        let s = RgbAlbedoSpectrum::new(c);
        for i in 0..=940 {
            let l = LAMBDA_MIN + 0.5 * i as f32;
            let v = s.eval(l);
            assert!((0.0..=1.0).contains(&v), "{c} at {l} nm: {v}");
        }
    }
}

#[test]
fn unbounded_spectra_reproduce_large_magnitudes() {
    for c in [
        Vec3::new(5.0, 0.2, 30.0),
        Vec3::new(120.0, 3.0, 0.5),
        Vec3::new(0.002, 0.04, 0.001),
        Vec3::new(2.5, 2.5, 0.0),
        Vec3::splat(17.0),
    ] {
        let s = RgbUnboundedSpectrum::new(c);
        // Coefficients (e.g. sigma_a) are looked up under the same D65 convention as albedo.
        let white = RgbIlluminantSpectrum::new(Vec3::ONE);
        let back = rgb::xyz_to_linear_srgb(quad_xyz(|l| s.eval(l) * white.eval(l)));
        let err = (back - c).abs().max_element() / c.max_element();
        println!("{c} -> {back} (error / max {err:.1e})");
        assert!(err < 1e-3, "{c} -> {back}");
        // Non-negative everywhere and bounded by twice the largest component.
        for i in 0..=470 {
            let v = s.eval(LAMBDA_MIN + i as f32);
            assert!(v >= 0.0 && v <= 2.0 * c.max_element(), "{v}");
        }
    }
}

/// Every wavelength density samples what its `pdf` says (chi-square over 94 bins of 5 nm, the
/// expected counts by midpoint quadrature of `pdf` at 0.05 nm), and the density returned with
/// a sample is `pdf` at it. The colour-balanced "rgb" table is sampled through an inverse CDF
/// on uniform steps of u whose density is its knot-interval averages, not the 1-nm bins.
#[test]
fn wavelength_densities_sample_their_pdf_chi_square() {
    let samples = 300_000;
    let bins = 94;
    let width = (LAMBDA_MAX - LAMBDA_MIN) / bins as f32;
    for (case, d) in [
        WavelengthPdf::Rgb,
        WavelengthPdf::Visible,
        WavelengthPdf::Uniform,
    ]
    .into_iter()
    .enumerate()
    {
        let mut rng = stats::Pcg32::new(29, case as u64);
        let mut observed = vec![0.0f64; bins];
        for _ in 0..samples {
            let (l, p) = d.sample_with_pdf(rng.next_f32());
            assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&l), "{d:?}: {l}");
            // Up to rounding at a knot: the sample's own interval or its neighbour.
            let matches = [l - 1e-3, l, l + 1e-3]
                .iter()
                .any(|&m| (p - d.pdf(m)).abs() <= 1e-3 * p);
            assert!(
                matches,
                "{d:?} at {l}: {p} vs {} {} {}",
                d.pdf(l - 1e-3),
                d.pdf(l),
                d.pdf(l + 1e-3)
            );
            observed[(((l - LAMBDA_MIN) / width) as usize).min(bins - 1)] += 1.0;
        }
        let sub = 100;
        let expected: Vec<f64> = (0..bins)
            .map(|b| {
                let h = width as f64 / sub as f64;
                (0..sub)
                    .map(|k| {
                        let l = LAMBDA_MIN as f64 + b as f64 * width as f64 + (k as f64 + 0.5) * h;
                        d.pdf(l as f32) as f64 * h
                    })
                    .sum::<f64>()
                    * samples as f64
            })
            .collect();
        let total: f64 = expected.iter().sum::<f64>() / samples as f64;
        assert!(
            (total - 1.0).abs() < 1e-3,
            "{d:?}: pdf integrates to {total}"
        );
        stats::chi2_test(&observed, &expected, 5.0).assert_fits(1e-4, format!("{d:?}"));
    }
}

/// The colour noise that the wavelengths alone add to a pixel: a Blender colour's reflectance
/// under white light (D65), estimated from one path's four members (`sample_hero`) as the film
/// does, over a fine stratified grid of the hero's u. Per channel the variance relative to
/// the square of the colour (with a floor of 0.05 x the largest channel's square, as the
/// density's fit weighs it), summed over channels and averaged over 64 random colours and 32
/// products of two: the `rgb` density, fitted to this four-member rule
/// (`data/gen_wavelength_pdf.py`; these colours are not among the fitted ones), must be far
/// below the luminance bell, and every estimate unbiased. (Measured: rgb 0.055, bell 0.42; the
/// previous density, the single-wavelength optimum mixed the same way, 0.12 fails.)
#[test]
fn rgb_wavelength_density_minimises_the_four_member_colour_noise() {
    let white = RgbIlluminantSpectrum::new(Vec3::ONE);
    let mut rng = stats::Pcg32::new(31, 7);
    let mut colour =
        || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.87 + Vec3::splat(0.03);
    let singles: Vec<RgbAlbedoSpectrum> =
        (0..64).map(|_| RgbAlbedoSpectrum::new(colour())).collect();
    let products: Vec<[RgbAlbedoSpectrum; 2]> = (0..32)
        .map(|_| {
            [
                RgbAlbedoSpectrum::new(colour()),
                RgbAlbedoSpectrum::new(colour()),
            ]
        })
        .collect();
    let spectra: Vec<Box<dyn Fn(f32) -> f32>> = singles
        .iter()
        .map(|&a| Box::new(move |l| a.eval(l)) as Box<dyn Fn(f32) -> f32>)
        .chain(
            products
                .iter()
                .map(|&[a, b]| Box::new(move |l| a.eval(l) * b.eval(l)) as Box<dyn Fn(f32) -> f32>),
        )
        .collect();
    const GRID: usize = 4096;
    let colour_noise = |density: WavelengthPdf| -> f64 {
        let mut total = 0.0;
        for f in &spectra {
            let exact = rgb::xyz_to_linear_srgb(quad_xyz(|l| f(l) * white.eval(l)));
            let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
            for i in 0..GRID {
                // The four members' u cover [0, 1) once as the hero's u covers [0, 1/4).
                let u = (i as f32 + 0.5) / (GRID * 4) as f32;
                let w = SampledWavelengths::sample_hero(u, density);
                let s = prism::spectrum::SampledSpectrum::from_fn(|k| {
                    f(w.lambda[k]) * white.eval(w.lambda[k])
                });
                let estimate = rgb::xyz_to_linear_srgb(spectrum_to_xyz(&s, &w)).to_array();
                for c in 0..3 {
                    sum[c] += estimate[c] as f64;
                    sum2[c] += (estimate[c] as f64).powi(2);
                }
            }
            let floor = 0.05 * (exact.max_element() as f64).powi(2);
            for c in 0..3 {
                let mean = sum[c] / GRID as f64;
                let truth = exact[c] as f64;
                assert!(
                    (mean - truth).abs() < 2e-3 * exact.max_element() as f64,
                    "{density:?}: channel {c} mean {mean} vs {truth}"
                );
                let variance = sum2[c] / GRID as f64 - mean * mean;
                total += variance / (truth * truth + floor);
            }
        }
        total / spectra.len() as f64
    };
    let fitted = colour_noise(WavelengthPdf::Rgb);
    let bell = colour_noise(WavelengthPdf::Visible);
    println!("four-member colour noise: rgb {fitted:.4}, bell {bell:.4}");
    assert!(fitted < 0.2 * bell, "rgb {fitted} vs bell {bell}");
}
