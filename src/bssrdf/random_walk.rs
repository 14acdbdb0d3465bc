//! Volumetric random-walk subsurface scattering (the method of Blender Cycles' default SSS):
//! exponential free flights inside the closed mesh, Henyey-Greenstein scattering, and the
//! boundary handled by the caller with the dielectric BSDF.
//!
//! Distances are sampled from one wavelength of the path chosen uniformly (hero-driven
//! spectral MIS, the one-sample balance heuristic over the active wavelengths): the density of
//! a scattering at distance t is the mean of sigma_t(l) exp(-sigma_t(l) t) over the active
//! wavelengths, the probability of reaching a surface at distance d the mean of
//! exp(-sigma_t(l) d) (Wilkie et al. 2014, section 4; the same construction as the spectral
//! tracking of Miller, Georgiev, Jarosz 2019 with a single free-flight sample).

use crate::geometry::{Geometry, Hit, Ray};
use crate::math::Frame;
use crate::sampler::Sampler;
use crate::spectrum::SampledSpectrum;
use glam::Vec3;

/// Upper bound on scattering events of one walk (a safety net: Russian roulette ends walks).
const MAX_SCATTER: u32 = 100_000;
/// Scattering events before Russian roulette may end the walk.
const RR_START: u32 = 16;

/// Henyey-Greenstein phase function (Henyey & Greenstein 1941) with `cos_theta` between the
/// propagation direction before and after scattering.
pub fn hg_phase(cos_theta: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * std::f32::consts::PI * denom * denom.max(1e-12).sqrt())
}

/// Samples a new propagation direction from HG around `dir` (phase / pdf = 1).
/// cos theta by inverting the HG CDF in closed form.
pub fn sample_hg(dir: Vec3, g: f32, u1: f32, u2: f32) -> Vec3 {
    let cos_theta = if g.abs() < 1e-3 {
        1.0 - 2.0 * u1
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u1);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u2;
    let frame = Frame::from_normal(dir);
    frame
        .to_world(Vec3::new(
            sin_theta * phi.cos(),
            sin_theta * phi.sin(),
            cos_theta,
        ))
        .normalize()
}

fn mean_active(s: SampledSpectrum, n_active: usize) -> f32 {
    s.0[..n_active].iter().sum::<f32>() / n_active as f32
}

/// Walks from `ray` (starting inside the medium) until it reaches a surface. Returns the
/// surface hit and the last ray segment (the caller shades the hit from inside), and multiplies
/// `beta` by the walk's throughput. `None` if the walk was absorbed or escaped to infinity.
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
    let n_active = n_active.max(1);
    let mut local = SampledSpectrum::ONE;
    for event in 0..MAX_SCATTER {
        let u_ch = sampler.next_1d();
        let u_t = sampler.next_1d();
        let ch = ((u_ch * n_active as f32) as usize).min(n_active - 1);
        let st = sigma_t[ch];
        let t = if st > 0.0 {
            -(1.0 - u_t).ln() / st
        } else {
            f32::INFINITY
        };
        match geometry.intersect(&ray, t) {
            Some(hit) => {
                let tr = (sigma_t * -hit.t).exp();
                let p = mean_active(tr, n_active);
                if !(p > 0.0) {
                    return None;
                }
                local *= tr / p;
                *beta *= local;
                return beta.is_finite().then_some((hit, ray));
            }
            None => {
                if !t.is_finite() {
                    return None;
                }
                let tr = (sigma_t * -t).exp();
                let pdf = mean_active(sigma_t * tr, n_active);
                if !(pdf > 0.0) {
                    return None;
                }
                local *= sigma_s * tr / pdf;
                let u = sampler.next_2d();
                let dir = sample_hg(ray.dir, g, u.x, u.y);
                ray = Ray::new(ray.at(t), dir);
                if event >= RR_START {
                    let rr = local.max_component();
                    if rr < 1.0 {
                        let q = (1.0 - rr).clamp(0.0, 0.95);
                        if sampler.next_1d() < q {
                            return None;
                        }
                        local /= 1.0 - q;
                    }
                }
                if !local.is_finite() || local.is_black() {
                    return None;
                }
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hg_sampling_mean_cosine_is_g() {
        let g = 0.6;
        let n = 20000;
        let mut sum = 0.0;
        for i in 0..n {
            let u1 = (i as f32 + 0.5) / n as f32;
            let d = sample_hg(Vec3::Z, g, u1, 0.3);
            sum += d.z;
        }
        assert!((sum / n as f32 - g).abs() < 2e-3, "{}", sum / n as f32);
        // Normalised: \int p dw = 1 by midpoint rule in cos.
        let mut integral = 0.0;
        for i in 0..1000 {
            let c = -1.0 + (i as f32 + 0.5) / 500.0;
            integral += hg_phase(c, g) * 2.0 * std::f32::consts::PI / 500.0;
        }
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    }
}
