import bpy
prism = bpy.context.scene.prism

prism.max_depth = 128
prism.clamp_direct = 0.0
prism.clamp_indirect = 0.0
