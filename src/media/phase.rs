//! The Henyey-Greenstein phase function (Henyey & Greenstein 1941), used by volumes and by the
//! random-walk subsurface medium, and mixtures of it for overlapping volumes.

use crate::math::sampling::spherical_direction;
use crate::math::Frame;
use glam::Vec3;
use std::f32::consts::PI;

/// Henyey-Greenstein phase function with `cos_theta` between the propagation direction before
/// and after scattering (so g > 0 scatters forwards). Normalised over the sphere.
pub fn hg_phase(cos_theta: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(1e-12).sqrt())
}

/// The cosine of the scattering angle drawn from Henyey-Greenstein's phase function with
/// anisotropy `g` (inverting its CDF; pbrt-v4 "Sampling the Henyey-Greenstein Phase Function").
#[inline]
pub fn sample_hg_cos(g: f32, u: f32) -> f32 {
    if g.abs() < 1e-3 {
        1.0 - 2.0 * u
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    }
}

/// Samples a new propagation direction from HG around `dir` (phase / pdf = 1), inverting the
/// HG CDF of cos theta in closed form.
pub fn sample_hg(dir: Vec3, g: f32, u1: f32, u2: f32) -> Vec3 {
    let cos_theta = sample_hg_cos(g, u1);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let local = spherical_direction(sin_theta, cos_theta, 2.0 * PI * u2);
    Frame::from_normal(dir).to_world(local).normalize()
}

/// Most volumes a point can be inside at once (`super::MediumStack`).
pub const MAX_MEDIA: usize = 4;

/// A mixture of HG lobes: the phase function of overlapping volumes, each lobe weighted by its
/// volume's share of the scattering coefficient. One volume (the usual case) is a single lobe.
#[derive(Clone, Copy, Debug)]
pub struct PhaseMixture {
    g: [f32; MAX_MEDIA],
    weight: [f32; MAX_MEDIA],
    len: usize,
}

impl PhaseMixture {
    pub fn single(g: f32) -> Self {
        let mut m = PhaseMixture {
            g: [0.0; MAX_MEDIA],
            weight: [0.0; MAX_MEDIA],
            len: 1,
        };
        m.g[0] = g;
        m.weight[0] = 1.0;
        m
    }

    /// Lobes `(g, weight)` with weights >= 0; normalised here. `None` when all weights are 0.
    pub fn new(lobes: &[(f32, f32)]) -> Option<Self> {
        let total: f32 = lobes.iter().map(|l| l.1).sum();
        if !(total > 0.0) {
            return None;
        }
        let mut m = PhaseMixture {
            g: [0.0; MAX_MEDIA],
            weight: [0.0; MAX_MEDIA],
            len: lobes.len().min(MAX_MEDIA),
        };
        for (i, &(g, w)) in lobes.iter().take(MAX_MEDIA).enumerate() {
            m.g[i] = g;
            m.weight[i] = w / total;
        }
        Some(m)
    }

    /// The phase function (= the density `sample` draws directions with).
    pub fn eval(&self, cos_theta: f32) -> f32 {
        (0..self.len)
            .map(|i| self.weight[i] * hg_phase(cos_theta, self.g[i]))
            .sum()
    }

    /// A direction around the propagation direction `dir`: a lobe chosen by weight with `u0`,
    /// then that lobe sampled exactly. The weight phase / pdf is 1.
    pub fn sample(&self, dir: Vec3, u0: f32, u1: f32, u2: f32) -> Vec3 {
        let mut acc = 0.0;
        let mut lobe = self.len - 1;
        for i in 0..self.len {
            acc += self.weight[i];
            if u0 < acc {
                lobe = i;
                break;
            }
        }
        sample_hg(dir, self.g[lobe], u1, u2)
    }
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
            integral += hg_phase(c, g) * 2.0 * PI / 500.0;
        }
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    }

    #[test]
    fn mixture_is_normalised_and_sampled_by_its_weights() {
        let m = PhaseMixture::new(&[(0.8, 1.0), (-0.3, 3.0)]).unwrap();
        let mut integral = 0.0;
        for i in 0..4000 {
            let c = -1.0 + (i as f32 + 0.5) / 2000.0;
            integral += m.eval(c) * 2.0 * PI / 2000.0;
        }
        assert!((integral - 1.0).abs() < 2e-3, "{integral}");
        // Mean cosine of the mixture: the weighted mean of the lobes' g.
        let n = 40000;
        let mut sum = 0.0;
        for i in 0..n {
            let u0 = (i as f32 + 0.5) / n as f32;
            let u1 = ((i * 7919) % n) as f32 / n as f32 + 0.5 / n as f32;
            sum += m.sample(Vec3::Z, u0, u1, 0.7).z;
        }
        let expected = 0.25 * 0.8 + 0.75 * -0.3;
        assert!(
            (sum / n as f32 - expected).abs() < 5e-3,
            "{}",
            sum / n as f32
        );
        assert!(PhaseMixture::new(&[(0.5, 0.0)]).is_none());
    }
}
