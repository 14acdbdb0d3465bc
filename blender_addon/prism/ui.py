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
        col = layout.column()
        col.prop(p, "wavelengths")
        col.prop(p, "wavelength_pdf")
        col.prop(p, "threads")
        col.prop(p, "seed")


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
            col.label(text="This Blender has no OpenImageDenoise library", icon="ERROR")


class RENDER_PT_prism_light_paths(PrismPanel, bpy.types.Panel):
    """Render > Light Paths, as Cycles': the path depth and the firefly clamps."""

    bl_label = "Light Paths"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

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
    """The material's node tree output, so a surface can be edited without the node editor."""

    bl_label = "Surface"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.material is not None and context.material.node_tree is not None

    def draw(self, context):
        mat = context.material
        out = next((n for n in mat.node_tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output), None)
        if out is None:
            self.layout.label(text="No material output node")
            return
        self.layout.template_node_view(mat.node_tree, out, out.inputs["Surface"])


classes = (RENDER_PT_prism_sampling, RENDER_PT_prism_denoise, RENDER_PT_prism_light_paths, RENDER_PT_prism_film, VIEWLAYER_PT_prism_passes, MATERIAL_PT_prism, MATERIAL_PT_prism_surface)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
