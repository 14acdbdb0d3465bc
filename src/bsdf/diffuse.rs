//! Lambertian reflection: f = R / pi, sampled with the cosine-weighted hemisphere warp; and
//! Lambertian transmission (Blender's Translucent BSDF): f = T / pi towards the other side.

use super::{BsdfSample, DiffuseBsdf, LobeFlags, TranslucentBsdf};
use crate::math::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use crate::math::INV_PI;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

impl DiffuseBsdf {
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return SampledSpectrum::ZERO;
        }
        self.reflectance * INV_PI
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        cosine_hemisphere_pdf(wi.z)
    }

    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (SampledSpectrum, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }

    pub fn sample(&self, wo: Vec3, _uc: f32, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let wi = sample_cosine_hemisphere(u);
        let pdf = cosine_hemisphere_pdf(wi.z);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.reflectance * INV_PI,
            pdf,
            flags: LobeFlags::REFLECTION.with(LobeFlags::DIFFUSE),
            eta: SampledSpectrum::ONE,
            pdf_wavelengths: SampledSpectrum::splat(pdf),
        })
    }
}

impl TranslucentBsdf {
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if !(wo.z * wi.z < 0.0) {
            return SampledSpectrum::ZERO;
        }
        self.transmittance * INV_PI
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z * wi.z < 0.0) {
            return 0.0;
        }
        cosine_hemisphere_pdf(wi.z.abs())
    }

    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (SampledSpectrum, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }

    /// A cosine-weighted direction in the hemisphere opposite `wo` (either side of the frame).
    pub fn sample(&self, wo: Vec3, _uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.z.is_finite() {
            return None;
        }
        let mut wi = sample_cosine_hemisphere(u);
        if wo.z > 0.0 {
            wi.z = -wi.z;
        }
        let pdf = cosine_hemisphere_pdf(wi.z.abs());
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.transmittance * INV_PI,
            pdf,
            flags: LobeFlags::TRANSMISSION.with(LobeFlags::DIFFUSE),
            eta: SampledSpectrum::ONE,
            pdf_wavelengths: SampledSpectrum::splat(pdf),
        })
    }
}
