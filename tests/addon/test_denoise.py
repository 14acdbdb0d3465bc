"""Denoising and clamps through the add-on in the bpy wheel (Blender 5.0.1, which ships Open
Image Denoise in bpy/lib). Run by run_addon_tests.sh.

    .venv-bpy/bin/python tests/addon/test_denoise.py [TEST_NAME ...]

- Denoise is on by default for final renders, in Render > Prism > Denoise, and the add-on finds
  the running Blender's OIDN library.
- A render with Denoise on: the Combined pass is the denoised image (smooth where the Noisy
  Image pass is grainy, same mean within 2%), the Noisy Image pass is the binary's noisy image,
  and the denoising data passes are written beside them.
- Without a library: one warning in Blender's report naming the problem, a noisy image.
- Clamp Direct / Indirect reach the binary: no pixel brighter than their sum.
"""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_denoise_")
prism = C.enable_addon()
C.prefs().binary_path = C.BINARY


def multilayer(sc, name):
    """Saves the Render Result as a multilayer EXR and returns its planes by channel name."""
    im = sc.render.image_settings
    if hasattr(im, "media_type"):  # Blender 5: multilayer EXR is a media type
        im.media_type = "MULTI_LAYER_IMAGE"
    im.file_format = "OPEN_EXR_MULTILAYER"
    im.color_depth = "32"
    path = os.path.join(OUT, name + ".exr")
    bpy.data.images["Render Result"].save_render(filepath=path, scene=sc)
    from prism import exr

    return exr.read_planes(path)


def plane(planes, suffix):
    key = next((k for k in planes if k.endswith(suffix)), None)
    if key is None:
        raise AssertionError("no channel %s in the file: %s" % (suffix, sorted(planes)))
    return planes[key]


def grain(img):
    """Mean absolute difference between horizontal neighbours: the grain of an image."""
    return float(np.mean(np.abs(np.diff(img, axis=1))))


def test_defaults_and_panels():
    C.reset()
    sc = bpy.context.scene
    sc.render.engine = "PRISM"
    C.check(sc.prism.use_denoising, "Denoise is on by default, as in Cycles")
    C.check(sc.prism.clamp_direct == 0.0 and sc.prism.clamp_indirect == 0.0, "clamps off by default (unbiased)")
    C.check((sc.prism.denoising_prefilter, sc.prism.denoising_quality) == ("ACCURATE", "HIGH"),
            "Cycles' defaults: Prefilter Accurate, Quality High")
    for name in ("RENDER_PT_prism_denoise", "RENDER_PT_prism_light_paths"):
        panel = getattr(bpy.types, name, None)
        C.check(panel is not None and panel.poll(bpy.context), "%s shown for Prism" % name)
    from prism import engine

    lib = engine.blender_oidn()
    C.check(lib is not None and os.path.isfile(lib), "the bpy wheel's OIDN found: %s" % lib)
    wheel_lib = os.path.join(os.path.dirname(bpy.utils.resource_path("LOCAL")), "lib")
    C.check(os.path.dirname(lib) == wheel_lib, "in bpy/lib")
    sc.render.engine = "CYCLES"
    C.check(not bpy.types.RENDER_PT_prism_denoise.poll(bpy.context), "denoise panel hidden for Cycles")


def test_library_locations_of_official_builds():
    """Where official builds keep the library, from their executable and version folder."""
    from prism import runner

    root = tempfile.mkdtemp(prefix="oidn_layouts_", dir=OUT)
    layouts = {
        # Linux tarball: blender-4.2/blender, blender-4.2/4.2/, blender-4.2/lib/
        "linux": ("blender-4.2/blender", "blender-4.2/4.2", "blender-4.2/lib"),
        # Windows: blender.exe beside 4.2/ and blender.shared/
        "windows": ("win/blender.exe", "win/4.2", "win/blender.shared"),
        # macOS: Blender.app/Contents/MacOS/Blender, Contents/Resources/4.2, Contents/Resources/lib
        "macos": ("Blender.app/Contents/MacOS/Blender", "Blender.app/Contents/Resources/4.2",
                  "Blender.app/Contents/Resources/lib"),
    }
    for name, (exe, local, lib) in layouts.items():
        dirs = runner.oidn_search_dirs(os.path.join(root, exe), os.path.join(root, local))
        C.check(os.path.join(root, lib) in dirs, "%s: %s searched" % (name, lib))
        os.makedirs(os.path.join(root, lib), exist_ok=True)
        open(os.path.join(root, lib, runner.OIDN_NAMES[0]), "w").close()
        C.check(runner.find_oidn(dirs) == os.path.join(root, lib, runner.OIDN_NAMES[0]), "%s: found" % name)
        os.remove(os.path.join(root, lib, runner.OIDN_NAMES[0]))
    C.check(runner.find_oidn(["/nonexistent"]) is None, "nothing found where there is nothing")


def test_denoised_render_with_noisy_image_pass():
    sc = C.simple_scene()
    C.use_prism(sc, spp=4)
    sc.prism.use_denoising = True
    sc.prism.denoising_data = True
    sc.prism.denoising_quality = "BALANCED"
    sc.render.resolution_x, sc.render.resolution_y = 120, 80
    res = bpy.ops.render.render(write_still=False)
    C.check("FINISHED" in res, "render finished")
    from prism import engine

    L = engine.LAST
    C.check(L["error"] is None, "no error: %s" % L["error"])
    C.check(L["denoised"], "the binary denoised (oidn %s, warnings %s)" % (L.get("oidn"), L["warnings"]))
    C.check(not L["warnings"], "no warnings: %s" % L["warnings"])
    C.check("--denoise-quality balanced" in " ".join(L.get("args", [])), "quality passed to the binary")
    C.check("denoise" in L["timings"], "denoise time reported: %.3f s" % L["timings"].get("denoise", -1))
    C.check(L["passes"] == ["Denoising Normal", "Denoising Albedo", "Denoising Depth", "Noisy Image"],
            "passes: %s" % L["passes"])
    planes = multilayer(sc, "denoised")
    combined = np.stack([plane(planes, "Combined." + c) for c in "RGB"], axis=-1)
    noisy = np.stack([plane(planes, "Noisy Image." + c) for c in "RGB"], axis=-1)
    C.check(np.isfinite(combined).all() and np.isfinite(noisy).all(), "finite")
    C.check(combined.shape == noisy.shape == (80, 120, 3), "sizes %s" % (combined.shape,))
    g_c, g_n = grain(combined), grain(noisy)
    C.check(g_c < 0.5 * g_n, "Combined is denoised: grain %.4f vs Noisy Image %.4f" % (g_c, g_n))
    m_c, m_n = combined.mean(), noisy.mean()
    C.check(abs(m_c - m_n) < 0.02 * m_n, "means %.4f (denoised) vs %.4f (noisy)" % (m_c, m_n))
    albedo = plane(planes, "Denoising Albedo.R")
    C.check(albedo.max() > 0.5, "Denoising Albedo written")
    C.check(plane(planes, "Denoising Depth.Z").min() > 0.0, "Denoising Depth written")
    sc.prism.denoising_data = False
    sc.prism.denoising_quality = "HIGH"


def test_without_a_library_the_user_is_warned():
    from prism import engine

    saved = dict(engine._OIDN)
    env = os.environ.pop("PRISM_OIDN", None)
    engine._OIDN.clear()
    engine._OIDN.update(path=None, dirs=["/nonexistent/blender/lib"])
    try:
        sc = C.simple_scene()
        C.use_prism(sc, spp=2)
        sc.prism.use_denoising = True
        res = bpy.ops.render.render(write_still=False)
        C.check("FINISHED" in res, "render finished")
        L = engine.LAST
        C.check(L["error"] is None and not L["denoised"], "rendered, not denoised")
        w = [x for x in L["warnings"] if "Open Image Denoise" in x]
        C.check(len(w) == 1 and "no Open Image Denoise library" in w[0] and "/nonexistent/blender/lib" in w[0],
                "one warning in Blender's report: %s" % L["warnings"])
    finally:
        engine._OIDN.clear()
        engine._OIDN.update(saved)
        if env is not None:
            os.environ["PRISM_OIDN"] = env


def test_clamps_bound_every_pixel():
    sc = C.parity_scene(64, 48)  # an area light seen directly, glass and glossy metal: bright
    C.use_prism(sc, spp=16)
    sc.prism.clamp_direct, sc.prism.clamp_indirect = 0.3, 0.2
    from prism import engine, export

    block = export.render_settings(sc)
    C.check(abs(block.get("clamp_direct") - 0.3) < 1e-6 and abs(block.get("clamp_indirect") - 0.2) < 1e-6,
            "clamps in the JSON render block: %s" % block)
    px = C.render_pixels(sc, os.path.join(OUT, "clamped.exr"))[..., :3]
    C.check(engine.LAST["error"] is None, "no error")
    lum = px @ np.array([0.2126, 0.7152, 0.0722])
    C.check(lum.max() <= 0.5 * 1.001, "max pixel luminance %.4f <= 0.3 + 0.2" % lum.max())
    sc.prism.clamp_direct = sc.prism.clamp_indirect = 0.0
    px = C.render_pixels(sc, os.path.join(OUT, "unclamped.exr"))[..., :3]
    lum = px @ np.array([0.2126, 0.7152, 0.0722])
    C.check(lum.max() > 1.0, "unclamped: the scene is brighter than that (%.3f)" % lum.max())


if __name__ == "__main__":
    from runner_util import run_tests

    run_tests("add-on denoise (bpy 5.0.1)", dict(globals()))
