//! How a camera path chooses its wavelengths.
//!
//! * `Hero` (Wilkie et al. 2014): a hero wavelength plus N-1 companions at equal spacing in the
//!   wavelength density's primary sample space (hero rotation of u, so each member follows the
//!   density); all N are carried by one path, weighted by the balance heuristic over the N
//!   "which one was the hero" techniques (see `integrator::spectral_mis`).
//! * `Single`: one wavelength per path, drawn independently for every sample.
//! * `Stratified`: one wavelength per path; the wavelengths of successive samples of a pixel
//!   are stratified over the spectrum (the sampler's wavelength dimension), the method of the
//!   report this project grew from (Evans and McCool 1999).
//!
//! `Hero` and `Stratified` take the hero's primary sample from the sampler's wavelength
//! dimensions (stratified over a pixel's samples with the low-discrepancy sampler). For `Hero`
//! the N members sit at u + k/N, so the set depends only on frac(N u): u is built as
//! (v + floor(N w)) / N from the stratified pair (v, w), which makes the set itself follow the
//! stratified v (a pixel's 2^m samples fill 2^m strata of it, not 2^m / N as a stratified u
//! would) while the hero's quarter stays uniform (w), so each member is the hero with the same
//! density, as the MIS over hero choices requires.
//!
//! All three draw from the same wavelength density (`WavelengthPdf`): the visible-range
//! importance density of `spectrum::sampled` or uniform over 360-830 nm.

use crate::sampler::Sampler;
pub use crate::spectrum::WavelengthPdf;
use crate::spectrum::{SampledWavelengths, N_WAVELENGTHS};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WavelengthStrategy {
    #[default]
    Hero,
    Single,
    Stratified,
}

impl WavelengthStrategy {
    pub const NAMES: &'static [&'static str] = &["hero", "single", "stratified"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "hero" => Some(Self::Hero),
            "single" => Some(Self::Single),
            "stratified" => Some(Self::Stratified),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Hero => "hero",
            Self::Single => "single",
            Self::Stratified => "stratified",
        }
    }
}

/// Everything that decides a camera path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct WavelengthSampling {
    pub strategy: WavelengthStrategy,
    pub pdf: WavelengthPdf,
    /// Diagnostic: every path carries exactly this wavelength (nm) with density 1, so the film
    /// receives f(lambda) * cmf(lambda). Overrides `strategy` and `pdf`.
    pub fixed: Option<f32>,
}

impl WavelengthSampling {
    /// Wavelengths of the path `sampler` belongs to. `Single` draws an independent value.
    pub fn sample(&self, sampler: &mut Sampler) -> SampledWavelengths {
        if let Some(lambda) = self.fixed {
            return SampledWavelengths::fixed(lambda);
        }
        match self.strategy {
            WavelengthStrategy::Hero => {
                let uv = sampler.wavelength();
                let n = N_WAVELENGTHS as f32;
                let quarter = (uv.y * n).floor().min(n - 1.0);
                let u = ((uv.x + quarter) / n).min(1.0 - f32::EPSILON / 2.0);
                SampledWavelengths::sample_hero(u, self.pdf)
            }
            WavelengthStrategy::Single => {
                SampledWavelengths::sample_single(sampler.next_1d(), self.pdf)
            }
            WavelengthStrategy::Stratified => {
                SampledWavelengths::sample_single(sampler.wavelength().x, self.pdf)
            }
        }
    }
}
