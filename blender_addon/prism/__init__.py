# SPDX-License-Identifier: MIT
"""Prism: a spectral path tracer as a Blender render engine.

Layout follows Cycles' add-on: engine (RenderEngine), properties (PropertyGroups), ui (panels),
export (glTF + material JSON from the depsgraph), runner (the prism process).
"""

bl_info = {
    "name": "Prism",
    "author": "Prism developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Render Properties > Render Engine > Prism",
    "description": "Spectral path tracer (subsurface scattering, dispersion) driven as an external binary",
    "category": "Render",
}

import os

import bpy
from bpy.props import BoolProperty, StringProperty

from . import engine, presets, properties, runner, ui


class PrismPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    binary_path: StringProperty(
        name="Prism Binary",
        description="Path to the prism executable (empty: bundled binary, then PATH, then the repository's target/release)",
        subtype="FILE_PATH",
        default="",
    )

    cache_bvh: BoolProperty(
        name="Cache BVHs Between Renders",
        description="Keep the acceleration structures of unchanged meshes on disk (in the temporary "
        "folder, at most 1 GiB) so re-renders skip their build, like Cycles' Persistent Data",
        default=True,
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "binary_path")
        layout.prop(self, "cache_bvh")
        try:
            found = runner.find_binary(self.binary_path)
            layout.label(text="Using: " + found, icon="CHECKMARK")
        except runner.RunnerError as e:
            layout.label(text=str(e), icon="ERROR")
        if not self.binary_path:
            box = layout.box()
            for where, path in runner.candidate_binaries():
                ok = os.path.isfile(path)
                box.label(text="%s: %s" % (where, path), icon="CHECKMARK" if ok else "X")


def register():
    bpy.utils.register_class(PrismPreferences)
    properties.register()
    engine.register()
    presets.register()
    ui.register()


def unregister():
    ui.unregister()
    presets.unregister()
    engine.unregister()
    properties.unregister()
    bpy.utils.unregister_class(PrismPreferences)
