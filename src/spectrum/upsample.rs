//! PLACEHOLDER (being replaced by the Jakob & Hanika 2019 sigmoid-polynomial upsampling):
//! a crude three-box spectrum so the rest of the renderer compiles and runs.
use super::{cie, SampledSpectrum, SampledWavelengths};
use glam::Vec3;

fn boxes(rgb: Vec3, lambda: f32) -> f32 {
    if lambda < 490.0 {
        rgb.z
    } else if lambda < 580.0 {
        rgb.y
    } else {
        rgb.x
    }
}

/// Reflectance-like spectrum in [0, 1] from an RGB albedo.
#[derive(Clone, Copy, Debug)]
pub struct RgbAlbedoSpectrum {
    rgb: Vec3,
}
impl RgbAlbedoSpectrum {
    pub fn new(rgb: Vec3) -> Self {
        Self { rgb: rgb.clamp(Vec3::ZERO, Vec3::ONE) }
    }
    pub fn eval(&self, lambda: f32) -> f32 {
        boxes(self.rgb, lambda)
    }
    pub fn sample(&self, w: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::from_fn(|i| self.eval(w.lambda[i]))
    }
}

/// Non-negative spectrum of any magnitude (absorption/scattering coefficients).
#[derive(Clone, Copy, Debug)]
pub struct RgbUnboundedSpectrum {
    rgb: Vec3,
}
impl RgbUnboundedSpectrum {
    pub fn new(rgb: Vec3) -> Self {
        Self { rgb: rgb.max(Vec3::ZERO) }
    }
    pub fn eval(&self, lambda: f32) -> f32 {
        boxes(self.rgb, lambda)
    }
    pub fn sample(&self, w: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::from_fn(|i| self.eval(w.lambda[i]))
    }
}

/// Emission spectrum: the RGB colour's reflectance shape times the D65 illuminant, so RGB
/// white (1,1,1) renders as RGB white.
#[derive(Clone, Copy, Debug)]
pub struct RgbIlluminantSpectrum {
    rgb: Vec3,
}
impl RgbIlluminantSpectrum {
    pub fn new(rgb: Vec3) -> Self {
        Self { rgb: rgb.max(Vec3::ZERO) }
    }
    pub fn eval(&self, lambda: f32) -> f32 {
        boxes(self.rgb, lambda) * cie::d65_normalized(lambda)
    }
    pub fn sample(&self, w: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::from_fn(|i| self.eval(w.lambda[i]))
    }
}
