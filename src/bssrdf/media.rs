//! Scattering coefficients of a subsurface material: measured presets, explicit coefficients
//! and the inversion (diffuse reflectance, mean free path) -> coefficients.

use super::table::BssrdfTable;
use crate::scene::{SubsurfaceCoefficients, SubsurfaceDesc};
use glam::Vec3;

/// Measured media of Jensen, Marschner, Levoy, Hanrahan 2001, "A Practical Model for Subsurface
/// Light Transport", Figure 5: reduced scattering coefficient sigma_s' and absorption
/// coefficient sigma_a in mm^-1 for the R, G, B channels. (name, sigma_s', sigma_a).
pub const JENSEN_2001_MEDIA: &[(&str, [f32; 3], [f32; 3])] = &[
    ("Apple", [2.29, 2.39, 1.97], [0.0030, 0.0034, 0.046]),
    ("Chicken1", [0.15, 0.21, 0.38], [0.015, 0.077, 0.19]),
    ("Chicken2", [0.19, 0.25, 0.32], [0.018, 0.088, 0.20]),
    ("Cream", [7.38, 5.47, 3.15], [0.0002, 0.0028, 0.0163]),
    ("Ketchup", [0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    ("Marble", [2.19, 2.62, 3.00], [0.0021, 0.0041, 0.0071]),
    ("Potato", [0.68, 0.70, 0.55], [0.0024, 0.0090, 0.12]),
    ("Skimmilk", [0.70, 1.22, 1.90], [0.0014, 0.0025, 0.0142]),
    ("Skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    ("Skin2", [1.09, 1.59, 1.79], [0.013, 0.070, 0.145]),
    ("Spectralon", [11.6, 20.4, 14.9], [0.00, 0.00, 0.00]),
    ("Wholemilk", [2.55, 3.21, 3.77], [0.0011, 0.0024, 0.014]),
];

/// (sigma_s', sigma_a) of a preset in mm^-1.
pub fn preset(name: &str) -> Option<(Vec3, Vec3)> {
    JENSEN_2001_MEDIA
        .iter()
        .find(|m| m.0 == name)
        .map(|m| (Vec3::from(m.1), Vec3::from(m.2)))
}

/// RGB coefficients in 1 / scene unit: absorption and *reduced* scattering (similarity theory,
/// sigma_s' = sigma_s (1 - g); Wyman, Patterson, Wiscombe 1989 / Jensen et al. 2001 sec. 2.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    pub sigma_a: Vec3,
    pub sigma_s_reduced: Vec3,
}

impl Coefficients {
    /// Full scattering coefficient for a walk with Henyey-Greenstein anisotropy g.
    pub fn sigma_s(&self, g: f32) -> Vec3 {
        self.sigma_s_reduced / (1.0 - g).max(1e-3)
    }
}

/// Coefficients for a subsurface description. `table` must be built for `desc.eta` (used by
/// the reflectance inversion).
pub fn coefficients(desc: &SubsurfaceDesc, table: &BssrdfTable) -> Coefficients {
    let (sigma_a, sigma_s_reduced) = match &desc.coefficients {
        SubsurfaceCoefficients::Preset(name) => {
            let (sp, sa) = preset(name).unwrap_or((Vec3::ONE, Vec3::ZERO));
            (sa, sp)
        }
        SubsurfaceCoefficients::Explicit { sigma_a, sigma_s } => {
            (*sigma_a, *sigma_s * (1.0 - desc.g))
        }
        SubsurfaceCoefficients::Reflectance { reflectance, mfp } => {
            let c = invert_reflectance(table, *reflectance, *mfp);
            (c.sigma_a, c.sigma_s_reduced)
        }
        SubsurfaceCoefficients::CyclesWalk {
            color,
            radius,
            skin,
        } => {
            let c = cycles_walk(*color, *radius, *skin, desc.g, desc.eta);
            (c.sigma_a, c.sigma_s_reduced)
        }
    };
    Coefficients {
        sigma_a: (sigma_a * desc.scale).max(Vec3::ZERO),
        sigma_s_reduced: (sigma_s_reduced * desc.scale).max(Vec3::ZERO),
    }
}

/// Per channel: the albedo whose effective albedo equals `reflectance` (Catmull-Rom inversion of
/// the table's rho_eff), and sigma_t' = 1 / mfp (mean free path in scene units).
pub fn invert_reflectance(table: &BssrdfTable, reflectance: Vec3, mfp: Vec3) -> Coefficients {
    let mut sigma_a = Vec3::ZERO;
    let mut sigma_s = Vec3::ZERO;
    for c in 0..3 {
        let rho = table.invert_rho_eff(reflectance[c]);
        let sigma_t = 1.0 / mfp[c].max(1e-12);
        sigma_s[c] = rho * sigma_t;
        sigma_a[c] = (1.0 - rho) * sigma_t;
    }
    Coefficients {
        sigma_a,
        sigma_s_reduced: sigma_s,
    }
}

/// Coefficients of Blender's random walk for colour `color` and radius `radius` (scene units)
/// per channel, HG anisotropy `g` and boundary IOR `eta`, as Cycles derives them (measured
/// against Cycles 5.0 in tests/addon/test_sss_parity.py): the single-scattering albedo from the
/// fit of Wrenninge, Villemin and Hery 2017 (`walk_albedo`) and sigma_t = 1 / (d (1 - g)), with
/// d = radius / (4 pi) (Random Walk: Cycles scales the radius to look like its older profiles)
/// or d = radius sqrt(3 (1 - a')) (Skin; a' the reduced albedo whose dipole reflects `color`,
/// `dipole_albedo_inverse`).
pub fn cycles_walk(color: Vec3, radius: Vec3, skin: bool, g: f32, eta: f32) -> Coefficients {
    let mut sigma_a = Vec3::ZERO;
    let mut sigma_s_reduced = Vec3::ZERO;
    for c in 0..3 {
        let a = color[c].clamp(0.0, 1.0);
        let d = if skin {
            radius[c] * (3.0 * (1.0 - dipole_albedo_inverse(a, eta))).sqrt()
        } else {
            radius[c] / (4.0 * std::f32::consts::PI)
        };
        let sigma_t = 1.0 / (d.max(1e-9) * (1.0 - g).max(1e-3));
        let alpha = walk_albedo(a, g);
        sigma_s_reduced[c] = alpha * sigma_t * (1.0 - g);
        sigma_a[c] = (1.0 - alpha) * sigma_t;
    }
    Coefficients {
        sigma_a,
        sigma_s_reduced,
    }
}

/// The single-scattering albedo whose random walk (no boundary reflection) reflects `a` for
/// Henyey-Greenstein anisotropy `g`: the fit of Wrenninge, Villemin and Hery 2017 ("Path
/// Traced Subsurface Scattering using Anisotropic Phase Functions and Non-Exponential Free
/// Flights", Pixar TM 17-07, their coefficients; extending Chiang, Kutz and Burley 2016 to
/// anisotropy), which Cycles uses.
pub fn walk_albedo(a: f32, g: f32) -> f32 {
    let (a, g) = (a.clamp(0.0, 1.0) as f64, g as f64);
    let poly = |c: [f64; 8]| c.iter().rev().fold(0.0, |acc, k| acc * g + k);
    let p_a = poly([
        1.8260523782,
        -1.28451056436,
        -1.79904629312,
        9.19393289202,
        -22.8215585862,
        32.0234874259,
        -23.6264803333,
        7.21067002658,
    ]);
    let p_b = 4.98511194385
        + 0.127355959438
            * poly([
                0.0,
                31.1491581433,
                -201.847017512,
                841.576016723,
                -2018.09288505,
                2731.71560286,
                -1935.41424244,
                559.009054474,
            ])
            .exp();
    let p_c = poly([
        1.09686102424,
        -0.394704063468,
        1.05258115941,
        -8.83963712726,
        28.8643230661,
        -46.8802913581,
        38.5402837518,
        -12.7181042538,
    ]);
    let p_d = poly([
        0.496310210422,
        0.360146581622,
        -2.15139309747,
        17.8896899217,
        -55.2984010333,
        82.065982243,
        -58.5106008578,
        15.8478295021,
    ]);
    let p_e = 4.23190299701
        + 0.00310603949088
            * poly([
                0.0,
                76.7316253952,
                -594.356773233,
                2448.8834203,
                -5576.68528998,
                7116.60171912,
                -4763.54467887,
                1303.5318055,
            ])
            .exp();
    let p_f = poly([
        2.40602999408,
        -2.51814844609,
        9.18494908356,
        -79.2191708682,
        259.082868209,
        -403.613804597,
        302.85712436,
        -87.4370473567,
    ]);
    let blend = a.powf(0.25);
    let alpha =
        (1.0 - blend) * p_a * (p_b * a).atan().powf(p_c) + blend * p_d * (p_e * a).atan().powf(p_f);
    alpha.clamp(0.0, 0.999_999) as f32
}

/// The reduced albedo a' whose dipole diffuse reflectance (Jensen et al. 2001, eq. 8, with
/// Egan and Hilgeman's fit of F_dr) is `rd`, by bisection (the reflectance rises with a').
pub fn dipole_albedo_inverse(rd: f32, eta: f32) -> f32 {
    if rd < 1e-4 {
        return 0.0;
    }
    let eta = eta as f64;
    let f_dr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    let a_coef = (1.0 + f_dr) / (1.0 - f_dr);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        let s = (3.0 * (1.0 - mid)).sqrt();
        let r = 0.5 * mid * (1.0 + (-4.0 / 3.0 * a_coef * s).exp()) * (-s).exp();
        if r < rd as f64 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walk_albedo_matches_the_published_fit() {
        // Values of the fit (Wrenninge et al. 2017) as the add-on computed them in Python
        // before this module took the formula over.
        for (a, g, want) in [
            (0.8f32, 0.0f32, 0.991_753_03f32),
            (0.2, 0.0, 0.613_351_3),
            (0.5, 0.5, 0.955_744_1),
            (0.05, 0.8, 0.599_573_5),
        ] {
            let got = walk_albedo(a, g);
            assert!((got - want).abs() < 1e-4, "a {a} g {g}: {got} vs {want}");
        }
        assert_eq!(walk_albedo(0.0, 0.0), 0.0);
        let mut last = 0.0;
        for k in 1..=100 {
            let v = walk_albedo(k as f32 / 100.0, 0.3);
            assert!(v >= last && v < 1.0, "monotonic below 1");
            last = v;
        }
    }

    #[test]
    fn dipole_inverse_round_trips() {
        let eta = 1.4f64;
        let f_dr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
        let a_coef = (1.0 + f_dr) / (1.0 - f_dr);
        for a in [0.1f64, 0.5, 0.9, 0.99] {
            let s = (3.0 * (1.0 - a)).sqrt();
            let rd = 0.5 * a * (1.0 + (-4.0 / 3.0 * a_coef * s).exp()) * (-s).exp();
            let back = dipole_albedo_inverse(rd as f32, eta as f32) as f64;
            assert!((back - a).abs() < 1e-5, "{a}: {back}");
        }
    }
}
