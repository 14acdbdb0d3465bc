"""Runs inside an interactive Blender (a window, under Xvfb in the tests): the factory startup
scene with Prism as the engine; the Properties editor is switched to the Light, World, Material
and Render tabs in turn and Blender redraws it. Every Properties panel's draw() is wrapped so
that the real drawing goes through a forwarding layout which notes each prop()'s label and each
template_*() call: what Blender itself chose to draw (its poll, COMPAT_ENGINES, open/closed
state) and the labels the user sees. A screenshot of the editor is saved per tab.

Output: $PRISM_PANELS_REPORT (JSON) and $PRISM_PANELS_OUT/<tab>.png.
"""

import json
import os
import traceback

import addon_utils
import blf
import bpy

REPORT = os.environ["PRISM_PANELS_REPORT"]
OUT = os.environ["PRISM_PANELS_OUT"]
report = {"errors": [], "tabs": {}}
current = {"tab": None}


class Forward:
    """A UILayout that forwards every call to Blender's and notes prop labels and templates."""

    def __init__(self, real, notes):
        object.__setattr__(self, "_real", real)
        object.__setattr__(self, "_notes", notes)

    def __setattr__(self, name, value):
        setattr(self._real, name, value)

    def __getattr__(self, name):
        v = getattr(self._real, name)
        if not callable(v):
            return v

        def call(*args, **kw):
            if name == "prop" and len(args) >= 2:
                rna = args[0].bl_rna.properties.get(args[1])
                self._notes.append(["prop", args[1], kw.get("text", rna.name if rna else ""), rna.type if rna else ""])
            elif name.startswith("template_"):
                self._notes.append([name, str(args[1]) if len(args) > 1 and isinstance(args[1], str) else ""])
            r = v(*args, **kw)
            if isinstance(r, bpy.types.UILayout):
                return Forward(r, self._notes)
            if isinstance(r, tuple):  # layout.panel(): (header, body)
                return tuple(Forward(x, self._notes) if isinstance(x, bpy.types.UILayout) else x for x in r)
            return r

        return call


class PanelSelf:
    def __init__(self, real, notes):
        object.__setattr__(self, "_real", real)
        object.__setattr__(self, "layout", Forward(real.layout, notes))

    def __getattr__(self, name):
        return getattr(self._real, name)


def wrap(cls):
    orig = cls.draw

    def draw(self, context):
        tab = current["tab"]
        if tab is None:
            return orig(self, context)
        notes = report["tabs"].setdefault(tab, {}).setdefault(cls.__name__, [])
        del notes[:]
        orig(PanelSelf(self, notes), context)

    cls.draw = draw


def properties_area():
    win = bpy.context.window_manager.windows[0]
    return win, next(a for a in win.screen.areas if a.type == "PROPERTIES")


def setup():
    addon_utils.enable("prism", default_set=True)
    sc = bpy.context.scene
    sc.render.engine = "PRISM"
    seen, todo = set(), list(bpy.types.Panel.__subclasses__())
    while todo:
        c = todo.pop()
        if c in seen:
            continue
        seen.add(c)
        todo.extend(c.__subclasses__())
        if getattr(c, "bl_space_type", "") == "PROPERTIES" and "draw" in c.__dict__ and getattr(c, "is_registered", False):
            wrap(c)
    ps = bpy.context.preferences.system
    blf.size(0, 11)  # the UI's text size in points, before the UI scale
    report["label_px"] = {}
    report["ui_scale"] = ps.ui_scale


# (tab, object made active, Properties context)
STEPS = [("light", "Light", "DATA"), ("world", "Cube", "WORLD"), ("material", "Cube", "MATERIAL"), ("render", "Cube", "RENDER")]
state = {"step": -1, "shot": False}


def tick():
    try:
        win, area = properties_area()
        if state["step"] >= 0 and not state["shot"]:
            # The editor has redrawn with this tab: keep its picture.
            tab = STEPS[state["step"]][0]
            with bpy.context.temp_override(window=win, area=area):
                bpy.ops.screen.screenshot_area(filepath=os.path.join(OUT, tab + ".png"))
            state["shot"] = True
        state["step"] += 1
        if state["step"] >= len(STEPS):
            report["region_width"] = next(r.width for r in area.regions if r.type == "WINDOW")
            for notes in report["tabs"].get("render", {}).values():
                for n in notes:
                    if n[0] == "prop" and n[2] and n[3] != "BOOLEAN":  # a checkbox's label is right of it
                        report["label_px"][n[2]] = blf.dimensions(0, n[2])[0] * report["ui_scale"]
            for t in ("Noise Threshold", "Wavelength Density"):
                report["label_px"][t] = blf.dimensions(0, t)[0] * report["ui_scale"]
            return finish()
        tab, ob_name, ctx = STEPS[state["step"]]
        current["tab"] = tab
        bpy.context.view_layer.objects.active = bpy.data.objects[ob_name]
        area.spaces.active.context = ctx
        area.tag_redraw()
        state["shot"] = False
        return 0.5
    except Exception:
        report["errors"].append(traceback.format_exc())
        return finish()


def finish():
    with open(REPORT, "w") as f:
        json.dump(report, f)
    bpy.ops.wm.quit_blender()
    return None


try:
    setup()
except Exception:
    report["errors"].append(traceback.format_exc())
    bpy.app.timers.register(finish, first_interval=0.5)
    raise
bpy.app.timers.register(tick, first_interval=1.0)
