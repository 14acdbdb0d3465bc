"""Volume shaders through the add-on, against Cycles, in the bpy wheel (Blender 5.0.1).

    .venv-bpy/bin/python tests/addon/test_volumes.py [TEST_NAME ...]

Four objects in a row in front of a sunlit wall, seen by a level orthographic camera: a
Principled Volume cube with nothing on Surface (fog), a Glass sphere filled with Volume
Absorption (tinted glass), an Add Shader of Volume Scatter and Volume Absorption (coloured
smoke), an emitting Principled Volume (glow) and a blackbody one (fire); then the same row inside a large fog box that
also holds the camera (Principled Volume fog), a cloud whose Density is a Noise texture, and
volumes whose Color is a texture. Each object's region is compared with Cycles
(unbiased: no clamping, Filter Glossy 0, the same bounces of every kind, volume bounces
included): mean per channel within 10% and relMSE of the 3x3-blurred region <= 0.03.
"""

import math
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_volumes_")
prism = C.enable_addon()
C.prefs().binary_path = C.BINARY

WIDTH, HEIGHT = 192, 64
ORTHO = 12.0  # scene units across the image: 16 px per unit
CAMERA_Z = 1.0
XS = (-4.4, -2.2, 0.0, 2.2, 4.4)
NAMES = ("Fog", "TintedGlass", "Smoke", "Glow", "Fire")


def volume_material(name, build, surface=None):
    """A material whose Volume output is `build(nt)`'s socket (and Surface `surface` if given)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(build(nt), out.inputs["Volume"])
    if surface is not None:
        sh = nt.nodes.new(surface[0])
        for k, v in surface[1].items():
            sh.inputs[k].default_value = v
        nt.links.new(sh.outputs[0], out.inputs["Surface"])
    return mat


def principled(nt, **inputs):
    n = nt.nodes.new("ShaderNodeVolumePrincipled")
    for k, v in inputs.items():
        n.inputs[k].default_value = v
    return n


def build_scene(fog_box=False):
    C.reset()
    sc = bpy.context.scene
    wall = C.material("Wall", "ShaderNodeBsdfDiffuse", (0.7, 0.7, 0.7))
    C.mesh_object("Wall", C.plane(16.0), wall, location=(0.0, 2.0, 1.0), rotation=(math.pi / 2, 0.0, 0.0))
    C.mesh_object("Floor", C.plane(16.0), wall)

    fog = volume_material("Fog", lambda nt: principled(nt, Color=(0.9, 0.85, 0.8, 1.0), Density=1.5, Anisotropy=0.3).outputs[0])

    def absorption(nt):
        a = nt.nodes.new("ShaderNodeVolumeAbsorption")
        a.inputs["Color"].default_value = (0.9, 0.4, 0.2, 1.0)
        a.inputs["Density"].default_value = 1.2
        return a.outputs[0]

    tinted = volume_material("TintedGlass", absorption,
                             surface=("ShaderNodeBsdfGlass", {"IOR": 1.45, "Roughness": 0.0}))

    def smoke(nt):
        s = nt.nodes.new("ShaderNodeVolumeScatter")
        s.inputs["Color"].default_value = (0.3, 0.8, 0.4, 1.0)
        s.inputs["Density"].default_value = 2.0
        s.inputs["Anisotropy"].default_value = -0.2
        a = nt.nodes.new("ShaderNodeVolumeAbsorption")
        a.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
        a.inputs["Density"].default_value = 1.0
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(s.outputs[0], add.inputs[0])
        nt.links.new(a.outputs[0], add.inputs[1])
        return add.outputs[0]

    smoky = volume_material("Smoke", smoke)
    glow = volume_material("Glow", lambda nt: principled(
        nt, Density=0.2, **{"Emission Strength": 1.5, "Emission Color": (1.0, 0.5, 0.1, 1.0)}).outputs[0])
    C.mesh_object("Fog", C.cube(1.6), fog, location=(XS[0], 0.0, 0.9))
    C.mesh_object("TintedGlass", C.sphere(0.8), tinted, location=(XS[1], 0.0, 0.9), smooth=True)
    C.mesh_object("Smoke", C.cube(1.6), smoky, location=(XS[2], 0.0, 0.9))
    fire = volume_material("Fire", lambda nt: principled(
        nt, Color=(0.3, 0.3, 0.3, 1.0), Density=0.5, Temperature=1400.0,
        **{"Blackbody Intensity": 1.0, "Blackbody Tint": (1.0, 0.9, 0.8, 1.0)}).outputs[0])
    C.mesh_object("Glow", C.cube(1.6), glow, location=(XS[3], 0.0, 0.9))
    C.mesh_object("Fire", C.cube(1.6), fire, location=(XS[4], 0.0, 0.9))
    if fog_box:
        haze = volume_material("Haze", lambda nt: principled(nt, Color=(0.8, 0.8, 0.8, 1.0), Density=0.04).outputs[0])
        C.mesh_object("HazeBox", C.cube(30.0), haze, location=(0.0, 0.0, 0.0))
    C.light("Sun", "SUN", 3.0, (0, 0, 10), rotation=(math.radians(40), 0.0, math.radians(-30)), angle=0.0)
    C.world((0.1, 0.1, 0.12), 1.0)
    cam = C.camera((0.0, -10.0, CAMERA_Z), (0.0, 0.0, CAMERA_Z))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = ORTHO
    sc.render.resolution_x = WIDTH
    sc.render.resolution_y = HEIGHT
    sc.render.resolution_percentage = 100
    return sc


def region(img, i):
    """The object i's square (1.6 units) in the image (rows bottom-up, as Blender stores them)."""
    px = WIDTH / ORTHO
    cx = WIDTH / 2 + XS[i] * px
    cz = HEIGHT / 2 + (0.9 - CAMERA_Z) * px
    half = 0.75 * px
    return img[int(cz - half):int(cz + half), int(cx - half):int(cx + half)]


def within_bounds(a, b):
    """(Prism mean, Cycles mean, blurred relMSE, ok) of two image regions: means within 10% per
    channel (absolutely for channels near 0) and relMSE of the 3x3-blurred regions <= 0.03."""
    ma, mb = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
    rel = C.rel_mse(C.blur(a), C.blur(b))
    ok = bool(np.all(np.abs(ma - mb) <= 0.10 * np.maximum(mb, 0.02))) and rel <= 0.03
    return ma, mb, rel, ok


def compare(pr, cy, label):
    failures = []
    for i, name in enumerate(NAMES):
        ma, mb, rel, ok = within_bounds(region(pr, i), region(cy, i))
        print("  %s %-12s prism %s cycles %s relMSE %.4f %s"
              % (label, name, np.round(ma, 3), np.round(mb, 3), rel, "" if ok else "FAIL"), flush=True)
        if not ok:
            failures.append(name)
    return failures


def test_volume_shaders_match_cycles():
    spp, bounces = 128, 16
    cy = C.render_engine(build_scene(), "cycles", spp, OUT, "volumes", bounces)
    pr = C.render_engine(build_scene(), "prism", spp, OUT, "volumes", bounces)
    warnings = prism.engine.LAST["warnings"]
    failures = compare(pr, cy, "row")
    C.check(not failures, "every volume within 10%% per channel and relMSE <= 0.03 (failed: %s)" % failures)
    C.check(not warnings, "no warnings: %s" % warnings)


def test_camera_inside_fog_matches_cycles():
    spp, bounces = 64, 16
    cy = C.render_engine(build_scene(fog_box=True), "cycles", spp, OUT, "fogbox", bounces)
    pr = C.render_engine(build_scene(fog_box=True), "prism", spp, OUT, "fogbox", bounces)
    clear = C.render_engine(build_scene(), "prism", spp, OUT, "nofog", bounces)
    failures = compare(pr, cy, "fog box")
    whole = C.rel_mse(C.blur(pr), C.blur(cy))
    ma, mb, mc = pr.mean(axis=(0, 1)), cy.mean(axis=(0, 1)), clear.mean(axis=(0, 1))
    print("  whole image: prism %s cycles %s (without the fog box %s), relMSE %.4f"
          % (np.round(ma, 4), np.round(mb, 4), np.round(mc, 4), whole), flush=True)
    # The haze changes the image (the camera sees through 12 units of it to the wall).
    C.check(float(np.abs(mc - mb).max()) > 0.05 * float(mb.max()), "the fog box is visible in Cycles' image")
    C.check(bool(np.all(np.abs(ma - mb) <= 0.05 * mb)) and whole <= 0.03,
            "whole image within 5% per channel, relMSE <= 0.03")
    C.check(not failures, "every object inside the fog within 10%% per channel and relMSE <= 0.03 (failed: %s)" % failures)


def cloud_scene():
    """A Principled Volume cube whose Density is a Noise texture through a Color Ramp (a
    cloud), lit by the sun in front of the wall."""
    sc = build_scene()
    for ob in [o for o in bpy.data.objects if o.name in NAMES]:
        bpy.data.objects.remove(ob)

    def cloud(nt):
        pv = principled(nt, Color=(0.85, 0.85, 0.9, 1.0), Anisotropy=0.4)
        noise = nt.nodes.new("ShaderNodeTexNoise")
        noise.inputs["Scale"].default_value = 2.5
        noise.inputs["Detail"].default_value = 3.0
        ramp = nt.nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.elements[0].position = 0.45
        ramp.color_ramp.elements[1].position = 0.65
        mul = nt.nodes.new("ShaderNodeMath")
        mul.operation = "MULTIPLY"
        mul.inputs[1].default_value = 6.0
        nt.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
        nt.links.new(ramp.outputs["Color"], mul.inputs[0])
        nt.links.new(mul.outputs[0], pv.inputs["Density"])
        return pv.outputs[0]

    mat = volume_material("Cloud", cloud)
    C.mesh_object("Cloud", C.cube(3.6), mat, location=(0.0, 0.0, 1.0))
    return sc


def test_textured_density_matches_cycles():
    spp, bounces = 64, 16
    cy = C.render_engine(cloud_scene(), "cycles", spp, OUT, "cloud", bounces)
    pr = C.render_engine(cloud_scene(), "prism", spp, OUT, "cloud", bounces)
    warnings = prism.engine.LAST["warnings"]
    px = WIDTH / ORTHO
    box = (slice(int(HEIGHT / 2 - 1.6 * px), int(HEIGHT / 2 + 1.6 * px)),
           slice(int(WIDTH / 2 - 1.7 * px), int(WIDTH / 2 + 1.7 * px)))
    a, b = pr[box], cy[box]
    ma, mb, rel, ok = within_bounds(a, b)
    # The pattern, 3x3-blurred (64 spp of noise would otherwise dominate the correlation).
    la, lb = C.blur(a).mean(axis=-1).ravel(), C.blur(b).mean(axis=-1).ravel()
    corr = float(np.corrcoef(la, lb)[0, 1])
    print("  cloud prism %s cycles %s relMSE %.4f, pattern std %.3f (Cycles %.3f) correlation %.3f"
          % (np.round(ma, 3), np.round(mb, 3), rel, la.std(), lb.std(), corr), flush=True)
    C.check(not warnings, "no warnings: %s" % warnings)
    C.check(lb.std() > 0.02 and corr > 0.95, "the cloud's pattern is Cycles' (correlation > 0.95)")
    C.check(ok, "cloud within 10% per channel and relMSE <= 0.03")


def painted_cloud_scene():
    """A Principled Volume cube (density 1.5) whose Color is a Checker texture of saturated red
    and blue through a Mix Color with a Gradient (a painted fog: the colour varies in hue and in
    brightness), and a Volume Absorption cube beside it whose Color is the same texture's Fac
    through a Color Ramp, lit by the sun in front of the wall."""
    sc = build_scene()
    for ob in [o for o in bpy.data.objects if o.name in NAMES]:
        bpy.data.objects.remove(ob)

    def painted(nt):
        pv = principled(nt, Density=1.5, Anisotropy=0.2)
        checker = nt.nodes.new("ShaderNodeTexChecker")
        checker.inputs["Scale"].default_value = 3.0
        checker.inputs["Color1"].default_value = (0.9, 0.15, 0.1, 1.0)
        checker.inputs["Color2"].default_value = (0.1, 0.3, 0.95, 1.0)
        grad = nt.nodes.new("ShaderNodeTexGradient")
        mix = nt.nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        mix.blend_type = "MULTIPLY"
        mix.inputs["Factor"].default_value = 0.8
        nt.links.new(checker.outputs["Color"], mix.inputs[6])
        nt.links.new(grad.outputs["Color"], mix.inputs[7])
        nt.links.new(mix.outputs[2], pv.inputs["Color"])
        return pv.outputs[0]

    def inked(nt):
        ab = nt.nodes.new("ShaderNodeVolumeAbsorption")
        ab.inputs["Density"].default_value = 1.2
        checker = nt.nodes.new("ShaderNodeTexChecker")
        checker.inputs["Scale"].default_value = 3.0
        ramp = nt.nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.elements[0].color = (0.05, 0.5, 0.2, 1.0)
        ramp.color_ramp.elements[1].color = (0.95, 0.9, 0.3, 1.0)
        nt.links.new(checker.outputs["Fac"], ramp.inputs["Fac"])
        nt.links.new(ramp.outputs["Color"], ab.inputs["Color"])
        return ab.outputs[0]

    C.mesh_object("Painted", C.cube(2.4), volume_material("Painted", painted), location=(-1.6, 0.0, 1.0))
    C.mesh_object("Inked", C.cube(2.4), volume_material("Inked", inked), location=(1.6, 0.0, 1.0))
    return sc


def test_textured_volume_colour_matches_cycles():
    spp, bounces = 64, 16
    cy = C.render_engine(painted_cloud_scene(), "cycles", spp, OUT, "painted", bounces)
    pr = C.render_engine(painted_cloud_scene(), "prism", spp, OUT, "painted", bounces)
    warnings = prism.engine.LAST["warnings"]
    C.check(not warnings, "no warnings: %s" % warnings)
    px = WIDTH / ORTHO
    failures = []
    for name, x in (("Painted", -1.6), ("Inked", 1.6)):
        cx = int(WIDTH / 2 + x * px)
        box = (slice(int(HEIGHT / 2 - 1.1 * px), int(HEIGHT / 2 + 1.1 * px)),
               slice(int(cx - 1.1 * px), int(cx + 1.1 * px)))
        a, b = pr[box], cy[box]
        ma, mb, rel, ok = within_bounds(a, b)
        # The pattern, 3x3-blurred, every channel (the hue varies, not only the brightness).
        la, lb = C.blur(a).ravel(), C.blur(b).ravel()
        corr = float(np.corrcoef(la, lb)[0, 1])
        print("  %s prism %s cycles %s relMSE %.4f, pattern std %.3f (Cycles %.3f) correlation %.3f"
              % (name, np.round(ma, 3), np.round(mb, 3), rel, la.std(), lb.std(), corr), flush=True)
        if not (ok and lb.std() > 0.02 and corr > 0.95):
            failures.append(name)
    C.check(not failures, "each textured-colour volume within 10%% per channel, relMSE <= 0.03 and its pattern Cycles' (correlation > 0.95); failed: %s" % failures)


def test_untranslatable_volume_inputs_are_named():
    sc = build_scene()
    fog = bpy.data.materials["Fog"]
    nt = fog.node_tree
    pv = next(n for n in nt.nodes if n.type == "PRINCIPLED_VOLUME")
    noise = nt.nodes.new("ShaderNodeTexNoise")
    nt.links.new(noise.outputs["Fac"], pv.inputs["Anisotropy"])
    # Emission colours are radiance, not coefficient colours: still constants (warned), on
    # Principled Volume and on an Emission shader added to it.
    glow = bpy.data.materials["Glow"].node_tree
    glow_pv = next(n for n in glow.nodes if n.type == "PRINCIPLED_VOLUME")
    glow_noise = glow.nodes.new("ShaderNodeTexNoise")
    glow.links.new(glow_noise.outputs["Color"], glow_pv.inputs["Emission Color"])
    glow_out = next(n for n in glow.nodes if n.type == "OUTPUT_MATERIAL")
    glow_add = glow.nodes.new("ShaderNodeAddShader")
    glow_emit = glow.nodes.new("ShaderNodeEmission")
    glow.links.new(glow_noise.outputs["Color"], glow_emit.inputs["Color"])
    glow.links.new(glow_pv.outputs[0], glow_add.inputs[0])
    glow.links.new(glow_emit.outputs[0], glow_add.inputs[1])
    glow.links.new(glow_add.outputs[0], glow_out.inputs["Volume"])
    scatter = nt.nodes.new("ShaderNodeVolumeScatter")
    has_phase = hasattr(scatter, "phase")
    if has_phase:  # Blender 4.3+: phase functions other than Henyey-Greenstein
        scatter.phase = "RAYLEIGH"
    smoke = bpy.data.materials["Smoke"].node_tree
    old = next(n for n in smoke.nodes if n.type == "VOLUME_SCATTER")
    smoke.nodes.remove(old)
    smoke_scatter = smoke.nodes.new("ShaderNodeVolumeScatter")
    if has_phase:
        smoke_scatter.phase = "RAYLEIGH"
    add = next(n for n in smoke.nodes if n.type == "ADD_SHADER")
    smoke.links.new(smoke_scatter.outputs[0], add.inputs[0])
    w = sc.world.node_tree
    out = next(n for n in w.nodes if n.type == "OUTPUT_WORLD")
    wv = w.nodes.new("ShaderNodeVolumeScatter")
    w.links.new(wv.outputs[0], out.inputs["Volume"])
    # A volume of density 0 and nothing on Surface: invisible, as in Cycles (not a grey surface).
    empty = volume_material("Empty", lambda nt: principled(nt, Density=0.0).outputs[0])
    C.mesh_object("EmptyBox", C.cube(1.0), empty, location=(0.0, -3.0, 1.0))
    C.use_prism(sc, 16)
    px = C.render_pixels(sc, os.path.join(OUT, "warnings.exr"))
    warnings = prism.engine.LAST["warnings"]
    print("  warnings: %s" % warnings)
    C.check(any("'Fog'" in x and pv.name in x and "'Anisotropy'" in x for x in warnings),
            "a linked Anisotropy is named (material, node, input)")
    C.check(any("'Glow'" in x and glow_pv.name in x and "'Emission Color'" in x for x in warnings),
            "a linked Emission Color is named")
    C.check(any("'Glow'" in x and glow_emit.name in x and "'Color'" in x for x in warnings),
            "a linked Color of an Emission volume shader is named")
    if has_phase:
        C.check(any("'Smoke'" in x and smoke_scatter.name in x and "RAYLEIGH" in x for x in warnings),
                "an unsupported phase function is named")
    C.check(any("world" in x and wv.name in x and "Volume" in x for x in warnings), "the world Volume is named")
    C.check(not any("Empty" in x for x in warnings), "an empty volume is no grey surface and no warning")
    # The box stands in front of the smoke cube (the middle object): hiding it changes nothing.
    bpy.data.objects["EmptyBox"].hide_render = True
    without = C.render_pixels(sc, os.path.join(OUT, "warnings_nobox.exr"))
    a, b = region(px, 2).mean(axis=(0, 1)), region(without, 2).mean(axis=(0, 1))
    C.check(bool(np.all(np.abs(a - b) <= 0.1 * b)), "the empty box is invisible: %s vs %s without it" % (a, b))


def test_light_volume_scatter_visibility_matches_cycles():
    """A light's Ray Visibility > Volume Scatter off: the fog, smoke and glow volumes of the row
    no longer scatter the sun (the wall and floor still see it, and the volumes see the light
    the wall reflects). Against Cycles, as the row test; and the fog's region is much darker
    than with the sun visible to volumes, in both renderers."""
    spp, bounces = 128, 16

    def hidden_sun():
        sc = build_scene()
        bpy.data.objects["Sun"].visible_volume_scatter = False
        return sc

    cy = C.render_engine(hidden_sun(), "cycles", spp, OUT, "volvis", bounces)
    pr = C.render_engine(hidden_sun(), "prism", spp, OUT, "volvis", bounces)
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    seen = C.render_engine(build_scene(), "prism", 32, OUT, "volvis_on", bounces)
    failures = compare(pr, cy, "sun hidden from volumes")
    C.check(not failures, "every volume within 10%% per channel and relMSE <= 0.03 (failed: %s)" % failures)
    dark, lit = region(pr, 0).mean(), region(seen, 0).mean()
    C.check(dark < 0.7 * lit, "the fog without the sun's scattering (%.4f) is darker than with it (%.4f)" % (dark, lit))


if __name__ == "__main__":
    names = sys.argv[1:] or [n for n in list(globals()) if n.startswith("test_")]
    for n in names:
        print(n, flush=True)
        globals()[n]()
    print("all volume tests passed")
