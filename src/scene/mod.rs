//! Scene input: glTF import, the material JSON sidecar, and the render-ready `Scene`.

pub mod build;
pub mod camera;
pub mod desc;
pub mod lights;
pub mod material;

pub use build::Scene;
pub use camera::Camera;
pub use desc::*;
