//! Pixel reconstruction filters, applied by filter importance sampling (Ernst, Stamminger and
//! Greiner 2006, "Filter Importance Sampling"): each camera sample's sub-pixel position is drawn
//! from the filter's own distribution around the pixel centre and the sample then counts with
//! weight 1 in that pixel. A pixel's value is thereby the filter-weighted average of the image
//! around its centre, with no splatting into neighbours (so rendering stays embarrassingly
//! parallel and deterministic per pixel) and no variance from varying sample weights.
//!
//! The filters are separable, `f(x) f(y)`: x and y offsets are drawn independently from one 1D
//! distribution. Widths follow Blender Cycles' `filter_width`, so an exported scene is
//! reconstructed the way Cycles reconstructs it:
//! * box: uniform over ±w/2 (w = 1 is plain uniform jitter inside the pixel);
//! * Gaussian: exp(-8 x² / w²), i.e. σ = w/4, truncated at ±1.5 w;
//! * Blackman–Harris (Harris 1978, the 4-term window): the window spread over ±w; Cycles'
//!   default, with w = 1.5 px.
//!
//! Gaussian and Blackman–Harris are tabulated over [`TABLE_BINS`] bins of the half range and
//! sampled through an O(1) inverse CDF ([`InverseCdf`]); its density (the table averaged
//! over each knot interval, piecewise constant) *is* the filter: sampling density and filter
//! agree exactly, which is what keeps every sample's weight exactly 1.

use crate::math::distribution::InverseCdf;

/// Bins of the tabulated half range (0..radius): 512 keeps each bin under 0.003 px at the
/// default width, far below what a pixel can show.
const TABLE_BINS: usize = 512;

/// Largest accepted width in pixels (Cycles' UI allows up to 10 px as well).
pub const MAX_FILTER_WIDTH: f32 = 10.0;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterKind {
    Box,
    Gaussian,
    BlackmanHarris,
}

impl FilterKind {
    /// Names used by the material JSON (`render.filter`) and the command line.
    pub const NAMES: &'static [&'static str] = &["box", "gaussian", "blackman_harris"];

    pub fn from_name(name: &str) -> Option<FilterKind> {
        match name {
            "box" => Some(FilterKind::Box),
            "gaussian" => Some(FilterKind::Gaussian),
            "blackman_harris" | "blackman-harris" => Some(FilterKind::BlackmanHarris),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            FilterKind::Box => "box",
            FilterKind::Gaussian => "gaussian",
            FilterKind::BlackmanHarris => "blackman_harris",
        }
    }
}

/// A separable pixel filter with its sampling table.
#[derive(Clone, Debug)]
pub struct PixelFilter {
    kind: FilterKind,
    width: f32,
    /// Half-range support: offsets lie in [-radius, radius] pixels.
    radius: f32,
    /// The density over [0, radius) in units of the radius (None for the box filter).
    half: Option<InverseCdf>,
}

impl Default for PixelFilter {
    /// Blackman–Harris, 1.5 px: Cycles' default, so standalone renders of Blender scenes match.
    fn default() -> Self {
        PixelFilter::new(FilterKind::BlackmanHarris, 1.5).expect("valid default filter")
    }
}

impl PixelFilter {
    /// `width` in pixels, Cycles' convention (see the module documentation); must be finite,
    /// positive and at most [`MAX_FILTER_WIDTH`].
    pub fn new(kind: FilterKind, width: f32) -> Result<PixelFilter, String> {
        if !(width.is_finite() && width > 0.0 && width <= MAX_FILTER_WIDTH) {
            return Err(format!(
                "filter width {width} must be a number in (0, {MAX_FILTER_WIDTH}] pixels"
            ));
        }
        let radius = match kind {
            FilterKind::Box => 0.5 * width,
            FilterKind::Gaussian => 1.5 * width,
            FilterKind::BlackmanHarris => width,
        };
        let half = (kind != FilterKind::Box).then(|| {
            let bin = radius / TABLE_BINS as f32;
            let weights: Vec<f32> = (0..TABLE_BINS)
                .map(|i| Self::profile(kind, width, (i as f32 + 0.5) * bin))
                .collect();
            InverseCdf::new(&weights, TABLE_BINS)
        });
        Ok(PixelFilter {
            kind,
            width,
            radius,
            half,
        })
    }

    /// The box filter of width 1 px: uniform jitter inside the pixel.
    pub fn unit_box() -> PixelFilter {
        PixelFilter::new(FilterKind::Box, 1.0).expect("valid box filter")
    }

    pub fn kind(&self) -> FilterKind {
        self.kind
    }

    pub fn width(&self) -> f32 {
        self.width
    }

    /// Offsets lie in [-radius, radius] pixels around the pixel centre.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The unnormalised 1D filter at offset `x` (pixels) from the pixel centre, before
    /// tabulation.
    fn profile(kind: FilterKind, width: f32, x: f32) -> f32 {
        match kind {
            FilterKind::Box => 1.0,
            FilterKind::Gaussian => (-8.0 * x * x / (width * width)).exp(),
            FilterKind::BlackmanHarris => {
                // The 4-term Blackman–Harris window over [-width, width], peak at 0.
                let t = std::f32::consts::TAU * (x / (2.0 * width) + 0.5);
                (0.35875 - 0.48829 * t.cos() + 0.14128 * (2.0 * t).cos()
                    - 0.01168 * (3.0 * t).cos())
                .max(0.0)
            }
        }
    }

    /// Sub-pixel position in [0, 1)² pixel units relative to the pixel's corner for the box of
    /// width 1 (identical to plain jitter), in general the pixel centre (0.5, 0.5) plus an offset
    /// drawn from the filter.
    #[inline]
    pub fn sample_2d(&self, u: glam::Vec2) -> glam::Vec2 {
        if self.kind == FilterKind::Box && self.width == 1.0 {
            return u;
        }
        glam::Vec2::new(0.5 + self.sample_1d(u.x), 0.5 + self.sample_1d(u.y))
    }

    /// An offset from the pixel centre drawn from the 1D filter (density [`Self::pdf_1d`]).
    pub fn sample_1d(&self, u: f32) -> f32 {
        let Some(half) = &self.half else {
            return (u - 0.5) * self.width;
        };
        // The filter is symmetric: u < 0.5 picks the negative side, and u is stretched back to
        // [0, 1) to choose the offset's magnitude from the half-range table; mirrored on the
        // negative side so the offset grows monotonically with u (keeps stratified u stratified).
        let (sign, u) = if u < 0.5 {
            (-1.0, 1.0 - 2.0 * u)
        } else {
            (1.0, 2.0 * u - 1.0)
        };
        let (x, _) = half.sample(u);
        sign * (x * self.radius).min(self.radius)
    }

    /// Density of [`Self::sample_1d`] at offset `x` (per pixel); integrates to 1 over
    /// [-radius, radius]. This is the (tabulated) filter itself, normalised.
    pub fn pdf_1d(&self, x: f32) -> f32 {
        if !(x.abs() <= self.radius) {
            return 0.0;
        }
        match &self.half {
            None => 1.0 / self.width,
            Some(half) => 0.5 * half.pdf(x.abs() / self.radius) / self.radius,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_box_is_plain_jitter() {
        let f = PixelFilter::unit_box();
        let u = glam::Vec2::new(0.3, 0.9);
        assert_eq!(f.sample_2d(u), u);
    }

    #[test]
    fn widths_follow_cycles() {
        assert_eq!(PixelFilter::default().radius(), 1.5);
        let g = PixelFilter::new(FilterKind::Gaussian, 2.0).unwrap();
        assert_eq!(g.radius(), 3.0);
        let b = PixelFilter::new(FilterKind::Box, 2.0).unwrap();
        assert_eq!(b.radius(), 1.0);
        for w in [0.0, -1.0, f32::NAN, f32::INFINITY, 11.0] {
            assert!(PixelFilter::new(FilterKind::Gaussian, w).is_err(), "{w}");
        }
    }

    #[test]
    fn samples_stay_in_support_and_are_symmetric() {
        for kind in [
            FilterKind::Box,
            FilterKind::Gaussian,
            FilterKind::BlackmanHarris,
        ] {
            let f = PixelFilter::new(kind, 1.5).unwrap();
            let n = 10_000;
            let mut mean = 0.0f64;
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                let x = f.sample_1d(u);
                assert!(x.abs() <= f.radius(), "{kind:?} {x}");
                mean += x as f64;
            }
            assert!((mean / n as f64).abs() < 1e-3, "{kind:?} mean {mean}");
            // (The Gaussian's last bins hold ~1e-8 of the mass: u = 0 lands short of its edge.)
            assert!(
                f.sample_1d(0.0) < -0.5 * f.radius(),
                "{kind:?}: u = 0 is the left end"
            );
            assert!(
                f.sample_1d(0.5).abs() < 1e-6,
                "{kind:?}: u = 1/2 is the centre"
            );
            let xs: Vec<f32> = (0..100).map(|i| f.sample_1d(i as f32 / 100.0)).collect();
            assert!(
                xs.windows(2).all(|w| w[0] <= w[1]),
                "{kind:?}: monotone in u"
            );
        }
    }
}
