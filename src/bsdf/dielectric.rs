//! Dielectric interface (glass, water): smooth Fresnel reflection + refraction, or the rough
//! GGX microfacet BRDF + BTDF of Walter et al. 2007, "Microfacet Models for Refraction through
//! Rough Surfaces" (reflection eq. 20, transmission eq. 21, generalized half vector eq. 16,
//! refraction Jacobian eq. 17).
//!
//! `eta` = n_inside / n_outside; the normal (+z) points outside, so `wo.z < 0` means the path is
//! inside the object. Radiance transport: transmission carries `1 / etap^2` with
//! `etap = n(wi side) / n(wo side)`, and `transmission_tint` multiplies transmitted light.
//!
//! Dispersion: when the per-wavelength `eta` differ, directions are sampled with the hero
//! wavelength's `eta[0]` and `pdf` is the hero's density. `eval` and sampled `f` give each
//! wavelength its own BSDF value (`eta[i]` in slot i), and `pdf_wavelengths` gives the
//! density each wavelength would have had as the hero, which the path tracer's hero MIS needs
//! (Wilkie et al. 2014). On a rough interface every wavelength keeps a non-zero density, so
//! all stay alive; a smooth refraction is a different Dirac direction per wavelength, so the
//! secondaries get f = 0 and density 0 there (they terminate, and the MIS weights make the
//! hero alone an unbiased estimate).
//!
//! With `energy_compensation` a rough interface's value is divided by its single-scattering
//! albedo `E_T(mu_o, eta)` (each wavelength by its own), so that it reflects and transmits all
//! the energy it receives (`energy.rs`); densities are unchanged.

use super::energy::ggx_dielectric_albedo;
use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::microfacet::TrowbridgeReitz;
use super::{BsdfSample, DielectricBsdf, LobeFlags};
use crate::math::sqr;
use crate::spectrum::{SampledSpectrum, N_WAVELENGTHS};
use glam::{Vec2, Vec3};

/// Scalar (one wavelength) BSDF value and hero-direction pdf of a rough interface, with the
/// microfacet cosine and Fresnel term they were made of (a reflection's other wavelengths
/// only rescale them, see `per_wavelength`).
#[derive(Clone, Copy, Debug, Default)]
struct RoughEval {
    f: f32,
    pdf: f32,
    transmission: bool,
    dot_o: f32,
    fresnel: f32,
    /// The energy-compensation factor already in `f` (1 without).
    compensation: f32,
}

/// What a rough-interface evaluation at (wo, wi) shares between wavelengths: the directions,
/// reflection vs transmission (the sides of wo and wi), and the Smith masking terms, which
/// depend on wo and wi but not on the IOR: G(wo, wi) of the BSDF (Walter et al. 2007 eqs.
/// 20-21, height-correlated form of Heitz 2014 eq. 99) and G1(wo) of the visible-normal
/// density (Heitz 2014 eq. 38). Computing them once per (wo, wi) instead of once per
/// wavelength saves two of the three Smith Lambda evaluations per wavelength on a dispersive
/// interface, and one D evaluation (D_wo is written with the D already at hand).
#[derive(Clone, Copy, Debug)]
struct RoughPair {
    wo: Vec3,
    wi: Vec3,
    reflection: bool,
    g: f32,
    g1_o: f32,
}

impl DielectricBsdf {
    #[inline]
    fn distribution(&self) -> TrowbridgeReitz {
        TrowbridgeReitz::isotropic(self.alpha)
    }

    /// The wavelength-dependent IOR of the hero wavelength, which decides directions.
    #[inline]
    pub fn hero_eta(&self) -> f32 {
        self.eta[0]
    }

    /// True when the per-wavelength IORs differ (dispersive glass).
    #[inline]
    pub fn is_dispersive(&self) -> bool {
        let e0 = self.eta[0];
        self.eta.0.iter().any(|&e| e != e0)
    }

    /// Dirac interface: smooth (alpha < 1e-3), or index-matched (eta == 1, where Walter's
    /// BTDF degenerates to a delta even for a rough surface).
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.distribution().effectively_smooth() || self.hero_eta() == 1.0
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        self.eval_pdf(wo, wi).0
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_specular() {
            return 0.0;
        }
        self.rough_pair(wo, wi)
            .map_or(0.0, |p| self.eval_at(&p, 0).pdf)
    }

    /// The hero wavelength's f(wo, wi) (tinted for transmission), one evaluation.
    pub fn hero_value(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_specular() {
            return 0.0;
        }
        let Some(pair) = self.rough_pair(wo, wi) else {
            return 0.0;
        };
        let hero = self.eval_at(&pair, 0);
        if hero.transmission {
            hero.f * self.transmission_tint[0]
        } else {
            hero.f
        }
    }

    /// `(eval(wo, wi), pdf(wo, wi))` in one pass.
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (SampledSpectrum, f32) {
        let (f, pdf) = self.eval_pdf_wavelengths(wo, wi);
        (f, pdf[0])
    }

    /// Each wavelength's BSDF value and the density each would have given `wi` as the hero.
    pub fn eval_pdf_wavelengths(&self, wo: Vec3, wi: Vec3) -> (SampledSpectrum, SampledSpectrum) {
        if self.is_specular() {
            return (SampledSpectrum::ZERO, SampledSpectrum::ZERO);
        }
        let Some(pair) = self.rough_pair(wo, wi) else {
            return (SampledSpectrum::ZERO, SampledSpectrum::ZERO);
        };
        let hero = self.eval_at(&pair, 0);
        if !self.varies_per_wavelength() {
            return (
                self.spectral(hero.f, hero.transmission),
                SampledSpectrum::splat(hero.pdf),
            );
        }
        self.per_wavelength(&pair, hero)
    }

    /// Dispersive rough interface: every wavelength's own f and hero density at (wo, wi), given
    /// the hero's evaluation.
    fn per_wavelength(
        &self,
        pair: &RoughPair,
        hero: RoughEval,
    ) -> (SampledSpectrum, SampledSpectrum) {
        let mut f = SampledSpectrum::ZERO;
        let mut pdf = SampledSpectrum::ZERO;
        f[0] = hero.f;
        pdf[0] = hero.pdf;
        if pair.reflection && hero.pdf > 0.0 && hero.fresnel > 0.0 {
            // Reflection: the half vector, D, G and the visible-normal density do not depend
            // on the IOR; f and pdf both scale with each wavelength's Fresnel term.
            for i in 1..N_WAVELENGTHS {
                let ratio = self.fresnel(hero.dot_o, i) / hero.fresnel;
                let compensation = self.compensation(pair.wo.z, self.eta[i]) / hero.compensation;
                f[i] = hero.f * ratio * compensation;
                pdf[i] = hero.pdf * ratio;
            }
            return (f, pdf);
        }
        for i in 1..N_WAVELENGTHS {
            let e = self.eval_at(pair, i);
            f[i] = e.f;
            pdf[i] = e.pdf;
        }
        // Transmission is a property of the geometry (wo, wi on opposite sides).
        if !pair.reflection {
            f *= self.transmission_tint;
        }
        (f, pdf)
    }

    /// The Fresnel reflectance of wavelength `k` that splits reflection from refraction: the
    /// plain interface's, or mixed with the thin film's by its weight; 0 for a Refraction BSDF
    /// (`refraction_only`).
    #[inline]
    fn fresnel(&self, cos: f32, k: usize) -> f32 {
        if self.refraction_only {
            return 0.0;
        }
        let plain = fresnel_dielectric(cos, self.eta[k]);
        match &self.iridescence {
            Some(i) if i.weight > 0.0 => {
                let film = i.film.reflectance(cos, self.eta[k], i.lambda[k]);
                plain + i.weight.min(1.0) * (film - plain)
            }
            _ => plain,
        }
    }

    /// Values or densities differ between the wavelengths: dispersion, or a thin film.
    #[inline]
    pub fn varies_per_wavelength(&self) -> bool {
        self.is_dispersive() || self.iridescence.is_some_and(|i| i.weight > 0.0)
    }

    /// `n(other side) / n(wo side)` per wavelength, for `wo` with cosine `cos_o`.
    #[inline]
    fn oriented_eta(&self, cos_o: f32) -> SampledSpectrum {
        if cos_o > 0.0 {
            self.eta
        } else {
            self.eta.map(|e| 1.0 / e)
        }
    }

    /// The factor restoring the energy a rough interface loses to single scattering,
    /// `1 / E_T(mu_o, eta)` (`energy.rs`); 1 for smooth interfaces and Refraction BSDFs.
    #[inline]
    fn compensation(&self, cos_o: f32, eta: f32) -> f32 {
        if !self.energy_compensation || self.refraction_only || self.is_specular() {
            return 1.0;
        }
        let e = ggx_dielectric_albedo(self.alpha, cos_o, eta);
        if e > 1e-3 {
            1.0 / e
        } else {
            1.0
        }
    }

    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if self.is_specular() {
            self.sample_smooth(wo, uc)
        } else {
            self.sample_rough(wo, uc, u)
        }
    }

    #[inline]
    fn spectral(&self, f: f32, transmission: bool) -> SampledSpectrum {
        if transmission {
            self.transmission_tint * f
        } else {
            SampledSpectrum::splat(f)
        }
    }

    /// Smooth interface: reflect with probability F(cos_o), else refract (Snell). The pdf is the
    /// discrete probability of the chosen branch; f holds (branch albedo) / |cos_i|.
    fn sample_smooth(&self, wo: Vec3, uc: f32) -> Option<BsdfSample> {
        let cos_o = wo.z;
        if cos_o == 0.0 || !wo.is_finite() {
            return None;
        }
        let eta = self.hero_eta();
        let fr = self.fresnel(cos_o, 0);
        if uc < fr {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            // The mirror direction is the same for every wavelength, so every slot stays
            // valid; each wavelength as the hero would have chosen this branch with its own
            // probability F(eta_i).
            let fr_all = if self.varies_per_wavelength() {
                SampledSpectrum::from_fn(|i| self.fresnel(cos_o, i))
            } else {
                SampledSpectrum::splat(fr)
            };
            let f = fr_all / cos_o.abs();
            if !f.is_finite() {
                return None;
            }
            Some(BsdfSample {
                wi,
                f,
                pdf: fr,
                flags: LobeFlags::sample(false, true),
                eta: SampledSpectrum::ONE,
                pdf_wavelengths: fr_all,
            })
        } else {
            let (wi, etap) = refract(wo, Vec3::Z, eta)?;
            let t = 1.0 - fr;
            let cos_i = wi.z.abs();
            if !(t > 0.0) || !(cos_i > 0.0) {
                return None;
            }
            let mut f = self.transmission_tint * (t / (cos_i * sqr(etap)));
            if !f.is_finite() {
                return None;
            }
            let mut pdf_wavelengths = SampledSpectrum::splat(t);
            if !self.is_dispersive() && self.varies_per_wavelength() {
                // A thin film: one direction for all, each wavelength transmits its own 1 - R.
                let t_all = SampledSpectrum::from_fn(|i| 1.0 - self.fresnel(cos_o, i));
                f = self.transmission_tint * t_all / (cos_i * sqr(etap));
                pdf_wavelengths = t_all;
            } else if self.is_dispersive() {
                // Each other wavelength refracts into its own Dirac direction: along `wi` its
                // BSDF and its density are both zero.
                for i in 1..N_WAVELENGTHS {
                    f[i] = 0.0;
                    pdf_wavelengths[i] = 0.0;
                }
            }
            Some(BsdfSample {
                wi,
                f,
                pdf: t,
                flags: LobeFlags::sample(true, true),
                eta: self.oriented_eta(cos_o),
                pdf_wavelengths,
            })
        }
    }

    /// Rough interface: a visible normal from D_wo, then reflection with probability F(wo.wm)
    /// or refraction through the microfacet.
    fn sample_rough(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        let eta = self.hero_eta();
        let wm = self.distribution().sample_visible(wo, u);
        let fr = self.fresnel(wo.dot(wm), 0);
        let wi = if uc < fr {
            let wi = reflect(wo, wm);
            if !(wi.z * wo.z > 0.0) {
                return None;
            }
            wi
        } else {
            let (wi, _) = refract(wo, wm, eta)?;
            if !(wi.z * wo.z < 0.0) {
                return None;
            }
            wi
        };
        // Re-derive f and pdf from (wo, wi) so that they agree exactly with eval/pdf (MIS).
        let pair = self.rough_pair(wo, wi)?;
        let hero = self.eval_at(&pair, 0);
        if !(hero.pdf > 0.0) {
            return None;
        }
        let (f, pdf_wavelengths) = if self.varies_per_wavelength() {
            self.per_wavelength(&pair, hero)
        } else {
            (
                self.spectral(hero.f, hero.transmission),
                SampledSpectrum::splat(hero.pdf),
            )
        };
        Some(BsdfSample {
            wi,
            f,
            pdf: hero.pdf,
            flags: LobeFlags::sample(hero.transmission, false),
            eta: if hero.transmission {
                self.oriented_eta(wo.z)
            } else {
                SampledSpectrum::ONE
            },
            pdf_wavelengths,
        })
    }

    /// The IOR-independent part of a rough evaluation at (wo, wi); None for grazing or
    /// non-finite directions, where the BSDF and its density are zero.
    fn rough_pair(&self, wo: Vec3, wi: Vec3) -> Option<RoughPair> {
        if wo.z == 0.0 || wi.z == 0.0 || !wo.is_finite() || !wi.is_finite() {
            return None;
        }
        let distrib = self.distribution();
        let (lambda_o, lambda_i) = (distrib.lambda(wo), distrib.lambda(wi));
        Some(RoughPair {
            wo,
            wi,
            reflection: wo.z * wi.z > 0.0,
            // G = 1 / (1 + Lambda(wo) + Lambda(wi)), G1(wo) = 1 / (1 + Lambda(wo)): the same
            // as `TrowbridgeReitz::g` and `g1` (Lambda is even in w, so no mirroring needed).
            g: 1.0 / (1.0 + lambda_o + lambda_i),
            g1_o: 1.0 / (1.0 + lambda_o),
        })
    }

    /// Walter et al. 2007 BSDF for wavelength `k` alone (its IOR `eta[k]`, its thin-film
    /// reflectance; without the tint) and the pdf of `sample_rough` run with `k` as the hero.
    /// Zero for the degenerate configurations (vanishing half vector, back-facing microfacets).
    fn eval_at(&self, pair: &RoughPair, k: usize) -> RoughEval {
        let eta = self.eta[k];
        let zero = RoughEval::default();
        if !(eta > 0.0) || !eta.is_finite() {
            return zero;
        }
        let (wo, wi) = (pair.wo, pair.wi);
        let (cos_o, cos_i) = (wo.z, wi.z);
        // etap = n(wi side) / n(wo side).
        let etap = if pair.reflection {
            1.0
        } else if cos_o > 0.0 {
            eta
        } else {
            1.0 / eta
        };
        // Generalized half vector (Walter eq. 16), oriented to the upper hemisphere.
        let wm = wi * etap + wo;
        if !(wm.length_squared() > 1e-12) || !wm.is_finite() {
            return zero;
        }
        let mut wm = wm.normalize();
        if wm.z < 0.0 {
            wm = -wm;
        }
        let (dot_o, dot_i) = (wo.dot(wm), wi.dot(wm));
        // Each direction must see the microfacet from its own side of the macro-surface.
        if !(dot_o * cos_o > 0.0 && dot_i * cos_i > 0.0) {
            return zero;
        }
        let d = self.distribution().d(wm);
        let fr = self.fresnel(dot_o, k);
        // Visible-normal density D_wo(wm) = G1(wo) |wo.wm| D(wm) / |cos_o| (Heitz 2014 eq. 38;
        // |wo.wm| since wo.wm has the sign of cos_o here), as `TrowbridgeReitz::d_visible`.
        let d_visible = pair.g1_o * dot_o.abs() * d / cos_o.abs();
        let (f, pdf) = if pair.reflection {
            // Walter eq. 20; pdf: visible normal, Fresnel choice, dwm/dwi = 1/(4|wo.wm|).
            let f = d * pair.g * fr / (4.0 * (cos_o * cos_i).abs());
            let pdf = d_visible * fr / (4.0 * dot_o.abs());
            (f, pdf)
        } else {
            // Walter eq. 21 in radiance form: the n_o^2 / (n_i i.h + n_o o.h)^2 factor equals
            // 1 / (etap wi.wm + wo.wm)^2, which already contains the 1/etap^2 of radiance.
            let denom = sqr(etap * dot_i + dot_o);
            let t = 1.0 - fr;
            let f = t * d * pair.g * (dot_i * dot_o).abs() / ((cos_i * cos_o).abs() * denom);
            // Walter eq. 17: dwm/dwi = etap^2 |wi.wm| / (etap wi.wm + wo.wm)^2.
            let dwm_dwi = sqr(etap) * dot_i.abs() / denom;
            let pdf = d_visible * t * dwm_dwi;
            (f, pdf)
        };
        let compensation = self.compensation(cos_o, eta);
        let f = f * compensation;
        if !(f.is_finite() && pdf.is_finite()) {
            return zero;
        }
        RoughEval {
            f,
            pdf,
            transmission: !pair.reflection,
            dot_o,
            fresnel: fr,
            compensation,
        }
    }
}
