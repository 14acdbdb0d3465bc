#!/usr/bin/env python3
"""Render a glTF scene with Blender Cycles (CPU) as a reference / speed baseline for Prism.

Run with the bpy wheel (Blender 5.0 as a Python module):
    python3 -m venv /work/venv-bpy && /work/venv-bpy/bin/pip install bpy==5.0.1 numpy
    /work/venv-bpy/bin/python bench/cycles_reference.py scenes/cornell/cornell.gltf \
        --out /tmp/cornell_cycles.exr --width 256 --height 256 --spp 64 --threads 2
(`blender -b --factory-startup -P bench/cycles_reference.py -- <same args>` should work too; untested).

The last stdout line is one JSON object:
    {"engine":"cycles","seconds":..,"width":..,"height":..,"spp":..,"threads":..,"samples_per_second":..}
"seconds" is the wall time of bpy.ops.render.render() only (Cycles scene sync, BVH build and path
tracing), excluding Blender start-up, glTF import, scene setup and EXR writing. The image is a float32
OPEN_EXR of the raw scene-linear render (view transform Standard; EXR is written linear anyway).
Diagnostics (imported material / light values) go to stderr.

Render settings: Cycles CPU, fixed sample count (adaptive sampling off), no denoising, light tree
on (the default), default film filter (Blackman-Harris 1.5 px), all bounce limits (total, diffuse,
glossy, transmission, volume, transparent) = --max-bounces, caustics on (default), and none of
Cycles' biasing defaults: no light clamping (default indirect clamp 10; --clamp-indirect 10 restores
it) and Filter Glossy 0 (default 1.0; --blur-glossy 1 restores it).
World is black unless --world-color is given. Defaults for width/height/spp/max-bounces/world come
from <scene>.materials.json next to the glTF when it exists (Prism's sidecar), else 256/256/64/16.

How the bundled glTF importer (io_scene_gltf2, Blender 5.0.1) maps what Prism cares about
(paths relative to bpy/5.0/scripts/addons_core/io_scene_gltf2/; this script prints the imported
values to stderr so they can be re-checked):
- Emission (blender/imp/pbrMetallicRoughness.py:484-522): Principled "Emission Strength" =
  KHR_materials_emissive_strength.emissiveStrength (default 1); a grey emissiveFactor [k,k,k] is folded
  into the strength (strength *= k, colour = 1), otherwise "Emission Color" = emissiveFactor.
  So colour x strength = glTF emissiveFactor x emissiveStrength, which Cycles uses as radiance
  (W m^-2 sr^-1 in Blender units) -- no 683 or pi factor for emissive materials.
  Cornell "Light": Emission Color (1,1,1), Emission Strength 15.
- KHR_materials_specular (pbrMetallicRoughness.py:317-350, factor at :331): "Specular IOR Level" = 0.5 * specularFactor
  (absent extension -> 0.5, the neutral value), "Specular Tint" = specularColorFactor. specularFactor 0
  -> level 0: no dielectric specular lobe, i.e. pure Lambertian diffuse (Principled v2 diffuse).
- KHR_materials_transmission (pbrMetallicRoughness.py:219-254): "Transmission Weight" = transmissionFactor.
  KHR_materials_ior (pbrMetallicRoughness.py:120-123): "IOR" = ior (default 1.5 when absent).
  There is no thin-walled/volume handling unless KHR_materials_volume is present: a closed mesh with
  transmission renders as solid glass in Cycles.
- metallicFactor/roughnessFactor -> "Metallic"/"Roughness"; baseColorFactor -> "Base Color".
- KHR_lights_punctual (blender/imp/light.py:57-77, 137-143; PBR_WATTS_TO_LUMENS = 683 in
  blender/com/conversion.py:10), default lighting mode 'SPEC' ("Standard"):
    point/spot: energy [W] = intensity [cd] / 683 * 4 pi      (light.py:71)
    sun:        energy [W/m^2] = intensity [lux] / 683         (light.py:60)
    spot_size = 2 * outerConeAngle; spot_blend = 1 - innerConeAngle / outerConeAngle
  'COMPAT' drops the 683, 'RAW' copies intensity unchanged. Imported lights get shadow_soft_size 0
  (true point/spot lights; checked in 5.0.1). A Blender spot's power is specified as if it were a point
  light (P / (4 pi) W/sr inside the cone). The exporter does the inverse (blender/exp/lights.py:145-159):
  point/spot intensity = W / (4 pi) * 683, sun = W/m^2 * 683, outerConeAngle = spot_size / 2,
  innerConeAngle = outer - outer * spot_blend (blender/exp/light_spots.py:28-47). Cycles' radiant
  intensity of a P-watt point light is P / (4 pi) W/sr, so glTF cd / 683 = Cycles W/sr.
- Cycles mesh emission is TWO-SIDED (a Principled/Emission shader emits from back faces too), whatever
  glTF doubleSided says (the importer only maps it to use_backface_culling, which Cycles ignores). In the
  Cornell scene the light quad's back face lights the 2 cm gap under the ceiling: +13% image mean vs
  front-only emission. --one-sided-emission multiplies the strength by (1 - Backfacing) for emissive
  materials with doubleSided false.
- Camera (blender/imp/camera.py:56-58): angle_y = yfov, sensor_fit VERTICAL; aspectRatio is ignored
  (the render resolution decides the aspect).
"""

import argparse
import json
import os
import sys
import tempfile
import time


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("gltf", help="glTF/GLB scene to import")
    p.add_argument("--out", default=None, help="output EXR path (default: /tmp/<stem>_cycles.exr)")
    p.add_argument("--width", type=int, default=None)
    p.add_argument("--height", type=int, default=None)
    p.add_argument("--spp", type=int, default=None, help="samples per pixel")
    p.add_argument("--threads", type=int, default=2, help="render threads (0 = all cores)")
    p.add_argument("--max-bounces", type=int, default=None, help="all Cycles bounce limits (default 16)")
    p.add_argument("--world-color", type=float, nargs=3, default=None, metavar=("R", "G", "B"))
    p.add_argument("--world-strength", type=float, default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--clamp-indirect", type=float, default=0.0, help="Cycles indirect clamp (0 = off)")
    p.add_argument("--blur-glossy", type=float, default=0.0, help="Cycles Filter Glossy (0 = off)")
    p.add_argument("--one-sided-emission", action="store_true",
                   help="emissive materials that are not doubleSided emit from the front face only "
                        "(Cycles mesh emission is two-sided by default)")
    p.add_argument("--json", default=None, help="also write the JSON result line to this file")
    p.add_argument("--quiet", action="store_true", help="no diagnostics on stderr")
    return p.parse_args(argv)


def load_sidecar(gltf_path):
    stem = os.path.splitext(gltf_path)[0]
    path = stem + ".materials.json"
    if os.path.exists(path):
        with open(path) as f:
            return json.load(f)
    return {}


def log(args, *msg):
    if not args.quiet:
        print(*msg, file=sys.stderr)


def main():
    args = parse_args()
    gltf_path = os.path.abspath(args.gltf)
    side = load_sidecar(gltf_path)
    rs = side.get("render", {})
    ws = side.get("world", {})
    width = args.width or rs.get("width", 256)
    height = args.height or rs.get("height", 256)
    spp = args.spp or rs.get("spp", 64)
    bounces = args.max_bounces if args.max_bounces is not None else rs.get("max_depth", 16)
    world_color = args.world_color if args.world_color is not None else ws.get("color", [0.0, 0.0, 0.0])
    world_strength = args.world_strength if args.world_strength is not None else ws.get("strength", 1.0)
    out = os.path.abspath(
        args.out or os.path.join(tempfile.gettempdir(), os.path.basename(os.path.splitext(gltf_path)[0]) + "_cycles.exr")
    )

    # Keep Blender from writing user config/scripts anywhere persistent.
    os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="bpy_user_"))
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)

    t0 = time.perf_counter()
    res = bpy.ops.import_scene.gltf(filepath=gltf_path)
    if "FINISHED" not in res:
        raise SystemExit("glTF import failed: %r" % (res,))
    import_seconds = time.perf_counter() - t0

    scene = bpy.context.scene
    cams = [o for o in scene.objects if o.type == "CAMERA"]
    if not cams:
        raise SystemExit("scene has no camera")
    scene.camera = cams[0]

    # --- render settings
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = spp
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    if hasattr(cy, "use_preview_denoising"):
        cy.use_preview_denoising = False
    cy.seed = args.seed
    cy.max_bounces = bounces
    cy.diffuse_bounces = bounces
    cy.glossy_bounces = bounces
    cy.transmission_bounces = bounces
    cy.volume_bounces = bounces
    cy.transparent_max_bounces = bounces
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = args.clamp_indirect
    cy.blur_glossy = args.blur_glossy
    # light tree (cy.use_light_tree), film filter, caustics: Cycles defaults, left alone.
    scene.render.resolution_x = width
    scene.render.resolution_y = height
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    scene.render.film_transparent = False
    scene.render.threads_mode = "FIXED" if args.threads > 0 else "AUTO"
    if args.threads > 0:
        scene.render.threads = args.threads
    scene.render.use_persistent_data = False

    # --- world
    world = bpy.data.worlds.new("World")
    scene.world = world
    if world.node_tree is None:  # 3.x/4.x; 5.0 worlds always have nodes (use_nodes is deprecated)
        world.use_nodes = True
    bg = next(n for n in world.node_tree.nodes if n.type == "BACKGROUND")
    bg.inputs["Color"].default_value = (*world_color, 1.0)
    bg.inputs["Strength"].default_value = world_strength

    # --- raw scene-linear output
    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    scene.display_settings.display_device = "sRGB"
    im = scene.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    im.color_mode = "RGBA"

    if args.one_sided_emission:
        make_emission_one_sided(args)

    describe_scene(args, scene)

    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    seconds = time.perf_counter() - t0

    bpy.data.images["Render Result"].save_render(filepath=out, scene=scene)
    log(args, "import %.3f s, render %.3f s, wrote %s" % (import_seconds, seconds, out))

    result = {
        "engine": "cycles",
        "seconds": round(seconds, 4),
        "width": width,
        "height": height,
        "spp": spp,
        "threads": args.threads,
        "samples_per_second": round(width * height * spp / seconds, 1),
    }
    line = json.dumps(result)
    if args.json:
        with open(args.json, "w") as f:
            f.write(line + "\n")
    sys.stdout.flush()
    print(line, flush=True)


def make_emission_one_sided(args):
    """Emission Strength *= (1 - Backfacing) for single-sided (use_backface_culling) emissive materials."""
    import bpy

    for mat in bpy.data.materials:
        if not mat.node_tree or not mat.use_backface_culling:
            continue
        nt = mat.node_tree
        for node in list(nt.nodes):
            if node.type != "BSDF_PRINCIPLED":
                continue
            sock = node.inputs["Emission Strength"]
            if sock.is_linked or sock.default_value == 0.0:
                continue
            geo = nt.nodes.new("ShaderNodeNewGeometry")
            front = nt.nodes.new("ShaderNodeMath")
            front.operation = "SUBTRACT"
            front.inputs[0].default_value = 1.0
            nt.links.new(geo.outputs["Backfacing"], front.inputs[1])
            mul = nt.nodes.new("ShaderNodeMath")
            mul.operation = "MULTIPLY"
            mul.inputs[1].default_value = sock.default_value
            nt.links.new(front.outputs[0], mul.inputs[0])
            nt.links.new(mul.outputs[0], sock)
            if hasattr(mat, "cycles") and hasattr(mat.cycles, "emission_sampling"):
                mat.cycles.emission_sampling = "FRONT"
            log(args, "material %s: emission made front-only (strength %g)" % (mat.name, mul.inputs[1].default_value))


def _val(v):
    try:
        return [round(x, 4) for x in v]
    except TypeError:
        return round(v, 4) if isinstance(v, float) else v


def describe_scene(args, scene):
    """Print what the importer produced (materials, lights, camera) to stderr."""
    if args.quiet:
        return
    sockets = [
        "Base Color", "Metallic", "Roughness", "IOR", "Specular IOR Level", "Specular Tint",
        "Transmission Weight", "Emission Color", "Emission Strength",
    ]
    import bpy

    for mat in bpy.data.materials:
        if not mat.node_tree:
            continue
        for node in mat.node_tree.nodes:
            if node.type != "BSDF_PRINCIPLED":
                continue
            vals = {}
            for s in sockets:
                inp = node.inputs.get(s)
                if inp is None:
                    continue
                vals[s] = "<linked>" if inp.is_linked else _val(inp.default_value)
            extra = {}
            if hasattr(mat, "cycles") and hasattr(mat.cycles, "emission_sampling"):
                extra["emission_sampling"] = mat.cycles.emission_sampling
            extra["backface_culling"] = mat.use_backface_culling
            log(args, "material %-8s %s %s" % (mat.name, json.dumps(vals), json.dumps(extra)))
    for ob in scene.objects:
        if ob.type == "LIGHT":
            L = ob.data
            d = {"type": L.type, "energy": L.energy, "color": list(L.color),
                 "shadow_soft_size": L.shadow_soft_size}
            if L.type == "SPOT":
                d.update(spot_size=L.spot_size, spot_blend=L.spot_blend)
            log(args, "light %s %s" % (ob.name, json.dumps(d)))
        elif ob.type == "CAMERA":
            c = ob.data
            log(args, "camera %s angle_y=%.4f sensor_fit=%s loc=%s" % (
                ob.name, c.angle_y, c.sensor_fit, _val(tuple(ob.matrix_world.translation))))
        elif ob.type == "MESH":
            log(args, "mesh %-12s verts=%d polys=%d world_bbox_z=[%.3f,%.3f]" % (
                ob.name, len(ob.data.vertices), len(ob.data.polygons),
                min((ob.matrix_world @ v.co).z for v in ob.data.vertices),
                max((ob.matrix_world @ v.co).z for v in ob.data.vertices)))


if __name__ == "__main__":
    main()
