//! Scene input: glTF import, the material JSON sidecar, and the render-ready `Scene`.

pub mod build;
pub mod camera;
pub mod desc;
pub mod gltf_graph;
pub mod gltf_import;
pub mod gltf_json;
pub mod load;
pub mod material;
pub mod materials_json;
pub mod texture;

pub use build::Scene;
pub use camera::Camera;
pub use desc::*;
pub use load::{load_scene, load_scene_any_camera};
