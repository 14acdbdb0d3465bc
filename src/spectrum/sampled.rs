//! Point samples of spectral quantities. Every radiometric quantity in the renderer is a
//! `SampledSpectrum` tied to one `SampledWavelengths`; RGB exists only at scene loading
//! (upsampling) and at the film (XYZ -> RGB).

use std::ops::{Add, AddAssign, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub};

/// The fitted shape of the `rgb` wavelength density (`RgbWavelengthTable`).
#[path = "data/wavelength_pdf.rs"]
mod data;

/// Wavelengths carried by one path (hero + 3 rotated companions, Wilkie et al. 2014).
pub const N_WAVELENGTHS: usize = 4;
/// The spectral range the renderer integrates over, in nanometres.
pub const LAMBDA_MIN: f32 = 360.0;
pub const LAMBDA_MAX: f32 = 830.0;

/// Values of a spectral function at the path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SampledSpectrum(pub [f32; N_WAVELENGTHS]);

impl SampledSpectrum {
    pub const ZERO: Self = Self([0.0; N_WAVELENGTHS]);
    pub const ONE: Self = Self([1.0; N_WAVELENGTHS]);

    #[inline]
    pub fn splat(v: f32) -> Self {
        Self([v; N_WAVELENGTHS])
    }
    #[inline]
    pub fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        Self(std::array::from_fn(f))
    }
    #[inline]
    pub fn map(self, mut f: impl FnMut(f32) -> f32) -> Self {
        Self(self.0.map(&mut f))
    }
    #[inline]
    pub fn is_black(&self) -> bool {
        self.0.iter().all(|&v| v == 0.0)
    }
    #[inline]
    pub fn max_component(&self) -> f32 {
        self.0.iter().copied().fold(f32::MIN, f32::max)
    }
    #[inline]
    pub fn min_component(&self) -> f32 {
        self.0.iter().copied().fold(f32::MAX, f32::min)
    }
    #[inline]
    pub fn sum(&self) -> f32 {
        self.0.iter().sum::<f32>()
    }
    #[inline]
    pub fn average(&self) -> f32 {
        self.sum() / N_WAVELENGTHS as f32
    }
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }
    #[inline]
    pub fn exp(self) -> Self {
        self.map(f32::exp)
    }
    /// Division that yields 0 where the denominator is 0 (used for throughput / pdf ratios).
    #[inline]
    pub fn safe_div(self, d: Self) -> Self {
        Self::from_fn(|i| {
            if d.0[i] != 0.0 {
                self.0[i] / d.0[i]
            } else {
                0.0
            }
        })
    }
    #[inline]
    pub fn clamp_zero(self) -> Self {
        self.map(|v| v.max(0.0))
    }
}

macro_rules! componentwise {
    ($tr:ident, $f:ident, $op:tt, $tra:ident, $fa:ident) => {
        impl $tr for SampledSpectrum {
            type Output = Self;
            #[inline]
            fn $f(self, o: Self) -> Self {
                Self::from_fn(|i| self.0[i] $op o.0[i])
            }
        }
        impl $tr<f32> for SampledSpectrum {
            type Output = Self;
            #[inline]
            fn $f(self, o: f32) -> Self {
                Self::from_fn(|i| self.0[i] $op o)
            }
        }
        impl $tra for SampledSpectrum {
            #[inline]
            fn $fa(&mut self, o: Self) {
                *self = *self $op o;
            }
        }
        impl $tra<f32> for SampledSpectrum {
            #[inline]
            fn $fa(&mut self, o: f32) {
                *self = *self $op o;
            }
        }
    };
}
componentwise!(Add, add, +, AddAssign, add_assign);
componentwise!(Mul, mul, *, MulAssign, mul_assign);
componentwise!(Div, div, /, DivAssign, div_assign);

impl Sub for SampledSpectrum {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self::from_fn(|i| self.0[i] - o.0[i])
    }
}
impl Neg for SampledSpectrum {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.map(|v| -v)
    }
}
impl Mul<SampledSpectrum> for f32 {
    type Output = SampledSpectrum;
    #[inline]
    fn mul(self, s: SampledSpectrum) -> SampledSpectrum {
        s * self
    }
}
impl Index<usize> for SampledSpectrum {
    type Output = f32;
    #[inline]
    fn index(&self, i: usize) -> &f32 {
        &self.0[i]
    }
}
impl IndexMut<usize> for SampledSpectrum {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut self.0[i]
    }
}

/// The wavelengths a path carries and the density each was chosen with.
///
/// Index 0 is the hero wavelength: it alone decides directions at interfaces whose
/// sampling depends on the wavelength (dispersion). `pdf[i]` is the effective density of
/// wavelength `i` for the film estimator `mean_i f(lambda_i) / pdf[i]`; a terminated
/// secondary has `pdf == 0` and contributes nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    pub lambda: [f32; N_WAVELENGTHS],
    pub pdf: [f32; N_WAVELENGTHS],
    /// Relative density with which the set would have been drawn had member i been the hero,
    /// in the variable the set is sampled in (0 for slots that are inactive from the start):
    /// the hero MIS shares of `integrator::spectral_mis` are proportional to these. All 1 for
    /// `sample_hero` (rotation in primary sample space).
    pub hero_pdf: [f32; N_WAVELENGTHS],
}

impl SampledWavelengths {
    /// Hero-wavelength rotation (Wilkie et al. 2014, eq. 5) in the primary sample space of
    /// `density`: the hero is `density.sample(u)`, the companions are `density.sample(u + k/N)`
    /// (mod 1). Every member is then distributed by `density` itself, one in each N-quantile
    /// of it, so with the visible-band density all N land where the eye is sensitive. (A
    /// rotation by k/N of the wavelength range instead puts about one member per path in the
    /// 360-420 / 700-830 nm tails, where it carries almost nothing to the image; with the
    /// uniform density the two rotations are the same.)
    ///
    /// Wilkie et al.'s derivation holds unchanged in the variable the set is rotated in: in u
    /// the hero density is 1 for whichever member is the hero, and the integrand is
    /// f(lambda) / p(lambda). So member i's film density is its own p(lambda_i) (`pdf`), and
    /// the one-sample MIS (balance heuristic) over "which member was the hero" gives every
    /// member the same share (`hero_pdf`, all 1); `integrator::spectral_mis` refines the
    /// weights by the members' path densities where they differ.
    pub fn sample_hero(u: f32, density: WavelengthPdf) -> Self {
        let members: [(f32, f32); N_WAVELENGTHS] = std::array::from_fn(|k| {
            // In [0, 2): one conditional subtraction wraps it exactly (Sterbenz).
            let uk = u + k as f32 / N_WAVELENGTHS as f32;
            density.sample_with_pdf(if uk >= 1.0 { uk - 1.0 } else { uk })
        });
        SampledWavelengths {
            lambda: members.map(|m| m.0),
            pdf: members.map(|m| m.1),
            hero_pdf: [1.0; N_WAVELENGTHS],
        }
    }

    /// One wavelength per path: slot 0 carries it, the other slots are inactive (pdf 0) from
    /// the start. The film's mean over N slots must then see slot 0 with density `p / N`.
    pub fn sample_single(u: f32, density: WavelengthPdf) -> Self {
        let (lambda, p) = density.sample_with_pdf(u);
        let mut pdf = [0.0; N_WAVELENGTHS];
        pdf[0] = p / N_WAVELENGTHS as f32;
        let mut hero_pdf = [0.0; N_WAVELENGTHS];
        hero_pdf[0] = p;
        SampledWavelengths {
            lambda: [lambda; N_WAVELENGTHS],
            pdf,
            hero_pdf,
        }
    }

    /// All N slots at one fixed wavelength with density 1 (for tests and analytic checks:
    /// the film then receives `f(lambda) * cmf(lambda)`).
    pub fn fixed(lambda: f32) -> Self {
        SampledWavelengths {
            lambda: [lambda; N_WAVELENGTHS],
            pdf: [1.0; N_WAVELENGTHS],
            hero_pdf: [1.0; N_WAVELENGTHS],
        }
    }

    /// Marks the secondary slots inactive and moves them onto the hero's wavelength (a
    /// direction valid only for the hero was chosen, e.g. a smooth dispersive refraction). The
    /// path tracer does this on its own copy: later stages see one wavelength (the BSSRDF
    /// samples one channel, interfaces are no longer dispersive); the film keeps the
    /// wavelengths and densities the path was drawn with.
    pub fn terminate_secondary(&mut self) {
        for k in 1..N_WAVELENGTHS {
            self.pdf[k] = 0.0;
            self.lambda[k] = self.lambda[0];
        }
    }

    pub fn secondary_terminated(&self) -> bool {
        self.pdf[1..].iter().all(|&p| p == 0.0)
    }
}

/// The density wavelengths are drawn from, shared by every wavelength strategy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WavelengthPdf {
    /// Tabulated density that minimises the colour noise of the linear Rec.709 image
    /// (`rgb_wavelength_pdf`).
    #[default]
    Rgb,
    /// sech^2 bell over the visible band (`visible_wavelength_pdf`), tuned for luminance.
    Visible,
    /// Uniform over [LAMBDA_MIN, LAMBDA_MAX].
    Uniform,
}

impl WavelengthPdf {
    pub const NAMES: &'static [&'static str] = &["rgb", "visible", "uniform"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "rgb" => Some(Self::Rgb),
            "visible" => Some(Self::Visible),
            "uniform" => Some(Self::Uniform),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Rgb => "rgb",
            Self::Visible => "visible",
            Self::Uniform => "uniform",
        }
    }

    /// Density per nm on [LAMBDA_MIN, LAMBDA_MAX] (0 outside).
    pub fn pdf(self, lambda: f32) -> f32 {
        match self {
            Self::Rgb => RgbWavelengthTable::get().pdf(lambda),
            Self::Visible => visible_wavelength_pdf(lambda),
            Self::Uniform if (LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) => {
                1.0 / (LAMBDA_MAX - LAMBDA_MIN)
            }
            Self::Uniform => 0.0,
        }
    }

    /// Inverse-CDF sample from `u` in [0, 1).
    pub fn sample(self, u: f32) -> f32 {
        self.sample_with_pdf(u).0
    }

    /// `(sample(u), pdf(sample(u)))`, the density computed along with the sample (equal to
    /// `pdf` up to rounding).
    #[inline]
    pub fn sample_with_pdf(self, u: f32) -> (f32, f32) {
        match self {
            Self::Rgb => RgbWavelengthTable::get().sample(u),
            Self::Visible => sample_visible_wavelength_with_pdf(u),
            Self::Uniform => (
                (LAMBDA_MIN + u * (LAMBDA_MAX - LAMBDA_MIN)).min(LAMBDA_MAX),
                1.0 / (LAMBDA_MAX - LAMBDA_MIN),
            ),
        }
    }
}

/// The colour-balanced wavelength density, tabulated per nanometre (piecewise constant).
///
/// A wavelength estimate of a pixel's linear Rec.709 channel c is f(lambda) c_bar(lambda) /
/// p(lambda), with c_bar the Rec.709 colour-matching functions (the XYZ-to-Rec.709 matrix
/// applied to the CIE 1931 functions). A path averages four such estimates, one wavelength in
/// each quartile of p (`SampledWavelengths::sample_hero`), and the density is fitted to that
/// rule: it minimises the four-member estimate's per-channel relative variance for Blender
/// colours (sigmoid-upsampled reflectances, once and squared, under D65; the fit and its
/// objective are in `data/gen_wavelength_pdf.py`). The single-wavelength optimum (Cauchy-
/// Schwarz: p ~ sqrt(sum_c (f c_bar / int f c_bar)^2)) does not see how the quartiles split
/// each channel's integral; on 40 random RGB reflectances not in the fit, the fitted density
/// has a median 0.31x its four-member colour variance (0.41x for products of two), and 1.04x
/// its single-wavelength variance. Images (64 spp): noise -5% on the SSS Cornell box, -3 to
/// -5% on the everyday, rough-glass and many-light scenes.
///
/// The fitted part is mixed 60/40 with the luminance bell, so that no wavelength gets less
/// than 0.4 of the bell's density: a narrow-band light at 700 nm must not become a firefly
/// source.
struct RgbWavelengthTable {
    /// Over [LAMBDA_MIN, LAMBDA_MAX] mapped to [0, 1): the density of the 1-nm bins below,
    /// sampled in O(1) (four wavelengths per path are drawn from it). 1024 steps of u: a knot
    /// interval averages the density over half a nanometre near the peak, a few nm in the
    /// far tails.
    inverse_cdf: crate::math::InverseCdf,
}

impl RgbWavelengthTable {
    fn get() -> &'static RgbWavelengthTable {
        static TABLE: std::sync::LazyLock<RgbWavelengthTable> =
            std::sync::LazyLock::new(RgbWavelengthTable::build);
        &TABLE
    }

    fn build() -> RgbWavelengthTable {
        use data::{RGB_PDF_BELL_SHARE, RGB_PDF_LOG_KNOTS};
        let bins = (LAMBDA_MAX - LAMBDA_MIN) as usize;
        let centre = |i: usize| LAMBDA_MIN + i as f32 + 0.5;
        // log q is piecewise linear between the knots, evenly spaced over the range.
        let knot_step = (LAMBDA_MAX - LAMBDA_MIN) / (RGB_PDF_LOG_KNOTS.len() - 1) as f32;
        let fitted: Vec<f64> = (0..bins)
            .map(|i| {
                let x = (centre(i) - LAMBDA_MIN) / knot_step;
                let j = (x as usize).min(RGB_PDF_LOG_KNOTS.len() - 2);
                let f = x - j as f32;
                let log_q = RGB_PDF_LOG_KNOTS[j] * (1.0 - f) + RGB_PDF_LOG_KNOTS[j + 1] * f;
                (log_q as f64).exp()
            })
            .collect();
        let total: f64 = fitted.iter().sum();
        let bell_share = RGB_PDF_BELL_SHARE as f64;
        let pdf: Vec<f32> = (0..bins)
            .map(|i| {
                ((1.0 - bell_share) * fitted[i] / total
                    + bell_share * visible_wavelength_pdf(centre(i)) as f64) as f32
            })
            .collect();
        // InverseCdf normalises (the bell's bins sum to 1 only up to its midpoint quadrature).
        RgbWavelengthTable {
            inverse_cdf: crate::math::InverseCdf::new(&pdf, 1024),
        }
    }

    fn pdf(&self, lambda: f32) -> f32 {
        if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
            return 0.0;
        }
        self.inverse_cdf
            .pdf((lambda - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN))
            / (LAMBDA_MAX - LAMBDA_MIN)
    }

    #[inline]
    fn sample(&self, u: f32) -> (f32, f32) {
        let (x, p) = self.inverse_cdf.sample(u);
        let range = LAMBDA_MAX - LAMBDA_MIN;
        ((LAMBDA_MIN + x * range).min(LAMBDA_MAX), p / range)
    }
}

// Wavelength importance sampling: p(lambda) proportional to sech^2(k (lambda - c)), a bell
// over the visible band that keeps a non-zero tail over the whole 360-830 nm range.
// Its CDF is tanh, so it is sampled in closed form. The shape parameters place the peak near
// the maximum of the CIE luminous efficiency and the width so that ~90% of samples fall in
// 420-680 nm (as in the visible-wavelength sampling of pbrt-v4, section 4.6.5).
const VIS_CENTER: f32 = 538.0;
const VIS_K: f32 = 0.0072;

/// tanh of the range ends: the CDF's bounds, computed once (they sit on the per-sample path).
fn vis_tanh_bounds() -> (f32, f32) {
    static BOUNDS: std::sync::LazyLock<(f32, f32)> = std::sync::LazyLock::new(|| {
        (
            (VIS_K * (LAMBDA_MIN - VIS_CENTER)).tanh(),
            (VIS_K * (LAMBDA_MAX - VIS_CENTER)).tanh(),
        )
    });
    *BOUNDS
}

/// Density (per nm) of `sample_visible_wavelength` on [LAMBDA_MIN, LAMBDA_MAX].
pub fn visible_wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let (t0, t1) = vis_tanh_bounds();
    let c = (VIS_K * (lambda - VIS_CENTER)).cosh();
    VIS_K / ((t1 - t0) * c * c)
}

pub fn sample_visible_wavelength(u: f32) -> f32 {
    sample_visible_wavelength_with_pdf(u).0
}

/// `sample_visible_wavelength(u)` and its density. The density comes from the CDF's tanh
/// value t itself, sech^2(atanh t) = 1 - t^2, without a cosh: the hero's four members each
/// need one, on every camera path.
pub fn sample_visible_wavelength_with_pdf(u: f32) -> (f32, f32) {
    let (t0, t1) = vis_tanh_bounds();
    let t = t0 + u * (t1 - t0);
    // atanh t = ln((1 + t) / (1 - t)) / 2 with `ln` rather than std's `atanh` (log1p): about
    // 4x cheaper in glibc, and t stays inside the open bounds (t0, t1), so the ratio is finite;
    // the lost precision near t = 0 is ~1e-7 in atanh, 1e-5 nm in lambda.
    let atanh_t = 0.5 * ((1.0 + t) / (1.0 - t)).ln();
    let lambda = (VIS_CENTER + atanh_t / VIS_K).clamp(LAMBDA_MIN, LAMBDA_MAX);
    (lambda, VIS_K * (1.0 - t * t) / (t1 - t0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visible_pdf_integrates_to_one_and_matches_sampling() {
        let n = 47_000;
        let h = (LAMBDA_MAX - LAMBDA_MIN) / n as f32;
        let integral: f32 = (0..n)
            .map(|i| visible_wavelength_pdf(LAMBDA_MIN + (i as f32 + 0.5) * h) * h)
            .sum();
        assert!((integral - 1.0).abs() < 1e-3, "integral {integral}");
        // Inverse-CDF check: the fraction of u below 0.5 maps to the CDF at the median.
        let median = sample_visible_wavelength(0.5);
        let m = ((median - LAMBDA_MIN) / h) as usize;
        let cdf: f32 = (0..m)
            .map(|i| visible_wavelength_pdf(LAMBDA_MIN + (i as f32 + 0.5) * h) * h)
            .sum();
        assert!((cdf - 0.5).abs() < 2e-3, "cdf at median {cdf}");
        // The density computed with the sample is the density at the sample.
        for i in 0..=1000 {
            let u = i as f32 / 1000.0;
            for d in [WavelengthPdf::Visible, WavelengthPdf::Uniform] {
                let (l, p) = d.sample_with_pdf(u);
                assert_eq!(l, d.sample(u));
                assert!(
                    (p - d.pdf(l)).abs() < 1e-4 * p,
                    "u {u}: {p} vs {}",
                    d.pdf(l)
                );
            }
        }
    }

    #[test]
    fn hero_rotation_covers_range_and_terminates() {
        // Uniform density: the rotation in primary sample space is the rotation by a quarter
        // of the wavelength range.
        let w = SampledWavelengths::sample_hero(0.3, WavelengthPdf::Uniform);
        let mut sorted = w.lambda;
        sorted.sort_by(f32::total_cmp);
        for k in 1..N_WAVELENGTHS {
            let gap = sorted[k] - sorted[k - 1];
            assert!((gap - (LAMBDA_MAX - LAMBDA_MIN) / 4.0).abs() < 1e-2);
        }
        // Visible density: one member in each quartile of the density, each with its own
        // density as film pdf, equal hero shares.
        for u in [0.0, 0.3, 0.74, 0.9999] {
            let mut w = SampledWavelengths::sample_hero(u, WavelengthPdf::Visible);
            let mut sorted = w.lambda;
            sorted.sort_by(f32::total_cmp);
            for (k, l) in sorted.into_iter().enumerate() {
                assert!((LAMBDA_MIN..=LAMBDA_MAX).contains(&l));
                let lo = sample_visible_wavelength(k as f32 / 4.0);
                let hi = sample_visible_wavelength((k + 1) as f32 / 4.0);
                assert!(
                    l >= lo - 1e-3 && l <= hi + 1e-3,
                    "u {u}: {l} not in [{lo}, {hi}]"
                );
            }
            for k in 0..N_WAVELENGTHS {
                let p = visible_wavelength_pdf(w.lambda[k]);
                assert!((w.pdf[k] - p).abs() < 1e-4 * p, "{} vs {p}", w.pdf[k]);
                assert_eq!(w.hero_pdf[k], w.hero_pdf[0]);
            }
            assert_eq!(w.lambda[0], sample_visible_wavelength(u));
            w.terminate_secondary();
            assert!(w.secondary_terminated() && w.pdf[0] > 0.0);
        }
    }
}
