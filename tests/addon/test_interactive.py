"""The interactive path: Debian's blender (3.4) with a window, under Xvfb.

    .venv-bpy/bin/python tests/addon/test_interactive.py
Starts `xvfb-run blender --factory-startup -P interactive_blender.py` (BLENDER_USER_SCRIPTS must
point at a folder with addons/prism, as run_addon_tests.sh sets up), which picks Prism in the
engine list and presses F12 on the factory scene; then checks what the user would see: Prism in
the engine list, its panels, the render window's image editor showing the Render Result, and
the pixels (the lit cube brighter than the grey world around it).
"""

import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
BLENDER = os.environ.get("BLENDER", "blender")


def check(cond, msg):
    if not cond:
        raise AssertionError(msg)
    print("  ok: " + msg, flush=True)


def test_interactive_f12_render():
    out = tempfile.mkdtemp(prefix="prism_interactive_")
    report_path = os.path.join(out, "report.json")
    exr_path = os.path.join(out, "render.exr")
    env = dict(os.environ, PRISM_INTERACTIVE_REPORT=report_path, PRISM_INTERACTIVE_EXR=exr_path)
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24",
           BLENDER, "--factory-startup", "-P", os.path.join(HERE, "interactive_blender.py")]
    try:
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=150)
    except subprocess.TimeoutExpired as e:
        raise AssertionError("interactive Blender did not finish in 150 s: %s" % (e.stderr or b"")[-600:])
    log = p.stdout + p.stderr
    check(os.path.exists(report_path), "the interactive session wrote its report (log tail: %s)" % log[-400:])
    with open(report_path) as f:
        report = json.load(f)
    print("  report:", report, flush=True)
    check(not report["errors"], "no Python errors in the session: %s" % report["errors"])
    check("PRISM" in report["engines"], "Prism is in the render-engine list")
    check(len(report["prism_panels"]) >= 2, "Prism panels registered: %s" % report["prism_panels"])
    check(report["invoke"] == ["RUNNING_MODAL"], "F12 (render.render INVOKE_DEFAULT) runs as a modal job")
    check(report["complete"] and not report["cancelled"], "the render completed in %.1f s" % report["seconds"])
    check("Prism: error" not in log, "no Prism error reported")
    check("Render Result" in report["image_editor_shows"], "the image editor shows the Render Result")
    import common  # bpy wheel: EXR reader

    px = common.read_exr(exr_path)
    check(px.shape[:2] == (60, 80), "80x60 result, got %s" % (px.shape,))
    import numpy as np

    rgb = px[..., :3]
    check(np.isfinite(rgb).all(), "finite pixels")
    centre = rgb[25:35, 35:45].mean()
    corner = rgb[:6, :6].mean()
    # Factory scene: grey world 0.05, a 1000 W point light on the grey cube.
    check(abs(corner - 0.05) < 0.01, "corner shows the grey world (%.4f vs 0.05)" % corner)
    check(centre > 2.0 * corner, "the lit cube is brighter than the world (%.3f vs %.3f)" % (centre, corner))


def test_properties_editor_panels():
    """Blender 3.4 with a window (1920x1080, the factory layout): the Properties editor's Light,
    World, Material and Render tabs with Prism as Blender itself draws them (panels_ui_blender.py
    notes what each panel's real draw() puts in the layout) and a screenshot of each."""
    out = tempfile.mkdtemp(prefix="prism_interactive_")
    report_path = os.path.join(out, "panels.json")
    env = dict(os.environ, PRISM_PANELS_REPORT=report_path, PRISM_PANELS_OUT=out)
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1920x1080x24",
           BLENDER, "--factory-startup", "-P", os.path.join(HERE, "panels_ui_blender.py")]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    if not os.path.exists(report_path) and "Segmentation fault" in p.stdout + p.stderr:
        # Debian's Blender 3.4.1 on Xvfb's software GL segfaulted here once in a fresh-clone run
        # (2026-12-07) and passed on every rerun: one retry, reported; a second crash fails.
        print("  note: Blender segfaulted drawing the panels; one retry")
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    check(os.path.exists(report_path), "the session wrote its report (log tail: %s)" % (p.stdout + p.stderr)[-400:])
    with open(report_path) as f:
        report = json.load(f)
    check(not report["errors"], "no Python errors in the session: %s" % report["errors"])
    tabs = report["tabs"]

    def labels(tab, panel):
        return [n[2] for n in tabs.get(tab, {}).get(panel, []) if n[0] == "prop"]

    def templates(tab, panel):
        return [n[0] for n in tabs.get(tab, {}).get(panel, []) if n[0].startswith("template_")]

    print("  drawn:", {t: sorted(v) for t, v in tabs.items()}, flush=True)
    light = labels("light", "DATA_PT_prism_light")
    check({"Color", "Power", "Radius"} <= set(light), "Light tab (point light): Color, Power, Radius drawn (%s)" % light)
    check("DATA_PT_light" not in tabs["light"] and not any(n.startswith(("CYCLES", "DATA_PT_EEVEE")) for n in tabs["light"]),
          "Light tab: neither Blender's type-only Light panel nor EEVEE's/Cycles'")
    check("template_ID" in templates("light", "DATA_PT_context_light"), "Light tab: the light browser")
    check("template_ID" in templates("world", "WORLD_PT_context_world"), "World tab: the world browser")
    check("template_node_view" in templates("world", "WORLD_PT_prism_surface"), "World tab: Surface draws the node view")
    check("template_list" in templates("material", "EEVEE_MATERIAL_PT_context_material")
          and "template_ID" in templates("material", "EEVEE_MATERIAL_PT_context_material"),
          "Material tab: the slot list and browse/new")
    check("template_node_view" in templates("material", "MATERIAL_PT_prism_surface"), "Material tab: Surface draws the node view")
    render = labels("render", "RENDER_PT_prism_sampling")
    check("Density" in render and "Wavelength Density" not in render, "Render tab: Density under Wavelengths (%s)" % render)
    px = report["label_px"]
    wide = {lab: round(w) for lab, w in px.items() if w > px["Noise Threshold"] and lab != "Wavelength Density"}
    check(not wide, "Render tab labels no wider than 'Noise Threshold' (%.0f px, fits the %d px editor; "
          "'Wavelength Density' is %.0f px): %s" % (px["Noise Threshold"], report["region_width"], px["Wavelength Density"], wide))
    shots = [os.path.join(out, t + ".png") for t in ("light", "world", "material", "render")]
    check(all(os.path.getsize(s) > 1000 for s in shots), "screenshots: %s" % ", ".join(shots))


def _png_rgb(path):
    """A screenshot's RGB (byte values / 255, display-encoded), top row first."""
    import common

    return common.read_exr(path)[::-1, :, :3]  # Blender's loader reads PNG as well


def _srgb(linear):
    import numpy as np

    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def _camera_view(step):
    """The screenshot's camera frame (y from the top), resampled to the render's size, and the
    F12 render's pixels in the same display encoding (Standard view transform = sRGB)."""
    import numpy as np
    import common

    shot = _png_rgb(step["png"])
    aw, ah = step["area"]
    check(shot.shape[:2] == (ah, aw), "screenshot is the viewport area (%dx%d)" % (aw, ah))
    x0, y0, x1, y1 = step["camera_rect"]
    # Region y runs up; the screenshot's rows run down.
    top, bottom = ah - y1, ah - y0
    render = _srgb(common.read_exr(step["exr"])[::-1, :, :3])  # top row first, as the screenshot
    rh, rw = render.shape[:2]
    # Sample the screenshot at the centres of the render's pixels.
    xs = (x0 + (np.arange(rw) + 0.5) * (x1 - x0) / rw).astype(int).clip(0, aw - 1)
    ys = (top + (np.arange(rh) + 0.5) * (bottom - top) / rh).astype(int).clip(0, ah - 1)
    return shot[np.ix_(ys, xs)], render


def _blocks(img, n=8):
    h, w = img.shape[:2]
    return img[: h - h % n, : w - w % n].reshape(h // n, n, w // n, n, 3).mean(axis=(1, 3))


def test_rendered_viewport():
    """Blender 3.4 with a window: the 3D viewport in Rendered shading with Prism (a `prism
    serve` process), seen through the camera, against F12 renders of the same camera; a camera
    move and a material edit made through the Python API show up; Solid shading, switching the
    engine and File > New end the renderer process."""
    import numpy as np

    out = tempfile.mkdtemp(prefix="prism_interactive_")
    start = os.path.join(out, "start.blend")
    # Opening a file skips the splash screen, which would cover the viewport.
    subprocess.run([BLENDER, "-b", "--factory-startup", "--python-expr",
                    "import bpy; bpy.ops.wm.save_as_mainfile(filepath=%r)" % start],
                   capture_output=True, timeout=60, check=True)
    report_path = os.path.join(out, "viewport.json")
    env = dict(os.environ, PRISM_VIEWPORT_REPORT=report_path, PRISM_VIEWPORT_OUT=out)
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 800x600x24",
           BLENDER, "--factory-startup", start, "-P", os.path.join(HERE, "viewport_blender.py")]
    try:
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=240)
    except subprocess.TimeoutExpired as e:
        raise AssertionError("viewport session did not finish in 240 s: %s" % (e.stderr or "")[-600:])
    log = p.stdout + p.stderr
    check(os.path.exists(report_path), "the viewport session wrote its report (log tail: %s)" % log[-600:])
    with open(report_path) as f:
        report = json.load(f)
    check(not report["errors"], "no Python errors in the session: %s" % report["errors"])
    check(p.returncode == 0, "Blender exited cleanly (rc %d)" % p.returncode)
    steps = report["steps"]
    for name in ("rendered", "camera_moved", "material_blue"):
        st = steps[name]
        print("  %s: %d frames drawn so far, %s; first frame %.2f s after the edit, finished in %.1f s"
              % (name, st["stats"]["frames_drawn"], st["frame"], st["latency"].get("first_frame", -1), st["seconds"]), flush=True)
        check(st["frame"]["spp"] >= 32, "%s: the viewport reached 32 samples" % name)
    check(steps["camera_moved"]["stats"]["loads"] == 1 and steps["camera_moved"]["stats"]["views"] >= 2,
          "a camera move is a new view, not a new export (%s)" % steps["camera_moved"]["stats"])
    check(steps["material_blue"]["stats"]["shadings"] >= 1 and steps["material_blue"]["stats"]["loads"] == 1,
          "a material edit is a shading update, not a reload (%s)" % steps["material_blue"]["stats"])
    views = {}
    for name in ("rendered", "camera_moved", "material_blue"):
        shot, render = _camera_view(steps[name])
        views[name] = (shot, render)
        ms, mr = shot.reshape(-1, 3).mean(axis=0), render.reshape(-1, 3).mean(axis=0)
        rel = np.abs(ms - mr) / np.maximum(mr, 1e-3)
        check(rel.max() < 0.05, "%s: viewport means %s within 5%% of the F12 render's %s" % (name, ms.round(4), mr.round(4)))
        diff = np.abs(_blocks(shot) - _blocks(render)).max()
        check(diff < 0.05, "%s: every 8x8 block of the viewport within 0.05 of the render's (max %.3f)" % (name, diff))
    moved = np.abs(_blocks(views["camera_moved"][0]) - _blocks(views["rendered"][1])).max()
    check(moved > 0.15, "the camera move changed the viewport (max block change %.3f)" % moved)
    shot_blue, _ = views["material_blue"]
    cube = shot_blue[shot_blue.max(axis=-1) - shot_blue.min(axis=-1) > 0.1]
    check(len(cube) > 500 and cube[:, 2].mean() > 2.0 * cube[:, 0].mean(),
          "the blue material shows in the viewport (%d coloured pixels, mean %s)" % (len(cube), cube.mean(axis=0).round(3) if len(cube) else None))
    check(report["preview_renders"] and report["icon_mean"] and report["icon_mean"] > 0.05,
          "Prism rendered the material's preview icon (renders %s, icon %s, mean %s)"
          % (report["preview_renders"], report["icon_size"], report["icon_mean"]))
    check(report["solid_process_alive"] is False, "Solid shading ended the renderer process (in %.2f s)" % report["solid_seconds"])
    check(report["engine_switch_process_alive"] is False,
          "switching the engine to EEVEE ended the renderer process (in %.2f s)" % report["engine_switch_seconds"])
    check(report["new_file_process_alive"] is False, "File > New ended the renderer process (in %.2f s)" % report["new_file_seconds"])


if __name__ == "__main__":
    test_rendered_viewport()
    test_interactive_f12_render()
    test_properties_editor_panels()
    print("interactive test passed")
