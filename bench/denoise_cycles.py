"""Cycles' own denoising cost on this machine, for comparison with bench/denoise.sh: the same
OIDN (the bpy wheel's) at Cycles' final-render defaults (Prefilter Accurate, Quality High), on a
1-spp render of a simple scene at 1920x1080 and 3840x2160, 2 threads. The denoising time is
the render time with denoising minus without (medians of N runs each).

    .venv-bpy/bin/python bench/denoise_cycles.py [RUNS=3] [SIZES=1920x1080,3840x2160]
"""
import json
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "addon"))
import bpy  # noqa: E402

import common as C  # noqa: E402

runs = int(sys.argv[1]) if len(sys.argv) > 1 else 3
sc = C.simple_scene()
C.use_cycles(sc, 1)
cy = sc.cycles
cy.denoiser = "OPENIMAGEDENOISE"
cy.denoising_prefilter = "ACCURATE"
if hasattr(cy, "denoising_quality"):
    cy.denoising_quality = "HIGH"
cy.denoising_input_passes = "RGB_ALBEDO_NORMAL"
sizes = sys.argv[2] if len(sys.argv) > 2 else "1920x1080,3840x2160"
for w, h in (tuple(int(v) for v in s.split("x")) for s in sizes.split(",")):
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = w, h, 100
    times = {}
    for denoise in (False, True):
        cy.use_denoising = denoise
        t = []
        for _ in range(runs):
            t0 = time.perf_counter()
            bpy.ops.render.render(write_still=False)
            t.append(time.perf_counter() - t0)
        times[denoise] = statistics.median(t)
    print(json.dumps({"engine": "cycles", "size": "%dx%d" % (w, h), "threads": 2,
                      "render_s_median": round(times[False], 3),
                      "denoise_s_median": round(times[True] - times[False], 3)}), flush=True)
