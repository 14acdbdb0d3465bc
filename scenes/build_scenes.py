"""Build the report's reference scenes in Blender, save them as .blend and export glTF + material JSON.

Run by Blender (either works):
    blender -b --factory-startup -P scenes/build_scenes.py [-- NAME ...]
    .venv-bpy/bin/python scenes/build_scenes.py [NAME ...]

For each scene NAME this writes scenes/NAME/NAME.blend (not committed) and, with the add-on's own
exporter (the one the render engine uses), scenes/NAME/NAME.gltf + NAME.bin + NAME.materials.json
(committed, so `prism render scenes/NAME/NAME.gltf` needs no Blender).

Scenes (1 unit = 1 m; the subsurface presets are in mm^-1, so their scale is 1000):
  sss_vs_diffuse    the same 4 cm sphere twice: Marble subsurface (left) and diffuse of the same colour
  sss_presets       Chicken1, Marble, Potato spheres (measured media of Jensen et al. 2001)
  rough_glass       four glass spheres, roughness 0 / 0.02 / 0.2 / 0.5, in front of a striped wall
  diamond           a brilliant-cut-like gem with the diamond Cauchy fit, lit by a small spot light
  rgb_vs_spectral   colour patches and a dispersive BK7 prism under a sun, at 1 spp
  everyday          an artist's everyday setup: three Principled spheres (one chrome) and a monkey on a
                    floor, lit by a sun, a point light and a grey world (noise-per-second benchmark)
  sss_cornell       a Cornell box with three Principled subsurface objects: two Christensen-Burley (Prism's
                    table method) and one random walk (noise-per-second benchmark)
  many_lights       a 10 m x 10 m hall lit by 400 small coloured emissive panels and 4 point lights
                    (light-selection benchmark)
  node_setups       the shading-graph test's grid of tiles, one per everyday Blender node setup (textures on
                    Roughness / Metallic, Noise -> Color Ramp, Mix / Add Shaders, Translucent, Transparent,
                    Bump, normal maps, ...; tests/addon/node_setups.py), under a white world and a side sun
  soap_bubble       three soap bubbles (Principled Thin Film 250 / 420 / 700 nm, IOR 1.33, on thin shells
                    of IOR 1) before a dark wall, under two soft lights: thin-film interference computed
                    exactly per wavelength
"""

import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "blender_addon"))

import bpy  # noqa: E402  (first: the bpy wheel provides bmesh only after it)
import bmesh  # noqa: E402

import prism  # noqa: E402
from prism import export  # noqa: E402

sys.path.insert(0, HERE)
from bpy_helpers import camera, light, material, world  # noqa: E402
from bpy_helpers import mesh_object as obj  # noqa: E402


# ----------------------------------------------------------------------------- building blocks


def reset():
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "PRISM"
    return sc


def sphere(r):
    def build(bm):
        try:
            bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, radius=r)
        except TypeError:
            bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, diameter=r)
    return build


def grid(sx, sy):
    def build(bm):
        bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=0.5)
        bmesh.ops.scale(bm, vec=(sx, sy, 1.0), verts=bm.verts)
    return build


def hull(points):
    def build(bm):
        verts = [bm.verts.new(p) for p in points]
        bmesh.ops.convex_hull(bm, input=verts)
    return build


def gem_points(r):
    """A round brilliant-like cut: table, crown, girdle, pavilion, culet."""
    pts = []
    n = 16
    for i in range(n):
        a = 2 * math.pi * i / n
        b = a + math.pi / n
        pts.append((r * math.cos(a), r * math.sin(a), 0.0))
        pts.append((r * math.cos(a), r * math.sin(a), 0.03 * r))
        pts.append((0.8 * r * math.cos(b), 0.8 * r * math.sin(b), 0.2 * r))
        pts.append((0.56 * r * math.cos(a), 0.56 * r * math.sin(a), 0.33 * r))
        pts.append((0.55 * r * math.cos(b), 0.55 * r * math.sin(b), -0.45 * r))
    pts.append((0.0, 0.0, -0.86 * r))
    return pts


def triangular_prism(w, h, depth):
    pts = []
    for y in (-depth / 2, depth / 2):
        pts += [(-w / 2, y, 0.0), (w / 2, y, 0.0), (0.0, y, h)]
    return hull(pts)


def settings(sc, width, height, spp, max_depth=32, wavelengths="HERO"):
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = width, height, 100
    sc.prism.samples = spp
    sc.prism.max_depth = max_depth
    sc.prism.wavelengths = wavelengths


def sss(mat, preset=None, scale=1000.0, eta=1.3):
    mat.prism.sss_mode = "PRESET"
    mat.prism.sss_preset = preset
    mat.prism.sss_scale = scale
    mat.prism.sss_eta = eta


def studio(size=0.6, light_power=6.0):
    """A grey floor, a back wall, one soft area light."""
    floor = material("Floor", color=(0.5, 0.5, 0.5))
    obj("Floor", grid(size * 4, size * 4), floor)
    obj("Wall", grid(size * 4, size), floor, location=(0, size, size / 2), rotation=(math.pi / 2, 0, 0))
    light("Key", "AREA", light_power, (-0.25 * size, -0.4 * size, 0.8 * size), rotation=(0.6, -0.3, 0.0),
          shape="RECTANGLE", size=0.3 * size, size_y=0.2 * size)


# ----------------------------------------------------------------------------- scenes


def sss_vs_diffuse():
    sc = reset()
    studio()
    colour = (0.85, 0.83, 0.78)
    marble = material("MarbleSSS", color=colour)
    sss(marble, "Marble")
    obj("SSSBall", sphere(0.04), marble, location=(-0.05, 0, 0.04), smooth=True)
    obj("DiffuseBall", sphere(0.04), material("MarbleDiffuse", color=colour), location=(0.05, 0, 0.04), smooth=True)
    world((0.02, 0.02, 0.025))
    camera((0, -0.45, 0.12), (0, 0, 0.035), lens=60)
    settings(sc, 512, 256, 256)


def sss_presets():
    sc = reset()
    studio()
    for i, (name, colour) in enumerate((("Chicken1", (0.9, 0.7, 0.6)), ("Marble", (0.85, 0.83, 0.78)), ("Potato", (0.85, 0.75, 0.5)))):
        m = material(name, color=colour)
        sss(m, name)
        obj(name + "Ball", sphere(0.035), m, location=(-0.09 + 0.09 * i, 0, 0.035), smooth=True)
    world((0.02, 0.02, 0.025))
    camera((0, -0.5, 0.12), (0, 0, 0.03), lens=55)
    settings(sc, 600, 240, 256)


def rough_glass():
    sc = reset()
    floor = material("Floor", color=(0.5, 0.5, 0.5))
    obj("Floor", grid(4, 4), floor)
    dark = material("Stripe", color=(0.05, 0.05, 0.05))
    for i in range(9):  # a striped wall behind the spheres shows the blur of the transmission
        obj("Stripe%d" % i, grid(0.1, 1.0), dark if i % 2 else floor, location=(-0.8 + 0.2 * i, 0.6, 0.5), rotation=(math.pi / 2, 0, 0))
    for i, r in enumerate((0.0, 0.02, 0.2, 0.5)):
        m = material("Glass_r%s" % str(r).replace(".", ""), "ShaderNodeBsdfGlass", (1, 1, 1), Roughness=r, IOR=1.5)
        obj("Glass%d" % i, sphere(0.12), m, location=(-0.45 + 0.3 * i, 0, 0.12), smooth=True)
    light("Key", "AREA", 40.0, (0, -0.6, 1.2), rotation=(0.45, 0, 0), shape="SQUARE", size=0.5)
    world((0.3, 0.3, 0.32))
    camera((0, -2.2, 0.45), (0, 0, 0.15), lens=50)
    settings(sc, 640, 240, 256)


def diamond():
    sc = reset()
    obj("Floor", grid(2, 2), material("Black", color=(0.02, 0.02, 0.02)))
    gem = material("Diamond", "ShaderNodeBsdfGlass", (1, 1, 1), IOR=2.417)
    gem.prism.dispersion_mode = "GLASS"
    gem.prism.glass_preset = "DIAMOND"
    obj("Gem", hull(gem_points(0.05)), gem, location=(0, 0, 0.06), rotation=(0.35, 0.2, 0.0))
    light("Spot", "SPOT", 400.0, (0.15, -0.3, 0.5), rotation=(0.55, 0.25, 0.0), spot_size=0.35, spot_blend=0.1, shadow_soft_size=0.0)
    light("Fill", "AREA", 5.0, (0.0, 0.0, 0.6), shape="SQUARE", size=0.3)
    world((0.01, 0.01, 0.012))
    camera((0, -0.42, 0.3), (0, 0, 0.05), lens=60)
    settings(sc, 400, 400, 1024, max_depth=64)


def rgb_vs_spectral():
    sc = reset()
    obj("Floor", grid(3, 3), material("Floor", color=(0.7, 0.7, 0.7)))
    colours = [(0.8, 0.1, 0.1), (0.1, 0.6, 0.1), (0.1, 0.1, 0.8), (0.8, 0.7, 0.1), (0.7, 0.1, 0.7), (0.1, 0.7, 0.7)]
    for i, c in enumerate(colours):
        obj("Patch%d" % i, grid(0.18, 0.18), material("Patch%d" % i, color=c), location=(-0.5 + 0.2 * i, 0.3, 0.001))
    glass = material("BK7", "ShaderNodeBsdfGlass", (1, 1, 1), IOR=1.5168)
    glass.prism.dispersion_mode = "GLASS"
    glass.prism.glass_preset = "BK7"
    obj("Prism", triangular_prism(0.25, 0.22, 0.4), glass, location=(0, -0.1, 0.0), rotation=(0, 0, 0.3))
    light("Sun", "SUN", 2.0, (0, 0, 2), rotation=(0.5, -0.6, 0.0))
    world((0.1, 0.12, 0.15))
    camera((0, -1.6, 0.9), (0, 0.05, 0.05), lens=45)
    settings(sc, 480, 320, 1)


def principled(name, color, **inputs):
    return material(name, "ShaderNodeBsdfPrincipled", color, **inputs)


def monkey(bm):
    bmesh.ops.create_monkey(bm)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges, cuts=1, use_grid_fill=True)


def everyday():
    sc = reset()
    obj("Floor", grid(8, 8), principled("Floor", (0.6, 0.6, 0.6), Roughness=0.5))
    obj("RedBall", sphere(0.5), principled("RedPlastic", (0.8, 0.08, 0.05), Roughness=0.35), location=(-1.2, 0.3, 0.5), smooth=True)
    obj("Chrome", sphere(0.5), principled("Chrome", (0.9, 0.9, 0.9), Metallic=1.0, Roughness=0.05), location=(0.0, 0.8, 0.5), smooth=True)
    obj("BlueBall", sphere(0.5), principled("BlueRough", (0.1, 0.25, 0.7), Roughness=0.7), location=(1.2, 0.3, 0.5), smooth=True)
    obj("Suzanne", monkey, principled("Clay", (0.75, 0.65, 0.5), Roughness=0.6), location=(0.0, -0.6, 0.45),
        scale=(0.45, 0.45, 0.45), smooth=True)
    light("Sun", "SUN", 3.0, (0, 0, 5), rotation=(0.7, 0.2, 0.6))
    light("Point", "POINT", 300.0, (-2.0, -2.0, 2.5), shadow_soft_size=0.0)
    world((0.35, 0.35, 0.35))
    camera((0.0, -5.5, 2.2), (0, 0.2, 0.45), lens=40)
    settings(sc, 256, 256, 64, max_depth=16)


def sss_cornell():
    sc = reset()
    white = principled("White", (0.73, 0.73, 0.73), Roughness=1.0)
    red = principled("Red", (0.63, 0.065, 0.05), Roughness=1.0)
    green = principled("Green", (0.14, 0.45, 0.09), Roughness=1.0)
    s = 1.0
    obj("Floor", grid(s, s), white, location=(0, 0, 0))
    obj("Ceiling", grid(s, s), white, location=(0, 0, s), rotation=(math.pi, 0, 0))
    obj("Back", grid(s, s), white, location=(0, s / 2, s / 2), rotation=(math.pi / 2, 0, 0))
    obj("Left", grid(s, s), red, location=(-s / 2, 0, s / 2), rotation=(0, math.pi / 2, 0))
    obj("Right", grid(s, s), green, location=(s / 2, 0, s / 2), rotation=(0, -math.pi / 2, 0))
    # Principled subsurface (radius in m; Subsurface Scale 1): skin-, marble- and jade-like.
    for i, (name, colour, radius, method) in enumerate((
            ("Skin", (0.85, 0.55, 0.45), (0.05, 0.02, 0.012), "BURLEY"),
            ("Marble", (0.83, 0.79, 0.75), (0.03, 0.03, 0.025), "BURLEY"),
            ("Jade", (0.35, 0.7, 0.4), (0.02, 0.05, 0.025), "RANDOM_WALK"))):
        m = principled(name, colour, Roughness=0.3)
        node = m.node_tree.nodes["Principled BSDF"]
        node.subsurface_method = method
        node.inputs["Subsurface Weight"].default_value = 1.0
        node.inputs["Subsurface Radius"].default_value = radius
        node.inputs["Subsurface Scale"].default_value = 1.0
        build = monkey if i == 1 else sphere(0.14)
        obj(name + "Object", build, m, location=(-0.28 + 0.28 * i, -0.05 + 0.1 * (i % 2), 0.15),
            scale=(0.22, 0.22, 0.22) if i == 1 else (1, 1, 1), smooth=True)
    light("Ceiling light", "AREA", 6.0, (0, 0, s - 0.002), shape="SQUARE", size=0.25)
    world((0.0, 0.0, 0.0))
    camera((0, -2.3, 0.5), (0, 0, 0.5), lens=38)
    settings(sc, 256, 256, 64, max_depth=16)


def many_lights():
    sc = reset()
    import random
    rng = random.Random(7)
    obj("Floor", grid(12, 12), principled("Floor", (0.5, 0.5, 0.5), Roughness=0.6))
    for i in range(12):
        x, y = rng.uniform(-4.5, 4.5), rng.uniform(-4.5, 4.5)
        obj("Ball%d" % i, sphere(0.3), principled("Ball%d" % i, (rng.uniform(0.2, 0.9), rng.uniform(0.2, 0.9), rng.uniform(0.2, 0.9)),
            Roughness=rng.uniform(0.2, 0.8)), location=(x, y, 0.3), smooth=True)
    for j in range(20):
        for i in range(20):
            colour = (rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0))
            strength = rng.uniform(5.0, 40.0)
            m = material("Panel%d_%d" % (i, j), "ShaderNodeEmission", colour, Strength=strength)
            obj("Panel%d_%d" % (i, j), grid(0.08, 0.08), m, location=(-4.75 + 0.5 * i, -4.75 + 0.5 * j, rng.uniform(0.6, 1.6)),
                rotation=(math.pi, 0, 0))
    for k, (x, y) in enumerate(((-3, -3), (3, -3), (-3, 3), (3, 3))):
        light("Point%d" % k, "POINT", 30.0, (x, y, 1.0), shadow_soft_size=0.0)
    world((0.0, 0.0, 0.0))
    camera((0.0, -7.5, 3.0), (0, -1.0, 0.0), lens=30)
    settings(sc, 256, 256, 64, max_depth=16)


def soap_bubble():
    sc = reset()
    # A dark backdrop and two soft lights: bubbles show their iridescence in what they reflect.
    floor = material("Floor", color=(0.03, 0.03, 0.035))
    obj("Floor", grid(6, 6), floor)
    obj("Wall", grid(6, 3), floor, location=(0, 1.2, 1.5), rotation=(math.pi / 2, 0, 0))
    light("Key", "AREA", 60.0, (-1.0, -1.5, 2.0), rotation=(0.7, -0.4, 0.0), shape="RECTANGLE", size=1.5, size_y=0.6)
    light("Rim", "AREA", 25.0, (1.4, 0.2, 1.4), rotation=(0.5, 0.9, 0.0), shape="SQUARE", size=0.8)
    world((0.02, 0.02, 0.025))
    # Thin shells (IOR 1: no refraction) under soap films of three thicknesses (Thin Film IOR 1.33).
    for i, (thickness, radius, z) in enumerate(((250.0, 0.22, 0.45), (420.0, 0.3, 0.55), (700.0, 0.18, 0.35))):
        m = principled("Bubble%d" % thickness, (1.0, 1.0, 1.0), **{"Roughness": 0.0, "IOR": 1.0,
                                                                     "Transmission Weight": 1.0,
                                                                     "Thin Film Thickness": thickness,
                                                                     "Thin Film IOR": 1.33})
        obj("Bubble%d" % i, sphere(radius), m, location=(-0.6 + 0.6 * i, 0, z), smooth=True)
    camera((0, -2.4, 0.7), (0, 0, 0.45), lens=45)
    settings(sc, 480, 270, 256)


def node_setups():
    sys.path.insert(0, os.path.join(REPO, "tests", "addon"))
    import node_setups as setups_module

    sc, _tiles, _rows = setups_module.build_scene()
    sc.render.engine = "PRISM"
    settings(sc, sc.render.resolution_x, sc.render.resolution_y, 64, max_depth=8)


SCENES = {f.__name__: f for f in (sss_vs_diffuse, sss_presets, rough_glass, diamond, rgb_vs_spectral, everyday,
                                  sss_cornell, many_lights, soap_bubble, node_setups)}


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    names = [a for a in argv if a in SCENES] or list(SCENES)
    try:
        prism.register()
    except ValueError:  # already registered (enabled as an add-on)
        pass
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backups
    for name in names:
        SCENES[name]()
        out = os.path.join(HERE, name)
        os.makedirs(out, exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, name + ".blend"), compress=True)
        dg = bpy.context.evaluated_depsgraph_get()
        gltf, mj, warnings, tris = export.export_scene(dg, out, name)
        for w in warnings:
            print("warning:", w)
        print("%s: %d triangles -> %s, %s" % (name, tris, os.path.relpath(gltf, REPO), os.path.relpath(mj, REPO)))


if __name__ == "__main__":
    main()
