//! Directional albedos of single-scattering GGX lobes, tabulated, for energy compensation.
//!
//! A microfacet BSDF that scatters once per microfacet loses the light that would have left
//! after bouncing between microfacets: at roughness 1 a white conductor reflects about 60% at
//! grazing view instead of 100%. Two compensations use the tables here:
//!
//! - **Reflection lobes** (conductors, the Principled dielectric specular layer) are scaled by
//!   `1 + (F_ms / F_avg) (1 - E(mu_o)) / E(mu_o)`, where `E(mu)` is the directional albedo of
//!   the lobe with F = 1 and `F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg))` (Kulla & Conty
//!   2017, "Revisiting Physically Based Shading at Imageworks", the Fresnel-averaged series of
//!   bounces, `E_avg = 2 int E(mu) mu dmu`), which darkens and saturates coloured metals as
//!   interreflection does; with F = 1 the lobe reflects exactly 1. This is Cycles'
//!   `microfacet_ggx_preserve_energy`: the energy stays in the lobe's shape (a rough metal
//!   under a sun agrees with Cycles), at the cost of reciprocity (`metallic_roughness.rs`).
//! - **Rough dielectrics** (glass, transmission, subsurface boundaries) scale the
//!   single-scattering BSDF by `1 / E_T(mu_o, eta)`, the reciprocal of the albedo of reflection
//!   plus refraction (Turquin 2019, "Practical multiple scattering compensation for microfacet
//!   models", eq. 10 with F = 1: a dielectric interface absorbs nothing, so all lost energy is
//!   restored). Why this and not Kulla & Conty's dielectric extension: their extra lobe is
//!   cosine-shaped on both sides, but light that scatters several times between the facets
//!   of rough glass still leaves mostly around the refracted and mirror directions (Heitz et
//!   al. 2016, "Multiple-Scattering Microfacet BSDFs with the Smith Model", fig. 13), which
//!   the scaled single-scattering lobe keeps; sampling is unchanged (the same directions with
//!   the same density); the table works per wavelength for dispersive glass without a
//!   reflect/refract split table; and it is what Cycles does, so the two agree. The cost is
//!   reciprocity: the scale depends on `mu_o` only (`tests/bsdf_chi2.rs` bounds the
//!   deviation).
//!
//! The albedos are integrals over visible normals: a direction reflected or refracted by a
//! visible normal `wm ~ D_wo` has the weight `f |cos_i| / pdf = F G2(wo, wi) / G1(wo)` (Heitz
//! 2014, "Understanding the Masking-Shadowing Function", eq. 99 over eq. 38: D, the Jacobians
//! and the cosines cancel), with F the Fresnel term for reflection and 1 - F for refraction.
//! Transmission is counted as energy (without the radiance factor 1/eta^2).
//!
//! The tables are computed by `tools/ggx_energy.rs` (`prism-ggx-energy`) with the functions
//! below and stored in `data/ggx_energy.bin`; `tests/bsdf_chi2.rs` checks them against Monte
//! Carlo integrals of the BSDFs' own sampling.
//!
//! Parameters: roughness `r = sqrt(alpha)` (Blender's roughness) and `sqrt(mu)`, `mu = |cos
//! theta_o|`, on uniform grids of `N_ROUGHNESS` x `N_COS` nodes, bilinear; for dielectrics the relative IOR
//! seen from `wo`'s side enters as `z = sqrt(|eta - 1| / (eta + 1))` of `max(eta, 1 / eta)`
//! (uniform in z: dense near eta = 1 where the lobe changes fastest, as Cycles' table), on
//! `N_ETA` nodes, with one table for light arriving from the optically thinner side and one
//! for the denser side (total internal reflection).

use super::fresnel::{fresnel_dielectric, reflect, refract, schlick_weight};
use super::microfacet::TrowbridgeReitz;
use crate::math::lerp;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Roughness nodes `r = i / (N_ROUGHNESS - 1)`, alpha = r^2.
pub const N_ROUGHNESS: usize = 32;
/// Cosine nodes `mu = (j / (N_COS - 1))^2`: dense at grazing angles, where a smooth lobe's
/// albedo changes over a range of cosines about alpha wide (the node at 0 is evaluated at
/// `MIN_COS`).
pub const N_COS: usize = 32;
/// IOR nodes `z = k / N_ETA` (k < N_ETA), so eta up to (1 + z^2) / (1 - z^2) = 31.5.
pub const N_ETA: usize = 32;
/// Grazing limit at which the first cosine node is evaluated.
const MIN_COS: f32 = 1e-3;

const MAGIC: &[u8; 8] = b"PRGGXE\0\x01";

/// The tables, in the order they are stored (all f32, row-major, last index fastest).
#[derive(Clone, Debug, PartialEq)]
pub struct EnergyTables {
    /// `E(r, mu)`: albedo of the GGX reflection lobe with F = 1.
    pub reflection: Vec<f32>,
    /// `B(r, mu)`: albedo with F = (1 - wo.wm)^5 (the Schlick weight), so that a Schlick
    /// Fresnel `f0 + (f90 - f0) (1 - cos)^5` gives the albedo `f0 E + (f90 - f0) B`.
    pub reflection_schlick: Vec<f32>,
    /// `E_avg(r) = 2 int E mu dmu`.
    pub reflection_average: Vec<f32>,
    /// `B_avg(r) = 2 int B mu dmu`.
    pub reflection_schlick_average: Vec<f32>,
    /// `E_T(z, r, mu)` of a dielectric seen from the thinner side (relative IOR >= 1).
    pub dielectric_enter: Vec<f32>,
    /// `E_T(z, r, mu)` seen from the denser side (relative IOR 1 / eta).
    pub dielectric_exit: Vec<f32>,
}

impl EnergyTables {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        for n in [N_ROUGHNESS, N_COS, N_ETA] {
            out.extend_from_slice(&(n as u32).to_le_bytes());
        }
        for table in self.tables() {
            for v in table {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < 20 || &bytes[..8] != MAGIC {
            return Err("not a GGX energy table (bad magic)".into());
        }
        let word = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
        if (word(8), word(12), word(16)) != (N_ROUGHNESS, N_COS, N_ETA) {
            return Err("GGX energy table of another resolution".into());
        }
        let mut floats = bytes[20..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()));
        let mut take = |n: usize| -> Vec<f32> { floats.by_ref().take(n).collect() };
        let rm = N_ROUGHNESS * N_COS;
        let t = EnergyTables {
            reflection: take(rm),
            reflection_schlick: take(rm),
            reflection_average: take(N_ROUGHNESS),
            reflection_schlick_average: take(N_ROUGHNESS),
            dielectric_enter: take(N_ETA * rm),
            dielectric_exit: take(N_ETA * rm),
        };
        let expected = 4 * (2 * rm + 2 * N_ROUGHNESS + 2 * N_ETA * rm) + 20;
        if bytes.len() != expected {
            return Err(format!(
                "GGX energy table: {} bytes, expected {expected}",
                bytes.len()
            ));
        }
        if t.tables()
            .iter()
            .any(|v| v.iter().any(|x| !(0.0..=1.0).contains(x)))
        {
            return Err("GGX energy table: value outside [0, 1]".into());
        }
        Ok(t)
    }

    fn tables(&self) -> [&Vec<f32>; 6] {
        [
            &self.reflection,
            &self.reflection_schlick,
            &self.reflection_average,
            &self.reflection_schlick_average,
            &self.dielectric_enter,
            &self.dielectric_exit,
        ]
    }

    /// Computes every table with `samples`^2 stratified visible normals per entry (the
    /// averages with 4 x `N_COS` cosines). Slow (seconds to minutes): for the generator.
    pub fn compute(samples: usize) -> Self {
        let parallel_map = |f: &(dyn Fn(usize) -> f32 + Sync), n: usize| -> Vec<f32> {
            (0..n).into_par_iter().map(f).collect()
        };
        let rm = N_ROUGHNESS * N_COS;
        let reflection = parallel_map(
            &|idx| {
                let (r, mu) = (roughness_node(idx / N_COS), cos_node(idx % N_COS));
                reflection_albedo(r * r, mu, samples).0
            },
            rm,
        );
        let reflection_schlick = parallel_map(
            &|idx| {
                let (r, mu) = (roughness_node(idx / N_COS), cos_node(idx % N_COS));
                reflection_albedo(r * r, mu, samples).1
            },
            rm,
        );
        // Averages by the midpoint rule in mu on a finer grid than the table's.
        let n_avg = 4 * N_COS;
        let average = |i: usize, schlick: bool| -> f32 {
            let alpha = roughness_node(i).powi(2);
            let mut sum = 0.0f64;
            for j in 0..n_avg {
                let mu = (j as f32 + 0.5) / n_avg as f32;
                let (e, b) = reflection_albedo(alpha, mu, samples);
                sum += (if schlick { b } else { e } * mu) as f64;
            }
            (2.0 * sum / n_avg as f64) as f32
        };
        let reflection_average = parallel_map(&|i| average(i, false), N_ROUGHNESS);
        let reflection_schlick_average = parallel_map(&|i| average(i, true), N_ROUGHNESS);
        let dielectric = |exit: bool| {
            parallel_map(
                &move |idx| {
                    let eta = eta_node(idx / rm);
                    let r = roughness_node((idx / N_COS) % N_ROUGHNESS);
                    let mu = cos_node(idx % N_COS);
                    dielectric_albedo(r * r, mu, if exit { 1.0 / eta } else { eta }, samples)
                },
                N_ETA * rm,
            )
        };
        EnergyTables {
            reflection,
            reflection_schlick,
            reflection_average,
            reflection_schlick_average,
            dielectric_enter: dielectric(false),
            dielectric_exit: dielectric(true),
        }
    }
}

/// Roughness (sqrt alpha) of node `i`.
pub fn roughness_node(i: usize) -> f32 {
    i as f32 / (N_ROUGHNESS - 1) as f32
}

/// Cosine at which node `j` is evaluated.
pub fn cos_node(j: usize) -> f32 {
    (j as f32 / (N_COS - 1) as f32).powi(2).max(MIN_COS)
}

/// Relative IOR (>= 1) of node `k`; node 0 is the limit eta -> 1+ (index-matched interfaces
/// are Dirac in `DielectricBsdf` and never look the table up).
pub fn eta_node(k: usize) -> f32 {
    let z = k as f32 / N_ETA as f32;
    let z2 = z * z;
    ((1.0 + z2) / (1.0 - z2)).max(1.0 + 1e-4)
}

/// Stratified visible normals seen from `wo` (`n`^2 of them).
fn visible_normals(alpha: f32, wo: Vec3, n: usize) -> impl Iterator<Item = Vec3> {
    let distrib = TrowbridgeReitz::isotropic(alpha);
    (0..n * n).map(move |k| {
        let u = Vec2::new(
            ((k % n) as f32 + 0.5) / n as f32,
            ((k / n) as f32 + 0.5) / n as f32,
        );
        distrib.sample_visible(wo, u)
    })
}

/// `(E, B)` of the GGX reflection lobe at `alpha`, `mu = cos theta_o`, by `n`^2 stratified
/// visible normals. A Dirac lobe (`alpha` below `SMOOTH_ALPHA`) gives the exact limit.
pub fn reflection_albedo(alpha: f32, mu: f32, n: usize) -> (f32, f32) {
    let distrib = TrowbridgeReitz::isotropic(alpha);
    if distrib.effectively_smooth() {
        return (1.0, schlick_weight(mu));
    }
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1_o = distrib.g1(wo);
    let (mut e, mut b) = (0.0f64, 0.0f64);
    for wm in visible_normals(alpha, wo, n) {
        let wi = reflect(wo, wm);
        if wi.z > 0.0 {
            let w = (distrib.g(wo, wi) / g1_o) as f64;
            e += w;
            b += w * schlick_weight(wo.dot(wm)) as f64;
        }
    }
    let m = (n * n) as f64;
    ((e / m).min(1.0) as f32, (b / m).min(1.0) as f32)
}

/// Albedo (reflection + refraction, as energy) of a rough dielectric interface with relative
/// IOR `eta` (IOR on the far side over IOR on `wo`'s side), `mu = cos theta_o > 0`.
pub fn dielectric_albedo(alpha: f32, mu: f32, eta: f32, n: usize) -> f32 {
    let distrib = TrowbridgeReitz::isotropic(alpha);
    if distrib.effectively_smooth() {
        return 1.0;
    }
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1_o = distrib.g1(wo);
    let mut sum = 0.0f64;
    for wm in visible_normals(alpha, wo, n) {
        let cos = wo.dot(wm);
        let fr = fresnel_dielectric(cos, eta);
        let wr = reflect(wo, wm);
        if wr.z > 0.0 {
            sum += (fr * distrib.g(wo, wr) / g1_o) as f64;
        }
        if let Some((wt, _)) = refract(wo, wm, eta) {
            if wt.z < 0.0 {
                sum += ((1.0 - fr) * distrib.g(wo, wt) / g1_o) as f64;
            }
        }
    }
    (sum / (n * n) as f64).min(1.0) as f32
}

static TABLE_BYTES: &[u8] = include_bytes!("data/ggx_energy.bin");

/// The embedded tables (decoded on first use).
pub fn tables() -> &'static EnergyTables {
    static TABLES: OnceLock<EnergyTables> = OnceLock::new();
    TABLES.get_or_init(|| {
        EnergyTables::from_bytes(TABLE_BYTES)
            .unwrap_or_else(|e| panic!("embedded GGX energy table: {e}"))
    })
}

/// Position of `x` in [0, 1] on `n` uniform nodes: (lower node, fraction).
#[inline]
fn grid(x: f32, n: usize) -> (usize, f32) {
    let t = (if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) }) * (n - 1) as f32;
    let i = (t as usize).min(n - 2);
    (i, t - i as f32)
}

/// Bilinear lookup of an `N_ROUGHNESS` x `N_COS` slice.
#[inline]
fn lookup_2d(table: &[f32], roughness: f32, mu: f32) -> f32 {
    let (i, fi) = grid(roughness, N_ROUGHNESS);
    let (j, fj) = grid(mu.max(0.0).sqrt(), N_COS);
    let at = |i: usize, j: usize| table[i * N_COS + j];
    lerp(
        fi,
        lerp(fj, at(i, j), at(i, j + 1)),
        lerp(fj, at(i + 1, j), at(i + 1, j + 1)),
    )
}

#[inline]
fn lookup_1d(table: &[f32], roughness: f32) -> f32 {
    let (i, fi) = grid(roughness, N_ROUGHNESS);
    lerp(fi, table[i], table[i + 1])
}

/// The albedos a reflection lobe of GGX `alpha` needs for energy compensation: at one cosine
/// (`e`, `b`) or averaged over the hemisphere (`e_avg`, `b_avg`). See [`EnergyTables`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReflectionAlbedo {
    pub e: f32,
    pub b: f32,
}

/// `(E, B)` of the GGX reflection lobe at `mu = cos theta`.
#[inline]
pub fn ggx_reflection_albedo(alpha: f32, mu: f32) -> ReflectionAlbedo {
    let t = tables();
    let r = alpha.max(0.0).sqrt();
    ReflectionAlbedo {
        e: lookup_2d(&t.reflection, r, mu),
        b: lookup_2d(&t.reflection_schlick, r, mu),
    }
}

/// `(E_avg, B_avg)`: cosine-weighted hemispherical averages of [`ggx_reflection_albedo`].
#[inline]
pub fn ggx_reflection_average(alpha: f32) -> ReflectionAlbedo {
    let t = tables();
    let r = alpha.max(0.0).sqrt();
    ReflectionAlbedo {
        e: lookup_1d(&t.reflection_average, r),
        b: lookup_1d(&t.reflection_schlick_average, r),
    }
}

/// Albedo (reflection + refraction energy) of a rough dielectric interface of GGX `alpha`
/// seen from `wo`: `cos_o` is its cosine with the outward normal (negative inside) and `eta`
/// the relative IOR inside / outside.
#[inline]
pub fn ggx_dielectric_albedo(alpha: f32, cos_o: f32, eta: f32) -> f32 {
    let eta_seen = if cos_o >= 0.0 { eta } else { 1.0 / eta };
    if !(eta_seen > 0.0) || !eta_seen.is_finite() {
        return 1.0;
    }
    let t = tables();
    let (table, ratio) = if eta_seen >= 1.0 {
        (&t.dielectric_enter, eta_seen)
    } else {
        (&t.dielectric_exit, 1.0 / eta_seen)
    };
    let z = ((ratio - 1.0) / (ratio + 1.0)).sqrt() * N_ETA as f32;
    let k = (z as usize).min(N_ETA - 2);
    let fk = (z - k as f32).min(1.0);
    let r = alpha.max(0.0).sqrt();
    let mu = cos_o.abs();
    let slice = N_ROUGHNESS * N_COS;
    lerp(
        fk,
        lookup_2d(&table[k * slice..(k + 1) * slice], r, mu),
        lookup_2d(&table[(k + 1) * slice..(k + 2) * slice], r, mu),
    )
}

/// The factor that gives a single-scattering GGX reflection lobe its multiple scattering, as
/// Cycles' `microfacet_ggx_preserve_energy` does: `1 + (F_ms / F_avg) (1 - E(mu_o)) / E(mu_o)`
/// with `F_ms = multiscatter_fresnel(f_avg, e_avg)`, one F_avg cancelled because the lobe
/// already carries one bounce of Fresnel. 1 for a mirror (E = 1), 1 / E(mu_o) for F = 1.
#[inline]
pub fn multiscatter_boost(f_avg: f32, e_o: f32, e_avg: f32) -> f32 {
    if !(e_o > 1e-3) || !(f_avg > 1e-6) {
        return 1.0;
    }
    let missing = ((1.0 - e_o) / e_o).max(0.0);
    1.0 + multiscatter_fresnel(f_avg, e_avg) / f_avg * missing
}

/// The cosine at which a rough lobe's Fresnel is taken for its albedo: the one whose Schlick
/// weight is the lobe's mean one, `(1 - mu_eff)^5 = B / E` (the microfacets a rough lobe
/// reflects through face the viewer more than the macro-surface does; `mu` itself for a
/// mirror). Used where the Fresnel curve is no Schlick curve (the real dielectric one, a thin
/// film), so `f0 E + (f90 - f0) B` does not apply.
#[inline]
pub fn effective_cosine(a: ReflectionAlbedo) -> f32 {
    let w = if a.e > 0.0 {
        (a.b / a.e).clamp(0.0, 1.0)
    } else {
        0.0
    };
    1.0 - w.powf(0.2)
}

/// A dielectric's hemispherical average Fresnel reflectance `2 int F(mu) mu dmu` from outside,
/// by Kulla & Conty's 2017 fit `(eta - 1) / (4.08567 + 1.00071 eta)` (eta >= 1; within 3% for
/// eta 1-3: 0.0895 at 1.5 against 0.0918 by quadrature).
#[inline]
pub fn dielectric_fresnel_average(eta: f32) -> f32 {
    let eta = eta.max(1.0);
    (eta - 1.0) / (4.08567 + 1.00071 * eta)
}

/// Kulla & Conty's Fresnel colour of the multiple-scattering lobe, `F_avg^2 E_avg / (1 - F_avg
/// (1 - E_avg))`: the sum over the bounces after the first, each weighted by the average
/// Fresnel and the average fraction that bounces again.
#[inline]
pub fn multiscatter_fresnel(f_avg: f32, e_avg: f32) -> f32 {
    let d = 1.0 - f_avg * (1.0 - e_avg);
    if d > 0.0 {
        (f_avg * f_avg * e_avg / d).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Hemispherical average of the Schlick factor `(1 - mu)^5`: `2 int (1 - mu)^5 mu dmu = 1/21`.
pub const SCHLICK_WEIGHT_AVERAGE: f32 = 1.0 / 21.0;
