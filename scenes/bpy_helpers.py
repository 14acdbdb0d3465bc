"""Scene-building helpers shared by scenes/build_scenes.py and the add-on tests (run inside Blender)."""

import bpy


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
