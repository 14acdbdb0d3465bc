"""Blender's render pipeline with Prism, against Cycles where it applies: the render border
(with and without Crop to Render Region), Film > Transparent, object holdout (and a holdout
collection), the Holdout shader and view layers. Runs in the bpy wheel (5.0.1) and in `blender -b` (3.4):

    .venv-bpy/bin/python tests/addon/test_pipeline.py [TEST_NAME ...]
    blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_pipeline.py -- [TEST_NAME ...]
"""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_pipeline_")
W, H = 80, 60


def scene():
    """A red sphere on a grey floor under a sun, a blue-grey world; the floor ends inside the
    view so the world shows behind it."""
    C.reset()
    sc = bpy.context.scene
    C.world((0.3, 0.4, 0.6), 1.0)
    C.mesh_object("Floor", C.plane(4.0), C.material("Floor", "ShaderNodeBsdfDiffuse", (0.6, 0.6, 0.6)))
    C.mesh_object("Ball", C.sphere(0.8), C.material("Red", "ShaderNodeBsdfDiffuse", (0.8, 0.1, 0.1)),
                  location=(0.0, 0.0, 0.8), smooth=True)
    C.light("Sun", "SUN", 3.0, (0, 0, 5), rotation=(0.5, 0.2, 0.0))
    C.camera((0.0, -6.0, 2.5), (0.0, 0.0, 0.7), lens=35.0)
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = W, H, 100
    return sc


def render(sc, engine, name, spp=16):
    return C.render_engine_rgba(sc, engine, spp, OUT, name, 2)


def test_render_border():
    """A region of a 80x60 render, without and with Crop to Render Region: Blender gets the
    region (laid into the frame, or cropped), and every pixel of it equals the full render's
    (each pixel takes its full-image samples)."""
    sc = scene()
    full = render(sc, "prism", "full")
    r = sc.render
    r.use_border = True
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.213, 0.677, 0.1, 0.55
    # Blender's region rounding; rows count from the bottom, as in Blender's pixels (read_exr).
    x0, x1, y0, y1 = int(0.213 * W), int(0.677 * W), int(0.1 * H), int(0.55 * H)
    for crop in (False, True):
        r.use_crop_to_border = crop
        img = render(sc, "prism", "border_crop%d" % crop)
        rows = slice(y0, y1)
        region_full = full[rows, x0:x1]
        if crop:
            C.check(img.shape[:2] == (y1 - y0, x1 - x0), "cropped: the image is the region, %s" % (img.shape[:2],))
            region = img
        else:
            C.check(img.shape[:2] == (H, W), "not cropped: the full frame, %s" % (img.shape[:2],))
            region = img[rows, x0:x1]
            outside = img.copy()
            outside[rows, x0:x1] = 0.0
            # Blender keeps what the frame held outside the region (here: nothing or the
            # previous full render).
            kept = (outside == 0) | (np.abs(outside - full) < 1e-6)
            C.check(bool(kept.all()), "not cropped: outside the region Blender's frame is unchanged")
        diff = float(np.abs(region - region_full).max())
        C.check(diff < 1e-5, "crop %s: the region equals the full render's pixels (max |diff| %.2g)" % (crop, diff))


def test_film_transparent():
    """Film > Transparent: the world behind the floor has alpha 0 (and no colour), the ball and
    floor alpha 1, in Prism and Cycles; the lit ball's colour stays within 3% of Cycles'."""
    sc = scene()
    sc.render.film_transparent = True
    imgs = {e: render(sc, e, "transparent_" + e) for e in ("cycles", "prism")}
    # Where Cycles sees only the world, one pixel away from any edge (partial coverage differs
    # by sample positions).
    seen = imgs["cycles"][..., 3] < 0.01
    background = seen.copy()
    for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        background &= np.roll(np.roll(seen, dy, axis=0), dx, axis=1)
    C.check(background.sum() > 0.2 * W * H, "the world covers %d px" % background.sum())
    for e, img in imgs.items():
        bg = img[background]
        centre = img[H // 2 - 3:H // 2 + 3, W // 2 - 3:W // 2 + 3]
        C.check(float(bg[:, 3].max()) < 0.01 and float(bg[:, :3].max()) < 0.01,
                "%s: background alpha %.3f, colour %.3f" % (e, bg[:, 3].max(), bg[:, :3].max()))
        C.check(float(centre[..., 3].min()) > 0.99, "%s: ball alpha %.3f" % (e, centre[..., 3].min()))
    a_c, a_p = imgs["cycles"][..., 3].mean(), imgs["prism"][..., 3].mean()
    C.check(abs(a_p - a_c) < 0.01, "mean alpha %.4f vs Cycles' %.4f" % (a_p, a_c))
    m_c = imgs["cycles"][H // 2 - 3:H // 2 + 3, W // 2 - 3:W // 2 + 3, :3].mean()
    m_p = imgs["prism"][H // 2 - 3:H // 2 + 3, W // 2 - 3:W // 2 + 3, :3].mean()
    C.check(abs(m_p / m_c - 1.0) < 0.03, "ball colour %.4f vs Cycles' %.4f" % (m_p, m_c))


def holdout_check(sc, what):
    imgs = {e: render(sc, e, "holdout_%s_%s" % (what.replace(" ", "_"), e)) for e in ("cycles", "prism")}
    for e, img in imgs.items():
        centre = img[H // 2 - 3:H // 2 + 3, W // 2 - 3:W // 2 + 3]
        corner = img[:3, :3]  # the floor, bottom left (rows from the bottom)
        C.check(float(centre[..., 3].max()) < 0.01, "%s, %s: the ball's alpha %.3f" % (what, e, centre[..., 3].max()))
        C.check(float(corner[..., 3].min()) > 0.99, "%s, %s: the floor stays opaque" % (what, e))
    a_c, a_p = imgs["cycles"][..., 3].mean(), imgs["prism"][..., 3].mean()
    C.check(abs(a_p - a_c) < 0.01, "%s: mean alpha %.4f vs Cycles' %.4f" % (what, a_p, a_c))


def test_object_holdout():
    sc = scene()
    bpy.data.objects["Ball"].is_holdout = True
    holdout_check(sc, "object holdout")


def test_holdout_collection():
    sc = scene()
    ball = bpy.data.objects["Ball"]
    coll = bpy.data.collections.new("Holes")
    sc.collection.children.link(coll)
    sc.collection.objects.unlink(ball)
    coll.objects.link(ball)
    bpy.context.view_layer.layer_collection.children["Holes"].holdout = True
    holdout_check(sc, "holdout collection")


def test_holdout_shader():
    sc = scene()
    mat = bpy.data.objects["Ball"].material_slots[0].material
    nt = mat.node_tree
    out = next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL")
    hold = nt.nodes.new("ShaderNodeHoldout")
    nt.links.new(hold.outputs[0], out.inputs["Surface"])
    holdout_check(sc, "Holdout shader")


def test_view_layers():
    """Two view layers, the second excluding the ball's collection and holding out the floor:
    each layer of the multilayer EXR Blender writes equals that layer rendered alone (before,
    the second layer's render overwrote the first)."""
    from prism import exr

    sc = scene()
    ball = bpy.data.objects["Ball"]
    coll = bpy.data.collections.new("BallColl")
    sc.collection.children.link(coll)
    sc.collection.objects.unlink(ball)
    coll.objects.link(ball)
    first = sc.view_layers[0]
    second = sc.view_layers.new("Second")
    second.layer_collection.children["BallColl"].exclude = True
    C.use_prism(sc, 8)
    im = sc.render.image_settings
    if hasattr(im, "media_type"):  # 5.0: multilayer is a media type of OpenEXR
        im.media_type = "MULTI_LAYER_IMAGE"
        im.file_format = "OPEN_EXR_MULTILAYER"
    else:
        im.file_format = "OPEN_EXR_MULTILAYER"
    im.color_depth = "32"
    if hasattr(im, "exr_codec"):
        im.exr_codec = "NONE"
    sc.render.filepath = os.path.join(OUT, "layers_")
    sc.render.use_file_extension = True

    def planes_of(path, layer):
        planes = exr.read_planes(path)
        names = [k for k in planes if k.startswith(layer + ".") and k.split(".")[-1] in "RGBA"]
        return np.stack([planes["%s.Combined.%s" % (layer, c)] for c in "RGBA"], axis=-1), names

    def render_to(name):
        sc.render.filepath = os.path.join(OUT, name)
        res = bpy.ops.render.render(write_still=True)
        C.check("FINISHED" in res, "render %s" % name)
        import glob

        found = sorted(glob.glob(os.path.join(OUT, name + "*.exr")))
        C.check(len(found) == 1, "one file written: %s" % found)
        return found[0]

    both = render_to("both_")
    a, _ = planes_of(both, first.name)
    b, _ = planes_of(both, "Second")
    C.check(float(np.abs(a - b).max()) > 0.1, "the layers differ (ball in the first only)")
    second.use = False
    solo_a, _ = planes_of(render_to("first_"), first.name)
    second.use, first.use = True, False
    solo_b, _ = planes_of(render_to("second_"), "Second")
    first.use = True
    C.check(float(np.abs(a - solo_a).max()) < 1e-6, "layer '%s' equals its solo render" % first.name)
    C.check(float(np.abs(b - solo_b).max()) < 1e-6, "layer 'Second' equals its solo render")


def test_untranslated_features_warn():
    """What Prism cannot render yet is named in a warning (they reach RenderEngine.report):
    the motion blur of a mesh whose vertex count changes over the shutter. Particle hair, area light spread, Diffuse / Glossy /
    Volume Scatter ray visibility and motion blur (on, with nothing deforming) are rendered
    (test_hair.py, test_lights.py, test_motion_blur.py): no warning."""
    from prism import export

    sc = scene()
    sc.render.use_motion_blur = True
    ball = bpy.data.objects["Ball"]
    bpy.context.view_layer.objects.active = ball
    ball.modifiers.new("Hair", "PARTICLE_SYSTEM")
    ball.particle_systems[0].settings.type = "HAIR"
    sun = bpy.data.objects["Sun"]
    sun.visible_diffuse = False
    sun.visible_volume_scatter = False
    area = C.light("Area", "AREA", 50.0, (0, 0, 3))
    area.data.spread = 1.0
    sc.render.engine = "PRISM"
    _, _, warnings, _ = export.export_scene(bpy.context.evaluated_depsgraph_get(), tempfile.mkdtemp(dir=OUT))
    text = "\n".join(warnings)
    C.check("hair" not in text and "spread" not in text and "diffuse" not in text and "motion" not in text
            and "volume scatter" not in text,
            "hair, spread, Diffuse / Volume Scatter visibility and motion blur (nothing moves or deforms) are not "
            "warned about: %r" % text)
    # A deforming mesh under motion blur is blurred (test_motion_blur.py): no warning; one
    # whose vertex count changes over the shutter (a Build modifier) is named in a warning.
    ball.modifiers.new("Wave", "WAVE")
    _, _, warnings, _ = export.export_scene(bpy.context.evaluated_depsgraph_get(), tempfile.mkdtemp(dir=OUT))
    C.check(not any("motion" in w for w in warnings), "a deforming mesh is not warned about: %r" % warnings)
    build = ball.modifiers.new("Build", "BUILD")
    build.frame_start, build.frame_duration = sc.frame_current - 5, 10
    _, _, warnings, _ = export.export_scene(bpy.context.evaluated_depsgraph_get(), tempfile.mkdtemp(dir=OUT))
    text = "\n".join(warnings)
    C.check("vertex count" in text and "Ball" in text, "a changing vertex count is warned about: %r" % text)


if __name__ == "__main__":
    from runner_util import run_tests

    C.enable_addon()
    C.prefs().binary_path = C.BINARY
    run_tests("pipeline tests", globals())
