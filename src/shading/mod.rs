//! The shading graph: Blender-style nodes (texture coordinates, images, colour and math nodes,
//! procedural textures) evaluated at a shading point, producing the inputs of a material
//! (base colour, roughness, ...). `parse` reads the material JSON's `graph` form (documented
//! there), `graph` compiles and evaluates it.
//!
//! Colours are linear Rec.709 RGB (Blender's scene-linear space); the material upsamples the
//! graph's RGB results to the path's wavelengths like every other RGB input.

pub mod color;
pub mod graph;
pub mod image;
pub mod math_ops;
pub mod noise;
pub mod parse;
pub mod procedural;
pub mod voronoi;

pub use graph::{MaterialInput, ShadingGraph};

use glam::{Vec2, Vec3, Vec4};

/// How many TEXCOORD_n / COLOR_n sets a graph can read.
pub const MAX_ATTRIBUTE_SETS: usize = 4;

/// What the graph can read at a shading point (Blender's conventions: UVs with v up, Cycles'
/// incoming vector pointing towards the viewer).
#[derive(Clone, Copy, Debug)]
pub struct ShadingInputs {
    /// UV sets in Blender's convention (origin bottom-left): (u, 1 - v) of glTF's TEXCOORD_n.
    pub uv: [Vec2; MAX_ATTRIBUTE_SETS],
    /// COLOR_n vertex colours (linear RGBA), white where the mesh has none.
    pub color: [Vec4; MAX_ATTRIBUTE_SETS],
    /// World-space position.
    pub position: Vec3,
    /// Object-space position (Texture Coordinate > Object).
    pub object: Vec3,
    /// The object-space position mapped to [0,1]^3 over the mesh's bounding box (Texture
    /// Coordinate > Generated, Blender's auto texture space).
    pub generated: Vec3,
    /// Shading normal, world space, flipped to the viewer's side on backfacing hits (Cycles'
    /// convention for every node that reads a normal).
    pub normal: Vec3,
    /// Shading normal in object space (Texture Coordinate > Normal).
    pub object_normal: Vec3,
    /// Turns object-space normals into world space: the inverse transpose of the object's
    /// linear transform (object-space normal maps).
    pub normal_to_world: glam::Mat3,
    /// Geometric normal, world space, flipped like `normal`.
    pub true_normal: Vec3,
    /// The tangent frame of TEXCOORD_0 (MikkTSpace tangents when the mesh has them), world
    /// space, around the outward shading normal: what tangent-space normal maps use.
    pub tangent: Vec3,
    pub bitangent: Vec3,
    /// Unit vector towards the viewer (the previous path vertex).
    pub incoming: Vec3,
    /// The ray hit the back of the surface (against the geometric normal).
    pub backfacing: bool,
    /// The shading point is seen directly by the camera.
    pub camera_ray: bool,
}

/// The shading inputs at two nearby points of the surface, for Bump nodes: the height is
/// evaluated at the point and at `p + dpdx`, `p + dpdy` (Cycles takes the offsets from ray
/// differentials, Prism from a pixel-sized step along two triangle edges).
#[derive(Clone, Copy, Debug)]
pub struct BumpInputs {
    pub dx: ShadingInputs,
    pub dy: ShadingInputs,
    pub dpdx: Vec3,
    pub dpdy: Vec3,
}

impl Default for ShadingInputs {
    fn default() -> Self {
        ShadingInputs {
            uv: [Vec2::ZERO; MAX_ATTRIBUTE_SETS],
            color: [Vec4::ONE; MAX_ATTRIBUTE_SETS],
            position: Vec3::ZERO,
            object: Vec3::ZERO,
            generated: Vec3::ZERO,
            normal: Vec3::Z,
            object_normal: Vec3::Z,
            normal_to_world: glam::Mat3::IDENTITY,
            true_normal: Vec3::Z,
            tangent: Vec3::X,
            bitangent: Vec3::Y,
            incoming: Vec3::Z,
            backfacing: false,
            camera_ray: false,
        }
    }
}
