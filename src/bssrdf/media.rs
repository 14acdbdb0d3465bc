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
