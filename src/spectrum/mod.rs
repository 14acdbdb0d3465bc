//! Spectral representation: sampled wavelengths/values, CIE colorimetry, and the
//! RGB <-> spectrum conversions. RGB appears only at the edges (scene loading and film).

pub mod cie;
pub mod dispersion;
pub mod rgb;
pub mod sampled;
pub mod upsample;

pub use dispersion::IorModel;
pub use sampled::{
    sample_visible_wavelength, visible_wavelength_pdf, SampledSpectrum, SampledWavelengths,
    WavelengthPdf, LAMBDA_MAX, LAMBDA_MIN, N_WAVELENGTHS,
};
pub use upsample::{RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum};

use glam::Vec3;

/// Monte Carlo estimate of CIE XYZ from one path's spectral samples:
/// XYZ = (1/N) sum_i s(lambda_i) cmf(lambda_i) / pdf(lambda_i), divided by the integral of
/// y-bar so that a constant spectrum of 1 has Y = 1. Terminated wavelengths (pdf 0) add nothing.
pub fn spectrum_to_xyz(s: &SampledSpectrum, w: &SampledWavelengths) -> Vec3 {
    let mut xyz = Vec3::ZERO;
    for i in 0..N_WAVELENGTHS {
        // Zero lanes (secondaries terminated at a smooth dispersive interface, paths that
        // found no light) skip the matching-function lookup: up to 3 of the 4 per sample.
        // NaN is not skipped, so the film still sees and discards it.
        if w.pdf[i] > 0.0 && s.0[i] != 0.0 {
            xyz += cie::cie_xyz_bar(w.lambda[i]) * (s.0[i] / w.pdf[i]);
        }
    }
    xyz / (N_WAVELENGTHS as f32 * cie::CIE_Y_INTEGRAL)
}
