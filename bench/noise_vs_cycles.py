#!/usr/bin/env python3
"""Noise per second, Prism vs Blender Cycles CPU, on the repository's benchmark scenes, in one run.

For every scene (scenes/NAME/NAME.gltf for Prism, the .blend beside it for Cycles) both renderers render
2 x ROUNDS images at the same spp with different seeds, interleaved, 2 threads, at the scene's own aspect
ratio (render.width / render.height of its materials JSON) with about --size x --size pixels. Cycles is set unbiased: no
clamping, Filter Glossy 0, every bounce limit max_depth - 1 (15), no adaptive sampling, no denoising.
With --adaptive both renderers use adaptive sampling at Cycles' defaults (noise threshold 0.01, min samples
0 = automatic, max samples --spp, default 4096 then) and the same time limit (--time-limit seconds): equal
wall time, compared by their noise.

Noise is the variance between two independent renders of the same renderer, E[(A - B)^2] / 2 per pixel and
channel, divided by (ref^2 + 0.01) with ref a high-spp Prism render (the same normalisation for both
renderers: model differences do not count, only noise); the median over the ROUNDS pairs. Two figures:
"full" (every pixel; rare fireflies dominate it) and "bulk" (the 0.1% of pixels with the largest error left
out: the grain a viewer sees). Efficiency = (noise_cycles x t_cycles) / (noise_prism x t_prism): > 1 means
Prism reaches a given noise level sooner. Times: Prism's whole process (scene load included), Cycles'
render call (Blender start-up and file load excluded).

usage: .venv-bpy/bin/python bench/noise_vs_cycles.py [SCENE ...] [--spp 64] [--rounds 3] [--size 256]
       [--ref-spp 2048] [--adaptive [--time-limit 5]] [--work DIR] [--prism BINARY]
       [-- extra prism render flags]
Scenes default to: everyday sss_cornell rough_glass many_lights. Prints one JSON line per scene, then a table.
Needs the bpy 5.0.1 wheel, numpy and OpenEXR in the running Python, and target/release/prism.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenEXR

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PRISM = os.path.join(REPO, "target", "release", "prism")

CYCLES_SCRIPT = r"""
import sys, time, bpy
blend, out, spp, seed, size, adaptive, time_limit = sys.argv[-7:]
width, height = size.split("x")
bpy.ops.wm.open_mainfile(filepath=blend)
s = bpy.context.scene; c = s.cycles
s.render.engine = "CYCLES"; c.device = "CPU"; c.samples = int(spp); c.seed = int(seed)
c.use_denoising = False
c.use_adaptive_sampling = adaptive == "1"
c.adaptive_threshold = 0.01; c.adaptive_min_samples = 0; c.time_limit = float(time_limit)
c.sample_clamp_direct = 0; c.sample_clamp_indirect = 0; c.blur_glossy = 0
for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces",
          "transparent_max_bounces"):
    setattr(c, k, 15)
s.render.threads_mode = "FIXED"; s.render.threads = 2
s.render.resolution_x = int(width); s.render.resolution_y = int(height); s.render.resolution_percentage = 100
s.render.image_settings.file_format = "OPEN_EXR"; s.render.image_settings.color_depth = "32"
s.render.filepath = out
t = time.time(); bpy.ops.render.render(write_still=True); print("CYCLES_SECONDS %.4f" % (time.time() - t))
"""


def read(path):
    with OpenEXR.File(path) as f:
        ch = f.channels()
        key = "RGBA" if "RGBA" in ch else "RGB"
        return np.asarray(ch[key].pixels, dtype=np.float64)[..., :3]


def image_size(scene_file, size):
    """The scene's own aspect ratio (its render.width / render.height in the materials JSON beside
    it) at about size x size pixels: a square image would show each renderer a different view of
    a wide scene (Blender fits the camera's horizontal field of view, glTF gives the vertical)."""
    sidecar = os.path.splitext(scene_file)[0] + ".materials.json"
    try:
        with open(sidecar) as f:
            render = json.load(f).get("render", {})
        aspect = float(render["width"]) / float(render["height"])
    except (OSError, KeyError, ValueError, ZeroDivisionError):
        aspect = 1.0
    return max(1, round(size * aspect ** 0.5)), max(1, round(size / aspect ** 0.5))


def prism(args, gltf, out, seed, spp, extra):
    width, height = image_size(gltf, args.size)
    cmd = [PRISM, "render", gltf, "-o", out, "--spp", str(spp), "--width", str(width), "--height",
           str(height), "--threads", "2", "--seed", str(seed), "--progress", "none",
           # Cycles' 15 bounces; the scene JSON's own depth and noise threshold must not leak in.
           "--max-depth", "16"] + extra
    if args.adaptive:
        cmd += ["--noise-threshold", "0.01", "--time-limit", str(args.time_limit)]
    else:
        cmd += ["--noise-threshold", "0"]
    t = time.time()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.time() - t


def cycles(args, blend, out, seed, script):
    size = "%dx%d" % image_size(blend, args.size)
    p = subprocess.run([sys.executable, script, blend, out, str(args.spp), str(seed), size,
                        "1" if args.adaptive else "0", str(args.time_limit if args.adaptive else 0.0)],
                       check=True, capture_output=True, text=True)
    return float([l for l in p.stdout.splitlines() if l.startswith("CYCLES_SECONDS")][0].split()[1])


def noise(images, den):
    full, bulk = [], []
    for a, b in zip(images[0::2], images[1::2]):
        e = ((a - b) ** 2 / 2 / den).mean(-1)
        full.append(float(e.mean()))
        bulk.append(float(e[e <= np.quantile(e, 0.999)].mean()))
    return float(np.median(full)), float(np.median(bulk))


def main():
    extra = []
    if "--" in sys.argv:
        i = sys.argv.index("--")
        sys.argv, extra = sys.argv[:i], sys.argv[i + 1:]
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*", default=["everyday", "sss_cornell", "rough_glass", "many_lights"])
    ap.add_argument("--spp", type=int)
    ap.add_argument("--time-limit", type=float, default=5.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--adaptive", action="store_true")
    ap.add_argument("--work")
    ap.add_argument("--prism", help="the prism binary (default: target/release/prism)")
    args = ap.parse_args()
    global PRISM
    if args.prism:
        PRISM = os.path.abspath(args.prism)
    if args.spp is None:
        args.spp = 4096 if args.adaptive else 64
    work = args.work or tempfile.mkdtemp(prefix="prism_nvc_")
    os.makedirs(work, exist_ok=True)
    script = os.path.join(work, "cycles_render.py")
    with open(script, "w") as f:
        f.write(CYCLES_SCRIPT)
    rows = []
    for name in args.scenes:
        gltf = os.path.join(REPO, "scenes", name, name + ".gltf")
        blend = os.path.join(REPO, "scenes", name, name + ".blend")
        ref = os.path.join(work, "%s_ref%d_%dx%d.exr" % ((name, args.ref_spp) + image_size(gltf, args.size)))
        if not os.path.exists(ref):
            prism(argparse.Namespace(size=args.size, adaptive=False, time_limit=0), gltf, ref, 1000, args.ref_spp, [])
        den = read(ref) ** 2 + 1e-2
        imgs, times = {"prism": [], "cycles": []}, {"prism": [], "cycles": []}
        for r in range(args.rounds):
            for k in range(2):
                seed = 1 + 2 * r + k
                po, co = os.path.join(work, "%s_p%d.exr" % (name, seed)), os.path.join(work, "%s_c%d.exr" % (name, seed))
                times["prism"].append(prism(args, gltf, po, seed, args.spp, extra))
                imgs["prism"].append(read(po))
                times["cycles"].append(cycles(args, blend, co, seed + 100, script))
                imgs["cycles"].append(read(co))
        res = {"scene": name, "spp": args.spp, "size": args.size, "adaptive": args.adaptive}
        for who in ("prism", "cycles"):
            full, bulk = noise(imgs[who], den)
            res[who] = {"seconds": round(float(np.median(times[who])), 3), "noise": full, "bulk_noise": bulk,
                        "mean_rgb": np.mean([x.reshape(-1, 3).mean(0) for x in imgs[who]], 0).round(4).tolist()}
        p, c = res["prism"], res["cycles"]
        res["efficiency"] = round(c["noise"] * c["seconds"] / (p["noise"] * p["seconds"]), 3)
        res["bulk_efficiency"] = round(c["bulk_noise"] * c["seconds"] / (p["bulk_noise"] * p["seconds"]), 3)
        print(json.dumps(res), flush=True)
        rows.append(res)
    print("\n| scene | Prism s / noise / bulk | Cycles s / noise / bulk | efficiency full / bulk |")
    print("| --- | --- | --- | --- |")
    for r in rows:
        p, c = r["prism"], r["cycles"]
        print("| %s | %.2f / %.3g / %.3g | %.2f / %.3g / %.3g | %.2f / %.2f |" % (
            r["scene"], p["seconds"], p["noise"], p["bulk_noise"], c["seconds"], c["noise"], c["bulk_noise"],
            r["efficiency"], r["bulk_efficiency"]))


if __name__ == "__main__":
    main()
