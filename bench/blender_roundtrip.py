#!/usr/bin/env python3
"""Overhead of the Blender round trip through the Prism add-on, for a ~100k-triangle scene.

    .venv-bpy/bin/python bench/blender_roundtrip.py [--spp 64] [--size 256] [--threads 2] [--repeat 3]

Renders with bpy.ops.render.render() (Prism engine) and splits the wall time:
  export     depsgraph -> glTF + .bin + material JSON (add-on, numpy foreach_get)
  start      Popen until the binary's "start" event (process start + glTF load + BVH build)
  load_bvh   the binary's own glTF load + BVH build time (part of start)
  render     path tracing, as the binary reports it ("done" seconds)
  exr_load   final EXR -> render result (bpy.data.images.load + foreach_get)
  overhead   wall time of the render operator minus `render`
Prints one JSON line per repeat and the median overhead.
"""

import argparse
import json
import os
import statistics
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "blender_addon"))
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="bpy_user_"))
import bpy  # noqa: E402
import bmesh  # noqa: E402

import prism  # noqa: E402


def build(spp, size, threads):
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    mat = bpy.data.materials.new("Clay")
    me = bpy.data.meshes.new("Dense")
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=320, v_segments=160, radius=1.0)
    bm.to_mesh(me)
    bm.free()
    me.materials.append(mat)
    ob = bpy.data.objects.new("Dense", me)
    sc.collection.objects.link(ob)
    L = bpy.data.lights.new("Lamp", "POINT")
    L.energy = 1000
    lo = bpy.data.objects.new("Lamp", L)
    lo.location = (3, -3, 4)
    sc.collection.objects.link(lo)
    cam = bpy.data.cameras.new("Cam")
    co = bpy.data.objects.new("Cam", cam)
    co.location = (0, -5, 0)
    co.rotation_euler = (1.5708, 0, 0)
    sc.collection.objects.link(co)
    sc.camera = co
    sc.render.engine = "PRISM"
    sc.render.resolution_x = sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.prism.samples = spp
    sc.prism.threads = threads
    return sc


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    prism.register()
    bpy.context.preferences.addons  # (binary found through the repository's target/release)
    overheads = []
    for _ in range(a.repeat):
        build(a.spp, a.size, a.threads)
        t0 = time.perf_counter()
        bpy.ops.render.render()
        wall = time.perf_counter() - t0
        last = prism.engine.LAST
        if last.get("error"):
            sys.exit(last["error"])
        t = last["timings"]
        render_s = float(last["done"]["seconds"])
        row = {
            "triangles": last["triangles"],
            "spp": a.spp,
            "size": a.size,
            "threads": a.threads,
            "wall": round(wall, 3),
            "export": round(t["export"], 3),
            "start": round(t["to_start_event"], 3),
            "load_bvh": round(t["prism_load"], 3),
            "render": round(render_s, 3),
            "exr_load": round(t["load"], 3),
            "overhead": round(wall - render_s, 3),
            "overhead_pct": round(100 * (wall - render_s) / wall, 2),
        }
        overheads.append(row["overhead"])
        print(json.dumps(row), flush=True)
    print("median overhead %.3f s" % statistics.median(overheads))


if __name__ == "__main__":
    main()
