"""Run by Blender (3.4 or 5.0): builds one of test_camera_world.py's scenes with both engines'
settings and saves it.  blender -b --factory-startup -P make_camera_world.py -- KIND OUT.blend

KIND: env (the environment image written next to the .blend as a float EXR and used from the file),
dof, ortho (HORIZONTAL fit on a portrait image)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import common as C  # noqa: E402
import test_camera_world as T  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
kind, out = argv[0], os.path.abspath(argv[1])
C.enable_addon()
if kind == "env":
    import numpy as np
    from prism import export

    sc = T.env_scene(-0.65)
    # The same pixels from a linear float EXR file. (Blender 3.4's Image.save() of the generated
    # float image writes sRGB-encoded values, which Cycles then reads as linear.)
    gen = bpy.data.images["EnvGen"]
    w, h = gen.size
    px = np.empty(w * h * 4, np.float32)
    gen.pixels.foreach_get(px)
    path = os.path.join(os.path.dirname(out), "env_%s.exr" % bpy.app.version_string.split()[0])
    export.write_exr_rgb(path, px.reshape(h, w, 4)[::-1, :, :3])
    tex = next(n for n in sc.world.node_tree.nodes if n.type == "TEX_ENVIRONMENT")
    tex.image = bpy.data.images.load(path)
    bpy.data.images.remove(gen)
    spp, bounces = 64, 4
elif kind == "dof":
    sc = T.dof_scene()
    spp, bounces = 64, 1
else:
    sc = T.ortho_scene("HORIZONTAL", 40, 64)
    spp, bounces = 64, 1
C.use_cycles(sc, spp, bounces=bounces)
C.use_prism(sc, spp)
sc.prism.max_depth = C.prism_depth(bounces)
vs = sc.view_settings
vs.view_transform = "Standard"
vs.look = "None"
bpy.ops.wm.save_as_mainfile(filepath=out)
print("saved", out)
