//! A clear coat: a dielectric GGX reflection layer over a material (Blender's Principled Coat,
//! `KHR_materials_clearcoat`).
//!
//! The coat reflects `weight x` its lobe and lets through what it does not reflect. Two
//! layerings:
//!
//! - energy-conserving (Cycles' Principled BSDF, 4.x): the exact dielectric Fresnel of the
//!   coat's IOR (Cycles' coat is a dielectric microfacet closure; Schlick's curve reflects up to
//!   17% less at 50-70 degrees), the lobe scaled by its multiple scattering at `wo`
//!   (`energy::multiscatter_boost`, Cycles' form), and the material below scaled by
//!   `1 - weight A_c(mu_o)`, `A_c` the coat lobe's albedo, then by the coat's absorption
//!   `mix(1, tint^(1 / cos_t), weight)` with `cos_t` the cosine of the view direction refracted
//!   into the coat (the tint is the colour after one vertical pass). Scaling by the albedo at
//!   `wo` keeps the whole at most 1 for every `wo` (layer + rest <= A_c + (1 - A_c) = 1) but is
//!   not reciprocal, as in Cycles;
//! - the glTF spec's (`KHR_materials_clearcoat`) and Blender 3.x's: single scattering, Schlick's
//!   Fresnel with `f0 = ((ior - 1) / (ior + 1))^2`, `f90 = 1`; the glTF spec's scales the layer
//!   below by `1 - weight F(wo.h)` per direction pair, no tint.
//!
//! The coat has its own shading normal (`normal`, in the base's local frame): Blender's Coat
//! Normal, glTF's `clearcoatNormalTexture`, and by default the unperturbed shading normal,
//! so that a bump or normal map on the base leaves the coat smooth (as in Cycles and the glTF
//! spec). The lobe, its density, its sampling and the cosines that set how much the coat lets
//! through are taken in the coat's frame; a rotation preserves solid angle, so the densities
//! carry over unchanged.

use super::energy::{
    dielectric_fresnel_average, effective_cosine, ggx_reflection_albedo, ggx_reflection_average,
    multiscatter_boost, ReflectionAlbedo, SCHLICK_WEIGHT_AVERAGE,
};
use super::fresnel::{fresnel_dielectric_entering, reflect, schlick_weight};
use super::microfacet::TrowbridgeReitz;
use crate::math::{safe_sqrt, sqr, Frame};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

/// Coat parameters; `weight` 0 is no coat.
#[derive(Clone, Copy, Debug)]
pub struct Coat {
    pub weight: f32,
    /// GGX alpha (roughness^2).
    pub alpha: f32,
    pub ior: f32,
    /// Colour after one vertical pass through the coat.
    pub tint: SampledSpectrum,
    /// The coat's unit normal in the base's local frame (+z: the base's normal).
    pub normal: Vec3,
    /// Blender 3.x's Disney clear coat: added on top of the base without dimming it (Cycles
    /// 3.x's Principled v1, which does not conserve energy there).
    pub additive: bool,
}

impl Coat {
    pub const NONE: Coat = Coat {
        weight: 0.0,
        alpha: 0.0,
        ior: 1.5,
        tint: SampledSpectrum::ONE,
        normal: Vec3::Z,
        additive: false,
    };

    /// The frame of a coat normal that differs from the base's (None: the same, where
    /// everything is computed as is, bit for bit).
    #[inline]
    fn frame(&self) -> Option<Frame> {
        (self.normal != Vec3::Z).then(|| Frame::from_normal(self.normal))
    }

    /// The cosine of `w` (base frame) with the coat's normal.
    #[inline]
    pub fn cos(&self, w: Vec3) -> f32 {
        if self.normal == Vec3::Z {
            w.z
        } else {
            w.dot(self.normal)
        }
    }

    #[inline]
    pub fn is_present(&self) -> bool {
        self.weight > 0.0
    }

    #[inline]
    pub(super) fn weight(&self) -> f32 {
        if self.weight.is_nan() {
            0.0
        } else {
            self.weight.clamp(0.0, 1.0)
        }
    }

    #[inline]
    pub(super) fn distribution(&self) -> TrowbridgeReitz {
        TrowbridgeReitz::isotropic(self.alpha)
    }

    #[inline]
    pub(super) fn is_smooth(&self) -> bool {
        self.distribution().effectively_smooth()
    }

    /// Normal-incidence reflectance of the coat's interface.
    #[inline]
    fn f0(&self) -> f32 {
        let r = sqr((self.ior - 1.0) / (self.ior + 1.0));
        if r.is_finite() {
            r.min(1.0)
        } else {
            0.0
        }
    }

    /// Fresnel for a cosine with the microfacet normal: the exact dielectric one of the coat's
    /// IOR in the energy-conserving model (`exact`), else Schlick's.
    #[inline]
    pub(super) fn fresnel(&self, cos: f32, exact: bool) -> f32 {
        if exact {
            fresnel_dielectric_entering(cos, self.ior.max(1.0))
        } else {
            let f0 = self.f0();
            f0 + (1.0 - f0) * schlick_weight(cos)
        }
    }

    fn albedos(&self, mu: f32) -> (ReflectionAlbedo, ReflectionAlbedo) {
        if self.is_smooth() {
            let one = |b| ReflectionAlbedo { e: 1.0, b };
            (one(schlick_weight(mu)), one(SCHLICK_WEIGHT_AVERAGE))
        } else {
            (
                ggx_reflection_albedo(self.alpha, mu),
                ggx_reflection_average(self.alpha),
            )
        }
    }

    /// The energy-conserving lobe's multiple-scattering factor at `mu_o`
    /// (`energy::multiscatter_boost` with the exact Fresnel's hemispherical average).
    fn boost(&self, mu_o: f32) -> f32 {
        let (a, average) = self.albedos(mu_o);
        self.boost_with(a, average)
    }

    /// `boost` from the lobe's albedos at `mu_o` and on average.
    fn boost_with(&self, a: ReflectionAlbedo, average: ReflectionAlbedo) -> f32 {
        multiscatter_boost(dielectric_fresnel_average(self.ior), a.e, average.e)
    }

    /// The weighted coat lobe's albedo at `mu` (energy-conserving model): the exact Fresnel at
    /// the lobe's effective cosine times E, times the multiple-scattering factor.
    pub fn albedo(&self, mu: f32) -> f32 {
        let (a, average) = self.albedos(mu);
        let single = self.fresnel(effective_cosine(a), true) * a.e;
        self.weight() * (single * self.boost_with(a, average)).clamp(0.0, 1.0)
    }

    /// What reaches the layer below and comes back, as a factor on it (energy-conserving
    /// model): `(1 - weight A_c(mu_o)) mix(1, tint^(1/cos_t), weight)`.
    pub fn transmittance(&self, cos_o: f32) -> SampledSpectrum {
        if self.additive {
            return SampledSpectrum::ONE;
        }
        let w = self.weight();
        let left = (1.0 - self.albedo(cos_o)).max(0.0);
        let cos_t = safe_sqrt(1.0 - (1.0 - sqr(cos_o)) / sqr(self.ior.max(1.0)));
        let depth = if cos_t > 1e-4 { 1.0 / cos_t } else { 1e4 };
        self.tint
            .map(|t| left * (1.0 + w * (t.max(0.0).powf(depth) - 1.0)))
    }

    /// The weighted coat lobe f(wo, wi) (no cosine) for `wo`, `wi` (base frame) and their
    /// half vector `h`; `energy_conserving`: the exact Fresnel and the lobe's multiple
    /// scattering. Zero for a smooth coat and below the coat.
    pub fn eval(&self, wo: Vec3, wi: Vec3, h: Vec3, energy_conserving: bool) -> f32 {
        let cos_base = wi.z;
        // One frame for the three vectors (it is rebuilt per call, not stored in the coat).
        let frame = self.frame();
        let local = |v: Vec3| frame.as_ref().map_or(v, |f| f.to_local(v));
        let (wo, wi, h) = (local(wo), local(wi), local(h));
        if !(wo.z > 0.0 && wi.z > 0.0 && cos_base > 0.0) {
            return 0.0;
        }
        // The caller's estimator multiplies by the cosine with the base's normal; the coat's
        // lobe is projected onto its own (as each closure's in Cycles).
        let projection = if self.normal == Vec3::Z {
            1.0
        } else {
            wi.z / cos_base
        };
        let w = self.weight() * projection;
        let mut f = 0.0;
        if !self.is_smooth() {
            let distrib = self.distribution();
            let s = distrib.d(h) * distrib.g(wo, wi) / (4.0 * wo.z * wi.z);
            if s.is_finite() && s > 0.0 {
                let boost = if energy_conserving {
                    self.boost(wo.z)
                } else {
                    1.0
                };
                f = self.fresnel(wo.dot(h), energy_conserving) * s * boost;
            }
        }
        w * f
    }

    /// Density of `wi` under the coat's visible-normal sampling (0 for a smooth coat), for
    /// `wo` and the half vector `h` in the base frame.
    pub fn pdf(&self, wo: Vec3, h: Vec3) -> f32 {
        if self.is_smooth() {
            return 0.0;
        }
        let frame = self.frame();
        let local = |v: Vec3| frame.as_ref().map_or(v, |f| f.to_local(v));
        let (wo, h) = (local(wo), local(h));
        if !(wo.z > 0.0 && h.z > 0.0) {
            return 0.0;
        }
        let vdoth = wo.dot(h);
        if !(vdoth > 0.0) {
            return 0.0;
        }
        let p = self.distribution().d_visible(wo, h) / (4.0 * vdoth);
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    /// A direction (base frame) from the coat lobe: a visible normal's mirror direction (the
    /// mirror direction itself for a smooth coat); None where `wo` is below the coat.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let Some(frame) = self.frame() else {
            return Some(self.sample_local(wo, u));
        };
        let wo = frame.to_local(wo);
        (wo.z > 0.0).then(|| frame.to_world(self.sample_local(wo, u)))
    }

    fn sample_local(&self, wo: Vec3, u: Vec2) -> Vec3 {
        if self.is_smooth() {
            return Vec3::new(-wo.x, -wo.y, wo.z);
        }
        reflect(wo, self.distribution().sample_visible(wo, u))
    }
}
