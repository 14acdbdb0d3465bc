"""Run by Blender: builds a test scene and saves it.  blender -b --factory-startup -P make_blend.py -- KIND OUT.blend [SPP]"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import common as C  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
kind, out = argv[0], os.path.abspath(argv[1])
spp = int(argv[2]) if len(argv) > 2 else 16
C.enable_addon()
sc = C.parity_scene(120, 90) if kind == "parity" else C.simple_scene()
if kind == "simple":
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 200, 150, 60
C.use_prism(sc, spp)
if kind == "denoise":
    sc.prism.use_denoising = True  # the default for a new scene; use_prism turns it off
# A modifier and a linked duplicate: the exporter must see the evaluated, instanced scene.
ball = bpy.data.objects.get("Ball")
if ball is not None:
    ball.modifiers.new("Sub", "SUBSURF").levels = 1
    dup = bpy.data.objects.new("Ball2", ball.data)
    dup.location = (2.2, 1.0, 1.0)
    dup.scale = (0.5, 0.5, 0.5)
    sc.collection.objects.link(dup)
    hidden = bpy.data.objects.new("Hidden", ball.data)
    hidden.location = (0.0, -5.0, 2.0)
    hidden.hide_render = True
    sc.collection.objects.link(hidden)
bpy.ops.wm.save_as_mainfile(filepath=out)
print("saved", out)
