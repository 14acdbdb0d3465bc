//! glTF 2.0 (`.gltf` / `.glb`) import into the plain-data [`SceneDesc`].
//!
//! * Geometry: every triangle primitive of every node of the default scene (or scene 0), with the
//!   node hierarchy's transforms. One [`MeshDesc`] per used (mesh, primitive), one
//!   [`InstanceDesc`] per node use. Strips and fans become triangle lists, points and lines are
//!   skipped (one warning). Degenerate triangles (zero area, non-finite positions) are dropped.
//! * Materials: metallic-roughness + KHR_materials_{emissive_strength, specular, transmission, ior,
//!   volume, dispersion} + KHR_texture_transform; textures decoded to linear texels.
//! * KHR_lights_punctual, converted to Blender/Cycles radiometric units by
//!   [`gltf_light_intensity_to_prism`].
//! * The camera: the first camera node in traversal order, or the one picked by name.
//!
//! The loader never trusts the file: the GLB container, buffer/accessor ranges, indices and node
//! graphs are checked here (the `gltf` crate's own readers slice without bounds checks and its
//! validation can index out of range), so bad input is always a one-line
//! [`PrismError::Input`] naming the file.

use rayon::prelude::*;
use std::cell::OnceCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf::Semantic;

use crate::error::PrismError;
use crate::scene::desc::*;
use crate::scene::gltf_json::{prepare, TextureSource};
use crate::scene::materials_json::io_msg;
use crate::scene::texture::{decode_image, parse_data_uri, percent_decode, to_linear_texels};
use crate::shading::image::Extension;

/// Luminous efficacy used by Blender's glTF I/O to convert between watts and lumens
/// (`PBR_WATTS_TO_LUMENS = 683` in glTF-Blender-IO `io_scene_gltf2/blender/com/conversion.py`).
pub const PBR_WATTS_TO_LUMENS: f32 = 683.0;

/// Converts a KHR_lights_punctual `intensity` to Prism's (= Blender/Cycles') radiometric units.
///
/// glTF stores photometric quantities: candela (lm/sr) for point and spot lights, lux (lm/m^2)
/// for directional lights. Blender's glTF exporter in its default "Standard" lighting mode
/// (`export_import_convert_lighting_mode = 'SPEC'`), glTF-Blender-IO
/// `io_scene_gltf2/blender/exp/lights.py`, `__gather_intensity`, writes
///
/// * point / spot: `intensity [cd]  = P [W] / (4 pi) * 683`  (a spot is given "as if it were a
///   point light": the same power-to-intensity rule, not concentrated into the cone)
/// * sun:          `intensity [lux] = S [W/m^2] * 683`
///
/// and its importer (`io_scene_gltf2/blender/imp/light.py`, `calc_energy_pointlike` /
/// `calc_energy_directional`) does the inverse: `P = cd / 683 * 4 pi`, `S = lux / 683`.
/// Prism uses Cycles' units: a point (or spot) light of power P has radiant intensity
/// `P / (4 pi)` W/sr, and a sun of strength S gives irradiance `S` W/m^2. Hence for every light
/// type
///
/// ```text
/// point/spot:   I [W/sr]  = P / (4 pi) = (cd / 683 * 4 pi) / (4 pi) = cd / 683
/// directional:  E [W/m^2] = S          = lux / 683
/// ```
pub fn gltf_light_intensity_to_prism(intensity: f32) -> f32 {
    intensity / PBR_WATTS_TO_LUMENS
}

/// The result of importing a glTF file.
#[derive(Debug)]
pub struct GltfImport {
    pub scene: SceneDesc,
    /// The glTF's material names by material index (`None` for unnamed materials); the sidecar
    /// matches against these.
    pub material_names: Vec<Option<String>>,
}

/// Most node visits accepted: a node may legally be reached along several paths (instancing),
/// and a malicious DAG could otherwise reach exponentially many instances.
const MAX_NODE_VISITS: usize = 1 << 22;
/// Upper bound for the element count of an accessor without a buffer view (all zeros, or
/// sparse-only): nothing in the file bounds its memory otherwise.
const MAX_ZERO_ACCESSOR_ELEMENTS: usize = 1 << 24;

type R<T> = Result<T, PrismError>;

/// Imports a `.gltf` or `.glb` file. `camera_name` selects a camera by node or camera name.
pub fn import_gltf(path: &Path, camera_name: Option<&str>) -> R<GltfImport> {
    let file = path.display().to_string();
    let fail = |msg: String| PrismError::input(format!("{file}: {msg}"));
    let bytes = std::fs::read(path).map_err(|e| fail(format!("cannot read: {}", io_msg(&e))))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let is_glb = bytes.starts_with(b"glTF") || ext.as_deref() == Some("glb");
    let (json_bytes, bin) = if is_glb {
        split_glb(&bytes).map_err(fail)?
    } else {
        (&bytes[..], None)
    };
    let prepared = prepare(json_bytes).map_err(fail)?;
    let mut warnings = prepared.warnings;
    let root = prepared.root;
    let (unsupported_used, unreadable_required) = extension_support(&root);
    if !unsupported_used.is_empty() {
        // Optional extensions may be ignored (glTF 2.0 spec 3.12); say which, since the image
        // then differs from what the author saw (clearcoat, sheen, ...).
        warnings.push(format!(
            "extensions not supported and ignored: {}",
            unsupported_used.join(", ")
        ));
    }
    if let Some(ext) = unreadable_required.first() {
        // Compressed geometry the renderer cannot decode: the only required extensions that
        // would draw wrong (nothing, or garbage) rather than approximately.
        return Err(fail(format!(
            "extensionsRequired: {ext} is required and not supported (its geometry cannot be read)"
        )));
    }
    // The crate's validation refuses valid files (issue 16) and stops at the first problem
    // anywhere; the importer checks every object it uses, where it uses it.
    let doc = gltf::Document::from_json_without_validation(root);
    let dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let buffers = (0..doc.as_json().buffers.len())
        .map(|_| OnceCell::new())
        .collect();
    let mut imp = Importer {
        doc: &doc,
        bin,
        buffers,
        dir,
        scene: SceneDesc::default(),
        mesh_cache: HashMap::new(),
        image_cache: HashMap::new(),
        texture_cache: HashMap::new(),
        texture_sources: prepared.texture_sources,
        unknown_lights: prepared.unknown_lights,
        material_errors: Vec::new(),
        cameras: Vec::new(),
        skipped_non_triangle: 0,
        warned: Vec::new(),
    };
    imp.scene.warnings = warnings;
    imp.run(camera_name).map_err(fail)?;
    // A missing camera is the caller's to judge (`load::load_scene` refuses it; a viewport
    // brings its own).
    let material_names = doc
        .materials()
        .map(|m| m.name().map(str::to_string))
        .collect();
    Ok(GltfImport {
        scene: imp.scene,
        material_names,
    })
}

/// Splits a binary glTF container into its JSON chunk and optional BIN chunk.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    const JSON: u32 = 0x4E4F_534A;
    const BIN: u32 = 0x004E_4942;
    let u32_at =
        |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    if bytes.len() < 12 {
        return Err(format!(
            "truncated GLB: {} bytes, shorter than the 12-byte header",
            bytes.len()
        ));
    }
    if &bytes[0..4] != b"glTF" {
        return Err("not a binary glTF file (missing 'glTF' magic)".into());
    }
    let version = u32_at(4);
    if version != 2 {
        return Err(format!("unsupported GLB version {version} (expected 2)"));
    }
    let length = u32_at(8) as usize;
    if length > bytes.len() {
        return Err(format!(
            "truncated GLB: header says {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    if length < 20 {
        return Err(format!(
            "invalid GLB: declared length {length} is too small"
        ));
    }
    let mut pos = 12usize;
    let mut json = None;
    let mut bin = None;
    let mut k = 0;
    while pos < length {
        if length - pos < 8 {
            return Err(format!(
                "truncated GLB: chunk {k} header at byte {pos} is cut short"
            ));
        }
        let clen = u32_at(pos) as usize;
        let ctype = u32_at(pos + 4);
        let start = pos + 8;
        if clen > length - start {
            return Err(format!(
                "truncated GLB: chunk {k} declares {clen} bytes but only {} remain",
                length - start
            ));
        }
        let data = &bytes[start..start + clen];
        match (k, ctype) {
            (0, JSON) => json = Some(data),
            (0, _) => return Err("invalid GLB: the first chunk is not JSON".into()),
            (_, BIN) if bin.is_none() => bin = Some(data),
            _ => {} // unknown chunks are ignored (glTF spec)
        }
        pos = start + clen;
        pos = (pos + 3) & !3; // chunks are 4-byte aligned
        k += 1;
    }
    match json {
        Some(j) => Ok((j, bin)),
        None => Err("invalid GLB: no JSON chunk".into()),
    }
}

/// The glTF extensions the importer implements (everything else in `extensionsUsed` is
/// ignored with one warning).
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "EXT_mesh_gpu_instancing",
    "EXT_texture_webp",
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_dispersion",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_iridescence",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    // Integer (normalised or not) positions, normals and UVs: every attribute is read through
    // `read_component`, which converts all component types.
    "KHR_mesh_quantization",
    "KHR_texture_transform",
];

/// Geometry-compression extensions: when required, their primitives cannot be read at all.
const GEOMETRY_COMPRESSION: &[&str] = &["KHR_draco_mesh_compression", "EXT_meshopt_compression"];

/// (extensions used but not supported, required extensions whose geometry cannot be read).
/// Other unsupported required extensions (texture formats, material models) draw
/// approximately and are warned about where they are met.
fn extension_support(root: &gltf::json::Root) -> (Vec<String>, Vec<String>) {
    let mut used: Vec<String> = root
        .extensions_used
        .iter()
        .chain(root.extensions_required.iter())
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(&e.as_str()))
        .cloned()
        .collect();
    used.sort();
    used.dedup();
    let unreadable = root
        .extensions_required
        .iter()
        .filter(|e| GEOMETRY_COMPRESSION.contains(&e.as_str()))
        .cloned()
        .collect();
    (used, unreadable)
}

/// "`what`: index `i` out of range (`n` `things`)", the one wording of a broken reference.
fn out_of_range(what: &str, i: usize, n: usize, things: &str) -> String {
    format!("{what}: index {i} out of range ({n} {things})")
}

/// `Err(out_of_range(..))` when the optional reference `index` is not below `n`.
fn check_reference(index: Option<usize>, n: usize, what: &str, things: &str) -> Result<(), String> {
    match index {
        Some(i) if i >= n => Err(out_of_range(what, i, n, things)),
        _ => Ok(()),
    }
}

fn is_remote(uri: &str) -> bool {
    uri.contains("://")
}

fn resolve_uri(dir: &Path, uri: &str) -> PathBuf {
    let decoded = percent_decode(uri);
    dir.join(String::from_utf8_lossy(&decoded).as_ref())
}

/// Reads buffer `i` (called on first use: a buffer no drawn geometry reads may be missing).
fn load_buffer(
    json: &gltf::json::Buffer,
    i: usize,
    bin: Option<&[u8]>,
    dir: &Path,
) -> Result<Vec<u8>, String> {
    let (data, what) = match json.uri.as_deref() {
        // Only the first buffer may refer to the GLB-stored BIN chunk (glTF 2.0 spec 4.4.3.3);
        // a later one without `uri` has no data (an EXT_meshopt_compression fallback, say).
        None if i == 0 => match bin {
            Some(b) => (b.to_vec(), "the GLB BIN chunk".to_string()),
            None => {
                return Err(format!(
                    "buffers[{i}]: has no 'uri' and the file has no GLB binary chunk"
                ))
            }
        },
        None => return Err(format!("buffers[{i}]: has no 'uri', so no data")),
        Some(uri) => {
            if let Some(d) = parse_data_uri(uri) {
                let d = d.map_err(|e| format!("buffers[{i}]: {e}"))?;
                (d.bytes, "its data URI".to_string())
            } else if is_remote(uri) {
                return Err(format!("buffers[{i}]: unsupported remote URI '{uri}'"));
            } else {
                let p = resolve_uri(dir, uri);
                let data = std::fs::read(&p)
                    .map_err(|e| format!("buffers[{i}]: cannot read '{uri}': {}", io_msg(&e)))?;
                (data, format!("'{uri}'"))
            }
        }
    };
    let declared = json.byte_length.0 as usize;
    if data.len() < declared {
        return Err(format!(
            "buffers[{i}]: {what} has {} bytes, its byteLength says {declared}",
            data.len()
        ));
    }
    Ok(data)
}

struct CameraCandidate {
    node_name: Option<String>,
    camera_name: Option<String>,
    camera_index: usize,
    world: Mat4,
    /// World transforms over the shutter (`prism_motion`), empty when still.
    motion: Vec<Mat4>,
}

struct Importer<'d> {
    doc: &'d gltf::Document,
    /// The GLB BIN chunk, if any.
    bin: Option<&'d [u8]>,
    /// Buffers by index, each read on first use.
    buffers: Vec<OnceCell<Result<Vec<u8>, String>>>,
    dir: PathBuf,
    scene: SceneDesc,
    /// (mesh, primitive, morph weights' bits) -> index into `scene.meshes` (None: no
    /// triangles / skipped).
    mesh_cache: HashMap<(usize, usize, Vec<u32>), Option<usize>>,
    image_cache: HashMap<usize, crate::scene::texture::DecodedImage>,
    /// (image, colour space is sRGB, wrap s, wrap t, bilinear) -> texture index.
    texture_cache: HashMap<(usize, bool, Extension, Extension, bool), usize>,
    /// By texture index: the image it reads, or why it reads none.
    texture_sources: Vec<TextureSource>,
    /// KHR_lights_punctual lights of types this renderer does not know: (index, type).
    unknown_lights: Vec<(usize, String)>,
    /// By material index: why the material could not be read. Raised when a drawn primitive
    /// uses it, a warning otherwise.
    material_errors: Vec<Option<String>>,
    cameras: Vec<CameraCandidate>,
    skipped_non_triangle: usize,
    warned: Vec<String>,
}

fn finite_all(xs: &[f32]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

impl<'d> Importer<'d> {
    fn warn_once(&mut self, msg: String) {
        if !self.warned.contains(&msg) {
            self.warned.push(msg.clone());
            self.scene.warnings.push(msg);
        }
    }

    /// One warning naming the meshes whose textured material has no TEXCOORD_0 to look the
    /// texture up with (they read texture coordinate (0, 0), as in Cycles).
    fn warn_textures_without_uvs(&mut self) {
        let mut names: Vec<String> = Vec::new();
        for mesh in &self.scene.meshes {
            let Some(material) = mesh.material.and_then(|i| self.scene.materials.get(i)) else {
                continue;
            };
            let g = &material.gltf;
            let textured = g.base_color_texture.is_some()
                || g.metallic_roughness_texture.is_some()
                || g.emissive_texture.is_some()
                || g.normal_texture.is_some();
            if textured && mesh.uvs.is_none() && !names.contains(&mesh.name) {
                names.push(mesh.name.clone());
            }
        }
        if !names.is_empty() {
            let shown: Vec<&str> = names.iter().take(5).map(String::as_str).collect();
            let more = names.len().saturating_sub(shown.len());
            self.scene.warnings.push(format!(
                "{} without TEXCOORD_0 use textured materials; the textures are read at uv (0, 0){}",
                shown.join(", "),
                if more > 0 { format!(" (and {more} more)") } else { String::new() }
            ));
        }
    }

    fn run(&mut self, camera_name: Option<&str>) -> Result<(), String> {
        // Every material is read (the sidecar addresses them by index); one that cannot be is
        // an error only if drawn geometry uses it.
        let doc = self.doc;
        for m in doc.materials() {
            let i = m.index().expect("listed materials have indices");
            let desc = self
                .check_material_references(i)
                .and_then(|()| self.material(&m));
            let (desc, error) = match desc {
                Ok(d) => (d, None),
                Err(e) => (
                    GltfMaterialDesc {
                        name: m
                            .name()
                            .map_or_else(|| format!("material {i}"), str::to_string),
                        ..Default::default()
                    },
                    Some(e),
                ),
            };
            self.material_errors.push(error);
            self.scene.materials.push(MaterialDesc {
                gltf: desc,
                ..Default::default()
            });
        }
        let json = doc.as_json();
        let scene = match json.scene {
            Some(s) if s.value() >= json.scenes.len() => {
                return Err(out_of_range(
                    "scene",
                    s.value(),
                    json.scenes.len(),
                    "scenes",
                ))
            }
            Some(s) => Some(s.value()),
            None => (!json.scenes.is_empty()).then_some(0),
        };
        let roots: Vec<usize> = match scene {
            Some(s) => json.scenes[s].nodes.iter().map(|n| n.value()).collect(),
            None => {
                // No scene: render every root node (a node that is nobody's child).
                let mut is_child = vec![false; json.nodes.len()];
                for n in &json.nodes {
                    for c in n.children.iter().flatten() {
                        if let Some(flag) = is_child.get_mut(c.value()) {
                            *flag = true;
                        }
                    }
                }
                (0..is_child.len()).filter(|&i| !is_child[i]).collect()
            }
        };
        self.traverse(&roots)?;
        let drawn: std::collections::HashSet<usize> = self
            .scene
            .meshes
            .iter()
            .filter_map(|m| m.material)
            .collect();
        let unused_broken: Vec<String> = self
            .material_errors
            .iter()
            .enumerate()
            .filter(|(i, e)| e.is_some() && !drawn.contains(i))
            .map(|(_, e)| e.clone().unwrap_or_default())
            .collect();
        for e in unused_broken {
            self.scene
                .warnings
                .push(format!("{e} (the material is not used by drawn geometry)"));
        }
        self.warn_textures_without_uvs();
        if self.skipped_non_triangle > 0 {
            let n = self.skipped_non_triangle;
            let s = if n == 1 { "" } else { "s" };
            self.scene.warnings.push(format!(
                "skipped {n} point/line primitive{s}: only triangles are rendered"
            ));
        }
        let has_triangles = self
            .scene
            .instances
            .iter()
            .any(|i| !self.scene.meshes[i.mesh].indices.is_empty());
        if !has_triangles {
            // Blender renders a scene without geometry (an HDRI look-development render, a
            // turntable before the model is loaded): so do we, with a warning.
            self.scene.warnings.push(
                "no renderable geometry (no non-degenerate triangles): the image shows only the world"
                    .into(),
            );
        }
        if !self.cameras.is_empty() {
            let (camera, warnings) = self.pick_camera(camera_name)?;
            self.scene.camera = Some(camera);
            self.scene.warnings.extend(warnings);
        }
        Ok(())
    }

    fn node_label(node: &gltf::Node) -> String {
        match node.name() {
            Some(n) => format!("node {} '{n}'", node.index()),
            None => format!("node {}", node.index()),
        }
    }

    /// Depth-first, pre-order traversal (the order that decides the default camera), iterative
    /// so that deep hierarchies cannot overflow the stack; cycles and references to nodes that
    /// do not exist are input errors.
    fn traverse(&mut self, roots: &[usize]) -> Result<(), String> {
        enum Step {
            /// (node, parent world transform, the node that lists it; None: the scene)
            Enter(usize, Mat4, Option<usize>),
            Exit(usize),
        }
        let json = self.doc.as_json();
        let n_nodes = json.nodes.len();
        let mut on_path = vec![false; n_nodes];
        let mut visits = 0usize;
        let mut stack: Vec<Step> = roots
            .iter()
            .rev()
            .map(|&r| Step::Enter(r, Mat4::IDENTITY, None))
            .collect();
        while let Some(step) = stack.pop() {
            match step {
                Step::Exit(i) => on_path[i] = false,
                Step::Enter(i, parent, referrer) => {
                    if i >= n_nodes {
                        let user = match referrer {
                            Some(p) => format!("nodes[{p}].children"),
                            None => "scenes.nodes".to_string(),
                        };
                        return Err(out_of_range(&user, i, n_nodes, "nodes"));
                    }
                    if on_path[i] {
                        let node = self.doc.nodes().nth(i).expect("index checked");
                        return Err(format!(
                            "{}: the node hierarchy has a cycle (the node is its own ancestor)",
                            Self::node_label(&node)
                        ));
                    }
                    visits += 1;
                    if visits > MAX_NODE_VISITS {
                        return Err(format!(
                            "the node hierarchy instantiates more than {MAX_NODE_VISITS} nodes"
                        ));
                    }
                    let world = self.visit(i, parent)?;
                    on_path[i] = true;
                    stack.push(Step::Exit(i));
                    for c in json.nodes[i].children.iter().flatten().rev() {
                        stack.push(Step::Enter(c.value(), world, Some(i)));
                    }
                }
            }
        }
        Ok(())
    }

    /// Handles one node (mesh instances, camera, light); returns its world transform.
    fn visit(&mut self, index: usize, parent: Mat4) -> Result<Mat4, String> {
        let node = self
            .doc
            .nodes()
            .nth(index)
            .ok_or_else(|| format!("node {index} does not exist"))?;
        let local = match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                let q = glam::Quat::from_array(rotation);
                let q = if q.length_squared() > 0.0 {
                    q.normalize()
                } else {
                    q
                };
                Mat4::from_scale_rotation_translation(
                    Vec3::from_array(scale),
                    q,
                    Vec3::from_array(translation),
                )
            }
        };
        if !finite_all(&local.to_cols_array()) {
            return Err(format!(
                "{}: transform has non-finite values",
                Self::node_label(&node)
            ));
        }
        let world = parent * local;
        let motion: Vec<Mat4> = self
            .node_motion(&node)?
            .into_iter()
            .map(|l| parent * l)
            .collect();
        let node_name = node
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("node {index}"));

        let json = self.doc.as_json();
        let node_json = &json.nodes[index];
        let mesh_ref = node_json.mesh.map(|m| m.value());
        check_reference(
            mesh_ref,
            json.meshes.len(),
            &format!("nodes[{index}].mesh"),
            "meshes",
        )?;
        let camera_ref = node_json.camera.map(|c| c.value());
        check_reference(
            camera_ref,
            json.cameras.len(),
            &format!("nodes[{index}].camera"),
            "cameras",
        )?;
        if let Some(mesh) = node.mesh() {
            let extras = node
                .extras()
                .as_ref()
                .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok());
            let flag = |key: &str| extras.as_ref().and_then(|v| v.get(key)?.as_bool());
            // Blender's ray visibility (Object > Visibility > Ray Visibility: Camera, Shadow),
            // written by the add-on when off, and its holdout (`prism_holdout`). An area light's mesh casts no shadow and is
            // hidden from the camera unless told otherwise.
            let area_light = flag("prism_area_light") == Some(true);
            let visibility = InstanceVisibility {
                casts_shadows: !area_light && flag("prism_casts_shadows").unwrap_or(true),
                camera_visible: flag("prism_visible_camera").unwrap_or(!area_light),
                light_only: area_light,
                holdout: flag("prism_holdout").unwrap_or(false),
                // An emitter's (an area light's) ray visibility as a light.
                light_visibility: RayVisibility {
                    diffuse: flag("prism_visible_diffuse").unwrap_or(true),
                    glossy: flag("prism_visible_glossy").unwrap_or(true),
                    transmission: flag("prism_visible_transmission").unwrap_or(true),
                    volume: flag("prism_visible_volume_scatter").unwrap_or(true),
                },
            };
            if node_json.skin.is_some() {
                let label = Self::node_label(&node);
                self.warn_once(format!(
                    "{label}: skinning is not supported; its mesh is rendered unskinned (the bind pose) under the node"
                ));
            }
            // Morph target weights: the node's override the mesh's (glTF 2.0 spec 3.7.2.2).
            let weights: Vec<f32> = node_json
                .weights
                .clone()
                .or_else(|| self.doc.as_json().meshes[mesh.index()].weights.clone())
                .unwrap_or_default();
            let gpu_locals = self.gpu_instances(index)?;
            let transforms = match &gpu_locals {
                Some(locals) => locals.iter().map(|l| world * *l).collect(),
                None => vec![world],
            };
            let locals = gpu_locals.unwrap_or_else(|| vec![Mat4::IDENTITY]);
            for prim in mesh.primitives() {
                if let Some(m) = self.mesh_for(&mesh, &prim, &weights)? {
                    for (&object_to_world, local) in transforms.iter().zip(&locals) {
                        let i = self.scene.instances.len();
                        if visibility != InstanceVisibility::default() {
                            let vis = &mut self.scene.instance_visibility;
                            vis.resize(i + 1, InstanceVisibility::default());
                            vis[i] = visibility;
                        }
                        if !motion.is_empty() {
                            let moves = &mut self.scene.instance_motion;
                            moves.resize(i + 1, Vec::new());
                            moves[i] = motion.iter().map(|m| *m * *local).collect();
                        }
                        self.scene.instances.push(InstanceDesc {
                            mesh: m,
                            object_to_world,
                            name: node_name.clone(),
                        });
                    }
                }
            }
        }
        if let Some(cam) = node.camera() {
            self.cameras.push(CameraCandidate {
                node_name: node.name().map(str::to_string),
                camera_name: cam.name().map(str::to_string),
                camera_index: cam.index(),
                world,
                motion: motion.clone(),
            });
        }
        // Read the light index from the JSON ourselves: `Node::light()` unwraps.
        let light_index = self.doc.as_json().nodes[index]
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map(|l| l.light.value());
        if let Some(li) = light_index {
            self.light(li, &node_name, world)?;
        }
        Ok(world)
    }

    /// The node's local transforms over the shutter from its extras' `prism_motion` (written
    /// by the Blender add-on for motion blur): an array of at least two column-major 4x4
    /// matrices (as glTF's `matrix`) at equally spaced times from shutter open to close.
    /// Empty when the node has none.
    fn node_motion(&self, node: &gltf::Node) -> Result<Vec<Mat4>, String> {
        let Some(raw) = node.extras().as_ref() else {
            return Ok(Vec::new());
        };
        let Ok(extras) = serde_json::from_str::<serde_json::Value>(raw.get()) else {
            return Ok(Vec::new());
        };
        let Some(value) = extras.get("prism_motion") else {
            return Ok(Vec::new());
        };
        let label = Self::node_label(node);
        let bad = || {
            format!(
                "{label}: extras.prism_motion must be an array of at least two arrays of 16 finite numbers (column-major 4x4 matrices)"
            )
        };
        let keys = value.as_array().ok_or_else(bad)?;
        if keys.len() < 2 {
            return Err(bad());
        }
        keys.iter()
            .map(|k| {
                let nums = k.as_array().filter(|a| a.len() == 16).ok_or_else(bad)?;
                let mut m = [0f32; 16];
                for (dst, v) in m.iter_mut().zip(nums) {
                    *dst = v.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)? as f32;
                }
                Ok(Mat4::from_cols_array(&m))
            })
            .collect()
    }

    /// EXT_mesh_gpu_instancing: the node's per-instance TRANSLATION / ROTATION / SCALE as
    /// local transforms applied before the node's (the extension's "the node's global transform
    /// is applied after the instance transform"); `None` without the extension.
    fn gpu_instances(&self, node: usize) -> Result<Option<Vec<Mat4>>, String> {
        let Some(ext) = self.doc.as_json().nodes[node]
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("EXT_mesh_gpu_instancing"))
        else {
            return Ok(None);
        };
        let path = format!("nodes[{node}].extensions.EXT_mesh_gpu_instancing.attributes");
        let attrs = ext.get("attributes").and_then(|a| a.as_object());
        let read = |key: &str, dims: Dimensions| -> Result<Option<Vec<f32>>, String> {
            let Some(v) = attrs.and_then(|a| a.get(key)) else {
                return Ok(None);
            };
            let i = v
                .as_u64()
                .ok_or_else(|| format!("{path}.{key}: not an accessor index"))?;
            let acc = self.accessor(i as usize, &format!("{path}.{key}"))?;
            self.read_floats(&acc, dims, &format!("{path}.{key}"))
                .map(Some)
        };
        let t = read("TRANSLATION", Dimensions::Vec3)?;
        let r = read("ROTATION", Dimensions::Vec4)?;
        let s = read("SCALE", Dimensions::Vec3)?;
        let counts: Vec<usize> = [
            t.as_ref().map(|v| v.len() / 3),
            r.as_ref().map(|v| v.len() / 4),
            s.as_ref().map(|v| v.len() / 3),
        ]
        .into_iter()
        .flatten()
        .collect();
        let Some(&n) = counts.first() else {
            return Err(format!("{path}: no TRANSLATION, ROTATION or SCALE"));
        };
        if counts.iter().any(|&c| c != n) {
            return Err(format!(
                "{path}: TRANSLATION, ROTATION and SCALE have different counts"
            ));
        }
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let tr = t
                .as_ref()
                .map_or(Vec3::ZERO, |v| Vec3::from_slice(&v[3 * i..]));
            let sc = s
                .as_ref()
                .map_or(Vec3::ONE, |v| Vec3::from_slice(&v[3 * i..]));
            let q = r.as_ref().map_or(glam::Quat::IDENTITY, |v| {
                glam::Quat::from_slice(&v[4 * i..])
            });
            let q = if q.length_squared() > 0.0 && q.is_finite() {
                q.normalize()
            } else {
                glam::Quat::IDENTITY
            };
            let m = Mat4::from_scale_rotation_translation(sc, q, tr);
            if !finite_all(&m.to_cols_array()) {
                return Err(format!("{path}: instance {i} has non-finite values"));
            }
            out.push(m);
        }
        Ok(Some(out))
    }

    // ---------------------------------------------------------------- lights

    fn light(&mut self, li: usize, node_name: &str, world: Mat4) -> Result<(), String> {
        if let Some((_, kind)) = self.unknown_lights.iter().find(|(i, _)| *i == li) {
            let msg = format!(
                "KHR_lights_punctual light {li} (on node '{node_name}'): type '{kind}' is not known to this renderer; skipped"
            );
            self.warn_once(msg);
            return Ok(());
        }
        let light = self
            .doc
            .lights()
            .and_then(|mut l| l.nth(li))
            .ok_or_else(|| format!("node '{node_name}': light {li} does not exist"))?;
        let name = light
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| node_name.to_string());
        let label = format!("light {li} '{name}'");
        let intensity = light.intensity();
        if !intensity.is_finite() || intensity < 0.0 {
            return Err(format!(
                "{label}: intensity must be a finite number >= 0, got {intensity}"
            ));
        }
        let color = Vec3::from_array(light.color());
        if !color.is_finite() || color.min_element() < 0.0 {
            return Err(format!("{label}: color must be finite and non-negative"));
        }
        let kind = match light.kind() {
            gltf::khr_lights_punctual::Kind::Point => PunctualKind::Point,
            gltf::khr_lights_punctual::Kind::Directional => PunctualKind::Directional,
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let (inner, outer) = (inner_cone_angle, outer_cone_angle);
                let ok = inner.is_finite()
                    && outer.is_finite()
                    && outer > 0.0
                    && outer <= std::f32::consts::FRAC_PI_2 + 1e-4
                    && inner >= 0.0
                    && inner <= outer;
                if !ok {
                    return Err(format!(
                        "{label}: spot cone angles must satisfy 0 <= inner <= outer <= pi/2 (inner {inner}, outer {outer})"
                    ));
                }
                PunctualKind::Spot {
                    inner_cone: inner,
                    outer_cone: outer.min(std::f32::consts::FRAC_PI_2),
                }
            }
        };
        let position = world.transform_point3(Vec3::ZERO);
        let dir = world.transform_vector3(Vec3::NEG_Z);
        let direction = if dir.length_squared() > 0.0 && dir.is_finite() {
            dir.normalize()
        } else if kind == PunctualKind::Point {
            Vec3::NEG_Z
        } else {
            // A zero-scaled node (a light switched off by scaling, say): no direction to shine.
            self.warn_once(format!(
                "{label}: node '{node_name}' has a degenerate transform (no direction); the light is skipped"
            ));
            return Ok(());
        };
        // What glTF has no field for, written by the add-on in the light's extras:
        // `prism_angle` (a directional light's angular diameter, Blender's sun angle, radians),
        // `prism_radius` (a point or spot light's radius, metres), `prism_soft_falloff`
        // (Blender's Soft Falloff, default true), `prism_visible_camera` (default false) and
        // `prism_spot_cosine` (a Blender 3.x spot, whose intensity also falls off with the
        // cosine to its axis), `prism_visible_diffuse` / `_glossy` / `_transmission` (Blender's
        // light Ray Visibility, default true).
        let extras = light
            .extras()
            .as_ref()
            .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok());
        let extra = |key: &str| extras.as_ref().and_then(|v| v.get(key));
        let number = |key: &str, max: f64, what: &str| -> Result<f32, String> {
            match extra(key) {
                None => Ok(0.0),
                Some(v) => match v.as_f64() {
                    Some(a) if a.is_finite() && (0.0..=max).contains(&a) => Ok(a as f32),
                    _ => Err(format!("{label}: extras.{key} must be {what}, got {v}")),
                },
            }
        };
        let flag = |key: &str, default: bool| -> Result<bool, String> {
            match extra(key) {
                None => Ok(default),
                Some(v) => v
                    .as_bool()
                    .ok_or_else(|| format!("{label}: extras.{key} must be true or false, got {v}")),
            }
        };
        let angle = number(
            "prism_angle",
            std::f64::consts::PI,
            "a number of radians from 0 to pi",
        )?;
        let radius = number("prism_radius", f64::from(f32::MAX), "a distance >= 0")?;
        let soft_falloff = flag("prism_soft_falloff", true)?;
        let visible_camera = flag("prism_visible_camera", false)?;
        let spot_cosine = flag("prism_spot_cosine", false)?;
        let ray_visibility = RayVisibility {
            diffuse: flag("prism_visible_diffuse", true)?,
            glossy: flag("prism_visible_glossy", true)?,
            transmission: flag("prism_visible_transmission", true)?,
            volume: flag("prism_visible_volume_scatter", true)?,
        };
        let directional = kind == PunctualKind::Directional;
        self.scene.lights.push(PunctualLightDesc {
            name,
            kind,
            color,
            intensity: gltf_light_intensity_to_prism(intensity),
            position,
            direction,
            angle: if directional { angle } else { 0.0 },
            radius: if directional { 0.0 } else { radius },
            soft_falloff,
            visible_camera,
            spot_cosine,
            ray_visibility,
        });
        Ok(())
    }

    // ---------------------------------------------------------------- camera

    /// The camera to render through, and warnings about it.
    fn pick_camera(&self, camera_name: Option<&str>) -> Result<(CameraDesc, Vec<String>), String> {
        let mut warnings = Vec::new();
        let cand = match camera_name {
            None => &self.cameras[0],
            Some(want) => self
                .cameras
                .iter()
                .find(|c| {
                    c.node_name.as_deref() == Some(want) || c.camera_name.as_deref() == Some(want)
                })
                .ok_or_else(|| {
                    let names: Vec<String> = self
                        .cameras
                        .iter()
                        .map(|c| match (&c.node_name, &c.camera_name) {
                            (Some(n), Some(cn)) if n != cn => format!("'{n}' (camera '{cn}')"),
                            (Some(n), _) => format!("'{n}'"),
                            (None, Some(cn)) => format!("'{cn}'"),
                            (None, None) => format!("unnamed camera {}", c.camera_index),
                        })
                        .collect();
                    format!(
                        "no camera named '{want}' (cameras in the scene: {})",
                        names.join(", ")
                    )
                })?,
        };
        let cam = self
            .doc
            .cameras()
            .nth(cand.camera_index)
            .ok_or_else(|| format!("camera {} does not exist", cand.camera_index))?;
        {
            use gltf::json::camera::Type;
            use gltf::json::validation::Checked;
            let json = &self.doc.as_json().cameras[cand.camera_index];
            let path = format!("cameras[{}]", cand.camera_index);
            match json.type_ {
                Checked::Invalid => {
                    return Err(format!(
                        "{path}.type: must be \"perspective\" or \"orthographic\""
                    ))
                }
                Checked::Valid(Type::Perspective) if json.perspective.is_none() => {
                    return Err(format!("{path}: type perspective without 'perspective'"))
                }
                Checked::Valid(Type::Orthographic) if json.orthographic.is_none() => {
                    return Err(format!("{path}: type orthographic without 'orthographic'"))
                }
                Checked::Valid(_) => {}
            }
        }
        let name = cand
            .node_name
            .clone()
            .or_else(|| cand.camera_name.clone())
            .unwrap_or_else(|| format!("camera {}", cand.camera_index));
        let (yfov, aspect, orthographic) = match cam.projection() {
            gltf::camera::Projection::Orthographic(o) => {
                // The view's width follows from the image's aspect (xmag is not used); a
                // negative magnification (allowed, "SHOULD NOT") would mirror the view.
                let (x, y) = (o.xmag(), o.ymag());
                if !(y.is_finite() && y != 0.0) {
                    return Err(format!(
                        "camera '{name}': orthographic ymag must be a non-zero number, got {y}"
                    ));
                }
                if x < 0.0 || y < 0.0 {
                    warnings.push(format!(
                        "camera '{name}': negative orthographic xmag/ymag would mirror the view; rendered unmirrored"
                    ));
                }
                let x = if x.is_finite() && x != 0.0 {
                    x.abs()
                } else {
                    y.abs()
                };
                (0.0, None, Some(Vec2::new(x, y.abs())))
            }
            gltf::camera::Projection::Perspective(p) => (p.yfov(), p.aspect_ratio(), None),
        };
        if orthographic.is_none() && !(yfov.is_finite() && yfov > 0.0) {
            return Err(format!(
                "camera '{name}': yfov must be a positive number of radians, got {yfov}"
            ));
        }
        // yfov >= pi is valid glTF (the validator warns) but no pinhole image: the widest a
        // perspective projection can show is just under pi.
        let max_fov = std::f32::consts::PI * 0.999;
        let yfov = if orthographic.is_none() && yfov > max_fov {
            warnings.push(format!(
                "camera '{name}': yfov {yfov} rad is not below pi; rendered with {max_fov} rad"
            ));
            max_fov
        } else {
            yfov
        };
        if let Some(a) = aspect {
            if !(a.is_finite() && a > 0.0) {
                return Err(format!(
                    "camera '{name}': aspectRatio must be positive, got {a}"
                ));
            }
        }
        // Remove scale from the camera frame (glTF cameras ignore it); keep the position.
        let camera_to_world = Self::camera_frame(cand.world, &name)?;
        let motion = cand
            .motion
            .iter()
            .map(|&w| Self::camera_frame(w, &name))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((
            CameraDesc {
                name,
                camera_to_world,
                yfov,
                aspect,
                orthographic,
                motion,
                ..Default::default()
            },
            warnings,
        ))
    }

    /// A camera node's world transform without its scale (glTF cameras ignore it).
    fn camera_frame(w: Mat4, name: &str) -> Result<Mat4, String> {
        let axes = [
            w.x_axis.truncate(),
            w.y_axis.truncate(),
            w.z_axis.truncate(),
        ];
        if axes.iter().any(|a| a.length_squared() <= 0.0) {
            return Err(format!(
                "camera '{name}': its node transform is degenerate (zero scale)"
            ));
        }
        let camera_to_world = Mat4::from_cols(
            axes[0].normalize().extend(0.0),
            axes[1].normalize().extend(0.0),
            axes[2].normalize().extend(0.0),
            w.w_axis,
        );
        Ok(camera_to_world)
    }

    // ---------------------------------------------------------------- accessors

    /// The bytes of buffer view `index`, its buffer read on first use; `user` names the JSON
    /// path that refers to the view.
    fn view_bytes(&self, index: usize, user: &str) -> Result<&[u8], String> {
        let json = self.doc.as_json();
        let view = json
            .buffer_views
            .get(index)
            .ok_or_else(|| out_of_range(user, index, json.buffer_views.len(), "buffer views"))?;
        let bi = view.buffer.value();
        let Some(cell) = self.buffers.get(bi) else {
            return Err(out_of_range(
                &format!("bufferViews[{index}].buffer"),
                bi,
                self.buffers.len(),
                "buffers",
            ));
        };
        let loaded = cell.get_or_init(|| load_buffer(&json.buffers[bi], bi, self.bin, &self.dir));
        let buf = match loaded {
            Ok(b) => b,
            Err(e) => {
                let meshopt = view
                    .extensions
                    .as_ref()
                    .is_some_and(|x| x.others.contains_key("EXT_meshopt_compression"));
                return Err(if meshopt {
                    format!("bufferViews[{index}]: its data is EXT_meshopt_compression-compressed, which is not supported ({e})")
                } else {
                    e.clone()
                });
            }
        };
        let start = view.byte_offset.map_or(0, |o| o.0) as usize;
        let length = view.byte_length.0 as usize;
        match start.checked_add(length).and_then(|e| buf.get(start..e)) {
            Some(b) => Ok(b),
            None => Err(format!(
                "bufferViews[{index}]: bytes {start}..{} are outside buffer {bi} ({} bytes)",
                start as u128 + length as u128,
                buf.len()
            )),
        }
    }

    /// Reads an accessor as `count * dims` f64 components (normalised integers mapped to [0,1] /
    /// [-1,1]), including sparse substitution, with every range checked.
    /// An attribute accessor's components as f32 (floats as stored; integer types converted,
    /// normalised per the spec when `normalized` is set), `want.multiplicity()` per element.
    /// TEXCOORD_`set` (non-finite UVs become (0, 0), as for TEXCOORD_0).
    fn read_uv_set(
        &self,
        acc: &gltf::Accessor,
        name: &str,
        set: u32,
        n: usize,
    ) -> Result<Vec<Vec2>, String> {
        let what = format!("{name} TEXCOORD_{set}");
        let v = self.read_floats(acc, Dimensions::Vec2, &what)?;
        if v.len() / 2 != n {
            return Err(format!(
                "{what} has {} elements but POSITION has {n}",
                v.len() / 2
            ));
        }
        Ok(v.chunks_exact(2)
            .map(|c| Vec2::new(c[0], c[1]))
            .map(|uv| if uv.is_finite() { uv } else { Vec2::ZERO })
            .collect())
    }

    /// COLOR_`set`: linear RGB or RGBA (float or normalised integers, glTF 2.0 spec 3.7.2.1);
    /// RGB gets alpha 1, non-finite values become white.
    fn read_color_set(
        &self,
        acc: &gltf::Accessor,
        name: &str,
        set: u32,
        n: usize,
    ) -> Result<Vec<Vec4>, String> {
        let what = format!("{name} COLOR_{set}");
        let dims = acc.dimensions();
        let k = match dims {
            Dimensions::Vec3 => 3,
            Dimensions::Vec4 => 4,
            other => return Err(format!("{what}: must be VEC3 or VEC4, found {other:?}")),
        };
        let v = self.read_floats(acc, dims, &what)?;
        if v.len() / k != n {
            return Err(format!(
                "{what} has {} elements but POSITION has {n}",
                v.len() / k
            ));
        }
        Ok(v.chunks_exact(k)
            .map(|c| Vec4::new(c[0], c[1], c[2], if k == 4 { c[3] } else { 1.0 }))
            .map(|c| if c.is_finite() { c } else { Vec4::ONE })
            .collect())
    }

    fn read_floats(
        &self,
        acc: &gltf::Accessor,
        want: Dimensions,
        what: &str,
    ) -> Result<Vec<f32>, String> {
        let (dt, normalized) = (acc.data_type(), acc.normalized());
        if dt == DataType::F32 {
            // The common case (positions, normals, UVs): no per-component type dispatch.
            self.read_accessor(acc, want, what, |b| {
                f32::from_le_bytes([b[0], b[1], b[2], b[3]])
            })
        } else {
            self.read_accessor(acc, want, what, |b| {
                read_component(b, dt, normalized) as f32
            })
        }
    }

    /// An index accessor (unsigned integer scalars; the caller checks the type).
    fn read_indices(&self, acc: &gltf::Accessor, what: &str) -> Result<Vec<u32>, String> {
        match acc.data_type() {
            DataType::U32 => self.read_accessor(acc, Dimensions::Scalar, what, |b| {
                u32::from_le_bytes([b[0], b[1], b[2], b[3]])
            }),
            DataType::U16 => self.read_accessor(acc, Dimensions::Scalar, what, |b| {
                u16::from_le_bytes([b[0], b[1]]) as u32
            }),
            _ => self.read_accessor(acc, Dimensions::Scalar, what, |b| b[0] as u32),
        }
    }

    /// Reads an accessor (buffer view and sparse substitution, every bound checked) into
    /// components of type `T`; `component` converts one stored component's bytes. Generic so
    /// each caller gets a loop specialised to its stored type: meshes are the largest input.
    fn read_accessor<T: Copy + Default>(
        &self,
        acc: &gltf::Accessor,
        want: Dimensions,
        what: &str,
        component: impl Fn(&[u8]) -> T,
    ) -> Result<Vec<T>, String> {
        let label = format!("accessors[{}] ({what})", acc.index());
        if acc.dimensions() != want {
            return Err(format!(
                "{label}: expected type {want:?}, found {:?}",
                acc.dimensions()
            ));
        }
        let ncomp = want.multiplicity();
        let dt = acc.data_type();
        let cs = dt.size();
        let elem = cs * ncomp;
        let count = acc.count();
        let read = component;
        let json = &self.doc.as_json().accessors[acc.index()];
        let path = format!("accessors[{}]", acc.index());
        let offset = json.byte_offset.map_or(0, |o| o.0) as usize;
        let mut out: Vec<T>;
        match json.buffer_view {
            Some(view) => {
                let vi = view.value();
                let bytes = self.view_bytes(vi, &format!("{path}.bufferView"))?;
                let stride = self.doc.as_json().buffer_views[vi]
                    .byte_stride
                    .map_or(elem, |s| s.0);
                if stride < elem {
                    return Err(format!(
                        "{label}: byteStride {stride} is smaller than the element size {elem}"
                    ));
                }
                if count > 0 {
                    let need = (count as u128 - 1) * stride as u128 + elem as u128 + offset as u128;
                    if need > bytes.len() as u128 {
                        return Err(format!(
                            "{label}: needs {need} bytes of buffer view {vi}, which has {}",
                            bytes.len()
                        ));
                    }
                }
                let data = &bytes[offset.min(bytes.len())..];
                // Bounds were checked above.
                if stride == elem {
                    // Tightly packed: one pass over all components.
                    out = data[..count * elem].chunks_exact(cs).map(&read).collect();
                } else {
                    out = Vec::with_capacity(count * ncomp);
                    for i in 0..count {
                        let element = &data[i * stride..i * stride + elem];
                        out.extend(element.chunks_exact(cs).map(&read));
                    }
                }
            }
            None => {
                // No buffer view: all zeros (glTF 2.0 spec 3.6.2.3), then the sparse values.
                if count > MAX_ZERO_ACCESSOR_ELEMENTS {
                    return Err(format!(
                        "{label}: count {count} without a bufferView is larger than the {MAX_ZERO_ACCESSOR_ELEMENTS} supported"
                    ));
                }
                out = vec![T::default(); count * ncomp];
            }
        }
        if let Some(sp) = json.sparse.as_ref() {
            let n = sp.count.0 as usize;
            // Checked in `accessor`.
            let isize = match sp.indices.component_type {
                gltf::json::validation::Checked::Valid(t) => t.0.size(),
                gltf::json::validation::Checked::Invalid => 4,
            };
            let (ioff, voff) = (
                sp.indices.byte_offset.0 as usize,
                sp.values.byte_offset.0 as usize,
            );
            let ibytes = self.view_bytes(
                sp.indices.buffer_view.value(),
                &format!("{path}.sparse.indices.bufferView"),
            )?;
            let ineed = ioff as u128 + n as u128 * isize as u128;
            if ineed > ibytes.len() as u128 {
                return Err(format!(
                    "{label}: sparse indices need {ineed} bytes, buffer view has {}",
                    ibytes.len()
                ));
            }
            let vbytes = self.view_bytes(
                sp.values.buffer_view.value(),
                &format!("{path}.sparse.values.bufferView"),
            )?;
            let vneed = voff as u128 + n as u128 * elem as u128;
            if vneed > vbytes.len() as u128 {
                return Err(format!(
                    "{label}: sparse values need {vneed} bytes, buffer view has {}",
                    vbytes.len()
                ));
            }
            for k in 0..n {
                let io = ioff + k * isize;
                let target = match isize {
                    1 => ibytes[io] as usize,
                    2 => u16::from_le_bytes([ibytes[io], ibytes[io + 1]]) as usize,
                    _ => u32::from_le_bytes([
                        ibytes[io],
                        ibytes[io + 1],
                        ibytes[io + 2],
                        ibytes[io + 3],
                    ]) as usize,
                };
                if target >= count {
                    return Err(format!(
                        "{label}: sparse index {target} out of range (count {count})"
                    ));
                }
                for c in 0..ncomp {
                    let o = voff + k * elem + c * cs;
                    out[target * ncomp + c] = read(&vbytes[o..o + cs]);
                }
            }
        }
        Ok(out)
    }

    /// Accessor `index`, referred to from `user` (a JSON path), with the enumerations its
    /// readers rely on checked: the crate's accessors unwrap them.
    fn accessor(&self, index: usize, user: &str) -> Result<gltf::Accessor<'d>, String> {
        use gltf::json::validation::Checked;
        let all = &self.doc.as_json().accessors;
        let json = all
            .get(index)
            .ok_or_else(|| out_of_range(user, index, all.len(), "accessors"))?;
        let path = format!("accessors[{index}]");
        if matches!(json.component_type, Checked::Invalid) {
            return Err(format!("{path}.componentType: not a glTF component type"));
        }
        if json.type_ == Checked::Invalid {
            return Err(format!("{path}.type: not a glTF accessor type"));
        }
        if let Some(sp) = json.sparse.as_ref() {
            if matches!(sp.indices.component_type, Checked::Invalid) {
                return Err(format!(
                    "{path}.sparse.indices.componentType: must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT"
                ));
            }
        }
        Ok(self.doc.accessors().nth(index).expect("index checked"))
    }

    /// The accessor of attribute `semantic` of primitive `prim` of mesh `mesh`, checked.
    fn attribute(
        &self,
        mesh: usize,
        prim: usize,
        semantic: Semantic,
    ) -> Result<Option<gltf::Accessor<'d>>, String> {
        let json = &self.doc.as_json().meshes[mesh].primitives[prim];
        let name = semantic.to_string();
        match json
            .attributes
            .get(&gltf::json::validation::Checked::Valid(semantic))
        {
            None => Ok(None),
            Some(i) => self
                .accessor(
                    i.value(),
                    &format!("meshes[{mesh}].primitives[{prim}].attributes.{name}"),
                )
                .map(Some),
        }
    }

    fn read_vec3(&self, acc: &gltf::Accessor, what: &str) -> Result<Vec<Vec3>, String> {
        let v = self.read_floats(acc, Dimensions::Vec3, what)?;
        Ok(v.chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect())
    }

    // ---------------------------------------------------------------- meshes

    fn mesh_for(
        &mut self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        weights: &[f32],
    ) -> Result<Option<usize>, String> {
        let has_targets = self.doc.as_json().meshes[mesh.index()].primitives[prim.index()]
            .targets
            .as_ref()
            .is_some_and(|t| !t.is_empty());
        // Without targets the weights change nothing: one mesh for every node.
        let weight_bits = if has_targets {
            weights.iter().map(|w| w.to_bits()).collect()
        } else {
            Vec::new()
        };
        let key = (mesh.index(), prim.index(), weight_bits);
        if let Some(&m) = self.mesh_cache.get(&key) {
            return Ok(m);
        }
        let result = match self.load_primitive(mesh, prim, weights)? {
            Some(desc) => {
                self.scene.meshes.push(desc);
                Some(self.scene.meshes.len() - 1)
            }
            None => None,
        };
        self.mesh_cache.insert(key, result);
        Ok(result)
    }

    fn load_primitive(
        &mut self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        weights: &[f32],
    ) -> Result<Option<MeshDesc>, String> {
        let mesh_name = mesh
            .name()
            .map(|n| format!("mesh '{n}'"))
            .unwrap_or_else(|| format!("mesh {}", mesh.index()));
        let name = format!("{mesh_name} primitive {}", prim.index());
        let (mi, pi) = (mesh.index(), prim.index());
        let path = format!("meshes[{mi}].primitives[{pi}]");
        let json = &self.doc.as_json().meshes[mi].primitives[pi];
        if json.mode == gltf::json::validation::Checked::Invalid {
            return Err(format!("{path}.mode: not a glTF primitive mode"));
        }
        if let Some(ext) = json.extensions.as_ref().and_then(|e| {
            GEOMETRY_COMPRESSION
                .iter()
                .find(|x| e.others.contains_key(**x))
        }) {
            // Without the extension required, the accessors may carry uncompressed fallback
            // data (Draco: KHR_draco_mesh_compression README, "Conformance").
            let fallback = json
                .attributes
                .get(&gltf::json::validation::Checked::Valid(Semantic::Positions))
                .and_then(|a| self.doc.as_json().accessors.get(a.value()))
                .is_some_and(|a| a.buffer_view.is_some());
            if !fallback {
                return Err(format!(
                    "{path}: its geometry is {ext}-compressed, which is not supported"
                ));
            }
            self.warn_once(format!(
                "{ext} is not supported: its primitives are read from their uncompressed fallback data"
            ));
        }
        let mode = prim.mode();
        if matches!(
            mode,
            Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
        ) {
            self.skipped_non_triangle += 1;
            return Ok(None);
        }
        let Some(pos_acc) = self.attribute(mi, pi, Semantic::Positions)? else {
            // glTF 2.0 spec 3.7.2.1: "When positions are not specified, client
            // implementations SHOULD skip primitive's rendering".
            self.warn_once(format!("{name}: no POSITION attribute; not rendered"));
            return Ok(None);
        };
        let mut positions = self.read_vec3(&pos_acc, &format!("{name} POSITION"))?;
        let n = positions.len();
        let mut normals = match self.attribute(mi, pi, Semantic::Normals)? {
            Some(a) => {
                let v = self.read_vec3(&a, &format!("{name} NORMAL"))?;
                if v.len() != n {
                    return Err(format!(
                        "{name}: NORMAL has {} elements but POSITION has {n}",
                        v.len()
                    ));
                }
                Some(v)
            }
            None => None,
        };
        let uvs = match self.attribute(mi, pi, Semantic::TexCoords(0))? {
            Some(a) => {
                let v = self.read_floats(&a, Dimensions::Vec2, &format!("{name} TEXCOORD_0"))?;
                if v.len() / 2 != n {
                    return Err(format!(
                        "{name}: TEXCOORD_0 has {} elements but POSITION has {n}",
                        v.len() / 2
                    ));
                }
                Some(
                    v.chunks_exact(2)
                        .map(|c| {
                            let uv = Vec2::new(c[0], c[1]);
                            if uv.is_finite() {
                                uv
                            } else {
                                Vec2::ZERO
                            }
                        })
                        .collect::<Vec<_>>(),
                )
            }
            None => None,
        };
        let deformation = self.deformation_keys(mesh, mi, pi, &positions, normals.as_deref())?;
        if deformation.is_none() {
            self.apply_morph_targets(mi, pi, weights, &mut positions, normals.as_mut())?;
        }
        let tangents = self.load_tangents(mi, prim, &name, n, normals.is_some())?;
        let mut extra_uvs = Vec::new();
        for set in 1..crate::shading::MAX_ATTRIBUTE_SETS as u32 {
            extra_uvs.push(match self.attribute(mi, pi, Semantic::TexCoords(set))? {
                Some(a) => Some(self.read_uv_set(&a, &name, set, n)?),
                None => None,
            });
        }
        let mut colors = Vec::new();
        for set in 0..crate::shading::MAX_ATTRIBUTE_SETS as u32 {
            colors.push(match self.attribute(mi, pi, Semantic::Colors(set))? {
                Some(a) => Some(self.read_color_set(&a, &name, set, n)?),
                None => None,
            });
        }
        let indices = match json.indices {
            Some(i) => Some(self.accessor(i.value(), &format!("{path}.indices"))?),
            None => None,
        };
        let raw_indices: Vec<u32> = match indices {
            Some(a) => {
                if !matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32) {
                    return Err(format!(
                        "{name}: indices must be unsigned integers, found {:?}",
                        a.data_type()
                    ));
                }
                if a.normalized() {
                    return Err(format!("{name}: indices must not be normalized"));
                }
                self.read_indices(&a, &format!("{name} indices"))?
            }
            None => {
                if n > u32::MAX as usize {
                    return Err(format!("{name}: too many vertices"));
                }
                (0..n as u32).collect()
            }
        };
        if let Some(&bad) = raw_indices.iter().find(|&&i| i as usize >= n) {
            return Err(format!(
                "{name}: vertex index {bad} out of range ({n} vertices)"
            ));
        }
        let tris = triangulate(mode, &raw_indices).map_err(|e| format!("{name}: {e}"))?;

        // Drop degenerate triangles (zero area, non-finite positions).
        let kept: Vec<[u32; 3]> = tris
            .into_par_iter()
            .filter(|t| {
                let (a, b, c) = (
                    positions[t[0] as usize],
                    positions[t[1] as usize],
                    positions[t[2] as usize],
                );
                let cr = (b - a).cross(c - a);
                a.is_finite()
                    && b.is_finite()
                    && c.is_finite()
                    && cr.is_finite()
                    && cr.length_squared() > 0.0
            })
            .collect();
        if kept.is_empty() {
            return Ok(None);
        }
        let material = match json.material {
            None => None,
            Some(m) => {
                let m = m.value();
                match self.material_errors.get(m) {
                    None => {
                        return Err(out_of_range(
                            &format!("{path}.material"),
                            m,
                            self.material_errors.len(),
                            "materials",
                        ))
                    }
                    Some(Some(e)) => return Err(e.clone()),
                    Some(None) => Some(m),
                }
            }
        };
        let mut desc = compact(name, positions, normals, uvs, tangents, &kept);
        let order = compact_order(desc.positions.len(), &kept, n);
        desc.extra_uvs = extra_uvs
            .into_iter()
            .map(|u| u.map(|u| pick(order.as_deref(), u)))
            .collect();
        desc.colors = colors
            .into_iter()
            .map(|c| c.map(|c| pick(order.as_deref(), c)))
            .collect();
        desc.material = material;
        desc.deformation = deformation.map(|d| DeformationDesc {
            positions: d
                .positions
                .into_iter()
                .map(|p| pick(order.as_deref(), p))
                .collect(),
            normals: d.normals.map(|keys| {
                keys.into_iter()
                    .map(|n| pick(order.as_deref(), n))
                    .collect()
            }),
        });
        if let Some(normals) = desc.normals.as_mut() {
            fix_normals(normals, &desc.positions, &desc.indices);
        }
        Ok(Some(desc))
    }

    /// A deforming mesh's vertices over the shutter: with `extras.prism_deformation: true` on
    /// the mesh (the Blender add-on writes it for armatures, shape keys and other deforming
    /// modifiers), its primitives' morph targets are not blend shapes but the displacements of
    /// POSITION (and NORMAL) at equally spaced times from shutter open to close (at least two).
    /// Other viewers see the base mesh (the current frame): the targets' weights are zero.
    fn deformation_keys(
        &self,
        mesh: &gltf::Mesh,
        mi: usize,
        pi: usize,
        base_positions: &[Vec3],
        base_normals: Option<&[Vec3]>,
    ) -> Result<Option<DeformationDesc>, String> {
        let flag = mesh
            .extras()
            .as_ref()
            .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
            .and_then(|v| v.get("prism_deformation").cloned());
        match flag {
            None | Some(serde_json::Value::Bool(false)) => return Ok(None),
            Some(serde_json::Value::Bool(true)) => {}
            Some(other) => {
                return Err(format!(
                    "meshes[{mi}]: extras.prism_deformation must be true or false, got {other}"
                ))
            }
        }
        let path = format!("meshes[{mi}].primitives[{pi}]");
        let json = &self.doc.as_json().meshes[mi].primitives[pi];
        let targets = json.targets.as_deref().unwrap_or(&[]);
        if targets.len() < 2 {
            return Err(format!(
                "{path}: extras.prism_deformation needs at least two morph targets (the shutter's keys), found {}",
                targets.len()
            ));
        }
        let n = base_positions.len();
        let read = |acc: gltf::json::Index<gltf::json::Accessor>,
                    what: String,
                    base: &[Vec3]|
         -> Result<Vec<Vec3>, String> {
            let a = self.accessor(acc.value(), &what)?;
            let d = self.read_vec3(&a, &what)?;
            if d.len() != n {
                return Err(format!("{what}: {} elements but POSITION has {n}", d.len()));
            }
            Ok(base.iter().zip(&d).map(|(b, dx)| *b + *dx).collect())
        };
        let mut positions = Vec::with_capacity(targets.len());
        for (k, t) in targets.iter().enumerate() {
            let Some(acc) = t.positions else {
                return Err(format!(
                    "{path}.targets[{k}]: a deformation key needs POSITION"
                ));
            };
            let keyed = read(acc, format!("{path}.targets[{k}].POSITION"), base_positions)?;
            if let Some(i) = keyed.iter().position(|p| !p.is_finite()) {
                return Err(format!(
                    "{path}.targets[{k}].POSITION: vertex {i} is not finite"
                ));
            }
            positions.push(keyed);
        }
        let normals = match base_normals {
            Some(base) if targets.iter().all(|t| t.normals.is_some()) => Some(
                targets
                    .iter()
                    .enumerate()
                    .map(|(k, t)| {
                        read(
                            t.normals.expect("checked"),
                            format!("{path}.targets[{k}].NORMAL"),
                            base,
                        )
                    })
                    .collect::<Result<Vec<_>, _>>()?,
            ),
            _ => None,
        };
        Ok(Some(DeformationDesc { positions, normals }))
    }

    /// Adds the weighted morph target displacements of POSITION and NORMAL (glTF 2.0 spec
    /// 3.7.2.2: attribute = base + sum_k weight_k target_k); normals are renormalised later.
    /// TANGENT displacements are not applied: the normal-map frame orthonormalises the
    /// tangent against the shading normal anyway (`Geometry::normal_map_frame`).
    fn apply_morph_targets(
        &self,
        mi: usize,
        pi: usize,
        weights: &[f32],
        positions: &mut [Vec3],
        mut normals: Option<&mut Vec<Vec3>>,
    ) -> Result<(), String> {
        let json = &self.doc.as_json().meshes[mi].primitives[pi];
        let Some(targets) = json.targets.as_ref() else {
            return Ok(());
        };
        let n = positions.len();
        for (k, target) in targets.iter().enumerate() {
            let w = weights.get(k).copied().unwrap_or(0.0);
            if w == 0.0 {
                continue;
            }
            if !w.is_finite() {
                return Err(format!(
                    "meshes[{mi}]: morph target weight {k} is not finite"
                ));
            }
            let path = format!("meshes[{mi}].primitives[{pi}].targets[{k}]");
            let add = |acc: Option<gltf::json::Index<gltf::json::Accessor>>,
                       what: &str,
                       dst: &mut [Vec3]|
             -> Result<(), String> {
                let Some(a) = acc else { return Ok(()) };
                let acc = self.accessor(a.value(), &format!("{path}.{what}"))?;
                let d = self.read_vec3(&acc, &format!("{path}.{what}"))?;
                if d.len() != n {
                    return Err(format!(
                        "{path}.{what}: {} elements but POSITION has {n}",
                        d.len()
                    ));
                }
                for (x, dx) in dst.iter_mut().zip(&d) {
                    *x += w * *dx;
                }
                Ok(())
            };
            add(target.positions, "POSITION", positions)?;
            if let Some(ns) = normals.as_deref_mut() {
                add(target.normals, "NORMAL", ns)?;
            }
        }
        Ok(())
    }

    /// The `TANGENT` attribute (glTF 2.0 spec 3.7.2.1: VEC4, xyz unit tangent, w = +-1
    /// bitangent sign). Unusable tangents are a warning, never fatal: a normal map then uses
    /// tangents derived from the UVs. Per the spec, tangents are ignored when the primitive has
    /// no normals ("client implementations MUST calculate flat normals and the provided
    /// tangents (if present) MUST be ignored").
    fn load_tangents(
        &mut self,
        prim_mesh: usize,
        prim: &gltf::Primitive,
        name: &str,
        n: usize,
        has_normals: bool,
    ) -> Result<Option<Vec<Vec4>>, String> {
        let Some(a) = self.attribute(prim_mesh, prim.index(), Semantic::Tangents)? else {
            return Ok(None);
        };
        if !has_normals {
            self.warn_once(format!(
                "{name}: TANGENT without NORMAL is ignored (glTF 2.0 spec 3.7.2.1)"
            ));
            return Ok(None);
        }
        if a.dimensions() != Dimensions::Vec4 {
            self.warn_once(format!(
                "{name}: TANGENT must be VEC4, found {:?}; ignored (tangents derived from UVs)",
                a.dimensions()
            ));
            return Ok(None);
        }
        if a.count() != n {
            self.warn_once(format!(
                "{name}: TANGENT has {} elements but POSITION has {n}; ignored (tangents derived from UVs)",
                a.count()
            ));
            return Ok(None);
        }
        let v = self.read_floats(&a, Dimensions::Vec4, &format!("{name} TANGENT"))?;
        let mut bad = 0usize;
        let tangents = v
            .chunks_exact(4)
            .map(|c| {
                let t = Vec3::new(c[0], c[1], c[2]);
                let w = c[3];
                let len = t.length();
                if t.is_finite() && w.is_finite() && len > 1e-12 && len.is_finite() {
                    // The spec asks for w = +-1; only its sign is meaningful.
                    (t / len).extend(if w < 0.0 { -1.0 } else { 1.0 })
                } else {
                    // Zero marks "no usable tangent": the renderer derives one from the UVs.
                    bad += 1;
                    Vec4::ZERO
                }
            })
            .collect::<Vec<_>>();
        if bad > 0 {
            self.warn_once(format!(
                "{name}: {bad} TANGENT value(s) are zero-length or not finite; tangents derived from UVs there"
            ));
        }
        Ok(Some(tangents))
    }

    // ---------------------------------------------------------------- materials

    /// Checks the references of material `i` that the importer follows through the crate's
    /// accessors, which do not check bounds: the texture slots it reads, and alphaMode.
    fn check_material_references(&self, i: usize) -> Result<(), String> {
        use gltf::json::validation::Checked;
        let json = self.doc.as_json();
        let m = &json.materials[i];
        let path = format!("materials[{i}]");
        if m.alpha_mode == Checked::Invalid {
            return Err(format!("{path}.alphaMode: must be OPAQUE, MASK or BLEND"));
        }
        let pbr = &m.pbr_metallic_roughness;
        let slots = [
            (
                "pbrMetallicRoughness.baseColorTexture",
                pbr.base_color_texture.as_ref().map(|t| t.index),
            ),
            (
                "pbrMetallicRoughness.metallicRoughnessTexture",
                pbr.metallic_roughness_texture.as_ref().map(|t| t.index),
            ),
            ("normalTexture", m.normal_texture.as_ref().map(|t| t.index)),
            (
                "emissiveTexture",
                m.emissive_texture.as_ref().map(|t| t.index),
            ),
        ];
        for (slot, index) in slots {
            if let Some(t) = index {
                if t.value() >= json.textures.len() {
                    return Err(out_of_range(
                        &format!("{path}.{slot}.index"),
                        t.value(),
                        json.textures.len(),
                        "textures",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Checks the texture's sampler reference and enumerations (the crate's accessors unwrap
    /// them).
    fn check_sampler(&self, texture: usize) -> Result<(), String> {
        use gltf::json::validation::Checked;
        let json = self.doc.as_json();
        let Some(si) = json.textures[texture].sampler else {
            return Ok(());
        };
        let path = format!("textures[{texture}].sampler");
        let sampler = json
            .samplers
            .get(si.value())
            .ok_or_else(|| out_of_range(&path, si.value(), json.samplers.len(), "samplers"))?;
        let sp = format!("samplers[{}]", si.value());
        if sampler.wrap_s == Checked::Invalid || sampler.wrap_t == Checked::Invalid {
            return Err(format!("{sp}: wrapS/wrapT must be 33071, 33648 or 10497"));
        }
        if sampler.mag_filter == Some(Checked::Invalid)
            || sampler.min_filter == Some(Checked::Invalid)
        {
            return Err(format!("{sp}: magFilter/minFilter is not a glTF filter"));
        }
        Ok(())
    }

    fn material(&mut self, m: &gltf::Material) -> Result<GltfMaterialDesc, String> {
        let name = m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| match m.index() {
                Some(i) => format!("material {i}"),
                None => "default material".into(),
            });
        let label = format!("material '{name}'");
        let check = |what: &str, xs: &[f32], min: f32| -> Result<(), String> {
            for &x in xs {
                if !x.is_finite() {
                    return Err(format!("{label}: {what} is not finite"));
                }
                if x < min {
                    return Err(format!("{label}: {what} must be >= {min}, got {x}"));
                }
            }
            Ok(())
        };
        let pbr = m.pbr_metallic_roughness();
        let base_color = pbr.base_color_factor();
        check("baseColorFactor", &base_color, 0.0)?;
        let metallic = pbr.metallic_factor();
        let roughness = pbr.roughness_factor();
        check("metallicFactor", &[metallic], 0.0)?;
        check("roughnessFactor", &[roughness], 0.0)?;
        let emissive_factor = m.emissive_factor();
        check("emissiveFactor", &emissive_factor, 0.0)?;
        let strength = m.emissive_strength().unwrap_or(1.0);
        check(
            "KHR_materials_emissive_strength.emissiveStrength",
            &[strength],
            0.0,
        )?;
        let (specular, specular_color) = match m.specular() {
            Some(s) => (s.specular_factor(), s.specular_color_factor()),
            None => (1.0, [1.0; 3]),
        };
        check("KHR_materials_specular.specularFactor", &[specular], 0.0)?;
        check(
            "KHR_materials_specular.specularColorFactor",
            &specular_color,
            0.0,
        )?;
        let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
        check(
            "KHR_materials_transmission.transmissionFactor",
            &[transmission],
            0.0,
        )?;
        let ior = m.ior().unwrap_or(1.5);
        // KHR_materials_ior allows 0 besides [1, inf): F0 = ((ior - 1) / (ior + 1))^2 = 1, the
        // limit of an infinitely dense dielectric (`GltfMaterialDesc::ior_model`).
        if !(ior.is_finite() && (ior >= 1.0 || ior == 0.0)) {
            return Err(format!(
                "{label}: KHR_materials_ior.ior must be 0 or at least 1, got {ior}"
            ));
        }
        let (attenuation_color, attenuation_distance) = match m.volume() {
            Some(v) => (v.attenuation_color(), v.attenuation_distance()),
            None => ([1.0; 3], f32::INFINITY),
        };
        check(
            "KHR_materials_volume.attenuationColor",
            &attenuation_color,
            0.0,
        )?;
        if attenuation_distance.is_nan() || attenuation_distance <= 0.0 {
            return Err(format!(
                "{label}: KHR_materials_volume.attenuationDistance must be positive, got {attenuation_distance}"
            ));
        }
        // KHR_materials_dispersion: dispersion = 20 / V_d with n_d = KHR_materials_ior; the
        // gltf crate does not parse it, so it is read from the raw extension object.
        let mut dispersion = 0.0f32;
        if let Some(d) = m
            .extensions()
            .and_then(|ext| ext.get("KHR_materials_dispersion"))
        {
            if let Some(v) = d.get("dispersion") {
                let x = v.as_f64().ok_or_else(|| {
                    format!(
                        "{label}: KHR_materials_dispersion.dispersion must be a number, got {v}"
                    )
                })?;
                // With ior = 0 (F0 = 1) nothing refracts: there is nothing to disperse.
                if !(x.is_finite() && x >= 0.0) {
                    return Err(format!(
                        "{label}: KHR_materials_dispersion.dispersion must be a non-negative number, got {x}"
                    ));
                }
                if ior != 0.0 {
                    match crate::spectrum::IorModel::from_gltf(ior, x as f32) {
                        Ok(_) => dispersion = x as f32,
                        // A valid pair the Abbe form cannot follow over the rendered range
                        // (n < 1 somewhere, for an IOR near 1): drawn without dispersion.
                        Err(e) => self.warn_once(format!(
                            "{label}: KHR_materials_dispersion ignored: {e} (with KHR_materials_ior.ior = {ior})"
                        )),
                    }
                }
            }
        }
        // KHR_materials_clearcoat (not parsed by the gltf crate): factor and roughness; the
        // add-on adds Blender's Coat IOR and Tint as material extras.
        let (mut coat, mut coat_roughness) = (0.0f32, 0.0f32);
        let mut coat_textures = false;
        let (mut coat_texture, mut coat_roughness_texture) = (None, None);
        let (mut coat_normal_texture, mut coat_normal_scale) = (None, 1.0f32);
        if let Some(c) = m
            .extensions()
            .and_then(|ext| ext.get("KHR_materials_clearcoat"))
        {
            let number = |key: &str, default: f32| -> Result<f32, String> {
                match c.get(key) {
                    None => Ok(default),
                    Some(v) => v
                        .as_f64()
                        .map(|x| x as f32)
                        .filter(|x| (0.0..=1.0).contains(x))
                        .ok_or_else(|| {
                            format!("{label}: KHR_materials_clearcoat.{key} must be a number in [0, 1], got {v}")
                        }),
                }
            };
            coat = number("clearcoatFactor", 0.0)?;
            coat_roughness = number("clearcoatRoughnessFactor", 0.0)?;
            if let Some(info) = c.get("clearcoatNormalTexture") {
                coat_normal_scale = match info.get("scale") {
                    None => 1.0,
                    Some(v) => v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                        format!("{label}: clearcoatNormalTexture.scale must be a number, got {v}")
                    })? as f32,
                };
                coat_normal_texture =
                    self.json_texture(info, ColorSpace::Linear, &label, "clearcoatNormalTexture")?;
                // Normal maps read TEXCOORD_0's tangent frame (as `normalTexture`).
                if coat_normal_texture.is_some_and(|t| t.tex_coord != 0) {
                    coat_normal_texture = None;
                    coat_textures = true;
                }
            }
            if let Some(info) = c.get("clearcoatTexture") {
                coat_texture =
                    self.json_texture(info, ColorSpace::Linear, &label, "clearcoatTexture")?;
            }
            if let Some(info) = c.get("clearcoatRoughnessTexture") {
                coat_roughness_texture = self.json_texture(
                    info,
                    ColorSpace::Linear,
                    &label,
                    "clearcoatRoughnessTexture",
                )?;
            }
        }
        // KHR_materials_sheen (not parsed by the gltf crate): colour and roughness factors.
        let (mut sheen_color, mut sheen_roughness) = (Vec3::ZERO, 0.0f32);
        let (mut sheen_color_texture, mut sheen_roughness_texture) = (None, None);
        if let Some(c) = m
            .extensions()
            .and_then(|ext| ext.get("KHR_materials_sheen"))
        {
            if let Some(v) = c.get("sheenColorFactor") {
                let rgb = v
                    .as_array()
                    .filter(|a| a.len() == 3)
                    .and_then(|a| {
                        a.iter()
                            .map(|x| x.as_f64().map(|x| x as f32).filter(|x| (0.0..=1.0).contains(x)))
                            .collect::<Option<Vec<f32>>>()
                    })
                    .ok_or_else(|| {
                        format!("{label}: KHR_materials_sheen.sheenColorFactor must be three numbers in [0, 1], got {v}")
                    })?;
                sheen_color = Vec3::new(rgb[0], rgb[1], rgb[2]);
            }
            if let Some(v) = c.get("sheenRoughnessFactor") {
                sheen_roughness = v
                    .as_f64()
                    .map(|x| x as f32)
                    .filter(|x| (0.0..=1.0).contains(x))
                    .ok_or_else(|| {
                        format!("{label}: KHR_materials_sheen.sheenRoughnessFactor must be a number in [0, 1], got {v}")
                    })?;
            }
            if let Some(info) = c.get("sheenColorTexture") {
                sheen_color_texture =
                    self.json_texture(info, ColorSpace::Srgb, &label, "sheenColorTexture")?;
            }
            if let Some(info) = c.get("sheenRoughnessTexture") {
                sheen_roughness_texture =
                    self.json_texture(info, ColorSpace::Linear, &label, "sheenRoughnessTexture")?;
            }
        }
        // KHR_materials_iridescence (not parsed by the gltf crate): a thin film whose thickness is
        // the maximum, or mix(minimum, maximum, G) of the thickness texture.
        let (mut iridescence, mut iridescence_ior, mut iridescence_thickness) =
            (0.0f32, 1.3f32, 400.0f32);
        let mut iridescence_thickness_min = 100.0f32;
        let (mut iridescence_texture, mut iridescence_thickness_texture) = (None, None);
        if let Some(c) = m
            .extensions()
            .and_then(|ext| ext.get("KHR_materials_iridescence"))
        {
            let number = |key: &str,
                          default: f32,
                          ok: &dyn Fn(f32) -> bool,
                          what: &str|
             -> Result<f32, String> {
                match c.get(key) {
                    None => Ok(default),
                    Some(v) => v
                        .as_f64()
                        .map(|x| x as f32)
                        .filter(|x| x.is_finite() && ok(*x))
                        .ok_or_else(|| {
                            format!(
                                "{label}: KHR_materials_iridescence.{key} must be {what}, got {v}"
                            )
                        }),
                }
            };
            iridescence = number(
                "iridescenceFactor",
                0.0,
                &|x| (0.0..=1.0).contains(&x),
                "a number in [0, 1]",
            )?;
            iridescence_ior = number("iridescenceIor", 1.3, &|x| x >= 1.0, "a number >= 1")?;
            iridescence_thickness = number(
                "iridescenceThicknessMaximum",
                400.0,
                &|x| x >= 0.0,
                "a non-negative number",
            )?;
            iridescence_thickness_min = number(
                "iridescenceThicknessMinimum",
                100.0,
                &|x| x >= 0.0,
                "a non-negative number",
            )?;
            if let Some(info) = c.get("iridescenceTexture") {
                iridescence_texture =
                    self.json_texture(info, ColorSpace::Linear, &label, "iridescenceTexture")?;
            }
            if let Some(info) = c.get("iridescenceThicknessTexture") {
                iridescence_thickness_texture = self.json_texture(
                    info,
                    ColorSpace::Linear,
                    &label,
                    "iridescenceThicknessTexture",
                )?;
            }
        }
        // Textures of KHR_materials_transmission and KHR_materials_specular. (A path tracer
        // measures the real distance through a volume: KHR_materials_volume's thickness and its
        // texture, a rasteriser's stand-in for it, are not needed.)
        let transmission_texture = match m.transmission().and_then(|t| t.transmission_texture()) {
            Some(info) => {
                self.texture_ref(&info, ColorSpace::Linear, &label, "transmissionTexture")?
            }
            None => None,
        };
        let (specular_texture, specular_color_texture) = match m.specular() {
            Some(sp) => (
                match sp.specular_texture() {
                    Some(info) => {
                        self.texture_ref(&info, ColorSpace::Linear, &label, "specularTexture")?
                    }
                    None => None,
                },
                match sp.specular_color_texture() {
                    Some(info) => {
                        self.texture_ref(&info, ColorSpace::Srgb, &label, "specularColorTexture")?
                    }
                    None => None,
                },
            ),
            None => (None, None),
        };
        let extras = m
            .extras()
            .as_ref()
            .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok());
        let coat_ior = extras
            .as_ref()
            .and_then(|e| e.get("prism_coat_ior")?.as_f64())
            .map_or(1.5, |x| x as f32);
        if !(coat_ior.is_finite() && coat_ior >= 1.0) {
            return Err(format!(
                "{label}: extras.prism_coat_ior must be a number >= 1, got {coat_ior}"
            ));
        }
        let coat_tint = match extras.as_ref().and_then(|e| e.get("prism_coat_tint")) {
            None => [1.0f32; 3],
            Some(v) => {
                let t: Option<Vec<f32>> = v.as_array().map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_f64().map(|x| x as f32))
                        .collect()
                });
                match t {
                    Some(t) if t.len() == 3 => [t[0], t[1], t[2]],
                    _ => {
                        return Err(format!(
                            "{label}: extras.prism_coat_tint must be an RGB array, got {v}"
                        ))
                    }
                }
            }
        };
        check("extras.prism_coat_tint", &coat_tint, 0.0)?;
        let coat_additive = match extras.as_ref().and_then(|e| e.get("prism_coat_additive")) {
            None => false,
            Some(v) => v.as_bool().ok_or_else(|| {
                format!("{label}: extras.prism_coat_additive must be true or false, got {v}")
            })?,
        };
        let emission_spread = extras
            .as_ref()
            .and_then(|e| e.get("prism_emission_spread")?.as_f64())
            .map_or(std::f32::consts::PI, |x| x as f32);
        if !(0.0..=std::f32::consts::PI).contains(&emission_spread) {
            return Err(format!(
                "{label}: extras.prism_emission_spread must be an angle from 0 to pi radians, got {emission_spread}"
            ));
        }
        // Inputs the renderer does not model yet: reported once, never fatal.
        let mut ignored: Vec<&str> = Vec::new();
        if coat_textures {
            ignored.push("clearcoatNormalTexture on a TEXCOORD set other than 0");
        }
        if !ignored.is_empty() {
            self.warn_once(format!(
                "{label}: {} not supported yet and ignored",
                ignored.join(", ")
            ));
        }
        let alpha_mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => crate::scene::desc::AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => crate::scene::desc::AlphaMode::Mask,
            gltf::material::AlphaMode::Blend => crate::scene::desc::AlphaMode::Blend,
        };
        let alpha_cutoff = m.alpha_cutoff().unwrap_or(0.5);
        let base_color_texture = match pbr.base_color_texture() {
            Some(t) => self.texture_ref(&t, ColorSpace::Srgb, &label, "baseColorTexture")?,
            None => None,
        };
        let metallic_roughness_texture = match pbr.metallic_roughness_texture() {
            Some(t) => {
                self.texture_ref(&t, ColorSpace::Linear, &label, "metallicRoughnessTexture")?
            }
            None => None,
        };
        let emissive_texture = match m.emissive_texture() {
            Some(t) => self.texture_ref(&t, ColorSpace::Srgb, &label, "emissiveTexture")?,
            None => None,
        };
        // normalTexture (glTF 2.0 spec 5.23): linear texels, XY scaled by `scale`. Its
        // KHR_texture_transform is not parsed by the gltf crate for this slot (it is a
        // normalTextureInfo, not a textureInfo), so it is read from the raw extension object.
        let (normal_texture, normal_scale) = match m.normal_texture() {
            Some(t) => {
                let slot = "normalTexture";
                let scale = t.scale();
                if !scale.is_finite() {
                    return Err(format!("{label}: {slot}.scale is not finite"));
                }
                let transform = match t.extension_value("KHR_texture_transform") {
                    Some(v) => Some(
                        parse_texture_transform(v)
                            .map_err(|e| format!("{label}: {slot}: KHR_texture_transform: {e}"))?,
                    ),
                    None => None,
                };
                let r = self.texture_slot(
                    t.texture(),
                    t.tex_coord(),
                    transform,
                    ColorSpace::Linear,
                    &label,
                    slot,
                )?;
                (r, scale)
            }
            None => (None, 1.0),
        };
        Ok(GltfMaterialDesc {
            name,
            base_color: Vec4::from_array(base_color),
            base_color_texture,
            metallic,
            roughness,
            metallic_roughness_texture,
            emissive: Vec3::from_array(emissive_factor) * strength,
            emissive_texture,
            normal_texture,
            normal_scale,
            specular,
            specular_color: Vec3::from_array(specular_color),
            transmission,
            ior,
            dispersion,
            attenuation_color: Vec3::from_array(attenuation_color),
            attenuation_distance,
            double_sided: m.double_sided(),
            coat,
            coat_roughness,
            coat_ior,
            coat_tint: Vec3::from_array(coat_tint),
            coat_additive,
            sheen_color,
            sheen_roughness,
            coat_texture,
            coat_roughness_texture,
            coat_normal_texture,
            coat_normal_scale,
            sheen_color_texture,
            sheen_roughness_texture,
            iridescence,
            iridescence_ior,
            iridescence_thickness,
            iridescence_thickness_min,
            iridescence_texture,
            iridescence_thickness_texture,
            transmission_texture,
            specular_texture,
            specular_color_texture,
            emission_spread,
            alpha_mode,
            alpha_cutoff: if alpha_cutoff.is_finite() {
                alpha_cutoff
            } else {
                0.5
            },
        })
    }

    fn texture_ref(
        &mut self,
        info: &gltf::texture::Info,
        space: ColorSpace,
        label: &str,
        slot: &str,
    ) -> Result<Option<TextureRef>, String> {
        let transform = info.texture_transform().map(|t| TextureTransform {
            offset: Vec2::from_array(t.offset()),
            rotation: t.rotation(),
            scale: Vec2::from_array(t.scale()),
            tex_coord: t.tex_coord(),
        });
        self.texture_slot(
            info.texture(),
            info.tex_coord(),
            transform,
            space,
            label,
            slot,
        )
    }

    /// A texture slot of a material: texture, TEXCOORD set and optional KHR_texture_transform.
    /// `None` (with a warning) when the texture has no image the renderer decodes: the slot's
    /// factor alone then applies, as in a viewer without the image's extension.
    /// A textureInfo the gltf crate leaves as JSON (inside KHR_materials_* objects): its index,
    /// texCoord and KHR_texture_transform.
    fn json_texture(
        &mut self,
        info: &serde_json::Value,
        space: ColorSpace,
        label: &str,
        slot: &str,
    ) -> Result<Option<TextureRef>, String> {
        let index =
            info.get("index").and_then(|v| v.as_u64()).ok_or_else(|| {
                format!("{label}: {slot}.index must be a texture index, got {info}")
            })? as usize;
        let n = self.doc.as_json().textures.len();
        let texture = self
            .doc
            .textures()
            .nth(index)
            .ok_or_else(|| out_of_range(&format!("{label}: {slot}"), index, n, "textures"))?;
        let tex_coord = match info.get("texCoord") {
            None => 0,
            Some(v) => v.as_u64().filter(|&t| t < 256).ok_or_else(|| {
                format!("{label}: {slot}.texCoord must be a TEXCOORD set number, got {v}")
            })? as u32,
        };
        let transform = match info
            .get("extensions")
            .and_then(|e| e.get("KHR_texture_transform"))
        {
            Some(v) => Some(
                parse_texture_transform(v)
                    .map_err(|e| format!("{label}: {slot}: KHR_texture_transform: {e}"))?,
            ),
            None => None,
        };
        self.texture_slot(texture, tex_coord, transform, space, label, slot)
    }

    fn texture_slot(
        &mut self,
        texture: gltf::Texture,
        tex_coord: u32,
        transform: Option<TextureTransform>,
        space: ColorSpace,
        label: &str,
        slot: &str,
    ) -> Result<Option<TextureRef>, String> {
        let ti = texture.index();
        let image = match &self.texture_sources[ti] {
            TextureSource::Image(i) => *i,
            TextureSource::Unsupported(why) => {
                let msg = format!(
                    "{label}: {slot}: texture {ti} is not used because {why}; the factor applies"
                );
                self.warn_once(msg);
                return Ok(None);
            }
        };
        let n_images = self.doc.as_json().images.len();
        if image >= n_images {
            return Err(out_of_range(
                &format!("textures[{ti}].source"),
                image,
                n_images,
                "images",
            ));
        }
        self.check_sampler(ti)?;
        let mut tex_coord = tex_coord;
        let mut uv_transform = Mat3::IDENTITY;
        if let Some(t) = transform {
            if let Some(tc) = t.tex_coord {
                tex_coord = tc;
            }
            let (o, r, s) = (t.offset, t.rotation, t.scale);
            if !finite_all(&[o.x, o.y, r, s.x, s.y]) {
                return Err(format!(
                    "{label}: {slot}: KHR_texture_transform has non-finite values"
                ));
            }
            uv_transform = texture_transform_matrix(o, r, s);
        }
        // Every slot but the normal maps reads its own set up to TEXCOORD_3 (its UV Map node,
        // `scene::gltf_graph`); normal maps take their tangent frame from TEXCOORD_0.
        let readable =
            slot != "normalTexture" && (tex_coord as usize) < crate::shading::MAX_ATTRIBUTE_SETS;
        if tex_coord != 0 && !readable {
            self.warn_once(format!(
                "{label}: {slot} uses TEXCOORD_{tex_coord}; TEXCOORD_0 is used instead"
            ));
        }
        let sampler = texture.sampler();
        let wrap = |w: gltf::texture::WrappingMode| -> Extension {
            match w {
                gltf::texture::WrappingMode::ClampToEdge => Extension::Extend,
                gltf::texture::WrappingMode::MirroredRepeat => Extension::Mirror,
                gltf::texture::WrappingMode::Repeat => Extension::Repeat,
            }
        };
        let bilinear = !matches!(
            sampler.mag_filter(),
            Some(gltf::texture::MagFilter::Nearest)
        );
        let key = (
            image,
            space == ColorSpace::Srgb,
            wrap(sampler.wrap_s()),
            wrap(sampler.wrap_t()),
            bilinear,
        );
        let index = match self.texture_cache.get(&key) {
            Some(&i) => i,
            None => {
                let decoded = self.image(image)?;
                let texels = to_linear_texels(decoded, space);
                let from_srgb_bytes = space == ColorSpace::Srgb && decoded.eight_bit;
                let (width, height) = (decoded.width, decoded.height);
                let img_json = &self.doc.as_json().images[image];
                let tname = img_json
                    .name
                    .clone()
                    .or_else(|| img_json.uri.clone().filter(|u| !u.starts_with("data:")))
                    .unwrap_or_else(|| format!("image {image}"));
                let mut desc =
                    TextureDesc::new(tname, width, height, texels, [key.2, key.3], bilinear);
                desc.from_srgb_bytes = from_srgb_bytes;
                self.scene.textures.push(desc);
                let i = self.scene.textures.len() - 1;
                self.texture_cache.insert(key, i);
                i
            }
        };
        Ok(Some(TextureRef {
            texture: index,
            tex_coord,
            uv_transform,
        }))
    }

    fn image(&mut self, index: usize) -> Result<&crate::scene::texture::DecodedImage, String> {
        if !self.image_cache.contains_key(&index) {
            let decoded = match self.decode_image_at(index)? {
                Ok(d) => d,
                Err(e) => {
                    // A missing or unreadable picture is an optional asset: Blender's magenta
                    // and a warning, not a failed render (Cycles does the same).
                    self.scene.warnings.push(format!("{e}; rendered magenta"));
                    crate::scene::texture::DecodedImage {
                        width: 1,
                        height: 1,
                        rgba: vec![[1.0, 0.0, 1.0, 1.0]],
                        eight_bit: false,
                    }
                }
            };
            self.image_cache.insert(index, decoded);
        }
        Ok(&self.image_cache[&index])
    }

    /// Decodes image `index`: the outer error is a broken file (an image whose buffer view
    /// does not exist), the inner one a picture that cannot be read or decoded.
    #[allow(clippy::type_complexity)]
    fn decode_image_at(
        &self,
        index: usize,
    ) -> Result<Result<crate::scene::texture::DecodedImage, String>, String> {
        let img = &self.doc.as_json().images[index];
        let mime = img.mime_type.as_ref().map(|m| m.0.clone());
        if let Some(view_idx) = img.buffer_view.as_ref() {
            let bytes =
                self.view_bytes(view_idx.value(), &format!("images[{index}].bufferView"))?;
            return Ok(
                decode_image(bytes, mime.as_deref()).map_err(|e| format!("image {index}: {e}"))
            );
        }
        let Some(uri) = img.uri.as_deref() else {
            return Err(format!("image {index}: has neither 'uri' nor 'bufferView'"));
        };
        if let Some(d) = parse_data_uri(uri) {
            return Ok(d.map_err(|e| format!("image {index}: {e}")).and_then(|d| {
                decode_image(&d.bytes, d.mime.as_deref().or(mime.as_deref()))
                    .map_err(|e| format!("image {index}: {e}"))
            }));
        }
        if is_remote(uri) {
            return Ok(Err(format!(
                "image {index}: unsupported remote URI '{uri}'"
            )));
        }
        let p = resolve_uri(&self.dir, uri);
        Ok(std::fs::read(&p)
            .map_err(|e| {
                format!(
                    "image {index}: cannot read '{uri}' ({}): {}",
                    p.display(),
                    io_msg(&e)
                )
            })
            .and_then(|bytes| {
                decode_image(&bytes, mime.as_deref())
                    .map_err(|e| format!("image {index} ('{uri}'): {e}"))
            }))
    }
}

fn read_component(b: &[u8], dt: DataType, normalized: bool) -> f64 {
    match dt {
        DataType::I8 => {
            let v = b[0] as i8 as f64;
            if normalized {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U8 => {
            let v = b[0] as f64;
            if normalized {
                v / 255.0
            } else {
                v
            }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([b[0], b[1]]) as f64;
            if normalized {
                v / 65535.0
            } else {
                v
            }
        }
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    }
}

/// Triangle list from the indices of a Triangles / TriangleStrip / TriangleFan primitive, using
/// the glTF spec's vertex orders (3.7.2.1): strip triangle i = (v_i, v_{i+1+i%2}, v_{i+2-i%2}),
/// fan triangle i = (v_{i+1}, v_{i+2}, v_0).
pub fn triangulate(mode: Mode, idx: &[u32]) -> Result<Vec<[u32; 3]>, String> {
    let mut out = Vec::new();
    match mode {
        Mode::Triangles => {
            if !idx.len().is_multiple_of(3) {
                return Err(format!(
                    "triangle list has {} indices, not a multiple of 3",
                    idx.len()
                ));
            }
            out.extend(idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        }
        Mode::TriangleStrip => {
            for i in 0..idx.len().saturating_sub(2) {
                let t = if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i], idx[i + 2], idx[i + 1]]
                };
                out.push(t);
            }
        }
        Mode::TriangleFan => {
            for i in 0..idx.len().saturating_sub(2) {
                out.push([idx[i + 1], idx[i + 2], idx[0]]);
            }
        }
        _ => {}
    }
    Ok(out)
}

/// Builds a mesh holding only the vertices the kept triangles use. When they use every
/// vertex in first-use order (what exporters write), the attribute arrays are moved, not
/// copied: a large mesh's arrays are tens of megabytes.
fn compact(
    name: String,
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    tangents: Option<Vec<Vec4>>,
    tris: &[[u32; 3]],
) -> MeshDesc {
    let mut remap = vec![u32::MAX; positions.len()];
    let mut order: Vec<u32> = Vec::new();
    let mut indices = Vec::with_capacity(tris.len() * 3);
    for t in tris {
        for &v in t {
            let r = &mut remap[v as usize];
            if *r == u32::MAX {
                *r = order.len() as u32;
                order.push(v);
            }
            indices.push(*r);
        }
    }
    let identity =
        order.len() == positions.len() && order.iter().enumerate().all(|(i, &v)| v as usize == i);
    if identity {
        return MeshDesc {
            name,
            positions,
            normals,
            uvs,
            tangents,
            indices,
            material: None,
            ..Default::default()
        };
    }
    fn pick<T: Copy>(order: &[u32], src: &[T]) -> Vec<T> {
        order.iter().map(|&v| src[v as usize]).collect()
    }
    MeshDesc {
        name,
        positions: pick(&order, &positions),
        normals: normals.map(|n| pick(&order, &n)),
        uvs: uvs.map(|u| pick(&order, &u)),
        tangents: tangents.map(|t| pick(&order, &t)),
        indices,
        material: None,
        ..Default::default()
    }
}

/// The vertex order `compact` produced for `tris` (`None`: unchanged, all `n` vertices kept
/// in order), to carry further per-vertex attributes along.
fn compact_order(kept_vertices: usize, tris: &[[u32; 3]], n: usize) -> Option<Vec<u32>> {
    let mut remap = vec![u32::MAX; n];
    let mut order: Vec<u32> = Vec::with_capacity(kept_vertices);
    for t in tris {
        for &v in t {
            if remap[v as usize] == u32::MAX {
                remap[v as usize] = order.len() as u32;
                order.push(v);
            }
        }
    }
    let identity = order.len() == n && order.iter().enumerate().all(|(i, &v)| v as usize == i);
    (!identity).then_some(order)
}

fn pick<T: Copy>(order: Option<&[u32]>, src: Vec<T>) -> Vec<T> {
    match order {
        None => src,
        Some(order) => order.iter().map(|&v| src[v as usize]).collect(),
    }
}

/// Normalises shading normals; a zero-length or non-finite normal is replaced by the
/// area-weighted average of the geometric normals of the triangles around the vertex.
fn fix_normals(normals: &mut [Vec3], positions: &[Vec3], indices: &[u32]) {
    let mut bad = false;
    for n in normals.iter_mut() {
        let l2 = n.length_squared();
        if n.is_finite() && l2 > 1e-30 && l2.is_finite() {
            *n /= l2.sqrt();
        } else {
            *n = Vec3::ZERO;
            bad = true;
        }
    }
    if !bad {
        return;
    }
    let mut acc = vec![Vec3::ZERO; normals.len()];
    let mut first = vec![Vec3::ZERO; normals.len()];
    for t in indices.chunks_exact(3) {
        let (a, b, c) = (
            positions[t[0] as usize],
            positions[t[1] as usize],
            positions[t[2] as usize],
        );
        let g = (b - a).cross(c - a);
        for &v in t {
            acc[v as usize] += g;
            if first[v as usize] == Vec3::ZERO {
                first[v as usize] = g.normalize_or_zero();
            }
        }
    }
    for (i, n) in normals.iter_mut().enumerate() {
        if *n == Vec3::ZERO {
            let a = acc[i].normalize_or_zero();
            *n = if a != Vec3::ZERO { a } else { first[i] };
            if *n == Vec3::ZERO {
                *n = Vec3::Z;
            }
        }
    }
}

/// A KHR_texture_transform extension object (glTF `KHR_texture_transform` spec; defaults
/// offset (0,0), rotation 0, scale (1,1), texCoord unchanged).
#[derive(Clone, Copy, Debug)]
struct TextureTransform {
    offset: Vec2,
    rotation: f32,
    scale: Vec2,
    tex_coord: Option<u32>,
}

/// Parses a raw KHR_texture_transform object (for texture slots the gltf crate leaves as JSON).
fn parse_texture_transform(v: &serde_json::Value) -> Result<TextureTransform, String> {
    let obj = v
        .as_object()
        .ok_or_else(|| format!("expected an object, got {v}"))?;
    let num = |key: &str, x: &serde_json::Value| -> Result<f32, String> {
        x.as_f64()
            .map(|f| f as f32)
            .ok_or_else(|| format!("{key} must be a number, got {x}"))
    };
    let pair = |key: &str, default: Vec2| -> Result<Vec2, String> {
        match obj.get(key) {
            None => Ok(default),
            Some(serde_json::Value::Array(a)) if a.len() == 2 => {
                Ok(Vec2::new(num(key, &a[0])?, num(key, &a[1])?))
            }
            Some(x) => Err(format!("{key} must be an array of 2 numbers, got {x}")),
        }
    };
    let rotation = match obj.get("rotation") {
        None => 0.0,
        Some(x) => num("rotation", x)?,
    };
    let tex_coord = match obj.get("texCoord") {
        None => None,
        Some(x) => Some(
            x.as_u64()
                .and_then(|t| u32::try_from(t).ok())
                .ok_or_else(|| format!("texCoord must be a non-negative integer, got {x}"))?,
        ),
    };
    Ok(TextureTransform {
        offset: pair("offset", Vec2::ZERO)?,
        rotation,
        scale: pair("scale", Vec2::ONE)?,
        tex_coord,
    })
}

/// KHR_texture_transform as a UV matrix: `T(offset) * R(rotation) * S(scale)`, with
/// `R` mapping (u, v) -> (u cos r + v sin r, -u sin r + v cos r) -- a counter-clockwise rotation
/// of the UVs in glTF's v-down texture space (consistent with the extension's worked example and
/// with Blender's importer, glTF-Blender-IO `texture_transform_gltf_to_blender`).
pub fn texture_transform_matrix(offset: Vec2, rotation: f32, scale: Vec2) -> Mat3 {
    let (s, c) = rotation.sin_cos();
    let r = Mat3::from_cols(Vec3::new(c, -s, 0.0), Vec3::new(s, c, 0.0), Vec3::Z);
    Mat3::from_translation(offset) * r * Mat3::from_scale(scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_units() {
        // A 1000 W Blender point light is exported as 1000 / (4 pi) * 683 cd.
        let cd = 1000.0 / (4.0 * std::f32::consts::PI) * 683.0;
        let i = gltf_light_intensity_to_prism(cd);
        assert!((i - 1000.0 / (4.0 * std::f32::consts::PI)).abs() < 1e-3);
        // A sun of strength 3 W/m^2 is exported as 3 * 683 lux.
        assert!((gltf_light_intensity_to_prism(3.0 * 683.0) - 3.0).abs() < 1e-5);
    }

    #[test]
    fn strips_and_fans() {
        let s = triangulate(Mode::TriangleStrip, &[0, 1, 2, 3, 4]).unwrap();
        assert_eq!(s, vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
        let f = triangulate(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap();
        assert_eq!(f, vec![[1, 2, 0], [2, 3, 0]]);
        assert!(triangulate(Mode::Triangles, &[0, 1]).is_err());
        assert!(triangulate(Mode::TriangleStrip, &[0, 1])
            .unwrap()
            .is_empty());
    }

    #[test]
    fn texture_transform_example_from_spec() {
        // "utilizes only the lower left quadrant of the source image, rotated clockwise 90 deg"
        let m = texture_transform_matrix(
            Vec2::new(0.0, 1.0),
            std::f32::consts::FRAC_PI_2,
            Vec2::splat(0.5),
        );
        let t = |u: f32, v: f32| {
            let p = m * Vec3::new(u, v, 1.0);
            Vec2::new(p.x, p.y)
        };
        for (uv, want) in [
            ((0.0, 0.0), (0.0, 1.0)),
            ((1.0, 0.0), (0.0, 0.5)),
            ((0.0, 1.0), (0.5, 1.0)),
            ((1.0, 1.0), (0.5, 0.5)),
        ] {
            let got = t(uv.0, uv.1);
            assert!(
                (got - Vec2::new(want.0, want.1)).length() < 1e-6,
                "{uv:?} -> {got:?}"
            );
        }
    }

    #[test]
    fn glb_container_checks() {
        assert!(split_glb(b"glTF").unwrap_err().contains("truncated"));
        let mut g = b"glTF".to_vec();
        g.extend(2u32.to_le_bytes());
        g.extend(100u32.to_le_bytes());
        g.extend([0u8; 20]);
        assert!(split_glb(&g).unwrap_err().contains("truncated GLB"));
        // A valid container: JSON chunk "{}  ".
        let mut g = b"glTF".to_vec();
        g.extend(2u32.to_le_bytes());
        g.extend(24u32.to_le_bytes());
        g.extend(4u32.to_le_bytes());
        g.extend(0x4E4F_534Au32.to_le_bytes());
        g.extend(b"{}  ");
        let (j, b) = split_glb(&g).unwrap();
        assert_eq!(j, b"{}  ");
        assert!(b.is_none());
    }
}
