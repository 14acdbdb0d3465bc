"""Directional albedo of Cycles' and Prism's Principled Sheen, measured in a white furnace:
a unit sphere of black Principled (Specular IOR Level 0) with Sheen Weight 1 at roughness r
in a uniform white world, seen by an orthographic camera, so each pixel shows E(mu) for its
mu = n.v. Prints E in ten mu bins per roughness for both renderers and writes
/tmp/sheen_albedo.json (bench/README.md: every bin within 0.001 since Prism renders the fibre
layer of Zeltner et al. 2022, src/bsdf/fibre_sheen.rs). Run with the add-on enabled as in
tests/addon:

    .venv-bpy/bin/python bench/sheen_albedo.py
"""
import sys, os, json
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "addon"))
import bpy, numpy as np
import common as C
C.enable_addon()
OUT = "/tmp/sheen_alb"; os.makedirs(OUT, exist_ok=True)
res = {}
for r in [0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]:
    C.reset()
    sc = bpy.context.scene
    C.world((1.0, 1.0, 1.0), 1.0)
    mat = C.material("S", "ShaderNodeBsdfPrincipled", (0.0, 0.0, 0.0), Roughness=0.5, **{"Specular IOR Level": 0.0, "Sheen Weight": 1.0, "Sheen Roughness": r})
    C.mesh_object("Ball", C.sphere(1.0, 128, 64), mat, smooth=True)
    cam = C.camera((0.0, -6.0, 0.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"; cam.data.ortho_scale = 2.2
    sc.render.resolution_x = sc.render.resolution_y = 96; sc.render.resolution_percentage = 100
    out = {}
    for eng in ("cycles", "prism"):
        px = C.render_engine(sc, eng, 256 if eng == "cycles" else 256, OUT, "alb%g" % r, 4)
        # mu per pixel: ortho along +y; pixel (i,j) -> x,z in [-1.1,1.1]
        n = px.shape[0]
        xs = (np.arange(n) + 0.5) / n * 2.2 - 1.1
        X, Z = np.meshgrid(xs, xs)
        rr = X**2 + Z**2
        mu = np.sqrt(np.clip(1 - rr, 0, 1))
        bins = np.linspace(0, 1, 11)
        e = []
        for a, b in zip(bins[:-1], bins[1:]):
            m = (rr < 0.97) & (mu >= a) & (mu < b)
            e.append(float(px[..., 1][m].mean()) if m.any() else float("nan"))
        out[eng] = e
    res[r] = out
    print("r", r, "cycles", np.round(out["cycles"], 3), "prism", np.round(out["prism"], 3), flush=True)
json.dump(res, open("/tmp/sheen_albedo.json", "w"))
