//! Fresnel reflectance and Snell refraction.
//!
//! Convention: `eta` is the relative index of refraction of the interface *as seen from the
//! side the normal points to*, i.e. `n_inside / n_outside` with the normal pointing outside.
//! A negative cosine means the incident direction is on the inside, and the functions then
//! use `1 / eta` themselves.

use crate::math::{safe_sqrt, sqr};
use crate::spectrum::SampledSpectrum;
use glam::Vec3;

/// Exact unpolarised Fresnel reflectance of a dielectric interface (Born & Wolf, "Principles
/// of Optics", sec. 1.5.2, eqs. 21a/21b: the mean of the squared s- and p-amplitude ratios).
///
/// `cos_theta_i` is the cosine between the incident direction and the normal (negative when
/// the incident direction is on the inside). Returns 1 under total internal reflection and for
/// degenerate `eta` (<= 0 or not finite), never NaN.
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    if !(eta > 0.0) || !eta.is_finite() || cos_theta_i.is_nan() {
        return 1.0;
    }
    let mut cos_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    // Snell: sin_t = sin_i / eta.
    let sin2_t = (1.0 - sqr(cos_i)).max(0.0) / sqr(eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = safe_sqrt(1.0 - sin2_t);
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let f = 0.5 * (sqr(r_parl) + sqr(r_perp));
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// `fresnel_dielectric` for light arriving from outside an interface of `eta >= 1` with
/// `cos_i` in [0, 1] (no total internal reflection): the same equations with one square root and
/// one division, for the hot path of layered BSDFs (`MetallicRoughnessBsdf`, the coat).
#[inline]
pub fn fresnel_dielectric_entering(cos_i: f32, eta: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let cos_t = safe_sqrt(1.0 - (1.0 - c * c) / (eta * eta));
    // r_perp = (c - eta t) / d1, r_parl = (eta c - t) / d2, over the one division 1 / (d1 d2).
    let (d1, d2) = (c + eta * cos_t, eta * c + cos_t);
    let inv = 1.0 / (d1 * d2);
    if !inv.is_finite() {
        return 1.0;
    }
    let r_perp = (c - eta * cos_t) * d2 * inv;
    let r_parl = (eta * c - cos_t) * d1 * inv;
    (0.5 * (r_perp * r_perp + r_parl * r_parl)).clamp(0.0, 1.0)
}

/// Schlick's approximation (Schlick 1994, "An Inexpensive BRDF Model for Physically-based
/// Rendering", eq. 15) with an explicit grazing value as in the glTF 2.0 spec, Appendix B:
/// `F = f0 + (f90 - f0) (1 - |cos|)^5`.
pub fn fresnel_schlick(f0: SampledSpectrum, f90: f32, cos_theta: f32) -> SampledSpectrum {
    let w = schlick_weight(cos_theta);
    f0.map(|f| f + (f90 - f) * w)
}

/// `(1 - |cos|)^5`, clamped to [0, 1].
#[inline]
pub fn schlick_weight(cos_theta: f32) -> f32 {
    let m = (1.0 - cos_theta.abs()).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Refracts `wi` (pointing away from the surface) through the interface with normal `n`
/// (Snell's law in vector form, e.g. Glassner, "An Introduction to Ray Tracing", ch. 6:
/// `t = -wi / eta + (cos_i / eta - cos_t) n`).
///
/// `eta` is relative to the side `n` points to (see the module doc). If `wi` is on the other
/// side, the normal is flipped and `1 / eta` used. Returns the refracted direction (unit
/// length if `wi` is) and the relative IOR actually applied, `n_transmitted / n_incident`;
/// `None` on total internal reflection or degenerate input.
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    if !(eta > 0.0) || !eta.is_finite() {
        return None;
    }
    let mut cos_i = n.dot(wi);
    let mut eta = eta;
    let mut n = n;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_t = (1.0 - sqr(cos_i)).max(0.0) / sqr(eta);
    if !(sin2_t < 1.0) {
        return None;
    }
    let cos_t = safe_sqrt(1.0 - sin2_t);
    let wt = -wi / eta + (cos_i / eta - cos_t) * n;
    if !wt.is_finite() {
        return None;
    }
    Some((wt, eta))
}

/// Mirror reflection of `wo` about the (unit) normal `n`.
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The entering-only Fresnel is the general one for eta >= 1 and cosines in [0, 1].
    #[test]
    fn entering_fresnel_matches_the_general_one() {
        for eta in [1.0f32, 1.0001, 1.33, 1.5, 2.4, 4.0] {
            for k in 0..=200 {
                let c = k as f32 / 200.0;
                let (a, b) = (
                    fresnel_dielectric_entering(c, eta),
                    fresnel_dielectric(c, eta),
                );
                assert!((a - b).abs() < 2e-6, "eta {eta} cos {c}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn normal_incidence_and_brewster() {
        let f = fresnel_dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-6, "{f}");
        // Same reflectance from inside at normal incidence.
        assert!((fresnel_dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6);
        // At Brewster's angle only the s-polarised part reflects.
        let tb = 1.5f32.atan();
        let f = fresnel_dielectric(tb.cos(), 1.5);
        let cos_t = (1.0 - tb.sin().powi(2) / 2.25).sqrt();
        let rs = (tb.cos() - 1.5 * cos_t) / (tb.cos() + 1.5 * cos_t);
        assert!((f - 0.5 * rs * rs).abs() < 1e-6);
        // Total internal reflection beyond the critical angle from inside.
        let crit = (1.0f32 / 1.5).asin();
        assert_eq!(fresnel_dielectric(-(crit + 0.01).cos(), 1.5), 1.0);
        assert!(fresnel_dielectric(-(crit - 0.01).cos(), 1.5) < 1.0);
        assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0);
        assert_eq!(fresnel_dielectric(f32::NAN, 1.5), 1.0);
    }

    #[test]
    fn refract_obeys_snell_and_symmetry() {
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let (wt, etap) = refract(wi, Vec3::Z, 1.5).unwrap();
        assert_eq!(etap, 1.5);
        assert!((wt.length() - 1.0).abs() < 1e-6);
        assert!((wt.x - (-0.6 / 1.5)).abs() < 1e-6 && wt.z < 0.0);
        // Back through the interface returns the original direction.
        let (back, etap2) = refract(wt, Vec3::Z, 1.5).unwrap();
        assert!((etap2 - 1.0 / 1.5).abs() < 1e-6);
        assert!((back - wi).length() < 1e-5);
        // Fresnel is the same on both sides of a refraction pair (Stokes relations).
        let a = fresnel_dielectric(wi.z, 1.5);
        let b = fresnel_dielectric(wt.z, 1.5);
        assert!((a - b).abs() < 1e-6);
        assert!(refract(Vec3::new(0.9, 0.0, -(0.19f32).sqrt()), Vec3::Z, 1.5).is_none());
    }
}
