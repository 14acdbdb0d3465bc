"""Scene-building helpers shared by scenes/build_scenes.py and the add-on tests (run inside Blender)."""

import bpy
import bmesh  # after bpy: the bpy wheel provides bmesh only once bpy is imported


def light(name, kind, energy, location, rotation=(0, 0, 0), **kw):
    """A light object of `kind` ('POINT', 'SPOT', 'SUN', 'AREA') linked to the scene."""
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    for k, v in kw.items():
        setattr(data, k, v)
    ob = bpy.data.objects.new(name, data)
    ob.location = location
    ob.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(ob)
    return ob


def camera(location, look_at, lens=50.0):
    """The scene's active camera at `location`, looking at `look_at`."""
    from mathutils import Vector

    cam = bpy.data.cameras.new("Camera")
    cam.lens = lens
    ob = bpy.data.objects.new("Camera", cam)
    ob.location = location
    ob.rotation_euler = (Vector(look_at) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.scene.camera = ob
    return ob


def material(name, kind="ShaderNodeBsdfDiffuse", color=(0.8, 0.8, 0.8), **inputs):
    """A node material with one shader node of `kind` ('Color' / 'Base Color' set to `color`,
    other inputs by name) connected to the output."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    node = shader_node(nt, kind, color, **inputs)
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


def shader_node(nt, kind, color=(0.8, 0.8, 0.8), **inputs):
    """A new shader node of `kind` in node tree `nt`, 'Color' / 'Base Color' set to `color`,
    other inputs by name."""
    node = nt.nodes.new(kind)
    for key in ("Color", "Base Color"):
        if key in node.inputs:
            node.inputs[key].default_value = (*color, 1.0)
    for k, v in inputs.items():
        node.inputs[k].default_value = v
    return node


def generated_x_range(nt, lo, hi):
    """The output socket of new nodes in `nt` that map the Generated X coordinate (0 to 1
    across an object) linearly to lo..hi (Texture Coordinate -> Separate XYZ -> Map Range)."""
    tc = nt.nodes.new("ShaderNodeTexCoord")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    mr = nt.nodes.new("ShaderNodeMapRange")
    mr.inputs[3].default_value = lo
    mr.inputs[4].default_value = hi
    nt.links.new(tc.outputs["Generated"], sep.inputs[0])
    nt.links.new(sep.outputs["X"], mr.inputs[0])
    return mr.outputs[0]


def noise_bump(nt, scale=3.0, strength=0.8, distance=0.3):
    """A Bump node in node tree `nt` whose height is a new Noise Texture's Fac (of `scale`)."""
    nz = nt.nodes.new("ShaderNodeTexNoise")
    nz.inputs["Scale"].default_value = scale
    bump = nt.nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = strength
    bump.inputs["Distance"].default_value = distance
    nt.links.new(nz.outputs["Fac"], bump.inputs["Height"])
    return bump


def node_group(name, inputs=(), outputs=()):
    """A new shader node group with (socket name, socket type) inputs and outputs (4.0+: the
    tree's interface; 3.x: its inputs/outputs), and its Group Input / Output nodes:
    (group, group input node, group output node)."""
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for in_out, sockets in (("INPUT", inputs), ("OUTPUT", outputs)):
        for sock_name, kind in sockets:
            if hasattr(group, "interface"):
                group.interface.new_socket(sock_name, in_out=in_out, socket_type=kind)
            else:
                (group.inputs if in_out == "INPUT" else group.outputs).new(kind, sock_name)
    return group, group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")


def mesh_object(name, build, mat, location=(0, 0, 0), rotation=(0, 0, 0), scale=(1, 1, 1), smooth=False):
    """A mesh object built by `build(bm)` (a bmesh callback), with material `mat` (or None)."""
    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    build(bm)
    bm.to_mesh(me)
    bm.free()
    for p in me.polygons:
        p.use_smooth = smooth
    if mat is not None:
        me.materials.append(mat)
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    ob.rotation_euler = rotation
    ob.scale = scale
    bpy.context.scene.collection.objects.link(ob)
    return ob


def world(color, strength=1.0):
    """A new world whose Background node has `color` x `strength` (also the viewport colour)."""
    w = bpy.data.worlds.new("World")
    bpy.context.scene.world = w
    if w.node_tree is None:
        w.use_nodes = True
    bg = next(n for n in w.node_tree.nodes if n.type == "BACKGROUND")
    bg.inputs["Color"].default_value = (*color, 1.0)
    bg.inputs["Strength"].default_value = strength
    w.color = color
    return w
