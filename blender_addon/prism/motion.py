"""Motion blur: where objects, their vertices and the camera are over Blender's shutter.

With Render > Motion Blur on, the scene is evaluated at equally spaced times from shutter
open to close (Cycles' convention: the shutter lasts `motion_blur_shutter` frames, placed
by Position start / centre / end on the current frame; an object's Motion Blur Steps s give
2^s + 1 keys, 3 by default). Every object whose world matrix changes over them gets its
matrices as glTF node extras (`prism_motion`); the renderer interpolates them and samples a
time per camera path (see `src/geometry/motion.rs`). A mesh whose evaluated vertices move
(armatures, shape keys, deforming modifiers, geometry nodes; Cycles' Deformation switch on)
gets its vertex positions and normals at the keys (`Motion.deformations`), exported as glTF
morph targets under the mesh's `extras.prism_deformation` (deformation blur). What is not
blurred is reported: a deforming mesh whose vertex count changes over the shutter, deforming
instances, particle hair and Curves objects, a rolling shutter.
"""

import math

import numpy as np

# Most keys per object: Cycles allows more, but transforms between keys are interpolated
# along the rotation's arc already, so more keys only follow curved paths more closely.
MAX_KEYS = 17

# Modifiers that may move vertices over time (what Cycles' deformation blur shows; the keys
# tell whether they do), or change their number (then warned).
_DEFORMING_MODIFIERS = {
    "ARMATURE", "CLOTH", "SOFT_BODY", "MESH_DEFORM", "LATTICE", "CURVE", "HOOK", "SURFACE_DEFORM",
    "LAPLACIANDEFORM", "WAVE", "OCEAN", "DYNAMIC_PAINT", "FLUID", "MESH_CACHE", "MESH_SEQUENCE_CACHE",
    "NODES", "EXPLODE", "SHRINKWRAP", "CAST", "DISPLACE", "SIMPLE_DEFORM", "SMOOTH", "WARP", "BUILD", "REMESH",
}


def shutter(scene):
    """(open, close) in frames, or None when motion blur is off."""
    r = scene.render
    if not getattr(r, "use_motion_blur", False):
        return None
    length = float(getattr(r, "motion_blur_shutter", 0.5))
    if not length > 0.0:
        return None
    # Blender 4.2+ keeps the position on the render settings, earlier versions on Cycles'.
    position = getattr(r, "motion_blur_position", None)
    if position is None:
        position = getattr(getattr(scene, "cycles", None), "motion_blur_position", "CENTER")
    frame = scene.frame_current + scene.frame_subframe
    start = {"START": frame, "END": frame - length}.get(position, frame - 0.5 * length)
    return start, start + length


def _object_keys(ob):
    """Keys an object asks for (Cycles: 2^steps + 1), 0 when its motion blur is off."""
    settings = getattr(ob, "cycles", None)
    if settings is not None and not getattr(settings, "use_motion_blur", True):
        return 0
    steps = max(1, int(getattr(settings, "motion_steps", 1) or 1))
    return min(MAX_KEYS, (2 << (steps - 1)) + 1)


def instance_key(inst):
    """What identifies an object instance across re-evaluations of the depsgraph."""
    if inst.is_instance:
        parent = inst.parent.original.name if inst.parent is not None else ""
        return ("I", parent, inst.object.original.name, tuple(inst.persistent_id))
    return ("O", inst.object.original.name)


def _likely_deforms(ob):
    if ob.type != "MESH":
        return False
    settings = getattr(ob, "cycles", None)
    if settings is not None and not getattr(settings, "use_deform_motion", True):
        return False
    if any(m.type in _DEFORMING_MODIFIERS and m.show_render for m in ob.modifiers):
        return True
    data = ob.data
    keys = getattr(data, "shape_keys", None)
    return getattr(data, "animation_data", None) is not None or (
        keys is not None and getattr(keys, "animation_data", None) is not None
    )


class Motion:
    """Matrices over the shutter: `objects[instance_key]` and `camera`, each a list of
    Blender matrices (world space) from shutter open to close, only for what moves; and
    `deformations[instance_key]`: per key, `vertex_data` of a mesh whose vertices move."""

    def __init__(self):
        self.objects = {}
        self.camera = None
        self.deformations = {}
        self.warnings = []


def vertex_data(me):
    """(positions (V, 3), vertex normals (V, 3) or None, corner normals (L, 3)) of an evaluated
    mesh, float32 copies (the mesh changes with the next frame change)."""
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    vn = None
    if hasattr(me, "vertex_normals"):  # 3.5+
        vn = np.empty(len(me.vertices) * 3, np.float32)
        me.vertex_normals.foreach_get("vector", vn)
        vn = vn.reshape(-1, 3)
    cn = np.empty(len(me.loops) * 3, np.float32)
    if hasattr(me, "corner_normals"):  # 4.1+
        me.corner_normals.foreach_get("vector", cn)
    else:
        me.calc_normals_split()
        me.loops.foreach_get("normal", cn)
    return co.reshape(-1, 3), vn, cn.reshape(-1, 3)


def sample(depsgraph, engine=None):
    """Evaluates the scene over the shutter (with `engine.frame_set` in a render, else the
    scene's own frame_set) and returns a Motion, or None when motion blur is off. The scene
    is back at its frame afterwards."""
    scene = depsgraph.scene
    window = shutter(scene)
    if window is None:
        return None
    # Original objects: the evaluated ones are rebuilt by every frame change.
    originals = {inst.object.original for inst in depsgraph.object_instances if inst.object is not None}
    n = max([_object_keys(ob) for ob in originals] + [3])
    deforming = sorted(ob.name for ob in originals if _object_keys(ob) and _likely_deforms(ob))
    times = [window[0] + (window[1] - window[0]) * k / (n - 1) for k in range(n)]
    frame, subframe = scene.frame_current, scene.frame_subframe

    def go(t):
        whole = math.floor(t)
        if engine is not None:
            engine.frame_set(int(whole), t - whole)
        else:
            scene.frame_set(int(whole), subframe=t - whole)

    tracks = {}
    camera = []
    keys_of = {}
    shapes = {}  # instance key -> vertex_data per time, for deforming meshes
    deforming_names = set(deforming)
    try:
        for t in times:
            go(t)
            for inst in depsgraph.object_instances:
                key = instance_key(inst)
                tracks.setdefault(key, []).append(inst.matrix_world.copy())
                if key not in keys_of:
                    keys_of[key] = _object_keys(inst.object.original)
                if not inst.is_instance and inst.object.original.name in deforming_names:
                    shapes.setdefault(key, []).append(vertex_data(inst.object.data))
            cam = scene.camera
            if cam is not None:
                camera.append(cam.evaluated_get(depsgraph).matrix_world.copy())
    finally:
        go(frame + subframe)

    def moves(ms):
        return len(ms) == n and any(
            abs(a[r][c] - b[r][c]) > 1e-6 for a, b in zip(ms, ms[1:]) for r in range(4) for c in range(4)
        )

    out = Motion()
    for key, ms in tracks.items():
        want = keys_of.get(key, 0)
        if want >= 2 and moves(ms):
            # An object with fewer keys than the scene's most: every (n-1)/(want-1)-th.
            stride = (n - 1) // (want - 1) if (n - 1) % (want - 1) == 0 else 1
            out.objects[key] = ms[::stride]
    if moves(camera):
        out.camera = camera
    unblurred = set(deforming)
    changing = []
    for key, data in shapes.items():
        name = key[1]
        want = keys_of.get(key, 0)
        if want < 2 or len(data) != n:
            continue
        if any(d[0].shape != data[0][0].shape or d[2].shape != data[0][2].shape for d in data):
            changing.append(name)
            continue
        unblurred.discard(name)
        if any(np.abs(d[0] - data[0][0]).max(initial=0.0) > 1e-6 for d in data[1:]):
            stride = (n - 1) // (want - 1) if (n - 1) % (want - 1) == 0 else 1
            out.deformations[key] = data[::stride]
    if changing:
        out.warnings.append(
            "motion blur: the vertex count of these meshes changes over the shutter, so their deformation is not "
            "blurred (they are shown at the current frame): " + ", ".join(sorted(changing))
        )
    unblurred -= set(changing)
    if unblurred:
        out.warnings.append(
            "motion blur: the deformation of these instanced meshes is not blurred (they are shown at the current "
            "frame): " + ", ".join(sorted(unblurred))
        )
    rolling = getattr(getattr(scene, "cycles", None), "rolling_shutter_type", "NONE")
    if rolling not in (None, "NONE"):
        out.warnings.append("motion blur: the rolling shutter is not rendered (a global shutter is used)")
    return out
