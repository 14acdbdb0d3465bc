# SPDX-License-Identifier: MIT
"""Bakes shader nodes the exporter cannot translate (a Gabor or Musgrave texture, Vector
Rotate, Attribute, Ambient Occlusion, a Script, ...) into float textures over the mesh's UV map,
with Cycles, so that Prism renders what the user saw instead of the input's slider value.

How (measured in Blender 5.0.1's bpy wheel and Debian's Blender 3.4.1):
- Only the node's output is baked: the nodes after it stay live in Prism's graph (a Bump whose
  height comes from a baked texture still bumps per shading point; a Color Ramp after it still
  maps). A node inside a node group bakes the group's output that leads to it.
- The object (with its modifiers, materials, node groups and images; image paths made
  absolute) is written to a .blend (`bpy.data.libraries.write`) and baked by a background
  Blender running this file: the bpy wheel's Python (`import bpy`) or `blender -b`. So the
  user's materials are never edited, and the bake also runs where `RenderEngine.render()` is
  off the main thread (F12 in an interactive Blender), where adding datablocks is not safe.
- In that process the node's output drives an Emission shader on the material's active output,
  and Cycles bakes the EMIT pass (`bpy.ops.object.bake`) into a float image on the mesh's
  active UV map: the exporter's TEXCOORD_0. Float outputs become grey, vectors RGB = XYZ
  (signed). Denoising must be off: with it on, Debian's build (no OIDN) bakes black.
- Nodes whose value depends on the view or the light path (Light Path, Camera Data, Fresnel,
  Layer Weight, Light Falloff, Reflection/Camera/Window/Incoming coordinates), and nodes fed by
  them, are not baked: a texture would freeze them. Ambient Occlusion is baked only with Only
  Local (the bake sees the object alone).
- Bakes are cached by a hash of the material's node tree, the mesh's positions and UVs, the
  object's transform and these settings, in <tmp>/prism-bake-cache.
"""

import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

try:
    from . import exr
    from .world_bake import _tree_signature, prune_cache
except ImportError:  # run as a script by the background Blender (see _main)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import exr
    from world_bake import _tree_signature, prune_cache

DEFAULT_SIZE = 1024
BAKE_SPP = 4  # anti-aliasing within a texel
MARGIN = 16  # texels of padding around UV islands (bilinear lookups at seams)
CACHE_KEEP = 64
VERSION = 1  # bumps the cache key when the bake changes

# Node types whose value depends on the view, the light path or something a texture over the
# surface cannot hold.
NOT_BAKEABLE = {
    "LIGHT_PATH", "CAMERA", "FRESNEL", "LAYER_WEIGHT", "LIGHT_FALLOFF", "SHADER_TO_RGB",
    "PARTICLE_INFO", "HAIR_INFO", "POINT_INFO", "VOLUME_INFO", "GROUP_INPUT", "GROUP_OUTPUT",
}
# (node type, output name) that depend on the view.
VIEW_OUTPUTS = {
    ("TEX_COORD", "Reflection"), ("TEX_COORD", "Camera"), ("TEX_COORD", "Window"),
    ("NEW_GEOMETRY", "Incoming"), ("NEW_GEOMETRY", "Backfacing"),
}


class BakeError(Exception):
    pass


def cache_dir():
    return os.path.join(tempfile.gettempdir(), "prism-bake-cache")


# ----------------------------------------------------------------------------- what can be baked


def why_not_bakeable(node, out):
    """None when output `out` of `node` can be baked into a texture over the surface, else
    the reason (for the warning)."""
    if out.type == "SHADER":
        return "it is a shader"
    if node.type in NOT_BAKEABLE:
        return "its value depends on the view or the light path"
    if node.type == "AMBIENT_OCCLUSION" and not getattr(node, "only_local", False):
        return "without Only Local it depends on the other objects, which the bake does not see"
    bad = _view_dependent_inside(node, set()) or _view_dependent_upstream(node, set())
    if bad is not None:
        return "it reads '%s', which depends on the view, the light path or other objects" % bad
    return None


def _view_dependent(node):
    """`node` itself gives values a texture cannot hold (see NOT_BAKEABLE, VIEW_OUTPUTS); an
    Ambient Occlusion node without Only Local depends on the other objects, which the bake
    does not see."""
    if node.type in NOT_BAKEABLE - {"GROUP_INPUT", "GROUP_OUTPUT"}:
        return True
    if node.type == "AMBIENT_OCCLUSION" and not getattr(node, "only_local", False):
        return True
    return node.type in {"TEX_COORD", "NEW_GEOMETRY"} and any(
        o.is_linked and (node.type, o.name) in VIEW_OUTPUTS for o in node.outputs)


def _view_dependent_inside(node, seen):
    """Name of a view-dependent node anywhere inside group node `node` (nested groups
    included), or None."""
    tree = getattr(node, "node_tree", None) if node.type == "GROUP" else None
    if tree is None or tree.as_pointer() in seen:
        return None
    seen.add(tree.as_pointer())
    for inner in tree.nodes:
        if _view_dependent(inner):
            return "%s/%s" % (node.name, inner.name)
        bad = _view_dependent_inside(inner, seen)
        if bad is not None:
            return "%s/%s" % (node.name, bad)
    return None


def _view_dependent_upstream(node, seen):
    """Name of a view-dependent node feeding `node` (through groups: any such node inside), or
    None."""
    for sock in node.inputs:
        for link in sock.links:
            if getattr(link, "is_muted", False):
                continue
            up = link.from_node
            if up.as_pointer() in seen:
                continue
            seen.add(up.as_pointer())
            if _view_dependent(up):
                return up.name
            bad = _view_dependent_inside(up, set()) or _view_dependent_upstream(up, seen)
            if bad is not None:
                return bad
    return None


# ----------------------------------------------------------------------------- cache keys


# Attribute data types whose values a bake may read (Attribute node, colour attributes, sharp
# faces, custom normals), by the `foreach_get` property and components per element.
_ATTRIBUTE_VALUES = {"FLOAT": ("value", 1), "INT": ("value", 1), "BOOLEAN": ("value", 1), "FLOAT2": ("vector", 2),
                     "FLOAT_VECTOR": ("vector", 3), "FLOAT_COLOR": ("color", 4), "BYTE_COLOR": ("color", 4)}


def mesh_signature(me):
    """A hash of the (evaluated) mesh's positions, faces, active UV map, smooth shading and
    attributes."""
    h = hashlib.sha1()
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    h.update(co.tobytes())
    loops = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", loops)
    h.update(loops.tobytes())
    layer = me.uv_layers.active
    if layer is not None:
        uv = np.empty(len(me.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        h.update(uv.tobytes())
    smooth = np.empty(len(me.polygons), bool)
    me.polygons.foreach_get("use_smooth", smooth)
    h.update(smooth.tobytes())
    for a in sorted(getattr(me, "attributes", []), key=lambda a: a.name):
        kind = _ATTRIBUTE_VALUES.get(a.data_type)
        if kind is None:
            continue
        h.update(("%s/%s/%s" % (a.name, a.domain, a.data_type)).encode())
        vals = np.empty(len(a.data) * kind[1], np.float32 if a.data_type not in {"INT", "BOOLEAN"} else np.int32)
        try:
            a.data.foreach_get(kind[0], vals)
        except (TypeError, RuntimeError):
            continue
        h.update(vals.tobytes())
    return h.hexdigest()


def _tree_dependencies(tree, seen, out):
    """What a bake reads besides the node settings: the images' files (path, modification
    time, unsaved edits) and the objects Texture Coordinate nodes look through (their
    transforms), inside groups too."""
    if tree is None or tree.as_pointer() in seen:
        return out
    seen.add(tree.as_pointer())
    for n in tree.nodes:
        img = getattr(n, "image", None)
        if img is not None:
            path = img.filepath_from_user() if img.filepath else ""
            try:
                mtime = os.path.getmtime(path) if path else 0.0
            except OSError:
                mtime = -1.0
            out.append(["image", img.name, path, mtime, bool(img.is_dirty), img.packed_file is not None])
        ob = getattr(n, "object", None)
        if ob is not None and hasattr(ob, "matrix_world"):
            out.append(["object", ob.name, [round(float(x), 6) for row in ob.matrix_world for x in row]])
        _tree_dependencies(getattr(n, "node_tree", None), seen, out)
    return out


def job_key(material, mesh_sig, matrix, node_name, socket_id, size, frame):
    import bpy

    sig = {"v": VERSION, "blender": list(bpy.app.version), "tree": _tree_signature(material.node_tree, set()),
           "deps": _tree_dependencies(material.node_tree, set(), []),
           "mesh": mesh_sig, "matrix": [round(float(x), 6) for row in matrix for x in row],
           "node": node_name, "socket": socket_id, "size": size, "spp": BAKE_SPP, "margin": MARGIN, "frame": frame}
    blob = json.dumps(sig, sort_keys=True, default=str).encode()
    return hashlib.sha1(blob).hexdigest()[:24]


# ----------------------------------------------------------------------------- the exporter's entry


def bake(jobs, frame):
    """Bakes `jobs` (dicts: object (original), material (original), node, socket, size, key,
    path) into their `path`s (float RGB EXR, rows top first), from the cache where it has them.
    Returns (seconds, how many were baked, how many came from the cache, {path: error} of the
    jobs that failed; the others are baked and cached). Raises BakeError when the background
    Blender itself fails."""
    t0 = time.perf_counter()
    cdir = cache_dir()
    todo = []
    for j in jobs:
        cached = os.path.join(cdir, j["key"] + ".exr")
        if os.path.exists(cached):
            shutil.copyfile(cached, j["path"])
        else:
            todo.append(j)
    failed = {}
    if todo:
        work = tempfile.mkdtemp(prefix="prismnodebake-")
        try:
            failed = _bake_subprocess(todo, frame, work)
            os.makedirs(cdir, exist_ok=True)
            for j in todo:
                if j["path"] in failed:
                    continue
                cached = os.path.join(cdir, j["key"] + ".exr")
                shutil.copyfile(j["path"], cached + ".part")
                os.replace(cached + ".part", cached)
            prune_cache(cdir, CACHE_KEEP, companions=())
        finally:
            shutil.rmtree(work, ignore_errors=True)
    return time.perf_counter() - t0, len(todo) - len(failed), len(jobs) - len(todo), failed


def _bake_subprocess(jobs, frame, work):
    import bpy

    blend = os.path.join(work, "objects.blend")
    objects = {j["object"] for j in jobs}
    bpy.data.libraries.write(blend, objects, fake_user=True, path_remap="ABSOLUTE")
    spec = {"blend": blend, "frame": frame, "errors": os.path.join(work, "errors.json"), "jobs": [
        {"object": j["object"].name, "material": j["material"].name, "node": j["node"], "socket": j["socket"],
         "size": j["size"], "path": j["path"]} for j in jobs]}
    spec_path = os.path.join(work, "spec.json")
    with open(spec_path, "w") as f:
        json.dump(spec, f)
    exe = bpy.app.binary_path
    if exe:
        cmd = [exe, "-b", "--factory-startup", "--python-exit-code", "1", "--python", os.path.abspath(__file__),
               "--", spec_path]
    else:  # the bpy wheel: Blender is a Python module
        cmd = [sys.executable, os.path.abspath(__file__), "--", spec_path]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    errors_path = os.path.join(work, "errors.json")
    if p.returncode != 0 or not os.path.exists(errors_path):
        lines = [l for l in (p.stdout + p.stderr).splitlines() if "Error" in l or "error" in l]
        raise BakeError("background Blender failed (%d): %s" % (p.returncode, " | ".join(lines[-3:]) or (p.stdout + p.stderr)[-300:]))
    with open(errors_path) as f:
        failed = json.load(f)
    for j in jobs:
        if j["path"] not in failed and not os.path.exists(j["path"]):
            failed[j["path"]] = "no image was written"
    return failed


# ----------------------------------------------------------------------------- baking (in the background Blender)


def _active_output(nt):
    outs = [n for n in nt.nodes if n.type == "OUTPUT_MATERIAL" and getattr(n, "target", "ALL") in {"ALL", "CYCLES"}]
    for n in outs:
        if n.is_active_output:
            return n
    if outs:
        return outs[0]
    return nt.nodes.new("ShaderNodeOutputMaterial")


def _bake_one(bpy, ob, job, dummy):
    mat = bpy.data.materials[job["material"]]
    nt = mat.node_tree
    node = nt.nodes.get(job["node"])
    if node is None:
        raise BakeError("material '%s' has no node '%s'" % (mat.name, job["node"]))
    sock = next((o for o in node.outputs if o.identifier == job["socket"]), None)
    if sock is None:
        raise BakeError("node '%s' has no output '%s'" % (node.name, job["socket"]))
    size = int(job["size"])
    img = bpy.data.images.new("PrismBake", size, size, alpha=False, float_buffer=True)
    made = []
    try:
        em = nt.nodes.new("ShaderNodeEmission")
        made.append(em)
        em.inputs["Strength"].default_value = 1.0
        nt.links.new(sock, em.inputs["Color"])
        out = _active_output(nt)
        nt.links.new(em.outputs[0], out.inputs["Surface"])
        # Every material of the object needs an active image node: the others bake into a
        # throw-away image, so faces of other materials sharing UV space do not overwrite ours.
        for slot in ob.material_slots:
            m = slot.material
            if m is None or not m.use_nodes:
                continue
            tex = m.node_tree.nodes.new("ShaderNodeTexImage")
            tex.image = img if m == mat else dummy
            m.node_tree.nodes.active = tex
            made.append(tex)
        res = bpy.ops.object.bake(type="EMIT", margin=MARGIN, use_clear=True, target="IMAGE_TEXTURES")
        if "FINISHED" not in res:
            raise BakeError("Cycles bake returned %s" % sorted(res))
        px = np.empty(size * size * 4, np.float32)
        img.pixels.foreach_get(px)
        # Blender's pixels are bottom row first; the EXR (like every image Prism reads) top first.
        exr.write_exr_rgb(job["path"], px.reshape(size, size, 4)[::-1, :, :3].copy())
    finally:
        for n in made:
            n.id_data.nodes.remove(n)
        bpy.data.images.remove(img)


def _main(argv):
    """Entry point of the background Blender: bake the jobs of a spec file."""
    import bpy

    with open(argv[-1]) as f:
        spec = json.load(f)
    # An empty file: the startup file's own datablocks ("Material", "Cube") would rename ours.
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.node_groups):
        for idb in list(coll):
            coll.remove(idb)
    names = sorted({j["object"] for j in spec["jobs"]})
    with bpy.data.libraries.load(spec["blend"]) as (src, dst):
        dst.objects = names
    sc = bpy.context.scene
    for ob in dst.objects:
        sc.collection.objects.link(ob)
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = BAKE_SPP
    cy.use_denoising = False
    if hasattr(cy, "use_adaptive_sampling"):
        cy.use_adaptive_sampling = False
    sc.frame_set(int(spec["frame"]))
    dummy = bpy.data.images.new("PrismBakeOther", 4, 4, float_buffer=True)
    by_name = {ob.name: ob for ob in dst.objects}
    vl = bpy.context.view_layer
    errors = {}
    for job in spec["jobs"]:
        # One job's failure (an object the .blend could not carry, a node gone) leaves the
        # others baked.
        try:
            ob = by_name.get(job["object"])
            if ob is None:
                raise BakeError("object '%s' could not be loaded" % job["object"])
            for o in sc.objects:
                o.select_set(o == ob)
            vl.objects.active = ob
            _bake_one(bpy, ob, job, dummy)
        except Exception as e:  # reported per job to the exporter
            errors[job["path"]] = str(e).strip().splitlines()[-1] if str(e).strip() else type(e).__name__
    with open(spec["errors"], "w") as f:
        json.dump(errors, f)


if __name__ == "__main__":
    _main(sys.argv)
