//! Photon beam diffusion (PBD) profile, tabulated over single-scattering albedo and optical
//! radius.
//!
//! References:
//! * Habel, Christensen, Jarosz 2013, "Photon Beam Diffusion: A Hybrid Monte Carlo Method for
//!   Subsurface Scattering" (PBD): the incident beam below the surface is a continuum of
//!   point sources at depths z_r with density proportional to sigma_t' exp(-sigma_t' z_r); the
//!   radial exitance is the integral over depth of one dipole per source, estimated by
//!   quadrature with samples distributed like the sources (eq. 10 and section 4).
//! * d'Eon 2014, "A Hitchhiker's Guide to Multiple Scattering" / d'Eon & Irving 2011, "A
//!   Quantized-Diffusion Model for Rendering Translucent Materials": the Grosjean diffusion
//!   coefficient D = (2 sigma_a + sigma_t') / (3 sigma_t'^2), the extrapolated boundary
//!   z_e = -2 D (1 + 3 Fm2) / (1 - 2 Fm1) from the Fresnel moments of the internal
//!   reflectance, and the exitance as the combination C_phi * phi + C_E * E of fluence and
//!   flux with C_phi = (1 - 2 Fm1) / 4 and C_E = (1 - 3 Fm2) / 2.
//! * Jensen et al. 2001, "A Practical Model for Subsurface Light Transport", eq. 5 (dipole),
//!   and section 2.2 (single scattering with the refracted outgoing path).
//! * The table layout (100 albedos x 64 radii, radii growing geometrically, rho_eff per albedo,
//!   Catmull-Rom in both dimensions) is the one described in Pharr, Jakob, Humphreys,
//!   "Physically Based Rendering" 3rd ed., section 15.5; this is an independent implementation.
//!
//! Everything is computed in optical units (sigma_t = 1); the runtime scales radii by 1 / sigma_t
//! and the profile by sigma_t^2. The table is built with g = 0: anisotropy enters through the
//! reduced coefficients (similarity theory, sigma_s' = sigma_s (1 - g)).

use crate::bsdf::fresnel_dielectric;
use crate::math::catmull_rom::{
    catmull_rom_weights, catmull_rom_weights_in, integrate_catmull_rom,
};

pub const N_ALBEDO: usize = 100;
pub const N_RADIUS: usize = 64;
/// Ratio of consecutive optical radii of the table (after 0 and 2.5e-3).
const RADIUS_GROWTH: f32 = 1.2;
/// Fraction of the profile's integral inside the probe radius r_max.
pub const R_MAX_QUANTILE: f32 = 0.999;
/// Quadrature points per depth integral (both the multiple- and the single-scattering term).
const N_DEPTH: usize = 100;

/// Fresnel moment  Fm_k(eta) = \int_0^1 F(mu) mu^k dmu  of the reflectance seen from *inside* a
/// medium of relative index `eta` (the diffusion boundary condition), by midpoint quadrature of
/// the exact Fresnel formula.
pub fn fresnel_moment_internal(eta: f32, k: i32) -> f64 {
    fresnel_moment(|mu| fresnel_dielectric(-mu, eta), k)
}

/// The same moment for light arriving from *outside* (normalises the exit lobe Sw).
pub fn fresnel_moment_external(eta: f32, k: i32) -> f64 {
    fresnel_moment(|mu| fresnel_dielectric(mu, eta), k)
}

fn fresnel_moment(fr: impl Fn(f32) -> f32, k: i32) -> f64 {
    const N: usize = 4096;
    let mut sum = 0.0f64;
    for i in 0..N {
        let mu = (i as f64 + 0.5) / N as f64;
        sum += fr(mu as f32) as f64 * mu.powi(k);
    }
    sum / N as f64
}

/// Boundary constants of the diffusion model for relative index `eta`.
#[derive(Clone, Copy, Debug)]
pub struct Boundary {
    pub eta: f32,
    fm1: f64,
    fm2: f64,
}

impl Boundary {
    pub fn new(eta: f32) -> Self {
        Boundary {
            eta,
            fm1: fresnel_moment_internal(eta, 1),
            fm2: fresnel_moment_internal(eta, 2),
        }
    }
}

/// Multiple-scattering radial exitance (per unit area, per unit incident flux) at distance `r`
/// from the beam, by PBD: the sum over source depths of dipoles (Habel et al. 2013, eq. 10 with
/// exponential depth samples; the dipole of d'Eon & Irving 2011, eqs. 4-5 and the flux term).
pub fn pbd_multiple(sigma_s: f64, sigma_a: f64, b: &Boundary, r: f64) -> f64 {
    let sigma_t = sigma_a + sigma_s;
    if !(sigma_t > 0.0) {
        return 0.0;
    }
    let rho = sigma_s / sigma_t;
    // Grosjean's diffusion coefficient and the effective transport coefficient.
    let d = (2.0 * sigma_a + sigma_t) / (3.0 * sigma_t * sigma_t);
    let sigma_tr = (sigma_a / d).max(0.0).sqrt();
    let ze = -2.0 * d * (1.0 + 3.0 * b.fm2) / (1.0 - 2.0 * b.fm1);
    let c_phi = 0.25 * (1.0 - 2.0 * b.fm1);
    let c_e = 0.5 * (1.0 - 3.0 * b.fm2);
    let mut sum = 0.0;
    for i in 0..N_DEPTH {
        // Real source depth distributed like the beam's first collisions, sigma_t e^{-sigma_t z}.
        let zr = -(1.0 - (i as f64 + 0.5) / N_DEPTH as f64).ln() / sigma_t;
        // Virtual source mirrored about the extrapolated boundary z = ze.
        let zv = -zr + 2.0 * ze;
        let dr = (r * r + zr * zr).sqrt();
        let dv = (r * r + zv * zv).sqrt();
        let er = (-sigma_tr * dr).exp();
        let ev = (-sigma_tr * dv).exp();
        // Fluence and normal flux (Fick's law) of the dipole at the surface.
        let phi = (er / dr - ev / dv) / (4.0 * std::f64::consts::PI * d);
        let flux = (zr * (1.0 + sigma_tr * dr) * er / (dr * dr * dr)
            - zv * (1.0 + sigma_tr * dv) * ev / (dv * dv * dv))
            / (4.0 * std::f64::consts::PI);
        let exitance = c_phi * phi + c_e * flux;
        // Habel et al. 2013, section 4.2: removes the double counting of light that the
        // single-scattering term already carries near the beam (kappa), with the source strength
        // rho (first scattering) and one more rho for the PBD normalisation used with
        // extended sources.
        let kappa = 1.0 - (-2.0 * sigma_t * (dr + zr)).exp();
        sum += kappa * rho * rho * exitance;
    }
    sum / N_DEPTH as f64
}

/// Single-scattering radial exitance at distance `r` (Jensen et al. 2001, section 2.2; the
/// refracted exit path parameterised by its depth t as in Habel et al. 2013, section 4.1).
/// Isotropic phase function (the table uses reduced coefficients).
pub fn pbd_single(sigma_s: f64, sigma_a: f64, b: &Boundary, r: f64) -> f64 {
    let sigma_t = sigma_a + sigma_s;
    if !(sigma_t > 0.0) {
        return 0.0;
    }
    let rho = sigma_s / sigma_t;
    let eta = b.eta as f64;
    // Minimum depth for which the straight path to the exit point is not totally reflected.
    let t_crit = r * (eta * eta - 1.0).max(0.0).sqrt();
    let phase = 0.25 * std::f64::consts::FRAC_1_PI;
    let mut sum = 0.0;
    for i in 0..N_DEPTH {
        let ti = t_crit - (1.0 - (i as f64 + 0.5) / N_DEPTH as f64).ln() / sigma_t;
        let dist = (r * r + ti * ti).sqrt();
        let cos_o = ti / dist;
        // Light leaves through the boundary from inside: internal Fresnel transmittance.
        let transmit = 1.0 - fresnel_dielectric(-cos_o as f32, b.eta) as f64;
        sum += rho * (-sigma_t * (dist + t_crit)).exp() / (dist * dist) * phase * transmit * cos_o;
    }
    sum / N_DEPTH as f64
}

/// The tabulated profile for one boundary (relative index eta).
#[derive(Clone, Debug)]
pub struct BssrdfTable {
    /// Single-scattering albedos rho = sigma_s / sigma_t (denser near 1, where the profile
    /// changes fastest).
    pub albedos: Vec<f32>,
    /// Optical radii (units of 1 / sigma_t): 0, then geometric growth by 1.2 from 2.5e-3.
    pub radii: Vec<f32>,
    /// 2 pi r (multiple + single scattering) at (albedo i, radius j), index i * N_RADIUS + j.
    pub profile: Vec<f32>,
    /// Running integral of `profile` over r per albedo (for sampling).
    pub profile_cdf: Vec<f32>,
    /// Effective albedo rho_eff (total diffuse reflectance) per albedo: the integral of the
    /// profile row.
    pub rho_eff: Vec<f32>,
    /// Optical radius holding 99.9% of the row's integral (the probe radius), per albedo.
    pub r_max: Vec<f32>,
    pub eta: f32,
}

impl BssrdfTable {
    pub fn new(eta: f32) -> Self {
        let b = Boundary::new(eta);
        let albedos: Vec<f32> = (0..N_ALBEDO)
            .map(|i| {
                ((1.0 - (-8.0 * i as f64 / (N_ALBEDO - 1) as f64).exp()) / (1.0 - (-8.0f64).exp()))
                    as f32
            })
            .collect();
        let mut radii = vec![0.0f32; N_RADIUS];
        radii[1] = 2.5e-3;
        for j in 2..N_RADIUS {
            radii[j] = radii[j - 1] * RADIUS_GROWTH;
        }
        let mut profile = vec![0.0f32; N_ALBEDO * N_RADIUS];
        let mut profile_cdf = vec![0.0f32; N_ALBEDO * N_RADIUS];
        let mut rho_eff = vec![0.0f32; N_ALBEDO];
        // Rows in parallel: the build (~50 ms on one thread) is most of a subsurface scene's
        // start-up, which every render pays.
        use rayon::prelude::*;
        profile
            .par_chunks_mut(N_RADIUS)
            .zip(profile_cdf.par_chunks_mut(N_RADIUS))
            .zip(rho_eff.par_iter_mut())
            .zip(albedos.par_iter())
            .for_each(|(((row, cdf), eff), &rho)| {
                for (j, &r) in radii.iter().enumerate() {
                    let (rho, r) = (rho as f64, r as f64);
                    let value =
                        pbd_multiple(rho, 1.0 - rho, &b, r) + pbd_single(rho, 1.0 - rho, &b, r);
                    row[j] = (2.0 * std::f64::consts::PI * r * value) as f32;
                }
                *eff = integrate_catmull_rom(&radii, row, cdf);
            });
        let mut table = BssrdfTable {
            albedos,
            radii,
            profile,
            profile_cdf,
            rho_eff,
            r_max: Vec::new(),
            eta,
        };
        table.r_max = (0..N_ALBEDO)
            .map(|i| {
                table
                    .sample_radius(table.albedos[i], R_MAX_QUANTILE)
                    .unwrap_or(0.0)
            })
            .collect();
        table
    }

    /// Probe radius (optical units) for an albedo: interpolated between the nodes' 99.9%
    /// quantiles. It only bounds the probe segment, so interpolation error costs nothing but
    /// a slightly longer or shorter probe.
    pub fn r_max_at(&self, rho: f32) -> f32 {
        crate::math::catmull_rom::catmull_rom_eval(&self.albedos, &self.r_max, rho)
            .max(self.radii[1])
    }

    /// Effective albedo for a single-scattering albedo (Catmull-Rom over the table).
    pub fn rho_eff_at(&self, rho: f32) -> f32 {
        crate::math::catmull_rom::catmull_rom_eval(&self.albedos, &self.rho_eff, rho)
    }

    /// Single-scattering albedo whose effective albedo is `rho_eff` (the inverse of
    /// `rho_eff_at`, which increases monotonically).
    pub fn invert_rho_eff(&self, rho_eff: f32) -> f32 {
        crate::math::catmull_rom::invert_catmull_rom(&self.albedos, &self.rho_eff, rho_eff)
    }

    /// Radial profile in optical units without the 2 pi r factor, and the table's rho_eff, at
    /// (albedo, optical radius): `(R(r), rho_eff)`, so that \int R(r) 2 pi r dr = rho_eff.
    /// Zero outside the table.
    pub fn eval(&self, rho: f32, r_optical: f32) -> (f32, f32) {
        self.eval_with(self.albedo_weights(rho), r_optical)
    }

    /// Catmull-Rom weights of an albedo (computed once per wavelength and reused by `eval_with`).
    pub fn albedo_weights(&self, rho: f32) -> Option<(isize, [f32; 4])> {
        catmull_rom_weights(&self.albedos, rho)
    }

    /// `eval` with precomputed albedo weights.
    pub fn eval_with(
        &self,
        albedo_weights: Option<(isize, [f32; 4])>,
        r_optical: f32,
    ) -> (f32, f32) {
        let (Some((oa, wa)), Some((or, wr))) = (albedo_weights, self.radius_weights(r_optical))
        else {
            return (0.0, 0.0);
        };
        let mut value = 0.0;
        let mut eff = 0.0;
        for (a, wa) in wa.iter().enumerate() {
            let ia = oa + a as isize;
            if *wa == 0.0 || ia < 0 || ia as usize >= N_ALBEDO {
                continue;
            }
            let ia = ia as usize;
            eff += wa * self.rho_eff[ia];
            for (k, wr) in wr.iter().enumerate() {
                let ir = or + k as isize;
                if *wr == 0.0 || ir < 0 || ir as usize >= N_RADIUS {
                    continue;
                }
                value += wa * wr * self.profile[ia * N_RADIUS + ir as usize];
            }
        }
        if r_optical > 0.0 {
            value /= 2.0 * std::f32::consts::PI * r_optical;
        }
        (value.max(0.0), eff)
    }

    /// `catmull_rom_weights(&self.radii, r)`, with the segment found from the radii's
    /// geometric growth (r_j = r_1 1.2^(j - 1)) instead of a binary search: every probe hit
    /// evaluates the profile a dozen times (three axes by the path's wavelengths).
    fn radius_weights(&self, r: f32) -> Option<(isize, [f32; 4])> {
        let radii = &self.radii;
        if !(r >= 0.0 && r <= radii[N_RADIUS - 1]) {
            return None;
        }
        let guess = if r < radii[1] {
            0
        } else {
            1 + ((r / radii[1]).ln() * (1.0 / RADIUS_GROWTH.ln())) as usize
        };
        // The segment containing r: the last node at or below r (the table's last segment
        // for its last node), as the search finds it; the guess is off by at most one where
        // rounding meets a node.
        let mut i = guess.min(N_RADIUS - 2);
        while i > 0 && radii[i] > r {
            i -= 1;
        }
        while i + 2 < N_RADIUS && radii[i + 1] <= r {
            i += 1;
        }
        Some(catmull_rom_weights_in(radii, r, i))
    }

    /// Samples an optical radius with density proportional to 2 pi r R(r) for albedo `rho`.
    pub fn sample_radius(&self, rho: f32, u: f32) -> Option<f32> {
        crate::math::catmull_rom::sample_catmull_rom_2d(
            &self.albedos,
            &self.radii,
            &self.profile,
            &self.profile_cdf,
            rho,
            u,
        )
        .map(|s| s.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_moment_matches_diffuse_reflectance_fit() {
        // 2 Fm1 is the internal diffuse Fresnel reflectance F_dr; Jensen et al. 2001 (eq. 7's
        // polynomial fit, Egan & Hilgeman) gives 0.472 for eta = 1.33.
        let eta = 1.33f32;
        let fit = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
        let fdr = 2.0 * fresnel_moment_internal(eta, 1) as f32;
        assert!((fdr - fit).abs() < 0.01, "{fdr} vs {fit}");
    }

    #[test]
    fn radius_weights_match_the_search() {
        let t = BssrdfTable::new(1.33);
        let r_last = t.radii[N_RADIUS - 1];
        // Every node, its float neighbours (where rounding could mislead the closed form),
        // points between the nodes and the ends; outside the table: None either way.
        let mut radii = vec![0.0, -1e-9, r_last, r_last * 1.0001, f32::NAN, 1e-7];
        for &r in &t.radii {
            radii.extend([
                r,
                f32::from_bits(r.to_bits() + 1),
                f32::from_bits(r.to_bits().max(1) - 1),
            ]);
        }
        radii.extend((0..10_000).map(|k| r_last * (k as f32 / 10_000.0).powi(3)));
        for r in radii {
            assert_eq!(
                t.radius_weights(r),
                catmull_rom_weights(&t.radii, r),
                "radius {r:e}"
            );
        }
    }

    #[test]
    fn rho_eff_is_monotonic_and_bounded() {
        let t = BssrdfTable::new(1.33);
        for w in t.rho_eff.windows(2) {
            assert!(w[1] >= w[0]);
        }
        // The diffusion approximation overshoots slightly for a non-absorbing medium
        // (rho = 1 gives rho_eff = 1.019 for eta = 1.33): allow a few percent, no more.
        assert!(t.rho_eff[0] == 0.0 && t.rho_eff[N_ALBEDO - 1] < 1.03);
        assert!(t.rho_eff[N_ALBEDO - 1] > 0.97);
        assert!((t.rho_eff[10] - 0.0800).abs() < 0.01, "{}", t.rho_eff[10]);
    }
}
