//! The material JSON sidecar (`<scene>.materials.json`), schema version 1.
//!
//! ```json
//! { "version": 1,
//!   "materials": {
//!     "Marble":  { "subsurface": { "preset": "Marble", "scale": 1000.0, "eta": 1.33, "g": 0.0 } },
//!     "Skin":    { "subsurface": { "sigma_a": [0.032, 0.17, 0.48], "sigma_s": [0.74, 0.88, 1.01],
//!                                  "scale": 1000.0, "eta": 1.4 } },
//!     "Wax":     { "subsurface": { "reflectance": [0.8, 0.7, 0.6], "mfp": [0.01, 0.005, 0.0025],
//!                                  "eta": 1.33 } },
//!     "Diamond": { "dielectric": { "cauchy": { "a": 2.38, "b": 0.0117 }, "roughness": 0.0 } },
//!     "Lens":    { "dielectric": { "preset": "BK7" } },
//!     "Prism":   { "dielectric": { "abbe": { "ior": 1.7847, "abbe": 25.68 } } },
//!     "Quartz":  { "dielectric": { "sellmeier": { "b": [0.6961663, 0.4079426, 0.8974794],
//!                                                 "c": [0.00467914826, 0.0135120631, 97.9340025] } } },
//!     "Jade":    { "subsurface": { "preset": "Marble", "ior": { "abbe": { "ior": 1.66, "abbe": 40 } } } } },
//!   "world": { "color": [0.05, 0.05, 0.05], "strength": 1.0 },
//!   "camera": { "aperture_radius": 0.0125, "focus_distance": 4.0 },
//!   "render": { "spp": 64, "width": 512, "height": 512, "max_depth": 16,
//!               "wavelengths": "hero", "wavelength_pdf": "visible" } }
//! ```
//!
//! * `materials.<glTF material name>`: at most one of `subsurface` | `dielectric`, and/or a
//!   `graph` (a shading graph driving the material's inputs: `crate::shading::parse`), and/or
//!   `holdout` (true: Blender's Holdout shader; the surface is a transparent hole in the image
//!   and ends paths), and/or `volume` (a homogeneous participating medium inside the material's
//!   closed meshes, `crate::media`: `sigma_a`, `sigma_s` (absorption and scattering coefficients
//!   per scene unit) and `emission` (radiance emitted per unit length), non-negative linear RGB
//!   triples, default black; `g` the Henyey-Greenstein anisotropy in (-1, 1), default 0; paths
//!   enter it where they are transmitted through the surface), with `surface` `"none"` (the
//!   surface does not scatter: rays pass through it into and out of the volume, as Blender's
//!   material with only a Volume output) or `"shaded"` (the default). Example, Blender's
//!   Principled Volume at density 0.5: `"Fog": {"volume": {"sigma_s": [0.25, 0.25, 0.25],
//!   "sigma_a": [0.25, 0.25, 0.25]}, "surface": "none"}`. `model`: `"cycles"` (the default:
//!   energy-conserving layers and multiple-scattering GGX as Cycles' Principled BSDF, see
//!   `crate::bsdf::metallic_roughness`) | `"gltf"` (the glTF 2.0 spec's BRDF as written, single
//!   scattering, for glTF viewer conformance) | `"principled_v1"` (Blender 3.x's Principled BSDF
//!   as Cycles 3.x renders it: Burley's diffuse under an added single-scattering specular layer;
//!   the add-on writes it for 3.x Principled materials).
//! * `subsurface`: exactly one of `preset` | `sigma_a` + `sigma_s` | `reflectance` + `mfp` |
//!   `color` + `radius` (Blender's random walk: subsurface colour and radius per channel in
//!   scene units, `method` must be `"random_walk"`; optional `skin` (default false): Random Walk
//!   (Skin)'s radius adjustment; see `crate::bssrdf::media::cycles_walk`). A medium given by a
//!   colour (`reflectance` or `color`) takes the graph's `subsurface_color` where it is textured;
//!   optional `scale` (> 0, default 1), `eta` (> 0, default 1.33) or `ior` (a number >= 1 or an
//!   object with exactly one of the dielectric IOR forms below; the BSSRDF then uses its n_d as
//!   the scalar eta), `g` (in (-1,1), default 0), `roughness` (in [0,1], default 0), `method`
//!   (`"table"` default | `"random_walk"`), `boundary` (random walk only: `"dielectric"`
//!   default | `"lambertian"`, see `crate::bssrdf::WalkBoundary`), `weight` (in [0,1], default 1: the fraction of the
//!   surface that is subsurface, the rest being the glTF material; chosen per shading point).
//!   Coefficients are non-negative RGB triples, `mfp` positive, `reflectance` in [0,1].
//! * `dielectric`: exactly one IOR form (models in `crate::spectrum::dispersion`, lambda in
//!   micrometres): `ior` (number >= 1) | `cauchy` `{a > 0, b >= 0, c >= 0 (default 0)}` for
//!   n = a + b/λ² + c/λ⁴ | `sellmeier` `{"b": [..], "c": [..]}` (1 to 6 non-negative terms each,
//!   C_i in µm²) for n² = 1 + Σ B_i λ²/(λ² − C_i) | `abbe` `{"ior": n_d, "abbe": V_d > 0}` |
//!   `preset` (one of `GLASS_PRESETS`: BK7, fused_silica, F2, SF11, diamond, water; any case).
//!   Every model must give 1 <= n < ∞ over 360–830 nm (no Sellmeier pole in that range).
//!   `roughness` in [0,1], default 0.
//! * `world`: `color` (non-negative RGB, default black), `strength` (>= 0, default 1 when the
//!   block is present). Without a `world` block the world is black with strength 0.
//!   Optional `texture`: an equirectangular image (`.exr`, `.hdr` or `.png`; a path relative to
//!   the sidecar's folder, or absolute), in Blender's Environment Texture mapping (see
//!   `crate::lights::envmap`); the radiance is then texture x `color` x `strength`, `color`
//!   defaulting to white. `rotation_z` (radians, any finite number, needs `texture`): the Z
//!   rotation of a Blender Mapping node on the texture's vector. Example:
//!   `"world": {"texture": "sky.exr", "strength": 1.5, "rotation_z": 0.5}`.
//! * `camera`: settings of the rendered camera that glTF has no field for, all optional:
//!   - thin-lens depth of field (perspective or orthographic): `aperture_radius` (scene units,
//!     at least 0; 0 = pinhole) and `focus_distance` (scene units along the view axis,
//!     positive), both or neither. Without them the camera is a pinhole.
//!   - `shift`: [x, y], the view window moved by x and y times the view's height (Blender's
//!     lens shift, which the add-on converts from its fraction of the fitted dimension).
//!   - `projection`: `"equirectangular"` (`longitude` [min, max], positive to the right,
//!     default [-pi, pi]; `latitude` [min, max], positive up, default [-pi/2, pi/2]; radians),
//!     `"fisheye_equidistant"` (`fisheye_fov`: the angle across the ellipse inscribed in the
//!     image, radians, default pi) or `"fisheye_equisolid"` (`fisheye_lens` focal length and
//!     `sensor` [width, height] spanning the image, mm; `fisheye_fov` the image circle): Cycles'
//!     panoramic cameras, around the camera's view axis.
//! * `render`: `spp`, `width`, `height` (positive integers), `max_depth` (integer >= 0),
//!   `wavelengths` (`"hero"` | `"single"` | `"stratified"`), `wavelength_pdf` (`"visible"` |
//!   `"uniform"`), `sampler` (`"sobol"`, the default: Owen-scrambled Sobol with blue-noise
//!   pixel ordering | `"independent"`: independent random numbers, for comparisons),
//!   `light_sampler` (`"tree"`, the default: a light tree, the distant lights sampled besides
//!   its choice | `"tree-single"`: one light per shading point | `"power"`: by emitted power),
//!   `noise_threshold` (>= 0: adaptive sampling's noise threshold, Cycles' convention, 0 = off),
//!   `min_samples` (integer >= 0, 0 = automatic), `time_limit` (seconds >= 0, 0 = none),
//!   `splits` (`"auto"`, the default: branches per camera path at its first vertex planned
//!   from the first samples | 1-4 everywhere, 1 = plain path tracing;
//!   `crate::integrator::splitting`), `caustic_guiding` (true, the default | false: guide
//!   bounces at diffuse and rough surfaces towards caustics found by photons traced through
//!   sharp metals and glass, `crate::integrator::caustics`),
//!   `denoise` (true | false: OIDN denoising of the final image, `crate::film::denoise`),
//!   `denoise_quality` (`"high"` default | `"balanced"` | `"fast"`), `denoise_prefilter`
//!   (`"accurate"` default | `"fast"` | `"none"`), and
//!   `clamp_direct` / `clamp_indirect` (>= 0, 0 = off: per-sample luminance limits of direct
//!   and indirect light, `crate::film::SampleClamp`), `film_transparent` (true | false:
//!   Blender's Film > Transparent, camera rays see no world and alpha is coverage), `crop`
//!   ([x, y, width, height] in pixels from the top-left corner: render only that window, as
//!   Blender's render border; checked against the image size by the renderer),
//!   `texture_filtering` (`"gltf"`, the default: 8-bit sRGB glTF textures are decoded before
//!   filtering, as the glTF specification asks | `"cycles"`: filtered in their encoded values
//!   and decoded after, as Cycles does; the Blender add-on writes it).
//!
//! Validation is strict and every error is one line:
//! `<file>: <json path, e.g. materials.Skin.subsurface.sigma_a[1]>: <what is wrong>`
//! (JSON syntax errors: `<file>:<line>:<column>: invalid JSON: ...`).

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Vec2, Vec3};
use serde_json::{Map, Value};

use crate::error::PrismError;
use crate::film::denoise::{DenoisePrefilter, DenoiseQuality};
use crate::scene::desc::{
    DielectricDesc, EnvironmentTextureDesc, IorDesc, LensDesc, MaterialOverride, PanoramaDesc,
    RenderDefaults, SubsurfaceCoefficients, SubsurfaceDesc, VolumeDesc, WorldDesc,
};
use crate::shading::image::Image;
use crate::shading::parse::{parse_graph, ImageLoader, NoImages};
use crate::shading::ShadingGraph;
use crate::spectrum::dispersion::MAX_SELLMEIER_TERMS;

/// The only sidecar schema version this Prism reads.
pub const SIDECAR_VERSION: u64 = 1;

/// Measured media of Jensen et al. 2001, "A Practical Model for Subsurface Light Transport",
/// Table (Figure 5). Only the names are validated here; the coefficients live with the BSSRDF.
pub const SUBSURFACE_PRESETS: &[&str] = &[
    "Apple",
    "Chicken1",
    "Chicken2",
    "Cream",
    "Ketchup",
    "Marble",
    "Potato",
    "Skimmilk",
    "Skin1",
    "Skin2",
    "Spectralon",
    "Wholemilk",
];

/// Accepted values of `render.wavelengths`.
pub const WAVELENGTH_MODES: &[&str] = &["hero", "single", "stratified"];

use crate::film::filter::{FilterKind, MAX_FILTER_WIDTH};
use crate::lights::LightSelection;
use crate::sampler::SamplerKind;

/// Accepted values of `render.texture_filtering`: how 8-bit sRGB glTF textures are filtered
/// (`crate::scene::desc::TextureDesc::filter_encoded_as_cycles`).
pub const TEXTURE_FILTERINGS: &[&str] = &["gltf", "cycles"];

/// Accepted values of `render.wavelength_pdf`.
pub const WAVELENGTH_PDFS: &[&str] = &["rgb", "visible", "uniform"];

/// The keys that give an IOR model; a `dielectric` (or a `subsurface.ior` object) takes exactly
/// one of them.
pub const IOR_FORMS: &[&str] = &["ior", "cauchy", "sellmeier", "abbe", "preset"];

/// Accepted values of `subsurface.method`.
pub const SUBSURFACE_METHODS: &[&str] = &["table", "random_walk"];
/// Accepted values of `subsurface.boundary` (random walk only).
pub const SUBSURFACE_BOUNDARIES: &[&str] = &["dielectric", "lambertian"];

/// A parsed, validated sidecar.
#[derive(Clone, Debug, Default)]
pub struct MaterialsFile {
    /// Overrides by glTF material name, in the order the file lists them.
    pub materials: Vec<(String, MaterialOverride)>,
    /// Shading graphs by glTF material name (`materials.<name>.graph`, see `crate::shading::parse`).
    pub graphs: Vec<(String, Arc<ShadingGraph>)>,
    /// Materials that are holdouts (`materials.<name>.holdout`: Blender's Holdout shader).
    pub holdouts: Vec<String>,
    /// Volumes by glTF material name (`materials.<name>.volume`), and whether the material's
    /// surface is `"none"`.
    pub volumes: Vec<(String, VolumeDesc, bool)>,
    /// Materials rendered with the glTF 2.0 spec's BRDF as written (`"model": "gltf"`), or
    /// with single-scattering lobes as Blender 3.x's Principled (`"model": "principled_v1"`).
    pub gltf_models: Vec<String>,
    /// Materials rendered as Blender 3.x's Principled BSDF in Cycles 3.x (`"model":
    /// "principled_v1"`).
    pub principled_v1_models: Vec<String>,
    /// Problems the user should see that do not stop the render (an unreadable texture).
    pub warnings: Vec<String>,
    /// `None` when the file has no `world` block. Its `texture` is decoded by
    /// [`load_materials_file`] (not by [`parse_materials_json`], which reads no other file).
    pub world: Option<WorldDesc>,
    /// `world.texture` and `world.rotation_z` as written in the file.
    pub world_texture: Option<WorldTextureRef>,
    /// The `camera` block.
    pub camera: Option<CameraOverride>,
    pub render: RenderDefaults,
}

/// The material JSON's `camera` block.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraOverride {
    pub lens: Option<LensDesc>,
    pub shift: Vec2,
    pub panorama: Option<PanoramaDesc>,
}

/// The sidecar's reference to an environment image.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldTextureRef {
    /// As written (relative to the sidecar's folder unless absolute).
    pub path: String,
    pub rotation_z: f32,
}

/// Accepted environment image extensions (lower case).
pub const ENVIRONMENT_IMAGE_TYPES: &[&str] = &["exr", "hdr", "png"];

/// Reads and validates a sidecar file. `gltf_material_names`, when given, are the material names
/// of the scene: a sidecar entry naming no glTF material is an error.
pub fn load_materials_file(
    path: &Path,
    gltf_material_names: Option<&[String]>,
) -> Result<MaterialsFile, PrismError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| PrismError::input(format!("{file}: cannot read: {}", io_msg(&e))))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| PrismError::input(format!("{file}: not valid UTF-8 text: {e}")))?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut images = FileImages {
        dir,
        cache: HashMap::new(),
        warnings: Vec::new(),
    };
    let mut parsed = parse_with_images(&text, &file, gltf_material_names, &mut images)?;
    parsed.warnings.append(&mut images.warnings);
    if let (Some(tex), Some(world)) = (&parsed.world_texture, parsed.world.as_mut()) {
        let dir = path.parent().unwrap_or(Path::new(""));
        let image_path = dir.join(&tex.path);
        let image = crate::lights::envmap::load_env_image(&image_path).map_err(|e| {
            PrismError::input(format!(
                "{file}: world.texture: {}: {e}",
                image_path.display()
            ))
        })?;
        world.texture = Some(EnvironmentTextureDesc {
            name: image_path.display().to_string(),
            width: image.width,
            height: image.height,
            texels: image.texels,
            rotation_z: tex.rotation_z,
        });
    }
    Ok(parsed)
}

/// `std::io::Error` text without the trailing " (os error N)".
pub(crate) fn io_msg(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" (os error") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

/// Validates sidecar text; `file` is only used in messages. Graph images are not read (each
/// is a placeholder): [`load_materials_file`] reads them.
pub fn parse_materials_json(
    text: &str,
    file: &str,
    gltf_material_names: Option<&[String]>,
) -> Result<MaterialsFile, PrismError> {
    parse_with_images(text, file, gltf_material_names, &mut NoImages)
}

fn parse_with_images(
    text: &str,
    file: &str,
    gltf_material_names: Option<&[String]>,
    images: &mut dyn ImageLoader,
) -> Result<MaterialsFile, PrismError> {
    let root: Value = serde_json::from_str(text).map_err(|e| syntax_error(text, file, &e))?;
    let v = Validator {
        file,
        images: RefCell::new(images),
    };
    v.root(&root, gltf_material_names)
}

/// Reads graph images relative to the sidecar's folder, once per (file, colour space). An
/// image that cannot be read becomes Blender's magenta with one warning naming it.
struct FileImages {
    dir: PathBuf,
    cache: HashMap<(String, bool), Arc<Image>>,
    warnings: Vec<String>,
}

impl ImageLoader for FileImages {
    fn load(&mut self, path: &str, linear: bool) -> Arc<Image> {
        let key = (path.to_string(), linear);
        if let Some(img) = self.cache.get(&key) {
            return img.clone();
        }
        let full = self.dir.join(path);
        let img = match read_graph_image(&full, linear) {
            Ok(img) => Arc::new(img),
            Err(e) => {
                self.warnings.push(format!(
                    "image '{path}' ({}): {e}; rendered magenta",
                    full.display()
                ));
                Image::missing(path)
            }
        };
        self.cache.insert(key, img.clone());
        img
    }
}

/// PNG/JPEG (8 or 16 bit, sRGB-decoded unless `linear`) or EXR/HDR (linear RGB).
fn read_graph_image(path: &Path, linear: bool) -> Result<Image, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let name = path.display().to_string();
    if ext == "exr" || ext == "hdr" {
        let env = crate::lights::envmap::load_linear_image(path)?;
        return Ok(Image {
            name,
            width: env.width,
            height: env.height,
            texels: env.texels.iter().map(|c| c.extend(1.0)).collect(),
            srgb_encoded: false,
        });
    }
    let bytes = std::fs::read(path).map_err(|e| io_msg(&e))?;
    let decoded = crate::scene::texture::decode_image(&bytes, None)?;
    // 8-bit sRGB images keep their encoded values and decode after filtering, as in Cycles.
    let srgb_encoded = !linear && decoded.eight_bit;
    let space = if linear || srgb_encoded {
        crate::scene::desc::ColorSpace::Linear
    } else {
        crate::scene::desc::ColorSpace::Srgb
    };
    Ok(Image {
        name,
        width: decoded.width,
        height: decoded.height,
        texels: crate::scene::texture::to_linear_texels(&decoded, space),
        srgb_encoded,
    })
}

fn syntax_error(text: &str, file: &str, e: &serde_json::Error) -> PrismError {
    let full = e.to_string();
    // serde_json appends " at line L column C"; we put the position first, compiler-style.
    let msg = match full.rfind(" at line ") {
        Some(i) => full[..i].to_string(),
        None => full,
    };
    let (line, col) = (e.line(), e.column());
    let mut hint = String::new();
    if line > 0 {
        if let Some(l) = text.lines().nth(line - 1) {
            let start = col.saturating_sub(1).min(l.len());
            let rest = l.get(start..).unwrap_or("");
            let rest_trim = rest.trim_start_matches(['-', '+']);
            if ["NaN", "nan", "Infinity", "inf", "Inf"]
                .iter()
                .any(|w| rest_trim.starts_with(w))
            {
                hint = " (NaN and Infinity are not valid JSON numbers)".into();
            }
        }
    }
    if msg.contains("number out of range") {
        hint = " (the number is too large to be finite)".into();
    }
    PrismError::input(format!("{file}:{line}:{col}: invalid JSON: {msg}{hint}"))
}

/// A JSON path for messages: `materials.Skin.subsurface.sigma_a[1]`.
#[derive(Clone)]
struct JPath(String);

impl JPath {
    fn root() -> Self {
        JPath(String::new())
    }
    fn key(&self, k: &str) -> Self {
        let simple = !k.is_empty()
            && k.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        let mut s = self.0.clone();
        if simple {
            if !s.is_empty() {
                s.push('.');
            }
            s.push_str(k);
        } else {
            s.push_str(&format!("[{}]", Value::String(k.to_string())));
        }
        JPath(s)
    }
    fn idx(&self, i: usize) -> Self {
        JPath(format!("{}[{i}]", self.0))
    }
    fn show(&self) -> &str {
        if self.0.is_empty() {
            "(top level)"
        } else {
            &self.0
        }
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

#[derive(Clone, Copy)]
enum Range {
    /// >= 0
    NonNeg,
    /// > 0
    Positive,
    /// [0, 1]
    Unit,
    /// (-1, 1)
    OpenSigned,
    /// any finite number
    Finite,
}

struct Validator<'a> {
    file: &'a str,
    images: RefCell<&'a mut dyn ImageLoader>,
}

type R<T> = Result<T, PrismError>;

impl Validator<'_> {
    fn err(&self, path: &JPath, msg: impl std::fmt::Display) -> PrismError {
        PrismError::input(format!("{}: {}: {}", self.file, path.show(), msg))
    }

    fn object<'v>(&self, v: &'v Value, path: &JPath) -> R<&'v Map<String, Value>> {
        v.as_object()
            .ok_or_else(|| self.err(path, format!("expected an object, found {}", kind(v))))
    }

    fn check_keys(&self, m: &Map<String, Value>, allowed: &[&str], path: &JPath) -> R<()> {
        for k in m.keys() {
            if !allowed.contains(&k.as_str()) {
                return Err(self.err(
                    &path.key(k),
                    format!(
                        "unknown key '{k}' (expected one of: {})",
                        allowed.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    fn number(&self, v: &Value, path: &JPath, range: Range) -> R<f32> {
        let (x, shown) = match v {
            Value::Number(n) => (n.as_f64().unwrap_or(f64::NAN), n.to_string()),
            _ => return Err(self.err(path, format!("expected a number, found {}", kind(v)))),
        };
        let f = x as f32;
        if !f.is_finite() {
            return Err(self.err(
                path,
                format!("{shown} is not a finite number (too large for 32-bit floats)"),
            ));
        }
        let (ok, what) = match range {
            Range::NonNeg => (f >= 0.0, "must be non-negative"),
            Range::Positive => (f > 0.0, "must be positive"),
            Range::Unit => ((0.0..=1.0).contains(&f), "must be in [0, 1]"),
            Range::OpenSigned => (f > -1.0 && f < 1.0, "must be in (-1, 1)"),
            Range::Finite => (true, ""),
        };
        if !ok {
            return Err(self.err(path, format!("{what}, got {shown}")));
        }
        Ok(f)
    }

    fn boolean(&self, v: &Value, path: &JPath) -> R<bool> {
        v.as_bool()
            .ok_or_else(|| self.err(path, format!("expected true or false, found {}", kind(v))))
    }

    fn rgb(&self, v: &Value, path: &JPath, range: Range) -> R<Vec3> {
        let a = v.as_array().ok_or_else(|| {
            self.err(
                path,
                format!("expected an array of 3 numbers, found {}", kind(v)),
            )
        })?;
        if a.len() != 3 {
            return Err(self.err(
                path,
                format!("expected an array of 3 numbers, found {} elements", a.len()),
            ));
        }
        let mut out = [0.0f32; 3];
        for (i, e) in a.iter().enumerate() {
            out[i] = self.number(e, &path.idx(i), range)?;
        }
        Ok(Vec3::from_array(out))
    }

    fn uint(&self, v: &Value, path: &JPath, min: u64) -> R<u32> {
        let n = match v {
            Value::Number(n) => n,
            _ => return Err(self.err(path, format!("expected an integer, found {}", kind(v)))),
        };
        let x = if let Some(u) = n.as_u64() {
            u
        } else if let Some(i) = n.as_i64() {
            return Err(self.err(path, format!("must be an integer >= {min}, got {i}")));
        } else {
            let f = n.as_f64().unwrap_or(f64::NAN);
            if f.fract() != 0.0 || !f.is_finite() {
                return Err(self.err(path, format!("expected an integer, got {f}")));
            }
            if f < 0.0 {
                return Err(self.err(path, format!("must be an integer >= {min}, got {f}")));
            }
            if f > u32::MAX as f64 {
                return Err(self.err(path, format!("{f} is too large")));
            }
            f as u64
        };
        if x < min {
            return Err(self.err(path, format!("must be an integer >= {min}, got {x}")));
        }
        u32::try_from(x).map_err(|_| self.err(path, format!("{x} is too large")))
    }

    fn string<'v>(&self, v: &'v Value, path: &JPath, allowed: &[&str], what: &str) -> R<&'v str> {
        let s = v
            .as_str()
            .ok_or_else(|| self.err(path, format!("expected a string, found {}", kind(v))))?;
        if !allowed.contains(&s) {
            return Err(self.err(
                path,
                format!("unknown {what} '{s}' (valid: {})", allowed.join(", ")),
            ));
        }
        Ok(s)
    }

    fn root(&self, root: &Value, names: Option<&[String]>) -> R<MaterialsFile> {
        let top = JPath::root();
        let m = self.object(root, &top)?;
        self.check_keys(
            m,
            &["version", "materials", "world", "camera", "render"],
            &top,
        )?;
        let vpath = top.key("version");
        match m.get("version") {
            None => {
                return Err(self.err(
                    &vpath,
                    format!("missing (this Prism reads version {SIDECAR_VERSION})"),
                ))
            }
            Some(v) => {
                if v.as_u64() != Some(SIDECAR_VERSION) && v.as_f64() != Some(1.0) {
                    return Err(self.err(
                        &vpath,
                        format!(
                            "unsupported version {v} (this Prism reads version {SIDECAR_VERSION})"
                        ),
                    ));
                }
            }
        }
        let mut out = MaterialsFile::default();
        if let Some(mats) = m.get("materials") {
            let mpath = top.key("materials");
            let mats = self.object(mats, &mpath)?;
            for (name, def) in mats {
                let p = mpath.key(name);
                let (ov, graph) = self.material(def, &p)?;
                if let Some(h) = def.get("holdout") {
                    if self.boolean(h, &p.key("holdout"))? {
                        out.holdouts.push(name.clone());
                    }
                }
                if let Some(names) = names {
                    if !names.iter().any(|n| n == name) {
                        let list = if names.is_empty() {
                            "the scene has no named materials".to_string()
                        } else {
                            let q: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
                            format!("materials in the scene: {}", q.join(", "))
                        };
                        return Err(self.err(
                            &p,
                            format!("no material named '{name}' in the glTF ({list})"),
                        ));
                    }
                }
                if let Some(ov) = ov {
                    out.materials.push((name.clone(), ov));
                }
                let def_map = self.object(def, &p)?;
                let volume = match def_map.get("volume") {
                    Some(v) => Some(self.volume(v, &p.key("volume"))?),
                    None => None,
                };
                if let Some(v) = def_map.get("model") {
                    let mp = p.key("model");
                    match self.string(v, &mp, &["gltf", "cycles", "principled_v1"], "model")? {
                        "gltf" => out.gltf_models.push(name.clone()),
                        "principled_v1" => {
                            out.gltf_models.push(name.clone());
                            out.principled_v1_models.push(name.clone());
                        }
                        _ => {}
                    }
                }
                let null_surface = match def_map.get("surface") {
                    Some(v) => {
                        let sp = p.key("surface");
                        self.string(v, &sp, &["none", "shaded"], "surface")? == "none"
                    }
                    None => false,
                };
                if null_surface && volume.is_none() {
                    return Err(self.err(
                        &p.key("surface"),
                        "\"none\" needs a 'volume' (a boundary without a surface and without a volume would be invisible)",
                    ));
                }
                if let Some(v) = volume {
                    out.volumes.push((name.clone(), v, null_surface));
                }
                if let Some(g) = graph {
                    out.graphs.push((name.clone(), Arc::new(g)));
                }
            }
        }
        if let Some(w) = m.get("world") {
            let (world, texture) = self.world(w, &top.key("world"))?;
            out.world = Some(world);
            out.world_texture = texture;
        }
        if let Some(c) = m.get("camera") {
            out.camera = Some(self.camera(c, &top.key("camera"))?);
        }
        if let Some(r) = m.get("render") {
            out.render = self.render(r, &top.key("render"))?;
        }
        Ok(out)
    }

    fn material(
        &self,
        v: &Value,
        path: &JPath,
    ) -> R<(Option<MaterialOverride>, Option<ShadingGraph>)> {
        let m = self.object(v, path)?;
        self.check_keys(
            m,
            &[
                "subsurface",
                "dielectric",
                "graph",
                "holdout",
                "volume",
                "surface",
                "model",
            ],
            path,
        )?;
        if m.contains_key("volume") && m.contains_key("subsurface") {
            return Err(self.err(
                path,
                "give 'volume' or 'subsurface', not both (a subsurface material is its own medium)",
            ));
        }
        let graph = match m.get("graph") {
            Some(g) => {
                let gpath = path.key("graph");
                let mut images = self.images.borrow_mut();
                let parsed = parse_graph(g, gpath.show(), &mut **images).map_err(|e| {
                    PrismError::input(format!("{}: {}: {}", self.file, e.path, e.msg))
                })?;
                Some(parsed)
            }
            None => None,
        };
        if graph.as_ref().is_some_and(|g| g.has_subsurface_closure())
            && !m.contains_key("subsurface")
        {
            return Err(self.err(
                &path.key("graph").key("closures"),
                "a 'subsurface' closure needs the material's 'subsurface' entry (its medium)",
            ));
        }
        let ov = match (m.get("subsurface"), m.get("dielectric")) {
            (Some(s), None) => Some(MaterialOverride::Subsurface(
                self.subsurface(s, &path.key("subsurface"))?,
            )),
            (None, Some(d)) => Some(MaterialOverride::Dielectric(
                self.dielectric(d, &path.key("dielectric"))?,
            )),
            (Some(_), Some(_)) => {
                return Err(self.err(
                    path,
                    "give exactly one of 'subsurface' or 'dielectric', not both",
                ))
            }
            (None, None)
                if graph.is_none()
                    && !["holdout", "volume", "model"].iter().any(|k| m.contains_key(*k)) =>
            {
                return Err(self.err(
                    path,
                    "empty material: give 'subsurface', 'dielectric', 'graph', 'volume', 'model' or 'holdout'",
                ))
            }
            (None, None) => None,
        };
        let by_colour = |s: &SubsurfaceDesc| {
            matches!(
                s.coefficients,
                SubsurfaceCoefficients::Reflectance { .. }
                    | SubsurfaceCoefficients::CyclesWalk { .. }
            )
        };
        if graph
            .as_ref()
            .is_some_and(|g| g.drives_anywhere(crate::shading::MaterialInput::SubsurfaceColor))
            && !matches!(&ov, Some(MaterialOverride::Subsurface(s)) if by_colour(s))
        {
            return Err(self.err(
                &path.key("graph"),
                "'subsurface_color' needs a 'subsurface' entry given by a colour ('reflectance' + 'mfp' or 'color' + 'radius')",
            ));
        }
        Ok((ov, graph))
    }

    fn volume(&self, v: &Value, path: &JPath) -> R<VolumeDesc> {
        let m = self.object(v, path)?;
        self.check_keys(
            m,
            &["sigma_a", "sigma_s", "g", "emission", "color_zero"],
            path,
        )?;
        let rgb_in = |m: &serde_json::Map<String, Value>, path: &JPath, key: &str| -> R<Vec3> {
            match m.get(key) {
                Some(c) => self.rgb(c, &path.key(key), Range::NonNeg),
                None => Ok(Vec3::ZERO),
            }
        };
        let rgb = |key: &str| rgb_in(m, path, key);
        let color_zero = match m.get("color_zero") {
            Some(z) => {
                let zp = path.key("color_zero");
                let zm = self.object(z, &zp)?;
                self.check_keys(zm, &["sigma_a", "sigma_s"], &zp)?;
                Some((rgb_in(zm, &zp, "sigma_a")?, rgb_in(zm, &zp, "sigma_s")?))
            }
            None => None,
        };
        let g = match m.get("g") {
            Some(g) => self.number(g, &path.key("g"), Range::OpenSigned)?,
            None => 0.0,
        };
        Ok(VolumeDesc {
            sigma_a: rgb("sigma_a")?,
            sigma_s: rgb("sigma_s")?,
            g,
            emission: rgb("emission")?,
            color_zero,
        })
    }

    fn subsurface(&self, v: &Value, path: &JPath) -> R<SubsurfaceDesc> {
        let m = self.object(v, path)?;
        self.check_keys(
            m,
            &[
                "preset",
                "sigma_a",
                "sigma_s",
                "reflectance",
                "mfp",
                "color",
                "radius",
                "skin",
                "scale",
                "eta",
                "ior",
                "g",
                "roughness",
                "method",
                "boundary",
                "weight",
            ],
            path,
        )?;
        let has = |k: &str| m.contains_key(k);
        let groups: Vec<&str> = [
            ("preset", has("preset")),
            ("sigma_a + sigma_s", has("sigma_a") || has("sigma_s")),
            ("reflectance + mfp", has("reflectance") || has("mfp")),
            ("color + radius", has("color") || has("radius")),
        ]
        .iter()
        .filter(|g| g.1)
        .map(|g| g.0)
        .collect();
        if groups.len() != 1 {
            let found = if groups.is_empty() {
                "none given".to_string()
            } else {
                format!("found {}", groups.join(" and "))
            };
            return Err(self.err(
                path,
                format!(
                    "give exactly one of 'preset', 'sigma_a' + 'sigma_s', 'reflectance' + 'mfp', or 'color' + 'radius' ({found})"
                ),
            ));
        }
        let pair = |a: &str, b: &str| -> R<(&Value, &Value)> {
            match (m.get(a), m.get(b)) {
                (Some(x), Some(y)) => Ok((x, y)),
                (Some(_), None) => Err(self.err(path, format!("'{a}' needs '{b}'"))),
                _ => Err(self.err(path, format!("'{b}' needs '{a}'"))),
            }
        };
        let coefficients = match groups[0] {
            "preset" => {
                let p = path.key("preset");
                let name = self.string(&m["preset"], &p, SUBSURFACE_PRESETS, "preset")?;
                SubsurfaceCoefficients::Preset(name.to_string())
            }
            "sigma_a + sigma_s" => {
                let (a, s) = pair("sigma_a", "sigma_s")?;
                SubsurfaceCoefficients::Explicit {
                    sigma_a: self.rgb(a, &path.key("sigma_a"), Range::NonNeg)?,
                    sigma_s: self.rgb(s, &path.key("sigma_s"), Range::NonNeg)?,
                }
            }
            "reflectance + mfp" => {
                let (r, d) = pair("reflectance", "mfp")?;
                SubsurfaceCoefficients::Reflectance {
                    reflectance: self.rgb(r, &path.key("reflectance"), Range::Unit)?,
                    mfp: self.rgb(d, &path.key("mfp"), Range::Positive)?,
                }
            }
            _ => {
                let (c, r) = pair("color", "radius")?;
                if m.get("method").and_then(Value::as_str) != Some("random_walk") {
                    return Err(self.err(
                        &path.key("color"),
                        "'color' + 'radius' (Blender's random walk) need \"method\": \"random_walk\"",
                    ));
                }
                let skin = match m.get("skin") {
                    Some(Value::Bool(b)) => *b,
                    Some(other) => {
                        return Err(self.err(
                            &path.key("skin"),
                            format!("expected true or false, found {}", kind(other)),
                        ))
                    }
                    None => false,
                };
                SubsurfaceCoefficients::CyclesWalk {
                    color: self.rgb(c, &path.key("color"), Range::Unit)?,
                    radius: self.rgb(r, &path.key("radius"), Range::Positive)?,
                    skin,
                }
            }
        };
        if m.contains_key("skin")
            && !matches!(coefficients, SubsurfaceCoefficients::CyclesWalk { .. })
        {
            return Err(self.err(&path.key("skin"), "applies to 'color' + 'radius' only"));
        }
        let opt = |k: &str, range: Range, default: f32| -> R<f32> {
            match m.get(k) {
                Some(x) => self.number(x, &path.key(k), range),
                None => Ok(default),
            }
        };
        let method = match m.get("method") {
            Some(x) => self
                .string(x, &path.key("method"), SUBSURFACE_METHODS, "method")?
                .to_string(),
            None => "table".to_string(),
        };
        let boundary = match m.get("boundary") {
            Some(x) => {
                let b = self.string(x, &path.key("boundary"), SUBSURFACE_BOUNDARIES, "boundary")?;
                if method != "random_walk" {
                    return Err(self.err(
                        &path.key("boundary"),
                        "applies to method 'random_walk' only",
                    ));
                }
                b.to_string()
            }
            None => "dielectric".to_string(),
        };
        // The boundary's IOR: scalar `eta`, or any IOR form under `ior` (the BSSRDF then uses
        // its n_d as the scalar eta).
        let ior = match (m.get("eta"), m.get("ior")) {
            (Some(_), Some(_)) => {
                return Err(self.err(path, "give 'eta' or 'ior', not both"));
            }
            (_, Some(x)) => Some(self.subsurface_ior(x, &path.key("ior"))?),
            _ => None,
        };
        let eta = match &ior {
            Some(model) => model.n_d(),
            None => opt("eta", Range::Positive, 1.33)?,
        };
        Ok(SubsurfaceDesc {
            coefficients,
            scale: opt("scale", Range::Positive, 1.0)?,
            eta,
            ior,
            g: opt("g", Range::OpenSigned, 0.0)?,
            roughness: opt("roughness", Range::Unit, 0.0)?,
            method,
            boundary,
            weight: opt("weight", Range::Unit, 1.0)?,
        })
    }

    fn dielectric(&self, v: &Value, path: &JPath) -> R<DielectricDesc> {
        let m = self.object(v, path)?;
        let mut keys = IOR_FORMS.to_vec();
        keys.push("roughness");
        self.check_keys(m, &keys, path)?;
        let ior = self.ior_forms(m, path)?;
        let roughness = match m.get("roughness") {
            Some(x) => self.number(x, &path.key("roughness"), Range::Unit)?,
            None => 0.0,
        };
        Ok(DielectricDesc { ior, roughness })
    }

    /// `subsurface.ior`: a number, or an object holding exactly one IOR form.
    fn subsurface_ior(&self, v: &Value, path: &JPath) -> R<IorDesc> {
        if v.is_number() {
            return self.constant_ior(v, path);
        }
        let m = v.as_object().ok_or_else(|| {
            self.err(
                path,
                format!("expected a number or an object, found {}", kind(v)),
            )
        })?;
        self.check_keys(m, IOR_FORMS, path)?;
        self.ior_forms(m, path)
    }

    /// Exactly one of the `IOR_FORMS` keys of `m` (the object at `path`) as a validated model.
    fn ior_forms(&self, m: &Map<String, Value>, path: &JPath) -> R<IorDesc> {
        let given: Vec<&str> = IOR_FORMS
            .iter()
            .copied()
            .filter(|k| m.contains_key(*k))
            .collect();
        let one_of = IOR_FORMS
            .iter()
            .map(|k| format!("'{k}'"))
            .collect::<Vec<_>>()
            .join(", ");
        let key = match given.as_slice() {
            [k] => *k,
            [] => return Err(self.err(path, format!("give exactly one of {one_of}"))),
            many => {
                return Err(self.err(
                    path,
                    format!(
                        "give exactly one of {one_of}, not several (found {})",
                        many.join(" and ")
                    ),
                ))
            }
        };
        let p = path.key(key);
        let v = &m[key];
        // Errors of the model itself (pole in range, n < 1) point at the form's path.
        let model = |r: Result<IorDesc, String>| r.map_err(|e| self.err(&p, e));
        match key {
            "ior" => self.constant_ior(v, &p),
            "cauchy" => {
                let cm = self.object(v, &p)?;
                self.check_keys(cm, &["a", "b", "c"], &p)?;
                let a = self.required(cm, "a", &p, Range::Positive)?;
                let b = self.required(cm, "b", &p, Range::NonNeg)?;
                let c = match cm.get("c") {
                    Some(x) => self.number(x, &p.key("c"), Range::NonNeg)?,
                    None => 0.0,
                };
                model(IorDesc::cauchy(a, b, c))
            }
            "sellmeier" => {
                let sm = self.object(v, &p)?;
                self.check_keys(sm, &["b", "c"], &p)?;
                let b = self.coefficient_list(sm, "b", &p)?;
                let c = self.coefficient_list(sm, "c", &p)?;
                model(IorDesc::sellmeier(&b, &c))
            }
            "abbe" => {
                let am = self.object(v, &p)?;
                self.check_keys(am, &["ior", "abbe"], &p)?;
                let n_d = self.required(am, "ior", &p, Range::Positive)?;
                let v_d = self.required(am, "abbe", &p, Range::Positive)?;
                model(IorDesc::from_abbe(n_d, v_d))
            }
            _ => {
                let name = v
                    .as_str()
                    .ok_or_else(|| self.err(&p, format!("expected a string, found {}", kind(v))))?;
                model(IorDesc::preset(name))
            }
        }
    }

    /// A constant IOR: a number >= 1 (sidecar IORs are relative to the surrounding air).
    fn constant_ior(&self, v: &Value, path: &JPath) -> R<IorDesc> {
        let n = self.number(v, path, Range::Positive)?;
        if n < 1.0 {
            return Err(self.err(path, format!("must be >= 1, got {n}")));
        }
        Ok(IorDesc::Constant(n))
    }

    /// `m[key]` as a number in `range`; missing is an error.
    fn required(&self, m: &Map<String, Value>, key: &str, path: &JPath, range: Range) -> R<f32> {
        match m.get(key) {
            Some(x) => self.number(x, &path.key(key), range),
            None => Err(self.err(path, format!("missing '{key}'"))),
        }
    }

    /// `m[key]`: a non-empty array of at most `MAX_SELLMEIER_TERMS` non-negative numbers,
    /// kept in double precision (catalogue coefficients have 9 significant digits).
    fn coefficient_list(&self, m: &Map<String, Value>, key: &str, path: &JPath) -> R<Vec<f64>> {
        let p = path.key(key);
        let v = m
            .get(key)
            .ok_or_else(|| self.err(path, format!("missing '{key}'")))?;
        let a = v.as_array().ok_or_else(|| {
            self.err(
                &p,
                format!("expected an array of numbers, found {}", kind(v)),
            )
        })?;
        if a.is_empty() || a.len() > MAX_SELLMEIER_TERMS {
            return Err(self.err(
                &p,
                format!(
                    "expected 1 to {MAX_SELLMEIER_TERMS} numbers, found {} elements",
                    a.len()
                ),
            ));
        }
        a.iter()
            .enumerate()
            .map(|(i, e)| {
                self.number(e, &p.idx(i), Range::NonNeg)?;
                Ok(e.as_f64().unwrap_or(f64::NAN))
            })
            .collect()
    }

    fn world(&self, v: &Value, path: &JPath) -> R<(WorldDesc, Option<WorldTextureRef>)> {
        let m = self.object(v, path)?;
        self.check_keys(m, &["color", "strength", "texture", "rotation_z"], path)?;
        let texture = match m.get("texture") {
            None => None,
            Some(t) => {
                let tp = path.key("texture");
                let s = t.as_str().ok_or_else(|| {
                    self.err(
                        &tp,
                        format!("expected a file path string, found {}", kind(t)),
                    )
                })?;
                if s.trim().is_empty() {
                    return Err(self.err(&tp, "empty file path"));
                }
                let ext = Path::new(s)
                    .extension()
                    .and_then(|e| e.to_str())
                    .map(|e| e.to_ascii_lowercase())
                    .unwrap_or_default();
                if !ENVIRONMENT_IMAGE_TYPES.contains(&ext.as_str()) {
                    return Err(self.err(
                        &tp,
                        format!(
                            "unsupported image type '{s}' (valid: .{})",
                            ENVIRONMENT_IMAGE_TYPES.join(", .")
                        ),
                    ));
                }
                let rotation_z = match m.get("rotation_z") {
                    Some(r) => self.number(r, &path.key("rotation_z"), Range::Finite)?,
                    None => 0.0,
                };
                Some(WorldTextureRef {
                    path: s.to_string(),
                    rotation_z,
                })
            }
        };
        if texture.is_none() && m.contains_key("rotation_z") {
            return Err(self.err(
                &path.key("rotation_z"),
                "only applies to a world 'texture', and none is given",
            ));
        }
        let default_color = if texture.is_some() {
            Vec3::ONE
        } else {
            Vec3::ZERO
        };
        let color = match m.get("color") {
            Some(c) => self.rgb(c, &path.key("color"), Range::NonNeg)?,
            None => default_color,
        };
        let strength = match m.get("strength") {
            Some(s) => self.number(s, &path.key("strength"), Range::NonNeg)?,
            None => 1.0,
        };
        Ok((
            WorldDesc {
                color,
                strength,
                texture: None,
            },
            texture,
        ))
    }

    fn camera(&self, v: &Value, path: &JPath) -> R<CameraOverride> {
        let m = self.object(v, path)?;
        self.check_keys(
            m,
            &[
                "aperture_radius",
                "focus_distance",
                "shift",
                "projection",
                "longitude",
                "latitude",
                "fisheye_fov",
                "fisheye_lens",
                "sensor",
            ],
            path,
        )?;
        let get = |k: &str, range: Range| -> R<f32> {
            match m.get(k) {
                Some(x) => self.number(x, &path.key(k), range),
                None => Err(self.err(path, format!("missing '{k}'"))),
            }
        };
        let pair = |k: &str, range: Range, default: Vec2| -> R<Vec2> {
            let Some(x) = m.get(k) else {
                return Ok(default);
            };
            let p = path.key(k);
            match x.as_array() {
                Some(a) if a.len() == 2 => Ok(Vec2::new(
                    self.number(&a[0], &p.idx(0), range)?,
                    self.number(&a[1], &p.idx(1), range)?,
                )),
                _ => Err(self.err(&p, "expected an array of 2 numbers")),
            }
        };
        let lens = match (
            m.contains_key("aperture_radius"),
            m.contains_key("focus_distance"),
        ) {
            (false, false) => None,
            _ => Some(LensDesc {
                aperture_radius: get("aperture_radius", Range::NonNeg)?,
                focus_distance: get("focus_distance", Range::Positive)?,
            }),
        };
        let shift = pair("shift", Range::Finite, Vec2::ZERO)?;
        let fov = || -> R<f32> {
            match m.get("fisheye_fov") {
                None => Ok(std::f32::consts::PI),
                Some(_) => {
                    let f = get("fisheye_fov", Range::Positive)?;
                    if f > std::f32::consts::TAU {
                        return Err(self.err(
                            &path.key("fisheye_fov"),
                            format!("must be at most 2 pi (360 degrees), got {f}"),
                        ));
                    }
                    Ok(f)
                }
            }
        };
        let only = |allowed: &[&str], kind: &str| -> R<()> {
            for k in [
                "longitude",
                "latitude",
                "fisheye_fov",
                "fisheye_lens",
                "sensor",
            ] {
                if m.contains_key(k) && !allowed.contains(&k) {
                    return Err(
                        self.err(&path.key(k), format!("not used by the projection '{kind}'"))
                    );
                }
            }
            Ok(())
        };
        let panorama = match m.get("projection") {
            None => {
                only(&[], "perspective/orthographic (from the glTF camera)")?;
                None
            }
            Some(Value::String(kind)) => match kind.as_str() {
                "equirectangular" => {
                    only(&["longitude", "latitude"], kind)?;
                    let pi = std::f32::consts::PI;
                    let lon = pair("longitude", Range::Finite, Vec2::new(-pi, pi))?;
                    let lat = pair("latitude", Range::Finite, Vec2::new(-pi / 2.0, pi / 2.0))?;
                    Some(PanoramaDesc::Equirectangular {
                        longitude: (lon.x, lon.y),
                        latitude: (lat.x, lat.y),
                    })
                }
                "fisheye_equidistant" => {
                    only(&["fisheye_fov"], kind)?;
                    Some(PanoramaDesc::FisheyeEquidistant { fov: fov()? })
                }
                "fisheye_equisolid" => {
                    only(&["fisheye_fov", "fisheye_lens", "sensor"], kind)?;
                    Some(PanoramaDesc::FisheyeEquisolid {
                        fov: fov()?,
                        lens: get("fisheye_lens", Range::Positive)?,
                        sensor: pair("sensor", Range::Positive, Vec2::new(36.0, 24.0))?,
                    })
                }
                other => {
                    return Err(self.err(
                        &path.key("projection"),
                        format!("unknown projection '{other}' (expected one of: equirectangular, fisheye_equidistant, fisheye_equisolid)"),
                    ))
                }
            },
            Some(other) => {
                return Err(self.err(
                    &path.key("projection"),
                    format!("expected a string, found {}", kind(other)),
                ))
            }
        };
        Ok(CameraOverride {
            lens,
            shift,
            panorama,
        })
    }

    fn render(&self, v: &Value, path: &JPath) -> R<RenderDefaults> {
        let m = self.object(v, path)?;
        self.check_keys(
            m,
            &[
                "spp",
                "width",
                "height",
                "max_depth",
                "wavelengths",
                "wavelength_pdf",
                "filter",
                "sampler",
                "light_sampler",
                "noise_threshold",
                "min_samples",
                "time_limit",
                "denoise",
                "denoise_quality",
                "denoise_prefilter",
                "clamp_direct",
                "clamp_indirect",
                "film_transparent",
                "crop",
                "texture_filtering",
                "splits",
                "caustic_guiding",
            ],
            path,
        )?;
        let get = |k: &str, min: u64| -> R<Option<u32>> {
            m.get(k)
                .map(|x| self.uint(x, &path.key(k), min))
                .transpose()
        };
        // A string from a fixed set of names.
        let choice = |k: &str, allowed: &[&str], what: &str| -> R<Option<String>> {
            m.get(k)
                .map(|x| {
                    self.string(x, &path.key(k), allowed, what)
                        .map(str::to_string)
                })
                .transpose()
        };
        Ok(RenderDefaults {
            spp: get("spp", 1)?,
            width: get("width", 1)?,
            height: get("height", 1)?,
            max_depth: get("max_depth", 0)?,
            wavelengths: choice("wavelengths", WAVELENGTH_MODES, "wavelength mode")?,
            wavelength_pdf: choice("wavelength_pdf", WAVELENGTH_PDFS, "wavelength pdf")?,
            filter: m
                .get("filter")
                .map(|f| self.filter(f, &path.key("filter")))
                .transpose()?,
            sampler: choice("sampler", SamplerKind::NAMES, "sampler")?,
            noise_threshold: m
                .get("noise_threshold")
                .map(|x| self.number(x, &path.key("noise_threshold"), Range::NonNeg))
                .transpose()?,
            min_samples: get("min_samples", 0)?,
            splits: m
                .get("splits")
                .map(|x| {
                    let key = path.key("splits");
                    if x.as_str() == Some("auto") {
                        return Ok(0);
                    }
                    match self.uint(x, &key, 1) {
                        Ok(k) if k <= crate::integrator::splitting::MAX_SPLITS => Ok(k),
                        _ => Err(self.err(
                            &key,
                            format!(
                                "must be \"auto\" or a number of branches from 1 to {}",
                                crate::integrator::splitting::MAX_SPLITS
                            ),
                        )),
                    }
                })
                .transpose()?,
            denoise: m
                .get("denoise")
                .map(|x| self.boolean(x, &path.key("denoise")))
                .transpose()?,
            denoise_quality: choice("denoise_quality", DenoiseQuality::NAMES, "denoise quality")?,
            denoise_prefilter: choice(
                "denoise_prefilter",
                DenoisePrefilter::NAMES,
                "denoise prefilter",
            )?,
            clamp_direct: m
                .get("clamp_direct")
                .map(|x| self.number(x, &path.key("clamp_direct"), Range::NonNeg))
                .transpose()?,
            clamp_indirect: m
                .get("clamp_indirect")
                .map(|x| self.number(x, &path.key("clamp_indirect"), Range::NonNeg))
                .transpose()?,
            crop: m
                .get("crop")
                .map(|x| -> R<[u32; 4]> {
                    let p = path.key("crop");
                    match x.as_array() {
                        Some(a) if a.len() == 4 => {
                            let mut out = [0u32; 4];
                            for (i, e) in a.iter().enumerate() {
                                out[i] = self.uint(e, &p.idx(i), 0)?;
                            }
                            Ok(out)
                        }
                        _ => {
                            Err(self
                                .err(&p, "expected an array of 4 integers [x, y, width, height]"))
                        }
                    }
                })
                .transpose()?,
            film_transparent: m
                .get("film_transparent")
                .map(|x| self.boolean(x, &path.key("film_transparent")))
                .transpose()?,
            caustic_guiding: m
                .get("caustic_guiding")
                .map(|x| self.boolean(x, &path.key("caustic_guiding")))
                .transpose()?,
            time_limit: m
                .get("time_limit")
                .map(|x| {
                    self.number(x, &path.key("time_limit"), Range::NonNeg)
                        .map(|v| v as f64)
                })
                .transpose()?,
            light_sampler: choice("light_sampler", LightSelection::NAMES, "light sampler")?,
            texture_filtering: choice(
                "texture_filtering",
                TEXTURE_FILTERINGS,
                "texture filtering",
            )?,
        })
    }

    /// `render.filter`: `{"type": "blackman_harris", "width": 1.5}`; either key may be left out
    /// (type defaults to Blackman–Harris, width to 1.5 px, Cycles' defaults).
    fn filter(&self, v: &Value, path: &JPath) -> R<(String, f32)> {
        let m = self.object(v, path)?;
        self.check_keys(m, &["type", "width"], path)?;
        let kind = match m.get("type") {
            Some(t) => self.string(t, &path.key("type"), FilterKind::NAMES, "pixel filter")?,
            None => FilterKind::BlackmanHarris.name(),
        };
        let width = match m.get("width") {
            Some(w) => {
                let width = self.number(w, &path.key("width"), Range::Positive)?;
                if width > MAX_FILTER_WIDTH {
                    return Err(self.err(
                        &path.key("width"),
                        format!("{width} is wider than {MAX_FILTER_WIDTH} pixels"),
                    ));
                }
                width
            }
            None => 1.5,
        };
        Ok((kind.to_string(), width))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<MaterialsFile, String> {
        let names: Vec<String> = ["Marble", "Skin", "Wax", "Diamond"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        parse_materials_json(s, "m.json", Some(&names)).map_err(|e| e.to_string())
    }

    #[test]
    fn model_chooses_the_gltf_spec_brdf() {
        let m = parse(r#"{"version": 1, "materials": {"Wax": {"model": "gltf"}, "Skin": {"model": "cycles"}, "Marble": {"model": "principled_v1"}}}"#)
            .unwrap();
        let mut gltf = m.gltf_models.clone();
        gltf.sort();
        // Blender 3.x's Principled scatters once, as the glTF model does.
        assert_eq!(gltf, vec!["Marble".to_string(), "Wax".to_string()]);
        assert_eq!(m.principled_v1_models, vec!["Marble".to_string()]);
        let e = parse(r#"{"version": 1, "materials": {"Wax": {"model": "pbr"}}}"#).unwrap_err();
        assert!(
            e.contains("materials.Wax.model") && e.contains("unknown model 'pbr'"),
            "{e}"
        );
    }

    #[test]
    fn render_caustic_guiding_parses_and_rejects_non_booleans() {
        let f = parse(r#"{"version":1,"render":{"caustic_guiding":false}}"#).unwrap();
        assert_eq!(f.render.caustic_guiding, Some(false));
        let f = parse(r#"{"version":1,"render":{}}"#).unwrap();
        assert_eq!(f.render.caustic_guiding, None);
        let e = parse(r#"{"version":1,"render":{"caustic_guiding":"on"}}"#).unwrap_err();
        assert!(
            e.contains("render.caustic_guiding") && !e.contains('\n'),
            "{e}"
        );
    }

    #[test]
    fn render_splits_parse_and_reject_bad_values() {
        let f = parse(r#"{"version":1,"render":{"splits":"auto"}}"#).unwrap();
        assert_eq!(f.render.splits, Some(0));
        let f = parse(r#"{"version":1,"render":{"splits":3}}"#).unwrap();
        assert_eq!(f.render.splits, Some(3));
        for doc in [
            r#"{"version":1,"render":{"splits":0}}"#,
            r#"{"version":1,"render":{"splits":5}}"#,
            r#"{"version":1,"render":{"splits":"many"}}"#,
            r#"{"version":1,"render":{"splits":2.5}}"#,
        ] {
            let e = parse(doc).unwrap_err();
            assert!(
                e.contains("render.splits") && !e.contains('\n'),
                "{doc}: {e}"
            );
        }
    }

    #[test]
    fn render_filter_parses_and_rejects_bad_values() {
        let f =
            parse(r#"{"version":1,"render":{"filter":{"type":"gaussian","width":2}}}"#).unwrap();
        assert_eq!(f.render.filter, Some(("gaussian".to_string(), 2.0)));
        let f = parse(r#"{"version":1,"render":{"filter":{}}}"#).unwrap();
        assert_eq!(f.render.filter, Some(("blackman_harris".to_string(), 1.5)));
        for (doc, msg) in [
            (
                r#"{"version":1,"render":{"filter":{"type":"mitchell"}}}"#,
                "render.filter.type",
            ),
            (
                r#"{"version":1,"render":{"filter":{"width":0}}}"#,
                "render.filter.width",
            ),
            (
                r#"{"version":1,"render":{"filter":{"width":40}}}"#,
                "render.filter.width",
            ),
            (
                r#"{"version":1,"render":{"filter":{"size":1}}}"#,
                "render.filter.size",
            ),
        ] {
            let e = parse(doc).unwrap_err();
            assert!(e.contains(msg), "{doc}: {e}");
        }
    }

    #[test]
    fn errors_are_one_line_with_paths() {
        let cases: &[(&str, &str)] = &[
            (
                r#"{"version":1,"materials":{"Skin":{"graph":{"version":1,"nodes":{},"closures":[{"kind":"subsurface","weight":0.5}]}}}}"#,
                "m.json: materials.Skin.graph.closures: a 'subsurface' closure needs the material's 'subsurface' entry (its medium)",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"sigma_a":[0.1,-0.2,0.3],"sigma_s":[1,1,1]}}}}"#,
                "m.json: materials.Skin.subsurface.sigma_a[1]: must be non-negative, got -0.2",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"sigma_a":[0.1,1e300,0.3],"sigma_s":[1,1,1]}}}}"#,
                "m.json: materials.Skin.subsurface.sigma_a[1]: 1e+300 is not a finite number",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"sigma_a":[0.1,0.3],"sigma_s":[1,1,1]}}}}"#,
                "materials.Skin.subsurface.sigma_a: expected an array of 3 numbers, found 2 elements",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"sigma_a":[0.1,0.2,0.3]}}}}"#,
                "materials.Skin.subsurface: 'sigma_a' needs 'sigma_s'",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Jelly"}}}}"#,
                "materials.Skin.subsurface.preset: unknown preset 'Jelly' (valid: Apple, Chicken1",
            ),
            (
                r#"{"version":1,"materials":{"Glass":{"dielectric":{"ior":1.5}}}}"#,
                "materials.Glass: no material named 'Glass' in the glTF (materials in the scene: 'Marble'",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","colour":1}}}}"#,
                "materials.Skin.subsurface.colour: unknown key 'colour'",
            ),
            (r#"{"version":2}"#, "m.json: version: unsupported version 2"),
            (r#"{"materials":{}}"#, "m.json: version: missing"),
            (
                "{\"version\":1,\n \"world\": {\"strength\": NaN}}",
                "m.json:2:24: invalid JSON: expected value (NaN and Infinity are not valid JSON numbers)",
            ),
            (
                "{\"version\":1, \"world\": {\"strength\": 1e999}}",
                "invalid JSON: number out of range",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","g":1.0}}}}"#,
                "materials.Skin.subsurface.g: must be in (-1, 1), got 1",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"ior":1.5,"cauchy":{"a":1,"b":0}}}}}"#,
                "materials.Diamond.dielectric: give exactly one of 'ior', 'cauchy', 'sellmeier', 'abbe', 'preset', not several (found ior and cauchy)",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"ior":1.5,"preset":"BK7"}}}}"#,
                "materials.Diamond.dielectric: give exactly one of 'ior', 'cauchy', 'sellmeier', 'abbe', 'preset', not several (found ior and preset)",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"roughness":0.1}}}}"#,
                "materials.Diamond.dielectric: give exactly one of 'ior', 'cauchy', 'sellmeier', 'abbe', 'preset'",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"preset":"BK8"}}}}"#,
                "materials.Diamond.dielectric.preset: unknown glass preset 'BK8' (valid: BK7, fused_silica, F2, SF11, diamond, water)",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"preset":7}}}}"#,
                "materials.Diamond.dielectric.preset: expected a string, found a number",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"sellmeier":{"b":[],"c":[]}}}}}"#,
                "materials.Diamond.dielectric.sellmeier.b: expected 1 to 6 numbers, found 0 elements",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"sellmeier":{"b":[1,1,1,1,1,1,1],"c":[0,0,0,0,0,0,0]}}}}}"#,
                "materials.Diamond.dielectric.sellmeier.b: expected 1 to 6 numbers, found 7 elements",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"sellmeier":{"b":[1.0,0.2],"c":[0.006]}}}}}"#,
                "materials.Diamond.dielectric.sellmeier: Sellmeier 'b' and 'c' must have the same length, got 2 and 1",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"sellmeier":{"b":[1.0]}}}}}"#,
                "materials.Diamond.dielectric.sellmeier: missing 'c'",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"sellmeier":{"b":[1.0,-0.2],"c":[0.006,0.02]}}}}}"#,
                "materials.Diamond.dielectric.sellmeier.b[1]: must be non-negative, got -0.2",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"sellmeier":{"b":[1.0],"c":["x"]}}}}}"#,
                "materials.Diamond.dielectric.sellmeier.c[0]: expected a number, found a string",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"sellmeier":{"b":[1.0],"c":[0.25]}}}}}"#,
                "materials.Diamond.dielectric.sellmeier: Sellmeier c[0] = 0.25 µm² puts a pole at 500.0 nm, inside the rendered range 360–830 nm",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"abbe":{"ior":1.5,"abbe":-30}}}}}"#,
                "materials.Diamond.dielectric.abbe.abbe: must be positive, got -30",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"abbe":{"ior":1.5}}}}}"#,
                "materials.Diamond.dielectric.abbe: missing 'abbe'",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"abbe":{"ior":1.1,"abbe":0.5}}}}}"#,
                "materials.Diamond.dielectric.abbe: the index of refraction must be >= 1 over 360–830 nm, but n(",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"cauchy":{"a":0.5,"b":0.01}}}}}"#,
                "materials.Diamond.dielectric.cauchy: the index of refraction must be >= 1 over 360–830 nm, but n(830 nm) = 0.51",
            ),
            (
                r#"{"version":1,"materials":{"Diamond":{"dielectric":{"ior":0.75}}}}"#,
                "materials.Diamond.dielectric.ior: must be >= 1, got 0.75",
            ),
            (
                "{\"version\":1,\"materials\":{\"Diamond\":{\"dielectric\":{\"sellmeier\":{\"b\":[NaN],\"c\":[0.01]}}}}}",
                "invalid JSON: expected value (NaN and Infinity are not valid JSON numbers)",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","eta":1.3,"ior":1.4}}}}"#,
                "materials.Skin.subsurface: give 'eta' or 'ior', not both",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","ior":{"preset":"Skin1"}}}}}"#,
                "materials.Skin.subsurface.ior.preset: unknown glass preset 'Skin1'",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","ior":{"roughness":0}}}}}"#,
                "materials.Skin.subsurface.ior.roughness: unknown key 'roughness'",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","weight":1.5}}}}"#,
                "materials.Skin.subsurface.weight: must be in [0, 1], got 1.5",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","method":"random_walk","boundary":"rough"}}}}"#,
                "materials.Skin.subsurface.boundary: unknown boundary 'rough' (valid: dielectric, lambertian)",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","boundary":"lambertian"}}}}"#,
                "materials.Skin.subsurface.boundary: applies to method 'random_walk' only",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","method":"random_walk","boundary":1}}}}"#,
                "materials.Skin.subsurface.boundary: expected a string, found a number",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","ior":"water"}}}}"#,
                "materials.Skin.subsurface.ior: expected a number or an object, found a string",
            ),
            (
                r#"{"version":1,"render":{"wavelength_pdf":"gaussian"}}"#,
                "render.wavelength_pdf: unknown wavelength pdf 'gaussian' (valid: rgb, visible, uniform)",
            ),
            (
                r#"{"version":1,"world":{"texture":"sky.jpg"}}"#,
                "m.json: world.texture: unsupported image type 'sky.jpg' (valid: .exr, .hdr, .png)",
            ),
            (
                r#"{"version":1,"world":{"texture":7}}"#,
                "m.json: world.texture: expected a file path string, found a number",
            ),
            (
                r#"{"version":1,"world":{"texture":"  "}}"#,
                "m.json: world.texture: empty file path",
            ),
            (
                r#"{"version":1,"world":{"color":[1,1,1],"rotation_z":1}}"#,
                "m.json: world.rotation_z: only applies to a world 'texture'",
            ),
            (
                r#"{"version":1,"world":{"texture":"a.hdr","rotation_z":"90deg"}}"#,
                "m.json: world.rotation_z: expected a number, found a string",
            ),
            (
                r#"{"version":1,"world":{"texture":"a.hdr","tint":[1,1,1]}}"#,
                "m.json: world.tint: unknown key 'tint' (expected one of: color, strength, texture, rotation_z)",
            ),
            (
                r#"{"version":1,"camera":{"aperture_radius":0.1}}"#,
                "m.json: camera: missing 'focus_distance'",
            ),
            (
                r#"{"version":1,"camera":{"aperture_radius":-0.1,"focus_distance":2}}"#,
                "m.json: camera.aperture_radius: must be non-negative, got -0.1",
            ),
            (
                r#"{"version":1,"camera":{"aperture_radius":0.1,"focus_distance":0}}"#,
                "m.json: camera.focus_distance: must be positive, got 0",
            ),
            (
                r#"{"version":1,"camera":{"aperture_radius":0.1,"focus_distance":2,"fstop":2}}"#,
                "m.json: camera.fstop: unknown key 'fstop' (expected one of: aperture_radius, focus_distance, shift, projection, longitude, latitude, fisheye_fov, fisheye_lens, sensor)",
            ),
            (
                r#"{"version":1,"camera":{"projection":"cylinder"}}"#,
                "m.json: camera.projection: unknown projection 'cylinder' (expected one of: equirectangular, fisheye_equidistant, fisheye_equisolid)",
            ),
            (
                r#"{"version":1,"camera":{"projection":"fisheye_equidistant","longitude":[0,1]}}"#,
                "m.json: camera.longitude: not used by the projection 'fisheye_equidistant'",
            ),
            (
                r#"{"version":1,"camera":{"projection":"fisheye_equisolid","fisheye_fov":3}}"#,
                "m.json: camera: missing 'fisheye_lens'",
            ),
            (
                r#"{"version":1,"camera":{"shift":[0.1]}}"#,
                "m.json: camera.shift: expected an array of 2 numbers",
            ),
            (
                r#"{"version":1,"camera":[0.1,2]}"#,
                "m.json: camera: expected an object, found an array",
            ),
            (
                r#"{"version":1,"render":{"spp":0}}"#,
                "render.spp: must be an integer >= 1, got 0",
            ),
            (
                r#"{"version":1,"render":{"wavelengths":"all"}}"#,
                "render.wavelengths: unknown wavelength mode 'all' (valid: hero, single, stratified)",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","mfp":[1,1,1]}}}}"#,
                "materials.Skin.subsurface: give exactly one of 'preset', 'sigma_a' + 'sigma_s', 'reflectance' + 'mfp', or 'color' + 'radius' (found preset and reflectance + mfp)",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"color":[0.8,0.5,0.3],"radius":[1,0.5,0.2]}}}}"#,
                "materials.Skin.subsurface.color: 'color' + 'radius' (Blender's random walk) need \"method\": \"random_walk\"",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"color":[0.8,0.5,0.3],"method":"random_walk"}}}}"#,
                "materials.Skin.subsurface: 'color' needs 'radius'",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","skin":true}}}}"#,
                "materials.Skin.subsurface.skin: applies to 'color' + 'radius' only",
            ),
            (
                r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1"},"graph":{"version":1,"nodes":{},"inputs":{"subsurface_color":[1,0,0]}}}}}"#,
                "materials.Skin.graph: 'subsurface_color' needs a 'subsurface' entry given by a colour",
            ),
        ];
        for (json, want) in cases {
            let e = parse(json).expect_err(json);
            assert!(e.contains(want), "{json}\n got: {e}\nwant: {want}");
            assert!(!e.contains('\n'), "multi-line error: {e}");
        }
    }

    #[test]
    fn blender_walk_colour_and_radius() {
        let f = parse(r#"{"version":1,"materials":{"Skin":{"subsurface":{"color":[0.8,0.5,0.3],"radius":[1,0.5,0.2],"skin":true,"method":"random_walk","g":0.2}}}}"#)
            .unwrap();
        let MaterialOverride::Subsurface(s) = &f.materials[0].1 else {
            panic!()
        };
        assert_eq!(
            s.coefficients,
            SubsurfaceCoefficients::CyclesWalk {
                color: Vec3::new(0.8, 0.5, 0.3),
                radius: Vec3::new(1.0, 0.5, 0.2),
                skin: true
            }
        );
        assert_eq!(s.method, "random_walk");
    }

    #[test]
    fn defaults() {
        let f = parse(r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1"}}},"world":{"color":[1,1,1]}}"#)
            .unwrap();
        let MaterialOverride::Subsurface(s) = &f.materials[0].1 else {
            panic!()
        };
        assert_eq!(s.scale, 1.0);
        assert_eq!(s.eta, 1.33);
        assert_eq!(s.g, 0.0);
        assert_eq!(s.roughness, 0.0);
        assert_eq!(s.method, "table");
        assert_eq!(s.boundary, "dielectric");
        assert_eq!(f.world.as_ref().unwrap().strength, 1.0);
        assert_eq!(s.ior, None);
        let f = parse(
            r#"{"version":1,"world":{"texture":"sky/a.EXR","strength":2,"rotation_z":-1.5},
                "camera":{"aperture_radius":0.05,"focus_distance":3}}"#,
        )
        .unwrap();
        let w = f.world.as_ref().unwrap();
        assert_eq!((w.color, w.strength), (Vec3::ONE, 2.0));
        assert!(w.texture.is_none(), "parse_materials_json decodes no image");
        let t = f.world_texture.as_ref().unwrap();
        assert_eq!((t.path.as_str(), t.rotation_z), ("sky/a.EXR", -1.5));
        let c = f.camera.unwrap().lens.unwrap();
        assert_eq!((c.aperture_radius, c.focus_distance), (0.05, 3.0));
        let c = parse(
            r#"{"version":1,"camera":{"shift":[0.25,-0.1],"projection":"equirectangular",
                "longitude":[-1,2]}}"#,
        )
        .unwrap()
        .camera
        .unwrap();
        assert_eq!(c.lens, None);
        assert_eq!(c.shift, Vec2::new(0.25, -0.1));
        let pi = std::f32::consts::PI;
        assert_eq!(
            c.panorama,
            Some(PanoramaDesc::Equirectangular {
                longitude: (-1.0, 2.0),
                latitude: (-pi / 2.0, pi / 2.0)
            })
        );
        let f = parse(r#"{"version":1}"#).unwrap();
        assert!(f.world.is_none());
        assert!(f.world_texture.is_none() && f.camera.is_none());
        assert!(f.materials.is_empty());
        assert_eq!(f.render.wavelength_pdf, None);
    }

    #[test]
    fn ior_forms() {
        let dielectric = |body: &str| -> IorDesc {
            let f = parse(&format!(
                r#"{{"version":1,"materials":{{"Diamond":{{"dielectric":{body}}}}}}}"#
            ))
            .unwrap();
            let MaterialOverride::Dielectric(d) = &f.materials[0].1 else {
                panic!()
            };
            d.ior
        };
        assert_eq!(dielectric(r#"{"ior":1.5}"#), IorDesc::Constant(1.5));
        assert_eq!(
            dielectric(r#"{"cauchy":{"a":1.5,"b":0.004}}"#),
            IorDesc::Cauchy {
                a: 1.5,
                b: 0.004,
                c: 0.0
            }
        );
        assert_eq!(
            dielectric(r#"{"preset":"bk7"}"#),
            IorDesc::preset("BK7").unwrap()
        );
        assert_eq!(
            dielectric(r#"{"abbe":{"ior":1.5168,"abbe":64.17}}"#),
            IorDesc::Abbe {
                n_d: 1.5168,
                v_d: 64.17
            }
        );
        let s = dielectric(
            r#"{"sellmeier":{"b":[1.03961212,0.231792344,1.01046945],"c":[0.00600069867,0.0200179144,103.560653]}}"#,
        );
        assert_eq!(
            s,
            IorDesc::preset("BK7").unwrap(),
            "full f64 precision kept"
        );

        let f = parse(
            r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","ior":{"preset":"water"}}}},
                "render":{"wavelength_pdf":"uniform"}}"#,
        )
        .unwrap();
        let MaterialOverride::Subsurface(s) = &f.materials[0].1 else {
            panic!()
        };
        let water = IorDesc::preset("water").unwrap();
        assert_eq!(s.ior, Some(water));
        assert_eq!(s.eta, water.n_d(), "the BSSRDF's scalar eta is n_d");
        assert_eq!(s.boundary_ior(), water);
        assert_eq!(f.render.wavelength_pdf.as_deref(), Some("uniform"));
        let f = parse(
            r#"{"version":1,"materials":{"Skin":{"subsurface":{"preset":"Skin1","ior":1.4}}}}"#,
        )
        .unwrap();
        let MaterialOverride::Subsurface(s) = &f.materials[0].1 else {
            panic!()
        };
        assert_eq!((s.eta, s.ior), (1.4, Some(IorDesc::Constant(1.4))));
    }
}
