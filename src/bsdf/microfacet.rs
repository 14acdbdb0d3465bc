//! Trowbridge-Reitz (GGX) microfacet distribution with the height-correlated Smith masking
//! function and visible-normal sampling.
//!
//! References:
//! - Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces" (GGX D, eq. 33).
//! - Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs":
//!   anisotropic D (eq. 85), Lambda (eq. 86), G1 = 1/(1+Lambda) (eq. 43), height-correlated
//!   G2 = 1/(1+Lambda(wo)+Lambda(wi)) (eq. 99), visible normals D_wo (eq. 38).
//! - Dupuy & Benyoub 2023, "Sampling Visible GGX Normals with Spherical Caps" (listing 3):
//!   visible-normal sampling, exact for the density D_wo.
//!
//! Microfacet normals `wm` always lie in the upper hemisphere (z > 0); functions taking a
//! direction `w` that may be below the surface use its mirror `-w` (the distribution is
//! symmetric), which is what a dielectric seen from inside needs.

use crate::math::{safe_sqrt, sqr, PI};
use glam::{Vec2, Vec3};

/// Below this alpha the lobe is treated as a perfect mirror/refractor (exact Dirac path): the
/// GGX density would otherwise be too peaked for f32 and for any light-sampling to matter.
pub const SMOOTH_ALPHA: f32 = 1e-3;
/// Alphas are stored clamped to at least this, so `d()` stays finite even when called on an
/// effectively smooth distribution.
const MIN_ALPHA: f32 = 1e-4;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrowbridgeReitz {
    pub alpha_x: f32,
    pub alpha_y: f32,
}

impl TrowbridgeReitz {
    /// Anisotropic distribution; alpha along the local x (tangent) and y (bitangent) axes.
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        // f32::max ignores NaN, so a NaN alpha becomes the minimum (a smooth surface).
        TrowbridgeReitz {
            alpha_x: alpha_x.max(MIN_ALPHA),
            alpha_y: alpha_y.max(MIN_ALPHA),
        }
    }

    pub fn isotropic(alpha: f32) -> Self {
        Self::new(alpha, alpha)
    }

    /// True when the lobe should be handled as a Dirac delta (alpha < `SMOOTH_ALPHA`).
    #[inline]
    pub fn effectively_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// Normal distribution D(wm), a density per unit solid angle of `wm` normalised
    /// so that the integral of D(wm) cos(theta_m) over the hemisphere is 1 (Heitz 2014, eq. 85,
    /// written in the stretched form 1 / (pi ax ay ((x/ax)^2 + (y/ay)^2 + z^2)^2) for unit wm).
    #[inline]
    pub fn d(&self, wm: Vec3) -> f32 {
        if !(wm.z > 0.0) {
            return 0.0;
        }
        let t = sqr(wm.x / self.alpha_x) + sqr(wm.y / self.alpha_y) + sqr(wm.z);
        let d = 1.0 / (PI * self.alpha_x * self.alpha_y * sqr(t));
        if d.is_finite() {
            d
        } else {
            0.0
        }
    }

    /// Smith Lambda(w) for GGX (Heitz 2014, eq. 86): (-1 + sqrt(1 + alpha(phi)^2 tan^2)) / 2,
    /// evaluated as x / (2 (1 + sqrt(1 + x))) with x = alpha^2 tan^2 to avoid cancellation.
    /// Infinite at grazing (w.z == 0). Symmetric in w -> -w.
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z2 = sqr(w.z);
        let x = (sqr(self.alpha_x * w.x) + sqr(self.alpha_y * w.y)) / z2;
        if !x.is_finite() {
            return f32::INFINITY;
        }
        x / (2.0 * (1.0 + (1.0 + x).sqrt()))
    }

    /// Smith masking G1(w) = 1 / (1 + Lambda(w)) (Heitz 2014, eq. 43).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2 (Heitz 2014, eq. 99).
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of visible normals seen from `w` (Heitz 2014, eq. 38):
    /// D_w(wm) = G1(w) max(0, w.wm) D(wm) / |cos theta_w|, with `w` mirrored to the upper
    /// hemisphere when below it. Integrates to 1 over `wm`; it is the density (per solid angle
    /// of `wm`) of `sample_visible`.
    #[inline]
    pub fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let w = if w.z < 0.0 { -w } else { w };
        if !(w.z > 0.0) {
            return 0.0;
        }
        let dot = w.dot(wm);
        if !(dot > 0.0) {
            return 0.0;
        }
        let p = self.g1(w) * dot * self.d(wm) / w.z;
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    /// Samples a microfacet normal visible from `w` with density `d_visible(w, wm)`
    /// (Dupuy & Benyoub 2023, listing 3: uniform spherical cap in the stretched configuration,
    /// where the visible normals of the unit hemisphere are sampled exactly, then unstretched).
    /// `w` below the surface is mirrored as in `d_visible`. The result is unit, z >= 0.
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        // Stretch to the alpha = 1 configuration.
        let wh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize_or(Vec3::Z);
        // Uniform direction on the spherical cap z >= -wh.z.
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wh.z) - wh.z;
        let sin_theta = safe_sqrt(1.0 - z * z);
        let c = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), z);
        // Halfway vector between the cap point and wh is the (stretched) visible normal.
        let h = c + wh;
        // Unstretch; the normal transforms with the inverse transpose (scale by alpha).
        let wm = Vec3::new(self.alpha_x * h.x, self.alpha_y * h.y, h.z.max(0.0));
        wm.normalize_or(Vec3::Z)
    }

    /// Density of the microfacet slopes: a normal wm = (-s.x, -s.y, 1) / |.| has slope `s`,
    /// and P22(s) = D(wm) cos^4(theta_m) = 1 / (pi ax ay (1 + (s.x/ax)^2 + (s.y/ay)^2)^2)
    /// per unit slope area (Heitz 2014, section 5.2 for the stretched form).
    #[inline]
    pub fn slope_pdf(&self, s: Vec2) -> f32 {
        let t = 1.0 + sqr(s.x / self.alpha_x) + sqr(s.y / self.alpha_y);
        let p = 1.0 / (PI * self.alpha_x * self.alpha_y * sqr(t));
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    /// Samples a slope with density `slope_pdf`: of alpha 1, |s|^2 = u / (1 - u) (the
    /// inverse of its radial CDF |s|^2 / (1 + |s|^2)) at a uniform azimuth, then stretched
    /// by the alphas.
    pub fn sample_slope(&self, u: Vec2) -> Vec2 {
        let u0 = u.x.min(0.999_999);
        let radius = (u0 / (1.0 - u0)).sqrt();
        let (sin, cos) = (2.0 * PI * u.y).sin_cos();
        Vec2::new(self.alpha_x * radius * cos, self.alpha_y * radius * sin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Integral of D(wm) cos over the hemisphere == 1 (projected-area normalisation) and of
    /// D_w over the hemisphere == 1, by midpoint quadrature in (cos theta, phi).
    #[test]
    fn distributions_are_normalised() {
        for &(ax, ay) in &[(0.3f32, 0.3f32), (0.6, 0.2), (1.0, 1.0)] {
            let m = TrowbridgeReitz::new(ax, ay);
            let w = Vec3::new(0.5, -0.3, 0.4).normalize();
            let (nt, np) = (2000, 400);
            let (mut sd, mut sv) = (0.0f64, 0.0f64);
            for i in 0..nt {
                let ct = (i as f32 + 0.5) / nt as f32;
                let st = (1.0 - ct * ct).sqrt();
                for j in 0..np {
                    let ph = 2.0 * PI * (j as f32 + 0.5) / np as f32;
                    let wm = Vec3::new(st * ph.cos(), st * ph.sin(), ct);
                    let da = (1.0 / nt as f64) * (2.0 * PI as f64 / np as f64);
                    sd += (m.d(wm) * ct) as f64 * da;
                    sv += m.d_visible(w, wm) as f64 * da;
                }
            }
            assert!((sd - 1.0).abs() < 2e-3, "D norm {sd}");
            assert!((sv - 1.0).abs() < 2e-3, "D_w norm {sv}");
        }
    }

    /// The slope density is D cos^4 of the normal of that slope, and `sample_slope` draws
    /// it: the fraction of samples within slope radius rho of an isotropic lobe against the
    /// radial CDF rho^2 / (alpha^2 + rho^2).
    #[test]
    fn slope_density_is_d_cos4_and_sample_slope_draws_it() {
        let m = TrowbridgeReitz::new(0.3, 0.12);
        for s in [Vec2::ZERO, Vec2::new(0.2, -0.1), Vec2::new(-1.5, 0.7)] {
            let wm = Vec3::new(-s.x, -s.y, 1.0).normalize();
            let expected = m.d(wm) * wm.z.powi(4);
            assert!((m.slope_pdf(s) / expected - 1.0).abs() < 1e-4, "{s}");
        }
        let m = TrowbridgeReitz::isotropic(0.2);
        let n = 100_000;
        let mut within = [0u32; 3];
        let radii = [0.1f32, 0.2, 0.6];
        for i in 0..n {
            // A (0,2)-sequence's first two dimensions: stratified enough for a CDF check.
            let u = Vec2::new(
                (i as f32 + 0.5) / n as f32,
                ((i * 7919) % n) as f32 / n as f32,
            );
            let s = m.sample_slope(u);
            for (k, rho) in radii.iter().enumerate() {
                within[k] += (s.length() < *rho) as u32;
            }
        }
        for (k, rho) in radii.iter().enumerate() {
            let cdf = rho * rho / (0.04 + rho * rho);
            let got = within[k] as f32 / n as f32;
            assert!((got - cdf).abs() < 2e-3, "rho {rho}: {got} against {cdf}");
        }
    }

    #[test]
    fn degenerate_inputs_are_finite() {
        let m = TrowbridgeReitz::isotropic(0.0);
        assert!(m.effectively_smooth());
        assert!(m.d(Vec3::Z).is_finite());
        assert_eq!(m.g1(Vec3::X), 0.0);
        assert_eq!(m.d_visible(Vec3::X, Vec3::Z), 0.0);
        let wm = m.sample_visible(Vec3::X, Vec2::new(0.3, 0.99));
        assert!(wm.is_finite() && wm.z >= 0.0);
        let m = TrowbridgeReitz::isotropic(f32::NAN);
        assert!(m.lambda(Vec3::new(0.6, 0.0, 0.8)).is_finite());
    }
}
