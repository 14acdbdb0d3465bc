//! Volumetric random-walk subsurface scattering (the method of Blender Cycles' default SSS):
//! exponential free flights inside the closed mesh, Henyey-Greenstein scattering, and the
//! boundary handled by the caller (`super::WalkBoundary`: internal reflection by the dielectric
//! BSDF, exits through a fixed lobe that gets next-event estimation).
//!
//! Distances are sampled with the sigma_t of one wavelength of the path, chosen afresh at every
//! event with probability proportional to that wavelength's throughput times its single-scattering
//! albedo, and the wavelengths are combined by the one-sample balance heuristic over that choice
//! at every event: wavelength j's throughput is multiplied by f_j / sum_i P_i p_i, with p_i the
//! flight density under wavelength i's extinction (Chiang, Kutz & Burley 2016, "Practical and
//! Controllable Subsurface Scattering for Production Path Tracing", section 5.2; Cycles'
//! `volume_sample_channel`). Choosing by throughput is what keeps per-event MIS stable: since
//! P_j is proportional to beta_j alpha_j, a scattering event leaves every throughput at most
//! sum_i beta_i alpha_i, so no wavelength's weight can run away over hundreds of events (with a
//! uniform choice the weights multiply and explode), and the wavelengths a walk has nearly
//! absorbed stop steering its flights. A choice fixed once per walk, combined over whole walks,
//! is as unbiased but left a strongly coloured medium (jade: albedos 0.81 to 0.98 across the
//! spectrum) with 1.24x the noise in the SSS Cornell box.
//! Directions follow the Henyey-Greenstein phase function, mixed with Dwivedi's guide towards
//! the surface the walk entered (`walk`).

use crate::geometry::{Geometry, Hit, Ray};
use crate::math::sampling::spherical_direction;
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

/// Walks from `ray` (starting inside the medium) until it reaches a surface. Returns the
/// surface hit and the last ray segment (the caller shades the hit from inside), and multiplies
/// `beta` by the walk's weight (only its first `n_active` wavelengths are live; the others
/// become 0). `None` if the walk was absorbed, ended by Russian roulette, or escaped to
/// infinity (an open mesh).
///
/// `guide`: the outward normal of the surface where the walk entered. With it, events after
/// the first flight draw their direction and distance either as above or, with probability
/// `guided_fraction(g)`, from Dwivedi sampling towards that surface or, where the first
/// flight found the object's far side within 10 mean free paths, towards that side with a
/// probability growing with the walk's depth (Krivanek & d'Eon 2014,
/// "A Zero-variance-based Sampling Scheme for Monte Carlo Subsurface Scattering"; the
/// direction density of Meng, Hanika & Dachsbacher 2016, "Improving the Dwivedi Sampling
/// Scheme", eq. 9-10), combined with the classical sampling by the balance heuristic (one
/// sample MIS over both strategies and all wavelengths). Walks reach the surface again in
/// fewer events: on the SSS Cornell box's jade, 0.84x the noise at +1.5% time (64 spp, 12
/// pairs of renders); through a slab 5 mean free paths thick the transmitted light's variance
/// is 0.79x the classical sampling's (2.4x with the forward guide alone). Cycles' random walk
/// guides the same way.
#[allow(clippy::too_many_arguments)]
pub fn walk(
    geometry: &Geometry,
    mut ray: Ray,
    sigma_a: SampledSpectrum,
    sigma_s: SampledSpectrum,
    g: f32,
    n_active: usize,
    guide: Option<Vec3>,
    sampler: &mut Sampler,
    beta: &mut SampledSpectrum,
) -> Option<(Hit, Ray)> {
    let sigma_t = sigma_a + sigma_s;
    let n = n_active.clamp(1, N_WAVELENGTHS);
    let albedo = SampledSpectrum::from_fn(|i| {
        if i < n && sigma_t[i] > 0.0 {
            sigma_s[i] / sigma_t[i]
        } else {
            0.0
        }
    });
    // Dwivedi's diffusion length nu (in mean free paths) of the most scattering wavelength:
    // the slowest decaying one, which the guide must not over-steer (d'Eon & Krivanek 2020,
    // "Zero-Variance Theory for Efficient Subsurface Scattering", eq. 67's fit of
    // 1 = (alpha nu / 2) ln((nu + 1) / (nu - 1))).
    let a_max = albedo.max_component().clamp(1e-3, 0.999_999);
    let nu = 1.0
        / (1.0 - a_max.powf(2.44294 - 0.0215813 * a_max + 0.578637 / a_max))
            .max(1e-12)
            .sqrt();
    let guided_fraction = guided_fraction(g);
    let n_out = guide.unwrap_or(Vec3::Z);
    let guide = guide.is_some() && guided_fraction > 0.0 && nu > 1.0 + 1e-4 && nu.is_finite();
    // ln((nu + 1) / (nu - 1)): the guided cosine density's normalisation.
    let log_nu = if guide {
        ((nu + 1.0) / (nu - 1.0)).ln()
    } else {
        1.0
    };
    // The guide's decay length in scene units: radiance deep in the medium falls as
    // exp(-sigma_t z / nu) for the most scattering wavelength.
    let decay_length = {
        let k = (0..n)
            .max_by(|&a, &b| albedo[a].total_cmp(&albedo[b]))
            .unwrap_or(0);
        nu / sigma_t[k].max(1e-30)
    };
    // Where the walk entered, and the depth below it of the object's far side along the
    // entry normal when the first flight's ray finds it within 10 mean free paths (a thin
    // part: light goes through it as much as back).
    let entry = ray.origin;
    let mut opposite_depth: Option<f32> = None;
    // Russian roulette compares the largest throughput with the walk's start.
    let beta_start = beta.max_component();
    // HG density of the current direction given the previous one (after the first flight),
    // whether the guide drew it and towards which side, and the probability with which the
    // guide aimed at the far side there.
    let mut phase_pdf = 0.0f32;
    let mut guided_now = false;
    let mut backward_now = false;
    let mut backward_fraction = 0.0f32;
    for event in 0..MAX_SCATTER {
        // The wavelength whose extinction draws this flight: P_i ~ beta_i alpha_i.
        let choice = SampledSpectrum::from_fn(|i| (beta[i] * albedo[i]).max(0.0));
        let total = choice.sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let choice = choice / total;
        let mut u = sampler.next_1d();
        let mut ch = n - 1;
        for i in 0..n {
            if u < choice[i] {
                ch = i;
                break;
            }
            u -= choice[i];
        }
        let u_t = sampler.next_1d();
        // After the first flight both strategies could have drawn this direction; a guided
        // flight towards the surface (mu > 0) sees its extinction stretched by 1 - mu / nu.
        let mixed = event > 0 && guide;
        let mu = ray.dir.dot(n_out).clamp(-1.0, 1.0);
        // Towards the entry surface (forward) and towards the far side (backward, the
        // guide mirrored about the entry plane).
        let (stretch_f, stretch_b) = (1.0 - mu / nu, 1.0 + mu / nu);
        let stretch = match (mixed && guided_now, backward_now) {
            (false, _) => 1.0,
            (true, false) => stretch_f,
            (true, true) => stretch_b,
        };
        let sample_sigma = sigma_t[ch] * stretch;
        let t = if sample_sigma > 0.0 {
            -(1.0 - u_t).ln() / sample_sigma
        } else {
            f32::INFINITY
        };
        let hit = if event == 0 && guide {
            // Look 10 mean free paths (of the least extinct wavelength) ahead for the far side.
            let reach = (0..n).map(|i| sigma_t[i]).fold(f32::INFINITY, f32::min);
            let ahead = geometry.intersect(&ray, t.max(10.0 / reach.max(1e-30)));
            if let Some(h) = ahead {
                opposite_depth = Some((ray.at(h.t) - entry).dot(-n_out).max(0.0));
            }
            ahead.filter(|h| h.t < t)
        } else {
            geometry.intersect(&ray, t)
        };
        let d = match hit {
            Some(h) => h.t,
            None if t.is_finite() => t,
            None => return None,
        };
        // Transmittances over d relative to the one sampled (the common factor cancels in
        // f / p; bounded by e^17, as the flight is at most ~17 of the sampled mean free paths).
        let rel =
            |s: f32| SampledSpectrum::from_fn(|i| (-(sigma_t[i] * s - sample_sigma) * d).exp());
        // f_j / sum of the strategies' densities: reaching the surface passes it with
        // probability T(d), a scattering event at d has density sigma_t T(d) and contributes
        // sigma_s,j T_j(d) (times the phase function, which the classical direction density
        // cancels; the guided one enters as its ratio to it).
        let classic = rel(1.0);
        let (f, p_classic) = if hit.is_some() {
            (classic, classic)
        } else {
            (sigma_s * classic, sigma_t * classic)
        };
        let mut denominator = (choice * p_classic).sum();
        if mixed {
            // Dwivedi's cosine density about the normal (forward) or its mirror (backward),
            // and its stretched flight densities, relative to the phase function's.
            let guided = |s: f32, cos: f32| {
                let gd = rel(s);
                let p = if hit.is_some() { gd } else { sigma_t * s * gd };
                let q = 1.0 / (2.0 * std::f32::consts::PI * log_nu * (nu - cos));
                q * (choice * p).sum()
            };
            let mut p_guided = (1.0 - backward_fraction) * guided(stretch_f, mu);
            if backward_fraction > 0.0 {
                p_guided += backward_fraction * guided(stretch_b, -mu);
            }
            denominator = (1.0 - guided_fraction) * denominator
                + guided_fraction * p_guided / phase_pdf.max(1e-30);
        }
        *beta = SampledSpectrum::from_fn(|j| {
            if j < n {
                beta[j] * f[j] / denominator
            } else {
                0.0
            }
        });
        if !beta.is_finite() {
            return None;
        }
        if let Some(hit) = hit {
            return Some((hit, ray));
        }
        // The next direction: from the phase function, or Dwivedi's cosine density
        // 1 / (2 pi ln((nu + 1) / (nu - 1)) (nu - mu)) about the outward normal, inverted.
        let u2 = sampler.next_2d();
        guided_now = guide && sampler.next_1d() < guided_fraction;
        // With a far side found, the guide aims at it the more, the deeper the walk is: a
        // logistic in the depth x below the entry, even at the middle, D / 2 (the recorded
        // presentation of d'Eon & Krivanek 2020, as Cycles).
        let position = ray.at(t);
        backward_fraction = match opposite_depth {
            Some(depth) if guide => {
                let x = (position - entry).dot(-n_out).clamp(0.0, depth);
                1.0 / (1.0 + ((depth - 2.0 * x) / decay_length).exp())
            }
            _ => 0.0,
        };
        backward_now =
            guided_now && backward_fraction > 0.0 && sampler.next_1d() < backward_fraction;
        let new_dir = if guided_now {
            let mu = (nu - (nu + 1.0) * (-u2.x * log_nu).exp()).clamp(-1.0, 1.0);
            let sin = (1.0 - mu * mu).max(0.0).sqrt();
            let axis = if backward_now { -n_out } else { n_out };
            Frame::from_normal(axis)
                .to_world(spherical_direction(sin, mu, TAU * u2.y))
                .normalize()
        } else {
            sample_hg(ray.dir, g, u2.x, u2.y)
        };
        // Only the guided events' MIS needs the phase function's density.
        if guide {
            phase_pdf = hg_phase(ray.dir.dot(new_dir), g);
        }
        ray = Ray::new_at(position, new_dir, ray.time);
        // Russian roulette on the largest throughput against the walk's start (every 4th
        // event: survivors are boosted back to it).
        if event >= RR_START && event % 4 == 0 {
            let w_max = beta.max_component() / beta_start;
            if !(w_max > 0.0) {
                return None;
            }
            if w_max < 1.0 {
                let q = (1.0 - w_max).clamp(0.0, 0.95);
                if sampler.next_1d() < q {
                    return None;
                }
                *beta /= 1.0 - q;
            }
        }
    }
    None
}

/// The probability of a guided event: Dwivedi's guide assumes isotropic scattering, so it
/// takes half the events at g = 0 (measured on the SSS Cornell box's jade: 0.84x the noise;
/// a quarter gave no gain) and fades out as the phase function grows anisotropic, where the
/// phase function's own sampling matches the transport better.
fn guided_fraction(g: f32) -> f32 {
    0.5 * (1.0 - g.abs()).clamp(0.0, 1.0).powi(4)
}

/// Total diffuse reflectance of a random walk with a Lambertian boundary (every walk that
/// reaches the boundary leaves) in a half-space, per entry direction and single-scattering
/// albedo: what a walk entering a flat surface returns on average, for light that leaves
/// where it entered after a diffuse bounce (`PathTracer::with_full_indirect_subsurface`).
/// Exact for isotropic scattering (`isotropic`, from Chandrasekhar's H-function); for an
/// anisotropic phase function tabulated by simulation once per anisotropy: walks without
/// absorption, each recording its number n of scattering events, give R(alpha) = mean(alpha^n)
/// for every albedo at once.
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
        if g == 0.0 {
            return Self::isotropic(&alpha);
        }
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

    /// The exact table for isotropic scattering: an index-matched half-space lit from
    /// direction mu0 reflects R = 1 - H(mu0) sqrt(1 - alpha) in total (Chandrasekhar 1960,
    /// "Radiative Transfer", ch. V), with H from `chandrasekhar_h`: ~6 ms of CPU time where
    /// the simulation took ~100 ms (50 ms of a scene's start-up on two threads), and without
    /// its noise.
    fn isotropic(alpha: &[f64]) -> Self {
        let mut table = vec![0.0f32; Self::COSINE_NODES * Self::ALBEDO_NODES];
        let cosines: Vec<f64> = (1..=Self::COSINE_NODES)
            .map(|c| c as f64 / Self::COSINE_NODES as f64)
            .collect();
        for (k, &a) in alpha.iter().enumerate() {
            let h = chandrasekhar_h(a, &cosines);
            for (c, hc) in h.iter().enumerate() {
                table[c * Self::ALBEDO_NODES + k] = (1.0 - hc * (1.0 - a).max(0.0).sqrt()) as f32;
            }
        }
        LambertianWalkReflectance { table }
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

/// Chandrasekhar's H-function for isotropic scattering with single-scattering albedo `alpha`
/// at each of `mu`, by its closed form (Chandrasekhar 1960, ch. V, eq. 41):
/// ln H(mu) = -(mu / pi) int_0^inf ln(1 - alpha arctan(t) / t) / (1 + mu^2 t^2) dt.
/// With t = tan(theta) the integral runs over theta in (0, pi / 2) with integrand
/// ln(1 - alpha theta cot(theta)) / (cos^2 theta + mu^2 sin^2 theta); theta = (pi / 2) u^2
/// puts the nodes where the logarithm is steep (near 0 for alpha near 1, where it becomes
/// ln(theta^2 / 3)), and u takes 2048 midpoints: H(1) within 1e-5 of Chandrasekhar's table.
fn chandrasekhar_h(alpha: f64, mu: &[f64]) -> Vec<f64> {
    const NODES: usize = 2048;
    let half_pi = std::f64::consts::FRAC_PI_2;
    let mut integral = vec![0.0f64; mu.len()];
    for i in 0..NODES {
        let u = (i as f64 + 0.5) / NODES as f64;
        let theta = half_pi * u * u;
        let dtheta = half_pi * 2.0 * u / NODES as f64;
        let (sin, cos) = theta.sin_cos();
        let log = (1.0 - alpha * theta * cos / sin).ln();
        for (sum, &m) in integral.iter_mut().zip(mu) {
            *sum += log * dtheta / (cos * cos + m * m * sin * sin);
        }
    }
    mu.iter()
        .zip(&integral)
        .map(|(&m, &sum)| (-m / std::f64::consts::PI * sum).exp())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks of `chandrasekhar_h` against exact properties of H (Chandrasekhar 1960, ch. V):
    /// its zeroth moment int_0^1 H dmu = (2 / alpha) (1 - sqrt(1 - alpha)) (2 when conservative),
    /// the conservative first moment 2 / sqrt(3), the conservative H(1) = 2.90781 of his table,
    /// and the fixed point of the integral equation (the form the half-space walk test uses).
    #[test]
    fn h_function_matches_chandrasekhars_identities() {
        let grid: Vec<f64> = (0..400).map(|i| (i as f64 + 0.5) / 400.0).collect();
        for alpha in [1.0f64, 0.99, 0.9, 0.5] {
            let h = chandrasekhar_h(alpha, &grid);
            let m0 = h.iter().sum::<f64>() / 400.0;
            let want = 2.0 / alpha * (1.0 - (1.0 - alpha).sqrt());
            assert!(
                (m0 - want).abs() < 1e-5,
                "alpha {alpha}: moment {m0} vs {want}"
            );
            if alpha == 1.0 {
                let m1 = grid.iter().zip(&h).map(|(m, x)| m * x).sum::<f64>() / 400.0;
                assert!((m1 - 2.0 / 3f64.sqrt()).abs() < 1e-5, "first moment {m1}");
            }
        }
        let h1 = chandrasekhar_h(1.0, &[1.0])[0];
        assert!((h1 - 2.90781).abs() < 2e-5, "H(1) = {h1}");
        let alpha = 0.9f64;
        let mut hg = vec![1.0f64; grid.len()];
        let s = (1.0 - alpha).sqrt();
        let at = |h: &[f64], m: f64| {
            let integral: f64 = grid.iter().zip(h).map(|(&x, &hx)| x * hx / (m + x)).sum();
            1.0 / (s + alpha / 2.0 * integral / grid.len() as f64)
        };
        for _ in 0..200 {
            hg = grid.iter().map(|&m| at(&hg, m)).collect();
        }
        for m in [1.0, 0.3] {
            let want = at(&hg, m);
            let got = chandrasekhar_h(alpha, &[m])[0];
            assert!((got - want).abs() < 1e-3 * want, "mu {m}: {got} vs {want}");
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
