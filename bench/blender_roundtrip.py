#!/usr/bin/env python3
"""Overhead of the Blender round trip through the Prism add-on, for a ~100k-triangle scene.

    .venv-bpy/bin/python bench/blender_roundtrip.py [--scene sphere|studio] [--spp 64] [--size 256]
                                                    [--threads 2] [--repeat 3]

Scenes (both ~100k triangles in one mesh, so the BVH build is the same size):
  sphere   a 101,760-triangle UV sphere, one point light, black world: the cheapest render
           possible (half the pixels are background, paths end after one bounce), so the
           fixed overhead is the largest possible fraction of it.
  studio   the same sphere on a floor plane (2 more triangles), lit by a sun, an area light and
           a grey world: an ordinary "object on a floor" scene with indirect light.

Renders with bpy.ops.render.render() (Prism engine) and splits the wall time:
  export     depsgraph -> glTF + .bin + material JSON (add-on, numpy foreach_get)
  start      Popen until the binary's "start" event (process start + glTF load + BVH build)
  load_bvh   the binary's own glTF load + scene build time (part of start)
  build      of which the scene build (BVHs, light tables)
  render     path tracing, as the binary reports it ("done" seconds)
  exr_load   final EXR -> render result (bpy.data.images.load + foreach_get)
  process    Popen until the binary has exited (start + render + final EXR write + exit)
  engine     the whole RenderEngine.render() call (the rest of the wall time is Blender's own
             render pipeline: render result, depsgraph, post-processing)
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
sys.path.insert(0, os.path.join(REPO, "scenes"))
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="bpy_user_"))
import bpy  # noqa: E402
import bmesh  # noqa: E402

import prism  # noqa: E402
from bpy_helpers import world  # noqa: E402


def _clay():
    return bpy.data.materials.new("Clay")


def _dense_sphere(sc, location=(0.0, 0.0, 0.0)):
    """A 101,760-triangle UV sphere of radius 1."""
    me = bpy.data.meshes.new("Dense")
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=320, v_segments=160, radius=1.0)
    bm.to_mesh(me)
    bm.free()
    me.materials.append(_clay())
    ob = bpy.data.objects.new("Dense", me)
    ob.location = location
    sc.collection.objects.link(ob)
    return ob


def _sphere_scene(sc):
    _dense_sphere(sc)
    L = bpy.data.lights.new("Lamp", "POINT")
    L.energy = 1000
    lo = bpy.data.objects.new("Lamp", L)
    lo.location = (3, -3, 4)
    sc.collection.objects.link(lo)


def _studio_scene(sc):
    _dense_sphere(sc)
    floor_me = bpy.data.meshes.new("Floor")
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=6.0)
    bm.to_mesh(floor_me)
    bm.free()
    floor_me.materials.append(bpy.data.materials.new("Floor"))
    floor = bpy.data.objects.new("Floor", floor_me)
    floor.location = (0, 0, -1.0)
    sc.collection.objects.link(floor)
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy = 3.0
    so = bpy.data.objects.new("Sun", sun)
    so.rotation_euler = (0.6, 0.2, 0.8)
    sc.collection.objects.link(so)
    area = bpy.data.lights.new("Key", "AREA")
    area.energy = 300.0
    area.size = 1.5
    ao = bpy.data.objects.new("Key", area)
    ao.location = (-2.5, -2.5, 3.0)
    ao.rotation_euler = (0.8, 0.0, -0.8)
    sc.collection.objects.link(ao)
    world((0.4, 0.45, 0.5), 1.0)


def build(spp, size, threads, scene="sphere"):
    bpy.ops.wm.read_homefile(use_empty=True)
    sc = bpy.context.scene
    {"sphere": _sphere_scene, "studio": _studio_scene}[scene](sc)
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
    ap.add_argument("--scene", choices=("sphere", "studio"), default="sphere")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--rerender", action="store_true",
                    help="build the scene once and render it --repeat times (re-renders of an unchanged "
                    "scene: the BVH cache hits after the first); default: a fresh scene per render")
    ap.add_argument("--no-bvh-cache", action="store_true", help="disable the add-on's BVH cache")
    a = ap.parse_args()
    prism.register()
    bpy.context.preferences.addons  # (binary found through the repository's target/release)
    overheads = []
    if a.no_bvh_cache:
        prism.runner.bvh_cache_dir = lambda: None
    for i in range(a.repeat):
        if i == 0 or not a.rerender:
            build(a.spp, a.size, a.threads, a.scene)
        t0 = time.perf_counter()
        bpy.ops.render.render()
        wall = time.perf_counter() - t0
        last = prism.engine.LAST
        if last.get("error"):
            sys.exit(last["error"])
        t = last["timings"]
        render_s = float(last["done"]["seconds"])
        row = {
            "scene": a.scene,
            "triangles": last["triangles"],
            "spp": a.spp,
            "size": a.size,
            "threads": a.threads,
            "wall": round(wall, 3),
            "export": round(t["export"], 3),
            "start": round(t["to_start_event"], 3),
            "load_bvh": round(t["prism_load"], 3),
            "build": round(t.get("prism_build", float("nan")), 3),
            "render": round(render_s, 3),
            "exr_load": round(t["load"], 3),
            "process": round(t["process"], 3),
            "engine": round(t["engine"], 3),
            "overhead": round(wall - render_s, 3),
            "overhead_pct": round(100 * (wall - render_s) / wall, 2),
        }
        overheads.append(row["overhead"])
        print(json.dumps(row), flush=True)
    print("median overhead %.3f s" % statistics.median(overheads))


if __name__ == "__main__":
    main()
