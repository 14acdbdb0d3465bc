//! Prism: a spectral, physically based path tracer.
//!
//! Data flows one way: scene files -> [`scene`] (geometry, materials, lights, camera) ->
//! [`integrator`] (per pixel, per path) -> [`film`] -> EXR.

pub mod bsdf;
pub mod bssrdf;
pub mod error;
pub mod film;
pub mod geometry;
pub mod integrator;
pub mod lights;
pub mod math;
pub mod media;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod serve;
pub mod shading;
pub mod spectrum;

pub use error::PrismError;
