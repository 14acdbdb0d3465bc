//! The microfibre sheen of Blender's Principled BSDF (Cycles 4.x and later): Zeltner, Burley &
//! Chiang 2022, "Practical Multiple-Scattering Sheen Using Linearly Transformed Cosines"
//! (SIGGRAPH talk).
//!
//! **The physical model.** A surface covered by fibres standing along its normal is a
//! volumetric layer of unit thickness and unit density above the material, filled with
//! specular microflakes whose SGGX distribution (Heitz et al. 2015, "The SGGX Microflake
//! Distribution") is that of a fibre along the normal: `S = diag(1, 1, s^2)` in the shading
//! frame with `s = roughness^2`. The flakes do not absorb; light scatters until it leaves the
//! top (the sheen's reflection) or the bottom (it reaches the material below). Rough sheens
//! (s -> 1: round flakes) reflect up to two thirds of the light; smooth ones (s -> 0: thin
//! fibres whose normals lie in the surface plane) reflect almost nothing except at grazing
//! views, where light skims along the fibres.
//!
//! **The lobe.** Simulating that layer per shading point would be far too slow and noisy, so
//! the reflected part is fitted once (`tools/sheen_ltc.rs`, `prism-sheen-ltc`) by a linearly
//! transformed cosine (Heitz et al. 2016, "Real-Time Polygonal-Light Shading with Linearly
//! Transformed Cosines") per (cos theta_o, roughness):
//!
//! ```text
//! f(wo, wi) cos(theta_i) = R(mu_o) D(wi),   D(w) = D_o(M^-1 w / |M^-1 w|) |det M^-1| / |M^-1 w|^3
//! M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]]  in the frame whose x axis is wo's azimuth
//! ```
//!
//! with `D_o` the clamped cosine over pi and `R` the layer's albedo (the fraction of walks
//! that leave the top). `D` integrates to 1 over the hemisphere and is sampled exactly (a
//! cosine sample mapped through `M`), so a sample's weight is `R` times the colour. As in the
//! paper and in Cycles the lobe is not reciprocal (the fit is per `wo`); the layers below are
//! dimmed by `1 - colour R(mu_o)` (`Sheen::below`).
//!
//! The table (`data/sheen_ltc.bin`) holds (a, b, R) on `N_COS` x `N_ROUGHNESS` uniform nodes
//! of mu_o and roughness in [0, 1], read bilinearly. `tests/bsdf_chi2.rs` checks the table's
//! albedos against a fresh simulation of the layer and the lobe's sampling by chi-square.

use crate::math::frame::Frame;
use crate::math::sampling::sample_cosine_hemisphere;
use crate::math::INV_PI;
use crate::sampler::Pcg32;
use glam::{DVec3, Vec2, Vec3};
use std::sync::OnceLock;

/// Cosine nodes `mu = i / (N_COS - 1)` (the node at 0 is simulated at `MIN_VALUE`).
pub const N_COS: usize = 32;
/// Roughness nodes `r = j / (N_ROUGHNESS - 1)` (the node at 0 is simulated at `MIN_VALUE`).
pub const N_ROUGHNESS: usize = 32;
/// Smallest cosine and roughness simulated: at exactly 0 the walk never enters the layer or
/// the flakes have no area.
pub const MIN_VALUE: f64 = 0.01;
/// Scattering events after which a walk counts as lost (it stays inside a non-absorbing layer
/// of optical depth about 1 only with vanishing probability: see `LayerStats::truncated`).
pub const MAX_SCATTERING: u32 = 256;

const MAGIC: &[u8; 8] = b"PRSHLTC1";

/// One node of the fit: the LTC's `a`, `b` and the layer's albedo `r`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FibreLobe {
    pub a: f32,
    pub b: f32,
    pub albedo: f32,
}

impl FibreLobe {
    /// The normalised lobe `D(w)` for `w` in the frame whose x axis is wo's azimuth.
    pub fn density(&self, w: Vec3) -> f32 {
        ltc_density(self.a, self.b, w)
    }

    /// A direction distributed as `D` (in the same frame).
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let c = sample_cosine_hemisphere(u);
        // M = (M^-1)^-1 = [[1/a, 0, -b/a], [0, 1/a, 0], [0, 0, 1]]; its last row keeps
        // w.z = c.z > 0, so every sample is above the surface.
        let a = self.a.max(1e-4);
        Vec3::new((c.x - self.b * c.z) / a, c.y / a, c.z).normalize()
    }

    /// The lobe for the view cosine `mu` and perceptual `roughness`, interpolated.
    pub fn at(roughness: f32, mu: f32) -> FibreLobe {
        table().lookup(roughness, mu)
    }
}

/// `D(w)` for `M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]]` (see the module doc).
pub fn ltc_density(a: f32, b: f32, w: Vec3) -> f32 {
    let t = Vec3::new(a * w.x + b * w.z, a * w.y, w.z);
    let len2 = t.length_squared();
    if !(t.z > 0.0 && len2 > 0.0) {
        return 0.0;
    }
    let len = len2.sqrt();
    // D_o(t / len) |det M^-1| / len^3 with D_o(v) = v.z / pi and det M^-1 = a^2.
    (t.z / len) * INV_PI * (a * a) / (len2 * len)
}

/// `(x, y, z)` of `wi` in the frame of the lobe at `wo` (x along wo's azimuth), and back.
pub fn to_lobe_frame(wo: Vec3, wi: Vec3) -> Vec3 {
    let (x, y) = azimuth_axes(wo);
    Vec3::new(wi.dot(x), wi.dot(y), wi.z)
}

pub fn from_lobe_frame(wo: Vec3, w: Vec3) -> Vec3 {
    let (x, y) = azimuth_axes(wo);
    x * w.x + y * w.y + Vec3::Z * w.z
}

fn azimuth_axes(wo: Vec3) -> (Vec3, Vec3) {
    let planar = Vec2::new(wo.x, wo.y);
    let len = planar.length();
    let x = if len > 1e-7 {
        Vec3::new(planar.x / len, planar.y / len, 0.0)
    } else {
        Vec3::X
    };
    (x, Vec3::new(-x.y, x.x, 0.0))
}

/// The fitted lobes on the (roughness, mu) grid.
#[derive(Clone, Debug, PartialEq)]
pub struct FibreTable {
    /// `nodes[j * N_COS + i]`: roughness node j, cosine node i.
    pub nodes: Vec<FibreLobe>,
}

impl FibreTable {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        for n in [N_COS, N_ROUGHNESS] {
            out.extend_from_slice(&(n as u32).to_le_bytes());
        }
        for l in &self.nodes {
            for v in [l.a, l.b, l.albedo] {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            return Err("not a fibre sheen table (bad magic)".into());
        }
        let word = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
        if (word(8), word(12)) != (N_COS, N_ROUGHNESS) {
            return Err("fibre sheen table of another resolution".into());
        }
        let floats: Vec<f32> = bytes[16..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        if floats.len() != 3 * N_COS * N_ROUGHNESS || floats.iter().any(|v| !v.is_finite()) {
            return Err("fibre sheen table: wrong length or non-finite entries".into());
        }
        let nodes = floats
            .chunks_exact(3)
            .map(|c| FibreLobe {
                a: c[0],
                b: c[1],
                albedo: c[2],
            })
            .collect();
        Ok(FibreTable { nodes })
    }

    /// Bilinear in (roughness, mu), both clamped to [0, 1].
    pub fn lookup(&self, roughness: f32, mu: f32) -> FibreLobe {
        let (j, fr) = node(roughness, N_ROUGHNESS);
        let (i, fm) = node(mu, N_COS);
        let at = |j: usize, i: usize| self.nodes[j * N_COS + i];
        let mix = |p: FibreLobe, q: FibreLobe, t: f32| FibreLobe {
            a: p.a + (q.a - p.a) * t,
            b: p.b + (q.b - p.b) * t,
            albedo: p.albedo + (q.albedo - p.albedo) * t,
        };
        let lo = mix(at(j, i), at(j, i + 1), fm);
        let hi = mix(at(j + 1, i), at(j + 1, i + 1), fm);
        mix(lo, hi, fr)
    }
}

/// Lower node and fraction of `x` (NaN taken as 1/2) on `n` uniform nodes over [0, 1].
fn node(x: f32, n: usize) -> (usize, f32) {
    let x = if x.is_nan() { 0.5 } else { x.clamp(0.0, 1.0) };
    let s = x * (n - 1) as f32;
    let i = (s as usize).min(n - 2);
    (i, s - i as f32)
}

/// The value of node `i` of `n` (0 .. 1), as simulated (not below `MIN_VALUE`).
pub fn node_value(i: usize, n: usize) -> f64 {
    (i as f64 / (n - 1) as f64).max(MIN_VALUE)
}

static TABLE_BYTES: &[u8] = include_bytes!("data/sheen_ltc.bin");

/// The embedded table (decoded on first use).
pub fn table() -> &'static FibreTable {
    static TABLE: OnceLock<FibreTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        FibreTable::from_bytes(TABLE_BYTES).unwrap_or_else(|e| panic!("embedded sheen table: {e}"))
    })
}

/// What walks through the fibre layer did, for one view cosine and roughness.
#[derive(Clone, Debug)]
pub struct LayerStats {
    pub walks: u64,
    /// Walks that left through the top.
    pub reflected: u64,
    /// Walks stopped after `MAX_SCATTERING` events (counted as lost).
    pub truncated: u64,
    /// Exit directions of the reflected walks: `N_THETA` x `N_PHI` bins uniform in theta over
    /// [0, pi/2] and in the azimuth over [0, pi] (mirrored: the layer is symmetric about the
    /// plane of incidence), azimuth 0 towards the view.
    pub histogram: Vec<u64>,
}

/// Histogram bins of `LayerStats`.
pub const N_THETA: usize = 32;
pub const N_PHI: usize = 32;

impl LayerStats {
    /// The albedo: the fraction of walks leaving through the top.
    pub fn albedo(&self) -> f64 {
        self.reflected as f64 / self.walks as f64
    }

    /// `f cos(theta_i) = R D` estimated over bin (t, p): its share of the walks over its solid
    /// angle (both azimuth halves).
    pub fn density(&self, t: usize, p: usize) -> f64 {
        let count = self.histogram[t * N_PHI + p] as f64;
        count / (self.walks as f64 * 2.0 * bin_solid_angle(t))
    }
}

/// Solid angle of one histogram bin in row `t` (one azimuth half).
pub fn bin_solid_angle(t: usize) -> f64 {
    let dt = std::f64::consts::FRAC_PI_2 / N_THETA as f64;
    let (t0, t1) = (t as f64 * dt, (t + 1) as f64 * dt);
    (t0.cos() - t1.cos()) * std::f64::consts::PI / N_PHI as f64
}

/// Bin centre direction (in the lobe frame).
pub fn bin_centre(t: usize, p: usize) -> Vec3 {
    let theta = (t as f64 + 0.5) / N_THETA as f64 * std::f64::consts::FRAC_PI_2;
    let phi = (p as f64 + 0.5) / N_PHI as f64 * std::f64::consts::PI;
    Vec3::new(
        (theta.sin() * phi.cos()) as f32,
        (theta.sin() * phi.sin()) as f32,
        theta.cos() as f32,
    )
}

/// Simulates `walks` light paths entering the fibre layer from the view direction at cosine
/// `mu` (azimuth 0) for perceptual `roughness`, with random numbers from `seed`.
pub fn simulate_layer(mu: f64, roughness: f64, walks: u64, seed: u64) -> LayerStats {
    let s = roughness * roughness;
    let mut rng = Pcg32::new(seed, mu.to_bits() ^ roughness.to_bits().rotate_left(17), 0);
    let mut u = move || {
        let hi = u64::from(rng.next_u32()) << 21;
        let lo = u64::from(rng.next_u32()) >> 11;
        ((hi | lo) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mu = mu.clamp(MIN_VALUE, 1.0);
    let view = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut stats = LayerStats {
        walks,
        reflected: 0,
        truncated: 0,
        histogram: vec![0; N_THETA * N_PHI],
    };
    for _ in 0..walks {
        // Light travels along `dir`; `depth` is 0 at the top of the layer, 1 at its bottom.
        let mut dir = -view;
        let mut depth = 0.0;
        let mut events = 0;
        loop {
            let sigma_t = projected_area(dir, s);
            depth += -(1.0 - u()).ln() / sigma_t * -dir.z;
            if depth < 0.0 {
                stats.reflected += 1;
                let theta = dir.z.clamp(-1.0, 1.0).acos();
                let phi = dir.y.atan2(dir.x).abs();
                let t = ((theta / std::f64::consts::FRAC_PI_2 * N_THETA as f64) as usize)
                    .min(N_THETA - 1);
                let p = ((phi / std::f64::consts::PI * N_PHI as f64) as usize).min(N_PHI - 1);
                stats.histogram[t * N_PHI + p] += 1;
                break;
            }
            if depth > 1.0 {
                break;
            }
            if events == MAX_SCATTERING {
                stats.truncated += 1;
                break;
            }
            events += 1;
            let m = sample_visible_flake_normal(-dir, s, u(), u());
            let w = -dir;
            dir = 2.0 * m.dot(w) * m - w;
        }
    }
    stats
}

/// The SGGX projected area `sqrt(w^T S w)` of the fibre flakes along `w`, `S = diag(1, 1,
/// s^2)`: the extinction coefficient at unit density.
fn projected_area(w: DVec3, s: f64) -> f64 {
    (w.x * w.x + w.y * w.y + s * s * w.z * w.z)
        .sqrt()
        .max(1e-12)
}

/// A flake normal seen from `w` (pointing away from the flake), distributed as the visible
/// SGGX normals. The SGGX ellipsoid of `S = diag(1, 1, s^2)` is the unit sphere stretched by
/// `A = diag(sqrt s, sqrt s, 1 / sqrt s)` (its projected areas along the axes are those of
/// `S`); a ray along `-w` hitting the ellipsoid at a uniformly chosen point of its silhouette
/// is, in the sphere's space, a ray along `A^-1 (-w)` hitting the sphere at a uniform point of
/// its silhouette disc, and the ellipsoid's normal there is `A^-1 p` for the sphere's point `p`.
fn sample_visible_flake_normal(w: DVec3, s: f64, u1: f64, u2: f64) -> DVec3 {
    let d = DVec3::new(-w.x, -w.y, -w.z * s).normalize();
    // Any basis of the disc's plane does (f32 is ample for it).
    let frame = Frame::from_normal(d.as_vec3());
    let (e1, e2) = (frame.s.as_dvec3(), frame.t.as_dvec3());
    let r = u1.sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let q = e1 * (r * phi.cos()) + e2 * (r * phi.sin());
    let p = q - d * (1.0 - r * r).max(0.0).sqrt();
    DVec3::new(p.x, p.y, p.z * s).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sampled flake normals are unit vectors facing the viewer; for round flakes (s = 1,
    /// a sphere) the visible normals' density is proportional to <w, m>, whose mean is 2/3.
    #[test]
    fn visible_normals_face_the_view() {
        let mut rng = Pcg32::new(3, 0, 0);
        let w = DVec3::new(0.3, -0.5, 0.6).normalize();
        let n = 200_000;
        let mean = (0..n)
            .map(|_| {
                let m = sample_visible_flake_normal(
                    w,
                    1.0,
                    f64::from(rng.next_1d()),
                    f64::from(rng.next_1d()),
                );
                m.dot(w)
            })
            .sum::<f64>()
            / f64::from(n);
        assert!((mean - 2.0 / 3.0).abs() < 3e-3, "mean cosine {mean}");
        for s in [0.05, 0.5, 1.0] {
            for w in [
                DVec3::Z,
                DVec3::new(0.8, 0.0, 0.6),
                DVec3::new(0.0, -0.99, 0.141),
            ] {
                let w = w.normalize();
                for _ in 0..1000 {
                    let m = sample_visible_flake_normal(
                        w,
                        s,
                        f64::from(rng.next_1d()),
                        f64::from(rng.next_1d()),
                    );
                    assert!(m.dot(w) >= -1e-9, "{m} against {w}");
                    assert!((m.length() - 1.0).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn round_flakes_scatter_like_a_sphere() {
        // s = 1: spherical flakes, whose specular phase function is isotropic. The albedo of a
        // unit-depth isotropic slab lit at normal incidence is about 0.33.
        let st = simulate_layer(1.0, 1.0, 200_000, 1);
        let r = st.albedo();
        assert!((0.28..0.38).contains(&r), "albedo {r}");
    }

    #[test]
    fn the_ltc_integrates_to_one_and_samples_its_density() {
        let lobe = FibreLobe {
            a: 0.6,
            b: -0.3,
            albedo: 1.0,
        };
        // Quadrature over the hemisphere.
        let n = 400;
        let mut sum = 0.0f64;
        for i in 0..n {
            let mu = (i as f32 + 0.5) / n as f32;
            let sin = (1.0 - mu * mu).sqrt();
            for j in 0..n {
                let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / n as f32;
                let w = Vec3::new(sin * phi.cos(), sin * phi.sin(), mu);
                sum += f64::from(lobe.density(w));
            }
        }
        let integral = sum * 2.0 * std::f64::consts::PI / (n * n) as f64;
        assert!((integral - 1.0).abs() < 2e-3, "integral {integral}");
        let mut rng = Pcg32::new(5, 0, 0);
        for _ in 0..1000 {
            let w = lobe.sample(rng.next_2d());
            assert!(w.z > 0.0 && lobe.density(w) > 0.0);
        }
    }
}
