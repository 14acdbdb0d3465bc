"""Motion blur against Cycles (issue 13), in the bpy wheel (Blender 5.0.1) and Debian's
Blender 3.4.1: object, camera and deformation (shape key) blur. Run by run_addon_tests.sh:

    .venv-bpy/bin/python tests/addon/test_motion_blur.py [TEST_NAME ...]
    blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_motion_blur.py -- [TEST_NAME ...]

The scene: an emissive sphere (radius 0.5) over a black world, seen from straight above by an
orthographic camera, 32 pixels per metre. Keyframed linearly from x = -1 (frame 1) to x = +1
(frame 2), with a shutter of 0.5 frames centred on frame 1.5 it moves one diameter (-0.5 to
+0.5) while the shutter is open. Along the row through its centre the time it covers a
point falls off linearly over one metre on each side (a triangle): the blur's 10-90% rise is
0.8 m = 25.6 px, where the still sphere's edge rises within a pixel or two.
"""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_motion_")
WIDTH, HEIGHT, SCALE = 128, 32, 4.0
PX_PER_M = WIDTH / SCALE


def linear(ob):
    """Makes `ob`'s keyframes linear (Blender 4.4+ keeps F-curves in the action's layers)."""
    act = ob.animation_data.action
    curves = list(getattr(act, "fcurves", None) or [])
    for layer in getattr(act, "layers", ()):
        for strip in layer.strips:
            for bag in strip.channelbags:
                curves.extend(bag.fcurves)
    for fc in curves:
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"
    if not curves:
        raise AssertionError("no F-curves on %s" % ob.name)


def scene(move_object=True, move_camera=False, position="CENTER", blur=True, deform=False):
    C.reset()
    sc = bpy.context.scene
    C.world((0.0, 0.0, 0.0), 0.0)
    glow = C.material("Glow", "ShaderNodeEmission", (1.0, 1.0, 1.0))
    ball = C.mesh_object("Ball", C.sphere(0.5, segs=64, rings=32), glow, smooth=True)
    cam = C.camera((0.0, 0.0, 6.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = SCALE
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = WIDTH, HEIGHT, 100
    if move_object:
        for frame, x in ((1, -1.0), (2, 1.0)):
            ball.location = (x, 0.0, 0.0)
            ball.keyframe_insert("location", frame=frame)
        linear(ball)
    if deform:
        # The same sweep by a shape key instead of the object: the ball stays at x = -1, its
        # "Moved" key (every vertex 2 m along +x) goes from 0 (frame 1) to 1 (frame 2).
        ball.location = (-1.0, 0.0, 0.0)
        ball.shape_key_add(name="Basis")
        moved = ball.shape_key_add(name="Moved")
        for point in moved.data:
            point.co.x += 2.0
        for frame, v in ((1, 0.0), (2, 1.0)):
            moved.value = v
            moved.keyframe_insert("value", frame=frame)
        linear(ball.data.shape_keys)
    if move_camera:
        # The camera moving +x -> -x: the still ball sweeps -x -> +x through the view.
        for frame, x in ((1, 1.0), (2, -1.0)):
            cam.location = (x, 0.0, 6.0)
            cam.keyframe_insert("location", frame=frame)
        linear(cam)
    sc.frame_set(1, subframe=0.5)
    sc.render.use_motion_blur = blur
    sc.render.motion_blur_shutter = 0.5
    if hasattr(sc.render, "motion_blur_position"):
        sc.render.motion_blur_position = position
    else:
        sc.cycles.motion_blur_position = position
    return sc


def profile(img):
    """Mean over the four rows through the ball's centre, along x."""
    mid = HEIGHT // 2
    return img[mid - 2:mid + 2, :, :3].mean(axis=(0, 2))


def rise(p):
    """(10-90% rise of the left edge, 90-10% fall of the right edge) in pixels."""
    peak = p.max()

    def crossing(level, side):
        idx = np.arange(len(p)) if side == "left" else np.arange(len(p))[::-1]
        for a, b in zip(idx, idx[1:]):
            if p[a] < level <= p[b]:
                return a + (b - a) * (level - p[a]) / (p[b] - p[a])
        raise AssertionError("no crossing of %g on the %s" % (level, side))

    return (crossing(0.9 * peak, "left") - crossing(0.1 * peak, "left"),
            crossing(0.1 * peak, "right") - crossing(0.9 * peak, "right"))


def centroid(p):
    return float((np.arange(len(p)) * p).sum() / p.sum())


def compare(name, **kw):
    sc = scene(**kw)
    cyc = C.render_engine(sc, "cycles", 64, OUT, name, 2)
    pri = C.render_engine(sc, "prism", 64, OUT, name, 2)
    pc, pp = profile(cyc), profile(pri)
    rc, rp = rise(pc), rise(pp)
    mc, mp = float(cyc.mean()), float(pri.mean())
    cc, cp = centroid(pc), centroid(pp)
    print("  %s: rise %.1f / %.1f px (Cycles %.1f / %.1f), centroid %.2f (Cycles %.2f), mean %.4f (Cycles %.4f)"
          % (name, rp[0], rp[1], rc[0], rc[1], cp, cc, mp, mc))
    for side in range(2):
        C.check(abs(rp[side] / rc[side] - 1.0) < 0.05,
                "%s: blur length (10-90%% rise) %.1f px within 5%% of Cycles' %.1f" % (name, rp[side], rc[side]))
    C.check(abs(mp / mc - 1.0) < 0.02, "%s: mean %.4f within 2%% of Cycles' %.4f" % (name, mp, mc))
    C.check(abs(cp - cc) < 0.5, "%s: centroid %.2f px within 0.5 px of Cycles' %.2f" % (name, cp, cc))
    return pp, rp


def test_moving_object():
    """The ball moving one diameter: the triangle profile (25.6 px rises), as Cycles."""
    _, r = compare("object")
    C.check(min(r) > 20.0, "the blur is there: rises %.1f / %.1f px (a still edge: ~1 px)" % r)


def test_shutter_position():
    """Position Start: the shutter opens at frame 1.5, so the ball sweeps 0 -> +1 m: the blur
    sits 16 px right of the centred one, as in Cycles."""
    centred = centroid(scene_profile("CENTER"))
    p, _ = compare("start", position="START")
    C.check(abs(centroid(p) - centred - 0.5 * PX_PER_M) < 1.0,
            "Start moves the blur by half a metre (%.2f px)" % (centroid(p) - centred))


def scene_profile(position):
    sc = scene(position=position)
    return profile(C.render_engine(sc, "prism", 16, OUT, "pos_" + position.lower(), 2))


def test_moving_camera():
    """The camera moving one diameter past the still ball blurs it alike."""
    compare("camera", move_object=False, move_camera=True)


def test_blur_off_is_sharp_and_export_is_still():
    """Motion blur off: the ball at its frame-1.5 place, sharp; no motion in the export."""
    import json
    from prism import export
    sc = scene(blur=False)
    img = C.render_engine(sc, "prism", 16, OUT, "still", 2)
    r = rise(profile(img))
    C.check(max(r) < 4.0, "a still edge rises within a few pixels (%.1f / %.1f)" % r)
    d = tempfile.mkdtemp(dir=OUT)
    gltf, _mj, warnings, _t = export.export_scene(bpy.context.evaluated_depsgraph_get(), d)
    with open(gltf) as f:
        nodes = json.load(f)["nodes"]
    C.check(not any("prism_motion" in n.get("extras", {}) for n in nodes), "no node carries motion")
    sc.render.use_motion_blur = True
    gltf, _mj, warnings, _t = export.export_scene(bpy.context.evaluated_depsgraph_get(), d)
    with open(gltf) as f:
        nodes = {n["name"]: n for n in json.load(f)["nodes"]}
    keys = nodes["Ball"]["extras"]["prism_motion"]
    C.check(len(keys) == 3, "three keys over the shutter (got %d)" % len(keys))
    xs = [k[12] for k in keys]
    C.check(np.allclose(xs, [-0.5, 0.0, 0.5], atol=1e-5), "keys at x = -0.5, 0, 0.5 (got %s)" % xs)
    C.check("prism_motion" not in nodes["Camera"].get("extras", {}), "the still camera has no motion")
    C.check(bpy.context.scene.frame_current == 1 and abs(bpy.context.scene.frame_subframe - 0.5) < 1e-6,
            "the scene is back at its frame after sampling the shutter")
    C.check(not any("motion" in w for w in warnings), "nothing to warn about: %r" % warnings)


def test_deforming_mesh():
    """Deformation blur: the ball swept one diameter by an animated shape key (the object
    still) blurs as the moving object does, against Cycles' deformation blur; the export
    carries the vertices at the keys as morph targets (extras.prism_deformation) and warns
    about nothing. Before, the deformation was shown at the current frame with a warning."""
    import json
    from prism import export
    _, r = compare("deform", move_object=False, deform=True)
    C.check(min(r) > 20.0, "the blur is there: rises %.1f / %.1f px (a still edge: ~1 px)" % r)
    last = sys.modules["prism.engine"].LAST
    C.check(not any("motion" in w for w in last["warnings"]), "no motion warnings: %r" % last["warnings"])
    gltf, _m, warnings, _t = export.export_scene(bpy.context.evaluated_depsgraph_get(), tempfile.mkdtemp(dir=OUT))
    with open(gltf) as f:
        meshes = json.load(f)["meshes"]
    ball = next(m for m in meshes if m["name"].startswith("Ball"))
    C.check(ball.get("extras", {}).get("prism_deformation") is True and len(ball["primitives"][0]["targets"]) == 3,
            "three deformation keys as morph targets: %s" % ball.get("extras"))
    bpy.context.scene.render.use_motion_blur = False


def wave_scene(blur=True):
    """A 64 x 64 grid bent by an animated Wave modifier (non-rigid: positions and normals
    change over the 1-frame shutter), grey diffuse under a sun and a grey world."""
    import bmesh

    C.reset()
    sc = bpy.context.scene
    C.world((0.3, 0.3, 0.3), 1.0)
    mat = C.material("Grey", "ShaderNodeBsdfDiffuse", (0.8, 0.8, 0.8))
    grid = C.mesh_object("Grid", lambda bm: bmesh.ops.create_grid(bm, x_segments=64, y_segments=64, size=2.0), mat,
                         smooth=True)
    wave = grid.modifiers.new("Wave", "WAVE")
    wave.height, wave.width, wave.speed = 0.3, 0.8, 0.4
    C.light("Sun", "SUN", 3.0, (0, 0, 5), rotation=(0.6, 0.2, 0.3), angle=0.0)
    C.camera((0.0, -4.0, 4.0), (0.0, 0.0, 0.0))
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 96, 72, 100
    sc.frame_set(10)
    sc.render.use_motion_blur = blur
    sc.render.motion_blur_shutter = 1.0
    return sc


def test_wave_deformation_matches_cycles():
    """Non-rigid deformation blur (an animated Wave modifier): Prism against Cycles, 3x3-blurred
    relMSE <= 1e-4 and means within 1% (measured 1.0e-5; the unblurred render is 6.4e-4 away)."""
    cy = C.render_engine(wave_scene(), "cycles", 128, OUT, "wave", 4)
    pr = C.render_engine(wave_scene(), "prism", 128, OUT, "wave", 4)
    still = C.render_engine(wave_scene(blur=False), "prism", 32, OUT, "wave_still", 4)
    rel, rel_still = C.rel_mse(C.blur(pr), C.blur(cy)), C.rel_mse(C.blur(still), C.blur(cy))
    mp, mc = pr.mean(axis=(0, 1)), cy.mean(axis=(0, 1))
    print("  wave: blurred relMSE %.2e (unblurred %.2e), means %s vs %s" % (rel, rel_still, mp.round(4), mc.round(4)))
    C.check(rel <= 1e-4, "blurred relMSE %.2e <= 1e-4" % rel)
    C.check(bool(np.all(np.abs(mp / mc - 1.0) < 0.01)), "means within 1%")
    C.check(rel_still > 3e-4, "the scene shows the blur (unblurred %.2e)" % rel_still)
    bpy.context.scene.render.use_motion_blur = False


if __name__ == "__main__":
    from runner_util import run_tests

    C.enable_addon()
    run_tests("motion blur tests", globals())
