//! Scene input: glTF import, the material JSON sidecar, and the render-ready `Scene`.

pub mod desc;

pub use desc::*;
