//! The `graph` form of a material in the material JSON (graph version 1).
//!
//! ```json
//! "Painted": { "graph": {
//!   "version": 1,
//!   "nodes": {
//!     "UV":    { "type": "uv_map", "set": 0 },
//!     "Image": { "type": "image_texture", "image": "paint.png", "color_space": "srgb",
//!                "interpolation": "linear", "extension": "repeat",
//!                "inputs": { "vector": { "node": "UV", "output": "uv" } } },
//!     "Ramp":  { "type": "color_ramp", "interpolation": "ease",
//!                "stops": [[0.0, [0, 0, 0, 1]], [1.0, [1, 1, 1, 1]]],
//!                "inputs": { "fac": { "node": "Image", "output": "alpha" } } } },
//!   "inputs": { "base_color": { "node": "Image", "output": "color" },
//!               "roughness": { "node": "Ramp", "output": "color" },
//!               "metallic": 0.0 } } }
//! ```
//!
//! * `world_up`: `"y"` (default: the glTF scene's world) or `"z"` (Blender's world, which the
//!   add-on writes): the frame of world-space vectors the graph reads (Geometry, Texture
//!   Coordinate > Reflection, world-space normal maps) and of the normal it returns.
//! * `inputs` binds material inputs (`base_color`, `metallic`, `roughness`, `specular`,
//!   `transmission`, `emission`, `emission_strength`, `alpha`, `normal`, `translucent`,
//!   `volume_density`, `volume_color`, `refraction`: 1 makes a closure Blender's Refraction BSDF, the
//!   dielectric's refraction alone; `coat_weight`, `coat_roughness`, `coat_tint`, `coat_ior`,
//!   `sheen_color`, `sheen_roughness`, `specular_tint` (Blender 4.x's colour),
//!   `thin_film_thickness` (nm, 0: none), `thin_film_ior`, `thin_film_weight` (1 when
//!   unbound), and `coat_normal`, the clear
//!   coat's own normal like `normal`; without it a coat keeps the unperturbed normal under a
//!   bumped base) to a node output or a constant; a bound input replaces the glTF
//!   material's factor and texture, the others keep the glTF values (glTF's texture slots
//!   are nodes appended to this graph, `scene::gltf_graph`). `volume_density` (a
//!   non-negative float) multiplies the material's `volume` coefficients at each point inside
//!   it, where the graph reads Position, Object and Generated coordinates (a heterogeneous
//!   volume); `volume_color` (a colour in [0, 1]) mixes per wavelength the `volume`'s
//!   coefficients (where it is white) and its `color_zero` ones (where it is black).
//! * A node's `inputs` give each socket a number, an array of 3 (vector, colour) or 4 (RGBA)
//!   numbers, or a link `{ "node": <name>, "output": <socket> }`. Unlinked sockets take the
//!   defaults listed in `graph::NodeOp::signature` (Blender's); Image Texture's `vector`
//!   defaults to UV set 0 (Blender's UV convention, v up), Checker's and Gradient's to the
//!   generated coordinates, Fresnel's and Layer Weight's `normal` to the shading normal.
//! * Node types and their settings (Blender's enum identifiers, in lower case):
//!   `tex_coord`; `uv_map` / `color_attribute` (`set`: TEXCOORD_n / COLOR_n, default 0);
//!   `geometry`; `light_path`; `fresnel`; `layer_weight`; `mapping` (`vector_type`: point |
//!   texture | vector | normal); `image_texture` (`image`: a PNG/JPEG/EXR/HDR file relative to
//!   this JSON, `color_space`: srgb | linear, `interpolation`: closest | linear | cubic | smart,
//!   `extension`: repeat | extend | clip | mirror); `math` (`operation`, `clamp`);
//!   `vector_math` (`operation`); `mix` (`data_type`: float | vector | rgba, `blend_type`,
//!   `clamp_factor` default true, `clamp_result`); `invert`; `hue_saturation`;
//!   `bright_contrast`; `gamma`; `rgb_to_bw`; `separate_color` / `combine_color` (`mode`: rgb
//!   | hsv | hsl); `separate_xyz`; `combine_xyz`; `map_range` (`interpolation`: linear |
//!   stepped | smoothstep | smootherstep, `clamp` default true); `clamp` (`clamp_type`: minmax
//!   | range); `color_ramp` (`interpolation`: constant | linear | ease | b_spline | cardinal,
//!   `stops`: [[position, [r, g, b, a]], ...]); `checker_texture`; `gradient_texture`
//!   (`gradient_type`); `noise_texture` (`dimensions` 1-4 default 3, `noise_type`: fbm |
//!   multifractal | hybrid_multifractal | ridged_multifractal | hetero_terrain, `normalize`
//!   default true); `white_noise_texture` (`dimensions`); `voronoi_texture` (`dimensions`,
//!   `feature`: f1 | f2 | smooth_f1 | distance_to_edge | n_sphere_radius, `distance`:
//!   euclidean | manhattan | chebychev | minkowski, `normalize`); `wave_texture`
//!   (`wave_type`: bands | rings, `direction`: x | y | z | diagonal (bands) / spherical
//!   (rings), `wave_profile`: sin | saw | tri); `magic_texture` (`depth` 0-10);
//!   `brick_texture` (`offset`, `offset_frequency`, `squash`, `squash_frequency`); `bump`
//!   (`invert`, `filter_width`: the offsets in pixels, default 0.1 as Blender 4.5+'s Filter
//!   Width, 1 for earlier Blenders; inputs `strength`, `distance`, `height`, `normal`), whose output goes to the
//!   material input `normal`; `curves` (`tables`: 1 for Float Curve, 3 for RGB Curves, each
//!   `{"lo", "hi", "values": [...], "extrapolate"}` sampled evenly over [lo, hi]; inputs `fac`
//!   and `value` / `color`); `vector_curves` (`tables`: 3, for X, Y and Z, sampled over the
//!   curve's range, usually [-1, 1]; inputs `fac`, `vector`; output `vector`); `wavelength`
//!   (input `wavelength` in nm; output `color`: Blender's colour of that wavelength);
//!   `normal_map` (`space`: tangent (TEXCOORD_0's frame) | object | world | blender_object |
//!   blender_world (Blender's convention: the colour's Y and Z negated);
//!   inputs `strength`, `color`); `blackbody` (input `temperature` in kelvin).
//! * `closures` (instead of or with `inputs`): a Mix / Add Shader tree flattened into its
//!   leaves, `[{"kind": "bsdf" | "emission" | "transparent" | "translucent" | "subsurface",
//!   "weight": <value or link>, "inputs": {...}}]` (a transparent leaf's weight is the
//!   surface's transparency, and its optional `base_color` the colour that multiplies what
//!   passes, per wavelength). Each shading point picks one BSDF or subsurface leaf with
//!   probability equal to its weight (the path is absorbed with the remaining probability;
//!   weights summing above 1 are normalised) and renders it with that leaf's inputs over the
//!   glTF defaults; a subsurface leaf hands the path to the material's `subsurface` medium,
//!   which the material must have, and its weight replaces that entry's `weight`; its one
//!   input, `subsurface_color` (also a top-level input), textures the colour of a medium given
//!   by a colour (`reflectance` + `mfp`, `color` + `radius`). Emission leaves add weight x `emission` x `emission_strength`.
//! * Links must not form a cycle; nodes no input depends on are ignored. An image that cannot
//!   be read renders magenta with a warning, as in Blender.

use std::collections::HashMap;
use std::sync::Arc;

use glam::Vec4;
use serde_json::{Map, Value};

use super::color::{ColorRamp, BLEND_MODES, RAMP_INTERPOLATIONS};
use super::graph::{
    ColorModel, GraphNode, MapRangeInterpolation, MappingKind, MaterialInput, NodeOp, NormalSpace,
    ShadingGraph, SocketType, Source, MATERIAL_INPUTS,
};
use super::image::{Image, EXTENSIONS, INTERPOLATIONS};
use super::math_ops::{MATH_OPS, VECTOR_MATH_OPS};
use super::procedural::GRADIENT_KINDS;
use super::MAX_ATTRIBUTE_SETS;

/// The only graph version this Prism reads.
pub const GRAPH_VERSION: u64 = 1;

pub const NODE_TYPES: &[&str] = &[
    "tex_coord",
    "uv_map",
    "color_attribute",
    "geometry",
    "light_path",
    "fresnel",
    "layer_weight",
    "mapping",
    "image_texture",
    "math",
    "vector_math",
    "mix",
    "invert",
    "hue_saturation",
    "bright_contrast",
    "gamma",
    "rgb_to_bw",
    "separate_color",
    "combine_color",
    "separate_xyz",
    "combine_xyz",
    "map_range",
    "clamp",
    "color_ramp",
    "checker_texture",
    "gradient_texture",
    "noise_texture",
    "white_noise_texture",
    "voronoi_texture",
    "wave_texture",
    "magic_texture",
    "brick_texture",
    "bump",
    "curves",
    "vector_curves",
    "normal_map",
    "blackbody",
    "wavelength",
];

/// Loads the images graphs name: `(path as written, linear?) -> image`.
pub trait ImageLoader {
    fn load(&mut self, path: &str, linear: bool) -> Arc<Image>;
}

/// For validation without reading files: every image is a 1x1 placeholder.
pub struct NoImages;

impl ImageLoader for NoImages {
    fn load(&mut self, path: &str, _linear: bool) -> Arc<Image> {
        Image::missing(path)
    }
}

/// A parse error: the JSON path below the graph and the message.
pub struct GraphError {
    pub path: String,
    pub msg: String,
}

type R<T> = Result<T, GraphError>;

fn err<T>(path: &str, msg: impl Into<String>) -> R<T> {
    Err(GraphError {
        path: path.to_string(),
        msg: msg.into(),
    })
}

fn key_path(base: &str, k: &str) -> String {
    let simple = !k.is_empty()
        && k.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if simple {
        format!("{base}.{k}")
    } else {
        format!("{base}[{}]", Value::String(k.to_string()))
    }
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

fn object<'v>(v: &'v Value, path: &str) -> R<&'v Map<String, Value>> {
    match v.as_object() {
        Some(m) => Ok(m),
        None => err(path, format!("expected an object, found {}", kind(v))),
    }
}

fn number(v: &Value, path: &str) -> R<f32> {
    match v.as_f64() {
        Some(x) if (x as f32).is_finite() => Ok(x as f32),
        Some(x) => err(path, format!("{x} is not a finite 32-bit number")),
        None => err(path, format!("expected a number, found {}", kind(v))),
    }
}

fn enum_value<T: Copy>(
    m: &Map<String, Value>,
    key: &str,
    path: &str,
    table: &[(&str, T)],
    default: T,
) -> R<T> {
    let Some(v) = m.get(key) else {
        return Ok(default);
    };
    let p = key_path(path, key);
    let Some(s) = v.as_str() else {
        return err(&p, format!("expected a string, found {}", kind(v)));
    };
    match table.iter().find(|(n, _)| *n == s) {
        Some((_, t)) => Ok(*t),
        None => {
            let names: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
            err(
                &p,
                format!("unknown value '{s}' (valid: {})", names.join(", ")),
            )
        }
    }
}

fn flag(m: &Map<String, Value>, key: &str, path: &str, default: bool) -> R<bool> {
    match m.get(key) {
        None => Ok(default),
        Some(Value::Bool(b)) => Ok(*b),
        Some(v) => err(
            &key_path(path, key),
            format!("expected true or false, found {}", kind(v)),
        ),
    }
}

fn attribute_set(m: &Map<String, Value>, path: &str) -> R<usize> {
    let Some(v) = m.get("set") else { return Ok(0) };
    let p = key_path(path, "set");
    match v.as_f64() {
        Some(x) if x >= 0.0 && x.fract() == 0.0 && (x as usize) < MAX_ATTRIBUTE_SETS => {
            Ok(x as usize)
        }
        _ => err(
            &p,
            format!(
                "expected an integer in 0..{} (TEXCOORD_n / COLOR_n), found {v}",
                MAX_ATTRIBUTE_SETS - 1
            ),
        ),
    }
}

/// A texture's `dimensions` (1 to 4, default 3).
fn dimensions(m: &Map<String, Value>, path: &str) -> R<u8> {
    let Some(v) = m.get("dimensions") else {
        return Ok(3);
    };
    match v.as_f64() {
        Some(x) if (1.0..=4.0).contains(&x) && x.fract() == 0.0 => Ok(x as u8),
        _ => err(
            &key_path(path, "dimensions"),
            format!("expected 1, 2, 3 or 4, found {v}"),
        ),
    }
}

fn check_keys(m: &Map<String, Value>, allowed: &[&str], path: &str) -> R<()> {
    for k in m.keys() {
        if !allowed.contains(&k.as_str()) {
            return err(
                &key_path(path, k),
                format!(
                    "unknown key '{k}' (expected one of: {})",
                    allowed.join(", ")
                ),
            );
        }
    }
    Ok(())
}

/// The node's settings (everything but `type` and `inputs`) -> its operation.
fn node_op(
    ty: &str,
    m: &Map<String, Value>,
    path: &str,
    images: &mut dyn ImageLoader,
) -> R<NodeOp> {
    let settings: &[&str] = match ty {
        "uv_map" | "color_attribute" => &["set"],
        "mapping" => &["vector_type"],
        "image_texture" => &["image", "color_space", "interpolation", "extension"],
        "math" => &["operation", "clamp"],
        "vector_math" => &["operation"],
        "mix" => &["data_type", "blend_type", "clamp_factor", "clamp_result"],
        "separate_color" | "combine_color" => &["mode"],
        "map_range" => &["interpolation", "clamp"],
        "clamp" => &["clamp_type"],
        "color_ramp" => &["interpolation", "stops"],
        "gradient_texture" => &["gradient_type"],
        "noise_texture" => &["dimensions", "noise_type", "normalize"],
        "white_noise_texture" => &["dimensions"],
        "voronoi_texture" => &["dimensions", "feature", "distance", "normalize"],
        "wave_texture" => &["wave_type", "direction", "wave_profile"],
        "magic_texture" => &["depth"],
        "bump" => &["invert", "filter_width"],
        "curves" => &["tables"],
        "vector_curves" => &["tables"],
        "normal_map" => &["space"],
        "brick_texture" => &["offset", "offset_frequency", "squash", "squash_frequency"],
        _ => &[],
    };
    let mut allowed = vec!["type", "inputs"];
    allowed.extend_from_slice(settings);
    check_keys(m, &allowed, path)?;
    let models = &[
        ("rgb", ColorModel::Rgb),
        ("hsv", ColorModel::Hsv),
        ("hsl", ColorModel::Hsl),
    ];
    Ok(match ty {
        "tex_coord" => NodeOp::TexCoord,
        "uv_map" => NodeOp::UvMap(attribute_set(m, path)?),
        "color_attribute" => NodeOp::ColorAttribute(attribute_set(m, path)?),
        "geometry" => NodeOp::Geometry,
        "light_path" => NodeOp::LightPath,
        "fresnel" => NodeOp::Fresnel,
        "layer_weight" => NodeOp::LayerWeight,
        "mapping" => NodeOp::Mapping(enum_value(
            m,
            "vector_type",
            path,
            &[
                ("point", MappingKind::Point),
                ("texture", MappingKind::Texture),
                ("vector", MappingKind::Vector),
                ("normal", MappingKind::Normal),
            ],
            MappingKind::Point,
        )?),
        "image_texture" => {
            let p = key_path(path, "image");
            let file = match m.get("image") {
                Some(Value::String(s)) if !s.is_empty() => s.as_str(),
                Some(v) => return err(&p, format!("expected a file name, found {}", kind(v))),
                None => return err(path, "an image_texture needs 'image' (a file name)"),
            };
            let linear = enum_value(
                m,
                "color_space",
                path,
                &[("srgb", false), ("linear", true)],
                false,
            )?;
            NodeOp::ImageTexture {
                image: images.load(file, linear),
                interpolation: enum_value(
                    m,
                    "interpolation",
                    path,
                    INTERPOLATIONS,
                    super::image::Interpolation::Linear,
                )?,
                extension: [enum_value(
                    m,
                    "extension",
                    path,
                    EXTENSIONS,
                    super::image::Extension::Repeat,
                )?; 2],
            }
        }
        "math" => NodeOp::Math {
            op: enum_value(m, "operation", path, MATH_OPS, super::math_ops::MathOp::Add)?,
            clamp: flag(m, "clamp", path, false)?,
        },
        "vector_math" => NodeOp::VectorMath(enum_value(
            m,
            "operation",
            path,
            VECTOR_MATH_OPS,
            super::math_ops::VectorMathOp::Add,
        )?),
        "mix" => {
            let clamp_factor = flag(m, "clamp_factor", path, true)?;
            match enum_value(
                m,
                "data_type",
                path,
                &[("float", 0), ("vector", 1), ("rgba", 2)],
                2,
            )? {
                0 => NodeOp::MixFloat { clamp_factor },
                1 => NodeOp::MixVector { clamp_factor },
                _ => NodeOp::MixColor {
                    blend: enum_value(
                        m,
                        "blend_type",
                        path,
                        BLEND_MODES,
                        super::color::BlendMode::Mix,
                    )?,
                    clamp_factor,
                    clamp_result: flag(m, "clamp_result", path, false)?,
                },
            }
        }
        "invert" => NodeOp::Invert,
        "hue_saturation" => NodeOp::HueSaturation,
        "bright_contrast" => NodeOp::BrightContrast,
        "gamma" => NodeOp::Gamma,
        "rgb_to_bw" => NodeOp::RgbToBw,
        "separate_color" => {
            NodeOp::SeparateColor(enum_value(m, "mode", path, models, ColorModel::Rgb)?)
        }
        "combine_color" => {
            NodeOp::CombineColor(enum_value(m, "mode", path, models, ColorModel::Rgb)?)
        }
        "separate_xyz" => NodeOp::SeparateXyz,
        "combine_xyz" => NodeOp::CombineXyz,
        "map_range" => NodeOp::MapRange {
            interpolation: enum_value(
                m,
                "interpolation",
                path,
                &[
                    ("linear", MapRangeInterpolation::Linear),
                    ("stepped", MapRangeInterpolation::Stepped),
                    ("smoothstep", MapRangeInterpolation::SmoothStep),
                    ("smootherstep", MapRangeInterpolation::SmootherStep),
                ],
                MapRangeInterpolation::Linear,
            )?,
            clamp: flag(m, "clamp", path, true)?,
        },
        "clamp" => NodeOp::Clamp {
            range: enum_value(
                m,
                "clamp_type",
                path,
                &[("minmax", false), ("range", true)],
                false,
            )?,
        },
        "color_ramp" => NodeOp::ColorRamp(ramp(m, path)?),
        "checker_texture" => NodeOp::Checker,
        "gradient_texture" => NodeOp::Gradient(enum_value(
            m,
            "gradient_type",
            path,
            GRADIENT_KINDS,
            super::procedural::GradientKind::Linear,
        )?),
        "noise_texture" => NodeOp::Noise {
            dimensions: dimensions(m, path)?,
            kind: enum_value(
                m,
                "noise_type",
                path,
                super::noise::FRACTAL_KINDS,
                super::noise::FractalKind::Fbm,
            )?,
            normalize: flag(m, "normalize", path, true)?,
        },
        "white_noise_texture" => NodeOp::WhiteNoise(dimensions(m, path)?),
        "wave_texture" => {
            let rings = enum_value(
                m,
                "wave_type",
                path,
                &[("bands", false), ("rings", true)],
                false,
            )?;
            let dirs: &[(&str, u8)] = if rings {
                &[("x", 0), ("y", 1), ("z", 2), ("spherical", 3)]
            } else {
                &[("x", 0), ("y", 1), ("z", 2), ("diagonal", 3)]
            };
            NodeOp::Wave(super::procedural::Wave {
                rings,
                direction: enum_value(m, "direction", path, dirs, 0)?,
                profile: enum_value(
                    m,
                    "wave_profile",
                    path,
                    &[("sin", 0), ("saw", 1), ("tri", 2)],
                    0,
                )?,
            })
        }
        "curves" => NodeOp::Curves(curve_tables(m, path)?),
        "vector_curves" => {
            let tables = curve_tables(m, path)?;
            if tables.len() != 3 {
                return err(
                    &key_path(path, "tables"),
                    "a vector_curves node needs 3 tables (X, Y, Z)",
                );
            }
            NodeOp::VectorCurves(tables)
        }
        "blackbody" => NodeOp::Blackbody,
        "wavelength" => NodeOp::Wavelength,
        "normal_map" => NodeOp::NormalMap {
            space: enum_value(
                m,
                "space",
                path,
                &[
                    ("tangent", NormalSpace::Tangent),
                    ("object", NormalSpace::Object),
                    ("world", NormalSpace::World),
                    ("blender_object", NormalSpace::BlenderObject),
                    ("blender_world", NormalSpace::BlenderWorld),
                ],
                NormalSpace::Tangent,
            )?,
        },
        "bump" => NodeOp::Bump {
            invert: flag(m, "invert", path, false)?,
            filter_width: match m.get("filter_width") {
                None => 0.1,
                Some(v) => {
                    let w = number(v, &key_path(path, "filter_width"))?;
                    if !(w > 0.0 && w.is_finite()) {
                        return err(
                            &key_path(path, "filter_width"),
                            format!("must be a positive number of pixels, got {w}"),
                        );
                    }
                    w
                }
            },
        },
        "magic_texture" => NodeOp::Magic {
            depth: match m.get("depth") {
                None => 2,
                Some(v) => match v.as_f64() {
                    Some(x) if (0.0..=10.0).contains(&x) && x.fract() == 0.0 => x as i32,
                    _ => {
                        return err(
                            &key_path(path, "depth"),
                            format!("expected an integer in 0..10, found {v}"),
                        )
                    }
                },
            },
        },
        "brick_texture" => {
            let int = |k: &str, default: i32| -> R<i32> {
                match m.get(k) {
                    None => Ok(default),
                    Some(v) => match v.as_f64() {
                        Some(x) if (0.0..=99.0).contains(&x) && x.fract() == 0.0 => Ok(x as i32),
                        _ => err(
                            &key_path(path, k),
                            format!("expected an integer in 0..99, found {v}"),
                        ),
                    },
                }
            };
            let float = |k: &str, default: f32| -> R<f32> {
                m.get(k)
                    .map_or(Ok(default), |v| number(v, &key_path(path, k)))
            };
            NodeOp::Brick(super::procedural::Brick {
                offset: float("offset", 0.5)?,
                offset_frequency: int("offset_frequency", 2)?,
                squash: float("squash", 1.0)?,
                squash_frequency: int("squash_frequency", 2)?,
            })
        }
        "voronoi_texture" => NodeOp::Voronoi {
            dimensions: dimensions(m, path)?,
            feature: enum_value(
                m,
                "feature",
                path,
                super::voronoi::FEATURES,
                super::voronoi::Feature::F1,
            )?,
            metric: enum_value(
                m,
                "distance",
                path,
                super::voronoi::METRICS,
                super::voronoi::Metric::Euclidean,
            )?,
            normalize: flag(m, "normalize", path, false)?,
        },
        other => {
            return err(
                &key_path(path, "type"),
                format!(
                    "unknown node type '{other}' (valid: {})",
                    NODE_TYPES.join(", ")
                ),
            )
        }
    })
}

/// `tables`: 1 (Float Curve) or 3 (RGB Curves: R, G, B) of
/// `{"lo": x, "hi": x, "values": [y, ...], "extrapolate": bool}`.
fn curve_tables(m: &Map<String, Value>, path: &str) -> R<Vec<super::color::CurveTable>> {
    let p = key_path(path, "tables");
    let Some(list) = m.get("tables").and_then(Value::as_array) else {
        return err(&p, "a curves node needs 'tables' (1 or 3 curve tables)");
    };
    if list.len() != 1 && list.len() != 3 {
        return err(&p, format!("expected 1 or 3 tables, found {}", list.len()));
    }
    let mut out = Vec::new();
    for (i, t) in list.iter().enumerate() {
        let tp = format!("{p}[{i}]");
        let tm = object(t, &tp)?;
        check_keys(tm, &["lo", "hi", "values", "extrapolate"], &tp)?;
        let num = |k: &str, d: f32| tm.get(k).map_or(Ok(d), |v| number(v, &key_path(&tp, k)));
        let values = match tm.get("values").and_then(Value::as_array) {
            Some(a) if !a.is_empty() => a
                .iter()
                .enumerate()
                .map(|(j, v)| number(v, &format!("{tp}.values[{j}]")))
                .collect::<R<Vec<f32>>>()?,
            _ => {
                return err(
                    &key_path(&tp, "values"),
                    "expected a non-empty array of numbers",
                )
            }
        };
        out.push(super::color::CurveTable {
            lo: num("lo", 0.0)?,
            hi: num("hi", 1.0)?,
            values,
            extrapolate: flag(tm, "extrapolate", &tp, false)?,
        });
    }
    Ok(out)
}

fn ramp(m: &Map<String, Value>, path: &str) -> R<ColorRamp> {
    let interpolation = enum_value(
        m,
        "interpolation",
        path,
        RAMP_INTERPOLATIONS,
        super::color::RampInterpolation::Linear,
    )?;
    let p = key_path(path, "stops");
    let Some(list) = m.get("stops").and_then(Value::as_array) else {
        return err(
            &p,
            "a color_ramp needs 'stops': [[position, [r, g, b, a]], ...]",
        );
    };
    if list.is_empty() {
        return err(&p, "a color_ramp needs at least one stop");
    }
    let mut stops = Vec::with_capacity(list.len());
    for (i, s) in list.iter().enumerate() {
        let sp = format!("{p}[{i}]");
        let pair = s.as_array().filter(|a| a.len() == 2);
        let Some(pair) = pair else {
            return err(&sp, "expected [position, [r, g, b, a]]");
        };
        let pos = number(&pair[0], &format!("{sp}[0]"))?;
        let c = vector(&pair[1], &format!("{sp}[1]"), SocketType::Color)?;
        stops.push((pos, c));
    }
    // Blender keeps its stops sorted; a hand-written list may not be.
    stops.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(ColorRamp {
        interpolation,
        stops,
    })
}

/// A constant: a number (splat), 3 numbers (vector or RGB with alpha 1) or 4 (RGBA).
fn vector(v: &Value, path: &str, ty: SocketType) -> R<Vec4> {
    match v {
        Value::Number(_) => Ok(Vec4::splat(number(v, path)?)),
        Value::Array(a) if a.len() == 3 || a.len() == 4 => {
            let mut out = [
                0.0,
                0.0,
                0.0,
                if ty == SocketType::Color { 1.0 } else { 0.0 },
            ];
            for (i, e) in a.iter().enumerate() {
                out[i] = number(e, &format!("{path}[{i}]"))?;
            }
            Ok(Vec4::from_array(out))
        }
        Value::Array(a) => err(path, format!("expected 3 or 4 numbers, found {}", a.len())),
        _ => err(
            path,
            format!("expected a number, an array or a link, found {}", kind(v)),
        ),
    }
}

struct Parsed<'v> {
    op: NodeOp,
    def: &'v Map<String, Value>,
    path: String,
}

/// Parses and compiles a graph; `path` is the graph's JSON path (for messages).
pub fn parse_graph(v: &Value, path: &str, images: &mut dyn ImageLoader) -> R<ShadingGraph> {
    let m = object(v, path)?;
    check_keys(
        m,
        &["version", "world_up", "nodes", "inputs", "closures"],
        path,
    )?;
    let z_up = enum_value(m, "world_up", path, &[("y", false), ("z", true)], false)?;
    match m.get("version").and_then(Value::as_f64) {
        Some(x) if x == GRAPH_VERSION as f64 => {}
        Some(x) => {
            return err(
                &key_path(path, "version"),
                format!("unsupported graph version {x} (this Prism reads {GRAPH_VERSION})"),
            )
        }
        None => {
            return err(
                &key_path(path, "version"),
                format!("missing (this Prism reads graph version {GRAPH_VERSION})"),
            )
        }
    }
    let npath = key_path(path, "nodes");
    let empty = Map::new();
    let nodes_json = match m.get("nodes") {
        Some(n) => object(n, &npath)?,
        None => &empty,
    };
    let mut parsed: HashMap<&str, Parsed> = HashMap::new();
    for (name, def) in nodes_json {
        let p = key_path(&npath, name);
        let d = object(def, &p)?;
        let ty = match d.get("type") {
            Some(Value::String(t)) => t.as_str(),
            Some(v) => {
                return err(
                    &key_path(&p, "type"),
                    format!("expected a string, found {}", kind(v)),
                )
            }
            None => {
                return err(
                    &p,
                    format!("missing 'type' (one of: {})", NODE_TYPES.join(", ")),
                )
            }
        };
        let op = node_op(ty, d, &p, images)?;
        parsed.insert(
            name.as_str(),
            Parsed {
                op,
                def: d,
                path: p,
            },
        );
    }

    // Depth-first from the bound inputs: evaluation order, cycle detection, unused nodes dropped.
    let ipath = key_path(path, "inputs");
    let empty_bindings = Map::new();
    let closures_json: Vec<&Value> = match m.get("closures") {
        Some(Value::Array(a)) => a.iter().collect(),
        Some(v) => {
            return err(
                &key_path(path, "closures"),
                format!("expected an array, found {}", kind(v)),
            )
        }
        None => Vec::new(),
    };
    let bindings_json = match m.get("inputs") {
        Some(b) => object(b, &ipath)?,
        None if !closures_json.is_empty() => &empty_bindings,
        None => {
            return err(
                &ipath,
                "missing: a graph must drive at least one material input",
            )
        }
    };
    let mut order: Vec<&str> = Vec::new();
    let mut state: HashMap<&str, u8> = HashMap::new(); // 1 = visiting, 2 = done
    fn link_target(v: &Value) -> Option<&str> {
        v.as_object()?.get("node")?.as_str()
    }
    fn visit<'v>(
        name: &'v str,
        from_path: &str,
        parsed: &HashMap<&'v str, Parsed<'v>>,
        state: &mut HashMap<&'v str, u8>,
        order: &mut Vec<&'v str>,
    ) -> R<()> {
        match state.get(name) {
            Some(2) => return Ok(()),
            Some(_) => {
                return err(
                    from_path,
                    format!("links form a cycle through node '{name}'"),
                )
            }
            None => {}
        }
        let Some(node) = parsed.get(name) else {
            return err(from_path, format!("no node named '{name}' in the graph"));
        };
        state.insert(name, 1);
        if let Some(inputs) = node.def.get("inputs").and_then(Value::as_object) {
            for (k, v) in inputs {
                if let Some(t) = link_target(v) {
                    let p = key_path(&key_path(&node.path, "inputs"), k);
                    visit(t, &p, parsed, state, order)?;
                }
            }
        }
        state.insert(name, 2);
        order.push(name);
        Ok(())
    }
    for (k, v) in bindings_json {
        if let Some(t) = link_target(v) {
            visit(t, &key_path(&ipath, k), &parsed, &mut state, &mut order)?;
        }
    }
    let cpath = key_path(path, "closures");
    for (ci, c) in closures_json.iter().enumerate() {
        let p = format!("{cpath}[{ci}]");
        let cm = object(c, &p)?;
        check_keys(cm, &["kind", "weight", "inputs"], &p)?;
        if let Some(t) = cm.get("weight").and_then(link_target) {
            visit(t, &key_path(&p, "weight"), &parsed, &mut state, &mut order)?;
        }
        if let Some(inputs) = cm.get("inputs").and_then(Value::as_object) {
            for (k, v) in inputs {
                if let Some(t) = link_target(v) {
                    let ip = key_path(&key_path(&p, "inputs"), k);
                    visit(t, &ip, &parsed, &mut state, &mut order)?;
                }
            }
        }
    }

    // Slots and inputs.
    let mut first_slot: HashMap<&str, u32> = HashMap::new();
    let mut next = 0u32;
    for name in &order {
        first_slot.insert(name, next);
        next += parsed[name].op.signature().outputs.len() as u32;
    }
    let resolve = |v: &Value, p: &str, to: SocketType| -> R<Source> {
        if let Some(obj) = v.as_object() {
            check_keys(obj, &["node", "output"], p)?;
            let target = match obj.get("node") {
                Some(Value::String(s)) => s.as_str(),
                _ => {
                    return err(
                        p,
                        "a link needs 'node' (a node name) and 'output' (a socket name)",
                    )
                }
            };
            let node = &parsed[target];
            let outputs = node.op.signature().outputs;
            let out_name = match obj.get("output") {
                Some(Value::String(s)) => s.as_str(),
                None if outputs.len() == 1 => outputs[0].0,
                _ => return err(p, "a link needs 'output' (a socket name)"),
            };
            let Some(k) = outputs.iter().position(|o| o.0 == out_name) else {
                let names: Vec<&str> = outputs.iter().map(|o| o.0).collect();
                return err(
                    &key_path(p, "output"),
                    format!(
                        "node '{target}' has no output '{out_name}' (outputs: {})",
                        names.join(", ")
                    ),
                );
            };
            return Ok(Source::Link {
                slot: first_slot[target] + k as u32,
                from: outputs[k].1,
                to,
            });
        }
        Ok(Source::Const(vector(v, p, to)?))
    };
    let mut nodes = Vec::with_capacity(order.len());
    for name in &order {
        let node = &parsed[name];
        let sig = node.op.signature();
        let inpath = key_path(&node.path, "inputs");
        let given = match node.def.get("inputs") {
            Some(i) => Some(object(i, &inpath)?),
            None => None,
        };
        if let Some(given) = given {
            for k in given.keys() {
                if !sig.inputs.iter().any(|s| s.0 == k) {
                    let names: Vec<&str> = sig.inputs.iter().map(|s| s.0).collect();
                    return err(
                        &key_path(&inpath, k),
                        format!("unknown input '{k}' (inputs: {})", names.join(", ")),
                    );
                }
            }
        }
        let mut inputs = Vec::with_capacity(sig.inputs.len());
        for (iname, ty, default) in sig.inputs {
            let src = match given.and_then(|g| g.get(*iname)) {
                Some(v) => resolve(v, &key_path(&inpath, iname), *ty)?,
                None => match node.op.implicit_input(iname) {
                    Some(imp) => Source::Implicit(imp),
                    None => Source::Const(*default),
                },
            };
            inputs.push(src);
        }
        nodes.push(GraphNode {
            name: name.to_string(),
            op: node.op.clone(),
            inputs,
            first_slot: first_slot[name],
        });
    }
    let binding_list =
        |json: &Map<String, Value>, ipath: &str| -> R<Vec<(MaterialInput, Source)>> {
            let mut bindings = Vec::new();
            for (k, v) in json {
                let p = key_path(ipath, k);
                let Some((_, input, ty)) = MATERIAL_INPUTS.iter().find(|(n, _, _)| n == k) else {
                    let names: Vec<&str> = MATERIAL_INPUTS.iter().map(|(n, _, _)| *n).collect();
                    return err(
                        &p,
                        format!("unknown material input '{k}' (valid: {})", names.join(", ")),
                    );
                };
                bindings.push((*input, resolve(v, &p, *ty)?));
            }
            Ok(bindings)
        };
    let bindings = binding_list(bindings_json, &ipath)?;
    let mut closures = Vec::new();
    for (ci, c) in closures_json.iter().enumerate() {
        let p = format!("{cpath}[{ci}]");
        let cm = object(c, &p)?;
        let closure_kind = enum_value(
            cm,
            "kind",
            &p,
            &[
                ("bsdf", 0),
                ("emission", 1),
                ("transparent", 2),
                ("translucent", 3),
                ("subsurface", 4),
            ],
            0,
        )?;
        let weight = match cm.get("weight") {
            Some(w) => resolve(w, &key_path(&p, "weight"), SocketType::Float)?,
            None => Source::Const(Vec4::ONE),
        };
        let ipath = key_path(&p, "inputs");
        let mut inputs = match cm.get("inputs") {
            Some(i) => binding_list(object(i, &ipath)?, &ipath)?,
            None => Vec::new(),
        };
        if closure_kind == 3 {
            inputs.push((MaterialInput::Translucent, Source::Const(Vec4::ONE)));
        }
        closures.push(super::graph::Closure {
            emission: closure_kind == 1,
            transparent: closure_kind == 2,
            subsurface: closure_kind == 4,
            weight,
            bindings: inputs,
        });
    }
    let mut graph = ShadingGraph::with_closures(nodes, bindings, closures);
    graph.z_up = z_up;
    Ok(graph)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shading::ShadingInputs;
    use glam::{Vec2, Vec4Swizzles};
    use serde_json::json;

    fn parse(v: Value) -> Result<ShadingGraph, String> {
        parse_graph(&v, "materials.M.graph", &mut NoImages)
            .map_err(|e| format!("{}: {}", e.path, e.msg))
    }

    #[test]
    fn parses_and_evaluates() {
        let g = parse(json!({
            "version": 1,
            "nodes": {
                "UV": {"type": "uv_map"},
                "Sep": {"type": "separate_xyz", "inputs": {"vector": {"node": "UV", "output": "uv"}}},
                "Mul": {"type": "math", "operation": "multiply", "clamp": true,
                        "inputs": {"a": {"node": "Sep", "output": "x"}, "b": 3.0}},
                "Mix": {"type": "mix", "blend_type": "multiply",
                        "inputs": {"factor": 1.0, "a": [0.5, 0.5, 0.5], "b": {"node": "Mul"}}},
                "Unused": {"type": "invert"}
            },
            "inputs": {"roughness": {"node": "Mul", "output": "value"},
                       "base_color": {"node": "Mix", "output": "result"},
                       "metallic": 0.25}
        }))
        .unwrap();
        assert_eq!(g.nodes.len(), 4);
        let mut ctx = ShadingInputs::default();
        ctx.uv[0] = Vec2::new(0.2, 0.0);
        let v = g.evaluate(&ctx, false);
        assert!((v[MaterialInput::Roughness.index()].unwrap().x - 0.6).abs() < 1e-6);
        assert!(
            (v[MaterialInput::BaseColor.index()].unwrap().xyz() - glam::Vec3::splat(0.3))
                .abs()
                .max_element()
                < 1e-6
        );
        assert_eq!(v[MaterialInput::Metallic.index()].unwrap().x, 0.25);
    }

    #[test]
    fn vector_curves_and_wavelength_nodes() {
        // X halved by its curve (mixed at fac 0.5), Y and Z identity; the wavelength 610 nm
        // (from UV u) is red.
        let line = |lo: f32, hi: f32| json!({"lo": -1.0, "hi": 1.0, "values": [lo, hi]});
        let g = parse(json!({"version": 1,
            "nodes": {
                "Curves": {"type": "vector_curves",
                           "tables": [line(-0.5, 0.5), line(-1.0, 1.0), line(-1.0, 1.0)],
                           "inputs": {"fac": 0.5, "vector": [0.8, 0.3, -0.2]}},
                "Sep": {"type": "separate_xyz", "inputs": {"vector": {"node": "Curves"}}},
                "UV": {"type": "uv_map"},
                "U": {"type": "separate_xyz", "inputs": {"vector": {"node": "UV", "output": "uv"}}},
                "Nm": {"type": "math", "operation": "multiply",
                       "inputs": {"a": {"node": "U", "output": "x"}, "b": 1000.0}},
                "Wl": {"type": "wavelength", "inputs": {"wavelength": {"node": "Nm"}}}
            },
            "inputs": {"roughness": {"node": "Sep", "output": "x"},
                       "metallic": {"node": "Sep", "output": "z"},
                       "base_color": {"node": "Wl", "output": "color"}}}))
        .unwrap();
        let mut ctx = ShadingInputs::default();
        ctx.uv[0] = Vec2::new(0.61, 0.0);
        let v = g.evaluate(&ctx, false);
        assert!((v[MaterialInput::Roughness.index()].unwrap().x - 0.6).abs() < 1e-6);
        assert!((v[MaterialInput::Metallic.index()].unwrap().x + 0.2).abs() < 1e-6);
        let c = v[MaterialInput::BaseColor.index()].unwrap().xyz();
        assert!(c.x > 0.2 && c.x > 4.0 * c.y && c.z < 1e-3, "{c}");
        let bad = parse(json!({"version": 1,
            "nodes": {"C": {"type": "vector_curves", "tables": [line(0.0, 1.0)]}},
            "inputs": {"roughness": {"node": "C"}}}));
        assert!(bad.unwrap_err().contains("3 tables"));
    }

    #[test]
    fn world_up_z_reads_blender_world_vectors() {
        // glTF's up (+Y) is Blender's +Z: a graph in Blender's frame sees the normal as +Z.
        let g = parse(json!({"version": 1, "world_up": "z",
            "nodes": {"Geo": {"type": "geometry"},
                      "Sep": {"type": "separate_xyz", "inputs": {"vector": {"node": "Geo", "output": "normal"}}}},
            "inputs": {"roughness": {"node": "Sep", "output": "z"},
                       "metallic": {"node": "Sep", "output": "y"}}}))
        .unwrap();
        let ctx = ShadingInputs {
            normal: glam::Vec3::Y,
            ..Default::default()
        };
        let v = g.evaluate(&ctx, false);
        assert_eq!(v[MaterialInput::Roughness.index()].unwrap().x, 1.0);
        assert_eq!(v[MaterialInput::Metallic.index()].unwrap().x, 0.0);
    }

    /// Bump offsets in pixels: Blender 4.5+'s default 0.1, the largest of several nodes.
    #[test]
    fn bump_filter_width() {
        let g = parse(json!({"version": 1, "nodes": {"B": {"type": "bump"}},
                             "inputs": {"normal": {"node": "B"}}}))
        .unwrap();
        assert_eq!(g.bump_filter_width(), 0.1);
        let g = parse(json!({"version": 1, "nodes": {
                "B": {"type": "bump", "filter_width": 1.0,
                      "inputs": {"normal": {"node": "C", "output": "normal"}}},
                "C": {"type": "bump", "filter_width": 0.5}},
            "inputs": {"normal": {"node": "B"}}}))
        .unwrap();
        assert_eq!(g.bump_filter_width(), 1.0);
    }

    #[test]
    fn errors_name_the_path() {
        let cases = [
            (
                json!({"nodes": {}, "inputs": {}}),
                "materials.M.graph.version: missing",
            ),
            (
                json!({"version": 2, "inputs": {}}),
                "unsupported graph version 2",
            ),
            (
                json!({"version": 1, "nodes": {"A": {"type": "warp"}}, "inputs": {}}),
                "materials.M.graph.nodes.A.type: unknown node type 'warp'",
            ),
            (
                json!({"version": 1, "nodes": {"A": {"type": "math", "operation": "mul"}}, "inputs": {}}),
                "materials.M.graph.nodes.A.operation: unknown value 'mul'",
            ),
            (
                json!({"version": 1, "nodes": {}, "inputs": {"roughness": {"node": "B"}}}),
                "materials.M.graph.inputs.roughness: no node named 'B'",
            ),
            (
                json!({"version": 1, "nodes": {"A": {"type": "bump", "filter_width": -1.0}}, "inputs": {}}),
                "materials.M.graph.nodes.A.filter_width: must be a positive number of pixels",
            ),
            (
                json!({"version": 1, "nodes": {
                    "A": {"type": "math", "inputs": {"a": {"node": "B"}}},
                    "B": {"type": "math", "inputs": {"a": {"node": "A"}}}},
                    "inputs": {"roughness": {"node": "A"}}}),
                "cycle",
            ),
            (
                json!({"version": 1, "nodes": {"A": {"type": "math", "inputs": {"q": 1}}},
                    "inputs": {"roughness": {"node": "A"}}}),
                "materials.M.graph.nodes.A.inputs.q: unknown input 'q'",
            ),
            (
                json!({"version": 1, "nodes": {"A": {"type": "math"}},
                    "inputs": {"roughness": {"node": "A", "output": "color"}}}),
                "node 'A' has no output 'color'",
            ),
            (
                json!({"version": 1, "nodes": {}, "inputs": {"shine": 1}}),
                "unknown material input 'shine'",
            ),
            (
                json!({"version": 1, "nodes": {"R": {"type": "color_ramp", "stops": []}},
                    "inputs": {"roughness": {"node": "R", "output": "alpha"}}}),
                "materials.M.graph.nodes.R.stops: a color_ramp needs at least one stop",
            ),
            (
                json!({"version": 1, "nodes": {"I": {"type": "image_texture"}}, "inputs": {}}),
                "needs 'image'",
            ),
            (
                json!({"version": 1, "nodes": {"U": {"type": "uv_map", "set": 9}}, "inputs": {}}),
                "materials.M.graph.nodes.U.set: expected an integer in 0..3",
            ),
        ];
        for (v, want) in cases {
            let e = parse(v).map(|_| ()).expect_err(want);
            assert!(e.contains(want), "{e} does not contain {want}");
        }
    }
}
