"""Rendered-viewport latency: how long after an edit the viewport's first new image exists.

    .venv-bpy/bin/python bench/serve_latency.py [--triangles 100000] [--size 800x600] [--rounds 5] [--threads 2]

Runs in the bpy wheel without a window, driving the add-on's viewport session
(viewport.ViewportSession) the way view_update/view_draw drive it: a depsgraph_update_post
handler calls sync() with the real depsgraph after each edit made through the Python API, and a
view change is the `view` command view_draw sends. The scene: `--triangles` triangles of smooth
spheres on a floor, a sun and a point light, a grey world.

Per edit kind, the median over `--rounds` of:
- sync: the add-on's work in Blender's thread (classifying the updates, exporting what changed),
- first: edit to the first frame received (the coarse preview at Start Pixels),
- full: edit to the first full-size frame (1 sample per pixel).
Edits: view (camera moved), transform (an object moved), shading (a material colour), light
(a light's power), mesh (one sphere's vertices moved: re-export and reload, the BVH cache
rebuilding only that mesh). `load` is the first load of the scene.
"""

import argparse
import math
import os
import statistics
import sys
import time

REPO = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.join(REPO, "tests", "addon"))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common  # noqa: E402


class Engine:
    def report(self, kind, msg):
        if "ERROR" in kind:
            print("  error:", msg, flush=True)


class Context:
    preferences = bpy.context.preferences


def build_scene(triangles, width, height, threads):
    common.enable_addon()
    common.reset()
    sc = bpy.context.scene
    floor = common.material("Floor", "ShaderNodeBsdfDiffuse", (0.7, 0.7, 0.7))
    common.mesh_object("Floor", common.plane(20.0), floor)
    # Spheres of 2 x segs x (rings - 1) triangles each, on a grid.
    n_spheres = 8
    segs = max(8, int(math.sqrt(triangles / n_spheres)))
    rings = max(4, segs // 2 + 1)
    mats = []
    for i in range(n_spheres):
        m = common.material("Mat%d" % i, "ShaderNodeBsdfPrincipled", (0.2 + 0.1 * i, 0.5, 0.8 - 0.08 * i))
        mats.append(m)
        x, y = (i % 4) * 2.5 - 3.75, (i // 4) * 2.5 - 1.25
        common.mesh_object("Ball%d" % i, common.sphere(1.0, segs, rings), m, location=(x, y, 1.0), smooth=True)
    common.light("Sun", "SUN", 3.0, (0.0, 0.0, 10.0))
    common.light("Lamp", "POINT", 1500.0, (3.0, -4.0, 5.0), shadow_soft_size=0.2)
    common.world((0.05, 0.05, 0.06), 1.0)
    common.camera((0.0, -12.0, 5.0), (0.0, 0.0, 0.8))
    common.use_prism(sc, spp=16, threads=threads)
    sc.render.resolution_x, sc.render.resolution_y = width, height
    sc.prism.preview_samples = 0
    sc.render.preview_pixel_size = "1"
    tris = sum(len(o.data.loop_triangles) if o.type == "MESH" and (o.data.calc_loop_triangles() or True) else 0
               for o in sc.objects)
    return sc, tris


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--triangles", type=int, default=100000)
    ap.add_argument("--size", default="800x600")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    sc, tris = build_scene(args.triangles, width, height, args.threads)
    from prism import viewport

    engine = Engine()
    state = {"session": None, "sync": 0.0}

    def on_update(scene, depsgraph):
        s = state["session"]
        if s is not None:
            t = time.perf_counter()
            s.sync(engine, Context, depsgraph)
            state["sync"] = time.perf_counter() - t

    bpy.app.handlers.depsgraph_update_post.append(on_update)
    results = {}

    def timed(kind, edit, mark_fn=None):
        client = state["session"].client
        mark = len(client.events)
        state["sync"] = 0.0
        t = time.monotonic()
        edit()
        first = client.wait_frame(mark, timeout=120)[0]["received"] - t
        full = client.wait_frame(mark, timeout=120, full_size=(width, height))[0]["received"] - t
        results.setdefault(kind, []).append((state["sync"], first, full))

    def view():
        cam = sc.camera

        class Region3D:
            view_matrix = cam.matrix_world.inverted()
            window_matrix = cam.calc_matrix_camera(bpy.context.evaluated_depsgraph_get(), x=width, y=height)
            is_perspective = True

        return {"width": width, "height": height, "camera": viewport.view_camera(Region3D)}

    try:
        t = time.monotonic()
        s = viewport.ViewportSession(engine, Context, bpy.context.evaluated_depsgraph_get())
        state["session"] = s
        load_sync = time.monotonic() - t
        mark = s.client.send("view", **view())
        first = s.client.wait_frame(mark, timeout=300)[0]["received"] - t
        full = s.client.wait_frame(mark, timeout=300, full_size=(width, height))[0]["received"] - t
        results["load"] = [(load_sync, first, full)]
        ball = bpy.data.objects["Ball0"]
        lamp = bpy.data.lights["Lamp"]
        colour = bpy.data.materials["Mat0"].node_tree.nodes["Principled BSDF"].inputs["Base Color"]
        me = bpy.data.objects["Ball1"].data
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", co)
        for r in range(args.rounds):
            sign = 1 if r % 2 == 0 else -1

            def move_camera():
                sc.camera.location.x += 0.3 * sign
                bpy.context.view_layer.update()
                s.client.send("view", **view())

            timed("view", move_camera)

            def move_object():
                ball.location.z += 0.2 * sign
                bpy.context.view_layer.update()

            timed("transform", move_object)

            def recolour():
                colour.default_value = (0.3 + 0.1 * r, 0.4, 0.5, 1.0)
                bpy.context.view_layer.update()

            timed("shading", recolour)

            def relight():
                lamp.energy = 1500.0 + 100.0 * r
                bpy.context.view_layer.update()

            timed("light", relight)

            def edit_mesh():
                me.vertices.foreach_set("co", co * np.float32(1.0 + 0.02 * (r + 1)))
                me.update()
                bpy.context.view_layer.update()

            timed("mesh", edit_mesh)
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(on_update)
        viewport.close_all()
    print("scene: %d triangles, %dx%d viewport, %d threads, Start Pixels %d, median of %d"
          % (tris, width, height, args.threads, sc.prism.preview_start_resolution, args.rounds))
    print("%-10s %9s %9s %9s" % ("edit", "sync ms", "first ms", "full ms"))
    for kind, rows in results.items():
        med = [statistics.median(c) * 1e3 for c in zip(*rows)]
        print("%-10s %9.1f %9.1f %9.1f" % (kind, *med))


if __name__ == "__main__":
    main()
