# SPDX-License-Identifier: MIT
"""Sampling and Light Paths presets, as Cycles has them: a preset menu in each panel's header
(Blender's `Menu.draw_preset`), "+" / "-" to add and remove the user's own (Blender's
`AddPresetBase`), and bundled presets copied into the user's preset folder
(`<scripts>/presets/prism/<kind>/`) on registration when absent, so Blender finds them the way it
finds Cycles'. The user's own edits of a bundled file are never overwritten."""

import os
import shutil

import bpy
from bl_operators.presets import AddPresetBase

BUNDLED = os.path.join(os.path.dirname(os.path.abspath(__file__)), "presets")

SAMPLING_VALUES = [
    "prism.samples",
    "prism.use_adaptive_sampling",
    "prism.adaptive_threshold",
    "prism.adaptive_min_samples",
    "prism.time_limit",
    "prism.path_splits",
    "prism.use_caustic_guiding",
    "prism.use_denoising",
]
LIGHT_PATHS_VALUES = ["prism.max_depth", "prism.clamp_direct", "prism.clamp_indirect"]


class PRISM_MT_sampling_presets(bpy.types.Menu):
    bl_label = "Sampling Presets"
    preset_subdir = "prism/sampling"
    preset_operator = "script.execute_preset"
    COMPAT_ENGINES = {"PRISM"}
    draw = bpy.types.Menu.draw_preset


class PRISM_MT_light_paths_presets(bpy.types.Menu):
    bl_label = "Light Paths Presets"
    preset_subdir = "prism/light_paths"
    preset_operator = "script.execute_preset"
    COMPAT_ENGINES = {"PRISM"}
    draw = bpy.types.Menu.draw_preset


class PRISM_OT_sampling_preset_add(AddPresetBase, bpy.types.Operator):
    """Add or remove a Prism sampling preset"""

    bl_idname = "render.prism_sampling_preset_add"
    bl_label = "Add Sampling Preset"
    preset_menu = "PRISM_MT_sampling_presets"
    preset_defines = ["prism = bpy.context.scene.prism"]
    preset_values = SAMPLING_VALUES
    preset_subdir = "prism/sampling"


class PRISM_OT_light_paths_preset_add(AddPresetBase, bpy.types.Operator):
    """Add or remove a Prism light paths preset"""

    bl_idname = "render.prism_light_paths_preset_add"
    bl_label = "Add Light Paths Preset"
    preset_menu = "PRISM_MT_light_paths_presets"
    preset_defines = ["prism = bpy.context.scene.prism"]
    preset_values = LIGHT_PATHS_VALUES
    preset_subdir = "prism/light_paths"


def draw_header_preset(layout, menu, add_operator):
    """The preset menu and its +/- buttons in a panel header (Cycles' layout)."""
    if hasattr(menu, "draw_panel_header"):
        menu.draw_panel_header(layout)
        return
    row = layout.row(align=True)  # older Blenders: menu and operators by hand
    row.menu(menu.__name__, text=menu.bl_label)
    row.operator(add_operator, text="", icon="ADD")
    row.operator(add_operator, text="", icon="REMOVE").remove_active = True


def install_bundled():
    """Copies the bundled presets into the user's preset folders where they are missing."""
    for kind in ("sampling", "light_paths"):
        src = os.path.join(BUNDLED, kind)
        try:
            dst = bpy.utils.user_resource("SCRIPTS", path=os.path.join("presets", "prism", kind), create=True)
        except TypeError:  # Blender before 2.93: positional subdir
            dst = bpy.utils.user_resource("SCRIPTS", os.path.join("presets", "prism", kind), create=True)
        if not dst or not os.path.isdir(src):
            continue
        for name in os.listdir(src):
            if name.endswith(".py") and not os.path.exists(os.path.join(dst, name)):
                shutil.copyfile(os.path.join(src, name), os.path.join(dst, name))


classes = (
    PRISM_MT_sampling_presets,
    PRISM_MT_light_paths_presets,
    PRISM_OT_sampling_preset_add,
    PRISM_OT_light_paths_preset_add,
)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    try:
        install_bundled()
    except OSError as e:  # a read-only user folder: the menus are simply empty
        print("Prism: presets not installed: %s" % e)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
