"""Blender's soft lights against Cycles in the bpy wheel (Blender 5.0.1): point and spot lights
with a Radius (Soft Falloff on and off), the sun's Angle, light Temperature, a Blackbody node in
a light's node tree, and Exposure. Run by run_addon_tests.sh:

    .venv-bpy/bin/python tests/addon/test_lights.py [TEST_NAME ...]

The penumbra scene: a white floor seen from straight above by an orthographic camera, and a
black plate (hidden from the camera, Blender's Ray Visibility) over the half x < 0 at height
PLATE_Z, under a light over the edge. The shadow edge's 10-90% width along x is the penumbra.
"""

import math
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_lights_")
PLATE_Z = 1.5
WIDTH, HEIGHT, SCALE = 128, 16, 4.0  # pixels; the view spans SCALE metres along x


def penumbra_scene(plate_z=PLATE_Z):
    C.reset()
    sc = bpy.context.scene
    C.world((0.0, 0.0, 0.0), 0.0)
    white = C.material("White", "ShaderNodeBsdfDiffuse", (0.8, 0.8, 0.8))
    black = C.material("Black", "ShaderNodeBsdfDiffuse", (0.0, 0.0, 0.0))
    C.mesh_object("Floor", C.plane(20.0), white)
    plate = C.mesh_object("Plate", C.plane(10.0), black, location=(-5.0, 0.0, plate_z))
    plate.visible_camera = False
    cam = C.camera((0.0, 0.0, 6.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = SCALE
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = WIDTH, HEIGHT, 100
    return sc


def profile(img):
    """Luminance along x, averaged over the rows."""
    lum = 0.2126 * img[..., 0] + 0.7152 * img[..., 1] + 0.0722 * img[..., 2]
    return lum.mean(axis=0)


def edge_width(p):
    """Distance in pixels between where the profile crosses 10% and 90% of the lit level (the
    mean of the last eighth), each crossing linearly interpolated."""
    lit = float(p[-len(p) // 8:].mean())
    q = p / lit

    def crossing(level):
        i = int(np.argmax(q >= level))
        if i == 0:
            return 0.0
        return i - 1 + (level - q[i - 1]) / max(q[i] - q[i - 1], 1e-9)

    return crossing(0.9) - crossing(0.1)


def compare(sc, name, spp=64, width_tol=0.10, mean_tol=0.02):
    """Penumbra width and image mean, Prism against Cycles (both unbiased, same spp)."""
    cyc = C.render_engine(sc, "cycles", spp, OUT, name, 2)
    pri = C.render_engine(sc, "prism", spp, OUT, name, 2)
    wc, wp = edge_width(profile(cyc)), edge_width(profile(pri))
    mc, mp = float(cyc.mean()), float(pri.mean())
    print("  %s: penumbra %.1f px (Cycles %.1f), mean %.4f (Cycles %.4f)" % (name, wp, wc, mp, mc))
    C.check(abs(wp / wc - 1.0) <= width_tol, "%s: penumbra width %.1f px within %d%% of Cycles' %.1f px"
            % (name, wp, round(width_tol * 100), wc))
    C.check(abs(mp / mc - 1.0) <= mean_tol, "%s: mean %.4f within %d%% of Cycles' %.4f"
            % (name, mp, round(mean_tol * 100), mc))
    return wp, wc


def test_point_radius():
    widths = []
    for radius in (0.25, 0.5):
        sc = penumbra_scene()
        C.light("Lamp", "POINT", 400.0, (0.0, 0.0, 3.0), shadow_soft_size=radius)
        widths.append(compare(sc, "point_r%g" % radius)[0])
    # A point light of radius 0 has a sharp edge: the radius is what widens it.
    C.check(widths[1] > 1.6 * widths[0] > 0.0, "radius 0.5 penumbra %.1f px about twice radius 0.25's %.1f px"
            % (widths[1], widths[0]))


def test_point_sphere_without_soft_falloff():
    sc = penumbra_scene()
    lamp = C.light("Lamp", "POINT", 400.0, (0.0, 0.0, 3.0), shadow_soft_size=0.5)
    lamp.data.use_soft_falloff = False
    compare(sc, "point_sphere")


def test_spot_radius():
    sc = penumbra_scene()
    C.light("Spot", "SPOT", 400.0, (0.0, 0.0, 3.0), shadow_soft_size=0.4,
            spot_size=math.radians(150.0), spot_blend=0.1)
    compare(sc, "spot_r0.4")


def test_sun_angle():
    sc = penumbra_scene(plate_z=3.0)
    C.light("Sun", "SUN", 3.0, (0.0, 0.0, 5.0), angle=math.radians(10.0))
    compare(sc, "sun_10deg")


def test_area_spread():
    """An area light's Spread (Blender's soft-box slats): a 0.5 m square, 2 m over the floor,
    spread 30, 90 and the default 180 degrees. The floor seen from above shows the cone's pool
    of light (30 degrees: a disc of radius about 2 tan(15) + 0.25 = 0.79 m); its profile along
    x and the image mean against Cycles'. (Cycles 3.x emits every area light pi/4 as strongly
    as 4.x for the same power: without the add-on's factor the 180-degree light was 1.273x
    Cycles 3.4's.)"""
    centre = {}
    for degrees in (30.0, 90.0, 180.0):
        sc = penumbra_scene()
        bpy.data.objects["Plate"].hide_render = True
        sc.render.resolution_y = 64
        bpy.data.objects["Camera"].data.ortho_scale = SCALE
        area = C.light("Panel", "AREA", 100.0, (0.0, 0.0, 2.0), size=0.5)
        area.data.spread = math.radians(degrees)
        cyc = C.render_engine(sc, "cycles", 64, OUT, "spread%d" % degrees, 2)
        pri = C.render_engine(sc, "prism", 64, OUT, "spread%d" % degrees, 2)
        pc, pp = profile(cyc), profile(pri)
        mc, mp = float(cyc.mean()), float(pri.mean())
        print("  spread %g: mean %.4f (Cycles %.4f), centre %.3f (Cycles %.3f), edge %.4f (Cycles %.4f)"
              % (degrees, mp, mc, pp[60:68].mean(), pc[60:68].mean(), pp[:8].mean(), pc[:8].mean()))
        C.check(abs(mp / mc - 1.0) < 0.03, "spread %g: mean %.4f within 3%% of Cycles' %.4f" % (degrees, mp, mc))
        # The profile, in 16 blocks along x: the pool's shape.
        centre[degrees] = float(pp[60:68].mean())
        bc, bp = pc.reshape(16, -1).mean(axis=1), pp.reshape(16, -1).mean(axis=1)
        worst = float(np.max(np.abs(bp - bc)) / bc.max())
        C.check(worst < 0.04, "spread %g: profile within 4%% of Cycles' peak in every block (worst %.3f)" % (degrees, worst))
    # The same power in a narrower cone: a brighter pool (a Lambertian panel would light both
    # alike).
    C.check(centre[30.0] > 2.5 * centre[90.0], "the 30-degree pool's centre (%.2f) is far brighter than the "
            "90-degree one's (%.2f)" % (centre[30.0], centre[90.0]))


def test_light_ray_visibility():
    """A light's Ray Visibility (Diffuse, Glossy off) against Cycles: a white floor and a
    glossy metal ball under a point light of radius 0.3 and an area light, both with the same
    visibility. Glossy off: the ball shows no highlight and reflects no light, the floor is
    lit as before; Diffuse off: the floor gets no direct light, the ball's reflection stays.
    Means and 8x8 block means against Cycles (256 spp, 4 bounces)."""
    images = {}
    for case in ("all", "no_glossy", "no_diffuse"):
        C.reset()
        sc = bpy.context.scene
        C.world((0.0, 0.0, 0.0), 0.0)
        white = C.material("White", "ShaderNodeBsdfDiffuse", (0.8, 0.8, 0.8))
        metal = C.material("Metal", "ShaderNodeBsdfPrincipled", (0.9, 0.7, 0.4), Metallic=1.0, Roughness=0.15)
        C.mesh_object("Floor", C.plane(20.0), white)
        C.mesh_object("Ball", C.sphere(0.8), metal, location=(0.0, 0.0, 0.8), smooth=True)
        point = C.light("Lamp", "POINT", 600.0, (1.5, -1.5, 3.0), shadow_soft_size=0.3)
        panel = C.light("Panel", "AREA", 300.0, (-2.0, 1.0, 2.5), rotation=(0.6, -0.5, 0.0), size=1.0)
        for ob in (point, panel):
            ob.visible_glossy = case != "no_glossy"
            ob.visible_diffuse = case != "no_diffuse"
        C.camera((0.0, -6.0, 3.0), (0.0, 0.0, 0.6), lens=50.0)
        sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 96, 64, 100
        # 256 spp: with Diffuse off the floor is lit only by the ball's glossy reflection of
        # the lamps (caustic paths), whose 8 x 8 block means at 64 spp scatter to the 6%
        # bound from seed to seed (measured 0.045-0.060 in Prism, no bias: 12 seeds at 256
        # spp agree within 0.3% with and without splitting).
        cyc = C.render_engine(sc, "cycles", 256, OUT, "vis_" + case, 4)
        pri = C.render_engine(sc, "prism", 256, OUT, "vis_" + case, 4)
        images[case] = (pri, cyc)
        mc, mp = cyc.mean(axis=(0, 1)), pri.mean(axis=(0, 1))
        print("  %s: mean %s (Cycles %s)" % (case, mp.round(4), mc.round(4)))
        C.check(np.all(np.abs(mp / mc - 1.0) < 0.05), "%s: means within 5%% of Cycles'" % case)

        def blocks(a):
            return a.reshape(8, 8, 12, 8, 3).mean(axis=(1, 3))

        worst = float(np.max(np.abs(blocks(pri) - blocks(cyc))) / blocks(cyc).max())
        C.check(worst < 0.06, "%s: 8x8 block means within 6%% of Cycles' peak (worst %.3f)" % (case, worst))
    # The switches matter: each removes light the full setup has, in both renderers.
    for k in (0, 1):
        name = ("prism", "cycles")[k]
        full, ng, nd = (images[c][k].mean() for c in ("all", "no_glossy", "no_diffuse"))
        C.check(ng < 0.97 * full and nd < 0.8 * full, "%s: glossy off %.4f and diffuse off %.4f below all %.4f"
                % (name, ng, nd, full))


def chromaticity(img):
    rgb = img.reshape(-1, 3).mean(axis=0)
    m = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
    xyz = m @ rgb
    return xyz[:2] / xyz.sum()


def colour_scene():
    sc = penumbra_scene()
    bpy.data.objects.remove(bpy.data.objects["Plate"])
    sc.render.resolution_x, sc.render.resolution_y = 32, 16
    return sc


def warm_light(setup):
    """A 3000 K point light made warm by `setup`: "temperature" (5.0: the light's own
    Temperature) or "blackbody" (a Blackbody node on the light's Emission colour)."""
    lamp = C.light("Lamp", "POINT", 400.0, (0.0, 0.0, 3.0), shadow_soft_size=0.1)
    if setup == "temperature":
        lamp.data.use_temperature = True
        lamp.data.temperature = 3000.0
    else:
        lamp.data.use_nodes = True
        nt = lamp.data.node_tree
        em = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeEmission")
        bb = nt.nodes.new("ShaderNodeBlackbody")
        bb.inputs["Temperature"].default_value = 3000.0
        nt.links.new(bb.outputs[0], em.inputs["Color"])
    return lamp


def test_temperature_blackbody_exposure():
    setups = ["blackbody"]
    if "use_temperature" in bpy.types.Light.bl_rna.properties:
        setups.insert(0, "temperature")
    for setup in setups:
        sc = colour_scene()
        lamp = warm_light(setup)
        cyc = C.render_engine(sc, "cycles", 16, OUT, setup, 2)
        pri = C.render_engine(sc, "prism", 16, OUT, setup, 2)
        xc, xp = chromaticity(cyc), chromaticity(pri)
        C.check(float(np.abs(xc - xp).max()) <= 0.01, "%s 3000 K: chromaticity %s within 0.01 of Cycles' %s"
                % (setup, np.round(xp, 4), np.round(xc, 4)))
        C.check(abs(pri.mean() / cyc.mean() - 1.0) <= 0.02, "%s: mean %.4f within 2%% of Cycles' %.4f"
                % (setup, pri.mean(), cyc.mean()))
    if "exposure" in bpy.types.Light.bl_rna.properties:
        base = pri.mean()
        lamp.data.exposure = 1.0
        brighter = C.render_engine(sc, "prism", 16, OUT, "exposure", 2)
        C.check(abs(brighter.mean() / base - 2.0) <= 0.02, "Exposure 1 doubles the light: %.4f / %.4f = %.4f"
                % (brighter.mean(), base, brighter.mean() / base))


def test_light_visible_to_camera_and_in_mirror():
    """A soft point light seen by the camera (Ray Visibility > Camera on) and reflected in a
    mirror floor, against Cycles: the bright disc's mean and size."""
    C.reset()
    sc = bpy.context.scene
    C.world((0.0, 0.0, 0.0), 0.0)
    mirror = C.material("Mirror", "ShaderNodeBsdfGlossy", (0.9, 0.9, 0.9), Roughness=0.0)
    C.mesh_object("Floor", C.plane(20.0), mirror)
    lamp = C.light("Lamp", "POINT", 200.0, (0.6, 0.0, 1.0), shadow_soft_size=0.3)
    lamp.visible_camera = True
    C.camera((-3.0, 0.0, 2.0), (0.3, 0.0, 0.5), lens=35.0)
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 48, 100
    cyc = C.render_engine(sc, "cycles", 16, OUT, "visible", 2)
    pri = C.render_engine(sc, "prism", 16, OUT, "visible", 2)
    lit_c = (cyc.mean(axis=2) > 1.0).sum()
    lit_p = (pri.mean(axis=2) > 1.0).sum()
    C.check(lit_c > 20 and abs(lit_p / lit_c - 1.0) <= 0.1, "light and its reflection cover %d px (Cycles %d)"
            % (lit_p, lit_c))
    C.check(abs(pri.mean() / cyc.mean() - 1.0) <= 0.03, "mean %.4f within 3%% of Cycles' %.4f"
            % (pri.mean(), cyc.mean()))


TESTS = [
    test_light_ray_visibility,
    test_area_spread,
    test_point_radius,
    test_point_sphere_without_soft_falloff,
    test_spot_radius,
    test_sun_angle,
    test_temperature_blackbody_exposure,
    test_light_visible_to_camera_and_in_mirror,
]


def main():
    C.enable_addon()
    # Test names: after "--" under `blender -b ... --python`, else the script's arguments.
    argv = sys.argv
    want = set(argv[argv.index("--") + 1:] if "--" in argv else ([] if "--python" in argv else argv[1:]))
    failed = []
    for t in TESTS:
        if want and t.__name__ not in want:
            continue
        if t is test_point_sphere_without_soft_falloff and "use_soft_falloff" not in bpy.types.PointLight.bl_rna.properties:
            continue
        print("== " + t.__name__, flush=True)
        try:
            t()
        except AssertionError as e:
            print("  FAIL: %s" % e, flush=True)
            failed.append(t.__name__)
    if failed:
        raise SystemExit("failed: " + ", ".join(failed))
    print("all light tests passed")


if __name__ == "__main__":
    main()
