import bpy
prism = bpy.context.scene.prism

prism.samples = 8192
prism.use_adaptive_sampling = True
prism.adaptive_threshold = 0.005
prism.adaptive_min_samples = 64
prism.time_limit = 0.0
prism.path_splits = 0
prism.use_denoising = False
