"""The standalone binary on glTF written by Blender's *bundled* exporter (bpy.ops.export_scene.gltf,
outside a render), against Cycles on the same scene. Users (and external checks) get glTF this way
as often as through the add-on, so the loader must read what that exporter writes (Principled
materials as metallic-roughness + KHR_materials_transmission/ior/emissive_strength/specular,
KHR_lights_punctual in its "Standard" photometric units, the camera with its aspect ratio) and
reproduce Cycles. The world is not in glTF: it goes in the material JSON sidecar, as a user would
write it. Both renderers use their default pixel filter (Blackman-Harris 1.5 px).

    .venv-bpy/bin/python tests/addon/test_bundled_gltf.py [TEST_NAME ...]
"""

import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_bundled_")


def principled(name, color, **inputs):
    mat = C.material(name, "ShaderNodeBsdfPrincipled", color)
    node = mat.node_tree.nodes["Principled BSDF"]
    for k, v in inputs.items():
        node.inputs[k].default_value = v
    return mat


def build_scene(width=96, height=72):
    """Principled diffuse, metal and glass balls on a floor; point, spot and sun lights; world."""
    C.reset()
    sc = bpy.context.scene
    floor = principled("Floor", (0.6, 0.6, 0.6), Roughness=0.9)
    clay = principled("Clay", (0.8, 0.3, 0.2), Roughness=0.7)
    gold = principled("Gold", (0.9, 0.7, 0.3), Metallic=1.0, Roughness=0.3)
    glass = principled("Glass", (1.0, 1.0, 1.0), Roughness=0.0, IOR=1.5)
    node = glass.node_tree.nodes["Principled BSDF"]
    node.inputs["Transmission Weight" if "Transmission Weight" in node.inputs else "Transmission"].default_value = 1.0
    C.mesh_object("Floor", C.plane(12.0), floor)
    C.mesh_object("ClayBall", C.sphere(0.7), clay, location=(-1.6, 0.3, 0.7), smooth=True)
    C.mesh_object("GoldBall", C.sphere(0.7), gold, location=(0.0, 0.8, 0.7), smooth=True)
    C.mesh_object("GlassBall", C.sphere(0.7), glass, location=(1.6, 0.0, 0.7), smooth=True)
    C.light("Point", "POINT", 300.0, (-3.0, -3.0, 3.0), shadow_soft_size=0.0)
    C.light("Spot", "SPOT", 800.0, (1.0, -3.0, 4.0), rotation=(0.6, 0.15, 0.0), spot_size=0.9, spot_blend=0.3,
            shadow_soft_size=0.0)
    C.light("Sun", "SUN", 1.5, (0, 0, 5), rotation=(0.4, -0.5, 0.0), angle=0.0)
    C.world((0.15, 0.17, 0.2), 1.0)
    C.camera((0.0, -7.5, 2.6), (0.0, 0.3, 0.6), lens=40.0)
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = width, height, 100
    return sc


def export_bundled(sc, folder, fmt="GLTF_SEPARATE"):
    """Blender's own glTF exporter, as a user runs it (File > Export > glTF: separate files, or
    the exporter's default, one .glb with the images embedded)."""
    path = os.path.join(folder, "scene.glb" if fmt == "GLB" else "scene.gltf")
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format=fmt,
        export_cameras=True,
        export_lights=True,
        export_yup=True,
        export_apply=True,
    )
    world = {"color": [0.15, 0.17, 0.2], "strength": 1.0}
    with open(os.path.join(folder, "scene.materials.json"), "w") as f:
        json.dump({"version": 1, "world": world}, f)
    return path


def render_both(sc, name, spp, fmt="GLTF_SEPARATE"):
    """Cycles on the scene, then Prism on the bundled exporter's glTF of it:
    (prism RGB, cycles RGB, path of the glTF)."""
    C.use_cycles(sc, spp)
    sc.cycles.pixel_filter_type = "BLACKMAN_HARRIS"
    sc.cycles.filter_width = 1.5
    cycles = C.render_pixels(sc, os.path.join(OUT, "%s_cycles.exr" % name))[..., :3]
    folder = tempfile.mkdtemp(prefix="export_", dir=OUT)
    gltf = export_bundled(sc, folder, fmt)
    out = os.path.join(folder, "prism.exr")
    h, w = cycles.shape[:2]
    run = subprocess.run(
        [C.BINARY, "render", gltf, "-o", out, "--spp", str(spp), "--width", str(w), "--height", str(h),
         # Cycles' 8 bounces (use_cycles) are path depth 9.
         "--max-depth", "9", "--threads", "2", "--progress", "none"],
        capture_output=True, text=True,
    )
    C.check(run.returncode == 0, "prism renders the bundled exporter's glTF: %s" % run.stderr.strip()[-400:])
    for line in run.stderr.splitlines():
        print("  prism: " + line)
    prism = C.read_exr(out)[..., :3]
    C.check(prism.shape == cycles.shape, "same image size %s vs %s" % (prism.shape, cycles.shape))
    return prism, cycles, gltf


def check_parity(prism, cycles, mean_bound=0.03):
    """Per-channel means within `mean_bound` (3%) and relMSE after a 3x3 blur below 0.005, the
    bounds of the add-on's Cycles parity tests (Cycles against itself with another seed: ~0.002
    here)."""
    ratio = prism.mean(axis=(0, 1)) / cycles.mean(axis=(0, 1))
    rel = C.rel_mse(C.blur(prism), C.blur(cycles))
    print("  means prism %s cycles %s ratio %s; blurred relMSE %.4f"
          % (prism.mean(axis=(0, 1)), cycles.mean(axis=(0, 1)), ratio, rel))
    C.check(np.all(np.abs(ratio - 1.0) < mean_bound), "channel means within %.1f%%: %s" % (mean_bound * 100, ratio))
    C.check(rel < 0.005, "relMSE after 3x3 blur %.4f < 0.005" % rel)


def test_bundled_exporter_matches_cycles():
    """Principled diffuse, metal and glass; point, spot and sun lights; the world from the sidecar."""
    prism, cycles, gltf = render_both(build_scene(), "lights", 256)
    with open(gltf) as f:
        doc = json.load(f)
    kinds = sorted(l["type"] for l in doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", []))
    C.check(kinds == ["directional", "point", "spot"], "the bundled exporter wrote the three lights: %s" % kinds)
    check_parity(prism, cycles)


def emission_checker_scene():
    """An emissive panel (Principled Emission Strength 8 -> KHR_materials_emissive_strength) as
    the only lamp besides a dim world, a generated 8-bit checker image (0.8 / 0.1, green dark
    checks) magnified on the floor, and rough glass (roughness 0.2)."""
    sc = build_scene()
    for name in ("Point", "Spot", "Sun", "GoldBall"):
        bpy.data.objects.remove(bpy.data.objects[name])
    panel = principled("Panel", (0.0, 0.0, 0.0), Roughness=1.0)
    node = panel.node_tree.nodes["Principled BSDF"]
    emission = "Emission Color" if "Emission Color" in node.inputs else "Emission"
    node.inputs[emission].default_value = (1.0, 0.9, 0.8, 1.0)
    node.inputs["Emission Strength"].default_value = 8.0
    C.mesh_object("Panel", C.plane(2.0), panel, location=(0.0, 1.0, 3.5), rotation=(3.14159, 0.0, 0.0))
    img = bpy.data.images.new("Checker", 64, 64)
    px = np.zeros((64, 64, 4), np.float32)
    yy, xx = np.mgrid[0:64, 0:64]
    on = ((xx // 8 + yy // 8) % 2).astype(bool)
    px[..., 0] = np.where(on, 0.8, 0.1)
    px[..., 1] = np.where(on, 0.8, 0.3)
    px[..., 2] = np.where(on, 0.8, 0.1)
    px[..., 3] = 1.0
    img.pixels.foreach_set(px.ravel())
    img.pack()
    floor = bpy.data.materials["Floor"]
    tex = floor.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    floor.node_tree.links.new(tex.outputs["Color"], floor.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    bpy.data.objects["Floor"].data.uv_layers.new(name="UVMap")  # unit square per face: 8x8 checks
    glass = bpy.data.materials["Glass"].node_tree.nodes["Principled BSDF"]
    glass.inputs["Roughness"].default_value = 0.2
    return sc


def test_bundled_emission_texture_rough_glass():
    """`emission_checker_scene` through the bundled exporter (a .glb with the image embedded as
    PNG, the exporter's default format). Same bounds as above, but 3.5% for the means: the
    renderer filters a plain glTF file's 8-bit sRGB textures as the glTF specification asks,
    decoding before interpolating, and Cycles interpolates the encoded values and decodes
    after, which darkens the blend between a light and a dark texel. Magnified 8x8-texel
    checks make the floor about 3% brighter than in Cycles (image means 1.031 / 1.015 / 1.027);
    with Closest interpolation on the image node (the exporter writes a NEAREST sampler) the
    floor's ratio is 0.999, and a plain floor 0.997. The add-on asks for Cycles' filtering
    (the test below)."""
    prism, cycles, _ = render_both(emission_checker_scene(), "emission", 256, fmt="GLB")
    check_parity(prism, cycles, mean_bound=0.035)


def test_addon_filters_8bit_textures_as_cycles():
    """`emission_checker_scene` rendered through the add-on, which translates the Image Texture
    node as a shading graph whose 8-bit sRGB images are filtered in their encoded values and
    decoded after, as in Cycles (and asks for the same of any plain glTF texture it writes:
    material JSON `render.texture_filtering: "cycles"`). The floor (lower two thirds of the
    image) must match Cycles' within 1% per channel: measured 2026-12-04 0.9991 / 0.9995 /
    0.9993 (image 0.998 / 0.998 / 0.998, blurred relMSE 0.0001; Prism at depth 9 = Cycles' 8
    bounces). With the graph's images decoded before filtering, as the glTF specification
    asks, the floor read 1.018 / 1.009 / 1.015 (at depth 8, where it read 0.9987 / 0.9991 /
    0.9989 filtered as Cycles)."""
    C.enable_addon()  # this file's other tests run the binary without the add-on
    spp = 256
    sc = emission_checker_scene()
    C.use_cycles(sc, spp)
    sc.cycles.pixel_filter_type = "BLACKMAN_HARRIS"
    sc.cycles.filter_width = 1.5
    cycles = C.render_pixels(sc, os.path.join(OUT, "addon_checker_cycles.exr"))[..., :3]
    C.use_prism(sc, spp)
    sc.prism.max_depth = C.prism_depth(8)  # use_cycles' 8 bounces
    sc.prism.filter_type = "BLACKMAN_HARRIS"
    sc.prism.filter_width = 1.5
    prism = C.render_pixels(sc, os.path.join(OUT, "addon_checker_prism.exr"))[..., :3]
    lower = slice(prism.shape[0] // 3, None)
    floor = prism[lower].mean(axis=(0, 1)) / cycles[lower].mean(axis=(0, 1))
    print("  lower two thirds (floor): prism / cycles %s" % floor)
    C.check(np.all(np.abs(floor - 1.0) < 0.01), "floor means within 1%%: %s" % floor)
    check_parity(prism, cycles, mean_bound=0.015)


if __name__ == "__main__":
    from runner_util import run_tests

    run_tests("bundled glTF exporter tests", globals())
