# SPDX-License-Identifier: MIT
"""Writes the evaluated depsgraph as glTF 2.0 (.gltf + .bin) plus Prism's material JSON.

Blender's bundled glTF exporter cannot run inside RenderEngine.render() (it reads
bpy.context.active_object) and drops area lights and the world, so this module writes the
file itself from the depsgraph with numpy foreach_get.

Units (so that Prism renders what Cycles renders; Prism's README "Units"):
- point/spot light of P W: KHR_lights_punctual intensity = P / (4 pi) * 683 cd (Prism divides
  by 683), spot cone: outer = spot_size / 2, inner = outer - outer * spot_blend; its Radius,
  Soft Falloff and Camera visibility -> extras.prism_radius / prism_soft_falloff /
  prism_visible_camera (a disc or sphere of the same intensity, as Cycles');
- every light's colour x Temperature (5.0: temperature_color) x its node tree's Emission colour
  and strength (constant or Blackbody), power x 2^Exposure (5.0), Normalize off: power per
  unit area (Cycles' light conventions);
- sun of strength S: intensity = S * 683 lux; its angle (angular diameter) -> the light's
  extras.prism_angle (radians): a disc of directions of the same irradiance, as Cycles' sun;
- area light of P W and world-space area A: a one-sided emissive mesh facing the light's -Z
  with radiance P / (pi A) (Cycles' Lambertian area light; checked by the parity test);
- emission colour x strength is radiance (emissiveFactor x KHR_materials_emissive_strength);
- world colour x strength -> material JSON "world"; an equirectangular Environment Texture on the
  Background -> "world.texture" (a float EXR written next to the glTF) + a Mapping node's Z
  rotation -> "world.rotation_z";
- orthographic camera: xmag/ymag from ortho_scale and the sensor fit; depth of field -> material
  JSON "camera" {aperture_radius, focus_distance} (Cycles' thin lens).
Blender is Z-up and glTF Y-up: every node hangs below one root node that rotates Z-up to Y-up,
so object matrices are written unchanged.
"""

import copy
import json
import math
import os
import shutil
import struct
import subprocess
import zlib

import numpy as np

from .blackbody import blackbody_rgb
from .node_graph import GraphBuilder, resolve_bakes
from . import hair, motion, node_bake, world_bake
from .exr import write_exr_rgb

WATTS_TO_LUMENS = 683.0
GREY = (0.8, 0.8, 0.8)

# Material panel glass preset -> the renderer's preset name (Sellmeier coefficients live in
# src/spectrum/dispersion.rs).
GLASS_PRESETS = {
    "BK7": "BK7",
    "FUSED_SILICA": "fused_silica",
    "F2": "F2",
    "SF11": "SF11",
    "DIAMOND": "diamond",
    "WATER": "water",
}


class ExportError(Exception):
    pass


# ----------------------------------------------------------------------------- buffers


class _Buffer:
    def __init__(self):
        self.chunks = []
        self.size = 0
        self.views = []
        self.accessors = []

    def add(self, array, target=None):
        data = np.ascontiguousarray(array).tobytes()
        pad = (-self.size) % 4
        if pad:
            self.chunks.append(b"\0" * pad)
            self.size += pad
        view = {"buffer": 0, "byteOffset": self.size, "byteLength": len(data)}
        if target:
            view["target"] = target
        self.chunks.append(data)
        self.size += len(data)
        self.views.append(view)
        return len(self.views) - 1

    def accessor(self, array, kind, minmax=False, target=34962):
        comp = {np.dtype(np.float32): 5126, np.dtype(np.uint32): 5125}[array.dtype]
        view = self.add(array, target)
        acc = {"bufferView": view, "componentType": comp, "count": int(array.shape[0]), "type": kind}
        if minmax:
            # Reducing a contiguous transposed copy is ~10x faster than min(axis=0) on an
            # (N, 3) array (numpy's strided axis-0 reduction).
            columns = np.ascontiguousarray(array.T)
            acc["min"] = [float(x) for x in columns.min(axis=1)]
            acc["max"] = [float(x) for x in columns.max(axis=1)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _matrix(m):
    """Blender Matrix -> glTF column-major list."""
    return [float(m[r][c]) for c in range(4) for r in range(4)]


def _unscaled(m):
    loc, rot, _scale = m.decompose()
    out = rot.to_matrix().to_4x4()
    out.translation = loc
    return out


# ----------------------------------------------------------------------------- materials


def _socket(node, *names, default=None):
    """First input among `names` (Blender 3.x and 4.x+ spellings)."""
    for n in names:
        s = node.inputs.get(n)
        if s is not None:
            return s
    return default


def _val(node, *names, default=0.0):
    s = _socket(node, *names)
    if s is None:
        return default
    v = s.default_value
    try:
        return tuple(v)
    except TypeError:
        return float(v)


def bpy_version():
    import bpy

    return tuple(bpy.app.version)


def _rgb(v):
    return [float(v[0]), float(v[1]), float(v[2])]


def _linked_image(sock):
    """Image of an Image Texture node connected directly to `sock`, else None."""
    if sock is None or not sock.is_linked:
        return None
    node = sock.links[0].from_node
    if node.type == "TEX_IMAGE" and node.image is not None:
        return node.image
    return None


def _output_node(mat, socket="Surface"):
    """The node linked into the active Material Output's `socket` ("Surface" or "Volume"),
    through reroutes; None when nothing (or a muted link) is there."""
    nt = mat.node_tree if getattr(mat, "node_tree", None) is not None else None
    if nt is None:
        return None
    out = None
    for n in nt.nodes:
        if n.type == "OUTPUT_MATERIAL" and n.target in {"ALL", "CYCLES"}:
            if out is None or n.is_active_output:
                out = n
    if out is None:
        return None
    s = out.inputs.get(socket)
    for _ in range(64):
        if s is None or not s.is_linked or getattr(s.links[0], "is_muted", False):
            return None
        node = s.links[0].from_node
        if node.type != "REROUTE":
            return node
        s = node.inputs[0]
    return None


# Nodes whose lobe is a plain microfacet distribution, and the distributions of those without
# multiple scattering (Blender 3.x's defaults for Glass and Glossy).
_SINGLE_SCATTER_NODES = {"BSDF_GLASS", "BSDF_GLOSSY", "BSDF_ANISOTROPIC"}
_SINGLE_SCATTER_DISTRIBUTIONS = {"GGX", "BECKMANN", "ASHIKHMIN_SHIRLEY"}


def _surface_node(mat):
    return _output_node(mat, "Surface")


# The volume shader nodes the renderer takes (homogeneous: constant inputs), and how Cycles
# turns their inputs into coefficients per unit length (intern/cycles/kernel/svm/closure.h).
VOLUME_NODES = {"PRINCIPLED_VOLUME", "VOLUME_ABSORPTION", "VOLUME_SCATTER", "EMISSION", "ADD_SHADER", "MIX_SHADER"}


class VolumeLobe:
    """One volume closure's coefficients (RGB lists, scaled by its Mix/Add weights): sigma_a,
    sigma_s, anisotropy g, emission; `density`: the linked Density socket (the coefficients are
    then at density 1) or None; `color`: the linked Color socket or None, and `sigma_a0`,
    `sigma_s0` the coefficients where that colour is black (sigma_a, sigma_s hold where it is
    white; without a linked colour both pairs are equal)."""

    def __init__(self, sigma_a, sigma_s, g, emission, density=None, color=None, sigma_a0=None, sigma_s0=None):
        self.sigma_a, self.sigma_s, self.g, self.emission = sigma_a, sigma_s, g, emission
        self.density, self.color = density, color
        self.sigma_a0 = sigma_a if sigma_a0 is None else sigma_a0
        self.sigma_s0 = sigma_s if sigma_s0 is None else sigma_s0


# The volume closures whose coefficients are linear in their Color (Emission's Color is
# radiance, not a coefficient colour: it stays a constant).
COLOURED_VOLUME_NODES = {"PRINCIPLED_VOLUME", "VOLUME_SCATTER", "VOLUME_ABSORPTION"}


def volume_lobes(node, warn, weight=1.0, depth=0, densities=None, colors=None):
    """The volume shader tree at `node` -> [VolumeLobe], each already scaled by its Mix/Add
    weight; `warn(node, what)` names what is not translated. Coefficients are linear in the
    closures' weights, so mixtures add exactly; only the phase functions of several scattering
    lobes are merged into one (see `volume_json`). A linked Density (a texture: a heterogeneous
    volume) gives its lobe's coefficients at density 1 and the socket, which the caller binds
    to the graph's `volume_density`, when `densities` is True; a linked Color (of Principled
    Volume, Volume Scatter or Volume Absorption: their coefficients are linear in it per
    channel) gives the coefficients at white and at black and the socket, bound to
    `volume_color`, when `colors` is True. Otherwise a linked input is warned about and its
    value used."""
    zero = [0.0, 0.0, 0.0]
    if node is None or depth > 32 or weight <= 0.0:
        return []
    t = node.type
    linked_density = [None]
    linked_color = [None]

    def const(name, default):
        sock = _socket(node, name)
        if sock is None:
            return default
        if sock.is_linked:
            if name == "Density" and densities:
                linked_density[0] = sock
                return 1.0
            if name == "Color" and colors and t in COLOURED_VOLUME_NODES:
                linked_color[0] = sock
                return (1.0, 1.0, 1.0, 1.0)
            why = ("only Density and the Color of Principled Volume, Volume Scatter and Volume Absorption may vary in a volume"
                   if densities and (name != "Color" or t not in COLOURED_VOLUME_NODES)
                   else "only one Color may vary per volume" if densities
                   else "volumes are homogeneous here (no textures or attributes)")
            warn(node, "input '%s' is linked; %s, using its value" % (name, why))
        return sock.default_value

    def rgb(name, default=(1.0, 1.0, 1.0, 1.0)):
        return [max(float(c), 0.0) for c in list(const(name, default))[:3]]

    def lobe(sigma_a_of, sigma_s_of, color, g, emission):
        """A lobe whose coefficients are sigma_*_of(colour): at `color`, and (with a linked
        Color) at black."""
        black = linked_color[0] is not None
        return VolumeLobe(sigma_a_of(color), sigma_s_of(color), g, emission, linked_density[0],
                          linked_color[0], sigma_a_of(zero) if black else None,
                          sigma_s_of(zero) if black else None)

    if t == "PRINCIPLED_VOLUME":
        color = rgb("Color")
        density = weight * max(float(const("Density", 1.0)), 0.0)
        absorption_color = [math.sqrt(c) for c in rgb("Absorption Color", (0, 0, 0, 1))]

        def principled_s(col):
            return [density * c for c in col]

        def principled_a(col):
            return [density * max(1.0 - c, 0.0) * max(1.0 - a, 0.0) for c, a in zip(col, absorption_color)]
        strength = max(float(const("Emission Strength", 0.0)), 0.0)
        emission = [weight * strength * c for c in rgb("Emission Color")]
        blackbody = max(float(const("Blackbody Intensity", 0.0)), 0.0)
        if blackbody > 0.0:
            # Fire: Stefan-Boltzmann radiance sigma T^4 / pi (in Cycles' 1e-6 scale), blended
            # from 1 by the intensity, times the black body's luminance-1 colour and the tint.
            kelvin = max(float(const("Temperature", 1000.0)), 0.0)
            intensity = 5.670373e-8 * 1e-6 / math.pi * ((1.0 - blackbody) + blackbody * kelvin ** 4)
            bb = blackbody_rgb(kelvin) if kelvin > 0.0 else (0.0, 0.0, 0.0)
            tint = rgb("Blackbody Tint")
            emission = [e + weight * intensity * t * c for e, t, c in zip(emission, tint, bb)]
        return [lobe(principled_a, principled_s, color, float(const("Anisotropy", 0.0)), emission)]
    if t == "VOLUME_ABSORPTION":
        density = weight * max(float(const("Density", 1.0)), 0.0)
        color = rgb("Color")
        return [lobe(lambda col: [density * max(1.0 - c, 0.0) for c in col], lambda col: zero, color, 0.0, zero)]
    if t == "VOLUME_SCATTER":
        phase = getattr(node, "phase", "HENYEY_GREENSTEIN")
        if phase != "HENYEY_GREENSTEIN":
            warn(node, "phase function %s is not supported; using Henyey-Greenstein with its Anisotropy" % phase)
        density = weight * max(float(const("Density", 1.0)), 0.0)
        color = rgb("Color")
        return [lobe(lambda col: zero, lambda col: [density * c for c in col], color,
                     float(const("Anisotropy", 0.0)), zero)]
    if t == "EMISSION":
        strength = max(float(const("Strength", 1.0)), 0.0)
        return [VolumeLobe(zero, zero, 0.0, [weight * strength * c for c in rgb("Color")])]
    if t in {"ADD_SHADER", "MIX_SHADER"}:
        shaders = [s for s in node.inputs if s.type == "SHADER"]
        weights = [weight, weight]
        if t == "MIX_SHADER":
            fac = min(max(float(const("Fac", 0.5)), 0.0), 1.0)
            weights = [weight * (1.0 - fac), weight * fac]
        lobes = []
        for sock, w in zip(shaders, weights):
            if sock.is_linked and not getattr(sock.links[0], "is_muted", False):
                src = sock.links[0].from_node
                while src.type == "REROUTE" and src.inputs[0].is_linked:
                    src = src.inputs[0].links[0].from_node
                sub = volume_lobes(src, warn, w, depth + 1, densities, colors)
                if sub is None:
                    return None
                lobes += sub
        return lobes
    warn(node, "is not a supported volume shader (Principled Volume, Volume Absorption, Volume Scatter, Emission, Add/Mix Shader); the volume is ignored")
    return None


def volume_json(lobes, warn_merge):
    """Lobes -> the material JSON `volume` (an empty volume, density 0 or no lobes, stays: a
    surface-less material is still invisible). The renderer has one Henyey-Greenstein lobe per
    volume: several scattering lobes keep their summed sigma_s and get the sigma_s-weighted
    mean anisotropy (`warn_merge` is called when their anisotropies differ)."""
    sigma_a = [sum(l.sigma_a[i] for l in lobes) for i in range(3)]
    sigma_s = [sum(l.sigma_s[i] for l in lobes) for i in range(3)]
    emission = [sum(l.emission[i] for l in lobes) for i in range(3)]
    scatter_weights = [(sum(l.sigma_s) + sum(l.sigma_s0), l.g) for l in lobes if sum(l.sigma_s) + sum(l.sigma_s0) > 0.0]
    total = sum(w for w, _ in scatter_weights)
    g = sum(w * g for w, g in scatter_weights) / total if total > 0.0 else 0.0
    if len({round(g_, 4) for _, g_ in scatter_weights}) > 1:
        warn_merge()
    out = {"sigma_a": sigma_a, "sigma_s": sigma_s, "g": min(max(g, -0.99), 0.99)}
    if max(emission) > 0.0:
        out["emission"] = emission
    if any(l.color is not None for l in lobes):
        out["color_zero"] = {"sigma_a": [sum(l.sigma_a0[i] for l in lobes) for i in range(3)],
                             "sigma_s": [sum(l.sigma_s0[i] for l in lobes) for i in range(3)]}
    return out


def convert_material(mat):
    """Blender material -> (glTF-ish dict, subsurface dict or None, supported flag).

    The dict has keys: base, image, metallic, roughness, ior, transmission, emission,
    emission_strength, specular (KHR_materials_specular factor or None).
    """
    m = {
        "base": list(GREY),
        "image": None,
        "metallic": 0.0,
        "roughness": 0.5,
        "ior": 1.5,
        "transmission": 0.0,
        "emission": [0.0, 0.0, 0.0],
        "emission_strength": 1.0,
        "specular": None,
    }
    if mat is None:
        m["specular"] = 0.0
        m["roughness"] = 1.0
        return m, None, True
    node = _surface_node(mat)
    if node is None:
        if getattr(mat, "node_tree", None) is None or not getattr(mat, "use_nodes", True):
            m["base"] = _rgb(mat.diffuse_color)
            m["metallic"] = float(mat.metallic)
            m["roughness"] = float(mat.roughness)
            return m, None, True
        m["specular"] = 0.0
        return m, None, False
    t = node.type
    sss = None
    if t == "BSDF_PRINCIPLED":
        base_sock = _socket(node, "Base Color")
        m["image"] = _linked_image(base_sock)
        m["base"] = _rgb(base_sock.default_value)
        m["metallic"] = _val(node, "Metallic")
        m["roughness"] = _val(node, "Roughness")
        m["ior"] = _val(node, "IOR", default=1.5)
        m["transmission"] = _val(node, "Transmission Weight", "Transmission")
        em = _val(node, "Emission Color", "Emission", default=(0, 0, 0, 1))
        m["emission"] = _rgb(em)
        m["emission_strength"] = _val(node, "Emission Strength", default=1.0)
        if node.inputs.get("Specular IOR Level") is not None:
            m["specular"] = 2.0 * _val(node, "Specular IOR Level")  # 4.x: 0.5 is neutral
        elif node.inputs.get("Specular") is not None:
            m["specular"] = _specular_3x_scale(m["ior"]) * _val(node, "Specular")
            # Cycles 3.x renders it as the Disney BRDF (material JSON "model": "principled_v1").
            m["principled_v1"] = True
            if getattr(node, "distribution", "GGX") != "GGX":
                m["approximation"] = ("Principled BSDF '%s': Multiscatter GGX is rendered single-scattering (rough "
                                      "metals up to about 10%% darker than in Cycles 3.x)" % node.name)
        sss = _principled_subsurface(node, m)
        _principled_coat(node, m)
        _principled_sheen(node, m)
        _principled_sheen_3x(node, m)
        m["specular_tint"] = _principled_specular_tint(node, m["base"])
        # Thin Film (4.2+): exact per wavelength in Prism, on the dielectric (not the metal).
        thickness = _val(node, "Thin Film Thickness", default=0.0)
        if thickness > 0.0:
            m["thin_film"] = (float(thickness), max(float(_val(node, "Thin Film IOR", default=1.33)), 1.0))
    elif t == "BSDF_DIFFUSE":
        sock = _socket(node, "Color")
        m["image"] = _linked_image(sock)
        m["base"] = _rgb(sock.default_value)
        m["roughness"] = 1.0
        m["specular"] = 0.0  # pure Lambertian
    elif t in {"BSDF_GLOSSY", "BSDF_ANISOTROPIC"}:
        sock = _socket(node, "Color")
        m["image"] = _linked_image(sock)
        m["base"] = _rgb(sock.default_value)
        m["metallic"] = 1.0
        m["roughness"] = _val(node, "Roughness")
    elif t == "BSDF_GLASS":
        m["base"] = _rgb(_val(node, "Color", default=(1, 1, 1, 1)))
        m["roughness"] = _val(node, "Roughness")
        m["ior"] = _val(node, "IOR", default=1.5)
        m["transmission"] = 1.0
    elif t == "SUBSURFACE_SCATTERING":
        sock = _socket(node, "Color")
        m["image"] = _linked_image(sock)
        m["base"] = _rgb(sock.default_value)
        m["roughness"] = _val(node, "Roughness", default=1.0)
        m["ior"] = _val(node, "IOR", default=1.4)
        sss = _sss_node_subsurface(node)
    elif t in {"BSDF_HAIR_PRINCIPLED", "BSDF_HAIR"}:
        m["base"] = _hair_colour(node)
        m["roughness"] = _val(node, "Roughness", "RoughnessU", default=0.3)
        m["ior"] = _val(node, "IOR", default=1.55)
        m["approximation"] = "%s '%s' is approximated by a Principled BSDF of the hair's colour" % (
            "Principled Hair BSDF" if t == "BSDF_HAIR_PRINCIPLED" else "Hair BSDF", node.name)
    elif t == "EMISSION":
        m["base"] = [0.0, 0.0, 0.0]
        m["emission"] = _rgb(_val(node, "Color", default=(1, 1, 1, 1)))
        m["emission_strength"] = _val(node, "Strength", default=1.0)
        m["specular"] = 0.0
    else:
        m["specular"] = 0.0
        m["roughness"] = 1.0
        return m, None, False
    m["normal"], normal_ok = _normal_map(node)
    if not normal_ok:
        m["normal_unsupported"] = True
    return m, sss, True


# Absorption of eumelanin and pheomelanin per unit concentration (d'Eon et al. 2011), as
# Chiang et al. 2016 and Blender's Principled Hair BSDF use them.
EUMELANIN_SIGMA_A = (0.419, 0.697, 1.37)
PHEOMELANIN_SIGMA_A = (0.187, 0.4, 1.05)


def _hair_colour(node):
    """The colour a Principled Hair BSDF shows, in [0, 1]: its Color (Direct Coloring), or the
    colour of its absorption (Melanin, Absorption Coefficient) through Chiang et al. 2016's
    mapping between colour and absorption, eq. 9: sigma_a = (ln c / D(beta_n))^2 with D a
    quintic in the radial roughness, inverted: c = exp(-sqrt(sigma_a) D(beta_n))."""
    mode = getattr(node, "parametrization", "COLOR")
    if node.type == "BSDF_HAIR" or mode == "COLOR":
        return _rgb(_val(node, "Color", default=(0.8, 0.5, 0.3, 1.0)))
    b = float(_val(node, "Radial Roughness", default=0.3))
    d = 5.969 - 0.215 * b + 2.532 * b ** 2 - 10.73 * b ** 3 + 5.574 * b ** 4 + 0.245 * b ** 5
    if mode == "ABSORPTION":
        sigma = [max(float(c), 0.0) for c in _val(node, "Absorption Coefficient", default=(0.245, 0.52, 1.365))[:3]]
    else:
        melanin = min(max(float(_val(node, "Melanin", default=0.8)), 0.0), 1.0)
        redness = min(max(float(_val(node, "Melanin Redness", default=1.0)), 0.0), 1.0)
        quantity = -math.log(max(1.0 - melanin, 1e-4))
        eu, pheo = quantity * (1.0 - redness), quantity * redness
        tint = _rgb(_val(node, "Tint", default=(1, 1, 1, 1)))
        sigma = []
        for k in range(3):
            # The tint's own absorption, through the same mapping.
            t = (math.log(max(tint[k], 1e-4)) / d) ** 2
            sigma.append(eu * EUMELANIN_SIGMA_A[k] + pheo * PHEOMELANIN_SIGMA_A[k] + t)
    return [math.exp(-math.sqrt(sg) * d) for sg in sigma]


def _principled_specular_tint(node, base):
    """Specular Tint as an RGB colour: 4.x's colour (the dielectric F0's tint and the metal's
    F82 edge tint, exported as KHR_materials_specular.specularColorFactor), or 3.x's factor
    towards the base colour's hue (Cycles 3.x: mix(1, base / luminance(base), tint))."""
    sock = node.inputs.get("Specular Tint")
    if sock is None:
        return None
    v = sock.default_value
    try:
        return [max(float(c), 0.0) for c in list(v)[:3]]
    except TypeError:
        t = min(max(float(v), 0.0), 1.0)
        lum = 0.2126 * base[0] + 0.7152 * base[1] + 0.0722 * base[2]
        hue = [c / lum for c in base] if lum > 0.0 else [1.0, 1.0, 1.0]
        return [(1.0 - t) + t * c for c in hue]


def _principled_coat(node, m):
    """Principled Coat (4.x: Coat Weight, Roughness, IOR, Tint) or Clearcoat (3.x: Clearcoat,
    Clearcoat Roughness; IOR 1.5, no tint) into m["coat"] = (weight, roughness, ior, tint rgb)
    or None. Written as KHR_materials_clearcoat plus extras prism_coat_ior / prism_coat_tint."""
    if node.inputs.get("Coat Weight") is not None:
        weight = _val(node, "Coat Weight")
        roughness = _val(node, "Coat Roughness", default=0.03)
        ior = _val(node, "Coat IOR", default=1.5)
        tint = _rgb(_val(node, "Coat Tint", default=(1, 1, 1, 1)))
    elif node.inputs.get("Clearcoat") is not None:
        # Blender 3.x: Cycles adds the Disney clear coat, 0.25 x Clearcoat x Schlick(F0 0.04) over
        # a GTR1 distribution, on top of the base (Burley 2012, "Physically-Based Shading at
        # Disney", sec. 5.6): a coat of a quarter of the weight.
        weight = 0.25 * _val(node, "Clearcoat")
        roughness = _val(node, "Clearcoat Roughness", default=0.03)
        ior, tint = 1.5, [1.0, 1.0, 1.0]
    else:
        return
    sock = node.inputs.get("Coat Weight") or node.inputs.get("Clearcoat")
    if sock.is_linked:
        weight = 1.0  # the graph's coat_weight replaces it; the IOR and tint still apply
    if weight > 0.0:
        m["coat"] = (min(float(weight), 1.0), min(max(float(roughness), 0.0), 1.0), max(float(ior), 1.0),
                     [max(float(c), 0.0) for c in tint])
        # 3.x: added on top of the base, not dimming it (the renderer's `additive` coat).
        m["coat_additive"] = node.inputs.get("Coat Weight") is None


def _principled_sheen(node, m):
    """Principled Sheen (4.x: Sheen Weight, Roughness, Tint) into m["sheen"] = (colour rgb =
    weight x tint, roughness) or None; written as KHR_materials_sheen with Blender's roughness,
    which the renderer's default material model renders with Cycles' microfibre sheen
    (src/bsdf/fibre_sheen.rs). Blender 3.x's Sheen (the Disney model's grazing tint, no
    roughness): `_principled_sheen_3x`."""
    if node.inputs.get("Sheen Weight") is None:
        return
    weight = float(_val(node, "Sheen Weight"))
    linked = node.inputs["Sheen Weight"].is_linked or node.inputs["Sheen Tint"].is_linked
    if linked:
        weight = 1.0  # the graph's sheen_color replaces the colour; the roughness still applies
    if not weight > 0.0:
        return
    tint = _rgb(_val(node, "Sheen Tint", default=(1, 1, 1, 1)))
    blender_roughness = float(_val(node, "Sheen Roughness", default=0.5))
    color = [min(max(weight * float(c), 0.0), 1.0) for c in tint]
    if max(color) > 0.0:
        m["sheen"] = (color, min(max(blender_roughness, 0.0), 1.0))


def _specular_3x_scale(ior):
    """Blender 3.x's Specular is F0 / 0.08 whatever the IOR (which only refracts): the factor
    on Specular that makes the IOR's own F0, ((ior - 1) / (ior + 1))^2, times the exported
    specular factor equal 0.08 x Specular."""
    ior = max(float(ior), 1.0 + 1e-3)
    return 0.08 / ((ior - 1.0) / (ior + 1.0)) ** 2


def _principled_sheen_3x(node, m):
    """Blender 3.x's Sheen on a Principled BSDF rendered as Cycles 3.x does (the Disney sheen of
    "model": "principled_v1"): m["sheen"] = (Sheen x mix(1, base / luminance(base), Sheen Tint),
    unused roughness), with Cycles 3.x's luminance 0.3 R + 0.6 G + 0.1 B of the Base Color's
    value (warned when Base Color is linked and the tint is not 0). A linked Sheen or Sheen Tint
    is warned about (`_principled_warnings`)."""
    sock = node.inputs.get("Sheen")
    if not m.get("principled_v1") or sock is None or sock.is_linked:
        return
    tint_sock = node.inputs.get("Sheen Tint")
    if tint_sock is not None and tint_sock.is_linked:
        return
    sheen = max(float(sock.default_value), 0.0)
    if not sheen > 0.0:
        return
    tint = min(max(float(tint_sock.default_value), 0.0), 1.0) if tint_sock is not None else 0.5
    base = m["base"]
    lum = 0.3 * base[0] + 0.6 * base[1] + 0.1 * base[2]
    hue = [c / lum for c in base] if lum > 0.0 else [1.0, 1.0, 1.0]
    m["sheen"] = ([min(sheen * ((1.0 - tint) + tint * c), 1.0) for c in hue], 0.5)
    m["sheen_3x"] = True
    base_sock = node.inputs.get("Base Color")
    if tint > 0.0 and base_sock is not None and base_sock.is_linked:
        m["sheen_3x_note"] = ("Principled BSDF '%s': Sheen Tint takes the hue of Base Color's value, not of its "
                              "linked texture" % node.name)


def _normal_map(node):
    """The shader's `Normal` input as a glTF normalTexture: (info or None, supported).

    Supported: a tangent-space Normal Map node whose Color comes from an Image Texture. Its
    Strength becomes normalTexture.scale. The two agree at Strength 1 (the usual setting);
    otherwise Cycles blends the unperturbed and the mapped normal, N + Strength (N_map - N),
    while glTF scales the map's X and Y (glTF 2.0 spec 5.23), which tilts mild maps alike
    and steep ones a little differently. Anything else on the input (Bump node, object- or
    world-space normal maps, procedural colours) is unsupported: the normal stays
    unperturbed and the material is named in a warning."""
    sock = node.inputs.get("Normal")
    if sock is None or not sock.is_linked:
        return None, True
    src = sock.links[0].from_node
    if src.type != "NORMAL_MAP" or src.space != "TANGENT":
        return None, False
    img = _linked_image(src.inputs.get("Color"))
    if img is None:
        return None, False
    tex = src.inputs["Color"].links[0].from_node
    vec = tex.inputs.get("Vector")
    if (vec is not None and vec.is_linked) or tex.interpolation != "Linear" or tex.extension != "REPEAT":
        # Mapped, filtered or extended unlike glTF's sampler: the shading graph carries it.
        return None, False
    strength = src.inputs.get("Strength")
    if strength is not None and strength.is_linked:
        return None, False
    scale = float(strength.default_value) if strength is not None else 1.0
    return {"image": img, "scale": max(scale, 0.0), "uv_map": src.uv_map}, True


def _principled_subsurface(node, m, weight_override=None):
    """The sidecar `subsurface` entry for a Principled BSDF with subsurface weight > 0.

    Cycles' three methods (measured against Cycles 5.0 in tests/addon/test_sss_parity.py):
    - Random Walk and Random Walk (Skin) (3.x: Random Walk (Fixed Radius) and Random Walk): a
      volumetric walk whose coefficients Cycles derives from colour and radius per channel;
      exported as they are (`color` + `radius`, `skin` for the radius-adjusting method) with
      method "random_walk" and boundary "lambertian", Cycles' boundary: refracted entry, no
      internal Fresnel reflection, diffuse exit. The renderer derives the coefficients
      (src/bssrdf/media.rs `cycles_walk`), also per point where the colour is textured.
    - Christensen-Burley: Prism's diffusion table ("table") with reflectance A and mean free
      path d / (4 pi), Cycles' own radius-to-mean-free-path scaling.
    The boundary's IOR and roughness are the Principled IOR and Roughness (its specular layer).
    `weight_override`: the entry's weight instead of the node's Subsurface Weight (a Mix Shader
    leaf, whose graph carries the weight)."""
    if node.inputs.get("Subsurface Weight") is not None:  # 4.x+: colour from Base Color
        weight = _val(node, "Subsurface Weight")
        radius = _val(node, "Subsurface Radius", default=(1.0, 0.2, 0.1))
        scale = _val(node, "Subsurface Scale", default=0.05)
        colour = m["base"]
        radius = [r * scale for r in radius]
        eta = _val(node, "IOR", default=1.5)
        skin = "RANDOM_WALK_SKIN"
    else:  # 3.x: "Subsurface" scales the radius, colour from "Subsurface Color"
        weight = _val(node, "Subsurface")
        radius = _val(node, "Subsurface Radius", default=(1.0, 0.2, 0.1))
        colour = _rgb(_val(node, "Subsurface Color", default=(0.8, 0.8, 0.8, 1)))
        radius = [r * weight for r in radius]
        eta = _val(node, "Subsurface IOR", default=1.4)
        skin = "RANDOM_WALK"  # 3.x's "Random Walk" adjusts the radius like 4.x's Skin
    if weight_override is not None:
        weight = weight_override
    if weight <= 0.0:
        return None
    method = getattr(node, "subsurface_method", "BURLEY")
    return _subsurface_block(method, skin, colour, radius, eta, _val(node, "Roughness", default=0.5),
                             _val(node, "Subsurface Anisotropy", default=0.0), weight)


def _subsurface_colour_socket(node):
    """The socket that gives a Principled BSDF's (4.x: Base Color, 3.x: Subsurface Color) or a
    Subsurface Scattering node's (Color) subsurface colour."""
    if node.type == "SUBSURFACE_SCATTERING":
        return "Color"
    return "Base Color" if node.inputs.get("Subsurface Weight") is not None else "Subsurface Color"


def _sss_node_subsurface(node):
    """The sidecar `subsurface` entry for a Subsurface Scattering node (Color, Radius x Scale,
    IOR, Roughness, Anisotropy; 3.x: no IOR/Roughness): the medium of Principled subsurface
    at weight 1, by the node's falloff (3.x's Cubic and Gaussian become Burley). Burley and
    Random Walk (Skin) hide Roughness: the boundary is then smooth, which matched Cycles 5.0
    (sphere means within 5%, tests/addon/test_sss_parity.py; roughness 1 was 13-17% dark)."""
    colour = _rgb(_val(node, "Color", default=(0.8, 0.8, 0.8, 1)))
    scale = _val(node, "Scale", default=1.0)
    radius = [r * scale for r in _val(node, "Radius", default=(1.0, 1.0, 1.0))]
    falloff = getattr(node, "falloff", "BURLEY")
    if falloff in {"CUBIC", "GAUSSIAN"}:
        falloff = "BURLEY"
    # 4.x: Random Walk (Skin) adjusts the radius; 3.x: its Random Walk does, Random Walk (Fixed
    # Radius) does not (as for the Principled node).
    kinds = [e.identifier for e in node.bl_rna.properties["falloff"].enum_items]
    skin = "RANDOM_WALK_SKIN" if "RANDOM_WALK_SKIN" in kinds else "RANDOM_WALK"
    return _subsurface_block(falloff, skin, colour, radius, _val(node, "IOR", default=1.4),
                             _val(node, "Roughness", default=0.0), _val(node, "Anisotropy", default=0.0), 1.0)


def _subsurface_block(method, skin, colour, radius, eta, roughness, anisotropy, weight):
    """The `subsurface` entry for Cycles' method `method` (`skin`: the name of the method whose
    radius gets the dipole adjustment) from colour, radius (scene units), IOR, boundary
    roughness, anisotropy and weight (see `_principled_subsurface`)."""
    eta = max(float(eta), 1.01)
    colour = [min(max(float(c), 0.0), 1.0) for c in colour]
    radius = [max(float(r), 1e-6) for r in radius]
    out = {
        "eta": eta,
        "roughness": min(max(float(roughness), 0.0), 1.0),
        # The rest of the surface is the Principled base (the glTF material), as in Cycles'
        # mix of subsurface and diffuse by the weight.
        "weight": min(max(float(weight), 0.0), 1.0),
    }
    if method == "BURLEY":
        g = min(max(float(anisotropy), -0.99), 0.99)
        out.update(reflectance=colour, mfp=[r / (4.0 * math.pi) for r in radius], g=g, method="table")
        return out
    g = min(max(float(anisotropy), 0.0), 0.9)  # Cycles' range
    out.update(color=colour, radius=radius, skin=method == skin, g=g, method="random_walk", boundary="lambertian")
    return out


def _drop_subsurface_colour(graph):
    """Removes the graph's `subsurface_color` inputs (top level and closures); True if any."""
    found = graph.get("inputs", {}).pop("subsurface_color", None) is not None
    for c in graph.get("closures", []):
        found |= c.get("inputs", {}).pop("subsurface_color", None) is not None
    return found


def prism_override(mat):
    """Material JSON entry from the material's Prism panel, or None."""
    if mat is None or not hasattr(mat, "prism"):
        return None
    p = mat.prism
    if p.sss_mode == "PRESET":
        return {"subsurface": {"preset": p.sss_preset, "scale": p.sss_scale, "eta": p.sss_eta, "g": p.sss_g}}
    if p.sss_mode == "EXPLICIT":
        return {
            "subsurface": {
                "sigma_a": list(p.sigma_a),
                "sigma_s": list(p.sigma_s),
                "scale": p.sss_scale,
                "eta": p.sss_eta,
                "g": p.sss_g,
            }
        }
    if p.dispersion_mode != "NONE":
        roughness = float(p.dispersion_roughness)
        if p.dispersion_mode == "CAUCHY":
            ior = {"cauchy": {"a": float(p.cauchy_a), "b": float(p.cauchy_b)}}
        elif p.dispersion_mode == "ABBE":
            ior = {"abbe": {"ior": float(p.abbe_nd), "abbe": float(p.abbe_number)}}
        else:  # the renderer's glass presets: published Sellmeier coefficients
            ior = {"preset": GLASS_PRESETS[p.glass_preset]}
        return {"dielectric": dict(ior, roughness=roughness)}
    return None


# ----------------------------------------------------------------------------- images


def image_rgba8(img):
    """An image's pixels as 8-bit sRGB RGBA rows, top row first (float images are encoded)."""
    w, h = img.size
    px = np.empty(w * h * 4, np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, 4)[::-1]
    if img.is_float:
        c = np.clip(px[..., :3], 0.0, 1.0)
        px[..., :3] = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    return (np.clip(px, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _is_data(img):
    cs = img.colorspace_settings
    return bool(getattr(cs, "is_data", False)) or cs.name in {"Non-Color", "Raw", "Generic Data"}


def image_data_rgba8(img):
    """A data image (normal map) as 8-bit RGBA rows, top row first, holding the values Cycles
    reads: the stored values for Non-Color images (glTF data textures are linear, spec 5.23),
    else the image's colours decoded to linear (an sRGB byte image; float pixels already are)."""
    w, h = img.size
    px = np.empty(w * h * 4, np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, 4)[::-1].copy()
    if not img.is_float and not _is_data(img):
        c = np.clip(px[..., :3], 0.0, 1.0)
        px[..., :3] = np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))
    return (np.clip(px, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def write_png(path, rgba):
    """Minimal PNG writer (8-bit RGBA, zlib), no Blender image API needed."""
    h, w = rgba.shape[:2]
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rgba.reshape(h, w * 4)], axis=1).tobytes()

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 6)))
        f.write(chunk(b"IEND", b""))


# ----------------------------------------------------------------------------- mesh data


def _corner_vertices(me, n_corners):
    """Vertex index of every corner (loop). Blender 4.0+ stores it as the ``.corner_vert``
    attribute, whose ``foreach_get`` is a plain copy; ``loops.foreach_get("vertex_index")``
    goes through RNA per element (~45 ns each, 9 ms for 200k corners)."""
    out = np.empty(n_corners, np.int32)
    attr = me.attributes.get(".corner_vert")
    if attr is not None and attr.domain == "CORNER" and attr.data_type == "INT":
        attr.data.foreach_get("value", out)
    else:  # 3.x
        me.loops.foreach_get("vertex_index", out)
    return out


def _triangle_materials(me, n_triangles):
    """Material slot index of every loop triangle. Read from the face ``material_index``
    attribute through ``loop_triangle_polygons`` where Blender has them (4.0+: plain copies),
    since ``loop_triangles.foreach_get("material_index")`` costs ~75 ns per triangle."""
    attr = me.attributes.get("material_index")
    if attr is None and hasattr(me, "loop_triangle_polygons"):
        # No attribute: every face uses slot 0.
        return np.zeros(n_triangles, np.int32)
    if (
        attr is not None
        and attr.domain == "FACE"
        and attr.data_type == "INT"
        and hasattr(me, "loop_triangle_polygons")
    ):
        face_material = np.empty(len(me.polygons), np.int32)
        attr.data.foreach_get("value", face_material)
        tri_face = np.empty(n_triangles, np.int32)
        me.loop_triangle_polygons.foreach_get("value", tri_face)
        return face_material[tri_face]
    out = np.empty(n_triangles, np.int32)
    me.loop_triangles.foreach_get("material_index", out)
    return out


def _mesh_triangles(me):
    """(loop index of every triangle corner as uint32, material slot of every triangle), or
    None for a mesh without faces."""
    me.calc_loop_triangles()
    nt = len(me.loop_triangles)
    if nt == 0:
        return None
    # uint32 matches the RNA type of LoopTriangle.loops, so foreach_get copies directly.
    tri_loops = np.empty(nt * 3, np.uint32)
    me.loop_triangles.foreach_get("loops", tri_loops)
    return tri_loops, _triangle_materials(me, nt)


def _corner_attributes(me, corner_vert, uv_sets, color_sets):
    """Per-corner arrays for the named UV maps and colour attributes graphs read:
    {"TEXCOORD_n" | "COLOR_n": array}, and warnings for names the mesh lacks. UVs are flipped
    to glTF's convention like TEXCOORD_0; colours are linear RGBA (Blender's `color`)."""
    nl = len(me.loops)
    out, missing = {}, []
    for name, k in uv_sets.items():
        layer = me.uv_layers.get(name) or me.uv_layers.active
        if me.uv_layers.get(name) is None:
            missing.append("UV map '%s'" % name)
        if layer is None:
            continue
        uv = np.empty(nl * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        uv = uv.reshape(-1, 2)
        uv[:, 1] = 1.0 - uv[:, 1]
        out["TEXCOORD_%d" % k] = uv
    attrs = getattr(me, "color_attributes", None)
    # (name, set) pairs: a named attribute that is also the default one goes to both sets.
    wanted = list(color_sets.items())
    if attrs is not None and len(attrs):
        default = getattr(attrs, "default_color_name", "") or (attrs.active_color.name if attrs.active_color else "")
        wanted.append((default, 0))
    for name, k in wanted:
        attr = attrs.get(name) if attrs is not None and name else None
        if attr is None:
            if name and k:
                missing.append("colour attribute '%s'" % name)
            continue
        col = np.empty(len(attr.data) * 4, np.float32)
        attr.data.foreach_get("color", col)
        col = col.reshape(-1, 4)
        out["COLOR_%d" % k] = col if attr.domain == "CORNER" else col[corner_vert]
    return out, missing


def _mesh_arrays(me, tri_loops, tri_mat, per_vertex_allowed=True):
    """Vertex positions, shading normals (None: flat, computed by the renderer), UVs,
    per-material triangle index lists, and whether the arrays are per vertex (else per corner).

    Per vertex where Blender's normals are per vertex (smooth, no custom normals) or per face
    (flat: glTF then carries no normals and the renderer uses each triangle's own normal, as
    Cycles does for flat faces), and every corner of a vertex has the same UV: the arrays are
    then a quarter of a per-corner export for quad meshes, which the export, the file and the
    renderer's load all pay for. Otherwise (custom or mixed normals, UV seams, Blender < 4.1,
    or `per_vertex_allowed` False because tangents are needed) one vertex per corner.
    """
    nl = len(me.loops)
    co = np.empty(len(me.vertices) * 3, np.float32)
    position = me.attributes.get("position")
    if position is not None and position.domain == "POINT" and position.data_type == "FLOAT_VECTOR":
        position.data.foreach_get("vector", co)  # 3.5+: a plain copy, unlike vertices.co
    else:
        me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    corner_vert = _corner_vertices(me, nl)
    uv = None
    layer = me.uv_layers.active
    if layer is not None:
        uv = np.empty(nl * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        uv = uv.reshape(-1, 2)
        uv[:, 1] = 1.0 - uv[:, 1]
    domain = getattr(me, "normals_domain", "CORNER")  # 4.1+
    per_vertex = per_vertex_allowed and domain in {"POINT", "FACE"}
    vertex_uv = None
    if per_vertex and uv is not None:
        vertex_uv = np.zeros((len(co), 2), np.float32)
        vertex_uv[corner_vert] = uv
        per_vertex = np.array_equal(vertex_uv[corner_vert], uv)  # no UV seams
    if per_vertex:
        nrm = None
        if domain == "POINT":
            nrm = np.empty(len(co) * 3, np.float32)
            me.vertex_normals.foreach_get("vector", nrm)
            nrm = nrm.reshape(-1, 3)
        pos, uv = co, vertex_uv
        tri_index = corner_vert.astype(np.uint32)[tri_loops]
    else:
        pos = co[corner_vert]
        nrm = np.empty(nl * 3, np.float32)
        if hasattr(me, "corner_normals"):  # 4.1+
            me.corner_normals.foreach_get("vector", nrm)
        else:  # 3.x / 4.0
            me.calc_normals_split()
            me.loops.foreach_get("normal", nrm)
        nrm = nrm.reshape(-1, 3)
        tri_index = tri_loops
    groups = {}
    tl = tri_index.reshape(-1, 3)
    for mi in np.unique(tri_mat):
        groups[int(mi)] = tl[tri_mat == mi].reshape(-1)
    return pos, nrm, uv, groups, per_vertex


def _deformation_targets(me, keys, pos, nrm, per_vertex):
    """glTF morph targets (POSITION, and NORMAL when the mesh has shading normals) holding the
    displacement of each exported vertex at each shutter key (`motion.vertex_data` per key),
    mapped as `_mesh_arrays` mapped the current frame; None when the keys do not fit the mesh
    (its vertex or corner count differs)."""
    nv, nl = len(me.vertices), len(me.loops)
    if any(co.shape[0] != nv or cn.shape[0] != nl for co, _vn, cn in keys):
        return None
    corner_vert = None if per_vertex else _corner_vertices(me, nl)
    out = []
    for co, vn, cn in keys:
        p = co if per_vertex else co[corner_vert]
        target = {"POSITION": p - pos}
        if nrm is not None:
            n = vn if per_vertex else cn
            if n is None or n.shape != nrm.shape:
                return None
            target["NORMAL"] = n - nrm
        out.append(target)
    return out


def _mesh_tangents(me, uv_name):
    """Per-corner MikkTSpace tangents of UV map `uv_name` as (N, 4) float32: xyz in object
    space (like the normals: the root node turns Z-up into Y-up), w = Blender's bitangent_sign,
    or None when Blender cannot compute them (n-gons). Blender defines bitangent =
    bitangent_sign * cross(normal, tangent), pointing along +v; the export flips v
    (v_gltf = 1 - v) and images upside down, so +v in Blender is "up" in the image, which is
    +Y of a glTF normal map: w is the same number (glTF 2.0 spec 3.7.2.1). These are the
    tangents Cycles' Normal Map node uses."""
    try:
        me.calc_tangents(uvmap=uv_name)
    except RuntimeError:
        return None
    try:
        nl = len(me.loops)
        t = np.empty(nl * 3, np.float32)
        me.loops.foreach_get("tangent", t)
        sign = np.empty(nl, np.float32)
        me.loops.foreach_get("bitangent_sign", sign)
    finally:
        me.free_tangents()
    return np.concatenate([t.reshape(-1, 3), sign.reshape(-1, 1)], axis=1)


# ----------------------------------------------------------------------------- exporter


class Exporter:
    """Writes a depsgraph as glTF + material JSON.

    `viewport`: for the rendered viewport, which brings its own view (no scene camera is
    needed). `shading_only`: only what a shading edit changes (materials, lights, world) and no
    mesh data, for `prism serve`'s `shading` command.
    """

    def __init__(self, depsgraph, out_dir, name="scene", width=None, height=None, viewport=False, shading_only=False):
        self.dg = depsgraph
        self.viewport = viewport
        self.shading_only = shading_only
        self.scene = depsgraph.scene_eval
        self.out_dir = out_dir
        self.name = name
        self.width = width
        self.height = height
        self.buf = _Buffer()
        self.nodes = [{"name": "ZupToYup", "matrix": [1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1], "children": []}]
        self.meshes = []
        self.mesh_cache = {}
        self.materials = []
        self.material_index = {}
        self.material_json = {}
        self.unsupported = []
        # Named UV maps / colour attributes that graphs read -> their TEXCOORD_n / COLOR_n set
        # (set 0: the active UV map, the default colour attribute).
        self.uv_sets = {}
        self.color_sets = {}
        self.graph_images = {}
        # Normal-mapped material name -> the Normal Map node's UV map ('' = the mesh's own).
        self.normal_uv_maps = {}
        # Materials whose Normal input is not exported (Bump, object-space maps, ...).
        self.unsupported_normals = []
        # Graphs of textured volume densities by material name (`_volume`).
        self.volume_graphs = {}
        self.images = []
        self.image_index = {}
        self.lights = []
        # Object and camera matrices over the shutter (motion.Motion), None without motion blur.
        self.motion = None
        # Objects whose particle hair is exported at the current frame although they move.
        self.hair_objects = []
        self.cameras = []
        self.warnings = []
        self.n_triangles = 0
        self.camera_lens = None
        # Baking of nodes the graphs cannot evaluate (node_bake.py): the texture size (0 = off;
        # the rendered viewport does not bake: a bake takes seconds), the requests per material
        # name [(node, output identifier, placeholder)], and the per-mesh material variants
        # [(variant name, {placeholder: file}, jobs)].
        props = getattr(self.scene, "prism", None)
        self.bake_size = 0
        if not viewport and getattr(props, "bake_unsupported_nodes", True):
            self.bake_size = int(getattr(props, "bake_resolution", node_bake.DEFAULT_SIZE))
        self.bake_requests = {}
        self.bake_variants = []
        self._bake_outcomes = {}
        self._variant_index = {}
        self._originals = {}
        self.bake_stats = None

    # -- helpers
    def _child(self, node):
        self.nodes.append(node)
        self.nodes[0]["children"].append(len(self.nodes) - 1)
        return len(self.nodes) - 1

    def _image(self, img, data=False):
        """glTF image index for `img`; `data`: a data texture (normal map), see image_data_rgba8."""
        key = (img.name, data)
        if key in self.image_index:
            return self.image_index[key]
        fname = "tex%d.png" % len(self.images)
        dst = os.path.join(self.out_dir, fname)
        src = img.filepath_from_user() if img.filepath else ""
        ext = os.path.splitext(src)[1].lower()
        # A data texture's file holds the right values only when Blender reads it as data.
        copy_ok = not data or _is_data(img)
        if copy_ok and src and os.path.isfile(src) and not img.packed_file and ext in {".png", ".jpg", ".jpeg"}:
            fname = "tex%d%s" % (len(self.images), ext)
            shutil.copyfile(src, os.path.join(self.out_dir, fname))
        elif data:
            write_png(dst, image_data_rgba8(img))
        else:
            write_png(dst, image_rgba8(img))
        self.images.append({"uri": fname})
        self.image_index[key] = len(self.images) - 1
        return self.image_index[key]

    def _uv_set(self, name):
        if not name:
            return 0
        if name not in self.uv_sets:
            if len(self.uv_sets) >= 3:
                self.warnings.append("more than 4 UV maps are read by materials; '%s' reads the active one" % name)
                return 0
            self.uv_sets[name] = len(self.uv_sets) + 1
        return self.uv_sets[name]

    def _color_set(self, name):
        if not name:
            return 0
        if name not in self.color_sets:
            if len(self.color_sets) >= 3:
                self.warnings.append("more than 4 colour attributes are read by materials; '%s' reads the default one" % name)
                return 0
            self.color_sets[name] = len(self.color_sets) + 1
        return self.color_sets[name]

    def _graph_image(self, img):
        """(file name, linear?) of `img` written for a graph's Image Texture node."""
        if img.name in self.graph_images:
            return self.graph_images[img.name]
        linear = img.is_float or img.colorspace_settings.name != "sRGB"
        src = img.filepath_from_user() if img.filepath else ""
        ext = os.path.splitext(src)[1].lower()
        n = len(self.graph_images)
        if src and os.path.isfile(src) and not img.packed_file and ext in {".png", ".jpg", ".jpeg"} and img.source == "FILE":
            fname = "graph%d%s" % (n, ext)
            shutil.copyfile(src, os.path.join(self.out_dir, fname))
            # A float-loaded PNG/JPEG file still holds its encoded values: decode by colour space.
            linear = img.colorspace_settings.name != "sRGB"
        else:
            w, h = img.size
            if w == 0 or h == 0:
                raise ExportError("the image has no pixels (file missing?)")
            if img.is_float:
                fname = "graph%d.exr" % n
                px = np.empty(w * h * 4, np.float32)
                img.pixels.foreach_get(px)
                write_exr_rgb(os.path.join(self.out_dir, fname), px.reshape(h, w, 4)[::-1, :, :3].copy())
                linear = True
            else:
                fname = "graph%d.png" % n
                write_png(os.path.join(self.out_dir, fname), image_rgba8(img))
        self.graph_images[img.name] = (fname, linear)
        return fname, linear

    def _baker(self, name):
        """GraphBuilder's `bake` callback for material `name` (None when baking is off)."""
        if not self.bake_size:
            return None

        def request(node, out, what):
            reqs = self.bake_requests.setdefault(name, [])
            placeholder = "__bake__/%s/%d" % (name, len(reqs))
            reqs.append((node.name, out.identifier, placeholder, "%s; its output '%s'" % (what, out.name)))
            return placeholder

        return request

    def _bake_fallback(self, name, where, why):
        """Records that material `name`'s baked nodes keep their inputs' own values on `where`
        (an object or mesh name) because of `why` (reported by `_run_bakes`)."""
        self._bake_outcomes.setdefault(name, {}).setdefault("fallback", []).append((where, why))

    def _baked_variant(self, index, ob, me):
        """The glTF material index mesh `me` (of object `ob`) uses for material `index`: a copy
        whose baked node outputs are textures baked on this mesh, or `index` itself when the
        material bakes nothing or this mesh cannot be baked (warned)."""
        name = self.materials[index]["name"]
        reqs = self.bake_requests.get(name)
        # (A graph the exporter dropped, e.g. a Mix Shader tree without a translatable leaf,
        # leaves its requests behind: nothing to bake.)
        if not reqs or "graph" not in self.material_json.get(name, {}):
            return index
        key = (name, me.as_pointer())
        if key in self._variant_index:
            return self._variant_index[key]
        mat = self._originals.get(name)
        self._variant_index[key] = index
        if ob is None or ob.type != "MESH" or mat is None:
            self._bake_fallback(name, ob.name if ob is not None else me.name, "not a mesh")
            return index
        if me.uv_layers.active is None:
            self._bake_fallback(name, ob.name, "its mesh '%s' has no UV map; add one" % me.name)
            return index
        variant = "%s@%s" % (name, ob.name)
        while variant in self.material_json:
            variant += "+"
        mesh_sig = node_bake.mesh_signature(me)
        frame = int(self.scene.frame_current)
        images, jobs = {}, []
        for node_name, socket_id, placeholder, _what in reqs:
            fname = "bake%d.exr" % (sum(len(v[4]) for v in self.bake_variants) + len(jobs))
            images[placeholder] = fname
            jobs.append({"object": ob.original, "material": mat, "node": node_name, "socket": socket_id,
                         "size": self.bake_size, "path": os.path.join(self.out_dir, fname),
                         "key": node_bake.job_key(mat, mesh_sig, ob.matrix_world, node_name, socket_id, self.bake_size, frame)})
        self.bake_variants.append((name, ob.name, variant, images, jobs))
        self.materials.append(dict(copy.deepcopy(self.materials[index]), name=variant))
        self.material_json[variant] = copy.deepcopy(self.material_json[name])
        self._variant_index[key] = len(self.materials) - 1
        return self._variant_index[key]

    def _run_bakes(self):
        """Bakes every variant's node outputs (one background Blender for all) and fills the
        graphs in: variants get their textures (a failed bake: the sockets' own values), the
        base materials the sockets' own values. Then one warning per baked node says where it
        was baked and where it keeps its input's own value (no UVs, not a mesh, a failed bake)."""
        for name in self.bake_requests:
            entry = self.material_json.get(name, {})
            if "graph" in entry:
                entry["graph"] = resolve_bakes(entry["graph"], {})
        jobs = [j for v in self.bake_variants for j in v[4]]
        failed = {}
        if jobs:
            try:
                seconds, baked, cached, failed = node_bake.bake(jobs, int(self.scene.frame_current))
                self.bake_stats = {"seconds": seconds, "baked": baked, "cached": cached, "failed": len(failed)}
                print("Prism: baked %d node output(s) with Cycles in %.1f s (%d from the cache)"
                      % (baked + cached, seconds, cached))
            except (node_bake.BakeError, OSError, RuntimeError, subprocess.SubprocessError) as e:
                failed = {j["path"]: str(e) for j in jobs}
        for name, ob_name, variant, images, vjobs in self.bake_variants:
            bad = [failed[j["path"]] for j in vjobs if j["path"] in failed]
            if bad:
                self._bake_fallback(name, ob_name, "the bake failed: %s" % bad[0])
            else:
                self._bake_outcomes.setdefault(name, {}).setdefault("baked", []).append(ob_name)
            entry = self.material_json[variant]
            if "graph" in entry:
                entry["graph"] = resolve_bakes(entry["graph"], {} if bad else images)
        for name, reqs in self.bake_requests.items():
            outcome = self._bake_outcomes.get(name, {})
            for _node, _sock, _ph, what in reqs:
                if outcome.get("baked"):
                    self.warnings.append("%s is baked with Cycles into a texture over the UV map of %s"
                                         % (what, ", ".join("'%s'" % o for o in sorted(set(outcome["baked"])))))
                for where, why in outcome.get("fallback", []):
                    self.warnings.append("%s cannot be baked on '%s' (%s); the input it feeds uses its own value"
                                         % (what, where, why))

    def _graph(self, mat, name, m, sss=None):
        """The material JSON graph for `mat`'s surface shader inputs that are linked, or None.
        `sss`: the material's subsurface block, whose colour the graph may texture."""
        node = _surface_node(mat)
        if node is None:
            return None
        gb = GraphBuilder(name, self._graph_image, self._uv_set, self._color_set, self.warnings.append,
                          bake=self._baker(name))
        t = node.type
        S = lambda *n: _socket(node, *n)  # noqa: E731
        handled = set()

        def bind(key, sock, scale=None):
            if sock is None:
                return False
            handled.add(sock.identifier)
            return gb.bind(key, sock, scale)

        if t == "BSDF_PRINCIPLED":
            if bind("base_color", S("Base Color")):
                m["image"] = None
            bind("metallic", S("Metallic"))
            bind("roughness", S("Roughness"))
            spec = S("Specular IOR Level", "Specular")
            bind("specular", spec, scale=2.0)
            bind("transmission", S("Transmission Weight", "Transmission"))
            e_col, e_str = S("Emission Color", "Emission"), S("Emission Strength")
            if (bind("emission", e_col) | bind("emission_strength", e_str)):
                if "emission" not in gb.inputs:
                    gb.bind_const("emission", _rgb(e_col.default_value))
                if "emission_strength" not in gb.inputs:
                    gb.bind_const("emission_strength", float(e_str.default_value) if e_str is not None else 1.0)
            # Coat and Sheen from textures (4.x; 3.x's Clearcoat too).
            cw = S("Coat Weight", "Clearcoat")
            bind("coat_weight", cw, scale=0.25 if cw is not None and cw.name == "Clearcoat" else None)
            bind("coat_roughness", S("Coat Roughness", "Clearcoat Roughness"))
            bind("coat_tint", S("Coat Tint"))
            bind("coat_ior", S("Coat IOR"))
            # Coat Normal (4.x; 3.x: Clearcoat Normal): the coat's own; unlinked, the coat keeps
            # the surface's unperturbed normal under a bumped base (the renderer's default).
            bind("coat_normal", S("Coat Normal", "Clearcoat Normal"))
            tint = S("Specular Tint")
            if tint is not None and tint.type == "RGBA":  # 4.x's colour (3.x: a factor)
                bind("specular_tint", tint)
            if bind("thin_film_thickness", S("Thin Film Thickness")) | bind("thin_film_ior", S("Thin Film IOR")):
                if "thin_film_thickness" not in gb.inputs:
                    gb.bind_const("thin_film_thickness", max(float(_val(node, "Thin Film Thickness")), 0.0))
                if "thin_film_ior" not in gb.inputs:
                    gb.bind_const("thin_film_ior", max(float(_val(node, "Thin Film IOR", default=1.33)), 1.0))
            self._graph_sheen(gb, node, handled)
            alpha = S("Alpha")
            if alpha is not None and not bind("alpha", alpha) and float(alpha.default_value) < 1.0:
                gb.bind_const("alpha", float(alpha.default_value))
                handled.add(alpha.identifier)
            self._graph_normal(gb, node, m, handled)
            colour = self._subsurface_colour(gb, node, _subsurface_colour_socket(node), sss)
            if colour is not None:
                gb.inputs["subsurface_color"] = colour
                handled.add(_subsurface_colour_socket(node))
            if m.get("sheen_3x"):
                handled.add("Sheen")  # translated (Blender 3.x's Disney sheen)
            self._principled_warnings(name, node, handled)
        elif t in {"BSDF_DIFFUSE", "BSDF_GLOSSY", "BSDF_ANISOTROPIC", "BSDF_GLASS"}:
            if bind("base_color", S("Color")):
                m["image"] = None
            if t != "BSDF_DIFFUSE":
                bind("roughness", S("Roughness"))
            self._graph_normal(gb, node, m, handled)
            handled.add("Weight")
            self._linked_warnings(name, node, handled)
        elif t == "SUBSURFACE_SCATTERING":
            # The medium's colour may be textured; its other inputs are per material (a linked
            # one is warned about).
            colour = self._subsurface_colour(gb, node, "Color", sss)
            if colour is not None:
                gb.inputs["subsurface_color"] = colour
                handled.add("Color")
            self._graph_normal(gb, node, m, handled)
            handled.add("Weight")
            self._linked_warnings(name, node, handled)
        elif t == "EMISSION":
            e_col, e_str = S("Color"), S("Strength")
            if bind("emission", e_col) | bind("emission_strength", e_str):
                if "emission" not in gb.inputs:
                    gb.bind_const("emission", _rgb(e_col.default_value))
                if "emission_strength" not in gb.inputs:
                    gb.bind_const("emission_strength", float(e_str.default_value))
                if max(m["emission"]) <= 0.0 or m["emission_strength"] <= 0.0:
                    # The glTF emission stands in for light power estimates: keep it non-zero.
                    m["emission"], m["emission_strength"] = [1.0, 1.0, 1.0], 1.0
            handled.add("Weight")
            self._linked_warnings(name, node, handled)
        return gb.result()

    def _graph_sheen(self, gb, node, handled):
        """Principled Sheen Weight x Tint from textures as the graph's `sheen_color`, and a
        linked Sheen Roughness as its `sheen_roughness`."""
        weight, tint = node.inputs.get("Sheen Weight"), node.inputs.get("Sheen Tint")
        if weight is None or tint is None:
            return
        wv, tv = gb.value(weight, ()), gb.value(tint, ())
        if not (isinstance(wv, dict) or isinstance(tv, dict)):
            return
        handled.update((weight.identifier, tint.identifier))
        if not isinstance(wv, dict):
            wv = [float(wv)] * 3
        n = "__sheen_color"
        gb.nodes[n] = {"type": "vector_math", "operation": "multiply", "inputs": {"a": wv, "b": tv}}
        gb.bind_const("sheen_color", {"node": n, "output": "vector"})
        rough = node.inputs.get("Sheen Roughness")
        if rough is not None and rough.is_linked:
            handled.add(rough.identifier)
            gb.bind("sheen_roughness", rough)

    def _mixed_graph(self, name, root, m):
        """A Mix / Add Shader tree as graph closures: the tree flattened into weighted leaves
        (weight = product of the mix factors on the way down). m gets the first BSDF leaf's
        constants as the glTF material's (for light power estimates and other viewers)."""
        gb = GraphBuilder(name, self._graph_image, self._uv_set, self._color_set, self.warnings.append,
                          bake=self._baker(name))
        counter = [0]

        def node_name(kind):
            counter[0] += 1
            return "__%s_%d" % (kind, counter[0])

        def math(op, a, b):
            if isinstance(a, float) and isinstance(b, float):
                return {"multiply": a * b, "subtract": a - b}[op]
            n = node_name(op)
            gb.nodes[n] = {"type": "math", "operation": op, "inputs": {"a": a, "b": b}}
            return {"node": n, "output": "value"}

        def source(sock):
            link = gb._live_link(sock) if sock is not None else None
            if link is None:
                return None
            node = link.from_node
            for _ in range(64):
                if node.type == "REROUTE" or getattr(node, "mute", False):
                    nxt = node.inputs[0] if node.inputs else None
                    if getattr(node, "mute", False):
                        nxt = next((x for x in node.inputs if x.type == "SHADER"), None)
                    link = gb._live_link(nxt) if nxt is not None else None
                    if link is None:
                        return None
                    node = link.from_node
                    continue
                break
            return node

        leaves = []

        def walk(node, weight, depth=0):
            if node is None or depth > 32:
                return
            if node.type == "MIX_SHADER":
                fac = gb.value(node.inputs[0], ())
                if isinstance(fac, float):
                    fac = min(max(fac, 0.0), 1.0)
                else:
                    n = node_name("clamp")
                    gb.nodes[n] = {"type": "clamp", "inputs": {"value": fac, "min": 0.0, "max": 1.0}}
                    fac = {"node": n, "output": "result"}
                walk(source(node.inputs[1]), math("multiply", weight, math("subtract", 1.0, fac)), depth + 1)
                walk(source(node.inputs[2]), math("multiply", weight, fac), depth + 1)
            elif node.type == "ADD_SHADER":
                walk(source(node.inputs[0]), weight, depth + 1)
                walk(source(node.inputs[1]), weight, depth + 1)
            else:
                leaves.append((node, weight))

        walk(root, 1.0)
        closures = []
        first = True
        media = []  # (leaf, subsurface block): the material has one medium, the first leaf's
        normals = []  # (leaf, the graph value driving its Normal input, or None)
        coat_normals = []  # (leaf, the graph value driving its linked Coat Normal)

        def subsurface_leaf(leaf, block, weight, sock_name):
            if block is None:
                return
            if media and media[0][1] != block:
                self.warnings.append(
                    "material '%s': several subsurface leaves with different settings in one Mix/Add Shader tree;"
                    " '%s' is rendered with the medium of '%s'" % (name, leaf.name, media[0][0].name))
            media.append((leaf, block))
            closure = {"kind": "subsurface", "weight": weight}
            colour = self._subsurface_colour(gb, leaf, sock_name, media[0][1])
            if colour is not None:
                closure["inputs"] = {"subsurface_color": colour}
            closures.append(closure)

        for leaf, weight in leaves:
            t = leaf.type
            S = lambda *n: _socket(leaf, *n)  # noqa: E731
            V = lambda sock, default: gb.value(sock, ()) if sock is not None else default  # noqa: E731
            inputs = None
            if t not in {"BSDF_TRANSPARENT", "EMISSION"} and leaf.inputs.get("Normal") is not None:
                sock = leaf.inputs["Normal"]
                normals.append((leaf, gb.value(sock, ()) if gb._live_link(sock) is not None else None))
            coat_sock = leaf.inputs.get("Coat Normal", leaf.inputs.get("Clearcoat Normal")) if t == "BSDF_PRINCIPLED" else None
            if coat_sock is not None and gb._live_link(coat_sock) is not None:
                coat_normals.append((leaf, gb.value(coat_sock, ())))
            if t == "SUBSURFACE_SCATTERING":
                subsurface_leaf(leaf, _sss_node_subsurface(leaf), weight, "Color")
                for sock_name in ("Radius", "Scale", "IOR", "Roughness", "Anisotropy"):
                    sock = leaf.inputs.get(sock_name)
                    if sock is not None and sock.is_linked:
                        self.warnings.append("material '%s': the link into '%s' of '%s' is not supported; its value is used"
                                             % (name, sock_name, leaf.name))
                continue
            if t == "BSDF_TRANSPARENT":
                # The colour multiplies what passes (per wavelength, upsampled as a reflectance).
                closures.append({"kind": "transparent", "weight": weight,
                                 "inputs": {"base_color": V(S("Color"), [1.0, 1.0, 1.0])}})
                continue
            if t == "BSDF_TRANSLUCENT":
                closures.append({"kind": "translucent", "weight": weight,
                                 "inputs": {"base_color": V(S("Color"), [0.8, 0.8, 0.8])}})
                continue
            if t == "EMISSION":
                closures.append({"kind": "emission", "weight": weight,
                                 "inputs": {"emission": V(S("Color"), [1.0, 1.0, 1.0]),
                                            "emission_strength": V(S("Strength"), 1.0)}})
                continue
            if t == "BSDF_DIFFUSE":
                inputs = {"base_color": V(S("Color"), [0.8, 0.8, 0.8]), "metallic": 0.0, "specular": 0.0,
                          "transmission": 0.0, "roughness": 1.0}
            elif t in {"BSDF_GLOSSY", "BSDF_ANISOTROPIC"}:
                inputs = {"base_color": V(S("Color"), [0.8, 0.8, 0.8]), "metallic": 1.0,
                          "roughness": V(S("Roughness"), 0.5), "transmission": 0.0}
            elif t == "BSDF_GLASS":
                inputs = {"base_color": V(S("Color"), [1.0, 1.0, 1.0]), "metallic": 0.0,
                          "roughness": V(S("Roughness"), 0.0), "transmission": 1.0}
                m["ior"] = float(_val(leaf, "IOR", default=1.5))
            elif t == "BSDF_REFRACTION":
                # The dielectric's refraction alone (Cycles' refraction closure has no Fresnel
                # term); the IOR is the material's, as for Glass.
                inputs = {"base_color": V(S("Color"), [1.0, 1.0, 1.0]), "metallic": 0.0,
                          "roughness": V(S("Roughness"), 0.0), "transmission": 1.0, "refraction": 1.0}
                m["ior"] = float(_val(leaf, "IOR", default=1.45))
            elif t == "BSDF_PRINCIPLED":
                spec = S("Specular IOR Level", "Specular")
                m["ior"] = float(_val(leaf, "IOR", default=1.5))
                # 4.x: 0.5 is neutral; 3.x: F0 = 0.08 x Specular whatever the IOR.
                spec_scale = 2.0 if spec is None or spec.name != "Specular" else _specular_3x_scale(m["ior"])
                inputs = {"base_color": V(S("Base Color"), [0.8, 0.8, 0.8]), "metallic": V(S("Metallic"), 0.0),
                          "roughness": V(S("Roughness"), 0.5), "specular": math("multiply", V(spec, 0.5), spec_scale),
                          "transmission": V(S("Transmission Weight", "Transmission"), 0.0)}
                e_col, e_str = S("Emission Color", "Emission"), S("Emission Strength")
                ev, sv = V(e_col, [0.0, 0.0, 0.0]), V(e_str, 1.0)
                if isinstance(ev, dict) or isinstance(sv, dict) or (max(ev[:3]) > 0.0 and sv > 0.0):
                    closures.append({"kind": "emission", "weight": weight,
                                     "inputs": {"emission": ev, "emission_strength": sv}})
                self._leaf_layers(name, leaf, inputs, gb, node_name, V)
                self._principled_warnings(name, leaf, {"Base Color", "Metallic", "Roughness", "Specular IOR Level",
                                                        "Specular", "Transmission Weight", "Transmission",
                                                        "Emission Color", "Emission", "Emission Strength", "IOR",
                                                        "Normal", "Coat Weight", "Coat Roughness", "Coat Tint", "Coat IOR",
                                                        "Coat Normal", "Clearcoat Normal",
                                                        "Clearcoat", "Clearcoat Roughness", "Sheen Weight",
                                                        "Sheen Tint", "Sheen Roughness", "Subsurface Weight",
                                                        "Subsurface", "Specular Tint", "Thin Film Thickness",
                                                        "Thin Film IOR"})
                # Subsurface Weight s splits the leaf: s of it is the subsurface medium (whose
                # boundary is this leaf's specular layer), 1 - s the Principled BSDF, as for a
                # Principled surface of its own (`_principled_subsurface`).
                s_sock = S("Subsurface Weight", "Subsurface")
                s_val = V(s_sock, 0.0)
                if isinstance(s_val, dict) or s_val > 0.0:
                    if not isinstance(s_val, dict):
                        s_val = min(s_val, 1.0)
                    block = _principled_subsurface(leaf, {"base": _rgb(S("Base Color").default_value)},
                                                   weight_override=1.0)
                    if block is not None:
                        subsurface_leaf(leaf, block, math("multiply", weight, s_val), _subsurface_colour_socket(leaf))
                        weight = math("multiply", weight, math("subtract", 1.0, s_val))
            else:
                self.warnings.append(
                    "material '%s': shader '%s' (%s) inside a Mix/Add Shader is not supported; its share renders black"
                    % (name, leaf.name, leaf.bl_idname))
                continue
            closures.append({"kind": "bsdf", "weight": weight, "inputs": inputs})
            if t == "BSDF_PRINCIPLED" and leaf.inputs.get("Clearcoat") is not None and "coat_weight" in inputs:
                # Blender 3.x's Clearcoat adds to the base without dimming it (see _principled_coat):
                # a material-wide setting of the coat, which every 3.x leaf shares.
                m["coat_additive"] = True
            if first:
                first = False
                for k in ("metallic", "roughness"):
                    if isinstance(inputs.get(k), float):
                        m[k] = inputs[k]
                if isinstance(inputs.get("base_color"), list):
                    m["base"] = inputs["base_color"][:3]
                if inputs.get("transmission") == 1.0:
                    m["transmission"] = 1.0
                m["specular"] = 0.0 if t == "BSDF_DIFFUSE" else None
        if root.type == "ADD_SHADER" and sum(1 for c in closures if c["kind"] == "bsdf") > 1:
            self.warnings.append(
                "material '%s': an Add Shader of BSDFs can reflect more than it receives; Prism normalises the sum"
                % name)
        if not closures:
            return None
        if media:
            # The graph's subsurface leaves carry the weight (material JSON `graph`).
            m["mixed_subsurface"] = dict(media[0][1], weight=1.0)
        graph = {"version": 1, "world_up": "z", "nodes": gb.nodes, "closures": closures}
        # The shading normal is the material's: exact when every scattering leaf takes its Normal
        # from the same source (the usual Bump or Normal Map feeding all the shaders); likewise
        # the coat's own normal (Coat Normal) of the coated Principled leaves.
        self._one_leaf_source(name, graph, "normal", "Normal", normals)
        self._one_leaf_source(name, graph, "coat_normal", "Coat Normal", coat_normals)
        return graph

    def _one_leaf_source(self, name, graph, input_name, socket_name, leaves):
        """Binds the graph input `input_name` to the value the leaves' `socket_name` links carry
        when every leaf in `leaves` [(leaf, value or None when unlinked)] takes it from the same
        source; otherwise warns, naming each linked leaf (the material has one such input)."""
        linked = [(leaf, v) for leaf, v in leaves if v is not None]
        if not linked:
            return
        if len(linked) == len(leaves) and all(v == linked[0][1] for _, v in linked):
            graph.setdefault("inputs", {})[input_name] = linked[0][1]
            return
        for leaf, _ in linked:
            self.warnings.append(
                "material '%s': the %s input of '%s' inside a Mix/Add Shader is not applied: the leaves of the tree"
                " take it from different sources (Prism shades them all with one)" % (name, socket_name, leaf.name))

    @staticmethod
    def _subsurface_colour(gb, node, sock_name, block):
        """The graph value of a textured subsurface colour (the link into `sock_name`, the
        socket that gives it), or None: unlinked, or a medium not given by a colour (a preset
        from the Prism panel), whose colour the renderer cannot replace."""
        sock = node.inputs.get(sock_name)
        if sock is None or block is None or not ("color" in block or "reflectance" in block):
            return None
        v = gb.value(sock, ()) if gb._live_link(sock) is not None else None
        return v if isinstance(v, dict) else None

    def _leaf_layers(self, name, leaf, inputs, gb, node_name, V):
        """A Principled leaf's Specular Tint, Thin Film, Coat and Sheen as its closure's inputs
        (`specular_tint`, `thin_film_thickness`, `thin_film_ior`, `coat_weight`,
        `coat_roughness`, `coat_tint`, `coat_ior`, `sheen_color`, `sheen_roughness`)."""
        tint = leaf.inputs.get("Specular Tint")
        if tint is not None and tint.type == "RGBA":
            tv = V(tint, [1.0, 1.0, 1.0])
            if isinstance(tv, dict) or any(abs(float(c) - 1.0) > 1e-6 for c in tv[:3]):
                inputs["specular_tint"] = tv if isinstance(tv, dict) else [max(float(c), 0.0) for c in tv[:3]]
        elif tint is not None:  # 3.x: a factor towards the base colour's hue
            if tint.is_linked:
                self.warnings.append("material '%s': a linked Specular Tint factor (Blender 3.x) inside a Mix/Add"
                                     " Shader is not supported; its value is used" % name)
            base = _rgb(_socket(leaf, "Base Color").default_value)
            t = _principled_specular_tint(leaf, base)
            if t is not None and any(abs(c - 1.0) > 1e-6 for c in t):
                inputs["specular_tint"] = t
        film = leaf.inputs.get("Thin Film Thickness")
        if film is not None:
            fv = V(film, 0.0)
            if isinstance(fv, dict) or fv > 0.0:
                inputs["thin_film_thickness"] = fv
                inputs["thin_film_ior"] = V(leaf.inputs.get("Thin Film IOR"), 1.33)
        cw = _socket(leaf, "Coat Weight", "Clearcoat")
        if cw is not None:
            wv = V(cw, 0.0)
            if cw.name == "Clearcoat":  # 3.x: a quarter (see _principled_coat)
                if isinstance(wv, dict):
                    n = node_name("clearcoat")
                    gb.nodes[n] = {"type": "math", "operation": "multiply", "inputs": {"a": wv, "b": 0.25}}
                    wv = {"node": n, "output": "value"}
                else:
                    wv = 0.25 * float(wv)
            if isinstance(wv, dict) or wv > 0.0:
                inputs["coat_weight"] = wv
                inputs["coat_roughness"] = V(_socket(leaf, "Coat Roughness", "Clearcoat Roughness"), 0.03)
                tint = _socket(leaf, "Coat Tint")
                if tint is not None:
                    inputs["coat_tint"] = V(tint, [1.0, 1.0, 1.0])
                ior = _socket(leaf, "Coat IOR")
                if ior is not None:
                    iv = V(ior, 1.5)
                    inputs["coat_ior"] = iv if isinstance(iv, dict) else min(max(float(iv), 1.0), 4.0)
        sw = _socket(leaf, "Sheen Weight")
        if sw is None:
            return
        wv, tv = V(sw, 0.0), V(_socket(leaf, "Sheen Tint"), [1.0, 1.0, 1.0])
        if isinstance(wv, dict) or isinstance(tv, dict):
            n = node_name("sheen_color")
            a = wv if isinstance(wv, dict) else [float(wv)] * 3
            gb.nodes[n] = {"type": "vector_math", "operation": "multiply", "inputs": {"a": a, "b": tv}}
            inputs["sheen_color"] = {"node": n, "output": "vector"}
        elif wv > 0.0:
            inputs["sheen_color"] = [min(max(float(wv) * float(c), 0.0), 1.0) for c in tv[:3]]
        else:
            return
        rv = V(_socket(leaf, "Sheen Roughness"), 0.5)
        inputs["sheen_roughness"] = rv if isinstance(rv, dict) else min(max(float(rv), 0.0), 1.0)

    def _graph_normal(self, gb, node, m, handled):
        """The shader's Normal input through the graph (Bump nodes, ...) unless it is the
        tangent-space normal map the glTF path carries."""
        handled.add("Normal")
        sock = node.inputs.get("Normal")
        if sock is None or not sock.is_linked or m.get("normal") is not None:
            return
        if gb.bind("normal", sock):
            m.pop("normal_unsupported", None)

    def _linked_warnings(self, name, node, handled):
        for sock in node.inputs:
            if sock.is_linked and sock.identifier not in handled and sock.name not in handled and sock.enabled:
                src = sock.links[0].from_node
                self.warnings.append(
                    "material '%s': the link from '%s' into '%s' of '%s' is not supported; its value is used"
                    % (name, src.name, sock.name, node.name)
                )

    def _principled_warnings(self, name, node, handled):
        """Names the Principled inputs Prism does not render yet (linked or set away from their
        neutral value): never a silent drop."""
        handled = set(handled)
        # Inputs the exporter translates from their values (subsurface, IOR) are handled when unlinked.
        self._linked_warnings(name, node, handled)
        checks = [
            # Blender 3.x's Sheen (the Disney model): translated on a Principled BSDF on the
            # output (`_principled_sheen_3x`), not inside Mix / Add Shaders.
            ("Sheen", lambda v: v > 0.0, "Sheen (Blender 3.x's model)"),
            ("Anisotropic", lambda v: v > 0.0, "Anisotropic"),
        ]
        for sock_name, bad, what in checks:
            sock = node.inputs.get(sock_name)
            if sock is None or sock.is_linked or sock_name in handled:
                continue
            try:
                if bad(float(sock.default_value)):
                    self.warnings.append("material '%s': %s is not supported yet and is ignored" % (name, what))
            except TypeError:
                pass

    def _material(self, mat):
        key = mat.name if mat is not None else None
        if key in self.material_index:
            return self.material_index[key]
        name = mat.name if mat is not None else "PrismDefault"
        if mat is not None:
            self._originals[name] = mat.original
        m, sss, ok = convert_material(mat)
        mixed = None
        surface = _surface_node(mat) if mat is not None else None
        # A Holdout shader on the output: a transparent hole (material JSON "holdout").
        holdout = surface is not None and surface.type == "HOLDOUT"
        if holdout:
            ok = True
        elif surface is not None and surface.type in {"MIX_SHADER", "ADD_SHADER", "BSDF_TRANSPARENT", "BSDF_TRANSLUCENT",
                                                      "BSDF_REFRACTION"}:
            mixed = self._mixed_graph(name, surface, m)
            ok = mixed is not None
        volume = self._volume(mat, name) if mat is not None else None
        if volume is not None and surface is None:
            # Only a Volume shader: the surface does not scatter (Cycles makes it transparent).
            ok = True
        for note in (m.get("approximation"), m.get("sheen_3x_note")):
            if note:
                self.warnings.append("material '%s': %s" % (name, note))
        if not ok:
            self.unsupported.append(name)
            node = _surface_node(mat)
            if node is not None:
                self.warnings.append(
                    "material '%s': surface shader '%s' (%s) is not supported; rendered grey diffuse"
                    % (name, node.name, node.bl_idname)
                )
        graph = None if holdout else mixed or (self._graph(mat, name, m, sss) if ok and mat is not None else None)
        if holdout:
            self.material_json.setdefault(name, {})["holdout"] = True
        elif m.get("principled_v1") and mixed is None:
            # Blender 3.x's Principled BSDF as Cycles 3.x renders it (a Disney diffuse base the
            # specular layer adds to, single-scattering GGX; src/bsdf/metallic_roughness.rs).
            self.material_json.setdefault(name, {})["model"] = "principled_v1"
        elif (mixed is None and surface is not None and surface.type in _SINGLE_SCATTER_NODES
              and getattr(surface, "distribution", "MULTI_GGX") in _SINGLE_SCATTER_DISTRIBUTIONS):
            # A Glass or Glossy BSDF whose distribution scatters once (Blender 3.x's defaults:
            # GGX, Beckmann): Cycles adds no multiple-scattering energy, so neither does the
            # renderer's glTF model (Beckmann's lobe is rendered as GGX's of the same roughness).
            self.material_json.setdefault(name, {})["model"] = "gltf"
        if (surface is not None and surface.type == "BSDF_PRINCIPLED" and not m.get("principled_v1")
                and getattr(surface, "distribution", "MULTI_GGX") == "GGX"):
            self.warnings.append("material '%s': Principled BSDF '%s' with the GGX distribution is rendered as "
                                 "Multiscatter GGX (rough surfaces up to about 10%% brighter than in Cycles)"
                                 % (name, surface.name))
        g = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [min(max(c, 0.0), 1.0) for c in m["base"]] + [1.0],
                "metallicFactor": min(max(m["metallic"], 0.0), 1.0),
                "roughnessFactor": min(max(m["roughness"], 0.0), 1.0),
            },
            "doubleSided": not (mat is not None and getattr(mat, "use_backface_culling", False)),
        }
        ext = {}
        if m["image"] is not None:
            tex = len(self._textures)
            self._textures.append({"source": self._image(m["image"]), "sampler": 0})
            g["pbrMetallicRoughness"]["baseColorTexture"] = {"index": tex}
            g["pbrMetallicRoughness"]["baseColorFactor"] = [1.0, 1.0, 1.0, 1.0]
        nm = m.get("normal")
        if nm is not None:
            if not _is_data(nm["image"]):
                self.warnings.append(
                    "material '%s': normal map image '%s' is not Non-Color; exported decoded to linear, as Cycles reads it"
                    % (name, nm["image"].name)
                )
            tex = len(self._textures)
            self._textures.append({"source": self._image(nm["image"], data=True), "sampler": 0})
            g["normalTexture"] = {"index": tex, "scale": nm["scale"]}
            self.normal_uv_maps[name] = nm["uv_map"]
        if m.get("normal_unsupported"):
            self.unsupported_normals.append(name)
        e = [max(c, 0.0) for c in m["emission"]]
        s = max(m["emission_strength"], 0.0)
        if max(e) > 0.0 and s > 0.0:
            peak = max(e)
            g["emissiveFactor"] = [c / peak for c in e]
            ext["KHR_materials_emissive_strength"] = {"emissiveStrength": peak * s}
        if m["transmission"] > 0.0:
            ext["KHR_materials_transmission"] = {"transmissionFactor": min(m["transmission"], 1.0)}
        if abs(m["ior"] - 1.5) > 1e-6:
            ext["KHR_materials_ior"] = {"ior": max(m["ior"], 1.0)}
        tint = m.get("specular_tint")
        tinted = tint is not None and any(abs(c - 1.0) > 1e-6 for c in tint)
        if (m["specular"] is not None and abs(m["specular"] - 1.0) > 1e-6) or tinted:
            spec = m["specular"] if m["specular"] is not None else 1.0
            ext["KHR_materials_specular"] = {"specularFactor": max(spec, 0.0)}
            if tinted:
                ext["KHR_materials_specular"]["specularColorFactor"] = tint
        film = m.get("thin_film")
        if film is not None:
            ext["KHR_materials_iridescence"] = {"iridescenceFactor": 1.0, "iridescenceIor": film[1],
                                                "iridescenceThicknessMinimum": film[0],
                                                "iridescenceThicknessMaximum": film[0]}
        coat = m.get("coat")
        if coat is not None:
            weight, roughness, ior, tint = coat
            ext["KHR_materials_clearcoat"] = {"clearcoatFactor": weight, "clearcoatRoughnessFactor": roughness}
            g["extras"] = {"prism_coat_ior": ior, "prism_coat_tint": tint}
        if m.get("coat_additive"):
            g.setdefault("extras", {})["prism_coat_additive"] = True
        sheen = m.get("sheen")
        if sheen is not None:
            ext["KHR_materials_sheen"] = {"sheenColorFactor": sheen[0], "sheenRoughnessFactor": sheen[1]}
            if (m.get("transmission") or 0.0) > 0.0:
                self.warnings.append("material '%s': Sheen on a transmissive Principled BSDF is not rendered" % name)
        if ext:
            g["extensions"] = ext
        self.materials.append(g)
        self.material_index[key] = len(self.materials) - 1
        override = prism_override(mat)
        if override is not None:
            self.material_json[name] = override
            if graph is not None and _drop_subsurface_colour(graph):
                self.warnings.append("material '%s': the Prism panel's medium replaces the node tree's, so the texture on"
                                     " its subsurface colour is not applied" % name)
        elif sss is not None or m.get("mixed_subsurface") is not None:
            self.material_json[name] = {"subsurface": sss if sss is not None else m["mixed_subsurface"]}
        if graph is not None:
            self.material_json.setdefault(name, {})["graph"] = graph
        if volume is not None:
            if "subsurface" in self.material_json.get(name, {}):
                self.warnings.append("material '%s': a Volume shader together with subsurface scattering is not supported; the volume is ignored" % name)
            else:
                entry = self.material_json.setdefault(name, {})
                entry["volume"] = volume
                if surface is None:
                    entry["surface"] = "none"
                vg = self.volume_graphs.get(name)
                if vg is not None:
                    # One graph per material: the volume's density beside the surface inputs
                    # (node names are the node tree's own, unique within it).
                    g = entry.get("graph")
                    if g is None:
                        entry["graph"] = vg
                    else:
                        g["nodes"].update(vg["nodes"])
                        g["inputs"].update(vg["inputs"])
        return self.material_index[key]

    def _volume(self, mat, name):
        """The material JSON `volume` of the shader on the Material Output's Volume input."""
        node = _output_node(mat, "Volume")
        if node is None:
            return None
        warned = set()

        def warn(n, what):
            if (n.name, what) not in warned:
                warned.add((n.name, what))
                self.warnings.append("material '%s': node '%s' (%s): %s" % (name, n.name, n.bl_idname, what))

        lobes = volume_lobes(node, warn, densities=True, colors=True)
        if lobes is None:
            # Not translatable (warned): an empty volume, so a surface-less material stays
            # invisible as in Cycles instead of turning into a grey surface.
            return {"sigma_a": [0.0] * 3, "sigma_s": [0.0] * 3, "g": 0.0}
        colors = {l.color.as_pointer(): l.color for l in lobes if l.color is not None}
        if len(colors) > 1:
            # One colour field per volume (the renderer mixes two ends by it): several cannot
            # be represented; their values are used (warned as linked inputs).
            lobes = volume_lobes(node, warn, densities=True, colors=False)
            colors = {}
        sockets = {l.density.as_pointer(): l.density for l in lobes if l.density is not None}
        extinct = [l for l in lobes if max(l.sigma_a + l.sigma_s + l.sigma_a0 + l.sigma_s0) > 0.0]
        if sockets and (len(sockets) > 1 or any(l.density is None for l in extinct)):
            # One density field per volume: several, or one beside constant densities, cannot
            # be represented; fall back to the sliders' values.
            lobes = volume_lobes(node, warn, densities=False, colors=bool(colors))
            sockets = {}
        merged = lambda: self.warnings.append(
            "material '%s': volume scattering lobes with different Anisotropy are merged into one (their sigma_s-weighted mean)" % name)
        volume = volume_json(lobes, merged)
        if volume is not None and (sockets or colors):
            gb = GraphBuilder(name, self._graph_image, self._uv_set, self._color_set, self.warnings.append)
            density_bound = bool(sockets) and bool(gb.bind("volume_density", next(iter(sockets.values()))))
            if colors and not gb.bind("volume_color", next(iter(colors.values()))):
                # The colour's nodes are not translatable (the builder warned): its value.
                lobes = volume_lobes(node, lambda n, what: None, densities=density_bound, colors=False)
                volume = volume_json(lobes, lambda: None)
                colors = {}
            if density_bound or colors:
                self.volume_graphs[name] = gb.result()
        return volume

    def _mesh(self, key, me, slots, ob=None, deformation=None):
        """glTF mesh index of evaluated mesh `me` (cached by `key`); `deformation`: its
        `motion.vertex_data` per shutter key (deformation blur), or None."""
        if key in self.mesh_cache:
            return self.mesh_cache[key]
        triangles = _mesh_triangles(me)
        if triangles is None:
            self.mesh_cache[key] = None
            return None
        tri_loops, tri_mat = triangles
        materials = {}
        for mi in np.unique(tri_mat):
            mi = int(mi)
            materials[mi] = self._baked_variant(self._material(slots[mi] if 0 <= mi < len(slots) else None), ob, me)
        # Normal-mapped materials need per-corner MikkTSpace tangents, so per-corner arrays;
        # so do the UV maps and colour attributes that shading graphs read.
        needs_tangents = any(self._uses_tangents(self.materials[i]) for i in materials.values())
        graph_names = [self.materials[i]["name"] for i in materials.values()]
        reads_attributes = any("graph" in self.material_json.get(n, {}) for n in graph_names)
        corner = {}
        if reads_attributes:
            corner, missing = _corner_attributes(me, _corner_vertices(me, len(me.loops)), self.uv_sets, self.color_sets)
            for what in missing:
                self.warnings.append("mesh '%s': %s not found; the active one is read" % (me.name, what))
        pos, nrm, uv, groups, per_vertex = _mesh_arrays(
            me, tri_loops, tri_mat, per_vertex_allowed=not needs_tangents and not corner
        )
        attrs = {"POSITION": self.buf.accessor(pos, "VEC3", minmax=True)}
        if nrm is not None:
            attrs["NORMAL"] = self.buf.accessor(nrm, "VEC3")
        if uv is not None:
            attrs["TEXCOORD_0"] = self.buf.accessor(uv, "VEC2")
        for attr_name, arr in sorted(corner.items()):
            attrs[attr_name] = self.buf.accessor(np.ascontiguousarray(arr, np.float32), "VEC2" if arr.shape[1] == 2 else "VEC4")
        self._mesh_tangent_attribute(me, attrs, [self.materials[i] for i in materials.values()])
        targets = None
        if deformation:
            keyed = _deformation_targets(me, deformation, pos, nrm, per_vertex)
            if keyed is None:
                self.warnings.append("motion blur: mesh '%s' does not match its shutter keys; its deformation is not"
                                     " blurred" % me.name)
            else:
                targets = [{k: self.buf.accessor(np.ascontiguousarray(v, np.float32), "VEC3", minmax=k == "POSITION")
                            for k, v in t.items()} for t in keyed]
        prims = []
        for mi, idx in groups.items():
            prims.append(
                {
                    "attributes": attrs,
                    "indices": self.buf.accessor(idx, "SCALAR", target=34963),
                    "material": materials[mi],
                }
            )
            if targets:
                prims[-1]["targets"] = targets
            self.n_triangles += len(idx) // 3
        gm = {"name": me.name, "primitives": prims}
        if targets:
            # The morph targets are the vertices over the shutter (src/scene/gltf_import.rs
            # `deformation_keys`), not blend shapes: their weights stay 0 for other viewers.
            gm["extras"] = {"prism_deformation": True}
        self.meshes.append(gm)
        self.mesh_cache[key] = len(self.meshes) - 1
        return self.mesh_cache[key]

    def _uses_tangents(self, g):
        """The glTF material has a normal map, or its shading graph a tangent-space one."""
        if "normalTexture" in g:
            return True
        graph = self.material_json.get(g["name"], {}).get("graph", {})
        return any(n.get("type") == "normal_map" and n.get("space") == "tangent"
                   for n in graph.get("nodes", {}).values())

    def _mesh_tangent_attribute(self, me, attrs, materials):
        """Adds TANGENT (MikkTSpace, as Cycles uses) when a material of the mesh is normal-mapped."""
        mapped = [g["name"] for g in materials if self._uses_tangents(g)]
        if not mapped or "TEXCOORD_0" not in attrs:
            return
        layer = me.uv_layers.active  # the exported TEXCOORD_0
        for name in mapped:
            want = self.normal_uv_maps.get(name, "")
            if want and want != layer.name:
                self.warnings.append(
                    "material '%s': the Normal Map node's UV map '%s' is not exported; using '%s'" % (name, want, layer.name)
                )
        tangents = _mesh_tangents(me, layer.name)
        if tangents is None:
            self.warnings.append(
                "mesh '%s': Blender cannot compute tangents (n-gons?); Prism derives them per triangle from the UVs" % me.name
            )
            return
        attrs["TANGENT"] = self.buf.accessor(tangents, "VEC4")

    # -- objects
    def _add_mesh_object(self, ob, matrix, is_instance, motion_key=None):
        if self.shading_only:
            # The materials the mesh can draw with (a superset of those its triangles use), and
            # the default one for faces without a slot.
            slots = [s.material for s in ob.material_slots]
            if ob.type == "MESH" and not slots:
                slots = list(ob.data.materials)
            for mat in slots + [None]:
                self._material(mat)
            return
        if ob.type == "MESH":
            me = ob.data
            key = ("mesh", me.as_pointer())
            slots = [s.material for s in ob.material_slots] or list(me.materials)
            deformation = self.motion.deformations.get(motion_key) if self.motion is not None else None
            if deformation:
                key = key + ("deforming", motion_key)  # not an instance's rigid copy
            mi = self._mesh(key, me, slots, ob, deformation)
        else:
            try:
                me = ob.to_mesh()
            except RuntimeError:
                return
            if me is None:
                return
            try:
                slots = [s.material for s in ob.material_slots]
                mi = self._mesh(("obj", ob.name, len(self.nodes)), me, slots, ob)
            finally:
                ob.to_mesh_clear()
        if mi is not None:
            node = {"name": ob.name, "mesh": mi, "matrix": _matrix(matrix)}
            # Ray visibility the renderer honours: Camera and Shadow (3.0+ object properties).
            extras = {}
            if not getattr(ob, "visible_camera", True):
                extras["prism_visible_camera"] = False
            if not getattr(ob, "visible_shadow", True):
                extras["prism_casts_shadows"] = False
            if self._is_holdout(ob):
                extras["prism_holdout"] = True
            moving = self.motion.objects.get(motion_key) if self.motion is not None else None
            if moving:
                extras["prism_motion"] = [_matrix(m) for m in moving]
            if extras:
                node["extras"] = extras
            self._child(node)

    def _light_emission(self, ob):
        """(linear RGB colour, power scale) of light `ob` as Cycles sees it: colour x
        Temperature x the node tree's Emission colour and strength, power x 2^Exposure."""
        L = ob.data
        col = [float(c) for c in L.color[:3]]
        if getattr(L, "use_temperature", False):
            tc = getattr(L, "temperature_color", None)
            t = list(tc) if tc is not None else blackbody_rgb(L.temperature)
            col = [c * k for c, k in zip(col, t)]
        scale = 2.0 ** float(getattr(L, "exposure", 0.0))
        if getattr(L, "use_nodes", False) and L.node_tree is not None:
            node_col, node_strength = self._light_nodes(ob)
            col = [c * k for c, k in zip(col, node_col)]
            scale *= node_strength
        return col, scale

    def _light_nodes(self, ob):
        """Colour and strength of the Emission node feeding a light's output: constants or a
        Blackbody of constant temperature; anything else is warned about and taken as white."""
        tree = ob.data.node_tree
        out = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputLight" and n.is_active_output), None)
        out = out or next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputLight"), None)
        if out is None or not out.inputs["Surface"].is_linked:
            return (1.0, 1.0, 1.0), 1.0
        em = out.inputs["Surface"].links[0].from_node
        if em.bl_idname != "ShaderNodeEmission":
            self.warnings.append("light '%s': node '%s' (%s) on the light output is not translated; the light's colour and power are used"
                                 % (ob.name, em.name, em.bl_idname))
            return (1.0, 1.0, 1.0), 1.0
        col = (1.0, 1.0, 1.0)
        c_in = em.inputs["Color"]
        if c_in.is_linked:
            src = c_in.links[0].from_node
            t_in = src.inputs.get("Temperature") if src.bl_idname == "ShaderNodeBlackbody" else None
            if t_in is not None and not t_in.is_linked:
                col = blackbody_rgb(t_in.default_value)
            else:
                self.warnings.append("light '%s': node '%s' (%s) on the Emission colour is not translated; white is used"
                                     % (ob.name, src.name, src.bl_idname))
        else:
            col = tuple(float(v) for v in c_in.default_value[:3])
        s_in = em.inputs["Strength"]
        strength = float(s_in.default_value)
        if s_in.is_linked:
            src = s_in.links[0].from_node
            self.warnings.append("light '%s': node '%s' (%s) on the Emission strength is not translated; strength %g is used"
                                 % (ob.name, src.name, src.bl_idname, strength))
        return col, strength

    def _add_tubes(self, name, strands, material, matrix=None, motion_key=None):
        """Hair strands (points, radii, offsets) as a tube mesh (hair.py) drawn with `material`."""
        mesh = hair.tube_mesh(*strands)
        if mesh is None:
            return
        pos, nrm, idx = mesh
        prim = {
            "attributes": {"POSITION": self.buf.accessor(pos, "VEC3", minmax=True), "NORMAL": self.buf.accessor(nrm, "VEC3")},
            "indices": self.buf.accessor(idx, "SCALAR", target=34963),
            "material": self._material(material),
        }
        self.meshes.append({"name": name, "primitives": [prim]})
        self.n_triangles += len(idx) // 3
        node = {"name": name, "mesh": len(self.meshes) - 1}
        if matrix is not None:
            node["matrix"] = _matrix(matrix)
        moving = self.motion.objects.get(motion_key) if self.motion is not None else None
        if moving:
            node["extras"] = {"prism_motion": [_matrix(m) for m in moving]}
        self._child(node)

    def _add_particle_hair(self, ob):
        """The object's particle hair systems (render as Path) as tubes, in world space."""
        enabled = {
            mod.particle_system.name: (mod.show_viewport if self.viewport else mod.show_render)
            for mod in ob.modifiers if mod.type == "PARTICLE_SYSTEM"
        }
        for ps in getattr(ob, "particle_systems", ()):
            st = ps.settings
            if st.type != "HAIR" or st.render_type != "PATH" or not enabled.get(ps.name, True):
                continue
            slot = int(st.material) - 1
            mat = ob.material_slots[slot].material if 0 <= slot < len(ob.material_slots) else None
            if self.shading_only:
                self._material(mat)
                continue
            strands = hair.particle_strands(ob, ps, self.viewport)
            if strands is not None:
                self._add_tubes("%s.%s" % (ob.name, ps.name), strands, mat)
                if self.motion is not None and ("O", ob.original.name) in self.motion.objects:
                    self.hair_objects.append(ob.name)

    def _add_curves_object(self, ob, matrix, motion_key=None):
        """A Curves object (hair curves) as tubes, in object space under the object's transform."""
        mat = ob.material_slots[0].material if len(ob.material_slots) else None
        if self.shading_only:
            self._material(mat)
            return
        strands, has_radius = hair.curves_strands(ob.data)
        if strands is None:
            return
        if not has_radius:
            self.warnings.append("object '%s': its curves have no 'radius' attribute, so they have no width and are "
                                 "not rendered (as in Cycles)" % ob.name)
            return
        if len(ob.material_slots) > 1:
            self.warnings.append("object '%s': curves are drawn with its first material only" % ob.name)
        self._add_tubes(ob.name, strands, mat, matrix, motion_key)

    def _light_ray_visibility(self, ob):
        """The light's Ray Visibility as extras (`prism_visible_diffuse` / `_glossy` /
        `_transmission` / `_volume_scatter`, written when off)."""
        out = {}
        for kind in ("diffuse", "glossy", "transmission", "volume_scatter"):
            if not getattr(ob, "visible_" + kind, True):
                out["prism_visible_" + kind] = False
        return out

    def _is_holdout(self, ob):
        """Object > Visibility > Holdout, or a holdout collection of the rendered view layer."""
        if getattr(ob, "is_holdout", False):
            return True
        orig = getattr(ob, "original", None) or ob
        try:
            return bool(orig.holdout_get(view_layer=self.dg.view_layer))
        except (AttributeError, TypeError, RuntimeError):
            return False

    def _add_light(self, ob, matrix):
        L = ob.data
        ray_visibility = self._light_ray_visibility(ob)
        col, scale = self._light_emission(ob)
        power = L.energy * scale
        normalize = bool(getattr(L, "normalize", True))
        if L.type in {"POINT", "SPOT"}:
            radius = max(float(L.shadow_soft_size), 0.0)
            # Cycles: radiance P / (pi x area) over a sphere of area 4 pi r^2 (a point: area 4),
            # i.e. intensity P / (4 pi); with Normalize off the area is not divided out.
            if normalize:
                intensity = power / (4.0 * math.pi)
            else:
                intensity = power * radius * radius if radius > 0.0 else power / math.pi
            light = {
                "type": "point" if L.type == "POINT" else "spot",
                "color": col,
                "intensity": intensity * WATTS_TO_LUMENS,
            }
            extras = {}
            if L.type == "SPOT":
                outer = L.spot_size / 2.0
                light["spot"] = {"outerConeAngle": outer, "innerConeAngle": outer - outer * L.spot_blend}
                if bpy_version() < (4, 0, 0):
                    # Cycles 3.x's spot intensity also falls off with the cosine to the axis.
                    extras["prism_spot_cosine"] = True
            if radius > 0.0:
                extras.update({
                    "prism_radius": radius,
                    # 3.x has no Soft Falloff: its point lights are the facing disc.
                    "prism_soft_falloff": bool(getattr(L, "use_soft_falloff", True)),
                    "prism_visible_camera": bool(getattr(ob, "visible_camera", False)),
                })
            if extras:
                light["extras"] = extras
        elif L.type == "SUN":
            light = {"type": "directional", "color": col, "intensity": power * WATTS_TO_LUMENS}
            # The sun's angular diameter (a soft sun: its disc is seen in glossy reflections and
            # BSDF samples can hit it, as in Cycles); glTF has no field for it.
            angle = float(getattr(L, "angle", 0.0))
            if angle > 0.0:
                light["extras"] = {"prism_angle": min(angle, math.pi)}
        elif L.type == "AREA":
            self._add_area_light(ob, matrix, ray_visibility)
            return
        else:
            return
        if ray_visibility:
            light.setdefault("extras", {}).update(ray_visibility)
        light["name"] = ob.name
        self.lights.append(light)
        self._child(
            {
                "name": ob.name,
                "matrix": _matrix(_unscaled(matrix)),
                "extensions": {"KHR_lights_punctual": {"light": len(self.lights) - 1}},
            }
        )

    def _add_area_light(self, ob, matrix, ray_visibility=None):
        L = ob.data
        sx = L.size
        sy = L.size_y if L.shape in {"RECTANGLE", "ELLIPSE"} else L.size
        if L.shape in {"DISK", "ELLIPSE"}:
            n = 48
            ang = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
            ring = np.stack([0.5 * sx * np.cos(ang), 0.5 * sy * np.sin(ang), np.zeros(n)], axis=1)
            pos = np.vstack([[0.0, 0.0, 0.0], ring]).astype(np.float32)
            # clockwise seen from +Z -> geometric normal -Z (the light's emitting side)
            idx = np.array([[0, 1 + (i + 1) % n, 1 + i] for i in range(n)], np.uint32).reshape(-1)
            area_local = 0.5 * n * (0.25 * sx * sy) * math.sin(2.0 * math.pi / n)
        else:
            hx, hy = 0.5 * sx, 0.5 * sy
            pos = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], np.float32)
            idx = np.array([0, 2, 1, 0, 3, 2], np.uint32)
            area_local = sx * sy
        m3 = matrix.to_3x3()
        ax, ay = m3.col[0].length, m3.col[1].length
        area = area_local * ax * ay
        if area <= 0.0:
            return
        col, scale = self._light_emission(ob)
        spread = float(getattr(L, "spread", math.pi))
        # Cycles: radiance P / (pi A); with Normalize off (5.0) the power is per unit area.
        radiance = L.energy * scale / (math.pi * (area if getattr(L, "normalize", True) else 1.0))
        peak = max(col) if max(col) > 0 else 1.0
        nrm = np.tile(np.array([0.0, 0.0, -1.0], np.float32), (len(pos), 1))
        # Cycles' area lights emit from the front only and are otherwise invisible: paths go
        # through them. An index-matched (IOR 1) clear dielectric lets paths through here too.
        mat = {
            "name": "PrismAreaLight_%s" % ob.name,
            "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
            "emissiveFactor": [c / peak for c in col],
            "extensions": {
                "KHR_materials_emissive_strength": {"emissiveStrength": radiance * peak},
                "KHR_materials_transmission": {"transmissionFactor": 1.0},
                "KHR_materials_ior": {"ior": 1.0},
            },
            "doubleSided": False,
        }
        if spread < math.pi - 1e-4:
            # Blender's Spread: the soft-box profile of `lights/spread.rs`, same power.
            mat["extras"] = {"prism_emission_spread": max(spread, 0.0)}
        if bpy_version() < (4, 0, 0):
            # Cycles 3.x emits an area light pi/4 as strongly as 4.x and later for the same
            # power, at every spread including the default 180 degrees (measured in 3.4.1,
            # square and disc, sizes 0.5 and 2, spreads 10 to 180 degrees: 1.2732 = 4/pi).
            strength = mat["extensions"]["KHR_materials_emissive_strength"]
            strength["emissiveStrength"] *= math.pi / 4.0
        self.materials.append(mat)
        prim = {
            "attributes": {
                "POSITION": self.buf.accessor(pos, "VEC3", minmax=True),
                "NORMAL": self.buf.accessor(nrm, "VEC3"),
            },
            "indices": self.buf.accessor(idx, "SCALAR", target=34963),
            "material": len(self.materials) - 1,
        }
        self.meshes.append({"name": "AreaLight_%s" % ob.name, "primitives": [prim]})
        # A Blender light is not geometry: it casts no shadow, and camera rays see it only
        # with the object's Camera ray visibility on (off by default for lights, 3.x and 5.x).
        extras = {
            "prism_area_light": True,
            "prism_visible_camera": bool(getattr(ob, "visible_camera", False)),
        }
        extras.update(ray_visibility or {})
        self._child({"name": ob.name, "mesh": len(self.meshes) - 1, "matrix": _matrix(matrix), "extras": extras})

    def _add_camera(self):
        cam_ob = self.scene.camera
        if cam_ob is None and self.viewport:
            return
        if cam_ob is None:
            raise ExportError("the scene has no active camera")
        cam_ob = cam_ob.evaluated_get(self.dg)
        c = cam_ob.data
        panorama = self._panorama(cam_ob) if c.type == "PANO" else None
        r = self.scene.render
        # Cycles' view plane: the sensor (or ortho_scale) spans the fitted dimension.
        w = self.width * r.pixel_aspect_x
        h = self.height * r.pixel_aspect_y
        fit = c.sensor_fit
        if fit == "AUTO":
            fit = "HORIZONTAL" if w > h else "VERTICAL"
            sensor = c.sensor_width
        else:
            sensor = c.sensor_width if fit == "HORIZONTAL" else c.sensor_height
        if c.type == "ORTHO":
            half = 0.5 * c.ortho_scale
            ymag = half * h / w if fit == "HORIZONTAL" else half
            xmag = ymag * w / h
            proj = {"type": "orthographic", "orthographic": {"xmag": xmag, "ymag": ymag, "znear": max(c.clip_start, 0.0), "zfar": max(c.clip_end, c.clip_start + 1e-3)}}
        else:
            half = 0.5 * sensor / c.lens
            tan_y = half * h / w if fit == "HORIZONTAL" else half
            proj = {"type": "perspective", "perspective": {"yfov": 2.0 * math.atan(tan_y), "znear": max(c.clip_start, 1e-4)}}
        self.cameras.append(dict(name=cam_ob.name, **proj))
        cam_node = {"name": cam_ob.name, "camera": 0, "matrix": _matrix(_unscaled(cam_ob.matrix_world))}
        if self.motion is not None and self.motion.camera:
            cam_node["extras"] = {"prism_motion": [_matrix(_unscaled(m)) for m in self.motion.camera]}
        self._child(cam_node)
        block = {}
        if panorama is not None:
            if c.dof.use_dof:
                self.warnings.append("camera '%s': depth of field is not rendered with panoramic cameras" % cam_ob.name)
            if c.shift_x or c.shift_y:
                self.warnings.append("camera '%s': shift is ignored by panoramic cameras" % cam_ob.name)
            if panorama.get("projection") == "fisheye_equisolid":
                # Cycles: the fitted sensor size spans the fitted dimension.
                sw, sh = (sensor, sensor * h / w) if fit == "HORIZONTAL" else (sensor * w / h, sensor)
                panorama["sensor"] = [sw, sh]
            block.update(panorama)
        else:
            block.update(self._depth_of_field(cam_ob) or {})
            if c.shift_x or c.shift_y:
                # Blender's shift is a fraction of the fitted dimension; the renderer's of the
                # view's height.
                per_height = w / h if fit == "HORIZONTAL" else 1.0
                block["shift"] = [c.shift_x * per_height, c.shift_y * per_height]
        self.camera_lens = block or None

    def _panorama(self, cam_ob):
        """The material JSON camera projection of a panoramic camera (5.0: the camera's own
        settings; 3.x: Cycles' camera settings), or None (a warning) for a type Prism lacks."""
        c = cam_ob.data
        src = c if hasattr(c, "panorama_type") else getattr(c, "cycles", None)
        kind = getattr(src, "panorama_type", None)
        if kind == "EQUIRECTANGULAR":
            return {
                "projection": "equirectangular",
                "longitude": [float(src.longitude_min), float(src.longitude_max)],
                "latitude": [float(src.latitude_min), float(src.latitude_max)],
            }
        if kind == "FISHEYE_EQUIDISTANT":
            return {"projection": "fisheye_equidistant", "fisheye_fov": float(src.fisheye_fov)}
        if kind == "FISHEYE_EQUISOLID":
            return {"projection": "fisheye_equisolid", "fisheye_fov": float(src.fisheye_fov),
                    "fisheye_lens": float(src.fisheye_lens)}
        self.warnings.append("camera '%s': %s panoramas are not supported; rendering as perspective"
                             % (cam_ob.name, str(kind).lower().replace("_", " ")))
        return None

    def _depth_of_field(self, cam_ob):
        """Cycles' thin lens: radius = focal length [mm] * 1e-3 / (2 f-stop) (1 / (2 f-stop) for
        orthographic cameras), in Blender units like Cycles (which does not apply the unit scale);
        focus distance along the view axis (to the focus object's origin if one is set)."""
        c = cam_ob.data
        dof = getattr(c, "dof", None)
        if dof is None or not dof.use_dof:
            return None
        fstop = max(dof.aperture_fstop, 1e-5)
        radius = (1.0 if c.type == "ORTHO" else c.lens * 1e-3) / (2.0 * fstop)
        distance = dof.focus_distance
        target = dof.focus_object
        if target is not None:
            target = target.evaluated_get(self.dg)
            pos = target.matrix_world.translation
            sub = getattr(dof, "focus_subtarget", "")
            if sub and target.pose is not None and sub in target.pose.bones:
                pos = (target.matrix_world @ target.pose.bones[sub].matrix).translation
            m = cam_ob.matrix_world
            view = m.col[2].xyz.normalized()
            distance = abs(view.dot(m.translation - pos))
        if dof.aperture_blades >= 3 or dof.aperture_ratio != 1.0:
            self.warnings.append("camera '%s': aperture blades/rotation/ratio are not supported; the aperture is a round disk" % cam_ob.name)
        if radius <= 0.0 or not distance > 0.0:
            return None
        return {"aperture_radius": float(radius), "focus_distance": float(max(distance, 1e-6))}

    def world(self):
        """The material JSON "world": Background colour x strength, or an equirectangular
        Environment Texture (optionally through a Mapping node rotating about Z) written next to
        the glTF as a float EXR. Any other graph (a Sky Texture, textures or shaders mixed into
        the Background, a linked Strength, a non-equirectangular Environment Texture) is baked
        by Cycles into an equirectangular EXR (world_bake.py), a sky's sun disc into a
        directional light added to the written glTF."""
        w = self.scene.world
        black = {"color": [0.0, 0.0, 0.0], "strength": 0.0}
        if w is None:
            return black
        nt = w.node_tree if getattr(w, "use_nodes", True) else None
        if nt is None:
            return {"color": _rgb(w.color), "strength": 1.0}
        out = next((n for n in nt.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
        out = out or next((n for n in nt.nodes if n.type == "OUTPUT_WORLD"), None)
        vol = out.inputs.get("Volume") if out else None
        if vol is not None and vol.is_linked:
            self.warnings.append("world '%s': the world Volume ('%s') is not supported; put the volume in a mesh (a large cube around the scene and the camera) instead"
                                 % (w.name, vol.links[0].from_node.name))
        s = out.inputs.get("Surface") if out else None
        if s is None or not s.is_linked:
            return black
        bg = s.links[0].from_node
        cs = bg.inputs["Color"] if bg.type == "BACKGROUND" else None
        tex = cs.links[0].from_node if cs is not None and cs.is_linked else None
        if (bg.type != "BACKGROUND" or bg.inputs["Strength"].is_linked
                or (tex is not None and (tex.type != "TEX_ENVIRONMENT" or tex.projection != "EQUIRECTANGULAR"))):
            why = tex if tex is not None and bg.type == "BACKGROUND" and not bg.inputs["Strength"].is_linked else bg
            try:
                fname, info = world_bake.bake_world(w.original, self.out_dir, self.name)
            except Exception as e:  # no Cycles, a failed render, ...: today's translation
                self.warnings.append("world '%s': node '%s' needs the world baked by Cycles, which failed (%s); %s"
                                     % (w.name, why.name, e, "using the Background colour" if bg.type == "BACKGROUND" else "world is black"))
                if bg.type != "BACKGROUND":
                    return black
            else:
                sun = info.get("sun")
                if sun is not None:
                    gltf_path = os.path.join(self.out_dir, self.name + ".gltf")
                    if os.path.exists(gltf_path):  # run() writes the glTF before the world
                        world_bake.add_sun_light(gltf_path, "%s sun" % w.name, sun)
                    else:
                        self.warnings.append("world '%s': the sun disc is not exported (no glTF yet)" % w.name)
                    if sun.get("clipped"):
                        self.warnings.append("world '%s': the sun disc was not centred in its measuring view; its irradiance may be low" % w.name)
                if info.get("disc_in_image"):
                    self.warnings.append("world '%s': the sky's Vector input is linked: its sun disc is baked into the %dx%d image, not a sun light"
                                         % (w.name, world_bake.BAKE_WIDTH, world_bake.BAKE_HEIGHT))
                return {"color": [1.0, 1.0, 1.0], "strength": 1.0, "texture": fname}
        strength_sock = bg.inputs["Strength"]
        if strength_sock.is_linked:
            self.warnings.append("world: a linked Strength is not supported; using its value %g" % strength_sock.default_value)
        result = {"color": _rgb(bg.inputs["Color"].default_value), "strength": float(strength_sock.default_value)}
        if not cs.is_linked:
            return result
        if tex.type != "TEX_ENVIRONMENT" or tex.image is None:
            self.warnings.append("world: only a colour or an Environment Texture is supported on the Background; '%s' is ignored" % tex.name)
            return result
        if tex.projection != "EQUIRECTANGULAR":
            self.warnings.append("world: environment projection %s is not supported; using equirectangular" % tex.projection)
        fname = self._environment_image(tex.image)
        if fname is None:
            return result
        result.update(color=[1.0, 1.0, 1.0], texture=fname)
        rz = self._mapping_rotation_z(tex)
        if rz:
            result["rotation_z"] = rz
        return result

    def _mapping_rotation_z(self, tex):
        """Z rotation of a Mapping node feeding the environment texture's Vector (0 if none)."""
        vs = tex.inputs.get("Vector")
        if vs is None or not vs.is_linked:
            return 0.0
        node = vs.links[0].from_node
        if node.type == "TEX_COORD":
            return 0.0
        if node.type != "MAPPING":
            self.warnings.append("world: '%s' on the environment texture's Vector is not supported; ignored" % node.name)
            return 0.0
        vt = getattr(node, "vector_type", "POINT")
        loc = node.inputs["Location"].default_value if "Location" in node.inputs else (0, 0, 0)
        rot = node.inputs["Rotation"].default_value
        scale = node.inputs["Scale"].default_value if "Scale" in node.inputs else (1, 1, 1)
        linked = [k for k in ("Location", "Rotation", "Scale") if k in node.inputs and node.inputs[k].is_linked]
        ignored = []
        if linked:
            ignored.append("linked " + "/".join(linked))
        if abs(rot[0]) > 1e-6 or abs(rot[1]) > 1e-6:
            ignored.append("X/Y rotation")
        if vt in {"POINT", "TEXTURE"} and max(abs(v) for v in loc) > 1e-6:
            ignored.append("location")
        if not (abs(scale[0] - scale[1]) < 1e-6 and abs(scale[1] - scale[2]) < 1e-6 and scale[0] > 0):
            ignored.append("non-uniform scale")
        if ignored:
            self.warnings.append("world: the Mapping node's %s is not supported; only its Z rotation is used" % ", ".join(ignored))
        # POINT/VECTOR/NORMAL rotate the lookup vector by +rz; TEXTURE applies the inverse.
        return float(-rot[2] if vt == "TEXTURE" else rot[2])

    def _environment_image(self, img):
        """Writes the image's pixels (linear, top row first) as a float EXR; returns its file name."""
        try:
            w, h = img.size
            if w == 0 or h == 0:
                raise RuntimeError("no pixel data (missing file?)")
            px = np.empty(w * h * 4, np.float32)
            img.pixels.foreach_get(px)
        except Exception as e:  # a missing or unreadable image
            self.warnings.append("world: environment image '%s' cannot be read (%s); using the background colour" % (img.name, e))
            return None
        rgb = px.reshape(h, w, 4)[::-1, :, :3]
        # Float buffers are scene linear; byte buffers keep the file's colour space.
        space = img.colorspace_settings.name
        if not img.is_float:
            if space == "sRGB":
                rgb = np.where(rgb <= 0.04045, rgb / 12.92, np.power((np.maximum(rgb, 0.0) + 0.055) / 1.055, 2.4))
            elif not (space.startswith("Linear") or space in {"Non-Color", "Raw"}):
                self.warnings.append("world: environment image colour space '%s' is read as linear" % space)
        rgb = np.nan_to_num(np.maximum(rgb, 0.0), nan=0.0, posinf=65504.0)
        fname = self.name + "_world.exr"
        write_exr_rgb(os.path.join(self.out_dir, fname), rgb.astype(np.float32))
        return fname

    def run(self, render_settings=None):
        self._textures = []
        for inst in self.dg.object_instances:
            ob = inst.object
            # The viewport's depsgraph has already applied viewport visibility; as in Cycles'
            # viewport, Disable in Renders does not hide an object there.
            if ob.original is not None and ob.original.hide_render and not inst.is_instance and not self.viewport:
                continue
            matrix = inst.matrix_world.copy()
            if ob.type == "MESH" and getattr(inst, "show_particles", True) and not inst.is_instance:
                # Hair is drawn with the particles, also when the emitter itself is hidden.
                self._add_particle_hair(ob)
            if not inst.show_self:
                continue
            if ob.type in {"MESH", "CURVE", "SURFACE", "FONT", "META"}:
                self._add_mesh_object(ob, matrix, inst.is_instance, motion.instance_key(inst))
            elif ob.type == "LIGHT":
                self._add_light(ob, matrix)
            elif ob.type == "CURVES":
                self._add_curves_object(ob, matrix, motion.instance_key(inst))
            elif ob.type in {"POINTCLOUD", "VOLUME"} and not inst.is_instance:
                self.warnings.append("object '%s': %s objects are not rendered yet" % (ob.name, ob.type.lower()))
        if self.motion is not None:
            self.warnings.extend(self.motion.warnings)
            if self.hair_objects:
                self.warnings.append("motion blur: particle hair is shown at the current frame (not blurred) on moving objects: "
                                     + ", ".join(sorted(set(self.hair_objects))))
        self._add_camera()
        self._run_bakes()
        if self.unsupported_normals:
            self.warnings.insert(
                0,
                "unsupported Normal inputs ignored (the nodes on them are named in their own warnings): "
                + ", ".join(sorted(set(self.unsupported_normals))),
            )
        gltf = {
            "asset": {"version": "2.0", "generator": "Prism Blender addon"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": self.nodes,
            "cameras": self.cameras,
        }
        used = set()
        for m in self.materials:
            used.update(m.get("extensions", {}).keys())
        if self.lights:
            gltf["extensions"] = {"KHR_lights_punctual": {"lights": self.lights}}
            used.add("KHR_lights_punctual")
        if used:
            gltf["extensionsUsed"] = sorted(used)
        for key, val in (("meshes", self.meshes), ("materials", self.materials), ("images", self.images), ("textures", self._textures)):
            if val:
                gltf[key] = val
        if self._textures:
            gltf["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]
        bin_name = self.name + ".bin"
        if self.buf.size:
            gltf["buffers"] = [{"uri": bin_name, "byteLength": self.buf.size}]
            gltf["bufferViews"] = self.buf.views
            gltf["accessors"] = self.buf.accessors
            with open(os.path.join(self.out_dir, bin_name), "wb") as f:
                for c in self.buf.chunks:
                    f.write(c)
        # glTF node name -> how many nodes have it (the viewport moves an object by name only
        # when its name is unique).
        self.node_names = {}
        for n in self.nodes[1:]:
            self.node_names[n.get("name")] = self.node_names.get(n.get("name"), 0) + 1
        gltf_path = os.path.join(self.out_dir, self.name + ".gltf")
        with open(gltf_path, "w") as f:
            json.dump(gltf, f, separators=(",", ":"))
        mj = {"version": 1, "materials": self.material_json, "world": self.world()}
        if self.camera_lens:
            mj["camera"] = self.camera_lens
        if render_settings:
            mj["render"] = render_settings
        json_path = os.path.join(self.out_dir, self.name + ".materials.json")
        with open(json_path, "w") as f:
            json.dump(mj, f, indent=1)
        return gltf_path, json_path


def render_size(scene):
    r = scene.render
    return max(1, int(r.resolution_x * r.resolution_percentage / 100)), max(1, int(r.resolution_y * r.resolution_percentage / 100))


def render_settings(scene):
    """The material JSON "render" block from the scene's Prism settings."""
    w, h = render_size(scene)
    # Blender's 8-bit sRGB images are filtered in their encoded values in Cycles (the glTF
    # specification, the renderer's default for glTF files, decodes first): a magnified
    # high-contrast texture differs by a few percent otherwise. (Float images, rare as base
    # colours, are written as 8-bit sRGB PNG for a glTF texture slot and so filtered encoded
    # too, where Cycles filters them in linear values.)
    out = {"width": w, "height": h, "texture_filtering": "cycles"}
    p = getattr(scene, "prism", None)
    if p is not None:
        out.update(spp=int(p.samples), max_depth=int(p.max_depth), wavelengths=p.wavelengths.lower())
        if hasattr(p, "wavelength_pdf"):
            out["wavelength_pdf"] = p.wavelength_pdf.lower()
        if hasattr(p, "filter_type"):
            out["filter"] = {"type": p.filter_type.lower(), "width": float(p.filter_width)}
        if getattr(p, "use_adaptive_sampling", False):
            out["noise_threshold"] = float(p.adaptive_threshold)
            out["min_samples"] = int(p.adaptive_min_samples)
        if getattr(p, "time_limit", 0.0) > 0.0:
            out["time_limit"] = float(p.time_limit)
        if hasattr(p, "path_splits"):
            out["splits"] = int(p.path_splits) if p.path_splits > 0 else "auto"
        if hasattr(p, "use_caustic_guiding"):
            out["caustic_guiding"] = bool(p.use_caustic_guiding)
        for key in ("clamp_direct", "clamp_indirect"):
            if getattr(p, key, 0.0) > 0.0:
                out[key] = float(getattr(p, key))
    if scene.render.film_transparent:
        out["film_transparent"] = True
    return out


def export_scene(depsgraph, out_dir, name="scene", engine=None, bake=True, info=None):
    """Writes <out_dir>/<name>.gltf/.bin/.materials.json; returns (gltf, json, warnings, triangles).
    With motion blur on, the scene is first evaluated over the shutter (`motion.sample`, with
    `engine.frame_set` inside a render). `bake`: bake the nodes graphs cannot evaluate (if the
    scene's setting allows; not for material previews); `info` (a dict) receives "bake", the
    bake's statistics or None."""
    movement = motion.sample(depsgraph, engine)
    scene = depsgraph.scene_eval
    w, h = render_size(scene)
    ex = Exporter(depsgraph, out_dir, name, w, h)
    if not bake:
        ex.bake_size = 0
    ex.motion = movement
    gltf_path, json_path = ex.run(render_settings(scene))
    if info is not None:
        info["bake"] = ex.bake_stats
    return gltf_path, json_path, ex.warnings, ex.n_triangles

