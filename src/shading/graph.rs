//! A compiled shading graph: nodes in evaluation order, each reading constants, implicit inputs
//! (the UV map, generated coordinates, the normal) or earlier nodes' outputs, and the material
//! inputs it drives.
//!
//! Every socket value is a `Vec4` (a float in `x`, a vector or colour in `xyz`); links between
//! sockets of different types convert as Blender does (colour -> float: luminance, vector ->
//! float: the average, float -> colour/vector: splat). Evaluation writes each node's outputs
//! into a per-thread slot array, so a shading point costs one pass over the nodes it needs and
//! no allocation.

use std::cell::RefCell;
use std::sync::Arc;

use glam::{Mat3, Vec2, Vec3, Vec4, Vec4Swizzles};

use super::color::{
    blackbody, bright_contrast, gamma, hsl_to_rgb, hsv_to_rgb, hue_saturation_value, luminance,
    rgb_to_hsl, rgb_to_hsv, wavelength_color, BlendMode, ColorRamp, CurveTable,
};
use super::image::{Extension, Image, Interpolation};
use super::math_ops::{safe_divide, smootherstep, smoothstep, MathOp, VectorMathOp};
use super::noise::{noise_texture, white_noise, Fractal, FractalKind};
use super::procedural::{checker, gradient, magic, Brick, GradientKind, Wave};
use super::voronoi::{Feature, Metric, VoronoiParams};
use super::{BumpInputs, ShadingInputs};
use crate::bsdf::fresnel_dielectric;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SocketType {
    Float,
    Vector,
    Color,
}

/// Converts a value of type `from` for a socket of type `to` (Blender's implicit conversions).
#[inline]
pub fn convert(v: Vec4, from: SocketType, to: SocketType) -> Vec4 {
    use SocketType::*;
    match (from, to) {
        (Color, Float) => Vec4::splat(luminance(v.xyz())),
        (Vector, Float) => Vec4::splat((v.x + v.y + v.z) / 3.0),
        (Float, Vector) | (Float, Color) => Vec4::splat(v.x),
        _ => v,
    }
}

/// Inputs a node reads when nothing is linked and no value is given (Blender's implicit
/// defaults: Image Texture reads the active UV map, procedural textures the generated
/// coordinates, Fresnel and Layer Weight the shading normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Implicit {
    Uv,
    Generated,
    Normal,
}

/// Where an input's value comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Source {
    Const(Vec4),
    Implicit(Implicit),
    /// Output slot `slot`, of type `from`, read as `to`.
    Link {
        slot: u32,
        from: SocketType,
        to: SocketType,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MappingKind {
    Point,
    Texture,
    Vector,
    Normal,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorModel {
    Rgb,
    Hsv,
    Hsl,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapRangeInterpolation {
    Linear,
    Stepped,
    SmoothStep,
    SmootherStep,
}

/// A node and its settings (the non-socket properties of Blender's node).
#[derive(Clone, Debug)]
pub enum NodeOp {
    TexCoord,
    UvMap(usize),
    ColorAttribute(usize),
    Geometry,
    LightPath,
    Fresnel,
    LayerWeight,
    Mapping(MappingKind),
    ImageTexture {
        image: Arc<Image>,
        interpolation: Interpolation,
        /// Along u and v (Blender's node: the same mode; glTF samplers: each its own).
        extension: [Extension; 2],
    },
    /// glTF's KHR_texture_transform (offset, rotation, scale), as an affine map of Blender
    /// UVs (the glTF matrix conjugated by the v flip; see `scene::gltf_graph`).
    UvTransform(Mat3),
    Math {
        op: MathOp,
        clamp: bool,
    },
    VectorMath(VectorMathOp),
    MixFloat {
        clamp_factor: bool,
    },
    MixVector {
        clamp_factor: bool,
    },
    MixColor {
        blend: BlendMode,
        clamp_factor: bool,
        clamp_result: bool,
    },
    Invert,
    HueSaturation,
    BrightContrast,
    Gamma,
    RgbToBw,
    SeparateColor(ColorModel),
    CombineColor(ColorModel),
    SeparateXyz,
    CombineXyz,
    MapRange {
        interpolation: MapRangeInterpolation,
        clamp: bool,
    },
    Clamp {
        range: bool,
    },
    ColorRamp(ColorRamp),
    Checker,
    Gradient(GradientKind),
    Noise {
        dimensions: u8,
        kind: FractalKind,
        normalize: bool,
    },
    WhiteNoise(u8),
    Voronoi {
        dimensions: u8,
        feature: Feature,
        metric: Metric,
        normalize: bool,
    },
    Wave(Wave),
    /// Bump: the normal tilted by the gradient of the height input, from the height at the
    /// point and at two nearby points (see `BumpInputs`).
    Bump {
        invert: bool,
        /// The offsets to the two nearby points, in pixels of the camera's footprint (Blender
        /// 4.5+'s Filter Width, default 0.1; earlier Cycles used 1, the whole differential).
        filter_width: f32,
    },
    Blackbody,
    /// Normal Map: a colour-encoded normal in tangent space (TEXCOORD_0's frame), object space
    /// (the object's own axes, turned to world space by its normal matrix) or world space.
    NormalMap {
        space: NormalSpace,
    },
    /// RGB Curves (3 tables: R, G, B, each with the combined curve applied) or Float Curve (1).
    Curves(Vec<CurveTable>),
    /// Vector Curves: one table per axis (X, Y, Z), usually over [-1, 1].
    VectorCurves(Vec<CurveTable>),
    /// Wavelength: the colour of a wavelength in nm (`color::wavelength_color`).
    Wavelength,
    Magic {
        depth: i32,
    },
    Brick(Brick),
}

/// The space a Normal Map node's colour encodes its normal in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalSpace {
    Tangent,
    Object,
    World,
    /// Blender's own convention for object- and world-space maps (as its old bakes wrote
    /// them): the colour's Y and Z axes point the other way (Cycles' Normal Map node negates
    /// them before reading the map as object or world space).
    BlenderObject,
    BlenderWorld,
}

use SocketType::{Color as C, Float as F, Vector as V};

/// A socket: name in the material JSON, type, default value.
pub type Socket = (&'static str, SocketType, Vec4);

const fn f(name: &'static str, v: f32) -> Socket {
    (name, F, Vec4::new(v, v, v, v))
}
const fn vec(name: &'static str, x: f32, y: f32, z: f32) -> Socket {
    (name, V, Vec4::new(x, y, z, 0.0))
}
const fn col(name: &'static str, r: f32, g: f32, b: f32) -> Socket {
    (name, C, Vec4::new(r, g, b, 1.0))
}
const fn out(name: &'static str, t: SocketType) -> Socket {
    (name, t, Vec4::ZERO)
}

/// The node types of the JSON form, their inputs and outputs.
pub struct NodeSignature {
    pub inputs: &'static [Socket],
    pub outputs: &'static [Socket],
}

impl NodeOp {
    pub fn signature(&self) -> NodeSignature {
        use NodeOp::*;
        let (inputs, outputs): (&'static [Socket], &'static [Socket]) = match self {
            TexCoord => (
                const { &[] },
                const {
                    &[
                        out("generated", V),
                        out("normal", V),
                        out("uv", V),
                        out("object", V),
                        out("reflection", V),
                    ]
                },
            ),
            UvMap(_) => (const { &[] }, const { &[out("uv", V)] }),
            ColorAttribute(_) => (const { &[] }, const { &[out("color", C), out("alpha", F)] }),
            Geometry => (
                const { &[] },
                const {
                    &[
                        out("position", V),
                        out("normal", V),
                        out("true_normal", V),
                        out("incoming", V),
                        out("backfacing", F),
                    ]
                },
            ),
            LightPath => (const { &[] }, const { &[out("is_camera_ray", F)] }),
            Fresnel => (
                const { &[f("ior", 1.45), vec("normal", 0.0, 0.0, 0.0)] },
                const { &[out("fac", F)] },
            ),
            LayerWeight => (
                const { &[f("blend", 0.5), vec("normal", 0.0, 0.0, 0.0)] },
                const { &[out("fresnel", F), out("facing", F)] },
            ),
            Mapping(_) => (
                const {
                    &[
                        vec("vector", 0.0, 0.0, 0.0),
                        vec("location", 0.0, 0.0, 0.0),
                        vec("rotation", 0.0, 0.0, 0.0),
                        vec("scale", 1.0, 1.0, 1.0),
                    ]
                },
                const { &[out("vector", V)] },
            ),
            ImageTexture { .. } => (
                const { &[vec("vector", 0.0, 0.0, 0.0)] },
                const { &[out("color", C), out("alpha", F)] },
            ),
            UvTransform(_) => (
                const { &[vec("vector", 0.0, 0.0, 0.0)] },
                const { &[out("vector", V)] },
            ),
            Math { .. } => (
                const { &[f("a", 0.5), f("b", 0.5), f("c", 0.0)] },
                const { &[out("value", F)] },
            ),
            VectorMath(_) => (
                const {
                    &[
                        vec("a", 0.0, 0.0, 0.0),
                        vec("b", 0.0, 0.0, 0.0),
                        vec("c", 0.0, 0.0, 0.0),
                        f("scale", 1.0),
                    ]
                },
                const { &[out("vector", V), out("value", F)] },
            ),
            MixFloat { .. } => (
                const { &[f("factor", 0.5), f("a", 0.0), f("b", 0.0)] },
                const { &[out("result", F)] },
            ),
            MixVector { .. } => (
                const {
                    &[
                        f("factor", 0.5),
                        vec("a", 0.0, 0.0, 0.0),
                        vec("b", 0.0, 0.0, 0.0),
                    ]
                },
                const { &[out("result", V)] },
            ),
            MixColor { .. } => (
                const {
                    &[
                        f("factor", 0.5),
                        col("a", 0.5, 0.5, 0.5),
                        col("b", 0.5, 0.5, 0.5),
                    ]
                },
                const { &[out("result", C)] },
            ),
            Invert => (
                const { &[f("fac", 1.0), col("color", 0.0, 0.0, 0.0)] },
                const { &[out("color", C)] },
            ),
            HueSaturation => (
                const {
                    &[
                        f("hue", 0.5),
                        f("saturation", 1.0),
                        f("value", 1.0),
                        f("fac", 1.0),
                        col("color", 0.8, 0.8, 0.8),
                    ]
                },
                const { &[out("color", C)] },
            ),
            BrightContrast => (
                const {
                    &[
                        col("color", 1.0, 1.0, 1.0),
                        f("bright", 0.0),
                        f("contrast", 0.0),
                    ]
                },
                const { &[out("color", C)] },
            ),
            Gamma => (
                const { &[col("color", 1.0, 1.0, 1.0), f("gamma", 1.0)] },
                const { &[out("color", C)] },
            ),
            RgbToBw => (
                const { &[col("color", 0.5, 0.5, 0.5)] },
                const { &[out("val", F)] },
            ),
            SeparateColor(_) => (
                const { &[col("color", 0.8, 0.8, 0.8)] },
                const { &[out("red", F), out("green", F), out("blue", F)] },
            ),
            CombineColor(_) => (
                const { &[f("red", 0.0), f("green", 0.0), f("blue", 0.0)] },
                const { &[out("color", C)] },
            ),
            SeparateXyz => (
                const { &[vec("vector", 0.0, 0.0, 0.0)] },
                const { &[out("x", F), out("y", F), out("z", F)] },
            ),
            CombineXyz => (
                const { &[f("x", 0.0), f("y", 0.0), f("z", 0.0)] },
                const { &[out("vector", V)] },
            ),
            MapRange { .. } => (
                const {
                    &[
                        f("value", 1.0),
                        f("from_min", 0.0),
                        f("from_max", 1.0),
                        f("to_min", 0.0),
                        f("to_max", 1.0),
                        f("steps", 4.0),
                    ]
                },
                const { &[out("result", F)] },
            ),
            Clamp { .. } => (
                const { &[f("value", 1.0), f("min", 0.0), f("max", 1.0)] },
                const { &[out("result", F)] },
            ),
            ColorRamp(_) => (
                const { &[f("fac", 0.5)] },
                const { &[out("color", C), out("alpha", F)] },
            ),
            Checker => (
                const {
                    &[
                        vec("vector", 0.0, 0.0, 0.0),
                        col("color1", 0.8, 0.8, 0.8),
                        col("color2", 0.2, 0.2, 0.2),
                        f("scale", 5.0),
                    ]
                },
                const { &[out("color", C), out("fac", F)] },
            ),
            Gradient(_) => (
                const { &[vec("vector", 0.0, 0.0, 0.0)] },
                const { &[out("color", C), out("fac", F)] },
            ),
            Noise { .. } => (
                const {
                    &[
                        vec("vector", 0.0, 0.0, 0.0),
                        f("w", 0.0),
                        f("scale", 5.0),
                        f("detail", 2.0),
                        f("roughness", 0.5),
                        f("lacunarity", 2.0),
                        f("offset", 0.0),
                        f("gain", 1.0),
                        f("distortion", 0.0),
                    ]
                },
                const { &[out("fac", F), out("color", C)] },
            ),
            WhiteNoise(_) => (
                const { &[vec("vector", 0.0, 0.0, 0.0), f("w", 0.0)] },
                const { &[out("value", F), out("color", C)] },
            ),
            Voronoi { .. } => (
                const {
                    &[
                        vec("vector", 0.0, 0.0, 0.0),
                        f("w", 0.0),
                        f("scale", 5.0),
                        f("detail", 0.0),
                        f("roughness", 0.5),
                        f("lacunarity", 2.0),
                        f("smoothness", 1.0),
                        f("exponent", 0.5),
                        f("randomness", 1.0),
                    ]
                },
                const {
                    &[
                        out("distance", F),
                        out("color", C),
                        out("position", V),
                        out("w", F),
                        out("radius", F),
                    ]
                },
            ),
            Curves(t) if t.len() == 1 => (
                const { &[f("fac", 1.0), f("value", 1.0)] },
                const { &[out("value", F)] },
            ),
            Curves(_) => (
                const { &[f("fac", 1.0), col("color", 1.0, 1.0, 1.0)] },
                const { &[out("color", C)] },
            ),
            Blackbody => (
                const { &[f("temperature", 1500.0)] },
                const { &[out("color", C)] },
            ),
            VectorCurves(_) => (
                const { &[f("fac", 1.0), vec("vector", 0.0, 0.0, 0.0)] },
                const { &[out("vector", V)] },
            ),
            Wavelength => (
                const { &[f("wavelength", 500.0)] },
                const { &[out("color", C)] },
            ),
            NormalMap { .. } => (
                const { &[f("strength", 1.0), col("color", 0.5, 0.5, 1.0)] },
                const { &[out("normal", V)] },
            ),
            Bump { .. } => (
                const {
                    &[
                        f("strength", 1.0),
                        f("distance", 1.0),
                        f("height", 1.0),
                        vec("normal", 0.0, 0.0, 0.0),
                    ]
                },
                const { &[out("normal", V)] },
            ),
            Wave(_) => (
                const {
                    &[
                        vec("vector", 0.0, 0.0, 0.0),
                        f("scale", 5.0),
                        f("distortion", 0.0),
                        f("detail", 2.0),
                        f("detail_scale", 1.0),
                        f("detail_roughness", 0.5),
                        f("phase_offset", 0.0),
                    ]
                },
                const { &[out("color", C), out("fac", F)] },
            ),
            Magic { .. } => (
                const {
                    &[
                        vec("vector", 0.0, 0.0, 0.0),
                        f("scale", 5.0),
                        f("distortion", 1.0),
                    ]
                },
                const { &[out("color", C), out("fac", F)] },
            ),
            Brick(_) => (
                const {
                    &[
                        vec("vector", 0.0, 0.0, 0.0),
                        col("color1", 0.8, 0.8, 0.8),
                        col("color2", 0.2, 0.2, 0.2),
                        col("mortar", 0.0, 0.0, 0.0),
                        f("scale", 5.0),
                        f("mortar_size", 0.02),
                        f("mortar_smooth", 0.1),
                        f("bias", 0.0),
                        f("brick_width", 0.5),
                        f("row_height", 0.25),
                    ]
                },
                const { &[out("color", C), out("fac", F)] },
            ),
        };
        NodeSignature { inputs, outputs }
    }

    /// The implicit value of an unlinked input given no value (else the signature default).
    pub fn implicit_input(&self, input: &str) -> Option<Implicit> {
        use NodeOp::*;
        match (self, input) {
            (ImageTexture { .. }, "vector") => Some(Implicit::Uv),
            (
                Checker
                | Gradient(_)
                | Noise { .. }
                | WhiteNoise(_)
                | Voronoi { .. }
                | Wave(_)
                | Magic { .. }
                | Brick(_),
                "vector",
            ) => Some(Implicit::Generated),
            (Fresnel | LayerWeight | Bump { .. }, "normal") => Some(Implicit::Normal),
            _ => None,
        }
    }
}

/// A node with its inputs resolved.
#[derive(Clone, Debug)]
pub struct GraphNode {
    pub name: String,
    pub op: NodeOp,
    pub inputs: Vec<Source>,
    /// Index of its first output slot.
    pub first_slot: u32,
}

/// The material inputs a graph can drive (the Principled BSDF's, as the glTF model has them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialInput {
    BaseColor,
    Metallic,
    Roughness,
    /// The specular factor (KHR_materials_specular; 1 = F0 of the IOR).
    Specular,
    Transmission,
    Emission,
    EmissionStrength,
    /// Coverage: 1 opaque, 0 fully transparent (Principled Alpha; stochastic transparency).
    Alpha,
    /// The shading normal (world space, on the viewer's side like `ShadingInputs::normal`),
    /// from a Bump node or any vector graph.
    Normal,
    /// 1: the closure is Lambertian transmission (Translucent BSDF) of colour `base_color`.
    Translucent,
    /// A multiplier on the material's volume coefficients at a point inside it (a textured
    /// Density: heterogeneous volumes, `crate::media`).
    VolumeDensity,
    /// 1: the closure is Blender's Refraction BSDF (the dielectric's refraction alone, tinted
    /// by `base_color`, with the material's IOR and `roughness`).
    Refraction,
    /// Principled Coat Weight, Roughness and Tint (the material's coat, textured).
    CoatWeight,
    CoatRoughness,
    CoatTint,
    /// Principled Sheen: its colour (Weight x Tint) and the (Charlie) roughness.
    SheenColor,
    SheenRoughness,
    /// Principled Specular Tint (4.x colour): the dielectric F0's tint and the metal's F82
    /// edge tint (KHR_materials_specular's specular colour).
    SpecularTint,
    /// Principled Thin Film Thickness (nm; 0: no film) and IOR.
    ThinFilmThickness,
    ThinFilmIor,
    /// The clear coat's own shading normal (Blender's Coat Normal), as `Normal`.
    CoatNormal,
    /// The colour of a subsurface medium given by a colour (`crate::bssrdf::SubsurfaceMaterial::at`):
    /// Blender's subsurface colour (4.x Base Color), textured.
    SubsurfaceColor,
    /// The clear coat's IOR (Blender's Coat IOR; at least 1).
    CoatIor,
    /// The thin film's weight where `ThinFilmThickness` is driven (1 when unbound):
    /// KHR_materials_iridescence's factor, textured.
    ThinFilmWeight,
    /// The colour of a volume at a point inside the material (a textured Principled Volume,
    /// Volume Scatter or Volume Absorption Color): its coefficients are those of the material
    /// JSON's `volume` where it is white and of `volume.color_zero` where it is black, linear
    /// in between per wavelength (`crate::media`).
    VolumeColor,
}

pub const MATERIAL_INPUTS: &[(&str, MaterialInput, SocketType)] = &[
    ("base_color", MaterialInput::BaseColor, C),
    ("metallic", MaterialInput::Metallic, F),
    ("roughness", MaterialInput::Roughness, F),
    ("specular", MaterialInput::Specular, F),
    ("transmission", MaterialInput::Transmission, F),
    ("emission", MaterialInput::Emission, C),
    ("emission_strength", MaterialInput::EmissionStrength, F),
    ("alpha", MaterialInput::Alpha, F),
    ("normal", MaterialInput::Normal, V),
    ("translucent", MaterialInput::Translucent, F),
    ("volume_density", MaterialInput::VolumeDensity, F),
    ("refraction", MaterialInput::Refraction, F),
    ("coat_weight", MaterialInput::CoatWeight, F),
    ("coat_roughness", MaterialInput::CoatRoughness, F),
    ("coat_tint", MaterialInput::CoatTint, C),
    ("sheen_color", MaterialInput::SheenColor, C),
    ("sheen_roughness", MaterialInput::SheenRoughness, F),
    ("specular_tint", MaterialInput::SpecularTint, C),
    ("thin_film_thickness", MaterialInput::ThinFilmThickness, F),
    ("thin_film_ior", MaterialInput::ThinFilmIor, F),
    ("coat_normal", MaterialInput::CoatNormal, V),
    ("subsurface_color", MaterialInput::SubsurfaceColor, C),
    ("coat_ior", MaterialInput::CoatIor, F),
    ("thin_film_weight", MaterialInput::ThinFilmWeight, F),
    ("volume_color", MaterialInput::VolumeColor, C),
];

pub const N_MATERIAL_INPUTS: usize = 25;

impl MaterialInput {
    pub fn index(self) -> usize {
        self as usize
    }
    fn is_emission(self) -> bool {
        matches!(
            self,
            MaterialInput::Emission | MaterialInput::EmissionStrength
        )
    }

    /// Which evaluation program computes the input: 0 scattering, 1 emission, 2 normal,
    /// 3 volume density, `ALPHA_PROGRAM` coverage (BSDFs never read Alpha).
    fn program(self) -> usize {
        match self {
            MaterialInput::Emission | MaterialInput::EmissionStrength => 1,
            MaterialInput::Normal | MaterialInput::CoatNormal => 2,
            MaterialInput::VolumeDensity | MaterialInput::VolumeColor => 3,
            MaterialInput::Alpha => ALPHA_PROGRAM,
            _ => 0,
        }
    }
}

/// Values of the material inputs the graph drives at one shading point (`None`: not driven).
pub type InputValues = [Option<Vec4>; N_MATERIAL_INPUTS];

/// The leaf of a mixture that scatters at one shading point.
// Returned by value once per shading point and never stored: boxing the inputs would cost an
// allocation per hit for nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum ClosurePick {
    /// A BSDF leaf, with its inputs.
    Bsdf(InputValues),
    /// A subsurface leaf: the material's subsurface medium takes the path, with the leaf's
    /// subsurface colour if the graph drives it.
    Subsurface(Option<Vec3>),
}

/// One leaf of a Mix / Add Shader tree: a BSDF or an emission with its weight (the product of
/// the mix factors above it) and its own inputs.
#[derive(Clone, Debug)]
pub struct Closure {
    pub emission: bool,
    /// A Transparent BSDF leaf: its weight is the surface's transparency.
    pub transparent: bool,
    /// A subsurface leaf (Subsurface Scattering node, a Principled leaf's subsurface share):
    /// picked like a BSDF leaf, it hands the path to the material's subsurface medium.
    pub subsurface: bool,
    pub weight: Source,
    pub bindings: Vec<(MaterialInput, Source)>,
}

/// A compiled graph.
#[derive(Debug)]
pub struct ShadingGraph {
    pub nodes: Vec<GraphNode>,
    n_slots: usize,
    bindings: Vec<(MaterialInput, Source)>,
    /// Mixed closures (empty: the material is the one model `bindings` drive).
    closures: Vec<Closure>,
    /// Nodes (in evaluation order) the scattering inputs need, and those emission needs.
    surface_program: Vec<u32>,
    emission_program: Vec<u32>,
    normal_program: Vec<u32>,
    volume_program: Vec<u32>,
    /// The nodes coverage needs (Alpha, the Transparent leaves' weights and colours): shadow
    /// rays and alpha tests run only these.
    alpha_program: Vec<u32>,
    /// World-space inputs and the normal output are in a Z-up frame (Blender's; the add-on's
    /// graphs) rather than the scene's glTF Y-up one.
    pub z_up: bool,
    /// (Bump node, the nodes its height input needs), for evaluation at offset points.
    bump_cones: Vec<(u32, Vec<u32>)>,
    /// See [`ShadingGraph::reads_object_space`].
    reads_object_space: bool,
    /// See [`ShadingGraph::bump_filter_width`] (read per bumped shading point: kept here).
    bump_filter_width: f32,
}

/// `ShadingGraph::run_with`'s index of the coverage program.
const ALPHA_PROGRAM: usize = 4;

thread_local! {
    static SLOTS: RefCell<Vec<Vec4>> = const { RefCell::new(Vec::new()) };
    static BUMP_SLOTS: RefCell<Vec<Vec4>> = const { RefCell::new(Vec::new()) };
}

/// The Bump node's normal (Cycles' formulation of Mikkelsen 2010, "Bump Mapping Unparametrized
/// Surfaces on the GPU"): with R_x = dPdy x N, R_y = N x dPdx and det = dPdx . R_x, the surface
/// gradient dh_x R_x + dh_y R_y tilts N: normalize(|det| N - distance sign(det) grad), blended
/// with N by `strength`.
pub fn bump_normal(
    n: Vec3,
    dpdx: Vec3,
    dpdy: Vec3,
    dhx: f32,
    dhy: f32,
    strength: f32,
    distance: f32,
) -> Vec3 {
    let rx = dpdy.cross(n);
    let ry = n.cross(dpdx);
    let det = dpdx.dot(rx);
    let grad = dhx * rx + dhy * ry;
    let bumped = (det.abs() * n - distance * det.signum() * grad)
        .try_normalize()
        .unwrap_or(n);
    let s = strength.max(0.0);
    (s * bumped + (1.0 - s) * n).try_normalize().unwrap_or(n)
}

/// Rotation of Blender's Mapping node: Euler XYZ (X applied first).
fn euler_xyz(r: Vec3) -> Mat3 {
    Mat3::from_rotation_z(r.z) * Mat3::from_rotation_y(r.y) * Mat3::from_rotation_x(r.x)
}

impl ShadingGraph {
    /// `nodes` must be in evaluation order (links point backwards) with consecutive slots.
    pub fn new(nodes: Vec<GraphNode>, bindings: Vec<(MaterialInput, Source)>) -> Self {
        Self::with_closures(nodes, bindings, Vec::new())
    }

    /// A graph whose surface is a mixture of `closures`.
    pub fn with_closures(
        nodes: Vec<GraphNode>,
        bindings: Vec<(MaterialInput, Source)>,
        closures: Vec<Closure>,
    ) -> Self {
        let n_slots = nodes
            .iter()
            .map(|n| n.first_slot as usize + n.op.signature().outputs.len())
            .max()
            .unwrap_or(0);
        let slot_owner = |slot: u32| nodes.iter().rposition(|n| n.first_slot <= slot);
        let cone = |sources: Vec<Source>| -> Vec<u32> {
            let mut needed = vec![false; nodes.len()];
            let mut stack: Vec<u32> = sources
                .iter()
                .filter_map(|s| match s {
                    Source::Link { slot, .. } => Some(*slot),
                    _ => None,
                })
                .collect();
            while let Some(slot) = stack.pop() {
                let Some(i) = slot_owner(slot) else { continue };
                if needed[i] {
                    continue;
                }
                needed[i] = true;
                for s in &nodes[i].inputs {
                    if let Source::Link { slot, .. } = s {
                        stack.push(*slot);
                    }
                }
            }
            (0..nodes.len() as u32)
                .filter(|&i| needed[i as usize])
                .collect()
        };
        let program = |which: usize| -> Vec<u32> {
            let mut sources: Vec<Source> = bindings
                .iter()
                .filter(|(m, _)| m.program() == which)
                .map(|(_, s)| *s)
                .collect();
            let emission = which == 1;
            for c in closures
                .iter()
                .filter(|c| which < 2 && (c.emission == emission || c.transparent))
            {
                sources.push(c.weight);
                sources.extend(c.bindings.iter().map(|(_, s)| *s));
            }
            cone(sources)
        };
        // Nodes that read only UVs, colours, the normals, the position, the view and the
        // ray type (a whitelist: a new node counts as reading everything until listed).
        let cheap = |op: &NodeOp| {
            use NodeOp::*;
            matches!(
                op,
                UvMap(_)
                    | ColorAttribute(_)
                    | Geometry
                    | LightPath
                    | Fresnel
                    | LayerWeight
                    | Mapping(_)
                    | ImageTexture { .. }
                    | UvTransform(_)
                    | Math { .. }
                    | VectorMath(_)
                    | MixFloat { .. }
                    | MixVector { .. }
                    | MixColor { .. }
                    | Invert
                    | HueSaturation
                    | BrightContrast
                    | Gamma
                    | RgbToBw
                    | SeparateColor(_)
                    | CombineColor(_)
                    | SeparateXyz
                    | CombineXyz
                    | MapRange { .. }
                    | Clamp { .. }
                    | ColorRamp(_)
                    | Curves(_)
                    | VectorCurves(_)
                    | Blackbody
                    | Wavelength
            )
        };
        let generated = |s: &Source| matches!(s, Source::Implicit(Implicit::Generated));
        let reads_object_space = nodes
            .iter()
            .any(|n| !cheap(&n.op) || n.inputs.iter().any(generated))
            || bindings.iter().any(|(_, s)| generated(s))
            || closures
                .iter()
                .any(|c| generated(&c.weight) || c.bindings.iter().any(|(_, s)| generated(s)));
        let bump_filter_width = nodes
            .iter()
            .filter_map(|n| match n.op {
                NodeOp::Bump { filter_width, .. } => Some(filter_width),
                _ => None,
            })
            .reduce(f32::max)
            .unwrap_or(0.1);
        let surface_program = program(0);
        let emission_program = program(1);
        let normal_program = program(2);
        let volume_program = program(3);
        let alpha_program = {
            let mut sources: Vec<Source> = bindings
                .iter()
                .filter(|(m, _)| *m == MaterialInput::Alpha)
                .map(|(_, s)| *s)
                .collect();
            for c in closures.iter().filter(|c| c.transparent) {
                sources.push(c.weight);
                sources.extend(
                    c.bindings
                        .iter()
                        .filter(|(m, _)| *m == MaterialInput::BaseColor)
                        .map(|(_, s)| *s),
                );
            }
            cone(sources)
        };
        // The height cone of every Bump node: re-run at the offset points.
        let bump_cones = nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| matches!(n.op, NodeOp::Bump { .. }))
            .map(|(i, n)| (i as u32, cone(vec![n.inputs[2]])))
            .collect();
        ShadingGraph {
            nodes,
            n_slots,
            bindings,
            closures,
            surface_program,
            emission_program,
            normal_program,
            volume_program,
            alpha_program,
            bump_cones,
            z_up: false,
            reads_object_space,
            bump_filter_width,
        }
    }

    /// Some node reads the object-space or tangent-frame inputs (`ShadingInputs::object`,
    /// `generated`, `object_normal`, `normal_to_world`, `tangent`, `bitangent`); without
    /// them the integrator gathers only the cheap inputs (`Geometry::shading_inputs`).
    pub fn reads_object_space(&self) -> bool {
        self.reads_object_space
    }

    /// This graph with `nodes` appended (their slots and links counted from 0) and
    /// `fallbacks` bound wherever the graph leaves the input unbound: the glTF textures under
    /// a sidecar graph (`scene::gltf_graph`). Without mixed closures they join the top-level
    /// bindings. With them, the scattering inputs go to every BSDF and subsurface leaf that
    /// does not bind them itself (a leaf's unbound inputs are the material's own values),
    /// Alpha to the top level when the graph has no coverage of its own, and emission stays
    /// the emission leaves'.
    pub fn with_fallbacks(
        &self,
        nodes: Vec<GraphNode>,
        fallbacks: Vec<(MaterialInput, Source)>,
    ) -> ShadingGraph {
        let offset = self.n_slots as u32;
        let shift = |s: Source| match s {
            Source::Link { slot, from, to } => Source::Link {
                slot: slot + offset,
                from,
                to,
            },
            other => other,
        };
        let mut all = self.nodes.clone();
        all.extend(nodes.into_iter().map(|n| GraphNode {
            first_slot: n.first_slot + offset,
            inputs: n.inputs.into_iter().map(shift).collect(),
            ..n
        }));
        let mut bindings = self.bindings.clone();
        let mut closures = self.closures.clone();
        let has_alpha = self.has_alpha();
        for (m, source) in fallbacks {
            let source = shift(source);
            if closures.is_empty() {
                if !self.drives(m) {
                    bindings.push((m, source));
                }
            } else if m == MaterialInput::Alpha {
                if !has_alpha {
                    bindings.push((m, source));
                }
            } else if !m.is_emission() {
                for c in closures
                    .iter_mut()
                    .filter(|c| !c.emission && !c.transparent)
                {
                    if !c.bindings.iter().any(|(b, _)| *b == m) {
                        c.bindings.push((m, source));
                    }
                }
            }
        }
        let mut graph = ShadingGraph::with_closures(all, bindings, closures);
        graph.z_up = self.z_up;
        graph
    }

    /// The filter width (pixels) the bump offsets use at a shading point: the largest of the
    /// graph's Bump nodes' (one pair of offset points serves them all), 0.1 without any.
    pub fn bump_filter_width(&self) -> f32 {
        self.bump_filter_width
    }

    pub fn drives_normal(&self) -> bool {
        self.bindings
            .iter()
            .any(|(m, _)| *m == MaterialInput::Normal)
    }

    pub fn drives_coat_normal(&self) -> bool {
        self.bindings
            .iter()
            .any(|(m, _)| *m == MaterialInput::CoatNormal)
    }

    /// The graph's shading normal at `ctx` (viewer's side, unit), Bump nodes using `bump`.
    pub fn normal(&self, ctx: &ShadingInputs, bump: &BumpInputs) -> Option<Vec3> {
        self.normal_input(MaterialInput::Normal, ctx, bump)
    }

    /// The graph's coat normal at `ctx`, as [`ShadingGraph::normal`].
    pub fn coat_normal(&self, ctx: &ShadingInputs, bump: &BumpInputs) -> Option<Vec3> {
        self.normal_input(MaterialInput::CoatNormal, ctx, bump)
    }

    fn normal_input(
        &self,
        input: MaterialInput,
        ctx: &ShadingInputs,
        bump: &BumpInputs,
    ) -> Option<Vec3> {
        let source = self.bindings.iter().find(|(m, _)| *m == input)?.1;
        let ctx = &self.local(ctx);
        let bump = BumpInputs {
            dx: *self.local(&bump.dx),
            dy: *self.local(&bump.dy),
            dpdx: self.vector_in(bump.dpdx),
            dpdy: self.vector_in(bump.dpdy),
        };
        let n = self
            .run_with(ctx, 2, Some(&bump), |slots| read(&source, slots, ctx))
            .xyz()
            .try_normalize()?;
        Some(self.vector_out(n))
    }

    /// The two world-space directions (unit, in the tangent plane of the geometric normal
    /// `ng`, on the viewer's side) along which Bump nodes offset their height: the basis
    /// Cycles builds around Ng for its compact ray differentials, a = normalize((1, 1, 1) x
    /// Ng) (or (-1, 1, 1) x Ng when Ng's components are all equal) and b = Ng x a, taken in
    /// the graph's world frame. For smooth heights any basis gives the same normal; for
    /// stepwise ones (a Filter Width bevel) the side of each edge the bevel lies on follows
    /// these directions, so Cycles' choice is kept.
    pub fn bump_directions(&self, ng: Vec3) -> [Vec3; 2] {
        let n = self.vector_in(ng);
        let a = if n.x != n.y || n.x != n.z {
            Vec3::new(n.z - n.y, n.x - n.z, n.y - n.x)
        } else {
            Vec3::new(n.z - n.y, n.x + n.z, -n.y - n.x)
        }
        .normalize_or_zero();
        let b = n.cross(a);
        [self.vector_out(a), self.vector_out(b)]
    }

    /// A vector of the graph's world frame in the scene's (the inverse of `vector_in`).
    fn vector_out(&self, v: Vec3) -> Vec3 {
        if self.z_up {
            Vec3::new(v.x, v.z, -v.y)
        } else {
            v
        }
    }

    /// A world-space vector of the scene in the graph's world frame.
    fn vector_in(&self, v: Vec3) -> Vec3 {
        if self.z_up {
            // glTF (Y up) -> Blender (Z up): the inverse of the exporter's root rotation.
            Vec3::new(v.x, -v.z, v.y)
        } else {
            v
        }
    }

    /// `ctx` with its world-space vectors in the graph's world frame (borrowed as it is for
    /// Y-up graphs: copying the inputs per evaluation was a visible share of textured
    /// glTF materials' time).
    fn local<'a>(&self, ctx: &'a ShadingInputs) -> std::borrow::Cow<'a, ShadingInputs> {
        if !self.z_up {
            return std::borrow::Cow::Borrowed(ctx);
        }
        let mut c = *ctx;
        {
            c.normal_to_world = Mat3::from_cols(
                self.vector_in(c.normal_to_world.x_axis),
                self.vector_in(c.normal_to_world.y_axis),
                self.vector_in(c.normal_to_world.z_axis),
            );
            for v in [
                &mut c.position,
                &mut c.normal,
                &mut c.true_normal,
                &mut c.incoming,
                &mut c.tangent,
                &mut c.bitangent,
            ] {
                *v = self.vector_in(*v);
            }
        }
        std::borrow::Cow::Owned(c)
    }

    /// The height input of Bump node `node` evaluated at the offset point `alt`.
    fn height_at(&self, node: u32, alt: &ShadingInputs) -> f32 {
        let Some((_, cone)) = self.bump_cones.iter().find(|(n, _)| *n == node) else {
            return 0.0;
        };
        BUMP_SLOTS.with(|cell| {
            let mut slots = cell.borrow_mut();
            if slots.len() < self.n_slots {
                slots.resize(self.n_slots, Vec4::ZERO);
            }
            for &i in cone {
                self.eval_into(i, &mut slots, alt, None);
            }
            read(&self.nodes[node as usize].inputs[2], &slots, alt).x
        })
    }

    /// Evaluates node `i` into `slots`; a Bump node with `bump` gets its tilted normal.
    fn eval_into(
        &self,
        i: u32,
        slots: &mut [Vec4],
        ctx: &ShadingInputs,
        bump: Option<&BumpInputs>,
    ) {
        let node = &self.nodes[i as usize];
        let mut inputs = [Vec4::ZERO; MAX_INPUTS];
        for (k, s) in node.inputs.iter().enumerate() {
            inputs[k] = read(s, slots, ctx);
        }
        let mut outputs = eval_node(&node.op, &inputs, ctx);
        if let (NodeOp::Bump { invert, .. }, Some(b)) = (&node.op, bump) {
            let h = inputs[2].x;
            let hx = self.height_at(i, &b.dx);
            let hy = self.height_at(i, &b.dy);
            let n = inputs[3].xyz().try_normalize().unwrap_or(ctx.normal);
            outputs[0] = v3(bump_normal(
                n,
                b.dpdx,
                b.dpdy,
                hx - h,
                hy - h,
                inputs[0].x,
                if *invert { -inputs[1].x } else { inputs[1].x },
            ));
        }
        let n_out = node.op.signature().outputs.len();
        let base = node.first_slot as usize;
        slots[base..base + n_out].copy_from_slice(&outputs[..n_out]);
    }

    pub fn has_closures(&self) -> bool {
        !self.closures.is_empty()
    }

    /// The graph makes the surface partly transparent somewhere (an Alpha input or a
    /// Transparent BSDF leaf).
    pub fn has_alpha(&self) -> bool {
        self.bindings
            .iter()
            .any(|(m, _)| *m == MaterialInput::Alpha)
            || self.closures.iter().any(|c| c.transparent)
    }

    /// Coverage at `ctx` in [0, 1]: the Alpha input (1 when unbound) times the share of the
    /// mixture that is not a Transparent BSDF.
    pub fn alpha(&self, ctx: &ShadingInputs) -> f32 {
        let ctx = &self.local(ctx);
        self.run_with(ctx, ALPHA_PROGRAM, None, |slots| {
            let a = self.alpha_input(slots, ctx);
            let transparent: f32 = self
                .closures
                .iter()
                .filter(|c| c.transparent)
                .map(|c| read(&c.weight, slots, ctx).x.max(0.0))
                .sum();
            (a * (1.0 - transparent)).clamp(0.0, 1.0)
        })
    }

    /// Coverage and the light the transparent share lets through, in linear RGB:
    /// `(alpha, (1 - a) + a sum_i w_i c_i)` with `a` the Alpha input, `w_i` the Transparent BSDF
    /// leaves' weights and `c_i` their colours (white when not given). Untinted, the second is
    /// `1 - alpha` in every channel (Cycles' transparent BSDF passes `c_i` times the light).
    pub fn transparency(&self, ctx: &ShadingInputs) -> (f32, Vec3) {
        let ctx = &self.local(ctx);
        self.run_with(ctx, ALPHA_PROGRAM, None, |slots| {
            let a = self.alpha_input(slots, ctx);
            let (mut share, mut tinted) = (0.0f32, Vec3::ZERO);
            for c in self.closures.iter().filter(|c| c.transparent) {
                let weight = read(&c.weight, slots, ctx).x.max(0.0);
                let colour = c
                    .bindings
                    .iter()
                    .find(|(m, _)| *m == MaterialInput::BaseColor)
                    .map_or(Vec3::ONE, |(_, s)| {
                        read(s, slots, ctx).xyz().max(Vec3::ZERO)
                    });
                share += weight;
                tinted += weight * colour;
            }
            // As `alpha` computes it, so the coverage decisions agree.
            let alpha = (a * (1.0 - share)).clamp(0.0, 1.0);
            let a = a.clamp(0.0, 1.0);
            let pass = (Vec3::splat(1.0 - a) + a * tinted).clamp(Vec3::ZERO, Vec3::ONE);
            (alpha, pass)
        })
    }

    /// The bound Alpha input (1 when unbound), unclamped.
    fn alpha_input(&self, slots: &[Vec4], ctx: &ShadingInputs) -> f32 {
        self.bindings
            .iter()
            .rev()
            .find(|(m, _)| *m == MaterialInput::Alpha)
            .map_or(1.0, |(_, s)| read(s, slots, ctx).x)
    }

    /// Some Transparent BSDF leaf has a colour (see [`ShadingGraph::transparency`]).
    pub fn has_tinted_transparency(&self) -> bool {
        self.closures.iter().any(|c| {
            c.transparent
                && c.bindings
                    .iter()
                    .any(|(m, _)| *m == MaterialInput::BaseColor)
        })
    }

    /// Runs the scattering (`emission == false`) or emission program, then `f` reads the slots.
    fn run<T>(&self, ctx: &ShadingInputs, emission: bool, f: impl FnOnce(&[Vec4]) -> T) -> T {
        self.run_with(ctx, emission as usize, None, f)
    }

    /// Runs program `which` (0 scattering, 1 emission, 2 normal, 3 volume density,
    /// `ALPHA_PROGRAM` coverage) into the per-thread slots.
    fn run_with<T>(
        &self,
        ctx: &ShadingInputs,
        which: usize,
        bump: Option<&BumpInputs>,
        f: impl FnOnce(&[Vec4]) -> T,
    ) -> T {
        SLOTS.with(|cell| {
            let mut slots = cell.borrow_mut();
            if slots.len() < self.n_slots {
                slots.resize(self.n_slots, Vec4::ZERO);
            }
            let program = match which {
                0 => &self.surface_program,
                1 => &self.emission_program,
                2 => &self.normal_program,
                3 => &self.volume_program,
                _ => &self.alpha_program,
            };
            for &i in program {
                self.eval_into(i, &mut slots, ctx, bump);
            }
            f(&slots)
        })
    }

    /// For a mixture: picks one scattering closure (BSDF or subsurface leaf) with probability
    /// equal to its weight (weights summing above 1 are normalised) and returns it with `u`
    /// reused within it; `None` when `u` falls beyond the weights' sum (the path is absorbed:
    /// the mixture's missing scattering weight, e.g. the emission share of a Mix Shader).
    /// Stochastic selection of one component keeps the estimator unbiased without evaluating
    /// every closure.
    pub fn pick_closure(&self, ctx: &ShadingInputs, u: f32) -> Option<(ClosurePick, f32)> {
        let ctx = &self.local(ctx);
        self.run(ctx, false, |slots| {
            let scattering = || {
                self.closures
                    .iter()
                    .filter(|c| !c.emission && !c.transparent)
            };
            let weight = |c: &Closure| read(&c.weight, slots, ctx).x.max(0.0);
            // A surface point is shaded only where the path did not pass through the mixture's
            // transparent share T: given that, each leaf's probability is its weight / (1 - T).
            let coverage = 1.0 - self.transparent_share(slots, ctx);
            let total: f32 = scattering().map(weight).sum::<f32>() / coverage.max(1e-6);
            let scale = if total > 1.0 {
                1.0 / (total * coverage.max(1e-6))
            } else {
                1.0 / coverage.max(1e-6)
            };
            let mut acc = 0.0;
            for c in scattering() {
                let w = weight(c) * scale;
                if w > 0.0 && u < acc + w {
                    let u_within = ((u - acc) / w).clamp(0.0, 1.0);
                    if c.subsurface {
                        let colour = c
                            .bindings
                            .iter()
                            .find(|(m, _)| *m == MaterialInput::SubsurfaceColor)
                            .map(|(_, s)| read(s, slots, ctx).xyz());
                        return Some((ClosurePick::Subsurface(colour), u_within));
                    }
                    let mut values: InputValues = [None; N_MATERIAL_INPUTS];
                    for (m, s) in &c.bindings {
                        values[m.index()] = Some(read(s, slots, ctx));
                    }
                    return Some((ClosurePick::Bsdf(values), u_within));
                }
                acc += w;
            }
            None
        })
    }

    /// Some leaf of the mixture is subsurface scattering.
    pub fn has_subsurface_closure(&self) -> bool {
        self.closures.iter().any(|c| c.subsurface)
    }

    /// For a mixture: the summed emission of its emission closures (linear RGB).
    pub fn mixed_emission(&self, ctx: &ShadingInputs) -> Vec3 {
        let ctx = &self.local(ctx);
        self.run(ctx, true, |slots| {
            let mut sum = Vec3::ZERO;
            for c in self.closures.iter().filter(|c| c.emission) {
                let w = read(&c.weight, slots, ctx).x.max(0.0);
                let mut color = Vec3::ONE;
                let mut strength = 1.0;
                for (m, s) in &c.bindings {
                    match m {
                        MaterialInput::Emission => color = read(s, slots, ctx).xyz(),
                        MaterialInput::EmissionStrength => strength = read(s, slots, ctx).x,
                        _ => {}
                    }
                }
                sum += w * strength * color.max(Vec3::ZERO);
            }
            // Seen only where the path did not pass through (see `pick_closure`).
            let coverage = 1.0 - self.transparent_share(slots, ctx);
            if coverage > 1e-6 {
                sum / coverage
            } else {
                Vec3::ZERO
            }
        })
    }

    /// The summed weight of the Transparent BSDF leaves, in [0, 1].
    fn transparent_share(&self, slots: &[Vec4], ctx: &ShadingInputs) -> f32 {
        self.closures
            .iter()
            .filter(|c| c.transparent)
            .map(|c| read(&c.weight, slots, ctx).x.max(0.0))
            .sum::<f32>()
            .min(1.0)
    }

    /// The volume density multiplier at a point inside the material (`ctx` from
    /// `Geometry::volume_inputs`), if the graph drives it; never negative.
    pub fn volume_density(&self, ctx: &ShadingInputs) -> Option<f32> {
        self.volume_field(ctx).0
    }

    /// The volume's density multiplier (never negative) and colour (linear RGB clamped to
    /// [0, 1]) at a point inside the material, each if the graph drives it: one run of the
    /// volume program for both.
    pub fn volume_field(&self, ctx: &ShadingInputs) -> (Option<f32>, Option<Vec3>) {
        let source = |input: MaterialInput| {
            self.bindings
                .iter()
                .find(|(m, _)| *m == input)
                .map(|(_, s)| *s)
        };
        let (density, color) = (
            source(MaterialInput::VolumeDensity),
            source(MaterialInput::VolumeColor),
        );
        if density.is_none() && color.is_none() {
            return (None, None);
        }
        let ctx = &self.local(ctx);
        self.run_with(ctx, 3, None, |slots| {
            (
                density.map(|s| {
                    let d = read(&s, slots, ctx).x;
                    if d > 0.0 {
                        d
                    } else {
                        0.0
                    }
                }),
                color.map(|s| {
                    let c = read(&s, slots, ctx).truncate().to_array();
                    // NaN reads as 0 (a comparison with NaN is false).
                    Vec3::from_array(c.map(|x| if x > 0.0 { x.min(1.0) } else { 0.0 }))
                }),
            )
        })
    }

    pub fn drives(&self, input: MaterialInput) -> bool {
        self.bindings.iter().any(|(m, _)| *m == input)
    }

    /// The graph drives `input` at its top level or on some closure.
    pub fn drives_anywhere(&self, input: MaterialInput) -> bool {
        self.drives(input)
            || self
                .closures
                .iter()
                .any(|c| c.bindings.iter().any(|(m, _)| *m == input))
    }

    pub fn drives_emission(&self) -> bool {
        self.bindings.iter().any(|(m, _)| m.is_emission())
            || self.closures.iter().any(|c| c.emission)
    }

    /// The material inputs for scattering (`emission == false`) or for emission at `ctx`.
    pub fn evaluate(&self, ctx: &ShadingInputs, emission: bool) -> InputValues {
        let ctx = &self.local(ctx);
        self.run(ctx, emission, |slots| {
            let mut values: InputValues = [None; N_MATERIAL_INPUTS];
            for (m, s) in &self.bindings {
                if m.program() == emission as usize {
                    values[m.index()] = Some(read(s, slots, ctx));
                }
            }
            values
        })
    }
}

#[inline]
fn read(s: &Source, slots: &[Vec4], ctx: &ShadingInputs) -> Vec4 {
    match *s {
        Source::Const(v) => v,
        Source::Implicit(Implicit::Uv) => ctx.uv[0].extend(0.0).extend(0.0),
        Source::Implicit(Implicit::Generated) => ctx.generated.extend(0.0),
        Source::Implicit(Implicit::Normal) => ctx.normal.extend(0.0),
        Source::Link { slot, from, to } => convert(slots[slot as usize], from, to),
    }
}

fn v3(v: Vec3) -> Vec4 {
    v.extend(0.0)
}

fn s(x: f32) -> Vec4 {
    Vec4::splat(x)
}

fn rgb(c: Vec3) -> Vec4 {
    c.extend(1.0)
}

/// Fresnel and Layer Weight's normal: the input's, else the shading normal.
fn facing_normal(n: Vec3, ctx: &ShadingInputs) -> Vec3 {
    n.try_normalize().unwrap_or(ctx.normal)
}

fn eval_node(op: &NodeOp, i: &[Vec4; MAX_INPUTS], ctx: &ShadingInputs) -> [Vec4; 6] {
    let mut o = [Vec4::ZERO; 6];
    match op {
        NodeOp::TexCoord => {
            o[0] = v3(ctx.generated);
            o[1] = v3(ctx.object_normal);
            o[2] = v3(ctx.uv[0].extend(0.0));
            o[3] = v3(ctx.object);
            let n = ctx.normal;
            o[4] = v3(2.0 * n.dot(ctx.incoming) * n - ctx.incoming);
        }
        NodeOp::UvMap(set) => o[0] = v3(ctx.uv[*set].extend(0.0)),
        NodeOp::ColorAttribute(set) => {
            o[0] = rgb(ctx.color[*set].xyz());
            o[1] = s(ctx.color[*set].w);
        }
        NodeOp::Geometry => {
            o[0] = v3(ctx.position);
            o[1] = v3(ctx.normal);
            o[2] = v3(ctx.true_normal);
            o[3] = v3(ctx.incoming);
            o[4] = s(ctx.backfacing as u8 as f32);
        }
        NodeOp::LightPath => o[0] = s(ctx.camera_ray as u8 as f32),
        NodeOp::Fresnel => {
            // Cycles: the dielectric Fresnel for eta = IOR (or 1/IOR from behind).
            let n = facing_normal(i[1].xyz(), ctx);
            let eta = i[0].x.max(1e-5);
            let eta = if ctx.backfacing { 1.0 / eta } else { eta };
            o[0] = s(fresnel_dielectric(n.dot(ctx.incoming), eta));
        }
        NodeOp::LayerWeight => {
            let n = facing_normal(i[1].xyz(), ctx);
            let blend = i[0].x.clamp(0.0, 1.0 - 1e-5);
            let eta = 1.0 / (1.0 - blend);
            let eta = if ctx.backfacing { 1.0 / eta } else { eta };
            let cos = n.dot(ctx.incoming);
            o[0] = s(fresnel_dielectric(cos, eta));
            let facing = cos.abs();
            let facing = if blend != 0.5 {
                let b = blend.clamp(0.0, 1.0 - 1e-5);
                let b = if b < 0.5 { 2.0 * b } else { 0.5 / (1.0 - b) };
                facing.powf(b)
            } else {
                facing
            };
            o[1] = s(1.0 - facing);
        }
        NodeOp::Mapping(kind) => {
            let (v, loc, rot, scale) = (i[0].xyz(), i[1].xyz(), i[2].xyz(), i[3].xyz());
            let r = euler_xyz(rot);
            let m = match kind {
                MappingKind::Point => r * (v * scale) + loc,
                MappingKind::Texture => {
                    let t = r.transpose() * (v - loc);
                    Vec3::new(
                        safe_divide(t.x, scale.x),
                        safe_divide(t.y, scale.y),
                        safe_divide(t.z, scale.z),
                    )
                }
                MappingKind::Vector => r * (v * scale),
                MappingKind::Normal => {
                    let inv = Vec3::new(
                        safe_divide(1.0, scale.x),
                        safe_divide(1.0, scale.y),
                        safe_divide(1.0, scale.z),
                    );
                    (r * (v * inv)).normalize_or_zero()
                }
            };
            o[0] = v3(m);
        }
        NodeOp::ImageTexture {
            image,
            interpolation,
            extension,
        } => {
            let t = image.sample(i[0].xy(), *interpolation, *extension);
            o[0] = rgb(t.xyz());
            o[1] = s(t.w);
        }
        NodeOp::UvTransform(m) => {
            let t = *m * Vec3::new(i[0].x, i[0].y, 1.0);
            o[0] = v3(Vec3::new(t.x, t.y, i[0].z));
        }
        NodeOp::Math { op, clamp } => {
            let r = op.eval(i[0].x, i[1].x, i[2].x);
            o[0] = s(if *clamp { r.clamp(0.0, 1.0) } else { r });
        }
        NodeOp::VectorMath(op) => {
            let (v, val) = op.eval(i[0].xyz(), i[1].xyz(), i[2].xyz(), i[3].x);
            o[0] = v3(v);
            o[1] = s(val);
        }
        NodeOp::MixFloat { clamp_factor } => {
            let t = clamp_if(i[0].x, *clamp_factor);
            o[0] = s(i[1].x + (i[2].x - i[1].x) * t);
        }
        NodeOp::MixVector { clamp_factor } => {
            let t = clamp_if(i[0].x, *clamp_factor);
            o[0] = v3(i[1].xyz().lerp(i[2].xyz(), t));
        }
        NodeOp::MixColor {
            blend,
            clamp_factor,
            clamp_result,
        } => {
            let t = clamp_if(i[0].x, *clamp_factor);
            let c = blend.blend(t, i[1].xyz(), i[2].xyz());
            o[0] = rgb(if *clamp_result {
                c.clamp(Vec3::ZERO, Vec3::ONE)
            } else {
                c
            });
        }
        NodeOp::Invert => {
            let c = i[1].xyz();
            o[0] = rgb(c.lerp(Vec3::ONE - c, i[0].x));
        }
        NodeOp::HueSaturation => {
            o[0] = rgb(hue_saturation_value(
                i[4].xyz(),
                i[0].x,
                i[1].x,
                i[2].x,
                i[3].x,
            ))
        }
        NodeOp::BrightContrast => o[0] = rgb(bright_contrast(i[0].xyz(), i[1].x, i[2].x)),
        NodeOp::Gamma => o[0] = rgb(gamma(i[0].xyz(), i[1].x)),
        NodeOp::RgbToBw => o[0] = s(luminance(i[0].xyz())),
        NodeOp::SeparateColor(model) => {
            let c = i[0].xyz();
            let c = match model {
                ColorModel::Rgb => c,
                ColorModel::Hsv => rgb_to_hsv(c),
                ColorModel::Hsl => rgb_to_hsl(c),
            };
            o[0] = s(c.x);
            o[1] = s(c.y);
            o[2] = s(c.z);
        }
        NodeOp::CombineColor(model) => {
            let c = Vec3::new(i[0].x, i[1].x, i[2].x);
            o[0] = rgb(match model {
                ColorModel::Rgb => c,
                ColorModel::Hsv => hsv_to_rgb(c),
                ColorModel::Hsl => hsl_to_rgb(c),
            });
        }
        NodeOp::SeparateXyz => {
            o[0] = s(i[0].x);
            o[1] = s(i[0].y);
            o[2] = s(i[0].z);
        }
        NodeOp::CombineXyz => o[0] = v3(Vec3::new(i[0].x, i[1].x, i[2].x)),
        NodeOp::MapRange {
            interpolation,
            clamp,
        } => o[0] = s(map_range(*interpolation, *clamp, i)),
        NodeOp::Clamp { range } => {
            let (v, lo, hi) = (i[0].x, i[1].x, i[2].x);
            let r = if *range && lo > hi {
                v.max(hi).min(lo)
            } else {
                v.max(lo).min(hi)
            };
            o[0] = s(r);
        }
        NodeOp::ColorRamp(ramp) => {
            let c = ramp.eval(i[0].x);
            o[0] = rgb(c.xyz());
            o[1] = s(c.w);
        }
        NodeOp::Checker => {
            let fac = checker(i[0].xyz(), i[3].x);
            o[0] = rgb(if fac == 1.0 { i[1].xyz() } else { i[2].xyz() });
            o[1] = s(fac);
        }
        NodeOp::Gradient(kind) => {
            let fac = gradient(i[0].xyz(), *kind);
            o[0] = rgb(Vec3::splat(fac));
            o[1] = s(fac);
        }
        NodeOp::Noise {
            dimensions,
            kind,
            normalize,
        } => {
            // The node's own clamping (Cycles' svm_node_tex_noise).
            let scale = i[2].x;
            let fractal = Fractal {
                kind: *kind,
                normalize: *normalize,
                detail: i[3].x.clamp(0.0, 15.0),
                roughness: i[4].x.max(0.0),
                lacunarity: i[5].x,
                offset: i[6].x,
                gain: i[7].x,
            };
            let (fac, color) = noise_texture(
                *dimensions,
                i[0].xyz() * scale,
                i[1].x * scale,
                i[8].x,
                &fractal,
            );
            o[0] = s(fac);
            o[1] = rgb(color);
        }
        NodeOp::Voronoi {
            dimensions,
            feature,
            metric,
            normalize,
        } => {
            let params = VoronoiParams::new(
                *dimensions as usize,
                *feature,
                *metric,
                *normalize,
                i[2].x,
                i[3].x,
                i[4].x,
                i[5].x,
                i[6].x,
                i[7].x,
                i[8].x,
            );
            let r = params.eval(i[0].xyz(), i[1].x);
            o[0] = s(r.distance);
            o[1] = rgb(r.color);
            o[2] = v3(r.position.truncate());
            o[3] = s(r.position.w);
            o[4] = s(r.radius);
        }
        // Without offsets (evaluated outside a normal binding) the normal passes unchanged;
        // `ShadingGraph::run` computes the bumped one.
        NodeOp::Blackbody => o[0] = rgb(blackbody(i[0].x)),
        NodeOp::NormalMap { space } => {
            // Work with the outward normal and frame, answer on the viewer's side.
            let side = if ctx.backfacing { -1.0 } else { 1.0 };
            let n_out = ctx.normal * side;
            let c = i[1].xyz() * 2.0 - Vec3::ONE;
            let blender = c * Vec3::new(1.0, -1.0, -1.0);
            let mapped = match space {
                NormalSpace::World => c,
                NormalSpace::Object => ctx.normal_to_world * c,
                NormalSpace::BlenderWorld => blender,
                NormalSpace::BlenderObject => ctx.normal_to_world * blender,
                NormalSpace::Tangent => ctx.tangent * c.x + ctx.bitangent * c.y + n_out * c.z,
            };
            let mapped = mapped.try_normalize().unwrap_or(n_out);
            let strength = i[0].x.max(0.0);
            let n = (n_out + (mapped - n_out) * strength)
                .try_normalize()
                .unwrap_or(n_out);
            o[0] = v3(n * side);
        }
        NodeOp::Curves(t) => {
            let fac = i[0].x;
            if t.len() == 1 {
                let v = i[1].x;
                o[0] = s(v + (t[0].eval(v) - v) * fac);
            } else {
                let c = i[1].xyz();
                let curved = Vec3::new(t[0].eval(c.x), t[1].eval(c.y), t[2].eval(c.z));
                o[0] = rgb(c.lerp(curved, fac));
            }
        }
        NodeOp::VectorCurves(t) => {
            let v = i[1].xyz();
            let curved = Vec3::new(t[0].eval(v.x), t[1].eval(v.y), t[2].eval(v.z));
            o[0] = v3(v.lerp(curved, i[0].x));
        }
        NodeOp::Wavelength => o[0] = rgb(wavelength_color(i[0].x)),
        NodeOp::Bump { .. } => o[0] = v3(i[3].xyz().try_normalize().unwrap_or(ctx.normal)),
        NodeOp::Wave(wave) => {
            let fac = wave.eval(i[0].xyz() * i[1].x, i[2].x, i[3].x, i[4].x, i[5].x, i[6].x);
            o[0] = rgb(Vec3::splat(fac));
            o[1] = s(fac);
        }
        NodeOp::Magic { depth } => {
            let c = magic(i[0].xyz(), i[1].x, *depth, i[2].x);
            o[0] = rgb(c);
            o[1] = s((c.x + c.y + c.z) / 3.0);
        }
        NodeOp::Brick(brick) => {
            let (tint, mortar) =
                brick.eval(i[0].xyz() * i[4].x, i[5].x, i[6].x, i[7].x, i[8].x, i[9].x);
            let mut c1 = i[1].xyz();
            if mortar != 1.0 {
                c1 = c1 * (1.0 - tint) + i[2].xyz() * tint;
            }
            o[0] = rgb(c1 * (1.0 - mortar) + i[3].xyz() * mortar);
            o[1] = s(mortar);
        }
        NodeOp::WhiteNoise(dimensions) => {
            let (value, color) = white_noise(*dimensions, i[0].xyz(), i[1].x);
            o[0] = s(value);
            o[1] = rgb(color);
        }
    }
    o
}

/// The most inputs a node has (the Brick texture's).
pub const MAX_INPUTS: usize = 10;

fn clamp_if(t: f32, clamp: bool) -> f32 {
    if clamp {
        t.clamp(0.0, 1.0)
    } else {
        t
    }
}

/// Map Range (float): `value` from [from_min, from_max] to [to_min, to_max].
fn map_range(interp: MapRangeInterpolation, clamp: bool, i: &[Vec4; MAX_INPUTS]) -> f32 {
    let (value, from_min, from_max, to_min, to_max, steps) =
        (i[0].x, i[1].x, i[2].x, i[3].x, i[4].x, i[5].x);
    let mut factor = safe_divide(value - from_min, from_max - from_min);
    match interp {
        MapRangeInterpolation::Linear => {}
        MapRangeInterpolation::Stepped => {
            factor = if steps > 0.0 {
                (factor * (steps + 1.0)).floor() / steps
            } else {
                0.0
            };
        }
        MapRangeInterpolation::SmoothStep => {
            factor = if from_min > from_max {
                1.0 - smoothstep(from_max, from_min, value)
            } else {
                smoothstep(from_min, from_max, value)
            };
        }
        MapRangeInterpolation::SmootherStep => {
            factor = if from_min > from_max {
                1.0 - smootherstep(from_max, from_min, value)
            } else {
                smootherstep(from_min, from_max, value)
            };
        }
    }
    let r = to_min + factor * (to_max - to_min);
    let clamps = matches!(
        interp,
        MapRangeInterpolation::Linear | MapRangeInterpolation::Stepped
    );
    if clamp && clamps {
        if to_min > to_max {
            r.clamp(to_max, to_min)
        } else {
            r.clamp(to_min, to_max)
        }
    } else {
        r
    }
}

/// `uv` of a glTF TEXCOORD (origin top-left, v down) in Blender's convention (v up).
#[inline]
pub fn blender_uv(gltf_uv: Vec2) -> Vec2 {
    Vec2::new(gltf_uv.x, 1.0 - gltf_uv.y)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(op: NodeOp, inputs: Vec<Source>, first_slot: u32) -> GraphNode {
        GraphNode {
            name: format!("{op:?}"),
            op,
            inputs,
            first_slot,
        }
    }

    fn link(slot: u32, from: SocketType, to: SocketType) -> Source {
        Source::Link { slot, from, to }
    }

    #[test]
    fn bump_of_a_linear_height_tilts_by_its_slope() {
        // h = k x on the plane z = 0: the bumped normal is normalize(-distance k, 0, 1).
        let (k, dist) = (0.5f32, 0.8f32);
        let (dx, dy) = (Vec3::new(1e-3, 0.0, 0.0), Vec3::new(2e-4, 1e-3, 0.0));
        let n = bump_normal(Vec3::Z, dx, dy, k * dx.x, k * dy.x, 1.0, dist);
        let want = Vec3::new(-dist * k, 0.0, 1.0).normalize();
        assert!((n - want).length() < 1e-4, "{n} vs {want}");
        // Strength 0 keeps the normal; swapped offsets (det < 0) give the same tilt.
        assert_eq!(bump_normal(Vec3::Z, dx, dy, 1e-3, 0.0, 0.0, dist), Vec3::Z);
        let m = bump_normal(Vec3::Z, dy, dx, k * dy.x, k * dx.x, 1.0, dist);
        assert!((m - want).length() < 1e-4, "{m}");
    }

    #[test]
    fn conversions_follow_blender() {
        let c = Vec4::new(1.0, 0.0, 0.0, 1.0);
        assert!((convert(c, C, F).x - 0.2126).abs() < 1e-6);
        assert!((convert(Vec4::new(1.0, 2.0, 3.0, 0.0), V, F).x - 2.0).abs() < 1e-6);
        assert_eq!(convert(Vec4::splat(0.3), F, C), Vec4::splat(0.3));
    }

    #[test]
    fn map_range_and_clamp() {
        let mut i = [Vec4::ZERO; MAX_INPUTS];
        let set = |i: &mut [Vec4; MAX_INPUTS], v: [f32; 6]| {
            for (k, x) in v.iter().enumerate() {
                i[k] = Vec4::splat(*x);
            }
        };
        set(&mut i, [0.25, 0.0, 1.0, 10.0, 20.0, 4.0]);
        assert_eq!(map_range(MapRangeInterpolation::Linear, true, &i), 12.5);
        set(&mut i, [2.0, 0.0, 1.0, 10.0, 20.0, 4.0]);
        assert_eq!(map_range(MapRangeInterpolation::Linear, true, &i), 20.0);
        assert_eq!(map_range(MapRangeInterpolation::Linear, false, &i), 30.0);
        set(&mut i, [0.3, 0.0, 1.0, 0.0, 1.0, 4.0]);
        assert_eq!(map_range(MapRangeInterpolation::Stepped, true, &i), 0.25);
        set(&mut i, [0.5, 0.0, 1.0, 0.0, 1.0, 4.0]);
        assert_eq!(map_range(MapRangeInterpolation::SmoothStep, true, &i), 0.5);
        set(&mut i, [0.25, 1.0, 0.0, 0.0, 1.0, 4.0]);
        // Reversed source range: smoothstep mirrored.
        let r = map_range(MapRangeInterpolation::SmoothStep, true, &i);
        assert!((r - (1.0 - smoothstep(0.0, 1.0, 0.25))).abs() < 1e-6);
    }

    #[test]
    fn graph_evaluates_chain_and_only_needed_nodes() {
        // uv -> separate xyz -> math(x * 2) -> roughness; a colour ramp on x -> base colour.
        let ramp = ColorRamp {
            interpolation: super::super::color::RampInterpolation::Linear,
            stops: vec![
                (0.0, Vec4::new(0.0, 0.0, 0.0, 1.0)),
                (1.0, Vec4::new(1.0, 0.5, 0.0, 1.0)),
            ],
        };
        let nodes = vec![
            node(NodeOp::UvMap(1), vec![], 0),
            node(NodeOp::SeparateXyz, vec![link(0, V, V)], 1),
            node(
                NodeOp::Math {
                    op: MathOp::Multiply,
                    clamp: false,
                },
                vec![
                    link(1, F, F),
                    Source::Const(Vec4::splat(2.0)),
                    Source::Const(Vec4::ZERO),
                ],
                4,
            ),
            node(NodeOp::ColorRamp(ramp), vec![link(1, F, F)], 5),
        ];
        let g = ShadingGraph::new(
            nodes,
            vec![
                (MaterialInput::Roughness, link(4, F, F)),
                (MaterialInput::BaseColor, link(5, C, C)),
                (MaterialInput::EmissionStrength, link(4, F, F)),
            ],
        );
        let mut ctx = ShadingInputs::default();
        ctx.uv[1] = Vec2::new(0.3, 0.9);
        let v = g.evaluate(&ctx, false);
        assert!((v[MaterialInput::Roughness.index()].unwrap().x - 0.6).abs() < 1e-6);
        let base = v[MaterialInput::BaseColor.index()].unwrap();
        assert!((base.xyz() - Vec3::new(0.3, 0.15, 0.0)).abs().max_element() < 1e-6);
        assert!(v[MaterialInput::EmissionStrength.index()].is_none());
        assert!(v[MaterialInput::Metallic.index()].is_none());
        // Emission needs the uv, separate and math nodes, not the ramp.
        assert_eq!(g.emission_program, vec![0, 1, 2]);
        let e = g.evaluate(&ctx, true);
        assert!((e[MaterialInput::EmissionStrength.index()].unwrap().x - 0.6).abs() < 1e-6);
    }

    #[test]
    fn mapping_point_and_texture_are_inverse() {
        let i = |v: Vec3| {
            let mut a = [Vec4::ZERO; MAX_INPUTS];
            a[0] = v.extend(0.0);
            a[1] = Vec4::new(0.5, -1.0, 2.0, 0.0);
            a[2] = Vec4::new(0.3, 0.2, 1.1, 0.0);
            a[3] = Vec4::new(2.0, 1.0, 0.5, 0.0);
            a
        };
        let ctx = ShadingInputs::default();
        let p = Vec3::new(0.2, 0.7, -0.4);
        let fwd = eval_node(&NodeOp::Mapping(MappingKind::Point), &i(p), &ctx)[0].xyz();
        let back = eval_node(&NodeOp::Mapping(MappingKind::Texture), &i(fwd), &ctx)[0].xyz();
        assert!((back - p).abs().max_element() < 1e-5, "{back} vs {p}");
        // Point: scale, then rotate, then translate. With no rotation: p * s + loc.
        let mut a = i(p);
        a[2] = Vec4::ZERO;
        let r = eval_node(&NodeOp::Mapping(MappingKind::Point), &a, &ctx)[0].xyz();
        assert!((r - (p * Vec3::new(2.0, 1.0, 0.5) + Vec3::new(0.5, -1.0, 2.0))).length() < 1e-6);
    }

    #[test]
    fn fresnel_and_layer_weight_at_normal_incidence() {
        let ctx = ShadingInputs::default(); // incoming = normal = +z
        let mut i = [Vec4::ZERO; MAX_INPUTS];
        i[0] = Vec4::splat(1.5);
        let fr = eval_node(&NodeOp::Fresnel, &i, &ctx)[0].x;
        assert!((fr - 0.04).abs() < 1e-4);
        i[0] = Vec4::splat(0.5);
        let lw = eval_node(&NodeOp::LayerWeight, &i, &ctx);
        // blend 0.5 = eta 2: F0 = 1/9; facing = 1 - |cos| = 0.
        assert!((lw[0].x - 1.0 / 9.0).abs() < 1e-4);
        assert!(lw[1].x.abs() < 1e-6);
    }

    /// Bump offsets follow Cycles' basis around Ng in Blender's frame: for a surface facing
    /// Blender's +Z, (1, -1, 0) / sqrt 2 and (1, 1, 0) / sqrt 2; orthonormal in the tangent
    /// plane for any normal.
    #[test]
    fn bump_directions_are_cycles_basis() {
        let mut g = ShadingGraph::new(vec![], vec![]);
        g.z_up = true;
        // Blender's +Z is glTF's +Y.
        let [a, b] = g.bump_directions(Vec3::Y);
        let r = std::f32::consts::FRAC_1_SQRT_2;
        // Blender (1, -1, 0) -> glTF (x, z, -y) = (1, 0, 1); (1, 1, 0) -> (1, 0, -1).
        assert!((a - Vec3::new(r, 0.0, r)).length() < 1e-6, "{a}");
        assert!((b - Vec3::new(r, 0.0, -r)).length() < 1e-6, "{b}");
        for n in [Vec3::X, Vec3::new(0.3, -0.5, 0.81), Vec3::ONE, -Vec3::ONE] {
            let n = n.normalize();
            for up in [false, true] {
                g.z_up = up;
                let [a, b] = g.bump_directions(n);
                for (v, w) in [(a, n), (b, n), (a, b)] {
                    assert!(v.dot(w).abs() < 1e-5, "{v} . {w}");
                }
                assert!((a.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            }
        }
    }
}
