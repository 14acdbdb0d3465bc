//! RGB -> spectrum upsampling with the sigmoid-polynomial model of
//! W. Jakob and J. Hanika, "A Low-Dimensional Function Space for Efficient Spectral
//! Upsampling", Computer Graphics Forum 38(2) (Eurographics 2019).
//!
//! A reflectance is `s(lambda) = S(c0 t^2 + c1 t + c2)` with the sigmoid
//! `S(x) = 1/2 + x / (2 sqrt(1 + x^2))` of the paper, which is smooth, bounded to (0, 1) and
//! needs three coefficients. Unlike the paper we write the quadratic in the normalised
//! wavelength `t = (lambda - 595 nm) / 235 nm`, which maps 360-830 nm to [-1, 1]: the
//! coefficients then stay O(1..1e3) and f32 evaluation does not cancel catastrophically.
//!
//! The coefficients of linear sRGB colours are precomputed, as in the paper, by the optimiser
//! `tools/rgb2spec_opt.rs`, which fits each table entry in CIELAB against the CIE 1931 observer
//! under D65 (the tables of [`cie`]), so a reflectance lit by the normalised D65 illuminant
//! reproduces its RGB through the film's XYZ -> sRGB. Regenerate the table with
//!
//! ```text
//! cargo run --release --bin prism-rgb2spec-opt -- src/spectrum/data/rgb2spec_srgb.bin
//! ```
//!
//! Table layout (as in the paper): three cubes, one per channel that is largest; in cube `l`
//! the axes are `z = rgb[l]` (remapped nonlinearly, see [`RgbToSpectrumTable::z_node`]),
//! `x = rgb[(l+1)%3] / z` and `y = rgb[(l+2)%3] / z` (nodes crowded towards 0 and 1, see
//! [`RgbToSpectrumTable::xy_node`]). Lookups interpolate the coefficients trilinearly; no
//! optimisation happens at run time.
//!
//! Accuracy (measured by the optimiser and `tests/spectrum_roundtrip.rs`, linear sRGB -> spectrum
//! -> XYZ by quadrature -> linear sRGB): at resolution 64 (9.4 MB) the worst error over a 17^3
//! grid plus 2 million random colours is 6.7e-4 per channel; resolution 48 gives 1.1e-3 and 32
//! gives 2.5e-3, so 64 is the smallest of these that stays under 1e-3.
//!
//! File format (little endian): 8-byte magic `PRSMR2SP`, u32 version (1), u32 resolution `n`,
//! then `3 * n^3 * 3` f32 coefficients indexed `[l][z][y][x][coefficient]`.

use super::{cie, SampledSpectrum, SampledWavelengths};
use glam::Vec3;
use std::borrow::Cow;
use std::sync::OnceLock;

/// Centre and half width (nm) of the wavelength normalisation `t = (lambda - MID) / HALF`.
pub const SIGMOID_LAMBDA_MID: f32 = 595.0;
pub const SIGMOID_LAMBDA_HALF: f32 = 235.0;

/// The sigmoid `S(x) = 1/2 + x / (2 sqrt(1 + x^2))` of the paper, with its limits at
/// +-infinity (NaN maps to 0).
///
/// Written as selects, not branches, so that a spectrum's four wavelengths are evaluated in
/// one vector (`sample` of the spectra below; their per-wavelength branches were 3% of the
/// everyday scene's time).
#[inline]
pub fn sigmoid(x: f32) -> f32 {
    let inner = x.clamp(-1e15, 1e15);
    let s = 0.5 + 0.5 * inner / (1.0 + inner * inner).sqrt();
    let s = if x >= 1e15 { 1.0 } else { s };
    // Also NaN: no comparison holds.
    if x > -1e15 {
        s
    } else {
        0.0
    }
}

/// `S(c0 t^2 + c1 t + c2)` with `t = (lambda - 595) / 235`: a smooth spectrum in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SigmoidPolynomial {
    pub c: [f32; 3],
}

impl SigmoidPolynomial {
    /// The flat spectrum of value `v` in [0, 1] (`c0 = c1 = 0`, `c2 = S^-1(v)`, infinite at 0 and 1).
    #[inline]
    pub fn constant(v: f32) -> Self {
        let v = v.clamp(0.0, 1.0);
        Self {
            c: [0.0, 0.0, (v - 0.5) / (v * (1.0 - v)).sqrt()],
        }
    }

    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        let t = (lambda - SIGMOID_LAMBDA_MID) * (1.0 / SIGMOID_LAMBDA_HALF);
        sigmoid((self.c[0] * t + self.c[1]) * t + self.c[2])
    }
}

/// Precomputed sigmoid-polynomial coefficients over the RGB cube (see the module docs).
#[derive(Clone, Debug)]
pub struct RgbToSpectrumTable {
    res: usize,
    xy_nodes: Vec<f32>,
    z_nodes: Vec<f32>,
    /// The coefficients as little-endian f32 bytes. The embedded table is used in place: a
    /// decoded copy would cost every process start ~7 ms (9.4 MB converted and faulted in),
    /// while lookups touch only the pages of the colours a scene uses.
    coeff_bytes: Cow<'static, [u8]>,
}

fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

impl RgbToSpectrumTable {
    pub const MAGIC: [u8; 8] = *b"PRSMR2SP";
    pub const VERSION: u32 = 1;
    const HEADER: usize = 16;

    /// Position of z-slice `k` of `res`: `smoothstep(smoothstep(k / (res - 1)))`, the paper's
    /// nonlinear brightness axis, which crowds slices near black and near the brightest colours.
    pub fn z_node(k: usize, res: usize) -> f64 {
        smoothstep(smoothstep(k as f64 / (res - 1) as f64))
    }

    /// Position of x/y node `i` of `res`: `smoothstep(i / (res - 1))`.
    ///
    /// The paper spaces x and y uniformly. Near x -> 0 (a channel -> 0, towards the primaries)
    /// the coefficients behave like sqrt(x) and near x -> 1 at high z they grow quickly, so
    /// uniform nodes leave trilinear-interpolation errors of 2e-3 in linear RGB at resolution
    /// 64 (measured with `tools/rgb2spec_opt.rs`); crowding nodes at both ends brings the
    /// worst case under 1e-3.
    pub fn xy_node(i: usize, res: usize) -> f64 {
        smoothstep(i as f64 / (res - 1) as f64)
    }

    /// Offset of the first coefficient of entry (table `l`, z `k`, y `j`, x `i`).
    #[inline]
    pub fn index(res: usize, l: usize, k: usize, j: usize, i: usize) -> usize {
        3 * (((l * res + k) * res + j) * res + i)
    }

    /// Build from `3 * res^3 * 3` coefficients in [`Self::index`] order.
    pub fn new(res: usize, coeffs: Vec<f32>) -> Result<Self, String> {
        if res < 2 {
            return Err(format!("table resolution {res} < 2"));
        }
        if coeffs.len() != 9 * res * res * res {
            return Err(format!(
                "{} coefficients for resolution {res}",
                coeffs.len()
            ));
        }
        if let Some(v) = coeffs.iter().find(|v| !v.is_finite()) {
            return Err(format!("non-finite coefficient {v}"));
        }
        let bytes = coeffs.iter().flat_map(|c| c.to_le_bytes()).collect();
        Ok(Self::with_coefficient_bytes(res, Cow::Owned(bytes)))
    }

    fn with_coefficient_bytes(res: usize, coeff_bytes: Cow<'static, [u8]>) -> Self {
        Self {
            res,
            xy_nodes: (0..res).map(|i| Self::xy_node(i, res) as f32).collect(),
            z_nodes: (0..res).map(|k| Self::z_node(k, res) as f32).collect(),
            coeff_bytes,
        }
    }

    pub fn resolution(&self) -> usize {
        self.res
    }

    /// The coefficients in [`Self::index`] order.
    pub fn coefficients(&self) -> Vec<f32> {
        self.coeff_bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }

    #[inline]
    fn coefficient(&self, index: usize) -> f32 {
        let b = &self.coeff_bytes[4 * index..4 * index + 4];
        f32::from_le_bytes([b[0], b[1], b[2], b[3]])
    }

    /// (resolution, coefficient bytes) of a table file, header checked.
    fn parse_header(bytes: &[u8]) -> Result<(usize, &[u8]), String> {
        if bytes.len() < Self::HEADER || bytes[..8] != Self::MAGIC {
            return Err("not an RGB-to-spectrum table (bad magic)".into());
        }
        let word = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let (version, res) = (word(8), word(12) as usize);
        if version != Self::VERSION {
            return Err(format!("unsupported table version {version}"));
        }
        if !(2..=1024).contains(&res) || bytes.len() != Self::HEADER + 36 * res * res * res {
            return Err(format!("bad size {} for resolution {res}", bytes.len()));
        }
        Ok((res, &bytes[Self::HEADER..]))
    }

    /// A table from file contents, every coefficient checked.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let (res, payload) = Self::parse_header(bytes)?;
        let coeffs = payload
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        Self::new(res, coeffs)
    }

    /// A table over static file contents (the embedded table), used in place. Only the
    /// header is checked here; the embedded table's coefficients are checked by a unit test.
    fn from_static_bytes(bytes: &'static [u8]) -> Result<Self, String> {
        let (res, payload) = Self::parse_header(bytes)?;
        Ok(Self::with_coefficient_bytes(res, Cow::Borrowed(payload)))
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(Self::HEADER + self.coeff_bytes.len());
        out.extend_from_slice(&Self::MAGIC);
        out.extend_from_slice(&Self::VERSION.to_le_bytes());
        out.extend_from_slice(&(self.res as u32).to_le_bytes());
        out.extend_from_slice(&self.coeff_bytes);
        out
    }

    /// Coefficients for a linear sRGB colour in [0, 1]^3 (clamped).
    ///
    /// Exact greys (including black and white) give exactly flat spectra. Colours with two or
    /// more components above 1/2 are looked up through their complement `1 - rgb` and the
    /// coefficients negated: `S(-q) = 1 - S(q)`, so this is the same function space and (the
    /// fit being unique) the same spectrum, but it is read from the part of the table where the
    /// coefficients vary slowly instead of next to white and the secondaries, where they
    /// diverge. (The unbounded and illuminant spectra only query max component 1/2, where this
    /// never triggers.)
    #[inline]
    pub fn lookup(&self, rgb: Vec3) -> SigmoidPolynomial {
        let rgb = rgb.clamp(Vec3::ZERO, Vec3::ONE);
        if rgb.x == rgb.y && rgb.y == rgb.z {
            return SigmoidPolynomial::constant(rgb.x);
        }
        let median = rgb.x.min(rgb.y).max(rgb.x.max(rgb.y).min(rgb.z));
        if median > 0.5 {
            let [c0, c1, c2] = self.lookup_direct(Vec3::ONE - rgb).c;
            SigmoidPolynomial { c: [-c0, -c1, -c2] }
        } else {
            self.lookup_direct(rgb)
        }
    }

    /// Trilinear interpolation of the table at `rgb` (in [0, 1]^3, not grey), without the
    /// complement rule of [`Self::lookup`].
    #[inline]
    pub fn lookup_direct(&self, rgb: Vec3) -> SigmoidPolynomial {
        let l = if rgb.x >= rgb.y && rgb.x >= rgb.z {
            0
        } else if rgb.y >= rgb.z {
            1
        } else {
            2
        };
        let z = rgb[l];
        if z.is_nan() || z <= 0.0 {
            return SigmoidPolynomial::constant(0.0);
        }
        let n = self.res;
        let cell = |nodes: &[f32], v: f32| {
            let i = nodes.partition_point(|&node| node <= v).clamp(1, n - 1) - 1;
            let f = (v - nodes[i]) / (nodes[i + 1] - nodes[i]);
            (i, f.clamp(0.0, 1.0))
        };
        let inv_z = 1.0 / z;
        let (xi, fx) = cell(&self.xy_nodes, rgb[(l + 1) % 3] * inv_z);
        let (yi, fy) = cell(&self.xy_nodes, rgb[(l + 2) % 3] * inv_z);
        let (zi, fz) = cell(&self.z_nodes, z);

        let mut c = [0.0f32; 3];
        for (dz, wz) in [(0, 1.0 - fz), (1, fz)] {
            for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                let base = Self::index(n, l, zi + dz, yi + dy, xi);
                let w = wz * wy;
                for (k, ck) in c.iter_mut().enumerate() {
                    let a = self.coefficient(base + k);
                    let b = self.coefficient(base + 3 + k);
                    *ck += w * (a + fx * (b - a));
                }
            }
        }
        SigmoidPolynomial { c }
    }
}

static SRGB_TABLE_BYTES: &[u8] = include_bytes!("data/rgb2spec_srgb.bin");

/// The linear-sRGB table, embedded in the binary and used in place (header parsed on first use).
pub fn srgb_table() -> &'static RgbToSpectrumTable {
    static TABLE: OnceLock<RgbToSpectrumTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        RgbToSpectrumTable::from_static_bytes(SRGB_TABLE_BYTES)
            .unwrap_or_else(|e| panic!("embedded sRGB-to-spectrum table: {e}"))
    })
}

/// Reflectance-like spectrum in [0, 1] from an RGB albedo (clamped to [0, 1]).
///
/// Lit by [`RgbIlluminantSpectrum::new(Vec3::ONE)`] (normalised D65), it renders back to its
/// RGB on the film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbAlbedoSpectrum {
    poly: SigmoidPolynomial,
}

impl RgbAlbedoSpectrum {
    #[inline]
    pub fn new(rgb: Vec3) -> Self {
        Self {
            poly: srgb_table().lookup(rgb.clamp(Vec3::ZERO, Vec3::ONE)),
        }
    }
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.poly.eval(lambda)
    }
    #[inline]
    pub fn sample(&self, w: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::from_fn(|i| self.eval(w.lambda[i]))
    }
    pub fn polynomial(&self) -> SigmoidPolynomial {
        self.poly
    }
}

/// Upsample a non-negative colour of any magnitude: `scale * s(lambda)` where `s` is the
/// reflectance of `rgb / scale` and `scale = 2 max(rgb)` (so the shape is looked up at
/// brightness 1/2, where the model has head room both ways, as pbrt-v4's RGBUnboundedSpectrum does).
#[inline]
fn unbounded(rgb: Vec3) -> (f32, SigmoidPolynomial) {
    let rgb = rgb.max(Vec3::ZERO); // also maps NaN to 0
    let m = rgb.max_element();
    if !(m > 0.0 && m.is_finite()) {
        return (0.0, SigmoidPolynomial::constant(0.0));
    }
    let scale = 2.0 * m;
    (scale, srgb_table().lookup(rgb / scale))
}

/// Non-negative spectrum of any magnitude (absorption/scattering coefficients, ...).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbUnboundedSpectrum {
    scale: f32,
    poly: SigmoidPolynomial,
}

impl RgbUnboundedSpectrum {
    #[inline]
    pub fn new(rgb: Vec3) -> Self {
        let (scale, poly) = unbounded(rgb);
        Self { scale, poly }
    }
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.scale * self.poly.eval(lambda)
    }
    #[inline]
    pub fn sample(&self, w: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::from_fn(|i| self.eval(w.lambda[i]))
    }
}

/// Emission spectrum: the unbounded shape of the RGB colour times D65 normalised to unit
/// luminance, so RGB (1, 1, 1) emission renders as RGB (1, 1, 1) on the film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbIlluminantSpectrum {
    scale: f32,
    poly: SigmoidPolynomial,
}

impl RgbIlluminantSpectrum {
    #[inline]
    pub fn new(rgb: Vec3) -> Self {
        let (scale, poly) = unbounded(rgb);
        Self { scale, poly }
    }
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        self.scale * self.poly.eval(lambda) * cie::d65_normalized(lambda)
    }
    #[inline]
    pub fn sample(&self, w: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::from_fn(|i| self.eval(w.lambda[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::rgb;

    /// Linear sRGB of a spectrum lit by normalised D65 (deterministic quadrature).
    fn albedo_rgb(f: impl Fn(f32) -> f32) -> Vec3 {
        rgb::xyz_to_linear_srgb(cie::integrate_xyz(|l| f(l) * cie::d65_normalized(l), 4))
    }

    /// The embedded table is used without per-coefficient checks (`from_static_bytes`); this
    /// is where they happen: it parses with full validation (all coefficients finite) into
    /// the same coefficients, and a lookup reads the same values either way.
    #[test]
    fn embedded_table_is_valid_and_read_in_place() {
        let checked = RgbToSpectrumTable::from_bytes(SRGB_TABLE_BYTES).expect("valid table");
        let in_place = srgb_table();
        assert!(matches!(in_place.coeff_bytes, Cow::Borrowed(_)));
        assert_eq!(checked.coefficients(), in_place.coefficients());
        for rgb in [
            Vec3::new(0.8, 0.1, 0.1),
            Vec3::new(0.2, 0.5, 0.3),
            Vec3::new(0.05, 0.02, 0.4),
        ] {
            assert_eq!(checked.lookup(rgb), in_place.lookup(rgb));
        }
        assert_eq!(checked.to_bytes(), SRGB_TABLE_BYTES);
    }

    #[test]
    fn sigmoid_limits_and_constants() {
        assert_eq!(sigmoid(0.0), 0.5);
        assert_eq!(sigmoid(f32::INFINITY), 1.0);
        assert_eq!(sigmoid(f32::NEG_INFINITY), 0.0);
        assert_eq!(sigmoid(f32::NAN), 0.0);
        assert!((sigmoid(1.0) - (0.5 + 0.5 / 2f32.sqrt())).abs() < 1e-7);
        assert!(sigmoid(-1e20) == 0.0 && sigmoid(1e20) == 1.0);
        for v in [0.0, 1e-6, 0.01, 0.18, 0.5, 0.73, 0.999, 1.0] {
            let p = SigmoidPolynomial::constant(v);
            assert_eq!((p.c[0], p.c[1]), (0.0, 0.0));
            for l in [360.0, 555.5, 830.0] {
                assert!((p.eval(l) - v).abs() < 1e-6, "{v}: {}", p.eval(l));
            }
        }
    }

    #[test]
    fn table_serialisation_roundtrip() {
        let t = srgb_table();
        assert_eq!(t.resolution(), 64);
        let again = RgbToSpectrumTable::from_bytes(&t.to_bytes()).unwrap();
        assert_eq!(again.coefficients(), t.coefficients());
        let mut bad = t.to_bytes();
        bad[0] = b'X';
        assert!(RgbToSpectrumTable::from_bytes(&bad).is_err());
        assert!(RgbToSpectrumTable::from_bytes(&t.to_bytes()[..1000]).is_err());
        assert!(RgbToSpectrumTable::new(2, vec![0.0; 71]).is_err());
        assert!(RgbToSpectrumTable::new(2, vec![f32::NAN; 72]).is_err());
        // Node placement: ends exact, both axes monotonic.
        assert_eq!(RgbToSpectrumTable::z_node(0, 64), 0.0);
        assert_eq!(RgbToSpectrumTable::z_node(63, 64), 1.0);
        assert_eq!(RgbToSpectrumTable::xy_node(63, 64), 1.0);
        assert!((RgbToSpectrumTable::z_node(32, 64) - 0.5).abs() < 0.03);
    }

    #[test]
    fn greys_are_exactly_flat() {
        for g in [0.0, 0.02, 0.18, 0.5, 0.9, 1.0] {
            let a = RgbAlbedoSpectrum::new(Vec3::splat(g));
            assert_eq!(&a.polynomial().c[..2], &[0.0, 0.0]);
            for l in [360.0, 450.0, 600.0, 830.0] {
                assert!((a.eval(l) - g).abs() < 1e-6);
            }
        }
        for m in [0.25, 1.0, 7.5, 1e4] {
            let u = RgbUnboundedSpectrum::new(Vec3::splat(m));
            let e = RgbIlluminantSpectrum::new(Vec3::splat(m));
            for l in [360.0, 451.3, 600.0, 830.0] {
                assert!((u.eval(l) - m).abs() <= 1e-6 * m);
                let d = cie::d65_normalized(l) * m;
                assert!((e.eval(l) - d).abs() <= 1e-6 * d);
            }
        }
        // Black and negative/NaN input give zero spectra.
        for c in [
            Vec3::ZERO,
            Vec3::splat(-1.0),
            Vec3::new(f32::NAN, 0.0, -2.0),
        ] {
            assert_eq!(RgbAlbedoSpectrum::new(c).eval(550.0), 0.0);
            assert_eq!(RgbUnboundedSpectrum::new(c).eval(550.0), 0.0);
            assert_eq!(RgbIlluminantSpectrum::new(c).eval(550.0), 0.0);
        }
    }

    #[test]
    fn albedo_roundtrip_spot_colours() {
        let colours = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.8, 0.6, 0.2),
            Vec3::new(0.05, 0.1, 0.02),
            Vec3::new(0.999, 0.998, 0.95),
            Vec3::new(0.001, 0.0, 0.002),
        ];
        for c in colours {
            let s = RgbAlbedoSpectrum::new(c);
            let back = albedo_rgb(|l| s.eval(l));
            let err = (back - c).abs().max_element();
            assert!(err < 1e-3, "{c} -> {back} (error {err})");
        }
    }

    #[test]
    fn complement_lookup_agrees_with_direct() {
        // Colours with median just above 1/2 are read through their complement; the direct
        // reading gives the same spectrum, so the switch leaves no visible seam.
        let t = srgb_table();
        for c in [
            Vec3::new(0.8, 0.52, 0.2),
            Vec3::new(0.51, 0.1, 0.9),
            Vec3::new(0.3, 0.55, 0.55),
        ] {
            let via = t.lookup(c);
            let direct = t.lookup_direct(c);
            let diff = (360..=830)
                .map(|l| (via.eval(l as f32) - direct.eval(l as f32)).abs())
                .fold(0.0, f32::max);
            assert!(diff < 2e-3, "{c}: spectra differ by {diff}");
            let (a, b) = (albedo_rgb(|l| via.eval(l)), albedo_rgb(|l| direct.eval(l)));
            assert!((a - b).abs().max_element() < 1e-3, "{c}: {a} vs {b}");
        }
    }

    #[test]
    fn albedo_is_bounded() {
        let mut state = 0x1234_5678u32;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        for n in 0..2000 {
            // Include out-of-range inputs, which are clamped.
            let c = Vec3::new(rnd(), rnd(), rnd()) * if n % 10 == 0 { 3.0 } else { 1.0 }
                - Vec3::splat(if n % 7 == 0 { 0.5 } else { 0.0 });
            let s = RgbAlbedoSpectrum::new(c);
            for l in (0..=470).map(|i| 360.0 + i as f32) {
                let v = s.eval(l);
                assert!((0.0..=1.0).contains(&v), "{c} at {l}: {v}");
            }
        }
    }

    #[test]
    fn unbounded_and_illuminant_scale() {
        let c = Vec3::new(5.0, 0.2, 30.0);
        let u = RgbUnboundedSpectrum::new(c);
        let back = albedo_rgb(|l| u.eval(l));
        assert!((back - c).abs().max_element() < 1e-3 * 30.0, "{back}");
        let e = RgbIlluminantSpectrum::new(c);
        let back = rgb::xyz_to_linear_srgb(cie::integrate_xyz(|l| e.eval(l), 4));
        assert!((back - c).abs().max_element() < 1e-3 * 30.0, "{back}");
        let w = SampledWavelengths::fixed(500.0);
        assert_eq!(u.sample(&w).0[0], u.eval(500.0));
    }
}
