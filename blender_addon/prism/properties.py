# SPDX-License-Identifier: MIT
"""Prism settings stored in .blend files: Scene.prism (render) and Material.prism (overrides)."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty, PointerProperty

SSS_PRESETS = [
    (n, n, "Measured medium (Jensen et al. 2001)")
    for n in (
        "Apple", "Chicken1", "Chicken2", "Cream", "Ketchup", "Marble",
        "Potato", "Skimmilk", "Skin1", "Skin2", "Spectralon", "Wholemilk",
    )
]

GLASS_PRESET_ITEMS = [
    ("BK7", "BK7", "Borosilicate crown glass, n_d 1.5168, V_d 64.17"),
    ("FUSED_SILICA", "Fused silica", "n_d 1.4585, V_d 67.82"),
    ("F2", "F2 flint", "n_d 1.6200, V_d 36.37"),
    ("SF11", "SF11 dense flint", "n_d 1.7847, V_d 25.68"),
    ("DIAMOND", "Diamond", "n_d 2.4175, V_d 55.3"),
    ("WATER", "Water", "20 degrees C, n_d 1.3330, V_d 55.8"),
]


class PrismRenderSettings(bpy.types.PropertyGroup):
    samples: IntProperty(
        name="Samples",
        description="Samples per pixel (the maximum when the noise threshold is on)",
        default=64,
        min=1,
        max=1 << 20,
    )
    preview_samples: IntProperty(
        name="Viewport Samples",
        description="Samples per pixel of the rendered viewport (0 = keep refining until the view changes)",
        default=1024,
        min=0,
        max=1 << 20,
    )
    preview_start_resolution: IntProperty(
        name="Start Pixels",
        description="Largest side of the viewport's first, coarse image after an edit (it then doubles to the full "
        "size), as Cycles' Start Pixels",
        default=64,
        min=8,
        max=16384,
    )
    use_preview_denoising: BoolProperty(
        name="Viewport Denoise",
        description="Denoise the rendered viewport with Open Image Denoise (the one Blender ships), as Cycles' "
        "Sampling > Viewport > Denoise",
        default=False,
    )
    preview_denoising_start_sample: IntProperty(
        name="Start Sample",
        description="Denoise the viewport from this many samples on (before: the noisy image)",
        default=1,
        min=1,
        max=1 << 20,
    )
    use_adaptive_sampling: BoolProperty(
        name="Noise Threshold",
        description="Adaptive sampling: stop sampling pixels whose estimated noise is below the threshold "
        "(the same error measure and threshold scale as Cycles)",
        default=True,
    )
    adaptive_threshold: FloatProperty(
        name="Noise Threshold",
        description="Noise level at which a pixel stops sampling (Cycles' default: 0.01); lower is cleaner "
        "and slower",
        default=0.01,
        min=0.0001,
        max=1.0,
        precision=4,
    )
    adaptive_min_samples: IntProperty(
        name="Min Samples",
        description="Samples every pixel takes before the noise threshold is tested (0 = automatic)",
        default=0,
        min=0,
        max=1 << 20,
    )
    time_limit: FloatProperty(
        name="Time Limit",
        description="Stop rendering after this time (0 = no limit); the image then has fewer samples",
        default=0.0,
        min=0.0,
        subtype="TIME_ABSOLUTE",
        unit="TIME_ABSOLUTE",
    )
    max_depth: IntProperty(
        name="Max Depth",
        description="Maximum path depth: 1 = direct light only (pbrt's maxdepth); "
        "Cycles' Max Bounces B corresponds to depth B + 1",
        default=16,
        min=1,
        max=1024,
    )
    wavelengths: EnumProperty(
        name="Wavelengths",
        description="How each path's wavelengths are chosen",
        items=[
            ("HERO", "Hero", "Four wavelengths per path, hero-wavelength rotation with spectral MIS (default)"),
            ("SINGLE", "Single", "One wavelength per path, drawn independently"),
            ("STRATIFIED", "Stratified", "One wavelength per path, stratified over a pixel's samples"),
        ],
        default="HERO",
    )
    wavelength_pdf: EnumProperty(
        name="Wavelength Density",
        description="Density the wavelengths are drawn from",
        items=[
            ("RGB", "RGB", "Least colour noise in the Rec.709 image (default)"),
            ("VISIBLE", "Visible", "A bell over the visible band, tuned for luminance noise"),
            ("UNIFORM", "Uniform", "Uniform over 360-830 nm"),
        ],
        default="RGB",
    )
    filter_type: EnumProperty(
        name="Pixel Filter",
        description="Pixel reconstruction filter (the same filters and widths as Cycles)",
        items=[
            ("BOX", "Box", "Uniform over the width (1 px: plain jitter inside the pixel)"),
            ("GAUSSIAN", "Gaussian", "Gaussian with sigma = width / 4"),
            ("BLACKMAN_HARRIS", "Blackman-Harris", "Blackman-Harris window over +-width (default, as Cycles)"),
        ],
        default="BLACKMAN_HARRIS",
    )
    filter_width: FloatProperty(
        name="Width",
        description="Pixel filter width in pixels, as Cycles' Film > Pixel Filter > Width",
        default=1.5,
        min=0.01,
        max=10.0,
        subtype="PIXEL",
    )
    path_splits: IntProperty(
        name="Path Splitting",
        description="Branches a camera path takes at its first diffuse, glossy or subsurface hit (Cycles' former "
        "branched path tracing): 0 = light samples and bounces planned apart per 8 x 8 pixels from the first "
        "samples, 1-4 of each where it pays (default; not below 16 samples), 1 = no splitting, 2-4 = that many "
        "branches everywhere, each with its own light sample and bounce",
        default=0,
        min=0,
        max=4,
    )
    use_caustic_guiding: BoolProperty(
        name="Caustic Guiding",
        description="Trace photons from the lights (the sun, lamps, small area lights) through sharp metals "
        "(roughness 0.1-0.3) and glass (0.03-0.3) before rendering, and send 15-35% of the bounces at diffuse and "
        "rough surfaces where their caustics come from: the sun's glint of a chrome or gold ball on the floor is "
        "found on purpose instead of by chance (unbiased). The first samples tell where that removes noise; "
        "elsewhere guiding stops",
        default=True,
    )
    threads: IntProperty(name="Threads", description="Worker threads (0 = all cores)", default=0, min=0, max=1024)
    use_denoising: BoolProperty(
        name="Denoise",
        description="Denoise the final render with Intel Open Image Denoise (the library that ships with "
        "Blender), guided by albedo and normals; the noisy image is kept in the Noisy Image pass",
        default=True,
    )
    denoising_prefilter: EnumProperty(
        name="Prefilter",
        description="How the albedo and normal guides are used, as Cycles' Denoise > Prefilter",
        items=[
            ("NONE", "None", "The guides are used as they are and taken as noise-free"),
            ("FAST", "Fast", "Denoise the image and the guides together (one pass)"),
            ("ACCURATE", "Accurate", "Denoise the guides first, then the image (the best result, three passes)"),
        ],
        default="ACCURATE",
    )
    denoising_quality: EnumProperty(
        name="Quality",
        description="Open Image Denoise's quality, as Cycles' Denoise > Quality",
        items=[
            ("HIGH", "High", "The best quality"),
            ("BALANCED", "Balanced", "About twice as fast, slightly softer"),
            ("FAST", "Fast", "The fastest"),
        ],
        default="HIGH",
    )
    denoise_previews: BoolProperty(
        name="Denoise Previews",
        description="Also denoise the progressive previews shown while rendering (slower updates)",
        default=False,
    )
    clamp_direct: FloatProperty(
        name="Direct Light",
        description="Limit the luminance a sample's direct light (at most one bounce) contributes, "
        "removing fireflies at the cost of energy (0 = off: unbiased). Cycles limits R + G + B, "
        "about 3x the luminance for white light",
        default=0.0,
        min=0.0,
    )
    clamp_indirect: FloatProperty(
        name="Indirect Light",
        description="Limit the luminance a sample's indirect light (two or more bounces) contributes, "
        "removing fireflies at the cost of energy (0 = off: unbiased). Cycles limits R + G + B, "
        "about 3x the luminance for white light",
        default=0.0,
        min=0.0,
    )
    denoising_data: BoolProperty(
        name="Denoising Data",
        description="Write Denoising Normal, Denoising Albedo and Denoising Depth passes (first "
        "non-mirror surface) for the compositor's Denoise node",
        default=False,
    )
    seed: IntProperty(name="Seed", description="Random seed", default=0, min=0)
    bake_unsupported_nodes: BoolProperty(
        name="Bake Unsupported Nodes",
        description="Bake the output of shader nodes Prism cannot evaluate (Gabor, Musgrave, Attribute, "
        "Vector Rotate, Ambient Occlusion, ...) with Cycles into a texture over the mesh's active UV map, "
        "instead of using the input's own value (final renders only; cached between renders)",
        default=True,
    )
    bake_resolution: EnumProperty(
        name="Resolution",
        description="Width and height of each baked texture",
        items=[(str(n), "%d px" % n, "%d x %d texels" % (n, n)) for n in (256, 512, 1024, 2048, 4096)],
        default="1024",
    )


class PrismMaterialSettings(bpy.types.PropertyGroup):
    sss_mode: EnumProperty(
        name="Subsurface",
        description="Override the surface with a subsurface-scattering medium",
        items=[
            ("NONE", "None", "Use the node tree (Principled subsurface is converted)"),
            ("PRESET", "Measured Preset", "A measured medium"),
            ("EXPLICIT", "Explicit", "Explicit absorption and scattering coefficients"),
        ],
        default="NONE",
    )
    sss_preset: EnumProperty(name="Preset", items=SSS_PRESETS, default="Marble")
    sigma_a: FloatVectorProperty(name="Absorption", description="sigma_a per RGB channel (per unit, before scale)", size=3, min=0.0, default=(0.0021, 0.0041, 0.0071))
    sigma_s: FloatVectorProperty(name="Scattering", description="sigma_s per RGB channel (per unit, before scale)", size=3, min=0.0, default=(2.19, 2.62, 3.00))
    sss_scale: FloatProperty(name="Scale", description="Multiplies the coefficients (1000: mm^-1 to m^-1)", default=1000.0, min=0.0)
    sss_eta: FloatProperty(name="IOR", description="Boundary index of refraction", default=1.33, min=1.0, max=4.0)
    sss_g: FloatProperty(name="Anisotropy", description="Henyey-Greenstein g", default=0.0, min=-0.99, max=0.99)

    dispersion_mode: EnumProperty(
        name="Dispersion",
        description="Make the material a dispersive dielectric",
        items=[
            ("NONE", "None", "No dispersion"),
            ("CAUCHY", "Cauchy", "n(lambda) = A + B / lambda^2, lambda in micrometres"),
            ("ABBE", "Abbe Number", "From n_d and the Abbe number V_d"),
            ("GLASS", "Glass Preset", "A catalogue glass"),
        ],
        default="NONE",
    )
    cauchy_a: FloatProperty(name="A", default=1.5046, min=1.0, max=4.0, precision=4)
    cauchy_b: FloatProperty(name="B", description="um^2", default=0.0042, min=0.0, max=1.0, precision=5)
    abbe_nd: FloatProperty(name="n_d", default=1.5168, min=1.0, max=4.0, precision=4)
    abbe_number: FloatProperty(name="Abbe V_d", default=64.17, min=1.0, max=200.0)
    glass_preset: EnumProperty(name="Glass", items=GLASS_PRESET_ITEMS, default="BK7")
    dispersion_roughness: FloatProperty(name="Roughness", default=0.0, min=0.0, max=1.0)


classes = (PrismRenderSettings, PrismMaterialSettings)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.prism = PointerProperty(type=PrismRenderSettings)
    bpy.types.Material.prism = PointerProperty(type=PrismMaterialSettings)


def unregister():
    del bpy.types.Material.prism
    del bpy.types.Scene.prism
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
