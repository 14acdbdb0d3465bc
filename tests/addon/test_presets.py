"""Sampling and Light Paths presets, as Cycles has them, in real Blender (bpy wheel 5.0.1 and
`blender -b` 3.4.1): the bundled presets are installed where Blender's preset menus look, applying
one sets the scene's Prism settings, a user preset can be added (and removed) with the panels'
+/- operators, and the panels' headers draw the preset menu.

    .venv-bpy/bin/python tests/addon/test_presets.py
    blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_presets.py
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402

import common as C  # noqa: E402


def apply(preset_name, subdir):
    path = bpy.utils.preset_find(preset_name, subdir)
    C.check(path is not None and os.path.isfile(path), "preset '%s' found in %s: %s" % (preset_name, subdir, path))
    bpy.ops.script.execute_preset(filepath=path, menu_idname="PRISM_MT_%s_presets" % subdir.split("/")[1])
    return path


def test_bundled_presets_apply():
    sc = C.simple_scene()
    sc.render.engine = "PRISM"
    p = sc.prism
    names = {os.path.splitext(f)[0] for d in bpy.utils.preset_paths("prism/sampling") for f in os.listdir(d)}
    C.check({"Preview", "Default", "Final"} <= names, "sampling presets: %s" % sorted(names))
    apply("Final", "prism/sampling")
    C.check((p.samples, p.adaptive_threshold, p.adaptive_min_samples, p.use_denoising) == (8192, 0.005, 64, False)
            or (p.samples == 8192 and abs(p.adaptive_threshold - 0.005) < 1e-7 and not p.use_denoising),
            "Final: %d samples, threshold %g, min %d, denoise %s" % (p.samples, p.adaptive_threshold, p.adaptive_min_samples, p.use_denoising))
    apply("Preview", "prism/sampling")
    C.check(p.samples == 128 and abs(p.adaptive_threshold - 0.1) < 1e-7, "Preview: %d samples" % p.samples)
    names = {os.path.splitext(f)[0] for d in bpy.utils.preset_paths("prism/light_paths") for f in os.listdir(d)}
    C.check({"Direct_Light", "Default", "Full_Global_Illumination"} <= names, "light paths presets: %s" % sorted(names))
    apply("Direct_Light", "prism/light_paths")
    C.check(p.max_depth == 1, "Direct Light: max depth %d" % p.max_depth)
    apply("Full_Global_Illumination", "prism/light_paths")
    C.check(p.max_depth == 128 and p.clamp_indirect == 0.0, "Full GI: max depth %d" % p.max_depth)


def test_user_preset_add_and_remove():
    sc = C.simple_scene()
    sc.render.engine = "PRISM"
    p = sc.prism
    p.max_depth, p.clamp_direct, p.clamp_indirect = 7, 2.5, 1.25
    bpy.ops.render.prism_light_paths_preset_add(name="My Paths")
    path = bpy.utils.preset_find("My_Paths", "prism/light_paths")
    C.check(path is not None, "user preset written: %s" % path)
    p.max_depth, p.clamp_direct, p.clamp_indirect = 3, 0.0, 0.0
    apply("My_Paths", "prism/light_paths")
    C.check((p.max_depth, p.clamp_direct, p.clamp_indirect) == (7, 2.5, 1.25),
            "the user preset restores %s" % ((p.max_depth, p.clamp_direct, p.clamp_indirect),))
    bpy.types.PRISM_MT_light_paths_presets.bl_label = "My Paths"  # what Blender sets after applying
    bpy.ops.render.prism_light_paths_preset_add(name="My Paths", remove_active=True)
    C.check(bpy.utils.preset_find("My_Paths", "prism/light_paths") is None, "user preset removed")


def test_panel_headers_draw_the_menus():
    """The Sampling and Light Paths panels define draw_header_preset and it draws the menus."""
    drawn = []

    class Layout:
        def row(self, *a, **k):
            return self

        def menu(self, name, *a, **k):
            drawn.append(name)

        def operator(self, idname, *a, **k):
            drawn.append(idname)

            class Props:
                pass
            return Props()

        def popover(self, panel=None, *a, **k):
            drawn.append(panel)

        def __getattr__(self, name):
            return lambda *a, **k: self

    for panel in (bpy.types.RENDER_PT_prism_sampling, bpy.types.RENDER_PT_prism_light_paths):
        fake = type("P", (), {"layout": Layout()})()
        panel.draw_header_preset(fake, bpy.context)
    text = " ".join(str(d) for d in drawn)
    C.check("sampling" in text.lower() and "light_paths" in text.lower(), "headers draw: %s" % drawn)


if __name__ == "__main__":
    from runner_util import run_tests

    C.enable_addon()
    run_tests("preset tests", globals())
