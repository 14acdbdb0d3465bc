//! Bidirectional scattering distribution functions, evaluated per sampled wavelength.
//!
//! Conventions (shared by every lobe): directions are unit vectors in the local shading frame
//! (normal = +z); `wo` points away from the surface towards the previous vertex (the camera side),
//! `wi` towards the next one (the light side). `eval` returns f(wo, wi) WITHOUT the cosine
//! factor; `sample` returns f and the solid-angle pdf of `wi`. Radiance transport only (the
//! 1/eta^2 factor for refraction is included).

use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

/// Result of sampling a direction from a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f(wo, wi), no cosine.
    pub f: SampledSpectrum,
    /// Solid-angle density of `wi` (for a specular lobe: the discrete probability of choosing it).
    pub pdf: f32,
    /// A Dirac lobe was chosen: `f / pdf` is the weight, light sampling cannot reach this direction.
    pub specular: bool,
    /// `wi` is on the other side of the surface from `wo`.
    pub transmission: bool,
    /// `wi` is valid for the hero wavelength only (dispersive specular refraction): the caller
    /// must call `SampledWavelengths::terminate_secondary`. `f` already holds the hero's value in
    /// slot 0 (other slots are ignored).
    pub terminates_secondary: bool,
}

/// The set of surface models. An enum rather than trait objects: a handful of lobes, built per
/// shading point on the stack, no allocation.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    Diffuse(DiffuseBsdf),
    MetallicRoughness(MetallicRoughnessBsdf),
    Dielectric(DielectricBsdf),
}

/// Lambertian reflection.
#[derive(Clone, Copy, Debug)]
pub struct DiffuseBsdf {
    pub reflectance: SampledSpectrum,
}

/// The glTF 2.0 metallic-roughness BRDF (spec appendix B) with KHR_materials_specular:
/// `mix(dielectric_brdf, conductor_brdf, metallic)` where the dielectric part is a GGX
/// specular layer over Lambertian diffuse weighted by a Schlick Fresnel with
/// f0 = min(((ior-1)/(ior+1))^2 * specular_color, 1) * specular and f90 = specular, and the
/// conductor is GGX with Schlick Fresnel f0 = base_color.
#[derive(Clone, Copy, Debug)]
pub struct MetallicRoughnessBsdf {
    pub base_color: SampledSpectrum,
    pub metallic: f32,
    /// GGX alpha = perceptual roughness^2 (clamped away from 0 for numerical safety).
    pub alpha: f32,
    pub specular: f32,
    pub specular_color: SampledSpectrum,
    pub ior: f32,
}

/// Dielectric interface: smooth (alpha == 0: exact Fresnel, specular reflection + refraction)
/// or rough (Walter et al. 2007 GGX microfacet BRDF + BTDF).
#[derive(Clone, Copy, Debug)]
pub struct DielectricBsdf {
    /// Relative IOR (inside / outside) per wavelength; all equal for non-dispersive glass.
    pub eta: SampledSpectrum,
    pub alpha: f32,
    /// Multiplies transmitted light (glTF transmission tinted by baseColor); ONE for clear glass.
    pub transmission_tint: SampledSpectrum,
}
