"""Runs inside an interactive Blender (a window, under Xvfb in the tests): the factory startup
scene (cube, point light, camera, grey world), Prism picked as the engine, F12 as a user
would press it (render.render INVOKE_DEFAULT: the render window with its image editor and the
live preview), then the Render Result saved for the driver (test_interactive.py) to check.

Output: the JSON report at $PRISM_INTERACTIVE_REPORT and the EXR at $PRISM_INTERACTIVE_EXR.
"""

import json
import os
import time

import addon_utils
import bpy

REPORT = os.environ["PRISM_INTERACTIVE_REPORT"]
EXR = os.environ["PRISM_INTERACTIVE_EXR"]
report = {"errors": []}


def finish():
    with open(REPORT, "w") as f:
        json.dump(report, f)
    bpy.ops.wm.quit_blender()


def setup():
    addon_utils.enable("prism", default_set=True)
    sc = bpy.context.scene
    report["engines"] = [e.bl_idname for e in bpy.types.RenderEngine.__subclasses__()]
    sc.render.engine = "PRISM"
    sc.render.resolution_x, sc.render.resolution_y = 80, 60
    sc.render.resolution_percentage = 100
    sc.prism.samples = 32
    # The add-on's panels (shown in the Properties editor while Prism is the engine).
    report["prism_panels"] = sorted(
        p.__name__ for p in bpy.types.Panel.__subclasses__() if p.__module__.startswith("prism")
    )
    bpy.app.handlers.render_complete.append(lambda *a: state.update(complete=True))
    bpy.app.handlers.render_cancel.append(lambda *a: state.update(cancelled=True))


state = {"invoked": False, "t0": time.time(), "complete": False, "cancelled": False}
try:
    setup()
except Exception as e:  # report and quit: a failing setup must not leave a window open
    report["errors"].append(repr(e))
    bpy.app.timers.register(finish, first_interval=0.5)
    raise


def tick():
    try:
        if not state["invoked"]:
            state["invoked"] = True
            win = bpy.context.window_manager.windows[0]
            with bpy.context.temp_override(window=win):
                report["invoke"] = sorted(bpy.ops.render.render("INVOKE_DEFAULT"))
            return 0.1
        if not (state["complete"] or state["cancelled"]) and time.time() - state["t0"] < 90:
            return 0.1
        report["complete"] = state["complete"]
        report["cancelled"] = state["cancelled"]
        report["seconds"] = time.time() - state["t0"]
        report["areas"] = sorted(
            a.type for w in bpy.context.window_manager.windows for a in w.screen.areas
        )
        shown = [
            a.spaces.active.image.name
            for w in bpy.context.window_manager.windows
            for a in w.screen.areas
            if a.type == "IMAGE_EDITOR" and a.spaces.active.image is not None
        ]
        report["image_editor_shows"] = shown
        img = bpy.data.images.get("Render Result")
        if img is not None:
            sc = bpy.context.scene
            sc.render.image_settings.file_format = "OPEN_EXR"
            img.save_render(EXR, scene=sc)
    except Exception as e:  # report, never hang the window
        report["errors"].append(repr(e))
    finish()
    return None


bpy.app.timers.register(tick, first_interval=1.0)
