"""The rendered viewport's renderer process (`prism serve`) in the bpy 5.0.1 wheel, no window.

    .venv-bpy/bin/python tests/addon/test_serve.py

Blender has no viewport here, so the add-on's viewport session (viewport.ViewportSession) is
driven the way view_update drives it: from a depsgraph_update_post handler, with the real
depsgraph and its updates after each edit made through the Python API. After each edit the
session's frames are compared with an F12 render of the scene as edited (same samples, seed
and settings): load, a camera view, an object moved, a material edited, a light edited, a
mesh edited, an object added. Each edit's path (view / transform / shading / load) is checked,
and its latency (edit to first frame, to the finished image) printed: a benchmark figure, not
an assertion. bench/serve_latency.py measures it on a 100k-triangle scene.
"""

import math
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Matrix  # noqa: E402

import common  # noqa: E402
from common import check  # noqa: E402

SPP = 8
W, H = 96, 64


class Engine:
    """What the session needs of a RenderEngine without a viewport: reports."""

    def __init__(self):
        self.reports = []

    def report(self, kind, msg):
        self.reports.append((sorted(kind)[0], msg))


class Context:
    preferences = bpy.context.preferences


def setup():
    common.enable_addon()
    sc = common.simple_scene()
    common.use_prism(sc, spp=SPP)
    sc.render.resolution_x, sc.render.resolution_y = W, H
    sc.prism.preview_samples = SPP
    sc.render.preview_pixel_size = "1"
    return sc


def scene_camera_view():
    """The `view` command of the scene camera, as view_draw builds it from a camera view's
    region (here from the camera itself: its inverse world matrix and its projection)."""
    sc = bpy.context.scene
    from prism import viewport

    class Region3D:
        view_matrix = sc.camera.matrix_world.inverted()
        window_matrix = sc.camera.calc_matrix_camera(bpy.context.evaluated_depsgraph_get(), x=W, y=H)
        is_perspective = sc.camera.data.type != "ORTHO"

    return {"width": W, "height": H, "camera": viewport.view_camera(Region3D)}


def run():
    sc = setup()
    from prism import viewport

    engine = Engine()
    state = {"session": None}

    def on_update(scene, depsgraph):
        s = state["session"]
        if s is not None:
            s.sync(engine, Context, depsgraph)

    bpy.app.handlers.depsgraph_update_post.append(on_update)
    out = tempfile.mkdtemp(prefix="prism_addon_test_serve_")
    try:
        t0 = time.monotonic()
        s = viewport.ViewportSession(engine, Context, bpy.context.evaluated_depsgraph_get())
        state["session"] = s
        client = s.client

        def send_view():
            view = scene_camera_view()
            s.view = view
            return client.send("view", **view)

        def frames_after(mark, what, t_edit):
            ev, _ = client.wait_frame(mark, timeout=60)
            first = ev["received"] - t_edit
            done = client.wait_for(lambda e: e.get("event") == "done", since=mark, timeout=120)
            fr = client.frame
            check(fr is not None and fr.spp == SPP and (fr.width, fr.height) == (W, H), "%s: a %dx%d frame at %d spp" % (what, W, H, SPP))
            print("  latency %-16s first frame %6.1f ms, %d spp in %6.1f ms" % (what, 1e3 * first, SPP, 1e3 * (done["received"] - t_edit)), flush=True)
            return fr.pixels[::-1]  # top row first

        def compare(what, px, name, exact=True):
            ref = common.render_pixels(sc, os.path.join(out, name + ".exr"))[::-1]
            ms, mr = px[..., :3].mean(axis=(0, 1)), ref[..., :3].mean(axis=(0, 1))
            check(np.allclose(ms, mr, rtol=0.01, atol=1e-4), "%s: frame means %s = F12 render's %s (1%%)" % (what, ms.round(4), mr.round(4)))
            # The same samples of the same paths give the same pixels, but where the viewport's
            # BVH layout (every instance under the top level) and the final render's (flattened)
            # round a hit differently, which changes that path from there on: nearly every pixel
            # equal. With emissive meshes (area lights) the light tables list a mesh's triangles
            # in its BVH's leaf order, which differs between the layouts: the same estimator
            # with other random choices, so equal 16x16 block means.
            diff = np.abs(px[..., :3] - ref[..., :3]).max(axis=-1)
            if not exact:
                def blocks(a):
                    return a[..., :3].reshape(H // 16, 16, W // 16, 16, 3).mean(axis=(1, 3))

                rel = float((np.abs(blocks(px) - blocks(ref)) / np.maximum(blocks(ref), 0.05)).max())
                check(rel < 0.03, "%s: 16x16 block means within 3%% of the F12 render's (max %.3f)" % (what, rel))
            else:
                off = float((diff > 1e-3).mean())
                check(off < 0.005 and float(diff.mean()) < 2e-3,
                      "%s: pixels equal to the F12 render's but %.2f%% (mean difference %.2g, max %.3f)"
                      % (what, 100 * off, float(diff.mean()), float(diff.max())))
            return ref

        mark = send_view()
        img0 = frames_after(mark, "load + view", t0)
        ref0 = compare("load", img0, "load")
        check(s.node_names.get("Ball") == 1, "the export names its nodes (Ball once)")

        # The camera: a new view only.
        cam = sc.camera
        cam.location.x += 1.5
        cam.rotation_euler.z += 0.15
        bpy.context.view_layer.update()
        t = time.monotonic()
        mark = send_view()
        img = frames_after(mark, "camera", t)
        ref = compare("camera", img, "camera")
        check(np.abs(ref - ref0).max() > 0.2, "the camera move changes the image")
        cam.location.x -= 1.5
        cam.rotation_euler.z -= 0.15
        bpy.context.view_layer.update()
        mark = send_view()
        frames_after(mark, "camera back", time.monotonic())

        # Lens shift and an orthographic camera: the view's projection matrix carries both.
        cam.data.shift_x, cam.data.shift_y = 0.15, -0.1
        bpy.context.view_layer.update()
        mark = send_view()
        compare("camera shift", frames_after(mark, "camera shift", time.monotonic()), "shift")
        cam.data.type = "ORTHO"
        cam.data.ortho_scale = 9.0
        bpy.context.view_layer.update()
        mark = send_view()
        compare("orthographic", frames_after(mark, "orthographic", time.monotonic()), "ortho")
        cam.data.type = "PERSP"
        cam.data.shift_x = cam.data.shift_y = 0.0
        bpy.context.view_layer.update()
        mark = send_view()
        frames_after(mark, "camera back", time.monotonic())

        stats = dict(viewport.STATS)

        def edit(what, fn, path):
            before = {k: viewport.STATS[k] for k in ("loads", "shadings", "transforms")}
            mark = len(client.events)
            t = time.monotonic()
            fn()
            bpy.context.view_layer.update()  # runs the depsgraph: the handler syncs
            after = {k: viewport.STATS[k] for k in ("loads", "shadings", "transforms")}
            grew = "+".join(sorted(k for k in after if after[k] > before[k]))
            check(grew == path, "%s: sent as %s (%s)" % (what, path, grew))
            return frames_after(mark, what, t)

        ball = bpy.data.objects["Ball"]
        img = edit("object move", lambda: setattr(ball, "location", (1.2, 0.5, 1.4)), "transforms")
        red = bpy.data.materials["Red"].node_tree.nodes["Diffuse BSDF"].inputs["Color"]
        img = edit("material colour", lambda: setattr(red, "default_value", (0.1, 0.2, 0.8, 1.0)), "shadings")
        compare("material colour", img, "blue")
        lamp = bpy.data.lights["Lamp"]
        img = edit("light power", lambda: setattr(lamp, "energy", 2500.0), "shadings")
        compare("light power", img, "light")
        lamp_ob = bpy.data.objects["Lamp"]
        img = edit("light move", lambda: setattr(lamp_ob, "location", (-2.0, -2.5, 3.0)), "shadings")
        compare("light move", img, "light_moved")

        def assign_material():
            ball.data.materials[0] = bpy.data.materials["Floor"]

        img = edit("material assigned", assign_material, "loads")
        compare("material assigned", img, "assigned")
        ball.data.materials[0] = bpy.data.materials["Red"]
        bpy.context.view_layer.update()

        def scale_mesh():
            me = ball.data
            co = np.empty(len(me.vertices) * 3, np.float32)
            me.vertices.foreach_get("co", co)
            # A scale no earlier run used: the BVH cache (kept in the temporary folder) has not
            # seen this mesh.
            me.vertices.foreach_set("co", co * np.float32(0.7 + 1e-4 * (time.time_ns() % 1000)))
            me.update()

        img = edit("mesh edit", scale_mesh, "loads")
        compare("mesh edit", img, "mesh")
        loaded = [e for e in client.events if e.get("event") == "loaded"][-1]
        check((loaded["bvh_cache_misses"], loaded["bvh_cache_hits"]) == (1, 1),
              "the mesh edit's reload built one BVH (the ball's) and took the floor's from the cache (%s)"
              % {k: v for k, v in loaded.items() if k.startswith("bvh")})

        def add_object():
            common.mesh_object("Box", common.cube(0.8), bpy.data.materials["Red"], location=(-1.5, 0.8, 0.4))

        frames_before_box = client.frame.pixels[::-1].copy()
        img = edit("object added", add_object, "loads")
        compare("object added", img, "added")

        def hide_box():
            box = bpy.data.objects["Box"]
            box.hide_viewport = True  # the viewport's depsgraph drops it
            box.hide_render = True  # and so does the F12 render compared with

        img = edit("object hidden", hide_box, "loads")
        compare("object hidden", img, "hidden")
        check(abs(img.mean() - frames_before_box.mean()) < 1e-3 * frames_before_box.mean() + 1e-4,
              "hiding the added object gives the image before it was added")

        def add_area_light():
            common.light("Panel", "AREA", 300.0, (-1.0, -3.0, 3.0), size=1.0)

        img = edit("area light added", add_area_light, "loads")
        compare("area light added", img, "area", exact=False)
        img = edit("area light size", lambda: setattr(bpy.data.lights["Panel"], "size", 2.5), "loads")
        compare("area light size", img, "area_size", exact=False)
        img = edit("area light move", lambda: setattr(bpy.data.objects["Panel"], "location", (1.0, -3.0, 2.5)), "shadings+transforms")
        compare("area light move", img, "area_moved", exact=False)
        # Viewport Denoise (the wheel's OIDN): a 2-spp frame, denoised, is closer to a 64-spp
        # render than the noisy 2-spp frame, and keeps its brightness.
        from prism import engine as prism_engine

        if prism_engine.blender_oidn() is not None:
            sc.prism.samples = 64
            ref = common.render_pixels(sc, os.path.join(out, "ref64.exr"))[::-1][..., :3]
            sc.prism.samples = SPP

            def frame_at(denoise):
                sc.prism.use_preview_denoising = denoise
                sc.prism.preview_samples = 2
                mark = len(client.events)
                s.send_settings(engine, Context, sc)  # what view_draw does on the next redraw
                try:
                    client.wait_for(lambda e: e.get("event") == "done", since=mark, timeout=60)
                except Exception:
                    print([{k: v for k, v in e.items() if k != "received"} for e in client.events[mark:]], client.stderr_tail)
                    raise
                return client.frame.pixels[::-1][..., :3]

            noisy, denoised = frame_at(False), frame_at(True)
            err = [float(np.mean((x - ref) ** 2)) for x in (noisy, denoised)]
            check(err[1] < 0.5 * err[0], "Viewport Denoise: MSE against 64 spp %.5f denoised vs %.5f noisy" % (err[1], err[0]))
            check(abs(denoised.mean() / noisy.mean() - 1.0) < 0.05, "Viewport Denoise keeps the brightness (%.4f vs %.4f)"
                  % (denoised.mean(), noisy.mean()))
            sc.prism.use_preview_denoising = False
            sc.prism.preview_samples = SPP
            s.send_settings(engine, Context, sc)
        else:
            print("  skipped: Viewport Denoise (no OIDN in this Blender)")
        check(not [r for r in engine.reports if r[0] == "ERROR"], "no errors reported: %s" % engine.reports)
        print("  session stats:", {k: v for k, v in viewport.STATS.items() if k != "last_frame"}, "(after camera: %s)" % stats)

        pid = client.proc.pid
        s.close()
        check(client.proc.poll() is not None, "close() ends the renderer process (pid %d)" % pid)
        check(not os.path.exists(s.tmp), "close() removes the session's export folder")
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(on_update)
        viewport.close_all()
        import shutil

        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    run()
    print("serve test passed")
