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
//! Phase function: Henyey-Greenstein, sampled exactly (weight 1).

use crate::geometry::{Geometry, Hit, Ray};
use crate::media::phase::sample_hg;
use crate::sampler::Sampler;
use crate::spectrum::{SampledSpectrum, N_WAVELENGTHS};

/// Upper bound on scattering events of one walk (a safety net: Russian roulette ends walks).
const MAX_SCATTER: u32 = 100_000;
/// Scattering events before Russian roulette may end the walk.
const RR_START: u32 = 16;

/// log(mean_i exp(x_i)) over the first `n` entries.
fn log_mean_exp(x: &[f64], n: usize) -> f64 {
    let m = x[..n].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        return m;
    }
    (x[..n].iter().map(|v| (v - m).exp()).sum::<f64>() / n as f64).ln() + m
}

/// Walks from `ray` (starting inside the medium) until it reaches a surface. Returns the
/// surface hit and the last ray segment (the caller shades the hit from inside), and multiplies
/// `beta` by the walk's weight. `None` if the walk was absorbed, ended by Russian roulette, or
/// escaped to infinity (an open mesh).
#[allow(clippy::too_many_arguments)]
pub fn walk(
    geometry: &Geometry,
    mut ray: Ray,
    sigma_a: SampledSpectrum,
    sigma_s: SampledSpectrum,
    g: f32,
    n_active: usize,
    sampler: &mut Sampler,
    beta: &mut SampledSpectrum,
) -> Option<(Hit, Ray)> {
    let sigma_t = sigma_a + sigma_s;
    let n = n_active.clamp(1, N_WAVELENGTHS);
    let ch = ((sampler.next_1d() * n as f32) as usize).min(n - 1);
    let st_c = sigma_t[ch] as f64;
    // log of f_j / p_ch (path contribution relative to the sampling density) and of
    // p_i / p_ch (density under wavelength i's sampling relative to the one used).
    // Per-event constants (ln 0 = -inf is fine: that wavelength's weight becomes 0).
    let ln_ss: [f64; N_WAVELENGTHS] = std::array::from_fn(|i| (sigma_s[i] as f64).ln());
    let ln_st: [f64; N_WAVELENGTHS] = std::array::from_fn(|i| (sigma_t[i] as f64).ln());
    let ln_st_c = st_c.ln();
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
    for event in 0..MAX_SCATTER {
        let u_t = sampler.next_1d();
        let t = if st_c > 0.0 {
            (-(1.0 - u_t as f64).ln() / st_c) as f32
        } else {
            f32::INFINITY
        };
        match geometry.intersect(&ray, t) {
            Some(hit) => {
                // Reached the surface: transmittance over probability of flying that far.
                let d = hit.t as f64;
                for i in 0..n {
                    let x = -(sigma_t[i] as f64 - st_c) * d;
                    log_f[i] += x;
                    log_p[i] += x;
                }
                let w = weight(&log_f, &log_p);
                if !w.is_finite() {
                    return None;
                }
                *beta *= w;
                return Some((hit, ray));
            }
            None => {
                if !t.is_finite() {
                    return None;
                }
                let td = t as f64;
                for i in 0..n {
                    let rel = -(sigma_t[i] as f64 - st_c) * td - ln_st_c;
                    log_f[i] += ln_ss[i] + rel;
                    log_p[i] += ln_st[i] + rel;
                }
                let u = sampler.next_2d();
                let dir = sample_hg(ray.dir, g, u.x, u.y);
                ray = Ray::new_at(ray.at(t), dir, ray.time);
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
        }
    }
    None
}
