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

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::microfacet::TrowbridgeReitz;
use super::{BsdfSample, DielectricBsdf};
use crate::math::sqr;
use crate::spectrum::{SampledSpectrum, N_WAVELENGTHS};
use glam::{Vec2, Vec3};

/// Scalar (one wavelength) BSDF value and hero-direction pdf of a rough interface.
#[derive(Clone, Copy, Debug, Default)]
struct RoughEval {
    f: f32,
    pdf: f32,
    transmission: bool,
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
        self.eval_with_eta(wo, wi, self.hero_eta()).pdf
    }

    /// The hero wavelength's f(wo, wi) (tinted for transmission), one evaluation.
    pub fn hero_value(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_specular() {
            return 0.0;
        }
        let hero = self.eval_with_eta(wo, wi, self.hero_eta());
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
        let hero = self.eval_with_eta(wo, wi, self.hero_eta());
        if !self.is_dispersive() {
            return (
                self.spectral(hero.f, hero.transmission),
                SampledSpectrum::splat(hero.pdf),
            );
        }
        self.per_wavelength(wo, wi, hero)
    }

    /// Dispersive rough interface: every wavelength's own f and hero density at (wo, wi).
    fn per_wavelength(
        &self,
        wo: Vec3,
        wi: Vec3,
        hero: RoughEval,
    ) -> (SampledSpectrum, SampledSpectrum) {
        let mut f = SampledSpectrum::ZERO;
        let mut pdf = SampledSpectrum::ZERO;
        f[0] = hero.f;
        pdf[0] = hero.pdf;
        // Oriented to the upper hemisphere as in `eval_with_eta` (the side decides Fresnel).
        let wm = (wo + wi).normalize_or_zero();
        let wm = if wm.z < 0.0 { -wm } else { wm };
        let fr_hero = fresnel_dielectric(wo.dot(wm), self.eta[0]);
        if wo.z * wi.z > 0.0 && hero.pdf > 0.0 && fr_hero > 0.0 {
            // Reflection: the half vector, D, G and the visible-normal density do not depend
            // on the IOR; f and pdf both scale with each wavelength's Fresnel term.
            for i in 1..N_WAVELENGTHS {
                let ratio = fresnel_dielectric(wo.dot(wm), self.eta[i]) / fr_hero;
                f[i] = hero.f * ratio;
                pdf[i] = hero.pdf * ratio;
            }
            return (f, pdf);
        }
        let g = Some(self.distribution().g(wo, wi));
        for i in 1..N_WAVELENGTHS {
            let e = self.eval_with_eta_g(wo, wi, self.eta[i], g);
            f[i] = e.f;
            pdf[i] = e.pdf;
        }
        // Transmission is a property of the geometry (wo, wi on opposite sides).
        if wo.z * wi.z < 0.0 {
            f *= self.transmission_tint;
        }
        (f, pdf)
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
        let fr = fresnel_dielectric(cos_o, eta);
        if uc < fr {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            // The mirror direction is the same for every wavelength, so every slot stays
            // valid; each wavelength as the hero would have chosen this branch with its own
            // probability F(eta_i).
            let fr_all = if self.is_dispersive() {
                SampledSpectrum::from_fn(|i| fresnel_dielectric(cos_o, self.eta[i]))
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
                specular: true,
                transmission: false,
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
            if self.is_dispersive() {
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
                specular: true,
                transmission: true,
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
        let fr = fresnel_dielectric(wo.dot(wm), eta);
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
        let hero = self.eval_with_eta(wo, wi, eta);
        if !(hero.pdf > 0.0) {
            return None;
        }
        let (f, pdf_wavelengths) = if self.is_dispersive() {
            self.per_wavelength(wo, wi, hero)
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
            specular: false,
            transmission: hero.transmission,
            pdf_wavelengths,
        })
    }

    /// Walter et al. 2007 BSDF for a single relative IOR `eta` (without the tint) and the pdf of
    /// `sample_rough` run with that `eta`. Zero for the degenerate configurations (grazing
    /// directions, vanishing half vector, back-facing microfacets).
    fn eval_with_eta(&self, wo: Vec3, wi: Vec3, eta: f32) -> RoughEval {
        self.eval_with_eta_g(wo, wi, eta, None)
    }

    /// `eval_with_eta` with the masking-shadowing term G(wo, wi) given when already known (it
    /// does not depend on the IOR, so the wavelengths of a dispersive interface share it).
    fn eval_with_eta_g(&self, wo: Vec3, wi: Vec3, eta: f32, g: Option<f32>) -> RoughEval {
        let zero = RoughEval::default();
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o == 0.0
            || cos_i == 0.0
            || !wo.is_finite()
            || !wi.is_finite()
            || !(eta > 0.0)
            || !eta.is_finite()
        {
            return zero;
        }
        let reflection = cos_o * cos_i > 0.0;
        // etap = n(wi side) / n(wo side).
        let etap = if reflection {
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
        let distrib = self.distribution();
        let d = distrib.d(wm);
        let g = g.unwrap_or_else(|| distrib.g(wo, wi));
        let fr = fresnel_dielectric(dot_o, eta);
        let (f, pdf) = if reflection {
            // Walter eq. 20; pdf: visible normal, Fresnel choice, dwm/dwi = 1/(4|wo.wm|).
            let f = d * g * fr / (4.0 * (cos_o * cos_i).abs());
            let pdf = distrib.d_visible(wo, wm) * fr / (4.0 * dot_o.abs());
            (f, pdf)
        } else {
            // Walter eq. 21 in radiance form: the n_o^2 / (n_i i.h + n_o o.h)^2 factor equals
            // 1 / (etap wi.wm + wo.wm)^2, which already contains the 1/etap^2 of radiance.
            let denom = sqr(etap * dot_i + dot_o);
            let t = 1.0 - fr;
            let f = t * d * g * (dot_i * dot_o).abs() / ((cos_i * cos_o).abs() * denom);
            // Walter eq. 17: dwm/dwi = etap^2 |wi.wm| / (etap wi.wm + wo.wm)^2.
            let dwm_dwi = sqr(etap) * dot_i.abs() / denom;
            let pdf = distrib.d_visible(wo, wm) * t * dwm_dwi;
            (f, pdf)
        };
        if !(f.is_finite() && pdf.is_finite()) {
            return zero;
        }
        RoughEval {
            f,
            pdf,
            transmission: !reflection,
        }
    }
}
