#!/usr/bin/env python3
"""A Blender-made scene of the issue's rough-glass kind, built as a user would and exported by the
add-on, for `../shared/tools/noise_per_second.py` (Prism against Cycles on a glTF + .blend pair):
four Principled glass balls (roughness R0 / 0.15 / 0.3 / 0.5, three tinted, IOR 1.45) on a
Checker-texture floor, an emissive quad (Principled emission) above them, a dim emissive backdrop,
world 0.05.

    .venv-bpy/bin/python bench/glass_scene.py OUT_DIR [--quad W H STRENGTH] [--r0 R]

writes OUT_DIR/NAME.blend, NAME.gltf (+ .bin, .materials.json), NAME = the folder's name.
bench/README.md's glass scenes: glass2 = defaults (a 1.2 x 0.8 m quad of strength 12), glass3 =
--quad 0.4 0.3 110 (a small bright lamp: the sharpest ball's caustics), glass4 = glass3 with
--r0 0 (a smooth ball)."""
import argparse
import math
import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "blender_addon"))
sys.path.insert(0, os.path.join(REPO, "scenes"))
import bpy  # noqa: E402

import prism  # noqa: E402
from prism import export  # noqa: E402
from bpy_helpers import camera, material, world  # noqa: E402
from bpy_helpers import mesh_object as obj  # noqa: E402
from build_scenes import grid, sphere  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--quad", nargs=3, type=float, default=(1.2, 0.8, 12.0), metavar=("W", "H", "STRENGTH"))
ap.add_argument("--r0", type=float, default=0.05)
a = ap.parse_args(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:])
name = os.path.basename(os.path.normpath(a.out))


def emissive(name, colour, strength, base):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    b = mat.node_tree.nodes["Principled BSDF"]
    b.inputs["Emission Color"].default_value = (*colour, 1)
    b.inputs["Emission Strength"].default_value = strength
    b.inputs["Base Color"].default_value = (*base, 1)
    return mat


bpy.ops.wm.read_homefile(use_empty=True)
try:
    prism.register()
except ValueError:  # already registered
    pass
sc = bpy.context.scene
sc.render.engine = "PRISM"
floor = bpy.data.materials.new("CheckerFloor")
floor.use_nodes = True
nt = floor.node_tree
bsdf = nt.nodes["Principled BSDF"]
chk = nt.nodes.new("ShaderNodeTexChecker")
chk.inputs["Scale"].default_value = 8.0
chk.inputs["Color1"].default_value = (0.8, 0.8, 0.8, 1)
chk.inputs["Color2"].default_value = (0.15, 0.15, 0.15, 1)
nt.links.new(chk.outputs["Color"], bsdf.inputs["Base Color"])
bsdf.inputs["Roughness"].default_value = 0.6
obj("Floor", grid(6, 6), floor)
tints = [(1, 1, 1), (0.9, 0.6, 0.5), (0.5, 0.8, 0.6), (0.5, 0.6, 0.95)]
for i, (r, t) in enumerate(zip((a.r0, 0.15, 0.3, 0.5), tints)):
    m = material("Glass%d" % i, "ShaderNodeBsdfPrincipled", t, Roughness=r, IOR=1.45)
    m.node_tree.nodes["Principled BSDF"].inputs["Transmission Weight"].default_value = 1.0
    rad = 0.35 - 0.05 * i
    obj("Ball%d" % i, sphere(rad), m, location=(-1.5 + 1.0 * i, 0.2 * (i % 2), rad), smooth=True)
w, h, strength = a.quad
obj("LampQuad", grid(w, h), emissive("Lamp", (1, 0.95, 0.85), strength, (0, 0, 0)),
    location=(0.5, -1.0, 2.6), rotation=(math.radians(200), 0, 0))
obj("Backdrop", grid(8, 3), emissive("Backdrop", (0.6, 0.7, 1.0), 0.4, (0.3, 0.3, 0.3)),
    location=(0, 2.5, 1.5), rotation=(math.pi / 2, 0, 0))
world((0.05, 0.05, 0.05))
camera((0.0, -3.6, 1.0), (0, 0.2, 0.3), lens=32)
sc.render.resolution_x = sc.render.resolution_y = 256
sc.render.resolution_percentage = 100
sc.prism.samples = 64
sc.prism.max_depth = 16
bpy.context.preferences.filepaths.save_version = 0
os.makedirs(a.out, exist_ok=True)
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(a.out, name + ".blend"))
gltf, _, warnings, tris = export.export_scene(bpy.context.evaluated_depsgraph_get(), a.out, name)
for w in warnings:
    print("warning:", w)
print("%s: %d triangles -> %s" % (name, tris, gltf))
