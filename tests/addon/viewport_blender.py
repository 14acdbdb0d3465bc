"""Runs inside an interactive Blender (a window, under Xvfb in the tests): the factory startup
scene with Prism as the engine, a 3D viewport switched to Rendered shading through the camera,
as a user would. Steps, each waiting for the viewport's renderer to finish its view:

1. Rendered shading: a screenshot of the viewport, and an F12 render of the same camera.
2. The camera moved through the Python API: a screenshot and an F12 render again.
3. The cube's material made blue: a screenshot.
4. Solid shading: the renderer process must end. Rendered again, then the engine switched to
   EEVEE: that process must end; Prism again, then File > New (the file is closed): that
   process must end too.

The viewport's overlays, gizmos, header and side regions are off, so the screenshot of the area
is the rendered image; the view transform is Standard, so pixels are sRGB-encoded values of the
scene-linear image, comparable with the EXR of the F12 render.

Output: $PRISM_VIEWPORT_REPORT (JSON) and PNG/EXR files in $PRISM_VIEWPORT_OUT.
"""

import json
import os
import time
import traceback

import addon_utils
import bpy
from bpy_extras.view3d_utils import location_3d_to_region_2d

REPORT = os.environ["PRISM_VIEWPORT_REPORT"]
OUT = os.environ["PRISM_VIEWPORT_OUT"]
report = {"errors": [], "steps": {}}
state = {"step": "start", "t": time.time(), "t0": time.time()}


def finish():
    with open(REPORT, "w") as f:
        json.dump(report, f, indent=1)
    bpy.ops.wm.quit_blender()


def view3d():
    win = bpy.context.window_manager.windows[0]
    area = max((a for a in win.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    return win, area, region


def setup():
    addon_utils.enable("prism", default_set=True)
    sc = bpy.context.scene
    sc.render.engine = "PRISM"
    sc.render.resolution_x, sc.render.resolution_y = 160, 120
    sc.render.resolution_percentage = 100
    sc.prism.samples = 32
    sc.prism.preview_samples = 32
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    win, area, region = view3d()
    space = area.spaces.active
    space.overlay.show_overlays = False
    space.show_gizmo = False
    space.show_region_header = False
    space.show_region_toolbar = False
    space.show_region_ui = False
    if hasattr(space, "show_region_tool_header"):
        space.show_region_tool_header = False
    space.region_3d.view_perspective = "CAMERA"
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.ops.view3d.view_center_camera()
    space.shading.type = "RENDERED"
    report["engines"] = [e.bl_idname for e in bpy.types.RenderEngine.__subclasses__()]
    # The Material tab: its slot list draws the material's icon, which Blender renders with
    # the engine's preview render (bl_use_preview) in a background job.
    props = next(a for a in win.screen.areas if a.type == "PROPERTIES")
    bpy.context.view_layer.objects.active = bpy.data.objects["Cube"]
    props.spaces.active.context = "MATERIAL"


def camera_rect(region, rv3d):
    """The camera frame's pixel box in the region: (x0, y0, x1, y1), y from the bottom."""
    sc = bpy.context.scene
    cam = sc.camera
    pts = [location_3d_to_region_2d(region, rv3d, cam.matrix_world @ v) for v in cam.data.view_frame(scene=sc)]
    xs, ys = [p.x for p in pts], [p.y for p in pts]
    return [min(xs), min(ys), max(xs), max(ys)]


def viewport_stats():
    from prism import viewport

    return dict(viewport.STATS), [s.client for s in viewport.SESSIONS]


def finished():
    _stats, clients = viewport_stats()
    return bool(clients) and clients[-1].finished() and clients[-1].frame is not None and clients[-1].frame.spp >= 32


def shoot(name):
    win, area, region = view3d()
    path = os.path.join(OUT, name + ".png")
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.screen.screenshot_area(filepath=path)
    stats, clients = viewport_stats()
    report["steps"][name] = {
        "png": path,
        "area": [area.width, area.height],
        "region": [region.width, region.height],
        "camera_rect": camera_rect(region, area.spaces.active.region_3d),
        "seconds": time.time() - state["t"],
        "frame": stats.get("last_frame"),
        "stats": {k: v for k, v in stats.items() if k != "last_frame"},
        "latency": dict(state.get("latency", {})),
    }


def f12(name):
    bpy.ops.render.render()
    img = bpy.data.images["Render Result"]
    path = os.path.join(OUT, name + ".exr")
    sc = bpy.context.scene
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    img.save_render(path, scene=sc)
    report["steps"].setdefault(name, {})["exr"] = path


def pid_alive(pid):
    try:
        with open("/proc/%d/stat" % pid) as f:
            return f.read().split()[2] != "Z"
    except OSError:
        return False


def next_step(name):
    state["step"] = name
    state["t"] = time.time()
    state["latency"] = {}


def note_first_frame():
    """Time from the step's edit to the first frame of the new view being drawn."""
    stats, _ = viewport_stats()
    fr = stats.get("last_frame")
    if fr and "first_frame" not in state["latency"] and fr.get("generation", -1) > state.get("generation", -1):
        state["latency"]["first_frame"] = time.time() - state["t"]


def tick():
    try:
        if time.time() - state["t0"] > 150:
            report["errors"].append("timed out in step %s" % state["step"])
            return finish()
        step = state["step"]
        if step in ("solid", "again"):
            return None
        if step == "start":
            setup()
            next_step("rendered")
            return 0.2
        note_first_frame()
        if not finished():
            if time.time() - state["t"] > 60:
                report["errors"].append("step %s: the viewport did not finish in 60 s" % step)
                return finish()
            return 0.1
        stats, clients = viewport_stats()
        state["generation"] = clients[-1].frame.generation
        if step == "rendered":
            from prism import engine

            pv = bpy.data.objects["Cube"].active_material.preview
            icon = list(pv.icon_pixels_float[:]) if pv is not None else []
            report["preview_renders"] = list(engine.PREVIEW_RENDERS)
            report["icon_size"] = list(pv.icon_size) if pv is not None else None
            report["icon_mean"] = sum(icon) / len(icon) if icon else None
            shoot("rendered")
            report["pid"] = stats["pid"]
            f12("rendered")
            cam = bpy.context.scene.camera
            cam.location.x += 0.6
            cam.location.z -= 0.4
            next_step("camera_moved")
            return 0.1
        if step == "camera_moved":
            shoot("camera_moved")
            f12("camera_moved")
            mat = bpy.data.objects["Cube"].active_material
            mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.05, 0.1, 0.8, 1.0)
            next_step("material_blue")
            return 0.1
        if step == "material_blue":
            shoot("material_blue")
            f12("material_blue")
            win, area, region = view3d()
            area.spaces.active.shading.type = "SOLID"
            # Blender frees the engine on a later redraw: tick_solid waits for the process.
            next_step("solid")
            return None
        return finish()
    except Exception:
        report["errors"].append(traceback.format_exc())
        return finish()


def tick_solid():
    """After Solid shading: the process must be gone; then Rendered again and File > New."""
    try:
        if state["step"] != "solid":
            return 0.2
        pid = report["pid"]
        if pid_alive(pid) and time.time() - state["t"] < 10:
            return 0.2
        report["solid_process_alive"] = pid_alive(pid)
        report["solid_seconds"] = time.time() - state["t"]
        win, area, region = view3d()
        area.spaces.active.shading.type = "RENDERED"
        state["step"] = "again"
        state["t"] = time.time()
        return None
    except Exception:
        report["errors"].append(traceback.format_exc())
        return None


def tick_again():
    """Rendered again: a new process; switching the engine to EEVEE must end it."""
    try:
        if state["step"] != "again":
            return 0.2
        stats, clients = viewport_stats()
        if not clients or clients[-1].frame is None:
            if time.time() - state["t"] > 30:
                report["errors"].append("Rendered again: no frame in 30 s")
                finish()
                return None
            return 0.2
        report["second_pid"] = stats["pid"]
        bpy.context.scene.render.engine = "BLENDER_EEVEE"
        state["step"] = "engine_switched"
        state["t"] = time.time()
        bpy.app.timers.register(tick_engine_switched, first_interval=0.2)
        return None
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()
        return None


def tick_engine_switched():
    """After the switch to EEVEE: the process must be gone; then Prism again, and File > New."""
    try:
        pid = report["second_pid"]
        if state["step"] == "engine_switched":
            if pid_alive(pid) and time.time() - state["t"] < 10:
                return 0.2
            report["engine_switch_process_alive"] = pid_alive(pid)
            report["engine_switch_seconds"] = time.time() - state["t"]
            bpy.context.scene.render.engine = "PRISM"
            state["step"] = "third"
            state["t"] = time.time()
            return 0.2
        stats, clients = viewport_stats()
        if not clients or clients[-1].frame is None or stats["pid"] == pid:
            if time.time() - state["t"] > 30:
                report["errors"].append("Prism again after EEVEE: no frame in 30 s")
                finish()
                return None
            return 0.2
        report["third_pid"] = stats["pid"]
        bpy.ops.wm.read_homefile(app_template="")
        state["step"] = "new_file"
        state["t"] = time.time()
        bpy.app.timers.register(tick_new_file, first_interval=0.2)
        return None
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()
        return None


def tick_new_file():
    """After File > New: the third process must be gone (the load_pre handler ends it)."""
    pid = report["third_pid"]
    if pid_alive(pid) and time.time() - state["t"] < 10:
        return 0.2
    report["new_file_process_alive"] = pid_alive(pid)
    report["new_file_seconds"] = time.time() - state["t"]
    finish()
    return None


bpy.app.timers.register(tick, first_interval=1.0)
bpy.app.timers.register(tick_solid, first_interval=1.0)
bpy.app.timers.register(tick_again, first_interval=1.0)
