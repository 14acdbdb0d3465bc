"""Shared helpers for the add-on tests: scene building (Blender 3.4 and 5.0), pixels, checks.

Imported inside real Blender (bpy wheel 5.0.1 or Debian's blender 3.4); no mocks.
"""

import os
import sys
import time

import bpy
import bmesh
import numpy as np

REPO = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
BINARY = os.path.join(REPO, "target", "release", "prism")

sys.path.insert(0, os.path.join(REPO, "scenes"))
from bpy_helpers import camera, generated_x_range, light, material, mesh_object, node_group, noise_bump, shader_node, world  # noqa: E402,F401  (re-exported to the tests)


def enable_addon():
    """Enable the add-on as Blender users do (BLENDER_USER_SCRIPTS/addons/prism, set by the runner)."""
    import addon_utils

    mod = addon_utils.enable("prism", default_set=True, handle_error=None)
    if mod is None:
        raise SystemExit("could not enable the prism add-on (BLENDER_USER_SCRIPTS=%s)" % os.environ.get("BLENDER_USER_SCRIPTS"))
    return sys.modules["prism"]


def prefs():
    return bpy.context.preferences.addons["prism"].preferences


def reset():
    """An empty scene; keeps the preferences (and so the enabled add-on)."""
    bpy.ops.wm.read_homefile(use_empty=True)


def plane(size):
    return lambda bm: bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=size / 2)


def sphere(radius, segs=48, rings=24):
    def build(bm):
        try:
            bmesh.ops.create_uvsphere(bm, u_segments=segs, v_segments=rings, radius=radius)
        except TypeError:  # older keyword
            bmesh.ops.create_uvsphere(bm, u_segments=segs, v_segments=rings, diameter=radius)
    return build


def cube(size):
    return lambda bm: bmesh.ops.create_cube(bm, size=size)


def simple_scene():
    """A grey floor, a red diffuse sphere, a point light and a dim world: bright, fast, no caustics."""
    reset()
    sc = bpy.context.scene
    floor = material("Floor", "ShaderNodeBsdfDiffuse", (0.8, 0.8, 0.8))
    red = material("Red", "ShaderNodeBsdfDiffuse", (0.8, 0.1, 0.1))
    mesh_object("Floor", plane(10.0), floor)
    mesh_object("Ball", sphere(1.0), red, location=(0, 0, 1), smooth=True)
    light("Lamp", "POINT", 1000.0, (2.0, -2.0, 4.0), shadow_soft_size=0.0)
    world((0.05, 0.05, 0.05), 1.0)
    camera((0.0, -8.0, 3.0), (0.0, 0.0, 0.8))
    sc.render.resolution_x = 160
    sc.render.resolution_y = 100
    sc.render.resolution_percentage = 100
    return sc


def prism_depth(bounces):
    """Prism's max depth for Cycles' Max Bounces `bounces`: a path of B bounces has B + 1
    vertices that see light (depth 1 = direct light only, as pbrt's maxdepth)."""
    return bounces + 1


def use_prism(sc, spp=16, threads=2):
    sc.render.engine = "PRISM"
    sc.prism.samples = spp
    # Fixed spp, as use_cycles (the parity tests compare equally sampled images).
    sc.prism.use_adaptive_sampling = False
    sc.prism.threads = threads
    # use_cycles' default 8 bounces.
    sc.prism.max_depth = prism_depth(8)
    # Unbiased noisy images, as use_cycles (denoising is tested on its own: test_denoise.py).
    if hasattr(sc.prism, "use_denoising"):
        sc.prism.use_denoising = False
    # The parity tests set Cycles to a 1 px box filter (use_cycles); match it.
    sc.prism.filter_type = "BOX"
    sc.prism.filter_width = 1.0


def render_pixels(sc, path):
    """bpy.ops.render.render(), then the Render Result saved as raw EXR and read back (H, W, 4)."""
    vs = sc.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    im = sc.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_depth = "32"
    im.color_mode = "RGBA"
    res = bpy.ops.render.render(write_still=False)
    if "FINISHED" not in res:
        raise AssertionError("render returned %r" % (res,))
    rr = bpy.data.images["Render Result"]
    rr.save_render(filepath=path, scene=sc)
    return read_exr(path)


def read_exr(path):
    img = bpy.data.images.load(path, check_existing=False)
    try:
        w, h = img.size
        px = np.empty(w * h * 4, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, 4)


def check(cond, msg):
    if not cond:
        raise AssertionError(msg)
    print("  ok: " + msg, flush=True)


def parity_scene(width=96, height=72):
    """Diffuse, glossy metal and glass spheres on a diffuse floor; area + point light + world."""
    reset()
    sc = bpy.context.scene
    floor = material("Floor", "ShaderNodeBsdfDiffuse", (0.6, 0.6, 0.6))
    diffuse = material("Clay", "ShaderNodeBsdfDiffuse", (0.8, 0.3, 0.2))
    metal = material("Gold", "ShaderNodeBsdfGlossy", (0.9, 0.7, 0.3), Roughness=0.3)
    glass = material("Glass", "ShaderNodeBsdfGlass", (1.0, 1.0, 1.0), Roughness=0.0, IOR=1.5)
    mesh_object("Floor", plane(12.0), floor)
    mesh_object("ClayBall", sphere(0.7), diffuse, location=(-1.6, 0.3, 0.7), smooth=True)
    mesh_object("GoldBall", sphere(0.7), metal, location=(0.0, 0.8, 0.7), smooth=True)
    mesh_object("GlassBall", sphere(0.7), glass, location=(1.6, 0.0, 0.7), smooth=True)
    light("Area", "AREA", 400.0, (0.0, -1.0, 4.0), shape="RECTANGLE", size=1.5, size_y=1.0)
    light("Point", "POINT", 300.0, (-3.0, -3.0, 3.0), shadow_soft_size=0.0)
    world((0.15, 0.17, 0.2), 1.0)
    camera((0.0, -7.5, 2.6), (0.0, 0.3, 0.6), lens=40.0)
    sc.render.resolution_x = width
    sc.render.resolution_y = height
    sc.render.resolution_percentage = 100
    return sc


def use_cycles(sc, spp, bounces=8, threads=2):
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = spp
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = 1
    for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces", "transparent_max_bounces"):
        setattr(cy, k, bounces)
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    sc.render.threads_mode = "FIXED"
    sc.render.threads = threads


def render_engine(sc, engine, spp, out_dir, name, bounces):
    """Renders `sc` with "cycles" (`bounces` of every kind) or "prism" (the same bounces: max
    depth `prism_depth(bounces)`) into out_dir/<name>_<engine>.exr, prints the time; returns the
    (H, W, 3) pixels."""
    return render_engine_rgba(sc, engine, spp, out_dir, name, bounces)[..., :3]


def render_engine_rgba(sc, engine, spp, out_dir, name, bounces):
    """`render_engine` with the alpha channel: (H, W, 4) pixels."""
    if engine == "cycles":
        use_cycles(sc, spp, bounces=bounces)
    else:
        use_prism(sc, spp)
        sc.prism.max_depth = prism_depth(bounces)
    t0 = time.perf_counter()
    px = render_pixels(sc, os.path.join(out_dir, "%s_%s.exr" % (name, engine)))
    print("  %s %s: %.1f s" % (name, engine, time.perf_counter() - t0), flush=True)
    return px


def blur(img, k=3):
    """k x k box blur (valid region), per channel."""
    h, w = img.shape[:2]
    out = np.zeros((h - k + 1, w - k + 1) + img.shape[2:], np.float64)
    for dy in range(k):
        for dx in range(k):
            out += img[dy:dy + h - k + 1, dx:dx + w - k + 1]
    return out / (k * k)


def rel_mse(a, b, eps=1e-2):
    """mean((a - b)^2 / (b^2 + eps)) over pixels and RGB channels."""
    return float(np.mean((a - b) ** 2 / (b * b + eps)))
