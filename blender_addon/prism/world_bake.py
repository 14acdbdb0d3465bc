# SPDX-License-Identifier: MIT
"""Bakes a world the exporter cannot translate (a Sky Texture of any model, or any world node
graph other than Background <- Environment Texture) into an equirectangular float EXR, by
rendering it with Cycles from Blender itself, so that Prism renders it as its (importance-
sampled) world texture.

How (measured in Blender 5.0.1's bpy wheel and Debian's Blender 3.4.1):
- A temporary scene holding only a panoramic equirectangular camera and a copy of the world is
  rendered with Cycles (`bpy.ops.render.render(scene=..., write_still=True)`), 1 px box filter,
  so each texel is the mean radiance over its cell. This works inside `RenderEngine.render()`
  on the main thread (`blender -b -f`, `bpy.ops.render.render()` from a script, the bpy wheel):
  about 1 s. Under F12 in an interactive Blender, `render()` runs on a job thread: the nested
  render itself works there but removing the temporary datablocks from that thread crashed
  Blender 3.4 (segfault in `bpy.data.scenes.remove`), so off the main thread the world is
  written to a .blend (`bpy.data.libraries.write`) and baked by a background Blender process
  running this file (`blender -b --factory-startup --python world_bake.py -- ...`, 2-3 s).
- The sun disc (the Sky Texture's Nishita / 5.0 single- and multiple-scattering models) is a
  0.545 degree disc about 10^4 times brighter than the sky: at BAKE_WIDTH = 1024 it spans
  1.5 texels, so baked into the image its position would be quantised to a texel, its edge
  smeared by bilinear lookup, its energy noisy. Instead the image is baked with the disc off
  and the disc becomes a directional light of the node's angular diameter (Prism's SunDisc:
  seen by camera and BSDF rays, light-sampled as a cone). Its irradiance and direction are
  measured, not modelled (Cycles' precomputed sun colour is not exposed to Python): a narrow
  perspective view centred on the sun (SUN_WINDOW sun diameters wide, SUN_RES^2 pixels) is
  rendered with the disc on; E = sum (L - L_sky) x the pixel's solid angle over the disc's
  pixels, L_sky the view's border (limb darkening, Strength and any colour multiplier on the
  way are in it), and the direction is the centroid of L - L_sky. The disc's direction guess
  is the node's own (sun elevation and
  rotation) when its Vector input is free; otherwise the disc is left in the image (a warning).
- Bakes are cached by a hash of the world's node graph and these settings in
  <tmp>/prism-world-cache, so a re-render of an unchanged world does not bake again.
"""

import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

try:
    from . import exr
except ImportError:  # run as a script by the background Blender (see _main)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import exr

BAKE_WIDTH, BAKE_HEIGHT = 1024, 512
BAKE_SPP = 4
SUN_RES = 48
SUN_SPP = 16
SUN_WINDOW = 3.0
CACHE_KEEP = 16
# Sky models with a sun disc (3.x: NISHITA; 5.0: SINGLE/MULTIPLE_SCATTERING).
DISC_MODELS = {"NISHITA", "SINGLE_SCATTERING", "MULTIPLE_SCATTERING"}
VERSION = 1  # bumps the cache key when the bake changes


class BakeError(Exception):
    pass


def cache_dir():
    return os.path.join(tempfile.gettempdir(), "prism-world-cache")


# ----------------------------------------------------------------------------- what to bake


def _nodes_of(tree, seen=None):
    """Every node of a node tree and of the groups inside it."""
    seen = set() if seen is None else seen
    for n in tree.nodes:
        yield n
        sub = getattr(n, "node_tree", None)
        if sub is not None and sub.name not in seen:
            seen.add(sub.name)
            yield from _nodes_of(sub, seen)


def sky_nodes(world):
    """Every node of the world's graph (groups included)."""
    nt = getattr(world, "node_tree", None)
    return list(_nodes_of(nt)) if nt is not None else []


def disc_sky(world):
    """The first Sky Texture node with a visible sun disc, or None."""
    for n in sky_nodes(world):
        if n.type == "TEX_SKY" and n.sky_type in DISC_MODELS and n.sun_disc:
            return n
    return None


def sun_direction(node):
    """Blender world direction towards the centre of a sky node's sun disc: elevation above
    the XY plane, rotation clockwise from +Y seen from above (measured: the disc-on minus
    disc-off bake peaks there in 5.0.1 and 3.4.1)."""
    e, r = float(node.sun_elevation), float(node.sun_rotation)
    return (math.cos(e) * math.sin(r), math.cos(e) * math.cos(r), math.sin(e))


def _value(v):
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    try:
        return [_value(x) for x in v]
    except TypeError:
        return getattr(v, "name", str(type(v).__name__))


def _rna_props(struct, depth=0):
    out = {}
    for p in struct.bl_rna.properties:
        k = p.identifier
        if k in {"rna_type", "location", "location_absolute", "width", "height", "dimensions", "select",
                 "show_options", "show_preview", "show_texture", "hide", "color", "use_custom_color",
                 "internal_links", "inputs", "outputs", "parent", "label", "width_hidden", "color_tag"}:
            continue
        try:
            v = getattr(struct, k)
        except Exception:
            continue
        if p.type == "POINTER":
            if v is None:
                out[k] = None
            elif hasattr(v, "filepath") or hasattr(v, "users"):  # an ID: its name (+ file)
                out[k] = [v.name, getattr(v, "filepath", ""), _value(getattr(v, "size", None))]
            elif depth < 2:
                out[k] = _rna_props(v, depth + 1)
        elif p.type != "COLLECTION":
            out[k] = _value(v)
    return out


def _tree_signature(tree, seen):
    nodes = []
    for n in sorted(tree.nodes, key=lambda n: n.name):
        entry = {"name": n.name, "props": _rna_props(n),
                 "in": [[s.identifier, _value(getattr(s, "default_value", None))] for s in n.inputs]}
        sub = getattr(n, "node_tree", None)
        if sub is not None and sub.name not in seen:
            seen.add(sub.name)
            entry["group"] = _tree_signature(sub, seen)
        nodes.append(entry)
    links = sorted([l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier,
                    bool(getattr(l, "is_muted", False))] for l in tree.links)
    return {"nodes": nodes, "links": links}


def world_key(world):
    """A hash of everything the bake depends on: the node graph (every node's settings and
    inputs, groups included), the world's own settings, Blender's version and this module's."""
    import bpy

    sig = {"v": VERSION, "blender": list(bpy.app.version),
           "res": [BAKE_WIDTH, BAKE_HEIGHT, BAKE_SPP, SUN_RES, SUN_SPP, SUN_WINDOW],
           "color": _value(world.color)}
    nt = getattr(world, "node_tree", None)
    if nt is not None:
        sig["tree"] = _tree_signature(nt, set())
    blob = json.dumps(sig, sort_keys=True, default=str).encode()
    return hashlib.sha1(blob).hexdigest()[:20]


# ----------------------------------------------------------------------------- baking (in Blender)


def _setup_scene(bpy, world, name):
    sc = bpy.data.scenes.new(name)
    sc.world = world
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.use_denoising = False
    cy.use_adaptive_sampling = False
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    cy.seed = 0
    sc.render.film_transparent = False
    sc.render.resolution_percentage = 100
    sc.render.pixel_aspect_x = sc.render.pixel_aspect_y = 1.0
    sc.render.use_border = False
    for k in ("use_compositing", "use_sequencer"):
        if hasattr(sc.render, k):
            setattr(sc.render, k, False)
    im = sc.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_depth = "32"
    im.color_mode = "RGB"
    im.exr_codec = "ZIP"
    sc.render.use_file_extension = False
    return sc


def _camera(bpy, sc, name):
    data = bpy.data.cameras.new(name)
    ob = bpy.data.objects.new(name, data)
    sc.collection.objects.link(ob)
    sc.camera = ob
    return ob


def _render(bpy, sc, path):
    sc.render.filepath = path
    res = bpy.ops.render.render(scene=sc.name, write_still=True)
    if "FINISHED" not in res or not os.path.exists(path):
        raise BakeError("Cycles render of the world returned %s" % sorted(res))
    return exr.read_rgba(path)[..., :3].astype(np.float64)


def _set_discs(world, on):
    for n in sky_nodes(world):
        if n.type == "TEX_SKY" and n.sky_type in DISC_MODELS:
            n.sun_disc = on


def bake_here(world, work_dir):
    """Bakes `world` (an original World datablock) with Cycles in this Blender; writes
    work_dir/world.exr; returns {"sun": {...} or None, "disc_in_image": bool}. Must run on the
    main thread (it adds and removes datablocks)."""
    import bpy
    from mathutils import Vector

    made = {"scenes": [], "objects": [], "cameras": [], "worlds": []}
    info = {"sun": None, "disc_in_image": False}
    try:
        w_off = world.copy()
        made["worlds"].append(w_off)
        w_off.name = "PrismBake_" + world.name
        vis = getattr(w_off, "cycles_visibility", None) or getattr(w_off, "visibility", None)
        if vis is not None and hasattr(vis, "camera"):
            vis.camera = True
        sky = disc_sky(world)
        # (5.0 hides the scattering models' Vector input: inputs.get finds no such socket.)
        vec = sky.inputs.get("Vector") if sky is not None else None
        separate_sun = sky is not None and not (vec is not None and vec.is_linked and getattr(vec, "enabled", True))
        info["disc_in_image"] = sky is not None and not separate_sun
        if separate_sun:
            _set_discs(w_off, False)
        sc = _setup_scene(bpy, w_off, "PrismWorldBake")
        made["scenes"].append(sc)
        cam = _camera(bpy, sc, "PrismWorldBakeCamera")
        made["objects"].append(cam)
        made["cameras"].append(cam.data)
        c = cam.data
        c.type = "PANO"
        src = c if hasattr(c, "panorama_type") else c.cycles
        src.panorama_type = "EQUIRECTANGULAR"
        for k, v in (("longitude_min", -math.pi), ("longitude_max", math.pi),
                     ("latitude_min", -0.5 * math.pi), ("latitude_max", 0.5 * math.pi)):
            setattr(src, k, v)
        # Cycles' equirectangular camera looks along its -Z with +Y up; Blender's Environment
        # Texture puts +X at the image centre and +Z at the top: the camera looks along +X, up +Z.
        cam.rotation_euler = (0.5 * math.pi, 0.0, -0.5 * math.pi)
        sc.render.resolution_x, sc.render.resolution_y = BAKE_WIDTH, BAKE_HEIGHT
        sc.cycles.samples = BAKE_SPP
        _render(bpy, sc, os.path.join(work_dir, "world.exr"))
        if separate_sun:
            info["sun"] = _measure_sun(bpy, sc, cam, world, w_off, Vector(sun_direction(sky)), float(sky.sun_size), work_dir)
    finally:
        for kind in ("scenes", "objects", "cameras", "worlds"):
            coll = getattr(bpy.data, kind)
            for idb in made[kind]:
                try:
                    coll.remove(idb)
                except Exception:
                    pass
    return info


def _measure_sun(bpy, sc, cam, world, w_off, guess, size, work_dir):
    """Irradiance (RGB, W/m^2 at normal incidence) and direction of the sun disc: a narrow
    perspective view around `guess` rendered with the disc on; the sky under it is the mean
    of the view's border pixels (the disc is ~10^4 times brighter: the sky inside the disc is
    ~1e-4 of E, so no second render with the disc off)."""
    fov = max(SUN_WINDOW * size, 1e-3)
    c = cam.data
    c.type = "PERSP"
    c.sensor_fit = "HORIZONTAL"
    c.angle = fov
    c.clip_start = 1e-3
    q = guess.to_track_quat("-Z", "Y")
    cam.rotation_euler = q.to_euler()
    sc.render.resolution_x = sc.render.resolution_y = SUN_RES
    sc.cycles.samples = SUN_SPP
    sc.world = world
    try:
        on = _render(bpy, sc, os.path.join(work_dir, "sun.exr"))
    finally:
        sc.world = w_off
    border = np.concatenate([on[0], on[-1], on[1:-1, 0], on[1:-1, -1]])
    diff = np.maximum(on - border.mean(axis=0), 0.0)  # (rows top first, cols, rgb)
    t = math.tan(0.5 * fov)
    n = SUN_RES
    centres = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    x = centres[None, :] * t
    y = -centres[:, None] * t
    d_omega = (2.0 * t / n) ** 2 / (1.0 + x * x + y * y) ** 1.5
    lum = diff @ np.array([0.2126, 0.7152, 0.0722])
    # Only the disc: pixels above 1% of the peak (the sky's own noise stays out).
    mask = lum > 0.01 * lum.max() if lum.max() > 0.0 else lum > 0.0
    e_rgb = (diff * (d_omega * mask)[..., None]).sum(axis=(0, 1))
    wsum = float((lum * d_omega * mask).sum())
    if not wsum > 0.0:
        return None  # the disc is below the horizon (Cycles draws it above only)
    cx = float((lum * d_omega * mask * x).sum() / wsum)
    cy = float((lum * d_omega * mask * y).sum() / wsum)
    m = q.to_matrix()
    right, up, fwd = m.col[0], m.col[1], -m.col[2]
    d = (fwd + right * cx + up * cy).normalized()
    edge = np.concatenate([mask[0], mask[-1], mask[:, 0], mask[:, -1]])
    return {"irradiance": [float(v) for v in e_rgb], "direction": [float(v) for v in d], "angle": size,
            "guess": [float(v) for v in guess], "clipped": bool(edge.any())}


def bake_subprocess(world, work_dir):
    """Bakes in a background Blender (the caller is not on the main thread)."""
    import bpy

    blend = os.path.join(work_dir, "world.blend")
    bpy.data.libraries.write(blend, {world}, fake_user=True)
    exe = bpy.app.binary_path
    if exe:
        cmd = [exe, "-b", "--factory-startup", "--python-exit-code", "1", "--python", os.path.abspath(__file__),
               "--", blend, world.name, work_dir]
    else:  # the bpy wheel: Blender is a Python module
        cmd = [sys.executable, os.path.abspath(__file__), "--", blend, world.name, work_dir]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    info_path = os.path.join(work_dir, "info.json")
    if p.returncode != 0 or not os.path.exists(info_path):
        raise BakeError("background Blender failed (%d): %s" % (p.returncode, (p.stdout + p.stderr)[-400:]))
    with open(info_path) as f:
        return json.load(f)


def _main(argv):
    """Entry point of the background Blender: bake the world of a .blend into a folder."""
    import bpy

    blend, name, work_dir = argv[-3:]
    with bpy.data.libraries.load(blend) as (src, dst):
        dst.worlds = [name]
    info = bake_here(dst.worlds[0], work_dir)
    with open(os.path.join(work_dir, "info.json"), "w") as f:
        json.dump(info, f)


# ----------------------------------------------------------------------------- the exporter's entry


def bake_world(world, out_dir, name):
    """Bakes `world` (original datablock) to out_dir/<name>_world.exr (cached); returns
    (file name, info) where info has "sun" (irradiance RGB, Blender direction, angle) or None,
    "disc_in_image", "seconds" and "cached"."""
    t0 = time.perf_counter()
    key = world_key(world)
    cdir = cache_dir()
    cached_exr = os.path.join(cdir, key + ".exr")
    cached_info = os.path.join(cdir, key + ".json")
    fname = name + "_world.exr"
    if os.path.exists(cached_exr) and os.path.exists(cached_info):
        with open(cached_info) as f:
            info = json.load(f)
        info["cached"] = True
    else:
        work = tempfile.mkdtemp(prefix="prismworldbake-")
        try:
            if threading.current_thread() is threading.main_thread():
                info = bake_here(world, work)
            else:
                info = bake_subprocess(world, work)
            info["cached"] = False
            os.makedirs(cdir, exist_ok=True)
            shutil.copyfile(os.path.join(work, "world.exr"), cached_exr + ".part")
            os.replace(cached_exr + ".part", cached_exr)
            with open(cached_info, "w") as f:
                json.dump(info, f)
            prune_cache(cdir)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    shutil.copyfile(cached_exr, os.path.join(out_dir, fname))
    info["seconds"] = time.perf_counter() - t0
    return fname, info


def prune_cache(cdir, keep=CACHE_KEEP, companions=(".json",)):
    """Keeps the `keep` newest .exr files of cache folder `cdir` (and their same-named
    `companions`); removes the older ones. Never fails."""
    try:
        files = sorted((os.path.getmtime(os.path.join(cdir, f)), f) for f in os.listdir(cdir) if f.endswith(".exr"))
        for _, f in files[:-keep]:
            for ext in (".exr",) + tuple(companions):
                try:
                    os.remove(os.path.join(cdir, f[:-4] + ext))
                except OSError:
                    pass
    except OSError:
        pass


def add_sun_light(gltf_path, name, sun):
    """Adds the sky's sun disc to an already written glTF as a KHR_lights_punctual directional
    light (lux = W/m^2 x 683, the exporter's convention) of the disc's angular diameter
    (extras.prism_angle), under the Z-up root node."""
    from mathutils import Vector

    with open(gltf_path) as f:
        gltf = json.load(f)
    e = [max(v, 0.0) for v in sun["irradiance"]]
    peak = max(e)
    if not peak > 0.0:
        return
    lights = gltf.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {}).setdefault("lights", [])
    lights.append({"name": name, "type": "directional", "color": [v / peak for v in e],
                   "intensity": peak * 683.0, "extras": {"prism_angle": float(sun["angle"])}})
    used = gltf.setdefault("extensionsUsed", [])
    if "KHR_lights_punctual" not in used:
        used.append("KHR_lights_punctual")
    # The light shines along its local -Z: local +Z towards the sun.
    m = Vector(sun["direction"]).to_track_quat("Z", "Y").to_matrix().to_4x4()
    gltf["nodes"].append({"name": name, "matrix": [float(m[r][c]) for c in range(4) for r in range(4)],
                          "extensions": {"KHR_lights_punctual": {"light": len(lights) - 1}}})
    gltf["nodes"][0].setdefault("children", []).append(len(gltf["nodes"]) - 1)
    with open(gltf_path, "w") as f:
        json.dump(gltf, f, separators=(",", ":"))


if __name__ == "__main__":
    _main(sys.argv)
