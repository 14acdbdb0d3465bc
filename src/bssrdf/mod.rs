//! Subsurface scattering.
//!
//! Two methods, selected per material by the sidecar's `subsurface.method`:
//!
//! * `"table"` (default): the separable BSSRDF of Jensen et al. 2001 (eq. 1 with the
//!   separable approximation popularised by pbrt-v3, section 11.4)
//!   S(po, wo, pi, wi) = (1 - Fr(cos theta_o)) Sp(|po - pi|) Sw(wi), with the radial profile
//!   Sp from a photon-beam-diffusion table (`table.rs`). The path tracer samples the rough
//!   dielectric boundary at the entry point; a transmission sample triggers `sample_probe`,
//!   which finds an exit point with probe rays (axis 0.5/0.25/0.25 along normal/tangents, a
//!   segment of length 2 r_max, every hit on the same material from one BVH traversal
//!   (`probe_hits`), one chosen in proportion to its estimate) and returns the sum of the
//!   hits' Sp / pdf, the pdf combining all three axes and all of the path's wavelengths
//!   (spectral MIS: one-sample balance heuristic over the wavelength that drove the radius,
//!   chosen in proportion to its effective albedo).
//!   The exit point then gets next-event estimation with the Sw lobe (`SwLobe`).
//! * `"random_walk"`: a volumetric random walk inside the closed mesh (`random_walk.rs`). Where
//!   the walk reaches the boundary from inside, what the boundary does is `WalkBoundary`: in
//!   both models the light that leaves does so with a fixed exit lobe (`ExitLobe`), so the
//!   exit point gets next-event estimation exactly like a table exit.
//!
//! Coefficients are RGB triples in 1 / scene unit, upsampled to unbounded spectra, so every
//! wavelength of the path has its own profile. A material given by a colour (reflectance +
//! mean free path, or Blender's colour + radius) may have that colour textured by its shading
//! graph: the medium is then derived at each entry point (`SubsurfaceMaterial::at`), as Cycles
//! derives its coefficients from the closure's albedo where the path enters.

pub mod media;
pub mod random_walk;
pub mod table;

use crate::bsdf::fresnel_dielectric;
use crate::geometry::{offset_ray_origin, Geometry, Ray, SurfacePoint};
use crate::math::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use crate::math::{Frame, INV_PI};
use crate::scene::{SubsurfaceCoefficients, SubsurfaceDesc};
use crate::spectrum::{
    RgbAlbedoSpectrum, RgbUnboundedSpectrum, SampledSpectrum, SampledWavelengths, LAMBDA_MAX,
    LAMBDA_MIN, N_WAVELENGTHS,
};
use glam::{Vec2, Vec3};
use std::sync::Arc;
pub use table::BssrdfTable;

/// Probe hits kept per sample (a ray through a thin, folded object rarely sees more).
const MAX_PROBE_HITS: usize = 16;
/// Probe axis probabilities: tangent s, tangent t, normal. pbrt and Cycles use 1/4, 1/4, 1/2.
/// Where the surface is flat on the scale of the mean free path (most of most objects) a
/// tangent probe runs parallel to it and misses, which ends the path: 35% of tangent probes
/// missed in the SSS Cornell box. Normal probes 3/4 of the time: 64-spp bulk noise -14% there,
/// -22% on scenes/sss/skin_pair, -17% on scenes/sss_presets (7/8 gained a few percent more but
/// weights tangent hits on thin, curved parts 4x higher than pbrt's choice; 3/4 keeps it 2x).
pub const AXIS_PROB: [f32; 3] = [0.125, 0.125, 0.75];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubsurfaceMethod {
    Table,
    RandomWalk,
}

/// The boundary of a random-walk medium (sidecar `subsurface.boundary`).
///
/// A smooth dielectric boundary taken literally lets a walk leave only through a Dirac
/// refraction, which next-event estimation cannot sample: delta lights (sun, point, spot) would
/// never light the object directly, and small area lights only through BSDF-sampled hits. Both
/// models below therefore let the transmitted light leave with a fixed lobe sampled at the exit
/// point, which then gets next-event estimation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkBoundary {
    /// `"dielectric"` (default). Entry: the (rough) dielectric BSDF, exactly. At the walk's
    /// exit the dielectric BSDF is sampled for the walk's incident direction: internal
    /// reflection (Fresnel, total internal reflection included) continues the walk with the
    /// interface's own direction and weight; a transmission keeps its weight (the interface's
    /// transmittance for that direction, times eta^2: radiance is eta^2 denser inside) and
    /// only its direction is replaced by one from Sw = (1 - Fr(cos)) / (c pi). Sw is the exit
    /// distribution of isotropic internal radiance through the smooth interface (the exit lobe
    /// of the separable BSSRDF, Jensen et al. 2001; pbrt-v3 section 11.4.1), so the model is
    /// exact where the radiance reaching the boundary from inside is isotropic, the diffusion
    /// regime, and keeps the energy that leaves for every incident direction exactly, so the
    /// white furnace stays exact.
    Dielectric,
    /// `"lambertian"`: Cycles' random walk (Chiang, Kutz, Burley 2016, "Practical and
    /// Controllable Subsurface Scattering for Production Path Tracing"): the surface's
    /// (rough) dielectric reflects and refracts at entry as usual, and every walk that reaches
    /// the boundary leaves through it with a Lambertian lobe (no internal Fresnel reflection,
    /// no eta^2 radiance factors at entry or exit). Against Cycles 5.0's Random Walk, a
    /// refracted entry matched within 2% on a sphere where a cosine entry was 4-9% too bright.
    Lambertian,
}

/// The direction distribution of light leaving a subsurface medium at an exit point (table
/// exits and random-walk exits), normalised: \int f cos dw = 1 over the outer hemisphere.
#[derive(Clone, Copy, Debug)]
pub enum ExitLobe {
    Sw(SwLobe),
    Lambertian,
}

impl ExitLobe {
    /// The lobe for a direction with `cos_theta` to the outward normal (0 below the surface).
    pub fn eval(&self, cos_theta: f32) -> f32 {
        match self {
            ExitLobe::Sw(sw) => sw.eval(cos_theta),
            ExitLobe::Lambertian if cos_theta > 0.0 => INV_PI,
            ExitLobe::Lambertian => 0.0,
        }
    }

    /// Both lobes are sampled with the cosine distribution.
    pub fn pdf(&self, cos_theta: f32) -> f32 {
        if cos_theta > 0.0 {
            cosine_hemisphere_pdf(cos_theta)
        } else {
            0.0
        }
    }

    /// Cosine-weighted direction in the local frame (outward normal = +z).
    pub fn sample(&self, u: Vec2) -> Vec3 {
        sample_cosine_hemisphere(u)
    }
}

/// A subsurface material's runtime data (built once per material instance).
#[derive(Clone, Debug)]
pub struct SubsurfaceMaterial {
    pub table: Arc<BssrdfTable>,
    pub coefficients: media::Coefficients,
    /// Reduced extinction sigma_a + sigma_s (1 - g), upsampled as an unbounded spectrum.
    pub sigma_t: RgbUnboundedSpectrum,
    /// Single-scattering albedo per nanometre from LAMBDA_MIN (see `spectral_albedo`).
    albedo: Vec<f32>,
    pub g: f32,
    pub eta: f32,
    /// GGX alpha of the boundary (perceptual roughness squared).
    pub alpha: f32,
    pub method: SubsurfaceMethod,
    /// What a random walk's boundary does (see `WalkBoundary`).
    pub boundary: WalkBoundary,
    /// Exit lobe normalisation c = 1 - 2 Fm1_external(eta).
    sw_norm: f32,
    /// How a colour becomes coefficients, for a textured colour (None: the material is not
    /// given by a colour).
    colour_map: Option<ColourMap>,
    /// A random walk with a Lambertian boundary: its reflectance on a flat surface, for light
    /// that leaves where it entered (`SubsurfaceAt::collapsed_albedo`). The table's rho_eff
    /// counts internal reflection that boundary does not have.
    walk_reflectance: Option<Arc<random_walk::LambertianWalkReflectance>>,
}

/// The colour-to-coefficients rule of a material given by a colour (see `media`).
#[derive(Clone, Copy, Debug)]
enum ColourMap {
    /// Reflectance with this mean free path (`media::invert_reflectance`), times `scale`.
    Reflectance { mfp: Vec3, scale: f32 },
    /// Blender's random walk with this radius (`media::cycles_walk`), times `scale`.
    CyclesWalk {
        radius: Vec3,
        skin: bool,
        scale: f32,
    },
}

/// A subsurface medium where a path enters it: the material's own, or the one a textured
/// colour gives at that point (`SubsurfaceMaterial::at`). Dereferences to the material for
/// what a colour does not change (method, boundary, anisotropy, exit lobe).
#[derive(Clone, Copy, Debug)]
pub struct SubsurfaceAt<'a> {
    pub medium: &'a SubsurfaceMaterial,
    /// Spectra of the point's colour: extinction and normalised effective albedo (as
    /// `spectral_albedo` upsamples them), evaluated at the path's wavelengths only.
    local: Option<(RgbUnboundedSpectrum, RgbAlbedoSpectrum)>,
}

impl std::ops::Deref for SubsurfaceAt<'_> {
    type Target = SubsurfaceMaterial;
    fn deref(&self) -> &SubsurfaceMaterial {
        self.medium
    }
}

impl SubsurfaceMaterial {
    pub fn new(desc: &SubsurfaceDesc) -> Self {
        let table = table_for_eta(desc.eta);
        let lambertian_walk = desc.method == "random_walk" && desc.boundary == "lambertian";
        let coefficients = media::coefficients(desc, &table);
        let r = desc.roughness.clamp(0.0, 1.0);
        SubsurfaceMaterial {
            sigma_t: RgbUnboundedSpectrum::new(coefficients.sigma_a + coefficients.sigma_s_reduced),
            albedo: spectral_albedo(&table, &coefficients),
            coefficients,
            table,
            g: desc.g,
            eta: desc.eta,
            alpha: r * r,
            method: if desc.method == "random_walk" {
                SubsurfaceMethod::RandomWalk
            } else {
                SubsurfaceMethod::Table
            },
            boundary: if desc.boundary == "lambertian" {
                WalkBoundary::Lambertian
            } else {
                WalkBoundary::Dielectric
            },
            sw_norm: (1.0 - 2.0 * table::fresnel_moment_external(desc.eta, 1)) as f32,
            walk_reflectance: lambertian_walk.then(|| lambertian_walk_reflectance(desc.g)),
            colour_map: match desc.coefficients {
                SubsurfaceCoefficients::Reflectance { mfp, .. } => Some(ColourMap::Reflectance {
                    mfp,
                    scale: desc.scale,
                }),
                SubsurfaceCoefficients::CyclesWalk { radius, skin, .. } => {
                    Some(ColourMap::CyclesWalk {
                        radius,
                        skin,
                        scale: desc.scale,
                    })
                }
                _ => None,
            },
        }
    }

    /// The material can take a textured colour (it is given by a colour).
    pub fn has_colour(&self) -> bool {
        self.colour_map.is_some()
    }

    /// The medium where a path enters: with `colour` (linear RGB, clamped to [0, 1]) in place
    /// of the material's own when the material is given by a colour; else the material's.
    pub fn at(&self, colour: Option<Vec3>) -> SubsurfaceAt<'_> {
        let local = match (colour, self.colour_map) {
            (Some(c), Some(map)) => {
                let c = c.clamp(Vec3::ZERO, Vec3::ONE);
                let (coefficients, scale) = match map {
                    ColourMap::Reflectance { mfp, scale } => {
                        (media::invert_reflectance(&self.table, c, mfp), scale)
                    }
                    ColourMap::CyclesWalk {
                        radius,
                        skin,
                        scale,
                    } => (media::cycles_walk(c, radius, skin, self.g, self.eta), scale),
                };
                let sigma_t = (coefficients.sigma_a + coefficients.sigma_s_reduced) * scale;
                Some((
                    RgbUnboundedSpectrum::new(sigma_t.max(Vec3::ZERO)),
                    RgbAlbedoSpectrum::new(normalised_effective_albedo(&self.table, &coefficients)),
                ))
            }
            _ => None,
        };
        SubsurfaceAt {
            medium: self,
            local,
        }
    }

    /// (sigma_a, reduced sigma_s) of the material's own colour for the path's wavelengths.
    fn own_coefficients_at(&self, w: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let sigma_t = self.sigma_t.sample(w);
        let rho = SampledSpectrum::from_fn(|i| {
            let x = (w.lambda[i] - LAMBDA_MIN).clamp(0.0, (self.albedo.len() - 1) as f32);
            let k = (x as usize).min(self.albedo.len() - 2);
            let t = x - k as f32;
            self.albedo[k] * (1.0 - t) + self.albedo[k + 1] * t
        });
        let sigma_s = rho * sigma_t;
        (sigma_t - sigma_s, sigma_s)
    }

    /// (sigma_a, reduced sigma_s) for the path's wavelengths (the material's own colour).
    pub fn coefficients_at(&self, w: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        self.at(None).coefficients_at(w)
    }

    /// The separable BSSRDF for the path's wavelengths (the material's own colour).
    pub fn bssrdf(&self, w: &SampledWavelengths) -> SeparableBssrdf<'_> {
        self.at(None).bssrdf(w)
    }

    /// Exit lobe Sw at the exit point.
    pub fn sw(&self) -> SwLobe {
        SwLobe {
            eta: self.eta,
            norm: self.sw_norm,
        }
    }

    /// The exit lobe: Sw for a dielectric boundary (table exits and random-walk exits alike),
    /// Lambertian for a random walk with `boundary: "lambertian"`.
    pub fn exit_lobe(&self) -> ExitLobe {
        match (self.method, self.boundary) {
            (SubsurfaceMethod::RandomWalk, WalkBoundary::Lambertian) => ExitLobe::Lambertian,
            _ => ExitLobe::Sw(self.sw()),
        }
    }
}

impl<'a> SubsurfaceAt<'a> {
    /// (sigma_a, reduced sigma_s) for the path's wavelengths.
    pub fn coefficients_at(&self, w: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let Some((sigma_t, effective)) = &self.local else {
            return self.medium.own_coefficients_at(w);
        };
        let sigma_t = sigma_t.sample(w);
        let rho = SampledSpectrum::from_fn(|i| {
            albedo_of_effective(&self.medium.table, effective.eval(w.lambda[i]))
        });
        let sigma_s = rho * sigma_t;
        (sigma_t - sigma_s, sigma_s)
    }

    /// Total diffuse reflectance of the medium (rho_eff of the single-scattering albedo) per
    /// wavelength: the colour the material shows, used as the albedo guide for denoising.
    pub fn effective_albedo(&self, w: &SampledWavelengths) -> SampledSpectrum {
        let (sigma_a, sigma_s) = self.coefficients_at(w);
        let rho = single_scattering_albedo(sigma_a, sigma_s);
        SampledSpectrum::from_fn(|i| self.table.rho_eff_at(rho[i]))
    }

    /// The medium's total diffuse reflectance per wavelength for light entering a flat surface
    /// along a direction at `cos_entry` to the inward normal, for light that leaves where it
    /// entered (`PathTracer::with_full_indirect_subsurface`): the table's rho_eff (what the
    /// probe's weight averages, and a walk with a dielectric boundary returns up to diffusion's
    /// error), or for a walk with a Lambertian boundary its own tabulated reflectance.
    pub fn collapsed_albedo(&self, w: &SampledWavelengths, cos_entry: f32) -> SampledSpectrum {
        let Some(walk) = &self.walk_reflectance else {
            return self.effective_albedo(w);
        };
        let (sigma_a, sigma_s) = self.walk_coefficients(w);
        let alpha = single_scattering_albedo(sigma_a, sigma_s);
        SampledSpectrum::from_fn(|i| walk.at(cos_entry, alpha[i]))
    }

    /// The separable BSSRDF for the path's wavelengths.
    pub fn bssrdf(&self, w: &SampledWavelengths) -> SeparableBssrdf<'a> {
        let (sigma_a, sigma_s) = self.coefficients_at(w);
        SeparableBssrdf::new(&self.medium.table, sigma_a, sigma_s, active_wavelengths(w))
    }

    /// (sigma_a, full sigma_s) for the random walk.
    pub fn walk_coefficients(&self, w: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        let k = 1.0 / (1.0 - self.g).max(1e-3);
        let (sigma_a, sigma_s) = self.coefficients_at(w);
        (sigma_a, sigma_s * k)
    }
}

/// Single-scattering albedo per nanometre that reproduces the RGB effective albedo.
///
/// Upsampling sigma_a and sigma_s separately gives a per-wavelength albedo that is a non-linear
/// function of the RGB inputs, and rho_eff is steep near albedo 1: Skin1 lost ~20% of its red
/// that way. Instead the RGB effective albedo rho_eff(rho_rgb) (what a user sees as the
/// material's colour) is upsampled as a reflectance spectrum (Jakob & Hanika 2019; normalised by
/// rho_eff(1) so that a non-absorbing medium stays exactly non-absorbing), and each wavelength's
/// albedo is the table inversion of it. The mean free path follows the upsampled sigma_t.
fn spectral_albedo(table: &BssrdfTable, c: &media::Coefficients) -> Vec<f32> {
    let spectrum = RgbAlbedoSpectrum::new(normalised_effective_albedo(table, c));
    let n = (LAMBDA_MAX - LAMBDA_MIN) as usize + 1;
    (0..n)
        .map(|k| albedo_of_effective(table, spectrum.eval(LAMBDA_MIN + k as f32)))
        .collect()
}

/// The RGB effective albedo rho_eff(rho) of coefficients `c`, over rho_eff(1) (see
/// `spectral_albedo`).
fn normalised_effective_albedo(table: &BssrdfTable, c: &media::Coefficients) -> Vec3 {
    let eff_max = table.rho_eff[table.rho_eff.len() - 1];
    let st = c.sigma_a + c.sigma_s_reduced;
    Vec3::from_array(std::array::from_fn(|i| {
        let rho = if st[i] > 0.0 {
            (c.sigma_s_reduced[i] / st[i]).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (table.rho_eff_at(rho) / eff_max).clamp(0.0, 1.0)
    }))
}

/// The single-scattering albedo whose effective albedo is `e` x rho_eff(1) (`e` normalised as
/// `normalised_effective_albedo`'s, upsampled).
fn albedo_of_effective(table: &BssrdfTable, e: f32) -> f32 {
    let e = e.clamp(0.0, 1.0);
    if e >= 1.0 - 1e-6 {
        1.0
    } else {
        table.invert_rho_eff(e * table.rho_eff[table.rho_eff.len() - 1])
    }
}

/// The profile table for a boundary IOR, built once per process and shared by every material
/// with the same `eta` (a build takes ~50 ms of CPU time, its rows in parallel).
pub fn table_for_eta(eta: f32) -> Arc<BssrdfTable> {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    static CACHE: OnceLock<Mutex<HashMap<u32, Arc<BssrdfTable>>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    let mut map = cache.lock().unwrap_or_else(|e| e.into_inner());
    map.entry(eta.to_bits())
        .or_insert_with(|| Arc::new(BssrdfTable::new(eta)))
        .clone()
}

/// Single-scattering albedo sigma_s / (sigma_a + sigma_s) per wavelength (0 where the medium
/// neither absorbs nor scatters).
fn single_scattering_albedo(sigma_a: SampledSpectrum, sigma_s: SampledSpectrum) -> SampledSpectrum {
    SampledSpectrum::from_fn(|i| {
        let sigma_t = sigma_a[i] + sigma_s[i];
        if sigma_t > 0.0 {
            sigma_s[i] / sigma_t
        } else {
            0.0
        }
    })
}

/// The Lambertian walk's reflectance table for anisotropy `g`, built once per process and `g`.
fn lambertian_walk_reflectance(g: f32) -> Arc<random_walk::LambertianWalkReflectance> {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    type Cache = Mutex<HashMap<u32, Arc<random_walk::LambertianWalkReflectance>>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    let mut map = cache.lock().unwrap_or_else(|e| e.into_inner());
    map.entry(g.to_bits())
        .or_insert_with(|| Arc::new(random_walk::LambertianWalkReflectance::new(g)))
        .clone()
}

/// Number of wavelengths still carried by the path (1 after a dispersive termination).
pub fn active_wavelengths(w: &SampledWavelengths) -> usize {
    if w.secondary_terminated() {
        1
    } else {
        N_WAVELENGTHS
    }
}

/// The exit lobe of the separable BSSRDF (sampled through [`ExitLobe`]):
/// Sw(wi) = (1 - Fr(cos theta_i)) / (c pi), with c = 1 - 2 Fm1 so that \int Sw cos dw = 1
/// (pbrt-v3 section 11.4.1's normalisation).
#[derive(Clone, Copy, Debug)]
pub struct SwLobe {
    eta: f32,
    norm: f32,
}

impl SwLobe {
    /// Sw for a direction with `cos_theta` to the outward normal (0 below the surface).
    pub fn eval(&self, cos_theta: f32) -> f32 {
        if !(cos_theta > 0.0) {
            return 0.0;
        }
        (1.0 - fresnel_dielectric(cos_theta, self.eta)) * INV_PI / self.norm
    }
}

/// A surface the probe crossed: the hit, its point and geometric normal (up to sign).
#[derive(Clone, Copy, Debug)]
struct ProbeHit {
    hit: crate::geometry::Hit,
    p: Vec3,
    ng: Vec3,
}

/// The surfaces of `material` along the probe segment `ray.origin + t ray.dir`, t in
/// (0, `length`), in order along it (at most `MAX_PROBE_HITS`), and their number (only the
/// one the path continues from needs its whole `SurfacePoint`). A hit less than a ray offset
/// (`offset_ray_origin`) beyond the previous one is that surface again (the second triangle of
/// an edge the probe crosses), as for a ray restarted past each hit.
fn probe_hits(
    geometry: &Geometry,
    material: u32,
    ray: Ray,
    length: f32,
) -> ([Option<ProbeHit>; MAX_PROBE_HITS], usize) {
    // Bounded: a grazing probe could otherwise crawl along a surface of another material.
    const MAX_STEPS: usize = 4 * MAX_PROBE_HITS;
    let mut hits = [None; MAX_PROBE_HITS];
    let mut count = 0usize;
    // All intersections from one traversal, sorted along the segment (one closest-hit query
    // per surface traversed the BVH once per hit: probes cross 2-4 surfaces). The buffer holds
    // as many as a probe keeps; more is rare and takes the slow path below.
    let mut found = [None; MAX_PROBE_HITS];
    let mut n = 0usize;
    geometry.for_each_hit(&ray, length, |hit| {
        if let Some(slot) = found.get_mut(n) {
            *slot = Some(hit);
        }
        n += 1;
    });
    if n > found.len() {
        // More surfaces than the buffer (a probe along a fold or through a detailed mesh):
        // the first MAX_STEPS along the segment, by successive closest-hit queries.
        let mut origin = ray.origin;
        let mut remaining = length;
        for _ in 0..MAX_STEPS {
            if !(remaining > 0.0) || count == MAX_PROBE_HITS {
                break;
            }
            let Some(hit) = geometry.intersect(&Ray::new_at(origin, ray.dir, ray.time), remaining)
            else {
                break;
            };
            let (p, ng, hit_material) = geometry.hit_point(&hit);
            if hit_material == material {
                hits[count] = Some(ProbeHit { hit, p, ng });
                count += 1;
            }
            let next = offset_ray_origin(p, ng, ray.dir);
            remaining -= (next - origin).dot(ray.dir);
            origin = next;
        }
        return (hits, count);
    }
    let found = &mut found[..n];
    found.sort_unstable_by(|a, b| {
        let t = |h: &Option<crate::geometry::Hit>| h.map_or(f32::INFINITY, |h| h.t);
        t(a).total_cmp(&t(b))
    });
    // Where the segment resumes past the last surface (distance along it from the origin).
    let mut resume = 0.0f32;
    for hit in found.iter().flatten() {
        if hit.t <= resume {
            continue;
        }
        let (p, ng, hit_material) = geometry.hit_point(hit);
        resume = (offset_ray_origin(p, ng, ray.dir) - ray.origin).dot(ray.dir);
        if hit_material == material {
            hits[count] = Some(ProbeHit { hit: *hit, p, ng });
            count += 1;
            if count == MAX_PROBE_HITS {
                break;
            }
        }
    }
    (hits, count)
}

/// The separable BSSRDF's spatial part for the path's wavelengths.
#[derive(Clone, Copy, Debug)]
pub struct SeparableBssrdf<'a> {
    table: &'a BssrdfTable,
    sigma_t: SampledSpectrum,
    rho: SampledSpectrum,
    /// Wavelengths that take part in the radius sampling (1 or N).
    n_active: usize,
    /// Probe radius per wavelength (radius holding ~99.9% of the profile).
    r_max: [f32; N_WAVELENGTHS],
    /// Catmull-Rom weights of each wavelength's albedo in the table.
    albedo_w: [Option<(isize, [f32; 4])>; N_WAVELENGTHS],
    /// Effective albedo per wavelength (`rho_eff`) and the probability that each drives the
    /// radius (`channel_probability`): every probe hit's density needs all of them (16 table
    /// look-ups per hit when they were recomputed there), so they are computed once.
    rho_eff: SampledSpectrum,
    channel_probability: [f32; N_WAVELENGTHS],
}

/// An exit point found by the probe rays and its weight Sp / pdf (per wavelength).
#[derive(Clone, Copy, Debug)]
pub struct ProbeSample {
    pub point: SurfacePoint,
    pub weight: SampledSpectrum,
    /// Every exit point the probe found and its own estimate Sr / pdf (the chosen `point`
    /// among them, at `chosen`): `weight` is the sum of these estimates carried by one of
    /// them, so next-event estimation may instead visit each with its own.
    pub hits: [Option<(crate::geometry::Hit, SampledSpectrum)>; MAX_PROBE_HITS],
    pub chosen: usize,
}

impl<'a> SeparableBssrdf<'a> {
    /// `sigma_s` is the reduced scattering coefficient.
    pub fn new(
        table: &'a BssrdfTable,
        sigma_a: SampledSpectrum,
        sigma_s: SampledSpectrum,
        n_active: usize,
    ) -> Self {
        let sigma_t = sigma_a + sigma_s;
        let albedo = single_scattering_albedo(sigma_a, sigma_s);
        let rho = SampledSpectrum::from_fn(|i| albedo[i].clamp(0.0, 1.0));
        let r_max = std::array::from_fn(|i| {
            if sigma_t[i] > 0.0 {
                table.r_max_at(rho[i]) / sigma_t[i]
            } else {
                0.0
            }
        });
        let n_active = n_active.clamp(1, N_WAVELENGTHS);
        let rho_eff = SampledSpectrum::from_fn(|i| table.rho_eff_at(rho[i]));
        // In proportion to the effective albedo, the integral of the wavelength's profile, so
        // the mixture density over the wavelengths is the sum of the profiles (normalised) and
        // every wavelength's weight Sr / pdf stays below the sum of the albedos; uniform when
        // every albedo is 0.
        let total: f32 = rho_eff.0[..n_active].iter().sum();
        let channel_probability = std::array::from_fn(|ch| match ch < n_active {
            false => 0.0,
            true if total > 0.0 => rho_eff[ch] / total,
            true => 1.0 / n_active as f32,
        });
        SeparableBssrdf {
            table,
            sigma_t,
            rho,
            n_active,
            r_max,
            albedo_w: std::array::from_fn(|i| table.albedo_weights(rho[i])),
            rho_eff,
            channel_probability,
        }
    }

    /// Radial profile Sr(r) per wavelength (per unit area, in 1 / scene unit^2), so that
    /// \int_0^inf Sr(r) 2 pi r dr = rho_eff.
    pub fn sr(&self, r: f32) -> SampledSpectrum {
        SampledSpectrum::from_fn(|i| {
            let st = self.sigma_t[i];
            if !(st > 0.0) {
                return 0.0;
            }
            self.table.eval_with(self.albedo_w[i], r * st).0 * st * st
        })
    }

    /// Effective albedo per wavelength.
    pub fn rho_eff(&self) -> SampledSpectrum {
        self.rho_eff
    }

    pub fn r_max(&self, ch: usize) -> f32 {
        self.r_max[ch]
    }

    /// Samples a radius (scene units) from wavelength `ch`'s profile (the whole table range).
    pub fn sample_sr(&self, ch: usize, u: f32) -> Option<f32> {
        let st = self.sigma_t[ch];
        if !(st > 0.0) {
            return None;
        }
        let r = self.table.sample_radius(self.rho[ch], u)? / st;
        r.is_finite().then_some(r)
    }

    /// Area density (on a plane) of `sample_sr` for wavelength `ch` at radius r.
    pub fn pdf_sr(&self, ch: usize, r: f32) -> f32 {
        let st = self.sigma_t[ch];
        if !(st > 0.0) {
            return 0.0;
        }
        let (value, eff) = self.table.eval_with(self.albedo_w[ch], r * st);
        if !(eff > 0.0) {
            return 0.0;
        }
        (value * st * st / eff).max(0.0)
    }

    /// Probability that wavelength `ch` (active) drives the radius (see `new`).
    fn channel_probability(&self, ch: usize) -> f32 {
        self.channel_probability[ch]
    }

    /// Area density of an exit point `pi` (with geometric normal `ni`) over the three probe
    /// axes and the active wavelengths (before the choice among a probe's hits).
    pub fn pdf_sp(&self, po: Vec3, frame: &Frame, pi: Vec3, ni: Vec3) -> f32 {
        let d = pi - po;
        let dl = frame.to_local(d);
        let nl = frame.to_local(ni);
        let r_proj = [
            (dl.y * dl.y + dl.z * dl.z).sqrt(),
            (dl.z * dl.z + dl.x * dl.x).sqrt(),
            (dl.x * dl.x + dl.y * dl.y).sqrt(),
        ];
        let mut pdf = 0.0;
        let ch_prob = self.channel_probability;
        for axis in 0..3 {
            let cos = nl[axis].abs();
            if cos == 0.0 {
                continue;
            }
            for (ch, &p) in ch_prob.iter().enumerate().take(self.n_active) {
                if p > 0.0 {
                    pdf += self.pdf_sr(ch, r_proj[axis]) * cos * AXIS_PROB[axis] * p;
                }
            }
        }
        pdf
    }

    /// Finds an exit point around `po` on surfaces of material `material` with probe rays.
    /// `frame` is the shading frame at `po` (normal = frame.n); probes see the scene at shutter
    /// time `time`. `u_disk` is the point on the probe disk (angle, radius): the sampler's
    /// stratified pair, so a pixel's exit points cover the disk evenly; `u_axis` chooses the
    /// axis and then, rescaled, the wavelength that drives the radius. (With the radius from
    /// the rescaled axis number the disk's radius and angle came from a weaker pair of
    /// dimensions: 64 spp, SSS Cornell box, 2 pairs, noise on the skin sphere 1.72e-2 against
    /// 1.45e-2 now, marble 2.72e-2 against 2.63e-2.)
    #[allow(clippy::too_many_arguments)]
    pub fn sample_probe(
        &self,
        geometry: &Geometry,
        material: u32,
        po: Vec3,
        time: f32,
        frame: &Frame,
        u_axis: f32,
        u_disk: Vec2,
        u_hit: f32,
    ) -> Option<ProbeSample> {
        // Probe axis (vz) by `AXIS_PROB`: the normal, then tangent s, then tangent t.
        let [p_s, p_t, p_n] = AXIS_PROB;
        let (vx, vy, vz, u) = if u_axis < p_n {
            (frame.s, frame.t, frame.n, u_axis / p_n)
        } else if u_axis < p_n + p_s {
            (frame.t, frame.n, frame.s, (u_axis - p_n) / p_s)
        } else {
            (frame.n, frame.s, frame.t, (u_axis - p_n - p_s) / p_t)
        };
        let u = u.min(1.0 - f32::EPSILON);
        // Wavelength whose profile drives the radius (`channel_probability`).
        let mut ch = None;
        let mut acc = 0.0f32;
        for c in 0..self.n_active {
            let p = self.channel_probability(c);
            if p > 0.0 {
                ch = Some(c);
                if u < acc + p {
                    break;
                }
            }
            acc += p;
        }
        let ch = ch?;
        let r = self.sample_sr(ch, u_disk.y.min(1.0 - f32::EPSILON))?;
        // The probe spans the sphere of radius r_max around po. The rare radii beyond r_max
        // (0.1%) still get a short probe rather than failing: the radius density stays exactly
        // `pdf_sr`, so the estimator is unbiased on a plane.
        let r_max = self.r_max[ch].max(1.05 * r);
        let phi = 2.0 * std::f32::consts::PI * u_disk.x;
        let half = (r_max * r_max - r * r).max(0.0).sqrt();
        if !(half > 0.0) {
            return None;
        }
        let base = po + r * (vx * phi.cos() + vy * phi.sin()) - vz * half;
        let (hits, count) = probe_hits(geometry, material, Ray::new_at(base, vz, time), 2.0 * half);
        if count == 0 {
            return None;
        }
        // Every hit's estimate Sr / pdf; the path continues from one of them, chosen in
        // proportion to its (wavelength-averaged) estimate, with weight sum / chosen share: the
        // estimator is then the sum over all hits (what evaluating every hit would give) for
        // the cost of one continuation. Choosing uniformly (weight = count x the hit's
        // estimate) made a hit's share of the sum, not the sum, the noise: on curved and
        // folded objects most probes see 2-4 hits of very different weights (Cycles resamples
        // its disk hits the same way).
        let mut weights = [SampledSpectrum::ZERO; MAX_PROBE_HITS];
        let mut shares = [0f32; MAX_PROBE_HITS];
        let mut total = 0.0f32;
        for i in 0..count {
            let hit = hits[i]?;
            let pdf = self.pdf_sp(po, frame, hit.p, hit.ng);
            if !(pdf > 0.0) || !pdf.is_finite() {
                continue;
            }
            let w = self.sr((hit.p - po).length()) / pdf;
            if !w.is_finite() {
                continue;
            }
            let share = w.0[..self.n_active].iter().sum::<f32>().max(0.0);
            weights[i] = w;
            shares[i] = share;
            total += share;
        }
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        let target = u_hit * total;
        let mut acc = 0.0;
        let mut k = count;
        for (i, &share) in shares.iter().enumerate().take(count) {
            if share > 0.0 {
                k = i;
                if target < acc + share {
                    break;
                }
            }
            acc += share;
        }
        let point = geometry.surface_point(&hits.get(k).copied().flatten()?.hit);
        let weight = weights[k] * (total / shares[k]);
        let mut all = [None; MAX_PROBE_HITS];
        for i in 0..count {
            if shares[i] > 0.0 {
                all[i] = hits[i].map(|h| (h.hit, weights[i]));
            }
        }
        weight.is_finite().then_some(ProbeSample {
            point,
            weight,
            hits: all,
            chosen: k,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Instance, Mesh};

    /// Parallel 2 x 2 sheets at z = 0, 0.01, ..., 0.19, the even ones of material 0 and the
    /// odd ones of material 1, each two triangles whose shared diagonal passes through the
    /// z axis; and a second sheet of material 0 at z = 0.04 (a surface met twice at one
    /// distance, as where a probe crosses an edge both triangles report).
    fn stacked_sheets() -> Geometry {
        let sheets = |material: u32, ks: &mut dyn Iterator<Item = u32>| {
            let mut positions = Vec::new();
            let mut indices = Vec::new();
            for k in ks {
                let z = 0.01 * k as f32;
                let base = positions.len() as u32;
                positions.extend([
                    Vec3::new(-1.0, -1.0, z),
                    Vec3::new(1.0, -1.0, z),
                    Vec3::new(1.0, 1.0, z),
                    Vec3::new(-1.0, 1.0, z),
                ]);
                indices.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
            }
            Mesh::new(positions, None, None, indices, material)
        };
        Geometry::new(
            vec![
                sheets(0, &mut (0..20).step_by(2)),
                sheets(1, &mut (1..20).step_by(2)),
                sheets(0, &mut std::iter::once(4)),
            ],
            (0..3)
                .map(|m| Instance::new(m, glam::Affine3A::IDENTITY))
                .collect(),
        )
    }

    #[test]
    fn a_probe_reports_every_exit_with_its_own_estimate() {
        // Through the stacked sheets a normal probe finds several surfaces of material 0: each
        // is reported with its estimate, the chosen one among them, and the carried weight is
        // their sum (as the wavelengths' mean, the share the choice is made by).
        let geometry = stacked_sheets();
        let table = BssrdfTable::new(1.33);
        let bssrdf = SeparableBssrdf::new(
            &table,
            SampledSpectrum([0.5, 1.0, 2.0, 4.0]),
            SampledSpectrum::splat(5.0),
            N_WAVELENGTHS,
        );
        let frame = Frame::from_normal(Vec3::Z);
        let po = Vec3::new(0.1, 0.05, 0.08);
        let mut several = 0;
        for k in 0..64 {
            let u_disk = Vec2::new((k as f32 * 0.618).fract(), (k as f32 + 0.5) / 64.0);
            let u_hit = (k as f32 * 0.371).fract();
            let Some(s) = bssrdf.sample_probe(&geometry, 0, po, 0.0, &frame, 0.1, u_disk, u_hit)
            else {
                continue;
            };
            let found: Vec<_> = s.hits.iter().flatten().collect();
            several += usize::from(found.len() > 1);
            let (hit, w) = s.hits[s.chosen].expect("the chosen exit is among the hits");
            assert_eq!(geometry.surface_point(&hit).p, s.point.p);
            assert!(w.0.iter().all(|v| v.is_finite() && *v >= 0.0));
            let sum: f32 = found.iter().map(|(_, w)| w.average()).sum();
            let carried = s.weight.average();
            assert!(
                (carried - sum).abs() <= 1e-4 * sum.max(1e-6),
                "carried {carried} vs sum {sum}"
            );
        }
        assert!(several > 10, "{several} probes with several exits");
    }

    /// The exit point's place on the probe disk comes from `u_disk` alone, angle from x and
    /// radius from y, so the sampler's stratified pair stratifies the disk: on a plane, with
    /// one wavelength and the normal axis, the exit point does not depend on `u_axis`, its
    /// distance grows with y and its angle is 2 pi x. (Fails if the radius is drawn from the
    /// rescaled axis number, as it once was.)
    #[test]
    fn exit_point_on_a_plane_follows_the_disk_point() {
        let plane = Geometry::new(
            vec![Mesh::new(
                vec![
                    Vec3::new(-10.0, -10.0, 0.0),
                    Vec3::new(10.0, -10.0, 0.0),
                    Vec3::new(10.0, 10.0, 0.0),
                    Vec3::new(-10.0, 10.0, 0.0),
                ],
                None,
                None,
                vec![[0, 1, 2], [0, 2, 3]],
                0,
            )],
            vec![Instance::new(0, glam::Affine3A::IDENTITY)],
        );
        let table = BssrdfTable::new(1.33);
        let bssrdf = SeparableBssrdf::new(
            &table,
            SampledSpectrum::splat(1.0),
            SampledSpectrum::splat(10.0),
            1,
        );
        let frame = Frame::from_normal(Vec3::Z);
        let exit = |u_axis: f32, u_disk: Vec2| {
            let s = bssrdf.sample_probe(&plane, 0, Vec3::ZERO, 0.0, &frame, u_axis, u_disk, 0.5);
            s.expect("a normal probe always meets the plane").point.p
        };
        let mut last_r = 0.0;
        for k in 1..20 {
            let u_disk = Vec2::new(0.3, k as f32 / 20.0);
            let p = exit(0.05, u_disk);
            assert_eq!(p, exit(0.7, u_disk), "the axis number moved the exit point");
            let r = p.length();
            assert!(r > last_r, "radius {r} after {last_r} at y = {}", u_disk.y);
            last_r = r;
            let along = frame.s * (2.0 * std::f32::consts::PI * 0.3).cos()
                + frame.t * (2.0 * std::f32::consts::PI * 0.3).sin();
            assert!((p / r - along).length() < 1e-3, "angle of {p}");
        }
    }

    /// The z of the probe's hits, in order.
    fn probe_depths(geometry: &Geometry, origin: Vec3, length: f32) -> Vec<f32> {
        let (hits, count) = probe_hits(geometry, 0, Ray::new(origin, Vec3::Z), length);
        hits[..count].iter().map(|h| h.unwrap().p.z).collect()
    }

    /// Both ways of collecting a probe's hits (one traversal, up to `MAX_PROBE_HITS`
    /// surfaces; successive closest-hit queries past that) keep only the probe's material,
    /// in order along the probe, each surface once even where two hits coincide.
    #[test]
    fn probe_hits_are_the_materials_surfaces_in_order() {
        let geometry = stacked_sheets();
        let expect = |n: usize| (0..n).map(|k| 0.02 * k as f32).collect::<Vec<f32>>();
        let close = |got: &[f32], want: &[f32]| {
            got.len() == want.len() && got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-5)
        };
        for origin in [Vec3::new(0.3, -0.2, -0.005), Vec3::new(0.0, 0.0, -0.005)] {
            // 13 hits on the segment: one traversal; 6 surfaces of material 0.
            let got = probe_depths(&geometry, origin, 0.12);
            assert!(close(&got, &expect(6)), "from {origin}: {got:?}");
            // 21 hits, more than the buffer: the successive queries; 10 of material 0.
            let got = probe_depths(&geometry, origin, 0.2);
            assert!(close(&got, &expect(10)), "from {origin}: {got:?}");
        }
    }
}
