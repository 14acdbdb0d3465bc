# SPDX-License-Identifier: MIT
"""The rendered viewport: one `prism serve` process per 3D viewport in Rendered shading.

The scene is exported and loaded once; each depsgraph update then sends only what changed
(`sync`): object moves as `transform` (the renderer rebuilds the top of its BVH), material,
light and world edits as a shading-only export (`shading`), and mesh edits, added or removed
objects as a new `load` (the BVH cache rebuilds only the meshes that changed). The view
(`view_draw`: the region's view and projection matrices and size) is sent whenever it
changes. Frames arrive on the client's reader thread; `draw` uploads the newest one to a
texture and draws it in scene-linear colour, which Blender's viewport then colour-manages as
it does Cycles' (view transform, look, exposure).
"""

import math
import os
import shutil
import sys
import tempfile
import time

import bpy
import numpy as np
from mathutils import Matrix

from . import export, runner
from .serve_client import ServeClient, ServeError

# Blender's Z-up world -> the glTF Y-up world the exporter writes (its root node).
Z_UP_TO_Y_UP = Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))
MESH_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META", "CURVES"}
SHADING_TYPES = tuple(
    getattr(bpy.types, n) for n in ("Material", "World", "Light", "NodeTree", "Image", "Texture") if hasattr(bpy.types, n)
)
GEOMETRY_TYPES = tuple(getattr(bpy.types, n) for n in ("Mesh", "Curve", "MetaBall", "TextCurve") if hasattr(bpy.types, n))

# Live sessions (tests read them; `close_all` ends them when a file is loaded or Blender exits).
SESSIONS = []
# What the newest session did, for the add-on tests.
STATS = {}


def _log(msg):
    print("Prism viewport: " + msg, file=sys.stderr, flush=True)


def pixel_size(context, scene):
    """Blender's Performance > Viewport > Pixel Size (AUTO: the interface's pixel size)."""
    v = getattr(scene.render, "preview_pixel_size", "AUTO")
    if v == "AUTO":
        return max(1, int(round(getattr(context.preferences.system, "pixel_size", 1.0))))
    return max(1, int(v))


def view_camera(rv3d, clip_end=1000.0):
    """The `view` command's camera for a 3D viewport's region: its view matrix (camera to world,
    in the exporter's Y-up world) and its projection (perspective: vertical field of view and
    the window's off-centre shift; orthographic: half height), taken from the region's own
    matrices, so a camera view with its zoom and offset, lens shift, and any viewport lens all
    come out as Blender draws them."""
    to_world = Z_UP_TO_Y_UP @ export._unscaled(rv3d.view_matrix.inverted())
    p = rv3d.window_matrix
    if rv3d.is_perspective:
        # x_ndc = (p00 x + p02 z) / -z: the window's centre at distance 1 is (p02/p00, p12/p11);
        # the renderer's shift is in units of the view's height, 2/p11.
        cam = {
            "yfov": 2.0 * math.atan(1.0 / p[1][1]),
            "shift": [p[0][2] * p[1][1] / (2.0 * p[0][0]), 0.5 * p[1][2]],
        }
    else:
        # x_ndc = p00 x + p03: the centre is at -p03/p00. The view origin of an orthographic
        # viewport sits among the objects (Blender clips from -clip_end/2): rays start behind it.
        to_world = to_world @ Matrix.Translation((0.0, 0.0, 0.5 * clip_end))
        cam = {
            "ortho_half_height": 1.0 / p[1][1],
            "shift": [-p[0][3] * p[1][1] / (2.0 * p[0][0]), -0.5 * p[1][3]],
        }
    cam["to_world"] = export._matrix(to_world)
    return cam


def _has_particle_hair(ob):
    """Its hair is exported in world space: moving the emitter needs a new export."""
    return any(ps.settings.type == "HAIR" for ps in getattr(ob, "particle_systems", ()))


def _slot_materials(ob):
    return tuple(s.material.name if s.material is not None else "" for s in ob.material_slots)


def _object_names(depsgraph):
    """The objects the export sees (instances included), to notice added, removed and hidden
    ones."""
    names = []
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type in MESH_TYPES or ob.type == "LIGHT":
            names.append((ob.name, bool(inst.is_instance)))
    names.sort()
    return names


class ViewportSession:
    def __init__(self, engine, context, depsgraph):
        from .engine import addon_preferences

        prefs = addon_preferences()
        self.binary = runner.find_binary(prefs.binary_path if prefs is not None else "")
        self.tmp = tempfile.mkdtemp(prefix="prism_view_")
        scene = depsgraph.scene_eval
        threads = int(getattr(scene.prism, "threads", 0)) or None
        cache = runner.bvh_cache_dir() if getattr(prefs, "cache_bvh", True) else None
        self.client = ServeClient(self.binary, threads=threads, bvh_cache=cache)
        self.warned = set()
        self.events_seen = 0
        self.view = None
        self.settings = None
        self.texture = None
        self.drawn = None
        self.exports = 0
        self.pending_dirs = []
        self.node_names = {}
        self.names = []
        self.t_edit = time.monotonic()
        self.scene_name = depsgraph.scene.name
        self.closed = False
        SESSIONS.append(self)
        STATS.clear()
        STATS.update(loads=0, shadings=0, transforms=0, views=0, frames_drawn=0, pid=self.client.proc.pid)
        self.send_settings(engine, context, scene)
        self._load(engine, depsgraph)

    # -- sync
    def _export(self, engine, depsgraph, shading_only):
        self.exports += 1
        d = os.path.join(self.tmp, "export%d" % self.exports)
        os.makedirs(d)
        scene = depsgraph.scene_eval
        w, h = export.render_size(scene)
        ex = export.Exporter(depsgraph, d, "scene", w, h, viewport=True, shading_only=shading_only)
        gltf, mjson = ex.run(export.render_settings(scene))
        for msg in ex.warnings:
            self._warn(engine, msg)
        self.pending_dirs.append(d)
        return ex, gltf, mjson

    def _load(self, engine, depsgraph):
        ex, gltf, mjson = self._export(engine, depsgraph, shading_only=False)
        self.node_names = ex.node_names
        self.names = _object_names(depsgraph)
        # Which materials each object draws with: a shading update cannot change that.
        self.slots = {ob.name: _slot_materials(ob) for ob in depsgraph.objects if ob.type in MESH_TYPES}
        self.client.send("load", scene=gltf, materials=mjson)
        STATS["loads"] += 1

    def send_settings(self, engine, context, scene):
        """Sends the viewport settings (Render > Prism > Viewport, Pixel Size) if they changed."""
        p = scene.prism
        s = {
            "samples": int(getattr(p, "preview_samples", 1024)),
            "max_depth": int(p.max_depth),
            "pixel_size": pixel_size(context, scene),
            "start_resolution": int(getattr(p, "preview_start_resolution", 64)),
            "denoise": bool(getattr(p, "use_preview_denoising", False)),
            "denoise_start_sample": int(getattr(p, "preview_denoising_start_sample", 1)),
        }
        if s["denoise"]:
            from .engine import blender_oidn

            oidn = blender_oidn()
            if oidn is None:
                # The renderer would look on the system; say where the add-on looked.
                self._warn(engine, "Viewport Denoise is on, but this Blender has no Open Image Denoise library; "
                                   "the viewport is not denoised")
                s["denoise"] = False
            else:
                s["oidn"] = oidn
        if s != self.settings:
            self.settings = s
            self.client.send("settings", **s)

    def sync(self, engine, context, depsgraph):
        """Sends what the depsgraph's updates changed."""
        self.t_edit = time.monotonic()
        reload = shading = False
        moves = {}
        for u in depsgraph.updates:
            idb = u.id
            if isinstance(idb, bpy.types.Object):
                ob = idb
                if ob.type in MESH_TYPES:
                    if (u.is_updated_geometry or _slot_materials(ob) != self.slots.get(ob.name)
                            or (u.is_updated_transform and _has_particle_hair(ob))):
                        reload = True  # new mesh data, other materials assigned, or moved hair
                    elif u.is_updated_transform:
                        moves[ob.name] = ob.matrix_world.copy()
                elif ob.type == "LIGHT":
                    # Punctual lights are part of the shading export; an area light is also a
                    # mesh that moves (its scale, and with it its radiance, are shading).
                    shading = True
                    if ob.data.type == "AREA" and u.is_updated_transform:
                        moves[ob.name] = ob.matrix_world.copy()
                elif ob.type == "EMPTY" and ob.instance_type != "NONE" and u.is_updated_transform:
                    reload = True  # a collection instance: its objects are not depsgraph objects
            elif isinstance(idb, bpy.types.Light) and idb.type == "AREA":
                reload = True  # its size and shape are the mesh the renderer holds for it
            elif isinstance(idb, SHADING_TYPES):
                shading = True
            elif isinstance(idb, GEOMETRY_TYPES) and u.is_updated_geometry:
                reload = True
        scene = depsgraph.scene_eval
        self.send_settings(engine, context, scene)
        # Objects added, removed, shown or hidden come with an update of their collection or
        # scene (or as an object not seen before): only then list the instances, which can be
        # many (particle instances).
        membership = any(
            isinstance(u.id, (bpy.types.Scene, bpy.types.Collection))
            or (isinstance(u.id, bpy.types.Object) and u.id.name not in self.slots and u.id.type in MESH_TYPES)
            for u in depsgraph.updates
        )
        if membership and _object_names(depsgraph) != self.names:
            reload = True
        if any(self.node_names.get(n) != 1 for n in moves):
            reload = True  # instanced (several nodes of that name): only a reload places them all
        if reload:
            self._load(engine, depsgraph)
            return
        if shading:
            _ex, gltf, mjson = self._export(engine, depsgraph, shading_only=True)
            self.client.send("shading", scene=gltf, materials=mjson)
            STATS["shadings"] += 1
        if moves:
            objects = [{"name": n, "matrix": export._matrix(Z_UP_TO_Y_UP @ m)} for n, m in sorted(moves.items())]
            self.client.send("transform", objects=objects)
            STATS["transforms"] += 1

    def _warn(self, engine, msg):
        if msg in self.warned:
            return
        self.warned.add(msg)
        _log("warning: " + msg)
        engine.report({"WARNING"}, "Prism: " + msg)

    def _poll(self, engine):
        """Reports the renderer's new errors and warnings, and removes the export folders it
        has answered for (each load / shading command gets one answer, in order). Only the
        events since the last call are looked at: a long session has many."""
        with self.client.lock:
            events = self.client.events[self.events_seen:]
            self.events_seen += len(events)
        for e in events:
            kind = e.get("event")
            if kind in ("loaded", "ok", "error") and e.get("cmd", "load") in ("load", "shading"):
                if self.pending_dirs:
                    shutil.rmtree(self.pending_dirs.pop(0), ignore_errors=True)
            if kind == "error":
                _log("error: %s" % e.get("message"))
                engine.report({"ERROR"}, "Prism: %s" % e.get("message"))
            elif kind == "loaded":
                for w in e.get("warnings", []):
                    self._warn(engine, w)

    # -- draw
    def draw(self, engine, context, depsgraph):
        import gpu
        from gpu_extras.presets import draw_texture_2d

        region, rv3d = context.region, context.region_data
        scene = depsgraph.scene_eval
        clip_end = getattr(context.space_data, "clip_end", 1000.0)
        view = {"width": int(region.width), "height": int(region.height), "camera": view_camera(rv3d, clip_end)}
        cam = scene.camera
        if rv3d.view_perspective == "CAMERA" and cam is not None and getattr(cam.data, "dof", None) is not None \
                and cam.data.dof.use_dof:
            self._warn(engine, "camera '%s': depth of field is not shown in the viewport (F12 renders it)" % cam.name)
        if view != self.view:
            self.view = view
            self.client.send("view", **view)
            STATS["views"] += 1
        # A changed add-on property does not always reach view_update (no depsgraph update),
        # but the viewport redraws: compare here too.
        self.send_settings(engine, context, scene)
        self._poll(engine)
        if not self.client.alive():
            engine.report({"ERROR"}, "Prism: the viewport renderer stopped: %s" % " | ".join(self.client.stderr_tail[-2:]))
            return
        fr = self.client.frame
        if fr is not None and fr is not self.drawn:
            data = np.ascontiguousarray(fr.pixels, dtype=np.float32).reshape(-1)
            buf = gpu.types.Buffer("FLOAT", data.size, data)
            self.texture = gpu.types.GPUTexture((fr.width, fr.height), format="RGBA16F", data=buf)
            self.drawn = fr
            STATS["frames_drawn"] += 1
            STATS["last_frame"] = {"generation": fr.generation, "spp": fr.spp, "width": fr.width, "height": fr.height,
                                   "since_edit": time.monotonic() - self.t_edit}
        if self.texture is not None:
            gpu.state.blend_set("ALPHA_PREMULT")
            engine.bind_display_space_shader(scene)
            draw_texture_2d(self.texture, (0, 0), region.width, region.height)
            engine.unbind_display_space_shader()
            gpu.state.blend_set("NONE")
        if self.drawn is not None:
            engine.update_stats("", "Prism: %s" % ("%d samples" % self.drawn.spp if self.drawn.spp else "preview"))
        # Frames arrive on another thread: keep drawing until this view's render is done.
        if not self.client.finished():
            engine.tag_redraw()

    def close(self):
        self.closed = True
        try:
            self.client.close()
        finally:
            shutil.rmtree(self.tmp, ignore_errors=True)
            if self in SESSIONS:
                SESSIONS.remove(self)


def close_all(*_args):
    for s in list(SESSIONS):
        try:
            s.close()
        except Exception as e:  # closing must go on for the others
            _log("closing a session: %s" % e)


@bpy.app.handlers.persistent
def _on_load_pre(*_args):
    close_all()


@bpy.app.handlers.persistent
def _on_depsgraph_update(*_args):
    """Another engine picked (or the scene gone): end that scene's sessions now. Blender frees
    the engine, and with it the session, only on a later redraw (seconds later when EEVEE
    compiles its shaders first)."""
    for s in list(SESSIONS):
        sc = bpy.data.scenes.get(s.scene_name)
        if sc is None or sc.render.engine != "PRISM":
            s.close()


def register():
    if _on_load_pre not in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.append(_on_load_pre)
    if _on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    import atexit

    atexit.register(close_all)


def unregister():
    if _on_load_pre in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_on_load_pre)
    if _on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    close_all()
