//! Light transport: the path tracer and wavelength sampling of camera paths.

pub mod path;

pub use path::{PathSample, PathTracer};
