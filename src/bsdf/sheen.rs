//! Sheen: the soft, retro-reflective rim of velvet and other fabrics (Blender's Principled
//! Sheen, `KHR_materials_sheen`), a layer over the whole material. Two lobes:
//!
//! - **Microfibre** (the default, what Blender users see in Cycles 4.x and later): the
//!   multiple-scattering fibre layer of Zeltner et al. 2022, fitted by a linearly transformed
//!   cosine per view angle and roughness (`fibre_sheen.rs`). The material below is dimmed by
//!   `1 - max(colour) R(mu_o)`, the layer's albedo at `wo` (energy-conserving: a white base
//!   under a sheen of colour c reflects exactly c R + (1 - c R) = 1; not reciprocal, as in
//!   Cycles). Sampled exactly by the LTC.
//! - **Charlie** (`"model": "gltf"`, the lobe `KHR_materials_sheen` specifies): the microfibre
//!   sheen of Estevez & Kulla 2017 ("Production Friendly Microfacet Sheen BRDF"),
//!
//! ```text
//! D(h)     = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi)              (fibres lying flat)
//! V        = 1 / ((1 + Lambda(mu_o) + Lambda(mu_i)) 4 mu_o mu_i)       (their shadowing)
//! sheen    = colour D V
//! ```
//!
//!   with alpha = roughness^2 and the paper's fitted Lambda (its eq. 3 and table 1: a curve
//!   L(x) = a / (1 + b x^c) + d x + e whose five constants blend between two fits by
//!   (1 - alpha)^2; Lambda(mu) = exp(L(mu)) below mu = 1/2 and exp(2 L(1/2) - L(1 - mu))
//!   above). The material below is dimmed by the extension's reciprocal
//!   `min(1 - c E(mu_o), 1 - c E(mu_i))`, with E the lobe's directional albedo (colour 1),
//!   tabulated here over (mu, roughness) by numerical integration at first use: at most 1,
//!   and up to 10% darker than 1 for rough sheens (the base is dimmed by the grazing side's
//!   larger albedo). Sampled uniformly over the hemisphere (the lobe is broad and strongest at
//!   grazing angles, where cosine-weighted sampling would be thin).
//! - **Disney** (Blender 3.x's Principled Sheen, `"model": "principled_v1"`): Burley 2012's
//!   grazing tint, `colour (1 - wi.h)^5` (not over pi), added on top of the undimmed layers
//!   below as Cycles 3.x does; the metallic part has none (`MetallicRoughnessBsdf` scales it by
//!   1 - metallic). Sampled cosine-weighted.

use super::fibre_sheen::{from_lobe_frame, to_lobe_frame, FibreLobe};
use super::fresnel::schlick_weight;
use crate::math::sampling::{
    cosine_hemisphere_pdf, sample_cosine_hemisphere, sample_uniform_hemisphere,
    uniform_hemisphere_pdf,
};
use crate::math::{INV_PI, PI};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Which sheen lobe (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SheenModel {
    /// Zeltner et al. 2022's fibre layer (Cycles' Principled Sheen).
    Microfibre,
    /// The Charlie lobe of `KHR_materials_sheen`, with the extension's reciprocal layering.
    Charlie,
    /// Blender 3.x's (the Disney BRDF's) sheen, added without dimming anything.
    Disney,
}

/// Sheen parameters; a black colour is no sheen.
#[derive(Clone, Copy, Debug)]
pub struct Sheen {
    /// Weight x tint, per wavelength.
    pub color: SampledSpectrum,
    /// The largest RGB component of weight x tint (the extension's max3(sheenColor)): what
    /// dims the layers below, the same for every wavelength.
    pub scale: f32,
    /// Perceptual roughness in [0, 1] (Blender's Sheen Roughness; the Charlie lobe's
    /// alpha = roughness^2).
    pub roughness: f32,
    pub model: SheenModel,
}

/// Smallest alpha evaluated: the lobe's exponent 1/alpha stays finite.
const MIN_ALPHA: f32 = 1e-3;

impl Sheen {
    pub const NONE: Sheen = Sheen {
        color: SampledSpectrum::ZERO,
        scale: 0.0,
        roughness: 0.5,
        model: SheenModel::Microfibre,
    };

    #[inline]
    pub fn is_present(&self) -> bool {
        self.scale > 0.0
    }

    #[inline]
    fn alpha(&self) -> f32 {
        let r = if self.roughness.is_nan() {
            0.5
        } else {
            self.roughness.clamp(0.0, 1.0)
        };
        (r * r).max(MIN_ALPHA)
    }

    /// The Charlie lobe with colour 1 (f without the cosine), `wo` and `wi` in the upper
    /// hemisphere. The fitted shadowing lets the smoothest sheens reflect a few percent more
    /// than they receive at grazing views (E up to 1.03 at roughness 0.1): the lobe is divided
    /// by max(1, E(mu_o), E(mu_i)), which keeps it reciprocal and its albedo at most 1.
    #[inline]
    fn charlie_lobe(&self, wo: Vec3, wi: Vec3) -> f32 {
        let excess = albedo(self.roughness, wo.z)
            .max(albedo(self.roughness, wi.z))
            .max(1.0);
        charlie(self.alpha(), wo, wi) / excess
    }

    #[inline]
    fn fibre_lobe(&self, cos_o: f32) -> FibreLobe {
        FibreLobe::at(self.roughness, cos_o)
    }

    /// f(wo, wi) of the sheen itself.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if !(self.is_present() && wo.z > 0.0 && wi.z > 0.0) {
            return SampledSpectrum::ZERO;
        }
        let f = match self.model {
            SheenModel::Microfibre => {
                // f cos_i = R D(wi) (fibre_sheen.rs).
                let lobe = self.fibre_lobe(wo.z);
                lobe.albedo * lobe.density(to_lobe_frame(wo, wi)) / wi.z
            }
            SheenModel::Charlie => self.charlie_lobe(wo, wi),
            SheenModel::Disney => {
                let h = (wo + wi).normalize_or_zero();
                schlick_weight(wi.dot(h).clamp(0.0, 1.0))
            }
        };
        if f.is_finite() {
            self.color * f
        } else {
            SampledSpectrum::ZERO
        }
    }

    /// The factor on everything below the sheen for the pair (`cos_o`, `cos_i`): Cycles'
    /// albedo scaling at `wo` (microfibre) or the extension's reciprocal form (Charlie).
    pub fn below(&self, cos_o: f32, cos_i: f32) -> f32 {
        if !self.is_present() {
            return 1.0;
        }
        let c = self.scale.min(1.0);
        let e = match self.model {
            SheenModel::Disney => return 1.0,
            SheenModel::Microfibre => self.fibre_lobe(cos_o).albedo.clamp(0.0, 1.0),
            SheenModel::Charlie => {
                lobe_albedo(self.roughness, cos_o).max(lobe_albedo(self.roughness, cos_i))
            }
        };
        (1.0 - c * e).max(0.0)
    }

    /// The sheen's albedo at `cos_o`, averaged over the wavelengths (its share when choosing
    /// which lobe to sample).
    pub fn albedo_estimate(&self, cos_o: f32) -> f32 {
        if !self.is_present() {
            return 0.0;
        }
        let e = match self.model {
            SheenModel::Microfibre => self.fibre_lobe(cos_o).albedo.clamp(0.0, 1.0),
            SheenModel::Charlie => lobe_albedo(self.roughness, cos_o),
            // Its albedo at wo, int (1 - wi.h)^5 cos_i dwi: 0.0003 / 0.006 / 0.024 / 0.048 /
            // 0.077 at mu = 1 / 0.7 / 0.4 / 0.2 / 0.05 (quadrature), within 35% of this fit.
            SheenModel::Disney => 0.08 * (1.0 - cos_o.clamp(0.0, 1.0)).powf(2.5),
        };
        self.scale.min(1.0) * e
    }

    /// A direction from the sheen's sampling density (`Sheen::pdf`) for the view `wo`.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Vec3 {
        match self.model {
            SheenModel::Microfibre => from_lobe_frame(wo, self.fibre_lobe(wo.z).sample(u)),
            SheenModel::Charlie => sample_uniform_hemisphere(u),
            SheenModel::Disney => sample_cosine_hemisphere(u),
        }
    }

    /// The density `Sheen::sample` draws `wi` with.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wi.z > 0.0) {
            return 0.0;
        }
        match self.model {
            SheenModel::Microfibre => self.fibre_lobe(wo.z).density(to_lobe_frame(wo, wi)),
            SheenModel::Charlie => uniform_hemisphere_pdf(),
            SheenModel::Disney => cosine_hemisphere_pdf(wi.z),
        }
    }
}

/// The Charlie lobe D V (colour 1) for `alpha`, both directions above the surface.
fn charlie(alpha: f32, wo: Vec3, wi: Vec3) -> f32 {
    let (mu_o, mu_i) = (wo.z, wi.z);
    if !(mu_o > 0.0 && mu_i > 0.0) {
        return 0.0;
    }
    let h = (wo + wi).normalize_or_zero();
    if h == Vec3::ZERO {
        return 0.0;
    }
    let sin2 = (1.0 - h.z * h.z).max(0.0);
    let inv = 1.0 / alpha;
    let d = (2.0 + inv) * sin2.powf(0.5 * inv) * (0.5 * INV_PI);
    let v = 1.0 / ((1.0 + lambda(mu_o, alpha) + lambda(mu_i, alpha)) * 4.0 * mu_o * mu_i);
    let f = d * v;
    if f.is_finite() {
        f
    } else {
        0.0
    }
}

/// Estevez & Kulla's fitted L(x) (their table 1), blended by (1 - alpha)^2.
fn fitted_l(x: f32, alpha: f32) -> f32 {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let mix = |lo: f32, hi: f32| lo + (hi - lo) * t;
    let a = mix(21.5473, 25.3245);
    let b = mix(3.82987, 3.32435);
    let c = mix(0.19823, 0.16801);
    let d = mix(-1.97760, -1.27393);
    let e = mix(-4.32054, -4.85967);
    a / (1.0 + b * x.max(0.0).powf(c)) + d * x + e
}

/// The shadowing term Lambda at cosine `mu` (the paper's eq. 3, symmetric about mu = 1/2 in
/// log space so that it is smooth there).
fn lambda(mu: f32, alpha: f32) -> f32 {
    if mu < 0.5 {
        fitted_l(mu, alpha).exp()
    } else {
        (2.0 * fitted_l(0.5, alpha) - fitted_l(1.0 - mu, alpha)).exp()
    }
}

const TABLE_MU: usize = 32;
const TABLE_ROUGHNESS: usize = 32;

/// Directional albedos over (roughness, mu) nodes (both from 0 to 1): the fitted Charlie lobe's
/// E, and that of the lobe `Sheen::lobe` evaluates (divided by max(1, E(mu_o), E(mu_i))).
struct Tables {
    charlie: Vec<f32>,
    lobe: Vec<f32>,
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        use rayon::prelude::*;
        let node = |k: usize| {
            let (ri, mi) = (k / TABLE_MU, k % TABLE_MU);
            let r = ri as f32 / (TABLE_ROUGHNESS - 1) as f32;
            let mu = (mi as f32 / (TABLE_MU - 1) as f32).max(1e-3);
            (r, mu)
        };
        let n = TABLE_ROUGHNESS * TABLE_MU;
        let charlie: Vec<f32> = (0..n)
            .into_par_iter()
            .map(|k| {
                let (r, mu) = node(k);
                integrate_albedo(alpha_of(r), mu, 64, 64, |_| 1.0)
            })
            .collect();
        let lobe = (0..n)
            .into_par_iter()
            .map(|k| {
                let (r, mu) = node(k);
                let e_o = lookup(&charlie, r, mu);
                integrate_albedo(alpha_of(r), mu, 64, 64, |mu_i| {
                    1.0 / e_o.max(lookup(&charlie, r, mu_i)).max(1.0)
                })
            })
            .collect();
        Tables { charlie, lobe }
    })
}

/// alpha for perceptual roughness `r`.
fn alpha_of(r: f32) -> f32 {
    (r * r).max(MIN_ALPHA)
}

/// int lobe(wo, wi) weight(mu_i) mu_i dwi for `alpha` at cosine `mu`, by the midpoint rule
/// with `n_mu` x `n_phi` nodes (mirror symmetry in the azimuth halves them).
fn integrate_albedo(
    alpha: f32,
    mu: f32,
    n_mu: usize,
    n_phi: usize,
    weight: impl Fn(f32) -> f32,
) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut sum = 0.0f64;
    for i in 0..n_mu {
        // Midpoints in s with mu_i = s^2 (dmu = 2 s ds): denser towards grazing, where the
        // lobe is strongest.
        let s = (i as f32 + 0.5) / n_mu as f32;
        let mu_i = s * s;
        let jac = 2.0 * s / n_mu as f32;
        let sin_i = (1.0 - mu_i * mu_i).max(0.0).sqrt();
        let mut ring = 0.0f64;
        for j in 0..n_phi {
            let phi = PI * (j as f32 + 0.5) / n_phi as f32;
            let wi = Vec3::new(sin_i * phi.cos(), sin_i * phi.sin(), mu_i);
            ring += f64::from(charlie(alpha, wo, wi));
        }
        // Both halves of the azimuth: 2 x (pi / n_phi) per node.
        sum += ring * f64::from(2.0 * PI / n_phi as f32) * f64::from(mu_i * jac * weight(mu_i));
    }
    sum as f32
}

/// Bilinear lookup of a (roughness, mu) table.
fn lookup(t: &[f32], roughness: f32, mu: f32) -> f32 {
    let r = if roughness.is_nan() {
        0.5
    } else {
        roughness.clamp(0.0, 1.0)
    } * (TABLE_ROUGHNESS - 1) as f32;
    let m = mu.clamp(0.0, 1.0) * (TABLE_MU - 1) as f32;
    let (r0, m0) = (
        (r as usize).min(TABLE_ROUGHNESS - 2),
        (m as usize).min(TABLE_MU - 2),
    );
    let (fr, fm) = (r - r0 as f32, m - m0 as f32);
    let at = |ri: usize, mi: usize| t[ri * TABLE_MU + mi];
    let lo = at(r0, m0) * (1.0 - fm) + at(r0, m0 + 1) * fm;
    let hi = at(r0 + 1, m0) * (1.0 - fm) + at(r0 + 1, m0 + 1) * fm;
    lo * (1.0 - fr) + hi * fr
}

/// The fitted Charlie lobe's directional albedo at perceptual `roughness` (up to 1.03).
pub fn albedo(roughness: f32, mu: f32) -> f32 {
    lookup(&tables().charlie, roughness, mu)
}

/// The directional albedo of the lobe `Sheen` evaluates (at most 1).
pub fn lobe_albedo(roughness: f32, mu: f32) -> f32 {
    lookup(&tables().lobe, roughness, mu).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambda_is_continuous_at_one_half() {
        for alpha in [0.01, 0.25, 1.0] {
            let (a, b) = (lambda(0.4999, alpha), lambda(0.5001, alpha));
            assert!((a - b).abs() < 1e-2 * a.max(1e-3), "{alpha}: {a} vs {b}");
        }
    }

    #[test]
    fn the_lobe_is_reciprocal() {
        let wo = Vec3::new(0.6, 0.1, 0.79).normalize();
        let wi = Vec3::new(-0.3, 0.7, 0.2).normalize();
        for alpha in [0.05, 0.3, 1.0] {
            let (a, b) = (charlie(alpha, wo, wi), charlie(alpha, wi, wo));
            assert!((a - b).abs() <= 1e-6 * a.abs().max(1.0), "{a} vs {b}");
        }
    }

    /// The table against a finer integration; E at most a few percent above 1 (the fitted
    /// shadowing's excess, which `Sheen::lobe` divides out).
    #[test]
    fn tabulated_albedo_matches_a_fine_integration() {
        for r in [0.1f32, 0.3, 0.5, 0.8, 1.0] {
            for mu in [0.05f32, 0.3, 0.6, 1.0] {
                let fine = integrate_albedo(alpha_of(r), mu, 512, 512, |_| 1.0);
                let got = albedo(r, mu);
                assert!(
                    (got - fine).abs() < 0.01 + 0.03 * fine,
                    "r {r} mu {mu}: table {got}, fine {fine}"
                );
                assert!(fine <= 1.05, "r {r} mu {mu}: albedo {fine}");
                assert!(lobe_albedo(r, mu) <= 1.0 && lobe_albedo(r, mu) <= got + 1e-6);
            }
        }
    }
}
