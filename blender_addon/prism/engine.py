# SPDX-License-Identifier: MIT
"""The Prism RenderEngine: export -> run the binary -> previews -> EXR into the render result."""

import os
import shutil
import sys
import tempfile
import time
import traceback

import bpy
import numpy as np

from . import exr, export, runner, viewport

# What the last render did (read by the add-on tests and the benchmark).
LAST = {}
# Samples of a material/world/light preview render (the Preview panel, icons): enough for the
# look of a material on the preview sphere at a few hundred pixels, in a fraction of a second.
PREVIEW_SAMPLES = 16
# How many preview renders ran (the tests check that Prism, not EEVEE, renders previews).
PREVIEW_RENDERS = []


def addon_preferences():
    pkg = __package__
    addon = bpy.context.preferences.addons.get(pkg) if bpy.context and bpy.context.preferences else None
    return addon.preferences if addon is not None else None


def read_exr(path, width, height):
    """RGBA float pixels of an EXR, bottom row first (the layout of RenderPass.rect).

    Read by the numpy reader (exr.py): it adds no image datablock from the render thread while
    the interface may be drawing, and on the raw scanlines the add-on asks the binary for it is
    a single numpy view (0.4 ms at 256x256, where Blender's loader takes ~3 ms). Blender's own
    loader is the fallback for files the reader does not handle.
    """
    try:
        px = exr.read_rgba(path)
        if px.shape[:2] != (height, width):
            raise runner.RunnerError("%s is %dx%d, expected %dx%d" % (os.path.basename(path), px.shape[1], px.shape[0], width, height))
        return np.ascontiguousarray(px[::-1]).reshape(-1, 4)
    except exr.ExrError as e:
        _log("EXR reader: %s; using Blender's loader" % e)
    img = bpy.data.images.load(path, check_existing=False)
    try:
        if tuple(img.size) != (width, height):
            raise runner.RunnerError("%s is %dx%d, expected %dx%d" % (os.path.basename(path), img.size[0], img.size[1], width, height))
        px = np.empty(width * height * 4, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(-1, 4)


def guide_passes(scene, view_layer):
    """Extra passes this render produces from the binary's guides, as (pass name, channels,
    chan_id, type), in the order Blender expects them: Blender's Depth/Normal passes when the
    view layer asks for them, and Cycles-style denoising data (for the Denoise compositor node)
    when Prism's setting is on."""
    out = []
    if view_layer is not None and getattr(view_layer, "use_pass_z", False):
        out.append(("Depth", 1, "Z", "VALUE"))
    if view_layer is not None and getattr(view_layer, "use_pass_normal", False):
        out.append(("Normal", 3, "XYZ", "VECTOR"))
    p = getattr(scene, "prism", None)
    if p is not None and getattr(p, "denoising_data", False):
        out.append(("Denoising Normal", 3, "XYZ", "VECTOR"))
        out.append(("Denoising Albedo", 3, "RGB", "COLOR"))
        out.append(("Denoising Depth", 1, "Z", "VALUE"))
    return out


def denoise_passes(scene):
    """Cycles' Noisy Image pass: the render before denoising, when denoising is on."""
    p = getattr(scene, "prism", None)
    if p is not None and getattr(p, "use_denoising", False):
        return [("Noisy Image", 4, "RGBA", "COLOR")]
    return []


_OIDN = {}


def blender_oidn():
    """The running Blender's Open Image Denoise library (cached: it does not move), or None."""
    if "path" not in _OIDN:
        _OIDN["dirs"] = runner.oidn_search_dirs(bpy.app.binary_path, bpy.utils.resource_path("LOCAL"))
        _OIDN["path"] = runner.find_oidn(_OIDN["dirs"])
    return _OIDN["path"]


def guide_pixels(planes, name, width, height):
    """A pass's pixels (bottom row first, channels last) from the binary's EXR planes. Normals
    come in glTF world axes (Y up) and go out in Blender's (Z up): (x, y, z) -> (x, -z, y)."""
    def flat(*channels):
        stack = np.stack([planes[c] for c in channels], axis=-1)
        return np.ascontiguousarray(stack[::-1]).reshape(width * height, len(channels))

    if name == "Depth":
        return flat("Depth.Z")
    if name in ("Normal", "Denoising Normal"):
        n = flat("Normal.X", "Normal.Y", "Normal.Z")
        return np.stack([n[:, 0], -n[:, 2], n[:, 1]], axis=-1)
    if name == "Denoising Albedo":
        return flat("Albedo.R", "Albedo.G", "Albedo.B")
    if name == "Denoising Depth":
        return flat("Depth.Z")
    if name == "Noisy Image":
        # Written by the binary when it denoised; otherwise the image is the noisy one.
        if "Noisy.R" in planes:
            return flat("Noisy.R", "Noisy.G", "Noisy.B", "Noisy.A")
        return flat("R", "G", "B", "A")
    raise KeyError(name)


def set_pass_pixels(render_pass, px):
    """Copies (pixels, channels) float32 into a RenderPass. `rect.foreach_set` takes the flat
    buffer directly; assigning `rect = px` converts it element by element in Python (about
    25 ms for 256x256 RGBA, most of the add-on's result-loading time)."""
    flat = np.ascontiguousarray(px, dtype=np.float32).reshape(-1)
    try:
        render_pass.rect.foreach_set(flat)
    except (AttributeError, TypeError, RuntimeError):  # older Blender without foreach_set here
        render_pass.rect = px


def border_window(scene, width, height):
    """Render > Format > Render Region (Blender's border): the window (x, y from the top-left
    corner, w, h) of the width x height image, with Blender's own rounding (the render
    result's size), or None without a border."""
    r = scene.render
    if not r.use_border:
        return None
    x0, x1 = int(r.border_min_x * width), int(r.border_max_x * width)
    y0, y1 = int(r.border_min_y * height), int(r.border_max_y * height)
    w, h = min(x1, width) - x0, min(y1, height) - y0
    if w <= 0 or h <= 0 or (w, h) == (width, height):
        return None
    return x0, height - y0 - h, w, h


def _log(msg):
    print("Prism: " + msg, file=sys.stderr, flush=True)


class PrismRenderEngine(bpy.types.RenderEngine):
    bl_idname = "PRISM"
    bl_label = "Prism"
    # Material, world and light previews (the Preview panel's sphere, data-block icons) are
    # rendered by Prism too, small and at PREVIEW_SAMPLES (render(): `is_preview`).
    bl_use_preview = True
    bl_use_postprocess = True
    bl_use_shading_nodes_custom = False  # materials are Blender's shader nodes (converted on export)
    bl_use_eevee_viewport = True  # Material Preview / Rendered viewport shading through EEVEE

    # -- the rendered viewport (viewport.py): a `prism serve` process per viewport
    def view_update(self, context, depsgraph):
        try:
            session = getattr(self, "_viewport", None)
            if session is None or session.closed:
                self._viewport = viewport.ViewportSession(self, context, depsgraph)
            else:
                session.sync(self, context, depsgraph)
        except (runner.RunnerError, export.ExportError, viewport.ServeError) as e:
            _log("viewport: " + str(e))
            self.report({"ERROR"}, "Prism: " + str(e))
        except Exception as e:  # never let an exception escape into Blender's draw loop
            traceback.print_exc()
            self.report({"ERROR"}, "Prism: internal error: %s" % e)

    def view_draw(self, context, depsgraph):
        session = getattr(self, "_viewport", None)
        if session is None or session.closed:
            return
        try:
            session.draw(self, context, depsgraph)
        except viewport.ServeError as e:
            self.report({"ERROR"}, "Prism: " + str(e))
        except Exception as e:
            traceback.print_exc()
            self.report({"ERROR"}, "Prism: internal error: %s" % e)

    def __del__(self):
        # Blender frees the engine when its viewport leaves Rendered shading, the engine
        # changes, or the area closes: the renderer process ends with it.
        session = getattr(self, "_viewport", None)
        if session is not None:
            session.close()

    def render(self, depsgraph):
        t_engine = time.perf_counter()
        scene = depsgraph.scene
        width, height = export.render_size(scene)
        LAST.clear()
        LAST.update(
            error=None, warnings=[], cancelled=False, width=width, height=height, timings={}, previews=0, progress=[],
            active=None,
        )
        # Blender calls render() once per enabled view layer, with that layer's depsgraph
        # (its own visibility and holdouts): the result goes to that layer.
        layer = depsgraph.view_layer.name if depsgraph.view_layer is not None else ""
        result = self.begin_result(0, 0, width, height, layer=layer)
        tmp = tempfile.mkdtemp(prefix="prism_")
        LAST["tmpdir"] = tmp
        try:
            # With a render border Blender's result is the region only (it lays it into the
            # frame, or crops to it): render that window of the full view.
            crop = border_window(scene, width, height)
            LAST["crop"] = crop
            if crop is not None:
                n = len(result.layers[0].passes["Combined"].rect)
                if n != crop[2] * crop[3]:
                    raise runner.RunnerError("render border: Blender's result has %d pixels, the region %dx%d"
                                             % (n, crop[2], crop[3]))
            self._render(depsgraph, scene, result, tmp, width, height, crop)
        except (runner.RunnerError, export.ExportError) as e:
            self._error(str(e))
        except Exception as e:  # never let an exception escape into Blender's render job
            traceback.print_exc()
            self._error("internal error: %s" % e)
        finally:
            self.end_result(result)
            shutil.rmtree(tmp, ignore_errors=True)
            LAST["timings"]["engine"] = time.perf_counter() - t_engine

    def _error(self, msg):
        LAST["error"] = msg
        _log("error: " + msg)
        if not self.is_preview:  # a preview that fails keeps its old picture; the log says why
            self.report({"ERROR"}, "Prism: " + msg)

    def _warn(self, msg):
        LAST["warnings"].append(msg)
        _log("warning: " + msg)
        self.report({"WARNING"}, "Prism: " + msg)

    def _set_pixels(self, result, px):
        set_pass_pixels(result.layers[0].passes["Combined"], px)

    def _set_all_passes(self, result, path, passes, width, height):
        planes = exr.read_planes(path)
        rgba = exr.rgba_of(planes)
        if rgba.shape[:2] != (height, width):
            raise runner.RunnerError("%s is %dx%d, expected %dx%d" % (os.path.basename(path), rgba.shape[1], rgba.shape[0], width, height))
        self._set_pixels(result, np.ascontiguousarray(rgba[::-1]).reshape(-1, 4))
        layer_passes = result.layers[0].passes
        for name, _channels, _chan_id, _kind in passes:
            target = layer_passes.get(name) if hasattr(layer_passes, "get") else None
            if target is None:
                self._warn("the render result has no '%s' pass" % name)
                continue
            set_pass_pixels(target, guide_pixels(planes, name, width, height))

    def update_render_passes(self, scene=None, renderlayer=None):
        """Declares the passes of a render (Blender calls this when it builds render results and
        the compositor's Render Layers node)."""
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        for name, channels, chan_id, kind in denoise_passes(scene) + guide_passes(scene, renderlayer):
            self.register_pass(scene, renderlayer, name, channels, chan_id, kind)

    def _render(self, depsgraph, scene, result, tmp, width, height, crop=None):
        prefs = addon_preferences()
        binary = runner.find_binary(prefs.binary_path if prefs is not None else "")
        timings = LAST["timings"]
        settings = scene.prism

        self.update_stats("", "Prism: exporting")
        t0 = time.perf_counter()
        preview_render = bool(self.is_preview)
        gltf, mjson, warnings, tris = export.export_scene(depsgraph, tmp, engine=self, bake=not preview_render, info=LAST)
        timings["export"] = time.perf_counter() - t0
        LAST["triangles"] = tris
        for w in warnings:
            if preview_render:
                # The preview scene's own objects and the icons would repeat the final
                # render's warnings many times over: the console only.
                _log("preview: warning: " + w)
            else:
                self._warn(w)

        output = os.path.join(tmp, "render.exr")
        preview = os.path.join(tmp, "preview.exr")
        denoise = bool(getattr(settings, "use_denoising", False)) and not preview_render
        oidn = blender_oidn() if denoise else None
        samples = min(settings.samples, PREVIEW_SAMPLES) if preview_render else settings.samples
        if preview_render:
            PREVIEW_RENDERS.append((width, height))
        LAST["oidn"] = oidn
        args = runner.render_args(
            binary, gltf, mjson, output, preview, samples, width, height,
            settings.max_depth, settings.seed, settings.threads,
            bvh_cache=runner.bvh_cache_dir() if getattr(prefs, "cache_bvh", True) else None,
            denoise=denoise, oidn=oidn, denoise_previews=getattr(settings, "denoise_previews", False),
            denoise_quality=getattr(settings, "denoising_quality", "HIGH"),
            denoise_prefilter=getattr(settings, "denoising_prefilter", "ACCURATE"),
            crop=crop,
        )
        if crop is not None:
            # The images the binary writes are the window.
            width, height = crop[2], crop[3]
        guides = guide_passes(scene, depsgraph.view_layer)
        if guides:
            args.append("--guides")
        passes = guides + denoise_passes(scene)
        LAST["passes"] = [p[0] for p in passes]
        t_start = time.perf_counter()
        proc = runner.PrismProcess(args, cwd=tmp)
        LAST["pid"] = proc.proc.pid
        LAST["args"] = list(args)
        _log("started %s (pid %d) in %s" % (binary, proc.proc.pid, tmp))
        seen_warnings = set()
        try:
            while True:
                if self.test_break():
                    t_cancel = time.perf_counter()
                    proc.stop()
                    LAST["cancelled"] = True
                    timings["cancel"] = time.perf_counter() - t_cancel
                    _log("cancelled; process %d stopped in %.2f s" % (proc.proc.pid, timings["cancel"]))
                    return
                for ev in proc.poll(0.01):
                    kind = ev.get("event")
                    if kind == "progress":
                        frac = float(ev.get("fraction", 0.0))
                        self.update_progress(min(max(frac, 0.0), 1.0))
                        LAST["progress"].append(frac)
                        status = "Prism: %.0f%% | %.1f s" % (100.0 * frac, float(ev.get("elapsed_s", 0.0)))
                        if "active" in ev:
                            # Adaptive sampling: the share of pixels still sampling.
                            LAST["active"] = float(ev["active"])
                        if LAST.get("active") is not None:
                            status += " | %.0f%% of pixels sampling" % (100.0 * LAST["active"])
                        self.update_stats("", status)
                    elif kind == "start":
                        timings["to_start_event"] = time.perf_counter() - t_start
                        timings["prism_load"] = float(ev.get("load_s", 0.0))
                        timings["prism_build"] = float(ev.get("build_s", 0.0))
                        LAST["bvh_cache"] = (int(ev.get("bvh_cache_hits", 0)), int(ev.get("bvh_cache_misses", 0)))
                    elif kind == "preview":
                        try:
                            self._set_pixels(result, read_exr(ev["path"], width, height))
                            self.update_result(result)
                            LAST["previews"] += 1
                            self.update_stats("", "Prism: preview at %s spp" % ev.get("spp"))
                        except Exception as e:  # a preview is best effort
                            _log("preview skipped: %s" % e)
                    elif kind == "warning":
                        msg = str(ev.get("message", ""))
                        if msg.startswith("Open Image Denoise not found"):
                            # The binary looked on the system after the add-on found nothing in
                            # Blender: say so in Blender's terms.
                            msg = ("Denoise is on, but this Blender has no Open Image Denoise library "
                                   "(looked in %s); the image is not denoised"
                                   % ", ".join(_OIDN.get("dirs", [])))
                        if msg not in seen_warnings and len(seen_warnings) < 5:
                            seen_warnings.add(msg)
                            self._warn(msg)
                    elif kind == "done":
                        LAST["done"] = ev
                if proc.finished and proc.events.empty():
                    break
                if not proc.running() and proc.events.empty():
                    break
            rc = proc.wait()
            for ev in proc.poll(0.0):
                if ev.get("event") == "done":
                    LAST["done"] = ev
        finally:
            proc.stop()
        timings["process"] = time.perf_counter() - t_start
        if rc != 0:
            raise runner.RunnerError(proc.error_message(rc))
        t0 = time.perf_counter()
        if passes:
            self._set_all_passes(result, output, passes, width, height)
        else:
            self._set_pixels(result, read_exr(output, width, height))
        timings["load"] = time.perf_counter() - t0
        self.update_progress(1.0)
        done = LAST.get("done") or {}
        LAST["denoised"] = bool(done.get("denoised", False))
        if "denoise_s" in done:
            timings["denoise"] = float(done["denoise_s"])
        self.update_stats("", "Prism: done in %.2f s" % float(done.get("seconds", timings["process"])))


def register():
    bpy.utils.register_class(PrismRenderEngine)
    viewport.register()


def unregister():
    viewport.unregister()
    bpy.utils.unregister_class(PrismRenderEngine)
