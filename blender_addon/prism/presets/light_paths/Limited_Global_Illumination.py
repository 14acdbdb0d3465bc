import bpy
prism = bpy.context.scene.prism

prism.max_depth = 3
prism.clamp_direct = 0.0
prism.clamp_indirect = 3.3
