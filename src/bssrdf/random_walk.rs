//! Volumetric random-walk subsurface scattering (the method of Blender Cycles' default SSS):
//! exponential free flights inside the closed mesh, Henyey-Greenstein scattering, and the
//! boundary handled by the caller (`super::WalkBoundary`: internal reflection by the dielectric
//! BSDF, exits through a fixed lobe that gets next-event estimation).
//!
//! Distances are sampled with the sigma_t of one wavelength of the path, chosen uniformly once
//! per walk (the hero-wavelength idea of Wilkie et al. 2014 applied to the whole walk), and the
//! wavelengths are combined with the one-sample balance heuristic over complete walks: the
//! weight of wavelength j is f_j(walk) / mean_i p_i(walk), where p_i is the density of the walk
//! when distances follow wavelength i. Per-event MIS (a fresh choice at every event) is also
//! unbiased, but its weights multiply over the hundreds of events of a high-albedo walk and the
//! variance explodes; with whole-walk MIS every weight is at most N times the albedo product.
//! Products are kept in log space (thousands of events would overflow f32 and f64).
//!
//! Walks that know the plane they entered through are guided back to it (Dwivedi sampling:
//! Meng, Hanika & Dachsbacher 2016, "Improving the Dwivedi Sampling Scheme"; Krivanek & d'Eon
//! 2014, "A Zero-variance-based Sampling Scheme for Monte Carlo Subsurface Scattering"): after
//! each scattering event the direction comes either from the phase function or, with
//! probability [`guided_fraction`], from the Dwivedi distribution about the entry plane's
//! normal, and a guided flight's extinction is stretched by (1 - mu / nu), so flights towards
//! the surface are longer and those away from it shorter. In a thin object a second guide leads
//! towards the opposite side (mirrored about the plane), chosen with a probability that grows
//! with the depth reached. Every event's density is the mixture of the strategies (one-sample
//! balance heuristic), so the walk stays unbiased whatever the geometry; the guides only decide
//! how many events a walk needs and how even its weights are. Phase function: Henyey-Greenstein.

use crate::geometry::{Geometry, Hit, Ray};
use crate::math::Frame;
use crate::media::phase::{hg_phase, sample_hg, sample_hg_cos};
use crate::sampler::Sampler;
use crate::spectrum::{SampledSpectrum, N_WAVELENGTHS};
use glam::Vec3;
use std::f32::consts::TAU;

/// Upper bound on scattering events of one walk (a safety net: Russian roulette ends walks).
const MAX_SCATTER: u32 = 100_000;
/// Scattering events before Russian roulette may end the walk.
const RR_START: u32 = 16;
/// How far (in the longest mean free path) the first flight looks for the opposite side of a
/// thin object, which the backward guide then leads to.
const OPPOSITE_SEARCH_MFP: f32 = 10.0;

/// log(mean_i exp(x_i)) over the first `n` entries.
fn log_mean_exp(x: &[f64], n: usize) -> f64 {
    let m = x[..n].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        return m;
    }
    (x[..n].iter().map(|v| (v - m).exp()).sum::<f64>() / n as f64).ln() + m
}

/// The plane a walk entered its medium through: a point on it and the normal pointing out of
/// the medium. The guides of [`walk`] lead back to it (or to the far side beyond it).
#[derive(Clone, Copy, Debug)]
pub struct EntryPlane {
    pub point: Vec3,
    pub outward_normal: Vec3,
}

/// Dwivedi's diffusion length nu (in mean free paths) for single-scattering albedo `alpha`:
/// the root nu > 1 of (alpha nu / 2) ln((nu + 1) / (nu - 1)) = 1, by the fit of d'Eon &
/// Krivanek 2020 ("A Hitchhiker's Guide to Multiple Scattering", eq. 67),
/// nu = 1 / sqrt(1 - alpha^(2.44294 - 0.0215813 alpha + 0.578637 / alpha)).
pub fn diffusion_length(alpha: f32) -> f32 {
    let a = alpha.clamp(1e-3, 1.0 - 1e-6) as f64;
    let k = 2.44294 - 0.0215813 * a + 0.578637 / a;
    (1.0 / (1.0 - a.powf(k)).sqrt()) as f32
}

/// The Dwivedi density of mu, the cosine of a direction to the guiding normal, on [-1, 1]:
/// 1 / ((nu - mu) ln((nu + 1) / (nu - 1))) (Meng et al. 2016, eq. 9; `log_ratio` is the log).
fn dwivedi_pdf(nu: f32, log_ratio: f32, mu: f32) -> f32 {
    1.0 / ((nu - mu) * log_ratio)
}

/// Inverts the CDF of [`dwivedi_pdf`]: mu = nu - (nu + 1) ((nu - 1) / (nu + 1))^u (eq. 10).
fn sample_dwivedi(nu: f32, log_ratio: f32, u: f32) -> f32 {
    (nu - (nu + 1.0) * (-u * log_ratio).exp()).clamp(-1.0, 1.0)
}

/// Share of a walk's scattering events whose direction is guided. The Dwivedi distribution is
/// the ideal for isotropic scattering; the more the phase function peaks, the worse a guided
/// direction fits it (and the larger its weight), so strongly forward-scattering media are
/// mostly left to the phase function. Half of the events for isotropic media (Cycles' compromise
/// between guided and classic walks).
pub fn guided_fraction(g: f32) -> f32 {
    1.0 - g.abs().powf(0.125).max(0.5)
}

/// A walk's guide: the entry plane and the Dwivedi parameters of its most scattering
/// wavelength (too low an albedo would guide too strongly and give fireflies; too high only
/// guides less).
struct Guide {
    plane: EntryPlane,
    nu: f32,
    log_ratio: f32,
    fraction: f32,
    /// 1 / (diffusion length in scene units): the scale of the backward guide's transition.
    inv_length: f32,
    frame: Frame,
}

impl Guide {
    fn new(
        plane: EntryPlane,
        sigma_s: SampledSpectrum,
        sigma_t: SampledSpectrum,
        g: f32,
        n: usize,
    ) -> Option<Self> {
        let fraction = guided_fraction(g);
        let best = (0..n)
            .filter(|&i| sigma_t[i] > 0.0)
            .max_by(|&a, &b| (sigma_s[a] / sigma_t[a]).total_cmp(&(sigma_s[b] / sigma_t[b])))?;
        let nu = diffusion_length(sigma_s[best] / sigma_t[best]);
        // nu -> 1 (albedo -> 0) makes the density infinite at mu = 1; such media end their
        // walks after an event or two anyway.
        if !(fraction > 0.0 && nu > 1.001 && nu.is_finite()) {
            return None;
        }
        Some(Guide {
            plane,
            nu,
            log_ratio: ((nu + 1.0) / (nu - 1.0)).ln(),
            fraction,
            inv_length: sigma_t[best] / nu,
            frame: Frame::from_normal(plane.outward_normal),
        })
    }

    /// Depth of `p` below the entry plane.
    fn depth(&self, p: Vec3) -> f32 {
        (self.plane.point - p).dot(self.plane.outward_normal)
    }

    /// Probability of guiding towards the opposite side (at depth `far`) from `p`: a logistic
    /// step from 0 at the entry plane through 1/2 half-way to 1 at the far side, over one
    /// diffusion length.
    fn backward_fraction(&self, p: Vec3, far: f32) -> f32 {
        let x = self.depth(p).clamp(0.0, far);
        1.0 / (1.0 + ((far - 2.0 * x) * self.inv_length).exp())
    }
}

/// What the density of one guided event needs besides the flight: the mixture weights of the
/// three strategies (classic, towards the entry plane, towards the opposite side), each guided
/// direction's density taken relative to the phase function's, and mu / nu, which stretches
/// the guided flights' extinction by (1 -/+ mu / nu).
struct GuidedEvent {
    weight: [f64; 3],
    mu_over_nu: f64,
}

impl GuidedEvent {
    /// ln of the event's density relative to the classic strategy's alone, for a wavelength
    /// whose flight covered `sigma_d` = sigma_t d: ln(w0 + sum_k w_k s_k^scatter
    /// e^(sigma d (1 - s_k))) with s_k = 1 -/+ mu / nu (a guided flight ending in scattering
    /// has density s sigma e^(-s sigma d), one reaching the surface probability e^(-s sigma d)).
    #[inline]
    fn log_mixture(&self, sigma_d: f64, scatter: bool) -> f64 {
        let [w0, w1, w2] = self.weight;
        let (s1, s2) = (1.0 - self.mu_over_nu, 1.0 + self.mu_over_nu);
        let (w1, w2) = if scatter {
            (w1 * s1, w2 * s2)
        } else {
            (w1, w2)
        };
        // e^(x) and e^(-x) with x = sigma d mu / nu; beyond +-700 f64 overflows (the walk
        // would be hundreds of mean free paths off its guide: the dominant term decides).
        let x = sigma_d * self.mu_over_nu;
        if x.abs() < 700.0 {
            let e = x.exp();
            let back = if w2 > 0.0 { w2 / e } else { 0.0 };
            (w0 + w1 * e + back).ln()
        } else if x > 0.0 {
            x + w1.ln()
        } else {
            -x + w2.ln()
        }
    }
}

/// Walks from `ray` (starting inside the medium) until it reaches a surface. Returns the
/// surface hit and the last ray segment (the caller shades the hit from inside), and multiplies
/// `beta` by the walk's weight. `None` if the walk was absorbed, ended by Russian roulette, or
/// escaped to infinity (an open mesh). With `entry`, the walk is guided back to that plane
/// (and, in thin objects, to the opposite side); without, it samples the phase function alone.
#[allow(clippy::too_many_arguments)]
pub fn walk(
    geometry: &Geometry,
    mut ray: Ray,
    sigma_a: SampledSpectrum,
    sigma_s: SampledSpectrum,
    g: f32,
    n_active: usize,
    entry: Option<EntryPlane>,
    sampler: &mut Sampler,
    beta: &mut SampledSpectrum,
) -> Option<(Hit, Ray)> {
    let sigma_t = sigma_a + sigma_s;
    let n = n_active.clamp(1, N_WAVELENGTHS);
    let ch = ((sampler.next_1d() * n as f32) as usize).min(n - 1);
    let st_c = sigma_t[ch];
    let guide = entry.and_then(|e| Guide::new(e, sigma_s, sigma_t, g, n));
    // ln f_j and ln p_i of the walk so far, both without the phase function's value at each
    // event (it is a common factor of f and of every strategy's density: guided directions'
    // densities are kept relative to it). ln 0 = -inf is fine: that wavelength's weight is 0.
    let ln_ss: [f64; N_WAVELENGTHS] = std::array::from_fn(|i| (sigma_s[i] as f64).ln());
    let ln_st: [f64; N_WAVELENGTHS] = std::array::from_fn(|i| (sigma_t[i] as f64).ln());
    let mut log_f = [0.0f64; N_WAVELENGTHS];
    let mut log_p = [0.0f64; N_WAVELENGTHS];
    let weight = |log_f: &[f64; N_WAVELENGTHS], log_p: &[f64; N_WAVELENGTHS]| {
        let norm = log_mean_exp(log_p, n);
        SampledSpectrum::from_fn(|j| {
            if j < n {
                (log_f[j] - norm).exp() as f32
            } else {
                0.0
            }
        })
    };
    // Depth of the opposite side below the entry plane, if the first flight found it near.
    let mut far_side: Option<f32> = None;
    for event in 0..MAX_SCATTER {
        // After a scattering event: the new direction, from the phase function or a guide.
        let mut guided = None;
        let mut sample_sigma = st_c;
        if let (true, Some(gd)) = (event > 0, &guide) {
            let use_guide = sampler.next_1d() < gd.fraction;
            let bf = far_side.map_or(0.0, |far| gd.backward_fraction(ray.origin, far));
            let backward = bf > 0.0 && sampler.next_1d() < bf;
            let u = sampler.next_2d();
            let old = ray.dir;
            let (dir, mu) = if use_guide {
                let mu = sample_dwivedi(gd.nu, gd.log_ratio, u.x);
                let mu = if backward { -mu } else { mu };
                let sin = (1.0 - mu * mu).max(0.0).sqrt();
                let phi = TAU * u.y;
                let dir = gd
                    .frame
                    .to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), mu));
                (dir.normalize(), mu)
            } else {
                let dir = sample_hg(old, g, u.x, u.y);
                (dir, dir.dot(gd.plane.outward_normal).clamp(-1.0, 1.0))
            };
            let phase = hg_phase(old.dot(dir), g) as f64;
            let f = gd.fraction as f64;
            let ratio = |m: f32| dwivedi_pdf(gd.nu, gd.log_ratio, m) as f64 / (TAU as f64 * phase);
            let mu_over_nu = (mu / gd.nu) as f64;
            if use_guide {
                sample_sigma *= if backward {
                    1.0 + mu / gd.nu
                } else {
                    1.0 - mu / gd.nu
                };
            }
            guided = Some(GuidedEvent {
                weight: [
                    1.0 - f,
                    f * (1.0 - bf as f64) * ratio(mu),
                    f * bf as f64 * ratio(-mu),
                ],
                mu_over_nu,
            });
            ray = Ray::new_at(ray.origin, dir, ray.time);
        }
        let u_t = sampler.next_1d();
        let t = if sample_sigma > 0.0 {
            (-(1.0 - u_t as f64).ln() / sample_sigma as f64) as f32
        } else {
            f32::INFINITY
        };
        // The first flight of a guided walk looks further, for the opposite side of a thin
        // object; a surface beyond t is no hit of this flight.
        let found = if event == 0 && guide.is_some() {
            let thinnest = (0..n).map(|i| sigma_t[i]).fold(f32::INFINITY, f32::min);
            let longest = OPPOSITE_SEARCH_MFP / thinnest.max(1e-30);
            let found = geometry.intersect(&ray, t.max(longest));
            if let (Some(h), Some(gd)) = (&found, &guide) {
                let far = gd.depth(ray.at(h.t));
                far_side = (far > 0.0).then_some(far);
            }
            found.filter(|h| h.t < t)
        } else {
            geometry.intersect(&ray, t)
        };
        let (d, hit) = match found {
            Some(h) => (h.t as f64, Some(h)),
            None if t.is_finite() => (t as f64, None),
            None => return None,
        };
        // The event's contribution and its density under each wavelength's sampling: a flight
        // ending in scattering has density sigma e^(-sigma d), one reaching the surface
        // probability e^(-sigma d); a guided flight's sigma is stretched.
        let scatter = hit.is_none();
        for i in 0..n {
            let s = sigma_t[i] as f64;
            // (Branches, not 0 * ln: ln 0 = -inf for a wavelength that does not scatter.)
            let (ln_f, classic) = if scatter {
                (ln_ss[i] - s * d, ln_st[i] - s * d)
            } else {
                (-s * d, -s * d)
            };
            log_f[i] += ln_f;
            log_p[i] += match &guided {
                None => classic,
                Some(ge) => classic + ge.log_mixture(s * d, scatter),
            };
        }
        if let Some(hit) = hit {
            // Reached the surface.
            let w = weight(&log_f, &log_p);
            if !w.is_finite() {
                return None;
            }
            *beta *= w;
            return Some((hit, ray));
        }
        ray = Ray::new_at(ray.at(t), ray.dir, ray.time);
        if guide.is_none() {
            let u = sampler.next_2d();
            ray = Ray::new_at(ray.origin, sample_hg(ray.dir, g, u.x, u.y), ray.time);
        }
        // Russian roulette (checked every 4th event: the weight needs exp/ln).
        if event >= RR_START && event % 4 == 0 {
            let w_max = weight(&log_f, &log_p).max_component();
            if !(w_max > 0.0) {
                return None;
            }
            if w_max < 1.0 {
                let q = (1.0 - w_max).clamp(0.0, 0.95);
                if sampler.next_1d() < q {
                    return None;
                }
                let boost = -((1.0 - q) as f64).ln();
                for v in log_f.iter_mut().take(n) {
                    *v += boost;
                }
            }
        }
    }
    None
}

/// Total diffuse reflectance of a random walk with a Lambertian boundary (every walk that
/// reaches the boundary leaves) in a half-space, per entry direction and single-scattering
/// albedo: what a walk entering a flat surface returns on average, for light that leaves
/// where it entered after a diffuse bounce (`PathTracer::with_full_indirect_subsurface`).
/// Tabulated by simulation once per anisotropy: walks without absorption, each recording its
/// number n of scattering events, give R(alpha) = mean(alpha^n) for every albedo at once.
#[derive(Debug)]
pub struct LambertianWalkReflectance {
    /// R at (cosine node c, albedo node k), index c * ALBEDO_NODES + k; albedo node k is
    /// alpha = 1 - s^2 with s = k / (ALBEDO_NODES - 1) (dense near alpha = 1, where R is steep).
    table: Vec<f32>,
}

impl LambertianWalkReflectance {
    /// Nodes of the entry direction's cosine to the inward normal: k / 16 for k = 1..=16
    /// (normal incidence is a node: with forward scattering R changes fastest there; below
    /// 1/16 the first node's value is used).
    const COSINE_NODES: usize = 16;
    const ALBEDO_NODES: usize = 65;
    /// Walks per cosine node: R's standard error stays below 0.6%.
    const WALKS: u32 = 4096;
    /// Walks still inside after this many events count as leaving then (exact at alpha = 1,
    /// where every walk returns; for alpha < 1 they weigh alpha^4096).
    const MAX_EVENTS: u32 = 4096;

    /// The table for Henyey-Greenstein anisotropy `g` (deterministic, whatever the threads).
    ///
    /// Only the depth matters in a half-space, so a walk tracks the cosine mu of its direction
    /// to the outward normal alone: after scattering by theta with azimuth phi about the old
    /// direction, mu' = mu cos(theta) + sqrt(1 - mu^2) sin(theta) cos(phi) (for g = 0, mu' is
    /// uniform on [-1, 1] directly). Event counts are histogrammed and R(alpha) = sum over n of
    /// P(n) alpha^n evaluated once per bin by running powers, instead of one exp per walk and
    /// albedo.
    pub fn new(g: f32) -> Self {
        let alpha: Vec<f64> = (0..Self::ALBEDO_NODES)
            .map(|k| {
                let s = k as f64 / (Self::ALBEDO_NODES - 1) as f64;
                1.0 - s * s
            })
            .collect();
        let isotropic = g.abs() < 1e-3;
        use rayon::prelude::*;
        let rows: Vec<Vec<f32>> = (0..Self::COSINE_NODES)
            .into_par_iter()
            .map(|c| {
                let cos = (c + 1) as f32 / Self::COSINE_NODES as f32;
                let mut rng = crate::sampler::Pcg32::new(c as u64, 0, 0x5eed_3a1c);
                let mut walks_with = vec![0u32; Self::MAX_EVENTS as usize + 1];
                for _ in 0..Self::WALKS {
                    // Depth below the surface (z < 0 inside), unit extinction: the half-space has
                    // no scale. mu: the direction's z (inwards: negative).
                    let mut z = 0.0f32;
                    let mut mu = -cos;
                    let mut events = 0u32;
                    loop {
                        let t = -(1.0 - rng.next_1d()).ln();
                        z += mu * t;
                        if z >= 0.0 || events == Self::MAX_EVENTS {
                            break;
                        }
                        events += 1;
                        let (u1, u2) = (rng.next_1d(), rng.next_1d());
                        mu = if isotropic {
                            1.0 - 2.0 * u1
                        } else {
                            let cos_theta = sample_hg_cos(g, u1);
                            let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
                            let sin_mu = (1.0 - mu * mu).max(0.0).sqrt();
                            (mu * cos_theta + sin_mu * sin_theta * (TAU * u2).cos())
                                .clamp(-1.0, 1.0)
                        };
                    }
                    walks_with[events as usize] += 1;
                }
                alpha
                    .iter()
                    .map(|&a| {
                        let (mut power, mut sum) = (1.0f64, 0.0f64);
                        for &count in &walks_with {
                            sum += count as f64 * power;
                            power *= a;
                        }
                        (sum / Self::WALKS as f64) as f32
                    })
                    .collect()
            })
            .collect();
        LambertianWalkReflectance {
            table: rows.concat(),
        }
    }

    /// R for an entry direction at `cos_entry` to the inward normal and single-scattering
    /// albedo `alpha` (bilinear in the cosine's nodes and in sqrt(1 - alpha)).
    pub fn at(&self, cos_entry: f32, alpha: f32) -> f32 {
        let x = (cos_entry.clamp(0.0, 1.0) * Self::COSINE_NODES as f32 - 1.0)
            .clamp(0.0, (Self::COSINE_NODES - 1) as f32);
        let c0 = (x as usize).min(Self::COSINE_NODES - 2);
        let tc = x - c0 as f32;
        let y = (1.0 - alpha.clamp(0.0, 1.0)).sqrt() * (Self::ALBEDO_NODES - 1) as f32;
        let k0 = (y as usize).min(Self::ALBEDO_NODES - 2);
        let tk = y - k0 as f32;
        let row = |c: usize| {
            let r = &self.table[c * Self::ALBEDO_NODES..];
            r[k0] * (1.0 - tk) + r[k0 + 1] * tk
        };
        row(c0) * (1.0 - tc) + row(c0 + 1) * tc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit of Dwivedi's diffusion length solves its defining equation
    /// (alpha nu / 2) ln((nu + 1) / (nu - 1)) = 1, against a bisection of it.
    #[test]
    fn diffusion_length_solves_the_dwivedi_equation() {
        for alpha in [0.3f64, 0.5, 0.8, 0.9, 0.99, 0.999, 0.9999] {
            let f = |v: f64| alpha * v / 2.0 * ((v + 1.0) / (v - 1.0)).ln() - 1.0;
            let (mut lo, mut hi) = (1.0 + 1e-12, 1e6);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if f(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let fit = diffusion_length(alpha as f32) as f64;
            assert!(
                (fit / lo - 1.0).abs() < 1e-3,
                "alpha {alpha}: {fit} vs {lo}"
            );
        }
        // The Dwivedi density integrates to 1 and its sampling inverts its CDF.
        let nu = diffusion_length(0.95);
        let log_ratio = ((nu + 1.0) / (nu - 1.0)).ln();
        let steps = 100_000;
        let integral: f32 = (0..steps)
            .map(|k| dwivedi_pdf(nu, log_ratio, -1.0 + 2.0 * (k as f32 + 0.5) / steps as f32))
            .sum::<f32>()
            * 2.0
            / steps as f32;
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
        for u in [0.1f32, 0.5, 0.9] {
            let mu = sample_dwivedi(nu, log_ratio, u);
            let cdf: f32 = (0..steps)
                .map(|k| -1.0 + (mu + 1.0) * (k as f32 + 0.5) / steps as f32)
                .map(|m| dwivedi_pdf(nu, log_ratio, m))
                .sum::<f32>()
                * (mu + 1.0)
                / steps as f32;
            assert!((cdf - u).abs() < 1e-3, "u {u}: cdf {cdf}");
        }
    }

    /// The tabulated reflectance of a Lambertian-boundary walk: 1 without absorption, 0 without
    /// scattering, increasing in the albedo, and matching direct walks (independent numbers)
    /// at a few points within their noise.
    #[test]
    fn lambertian_walk_reflectance_is_bounded_monotone_and_matches_walks() {
        // Isotropic, and forward-scattering (the table tracks only the direction's depth
        // cosine; the reference walks turn full 3D directions).
        for g in [0.0f32, 0.7] {
            let r = LambertianWalkReflectance::new(g);
            for cos in [0.05, 0.5, 1.0] {
                assert!((r.at(cos, 1.0) - 1.0).abs() < 1e-3, "{}", r.at(cos, 1.0));
                assert!(r.at(cos, 0.0).abs() < 1e-6);
                let mut last = 0.0;
                for k in 0..=100 {
                    let v = r.at(cos, k as f32 / 100.0);
                    assert!(v >= last - 1e-6, "g {g}: not monotone at {k}: {v} < {last}");
                    last = v;
                }
            }
            // Grazing entries stay near the surface and come back more often.
            assert!(r.at(0.1, 0.9) > r.at(1.0, 0.9));
            let mut rng = crate::sampler::Pcg32::new(7, 7, 7);
            for (cos, alpha) in [(1.0f32, 0.9f32), (0.3, 0.99), (0.7, 0.6)] {
                let n = 40_000;
                let mut back = 0u32;
                for _ in 0..n {
                    let mut z = 0.0f32;
                    let mut dir = glam::Vec3::new((1.0 - cos * cos).sqrt(), 0.0, -cos);
                    loop {
                        z += dir.z * -(1.0 - rng.next_1d()).ln();
                        if z >= 0.0 {
                            back += 1;
                            break;
                        }
                        if rng.next_1d() >= alpha {
                            break;
                        }
                        dir = sample_hg(dir, g, rng.next_1d(), rng.next_1d());
                    }
                }
                let direct = back as f32 / n as f32;
                let tabulated = r.at(cos, alpha);
                assert!(
                    (tabulated - direct).abs() < 0.012,
                    "g {g} cos {cos} alpha {alpha}: table {tabulated} vs walks {direct}"
                );
            }
        }
    }
}
