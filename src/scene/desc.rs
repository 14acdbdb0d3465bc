//! Plain-data description of a scene as read from files (glTF + material JSON), before any
//! acceleration structure or spectral upsampling. The loaders produce it, `Scene::build`
//! consumes it; tests can also build one by hand.

use glam::{Mat4, Vec2, Vec3, Vec4};

/// One triangle mesh in object space (a glTF primitive).
#[derive(Clone, Debug, Default)]
pub struct MeshDesc {
    /// For messages: "mesh 'Name' primitive 0".
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (object space), if the file has them.
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// Per-vertex tangents (object space) from the glTF `TANGENT` attribute: xyz = unit
    /// tangent along +u, w = +-1 bitangent sign (glTF 2.0 spec 3.7.2.1: bitangent =
    /// cross(normal, tangent.xyz) * w). `None`: tangents are derived from the UVs per triangle
    /// when a normal map needs them.
    pub tangents: Option<Vec<Vec4>>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// TEXCOORD_1.. (index 0 = TEXCOORD_1), per vertex; `None` where the set is absent.
    pub extra_uvs: Vec<Option<Vec<Vec2>>>,
    /// COLOR_0.. as linear RGBA per vertex (RGB sets get alpha 1); `None` where absent.
    pub colors: Vec<Option<Vec<Vec4>>>,
    /// Index into `SceneDesc::materials`; `None` = the glTF default material.
    pub material: Option<usize>,
    /// Deformation motion blur: the vertices at equally spaced times over the shutter.
    pub deformation: Option<DeformationDesc>,
}

/// Vertex positions (and shading normals) of a deforming mesh (armature, shape keys) at
/// `positions.len()` >= 2 equally spaced times from shutter open to close, per vertex of the
/// mesh (`MeshDesc::positions` is the mesh at the current frame).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeformationDesc {
    pub positions: Vec<Vec<Vec3>>,
    pub normals: Option<Vec<Vec<Vec3>>>,
}

/// A placement of a mesh in the world. Several instances may share one mesh.
#[derive(Clone, Debug)]
pub struct InstanceDesc {
    pub mesh: usize,
    pub object_to_world: Mat4,
    /// Node name, for messages.
    pub name: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorSpace {
    /// 8-bit sRGB-encoded colour (baseColor, emissive): decoded to linear at load.
    Srgb,
    /// Linear data (metallicRoughness, normal maps).
    Linear,
}

/// A glTF texture: a decoded image (linear values, row 0 = top) and its sampler.
#[derive(Clone, Debug)]
pub struct TextureDesc {
    pub image: std::sync::Arc<crate::shading::image::Image>,
    /// The sampler's wrapS and wrapT (REPEAT, CLAMP_TO_EDGE = Extend, MIRRORED_REPEAT).
    pub wrap: [crate::shading::image::Extension; 2],
    /// Nearest-neighbour (false) or bilinear (true) magnification.
    pub bilinear: bool,
    /// The texels were decoded from an 8-bit sRGB-encoded image (baseColor, emissive).
    pub from_srgb_bytes: bool,
}

impl TextureDesc {
    /// Linear texels, row 0 = top, under the sampler `wrap` / `bilinear`.
    pub fn new(
        name: String,
        width: u32,
        height: u32,
        texels: Vec<Vec4>,
        wrap: [crate::shading::image::Extension; 2],
        bilinear: bool,
    ) -> Self {
        TextureDesc {
            image: std::sync::Arc::new(crate::shading::image::Image {
                name,
                width,
                height,
                texels,
                srgb_encoded: false,
            }),
            wrap,
            bilinear,
            from_srgb_bytes: false,
        }
    }

    /// Filters an 8-bit sRGB texture as Cycles does: in its encoded values, decoding after
    /// (Cycles keeps such images "compressed as sRGB" and converts the filtered value,
    /// `NODE_IMAGE_COMPRESS_AS_SRGB`). The glTF specification asks for the opposite, decoding
    /// before filtering (what the importer does, and Khronos' TextureLinearInterpolationTest
    /// checks). The two differ wherever neighbouring texels differ: filtered in encoded values,
    /// the blend between a 0.8 and a 0.1 texel is darker (sRGB decoding is convex), and a
    /// magnified high-contrast checker reads about 3% darker over a floor. Texels that did
    /// not come from 8-bit sRGB are left as they are.
    pub fn filter_encoded_as_cycles(&mut self) {
        if !self.from_srgb_bytes || self.image.srgb_encoded {
            return;
        }
        use crate::spectrum::rgb::linear_to_srgb;
        let img = &self.image;
        // Re-encoding the decoded 8-bit values is exact to float rounding (~1e-7).
        let texels = img
            .texels
            .iter()
            .map(|t| {
                Vec4::new(
                    linear_to_srgb(t.x),
                    linear_to_srgb(t.y),
                    linear_to_srgb(t.z),
                    t.w,
                )
            })
            .collect();
        self.image = std::sync::Arc::new(crate::shading::image::Image {
            name: img.name.clone(),
            width: img.width,
            height: img.height,
            texels,
            srgb_encoded: true,
        });
    }

    pub fn interpolation(&self) -> crate::shading::image::Interpolation {
        if self.bilinear {
            crate::shading::image::Interpolation::Linear
        } else {
            crate::shading::image::Interpolation::Closest
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub struct TextureRef {
    pub texture: usize,
    /// Which TEXCOORD_n set (0 to `shading::MAX_ATTRIBUTE_SETS - 1`).
    pub tex_coord: u32,
    /// KHR_texture_transform as a 3x3 (affine, column-major) UV matrix.
    pub uv_transform: glam::Mat3,
}

/// The material as glTF's metallic-roughness model (+ KHR extensions) describes it.
#[derive(Clone, Debug)]
pub struct GltfMaterialDesc {
    pub name: String,
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    pub roughness: f32,
    /// Blue channel = metallic, green = roughness (glTF spec).
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Linear RGB radiance scale: emissiveFactor x KHR_materials_emissive_strength.
    pub emissive: Vec3,
    pub emissive_texture: Option<TextureRef>,
    /// Tangent-space normal map (glTF `normalTexture`, linear texels).
    pub normal_texture: Option<TextureRef>,
    /// `normalTexture.scale`: multiplies the map's X and Y (glTF 2.0 spec 5.23).
    pub normal_scale: f32,
    /// KHR_materials_specular (defaults 1 and white).
    pub specular: f32,
    pub specular_color: Vec3,
    /// KHR_materials_transmission (0 = opaque).
    pub transmission: f32,
    /// KHR_materials_ior (1.5 when absent).
    pub ior: f32,
    /// KHR_materials_dispersion: 20 / V_d (Abbe number), 0 = no dispersion (the default).
    /// The loader has validated it; `ior_model` turns (ior, dispersion) into an IOR model.
    pub dispersion: f32,
    /// KHR_materials_volume: Beer-Lambert absorption inside the closed object.
    pub attenuation_color: Vec3,
    pub attenuation_distance: f32,
    pub double_sided: bool,
    /// glTF alphaMode: opaque, MASK (coverage = alpha >= `alpha_cutoff`) or BLEND
    /// (coverage = alpha); alpha = baseColorFactor.a x the base colour texture's alpha.
    pub alpha_mode: AlphaMode,
    pub alpha_cutoff: f32,
    /// KHR_materials_clearcoat `clearcoatFactor` (0 = no coat; Blender's Coat Weight).
    pub coat: f32,
    /// `clearcoatRoughnessFactor` (perceptual).
    pub coat_roughness: f32,
    /// The coat's IOR (material extras `prism_coat_ior`, Blender's Coat IOR; the extension's
    /// fixed 1.5 otherwise).
    pub coat_ior: f32,
    /// Colour after one vertical pass through the coat (extras `prism_coat_tint`, Blender's
    /// Coat Tint; white otherwise).
    pub coat_tint: Vec3,
    /// The coat adds to the base without dimming it (extras `prism_coat_additive`: Blender
    /// 3.x's Clearcoat, as Cycles 3.x renders it).
    pub coat_additive: bool,
    /// KHR_materials_sheen `sheenColorFactor` (linear RGB; black = no sheen; Blender's Sheen
    /// Weight x Sheen Tint).
    pub sheen_color: Vec3,
    /// `sheenRoughnessFactor` (perceptual; Blender's Sheen Roughness).
    pub sheen_roughness: f32,
    /// `clearcoatTexture` (R multiplies the coat factor) and `clearcoatRoughnessTexture` (G
    /// multiplies its roughness), linear.
    pub coat_texture: Option<TextureRef>,
    pub coat_roughness_texture: Option<TextureRef>,
    /// `clearcoatNormalTexture` (tangent space on TEXCOORD_0, as `normal_texture`) and its
    /// scale: the coat's own normal (without it the coat keeps the unperturbed normal).
    pub coat_normal_texture: Option<TextureRef>,
    pub coat_normal_scale: f32,
    /// `sheenColorTexture` (sRGB, RGB multiplies the colour) and `sheenRoughnessTexture` (A
    /// multiplies the roughness, linear).
    pub sheen_color_texture: Option<TextureRef>,
    pub sheen_roughness_texture: Option<TextureRef>,
    /// KHR_materials_iridescence `iridescenceFactor` (0 = none; Blender's Thin Film: 1).
    pub iridescence: f32,
    /// `iridescenceIor` (default 1.3; Blender's Thin Film IOR).
    pub iridescence_ior: f32,
    /// The film's thickness in nm: `iridescenceThicknessMaximum` (default 400; Blender's Thin
    /// Film Thickness), the extension's thickness without a thickness texture.
    pub iridescence_thickness: f32,
    /// `iridescenceThicknessMinimum` (default 100): with `iridescence_thickness_texture`, the
    /// thickness is mix(minimum, maximum, G).
    pub iridescence_thickness_min: f32,
    /// `iridescenceTexture` (R multiplies the factor) and `iridescenceThicknessTexture` (G
    /// interpolates the thickness), linear.
    pub iridescence_texture: Option<TextureRef>,
    pub iridescence_thickness_texture: Option<TextureRef>,
    /// KHR_materials_transmission `transmissionTexture` (R multiplies the factor, linear).
    pub transmission_texture: Option<TextureRef>,
    /// KHR_materials_specular `specularTexture` (A multiplies `specular`, linear) and
    /// `specularColorTexture` (RGB multiplies `specular_color`, sRGB).
    pub specular_texture: Option<TextureRef>,
    pub specular_color_texture: Option<TextureRef>,
    /// Blender's area light Spread (extras `prism_emission_spread`, radians, full angle):
    /// the emission narrows to a cone of that angle around the normal (`crate::lights::spread`);
    /// pi (the default) is the Lambertian emitter.
    pub emission_spread: f32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlphaMode {
    Opaque,
    Mask,
    Blend,
}

impl Default for GltfMaterialDesc {
    fn default() -> Self {
        GltfMaterialDesc {
            name: String::new(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            specular: 1.0,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
            dispersion: 0.0,
            attenuation_color: Vec3::ONE,
            attenuation_distance: f32::INFINITY,
            double_sided: false,
            coat: 0.0,
            coat_roughness: 0.0,
            coat_ior: 1.5,
            coat_tint: Vec3::ONE,
            coat_additive: false,
            sheen_color: Vec3::ZERO,
            sheen_roughness: 0.0,
            coat_texture: None,
            coat_roughness_texture: None,
            coat_normal_texture: None,
            coat_normal_scale: 1.0,
            sheen_color_texture: None,
            sheen_roughness_texture: None,
            iridescence: 0.0,
            iridescence_ior: 1.3,
            iridescence_thickness: 400.0,
            iridescence_thickness_min: 100.0,
            iridescence_texture: None,
            iridescence_thickness_texture: None,
            transmission_texture: None,
            specular_texture: None,
            specular_color_texture: None,
            emission_spread: std::f32::consts::PI,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
        }
    }
}

/// Index of refraction as a function of wavelength: the one model of `crate::spectrum::dispersion`
/// (constant, Cauchy, Sellmeier, Abbe form, glass presets), under the name scene code uses.
pub use crate::spectrum::dispersion::IorModel as IorDesc;

impl GltfMaterialDesc {
    /// The transmissive part's IOR: the Abbe form with n_d = `ior` and V_d = 20 / `dispersion`
    /// when `dispersion` > 0, else the constant `ior`. Falls back to the constant if the pair is
    /// invalid (the glTF loader rejects such files; hand-built descriptions may not).
    ///
    /// KHR_materials_ior's `ior = 0` means F0 = 1: the limit of an ever denser dielectric,
    /// which refraction gets as [`IOR_ZERO_LIMIT`] (F0 = 0.9996; the metallic-roughness BRDF
    /// takes the exact limit from `ior` = 0 itself).
    pub fn ior_model(&self) -> IorDesc {
        if self.ior == 0.0 {
            return IorDesc::Constant(IOR_ZERO_LIMIT);
        }
        IorDesc::from_gltf(self.ior, self.dispersion).unwrap_or(IorDesc::Constant(self.ior))
    }
}

/// The refractive index that stands for KHR_materials_ior's `ior = 0` (F0 = 1) in refraction.
pub const IOR_ZERO_LIMIT: f32 = 1.0e4;

/// Measured or explicit participating medium of a subsurface material (consumed by the BSSRDF).
#[derive(Clone, Debug, PartialEq)]
pub enum SubsurfaceCoefficients {
    /// Jensen et al. 2001 table entry by name (sigma_s', sigma_a in mm^-1).
    Preset(String),
    /// Coefficients per RGB channel in 1/scene-unit before `scale`.
    Explicit { sigma_a: Vec3, sigma_s: Vec3 },
    /// Diffuse reflectance and mean free path per channel (scene units), inverted by the BSSRDF.
    Reflectance { reflectance: Vec3, mfp: Vec3 },
    /// Blender's subsurface colour and radius per channel (scene units) for its random walk
    /// (`crate::bssrdf::media::cycles_walk`); `skin`: Random Walk (Skin)'s radius adjustment.
    CyclesWalk {
        color: Vec3,
        radius: Vec3,
        skin: bool,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct SubsurfaceDesc {
    pub coefficients: SubsurfaceCoefficients,
    /// Multiplies coefficients (e.g. 1000 turns mm^-1 into m^-1 for a scene in metres).
    pub scale: f32,
    /// Scalar IOR of the boundary, used by the BSSRDF's profile and Fresnel terms. When `ior`
    /// is given this is its `n_d()`.
    pub eta: f32,
    /// Optional spectral IOR of the boundary (sidecar `subsurface.ior`); `None` = constant `eta`.
    pub ior: Option<IorDesc>,
    pub g: f32,
    pub roughness: f32,
    /// "table" (photon beam diffusion) or "random_walk".
    pub method: String,
    /// Random walk only: "dielectric" (default) or "lambertian" (`crate::bssrdf::WalkBoundary`).
    pub boundary: String,
    /// Fraction of the surface that is subsurface scattering (Blender's Principled
    /// "Subsurface Weight"); the rest is the glTF surface model. 1 = all subsurface.
    pub weight: f32,
}

impl SubsurfaceDesc {
    /// The boundary dielectric's IOR model: `ior` if given, else the constant `eta`.
    pub fn boundary_ior(&self) -> IorDesc {
        self.ior.unwrap_or(IorDesc::Constant(self.eta))
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct DielectricDesc {
    pub ior: IorDesc,
    pub roughness: f32,
}

/// Sidecar override that replaces the glTF surface model of a material.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialOverride {
    Subsurface(SubsurfaceDesc),
    Dielectric(DielectricDesc),
}

#[derive(Clone, Debug, Default)]
pub struct MaterialDesc {
    pub gltf: GltfMaterialDesc,
    pub sidecar: Option<MaterialOverride>,
    /// A shading graph driving some of the material's inputs (material JSON `graph`).
    pub graph: Option<std::sync::Arc<crate::shading::ShadingGraph>>,
    /// A participating medium inside the material's closed meshes (material JSON `volume`).
    pub volume: Option<VolumeDesc>,
    /// The surface does not scatter: rays pass through it and only cross into or out of its
    /// volume (material JSON `"surface": "none"`; Blender: a material with only a Volume output).
    pub null_surface: bool,
    /// The glTF 2.0 spec's single-scattering BRDF as written, without energy compensation
    /// (material JSON `"model": "gltf"`); else Cycles' energy-conserving layering.
    pub gltf_brdf: bool,
    /// Blender 3.x's Principled BSDF as Cycles 3.x renders it (material JSON `"model":
    /// "principled_v1"`, which also sets `gltf_brdf`: single-scattering lobes): a Disney
    /// diffuse base the specular layer adds to (`crate::bsdf::metallic_roughness`).
    pub principled_v1: bool,
}

/// A homogeneous volume (`crate::media::Medium`): coefficients per scene unit in
/// linear RGB, upsampled per wavelength as unbounded spectra.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VolumeDesc {
    /// Absorption coefficient sigma_a.
    pub sigma_a: Vec3,
    /// Scattering coefficient sigma_s.
    pub sigma_s: Vec3,
    /// Henyey-Greenstein anisotropy in (-1, 1).
    pub g: f32,
    /// Emitted radiance per unit length.
    pub emission: Vec3,
    /// Where the material's graph drives `volume_color`: (sigma_a, sigma_s) where that colour
    /// is black; `sigma_a` and `sigma_s` above hold where it is white.
    pub color_zero: Option<(Vec3, Vec3)>,
}

#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum PunctualKind {
    /// Radiant intensity `intensity` (W/sr, Blender units) in all directions.
    #[default]
    Point,
    /// Cone with full intensity inside `inner` and a smooth fall-off to zero at `outer` (radians).
    Spot { inner_cone: f32, outer_cone: f32 },
    /// Irradiance `intensity` (W/m^2 on a surface facing it) from direction -`direction`.
    Directional,
}

/// A KHR_lights_punctual light in world space, intensities already converted to the renderer's
/// radiometric units (see the loader for the photometric -> radiometric convention).
#[derive(Clone, Debug, Default)]
pub struct PunctualLightDesc {
    pub name: String,
    pub kind: PunctualKind,
    pub color: Vec3,
    pub intensity: f32,
    pub position: Vec3,
    /// Direction the light points to (spot axis, directional travel direction), unit length.
    pub direction: Vec3,
    /// Angular diameter of a directional light (radians; Blender's sun angle): 0 for a
    /// parallel light, else a disc of directions (`lights::SunDisc`).
    pub angle: f32,
    /// Radius of a point or spot light (Blender's Radius): 0 for a true point, else a soft
    /// source of the same intensity (`lights::round`).
    pub radius: f32,
    /// Blender's Soft Falloff (its default): a radius-r disc facing the shading point instead
    /// of a sphere.
    pub soft_falloff: bool,
    /// Camera rays see the light's disc or sphere (Blender's Ray Visibility > Camera, off by
    /// default for lights).
    pub visible_camera: bool,
    /// A spot that also falls off with the cosine to its axis, as Blender 3.x's (Cycles
    /// before 4.0).
    pub spot_cosine: bool,
    /// Which scattering the light reaches (Blender's light Ray Visibility).
    pub ray_visibility: RayVisibility,
}

/// Which kinds of scattering see a light (defined with the lobe kinds it classifies).
pub use crate::bsdf::RayVisibility;

#[derive(Clone, Debug, Default)]
pub struct CameraDesc {
    pub name: String,
    /// Camera looks down its local -Z with +Y up (glTF).
    pub camera_to_world: Mat4,
    /// Vertical field of view in radians (perspective cameras; 0 for orthographic ones).
    pub yfov: f32,
    /// From the file; when `None` the image's aspect is used.
    pub aspect: Option<f32>,
    /// Orthographic camera: glTF (xmag, ymag), half the view's width and height in scene
    /// units. Only ymag is used; the width follows from the image aspect, as for `yfov`.
    pub orthographic: Option<Vec2>,
    /// Thin lens from the material JSON's `camera` block; `None` = pinhole.
    pub lens: Option<LensDesc>,
    /// Blender's lens shift: the view window moved by (x, y) x the view's height (perspective
    /// and orthographic cameras), from the material JSON's `camera.shift`.
    pub shift: Vec2,
    /// A panoramic projection (material JSON `camera.projection`) instead of the file's
    /// perspective or orthographic one.
    pub panorama: Option<PanoramaDesc>,
    /// Camera motion blur: `camera_to_world` at equally spaced times over the shutter (empty:
    /// the camera does not move).
    pub motion: Vec<Mat4>,
}

/// Cycles' panoramic cameras. The view axis is the camera's -Z, up its +Y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PanoramaDesc {
    /// Longitude (positive to the right) and latitude (positive up) ranges in radians across
    /// the image's width and height.
    Equirectangular {
        longitude: (f32, f32),
        latitude: (f32, f32),
    },
    /// Angle from the axis proportional to the distance from the image centre: `fov` (radians)
    /// across the ellipse inscribed in the image.
    FisheyeEquidistant { fov: f32 },
    /// A real equisolid fisheye lens: focal length `lens` and sensor `sensor` (mm, the sensor
    /// spanning the image), image circle of `fov` (radians).
    FisheyeEquisolid { fov: f32, lens: f32, sensor: Vec2 },
}

/// Thin-lens depth of field (scene units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensDesc {
    /// Radius of the aperture disk (0 = pinhole).
    pub aperture_radius: f32,
    /// Distance of the plane in focus along the view axis.
    pub focus_distance: f32,
}

/// An equirectangular world texture (see `crate::lights::envmap` for the mapping).
#[derive(Clone, Debug)]
pub struct EnvironmentTextureDesc {
    /// The file, for messages.
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row 0 = top (up), column 0 = u = 0.
    pub texels: Vec<Vec3>,
    /// Z rotation (radians) of Blender's Mapping node on the lookup vector.
    pub rotation_z: f32,
}

#[derive(Clone, Debug)]
pub struct WorldDesc {
    /// Uniform environment radiance (linear RGB) = color x strength; with a texture, the
    /// radiance is texture x color x strength.
    pub color: Vec3,
    pub strength: f32,
    pub texture: Option<EnvironmentTextureDesc>,
}

impl Default for WorldDesc {
    fn default() -> Self {
        WorldDesc {
            color: Vec3::ZERO,
            strength: 0.0,
            texture: None,
        }
    }
}

/// Render defaults carried by the material JSON's "render" block (CLI flags override them).
#[derive(Clone, Debug, Default)]
pub struct RenderDefaults {
    pub spp: Option<u32>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub max_depth: Option<u32>,
    pub wavelengths: Option<String>,
    /// `render.wavelength_pdf`: "visible" or "uniform" (validated by the sidecar parser).
    pub wavelength_pdf: Option<String>,
    /// `render.filter`: pixel filter type ("box" | "gaussian" | "blackman_harris") and width in
    /// pixels (Cycles' convention; validated by the sidecar parser).
    pub filter: Option<(String, f32)>,
    /// `render.sampler`: "sobol" or "independent" (validated by the sidecar parser).
    pub sampler: Option<String>,
    /// `render.light_sampler`: "tree", "tree-single" or "power" (validated by the sidecar
    /// parser).
    pub light_sampler: Option<String>,
    /// `render.noise_threshold` (>= 0; 0 = no adaptive sampling), `render.min_samples`
    /// (0 = automatic) and `render.time_limit` (seconds, 0 = none).
    pub noise_threshold: Option<f32>,
    pub min_samples: Option<u32>,
    pub time_limit: Option<f64>,
    /// `render.splits`: branches per camera path at its first vertex, 0 for "auto" (planned),
    /// else 1-4 (validated by the sidecar parser).
    pub splits: Option<u32>,
    /// `render.denoise`: denoise the final image with OIDN; `render.denoise_quality` ("high" |
    /// "balanced" | "fast") and `render.denoise_prefilter` ("accurate" | "fast" | "none"),
    /// validated by the sidecar parser.
    pub denoise: Option<bool>,
    pub denoise_quality: Option<String>,
    pub denoise_prefilter: Option<String>,
    /// `render.clamp_direct` / `render.clamp_indirect` (>= 0, 0 = off).
    pub clamp_direct: Option<f32>,
    pub clamp_indirect: Option<f32>,
    /// `render.film_transparent`: Blender's Film > Transparent.
    pub film_transparent: Option<bool>,
    /// `render.caustic_guiding` (`crate::integrator::caustics`; on by default).
    pub caustic_guiding: Option<bool>,
    /// `render.crop`: [x, y, width, height] window of the image to render (render border).
    pub crop: Option<[u32; 4]>,
    /// `render.texture_filtering`: "gltf" or "cycles" (validated by the sidecar parser; see
    /// `TextureDesc::filter_encoded_as_cycles`).
    pub texture_filtering: Option<String>,
}

#[derive(Clone, Debug, Default)]
pub struct SceneDesc {
    pub meshes: Vec<MeshDesc>,
    pub instances: Vec<InstanceDesc>,
    pub materials: Vec<MaterialDesc>,
    pub textures: Vec<TextureDesc>,
    pub lights: Vec<PunctualLightDesc>,
    pub camera: Option<CameraDesc>,
    pub world: WorldDesc,
    pub render: RenderDefaults,
    /// Warnings the loader wants the user to see once (skipped primitives, ...).
    pub warnings: Vec<String>,
    /// Ray visibility of `instances[i]` (shorter than `instances`: the rest are default).
    pub instance_visibility: Vec<InstanceVisibility>,
    /// Transform motion blur: `instances[i]`'s object-to-world at equally spaced times over
    /// the shutter (at least two; shorter than `instances` or empty: the rest do not move).
    pub instance_motion: Vec<Vec<Mat4>>,
}

/// Ray visibility of an instance, from glTF node extras (the Blender add-on writes them for
/// area lights, which in Blender are not geometry): `"prism_area_light": true` makes the mesh
/// cast no shadows and hides it from camera rays unless `"prism_visible_camera": true`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InstanceVisibility {
    pub casts_shadows: bool,
    pub camera_visible: bool,
    /// A Blender light standing as a mesh (`"prism_area_light"`): rays that meet it take its
    /// emission and go on as if it were not there (lights are no geometry in Blender).
    pub light_only: bool,
    /// Blender's holdout (the object's, or a Holdout material's): a transparent hole.
    pub holdout: bool,
    /// An emitting instance's (an area light's) ray visibility as a light.
    pub light_visibility: RayVisibility,
}

impl Default for InstanceVisibility {
    fn default() -> Self {
        InstanceVisibility {
            casts_shadows: true,
            camera_visible: true,
            light_only: false,
            holdout: false,
            light_visibility: RayVisibility::ALL,
        }
    }
}
