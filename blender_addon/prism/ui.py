# SPDX-License-Identifier: MIT
"""Panels, shown only when Prism is the render engine."""

import bpy


class PrismPanel:
    COMPAT_ENGINES = {"PRISM"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class RENDER_PT_prism_sampling(PrismPanel, bpy.types.Panel):
    bl_label = "Prism"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw_header_preset(self, context):
        from . import presets

        presets.draw_header_preset(self.layout, presets.PRISM_MT_sampling_presets,
                                   presets.PRISM_OT_sampling_preset_add.bl_idname)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        p = context.scene.prism
        # As Cycles' Sampling > Render: Noise Threshold, Max Samples, Min Samples, Time Limit.
        heading = layout.column(align=True, heading="Noise Threshold")
        row = heading.row(align=True)
        row.prop(p, "use_adaptive_sampling", text="")
        sub = row.row()
        sub.active = p.use_adaptive_sampling
        sub.prop(p, "adaptive_threshold", text="")
        col = layout.column(align=True)
        col.prop(p, "samples", text="Max Samples" if p.use_adaptive_sampling else "Samples")
        sub = col.column(align=True)
        sub.active = p.use_adaptive_sampling
        sub.prop(p, "adaptive_min_samples", text="Min Samples")
        layout.prop(p, "time_limit")
        # "Wavelength Density" is cut off at the default editor width: "Density" under "Wavelengths".
        col = layout.column(align=True)
        col.prop(p, "wavelengths")
        col.prop(p, "wavelength_pdf", text="Density")
        layout.prop(p, "path_splits")
        layout.prop(p, "use_caustic_guiding")
        col = layout.column()
        col.prop(p, "threads")
        col.prop(p, "seed")


class RENDER_PT_prism_viewport(PrismPanel, bpy.types.Panel):
    """Render > Prism > Viewport, as Cycles' Sampling > Viewport and Performance > Viewport."""

    bl_label = "Viewport"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_prism_sampling"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        p = context.scene.prism
        col = layout.column(align=True)
        col.prop(p, "preview_samples", text="Max Samples")
        col.prop(p, "preview_start_resolution")
        layout.prop(context.scene.render, "preview_pixel_size", text="Pixel Size")
        heading = layout.column(align=True, heading="Denoise")
        row = heading.row(align=True)
        row.prop(p, "use_preview_denoising", text="")
        sub = row.row()
        sub.active = p.use_preview_denoising
        sub.prop(p, "preview_denoising_start_sample", text="Start Sample")


class RENDER_PT_prism_denoise(PrismPanel, bpy.types.Panel):
    """Render > Prism > Denoise, as Cycles' Sampling > Render > Denoise: the checkbox in the header."""

    bl_label = "Denoise"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_prism_sampling"

    def draw_header(self, context):
        self.layout.prop(context.scene.prism, "use_denoising", text="")

    def draw(self, context):
        from . import engine

        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        p = context.scene.prism
        layout.active = p.use_denoising
        col = layout.column()
        col.label(text="Denoiser: OpenImageDenoise")
        col.prop(p, "denoising_prefilter")
        col.prop(p, "denoising_quality")
        col.prop(p, "denoise_previews")
        if p.use_denoising and engine.blender_oidn() is None:
            col.label(text="No OpenImageDenoise library", icon="ERROR")


class RENDER_PT_prism_light_paths(PrismPanel, bpy.types.Panel):
    """Render > Light Paths, as Cycles': the path depth and the firefly clamps."""

    bl_label = "Light Paths"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header_preset(self, context):
        from . import presets

        presets.draw_header_preset(self.layout, presets.PRISM_MT_light_paths_presets,
                                   presets.PRISM_OT_light_paths_preset_add.bl_idname)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        p = context.scene.prism
        layout.prop(p, "max_depth")
        col = layout.column(align=True, heading="Clamping")
        col.prop(p, "clamp_direct")
        col.prop(p, "clamp_indirect")


class RENDER_PT_prism_film(PrismPanel, bpy.types.Panel):
    bl_label = "Film"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        p = context.scene.prism
        col = layout.column()
        col.prop(p, "filter_type")
        col.prop(p, "filter_width")


class RENDER_PT_prism_node_bake(PrismPanel, bpy.types.Panel):
    """Cycles bakes of the shader nodes Prism cannot evaluate (node_bake.py)."""

    bl_label = "Bake Unsupported Nodes"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.prism, "bake_unsupported_nodes", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        p = context.scene.prism
        col = layout.column()
        col.active = p.bake_unsupported_nodes
        col.prop(p, "bake_resolution")


class VIEWLAYER_PT_prism_passes(PrismPanel, bpy.types.Panel):
    """Blender's own pass panel is Cycles/EEVEE specific; these are the passes Prism writes."""

    bl_label = "Passes"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        col = layout.column(heading="Data")
        col.prop(context.view_layer, "use_pass_combined")
        col.prop(context.view_layer, "use_pass_z")
        col.prop(context.view_layer, "use_pass_normal")
        layout.column(heading="Denoising").prop(context.scene.prism, "denoising_data")
        if context.scene.prism.use_denoising:
            layout.label(text="Noisy Image: written while Denoise is on")


class MATERIAL_PT_prism(PrismPanel, bpy.types.Panel):
    bl_label = "Prism"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.material is not None

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        p = context.material.prism
        layout.prop(p, "sss_mode")
        if p.sss_mode == "PRESET":
            layout.prop(p, "sss_preset")
        elif p.sss_mode == "EXPLICIT":
            layout.prop(p, "sigma_a")
            layout.prop(p, "sigma_s")
        if p.sss_mode != "NONE":
            layout.prop(p, "sss_scale")
            layout.prop(p, "sss_eta")
            layout.prop(p, "sss_g")
            return
        layout.prop(p, "dispersion_mode")
        if p.dispersion_mode == "CAUCHY":
            layout.prop(p, "cauchy_a")
            layout.prop(p, "cauchy_b")
        elif p.dispersion_mode == "ABBE":
            layout.prop(p, "abbe_nd")
            layout.prop(p, "abbe_number")
        elif p.dispersion_mode == "GLASS":
            layout.prop(p, "glass_preset")
        if p.dispersion_mode != "NONE":
            layout.prop(p, "dispersion_roughness")


class MATERIAL_PT_prism_surface(PrismPanel, bpy.types.Panel):
    """Material > Surface, as Cycles': the node tree behind the output Prism renders (target All
    or Cycles, as the export reads it), or the base colour, metallic and roughness of a material
    without nodes (Blender 3.x)."""

    bl_label = "Surface"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        mat = context.material
        return super().poll(context) and mat is not None and not getattr(mat, "grease_pencil", None)

    def draw(self, context):
        layout = self.layout
        mat = context.material
        draw_use_nodes(layout, mat)
        layout.use_property_split = True
        if uses_nodes(mat):
            draw_node_view(layout, mat.node_tree, "Surface")
        else:
            layout.prop(mat, "diffuse_color", text="Base Color")
            layout.prop(mat, "metallic")
            layout.prop(mat, "roughness")


class MATERIAL_PT_prism_settings(PrismPanel, bpy.types.Panel):
    """Material > Settings: what of Blender's material settings the export reads."""

    bl_label = "Settings"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        mat = context.material
        return super().poll(context) and mat is not None and not getattr(mat, "grease_pencil", None)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        # glTF doubleSided = not backface culling.
        layout.prop(context.material, "use_backface_culling")


class DATA_PT_prism_light(PrismPanel, bpy.types.Panel):
    """Light properties, as Cycles' Light panel (Blender's own DATA_PT_light draws only the type
    for external engines, DATA_PT_EEVEE_light is EEVEE's)."""

    bl_label = "Light"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.light is not None

    def draw(self, context):
        layout = self.layout
        light = context.light
        layout.row().prop(light, "type", expand=True)
        layout.use_property_split = True

        col = layout.column()
        if hasattr(light, "use_temperature"):  # Blender 4.5+
            heading = col.column(align=True, heading="Temperature")
            row = heading.row(align=True)
            row.use_property_decorate = False
            row.prop(light, "use_temperature", text="")
            sub = row.row()
            sub.active = light.use_temperature
            sub.prop(light, "temperature", text="")
            row.prop_decorator(light, "temperature")
            col.prop(light, "color", text="Tint" if light.use_temperature else "Color")
        else:
            col.prop(light, "color")

        layout.separator()
        col = layout.column()
        col.prop(light, "energy")  # "Power" (W), "Strength" for a sun
        if hasattr(light, "exposure"):  # Blender 4.x+
            col.prop(light, "exposure")

        layout.separator()
        col = layout.column()
        if light.type in {"POINT", "SPOT"}:
            col.prop(light, "shadow_soft_size", text="Radius")
            if hasattr(light, "use_soft_falloff"):  # Blender 4.0+
                col.prop(light, "use_soft_falloff")
        elif light.type == "SUN":
            col.prop(light, "angle")
        elif light.type == "AREA":
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in {"SQUARE", "DISK"}:
                sub.prop(light, "size")
            else:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")


class DATA_PT_prism_light_beam_shape(PrismPanel, bpy.types.Panel):
    """Light > Beam Shape, as Cycles': the spot cone, an area light's spread. Blender's DATA_PT_spot
    draws the same but is a child of EEVEE's light panel, so it cannot show under Prism's."""

    bl_label = "Beam Shape"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"
    bl_parent_id = "DATA_PT_prism_light"

    @classmethod
    def poll(cls, context):
        light = context.light
        return super().poll(context) and light is not None and (
            light.type == "SPOT" or (light.type == "AREA" and hasattr(light, "spread"))
        )

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        light = context.light
        col = layout.column()
        if light.type == "SPOT":
            col.prop(light, "spot_size", text="Size")
            col.prop(light, "spot_blend", text="Blend", slider=True)
            col.prop(light, "show_cone")
        else:
            col.prop(light, "spread")


class DATA_PT_prism_light_nodes(PrismPanel, bpy.types.Panel):
    """Light > Nodes, as Cycles': the light's shader nodes, when it uses them."""

    bl_label = "Nodes"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        light = context.light
        return super().poll(context) and light is not None and getattr(light, "use_nodes", False) and light.node_tree is not None

    def draw(self, context):
        self.layout.use_property_split = True
        draw_node_view(self.layout, context.light.node_tree, "Surface")


class WORLD_PT_prism_surface(PrismPanel, bpy.types.Panel):
    """World > Surface, as Cycles': the world output's Surface node tree (the Background Prism
    exports), or the world colour without nodes (Blender 3.x)."""

    bl_label = "Surface"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.world is not None

    def draw(self, context):
        layout = self.layout
        world = context.world
        draw_use_nodes(layout, world)
        layout.use_property_split = True
        if uses_nodes(world):
            draw_node_view(layout, world.node_tree, "Surface")
        else:
            layout.prop(world, "color")


def uses_nodes(idb):
    """Whether a material or world renders its node tree. Blender 5.0 always does (use_nodes is
    deprecated and warns when read)."""
    if idb.node_tree is None:
        return False
    return bpy.app.version >= (5, 0, 0) or idb.use_nodes


def draw_use_nodes(layout, idb):
    """The Use Nodes toggle of Blender 3.x's EEVEE and Cycles surface panels (gone in 5.0)."""
    if bpy.app.version < (5, 0, 0):
        layout.prop(idb, "use_nodes", icon="NODETREE")
        layout.separator()


def draw_node_view(layout, ntree, input_name):
    """The node tree behind an output's input, as Cycles' panel_node_draw: the active output for
    target All or Cycles, the one the export reads."""
    node = ntree.get_output_node("CYCLES")
    if node is None:
        layout.label(text="No output node")
        return
    socket = node.inputs.get(input_name)
    if socket is None:
        layout.label(text="Incompatible output node")
        return
    layout.template_node_view(ntree, node, socket)


# Blender's own panels list the engines they draw for in COMPAT_ENGINES. Prism joins those
# written for any engine: the ones that list BLENDER_RENDER (the engine-agnostic set, as every
# external engine does), less those it replaces or that draw what Prism does not use, plus the
# generic ones Blender flags EEVEE/Workbench only.
BUILTIN_EXCLUDE = {
    "DATA_PT_light",  # the type alone; DATA_PT_prism_light draws the whole light
    "DATA_PT_area",  # 3.x: area shape and size; in DATA_PT_prism_light
    "DATA_PT_falloff_curve",  # 3.x: Blender Internal's custom falloff curve
    "VIEWLAYER_PT_filter",
    "VIEWLAYER_PT_layer_passes",  # VIEWLAYER_PT_prism_passes: the passes Prism writes
}
BUILTIN_EXTRA = {
    "EEVEE_MATERIAL_PT_context_material",  # material slots, browse/new: no EEVEE setting in it
    "DATA_PT_camera_dof",  # focus object/distance (exported)
    "DATA_PT_camera_dof_aperture",  # f-stop (exported), blades, rotation, ratio
}

# The panels register() added PRISM to, so unregister() removes it from exactly those.
_added = []


def _panel_classes():
    seen, todo = [], list(bpy.types.Panel.__subclasses__())
    while todo:
        c = todo.pop()
        if c in seen:
            continue
        seen.append(c)
        todo.extend(c.__subclasses__())
    return seen


def builtin_panels():
    """Blender's registered panels Prism shows, in the sense of the comment above."""
    panels = [
        p for p in _panel_classes()
        if isinstance(getattr(p, "COMPAT_ENGINES", None), set) and getattr(p, "is_registered", False)
    ]
    # Copies share their original's set (the node editor's NODE_DATA_PT_light is DATA_PT_light's
    # class dict), so a panel is left out when its set is an excluded panel's.
    excluded = {id(p.COMPAT_ENGINES) for p in panels if p.__name__ in BUILTIN_EXCLUDE}
    return [
        p for p in panels
        if id(p.COMPAT_ENGINES) not in excluded
        and ("BLENDER_RENDER" in p.COMPAT_ENGINES or p.__name__ in BUILTIN_EXTRA)
    ]


classes = (
    RENDER_PT_prism_sampling,
    RENDER_PT_prism_viewport,
    RENDER_PT_prism_denoise,
    RENDER_PT_prism_light_paths,
    RENDER_PT_prism_film,
    RENDER_PT_prism_node_bake,
    VIEWLAYER_PT_prism_passes,
    DATA_PT_prism_light,
    DATA_PT_prism_light_beam_shape,
    DATA_PT_prism_light_nodes,
    WORLD_PT_prism_surface,
    MATERIAL_PT_prism_surface,
    MATERIAL_PT_prism,
    MATERIAL_PT_prism_settings,
)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    for p in builtin_panels():
        if "PRISM" not in p.COMPAT_ENGINES:  # a set shared by subclasses counts once
            p.COMPAT_ENGINES.add("PRISM")
            _added.append(p)


def unregister():
    for p in _added:
        p.COMPAT_ENGINES.discard("PRISM")
    _added.clear()
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
