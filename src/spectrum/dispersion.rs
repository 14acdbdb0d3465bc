//! Index of refraction as a function of wavelength (dispersion).
//!
//! One type, [`IorModel`], describes every IOR the scene formats can express: a constant,
//! Cauchy's and Sellmeier's equations, the (n_d, V_d) "Abbe" form used by glass catalogues and
//! glTF's `KHR_materials_dispersion`, and named glasses with published Sellmeier coefficients.
//! The loaders build and validate models here; the renderer only calls [`IorModel::eval`].
//!
//! Units: wavelengths are given to [`IorModel::eval`] in nanometres (like the rest of
//! `crate::spectrum`) but, as in every glass catalogue, the equations' coefficients use
//! micrometres (Cauchy's b in µm², c in µm⁴; Sellmeier's C_i in µm²).

use super::sampled::{LAMBDA_MAX, LAMBDA_MIN};

/// Fraunhofer F line (hydrogen, blue), nm. The F, d and C lines define n_d and V_d
/// (Schott, "Optical Glass – Data Sheets", and ISO 7944).
pub const LAMBDA_F_NM: f32 = 486.13;
/// Fraunhofer d line (helium, yellow), nm.
pub const LAMBDA_D_NM: f32 = 587.56;
/// Fraunhofer C line (hydrogen, red), nm.
pub const LAMBDA_C_NM: f32 = 656.27;

/// Most terms a Sellmeier model may have (catalogues use 3; fits of liquids up to 4–6).
pub const MAX_SELLMEIER_TERMS: usize = 6;

/// Canonical names of the glass presets, as accepted by [`IorModel::preset`]
/// (matching ignores ASCII case).
pub const GLASS_PRESETS: &[&str] = &["BK7", "fused_silica", "F2", "SF11", "diamond", "water"];

/// Sellmeier coefficients: n²(λ) = 1 + Σ_i B_i λ² / (λ² − C_i), λ in µm, C_i in µm².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SellmeierTerms {
    len: usize,
    b: [f64; MAX_SELLMEIER_TERMS],
    c: [f64; MAX_SELLMEIER_TERMS],
}

impl SellmeierTerms {
    /// The B_i (dimensionless).
    pub fn b(&self) -> &[f64] {
        &self.b[..self.len]
    }
    /// The C_i (µm²); each is the square of a resonance wavelength.
    pub fn c(&self) -> &[f64] {
        &self.c[..self.len]
    }
}

/// Index of refraction as a function of wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IorModel {
    /// The same IOR at every wavelength.
    Constant(f32),
    /// Cauchy's equation n(λ) = a + b/λ² + c/λ⁴, λ in µm (b in µm², c in µm⁴).
    Cauchy { a: f32, b: f32, c: f32 },
    /// Sellmeier's equation n²(λ) = 1 + Σ_i B_i λ² / (λ² − C_i), λ in µm, C_i in µm².
    Sellmeier(SellmeierTerms),
    /// A glass given by its catalogue numbers: n_d at the d line and the Abbe number
    /// V_d = (n_d − 1) / (n_F − n_C). Evaluated as the two-term Cauchy equation through those
    /// constraints (the construction `KHR_materials_dispersion` specifies):
    ///
    /// n(λ) = A + B/λ², B = (n_d − 1) / (V_d (1/λ_F² − 1/λ_C²)), A = n_d − B/λ_d²,
    ///
    /// with λ_F = 486.13 nm, λ_d = 587.56 nm, λ_C = 656.27 nm (in µm in the formula). By
    /// construction n(λ_d) = n_d and (n_d − 1)/(n(λ_F) − n(λ_C)) = V_d.
    Abbe { n_d: f32, v_d: f32 },
}

/// Published Sellmeier coefficients of the presets, (B_i, C_i in µm²).
fn preset_terms(canonical: &str) -> &'static [(f64, f64)] {
    match canonical {
        // Schott N-BK7 data sheet (SCHOTT Optical Glass Data Sheets, 2017 catalogue).
        "BK7" => &[
            (1.039_612_12, 0.006_000_698_67),
            (0.231_792_344, 0.020_017_914_4),
            (1.010_469_45, 103.560_653),
        ],
        // I. H. Malitson, "Interspecimen comparison of the refractive index of fused silica",
        // J. Opt. Soc. Am. 55, 1205 (1965): resonances 0.0684043, 0.1162414, 9.896161 µm.
        "fused_silica" => &[
            (0.696_166_3, 0.068_404_3 * 0.068_404_3),
            (0.407_942_6, 0.116_241_4 * 0.116_241_4),
            (0.897_479_4, 9.896_161 * 9.896_161),
        ],
        // Schott F2 data sheet (SCHOTT Optical Glass Data Sheets).
        "F2" => &[
            (1.345_333_59, 0.009_977_438_71),
            (0.209_073_176, 0.047_045_076_7),
            (0.937_357_162, 111.886_764),
        ],
        // Schott SF11 data sheet (SCHOTT Optical Glass Data Sheets).
        "SF11" => &[
            (1.737_596_95, 0.013_188_707),
            (0.313_747_346, 0.062_306_814_2),
            (1.898_781_01, 155.236_29),
        ],
        // F. Peter, "Über Brechungsindizes und Absorptionskonstanten des Diamanten zwischen
        // 644 und 226 mµ", Z. Phys. 15, 358 (1923), in the Sellmeier form given on
        // refractiveindex.info (resonances 0.1750 and 0.1060 µm).
        "diamond" => &[(0.3306, 0.1750 * 0.1750), (4.3356, 0.1060 * 0.1060)],
        // M. Daimon and A. Masumura, "Measurement of the refractive index of distilled water
        // from the near-infrared region to the ultraviolet region", Appl. Opt. 46, 3811
        // (2007), 4-term fit at 20 °C (as on refractiveindex.info).
        "water" => &[
            (5.684_027_565e-1, 5.101_829_712e-3),
            (1.726_177_391e-1, 1.821_153_936e-2),
            (2.086_189_578e-2, 2.620_722_293e-2),
            (1.130_748_688e-1, 1.069_792_721e1),
        ],
        _ => &[],
    }
}

/// Wavelengths (nm) at which `validate` checks n >= 1: every nanometre of the sampled range.
fn check_wavelengths() -> impl Iterator<Item = f32> {
    let n = (LAMBDA_MAX - LAMBDA_MIN) as usize;
    (0..=n).map(|i| LAMBDA_MIN + i as f32)
}

impl IorModel {
    /// Cauchy's equation; `c` may be 0 for the two-term form. Validated.
    pub fn cauchy(a: f32, b: f32, c: f32) -> Result<Self, String> {
        for (name, v) in [("a", a), ("b", b), ("c", c)] {
            if !v.is_finite() {
                return Err(format!("Cauchy '{name}' must be a finite number, got {v}"));
            }
        }
        if b < 0.0 || c < 0.0 {
            return Err(format!(
                "Cauchy 'b' and 'c' must be non-negative (normal dispersion), got b = {b}, c = {c}"
            ));
        }
        let m = IorModel::Cauchy { a, b, c };
        m.validate()?;
        Ok(m)
    }

    /// Sellmeier's equation from equal-length lists of B_i and C_i (µm²), 1 to 6 terms. Validated.
    pub fn sellmeier(b: &[f64], c: &[f64]) -> Result<Self, String> {
        if b.len() != c.len() {
            return Err(format!(
                "Sellmeier 'b' and 'c' must have the same length, got {} and {}",
                b.len(),
                c.len()
            ));
        }
        if b.is_empty() || b.len() > MAX_SELLMEIER_TERMS {
            return Err(format!(
                "Sellmeier needs 1 to {MAX_SELLMEIER_TERMS} terms, got {}",
                b.len()
            ));
        }
        let mut t = SellmeierTerms {
            len: b.len(),
            b: [0.0; MAX_SELLMEIER_TERMS],
            c: [0.0; MAX_SELLMEIER_TERMS],
        };
        for i in 0..b.len() {
            if !(b[i].is_finite() && b[i] >= 0.0) {
                return Err(format!(
                    "Sellmeier b[{i}] must be a non-negative number, got {}",
                    b[i]
                ));
            }
            if !(c[i].is_finite() && c[i] >= 0.0) {
                return Err(format!(
                    "Sellmeier c[{i}] must be a non-negative number (µm²), got {}",
                    c[i]
                ));
            }
            t.b[i] = b[i];
            t.c[i] = c[i];
        }
        let m = IorModel::Sellmeier(t);
        m.validate()?;
        Ok(m)
    }

    /// The Abbe form (see [`IorModel::Abbe`]). Validated.
    pub fn from_abbe(n_d: f32, v_d: f32) -> Result<Self, String> {
        if !(n_d.is_finite() && n_d >= 1.0) {
            return Err(format!("n_d must be a number >= 1, got {n_d}"));
        }
        if !(v_d.is_finite() && v_d > 0.0) {
            return Err(format!("the Abbe number must be positive, got {v_d}"));
        }
        let m = IorModel::Abbe { n_d, v_d };
        m.validate()?;
        Ok(m)
    }

    /// glTF's `KHR_materials_dispersion`: `dispersion` = 20 / V_d with n_d = the material's
    /// `KHR_materials_ior` (spec: github.com/KhronosGroup/glTF, extensions/2.0/Khronos/
    /// KHR_materials_dispersion). 0 means no dispersion.
    pub fn from_gltf(ior: f32, dispersion: f32) -> Result<Self, String> {
        if !(dispersion.is_finite() && dispersion >= 0.0) {
            return Err(format!(
                "KHR_materials_dispersion.dispersion must be a non-negative number, got {dispersion}"
            ));
        }
        if dispersion == 0.0 {
            return Ok(IorModel::Constant(ior));
        }
        IorModel::from_abbe(ior, 20.0 / dispersion)
    }

    /// A named glass (see [`GLASS_PRESETS`]; ASCII case is ignored).
    pub fn preset(name: &str) -> Result<Self, String> {
        let Some(canonical) = GLASS_PRESETS.iter().find(|p| p.eq_ignore_ascii_case(name)) else {
            return Err(format!(
                "unknown glass preset '{name}' (valid: {})",
                GLASS_PRESETS.join(", ")
            ));
        };
        let terms = preset_terms(canonical);
        let b: Vec<f64> = terms.iter().map(|t| t.0).collect();
        let c: Vec<f64> = terms.iter().map(|t| t.1).collect();
        IorModel::sellmeier(&b, &c)
    }

    /// Checks what the constructors cannot see from single numbers: n must be finite and >= 1
    /// at every wavelength the renderer samples (360–830 nm), and no Sellmeier resonance may
    /// lie inside that range (n is infinite there).
    pub fn validate(&self) -> Result<(), String> {
        if let IorModel::Sellmeier(t) = self {
            for (i, &c) in t.c().iter().enumerate() {
                let pole_nm = (c.sqrt() * 1000.0) as f32;
                if (LAMBDA_MIN..=LAMBDA_MAX).contains(&pole_nm) {
                    return Err(format!(
                        "Sellmeier c[{i}] = {c} µm² puts a pole at {pole_nm:.1} nm, inside the \
                         rendered range {LAMBDA_MIN}–{LAMBDA_MAX} nm (C_i is a squared resonance \
                         wavelength in µm²)"
                    ));
                }
            }
        }
        // Report the worst wavelength, which tells the user which end of the model is off.
        let mut worst = (LAMBDA_MIN, f32::INFINITY);
        for l in check_wavelengths() {
            let n = self.eval(l);
            if !n.is_finite() {
                return Err(format!(
                    "the index of refraction is not finite at {l} nm (n = {n})"
                ));
            }
            if n < worst.1 {
                worst = (l, n);
            }
        }
        if worst.1 < 1.0 {
            return Err(format!(
                "the index of refraction must be >= 1 over {LAMBDA_MIN}–{LAMBDA_MAX} nm, but \
                 n({} nm) = {}",
                worst.0, worst.1
            ));
        }
        Ok(())
    }

    /// The IOR at `lambda_nm` (nanometres).
    pub fn eval(&self, lambda_nm: f32) -> f32 {
        let l_um = f64::from(lambda_nm) * 1e-3;
        let l2 = l_um * l_um;
        match *self {
            IorModel::Constant(n) => n,
            IorModel::Cauchy { a, b, c } => {
                (f64::from(a) + f64::from(b) / l2 + f64::from(c) / (l2 * l2)) as f32
            }
            IorModel::Sellmeier(t) => {
                let n2 = 1.0
                    + t.b()
                        .iter()
                        .zip(t.c())
                        .map(|(&b, &c)| b * l2 / (l2 - c))
                        .sum::<f64>();
                n2.sqrt() as f32
            }
            IorModel::Abbe { n_d, v_d } => {
                let (a, b) = abbe_to_cauchy(f64::from(n_d), f64::from(v_d));
                (a + b / l2) as f32
            }
        }
    }

    /// True when the IOR varies with wavelength (the renderer then splits the path's
    /// wavelengths at refractions).
    pub fn is_dispersive(&self) -> bool {
        match *self {
            IorModel::Constant(_) => false,
            IorModel::Cauchy { b, c, .. } => b != 0.0 || c != 0.0,
            IorModel::Sellmeier(t) => t.b().iter().zip(t.c()).any(|(&b, &c)| b != 0.0 && c != 0.0),
            IorModel::Abbe { n_d, .. } => n_d != 1.0,
        }
    }

    /// The IOR at the d line (587.56 nm), the catalogue's "n_d". Also the value a consumer that
    /// needs one scalar IOR (the BSSRDF's profile) should use.
    pub fn n_d(&self) -> f32 {
        match *self {
            IorModel::Abbe { n_d, .. } => n_d,
            _ => self.eval(LAMBDA_D_NM),
        }
    }

    /// V_d = (n_d − 1) / (n_F − n_C), computed from the model; `None` without dispersion
    /// (V_d would be infinite).
    pub fn abbe_number(&self) -> Option<f32> {
        let (nf, nc) = (
            f64::from(self.eval(LAMBDA_F_NM)),
            f64::from(self.eval(LAMBDA_C_NM)),
        );
        (nf != nc).then(|| ((f64::from(self.n_d()) - 1.0) / (nf - nc)) as f32)
    }
}

/// (A, B) of the two-term Cauchy equation (λ in µm) with n(λ_d) = n_d and Abbe number v_d.
fn abbe_to_cauchy(n_d: f64, v_d: f64) -> (f64, f64) {
    let inv2 = |nm: f32| {
        let um = f64::from(nm) * 1e-3;
        1.0 / (um * um)
    };
    let b = (n_d - 1.0) / (v_d * (inv2(LAMBDA_F_NM) - inv2(LAMBDA_C_NM)));
    (n_d - b * inv2(LAMBDA_D_NM), b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_and_cauchy() {
        let c = IorModel::cauchy(1.5, 0.01, 0.0).unwrap();
        assert!((c.eval(500.0) - (1.5 + 0.01 / 0.25)).abs() < 1e-6);
        assert!(c.is_dispersive());
        let k = IorModel::Constant(1.33);
        assert_eq!(k.eval(400.0), 1.33);
        assert!(!k.is_dispersive());
        assert_eq!(k.abbe_number(), None);
    }

    #[test]
    fn presets_are_valid_and_case_insensitive() {
        for p in GLASS_PRESETS {
            let m = IorModel::preset(p).unwrap();
            assert!(m.is_dispersive(), "{p}");
            assert_eq!(IorModel::preset(&p.to_ascii_uppercase()).unwrap(), m);
        }
        let e = IorModel::preset("unobtainium").unwrap_err();
        assert!(e.contains("valid: BK7, fused_silica"), "{e}");
    }

    #[test]
    fn bad_parameters_are_rejected() {
        let pole = IorModel::sellmeier(&[1.0], &[0.25]).unwrap_err();
        assert!(pole.contains("pole at 500.0 nm"), "{pole}");
        assert!(IorModel::sellmeier(&[], &[]).is_err());
        assert!(IorModel::sellmeier(&[1.0, 1.0], &[0.01]).is_err());
        assert!(IorModel::sellmeier(&[f64::NAN], &[0.01]).is_err());
        assert!(IorModel::sellmeier(&[-1.0], &[0.01]).is_err());
        assert!(IorModel::sellmeier(&[1.0; 7], &[0.01; 7]).is_err());
        // An IR resonance with a large B pulls n² below 1 in the visible.
        assert!(IorModel::sellmeier(&[0.1, 5.0], &[0.01, 1.0]).is_err());
        assert!(IorModel::cauchy(0.9, 0.0, 0.0).is_err());
        assert!(IorModel::cauchy(1.5, f32::NAN, 0.0).is_err());
        assert!(IorModel::from_abbe(1.5, -3.0).is_err());
        assert!(IorModel::from_abbe(1.5, 0.0).is_err());
        // V_d = 0.5 is far too dispersive: n(830 nm) = n_d - 0.757 (n_d - 1) / V_d < 1.
        assert!(IorModel::from_abbe(1.2, 0.5).is_err());
        assert!(IorModel::from_gltf(1.5, -0.1).is_err());
        assert!(IorModel::from_gltf(1.5, f32::NAN).is_err());
        assert_eq!(
            IorModel::from_gltf(1.5, 0.0).unwrap(),
            IorModel::Constant(1.5)
        );
    }
}
