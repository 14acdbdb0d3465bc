//! Light transport: the path tracer and wavelength sampling of camera paths.

pub mod caustics;
pub mod path;
pub mod spectral_mis;
pub mod splitting;
pub mod wavelengths;

pub use path::{CameraRay, PathSample, PathTracer};
pub use wavelengths::{WavelengthPdf, WavelengthSampling, WavelengthStrategy};
