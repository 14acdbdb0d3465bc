#!/usr/bin/env python3
"""Where a scene's noise comes from, by path length: Prism against Cycles at each bounce limit.

For each DEPTH, Prism renders with --max-depth DEPTH (scattering events; light seen after the last one
counts) and Cycles with every bounce limit DEPTH - 1 (1 = direct light only in both), 2 x PAIRS images
each at 64 spp, 2 threads, the scene's own aspect (as bench/noise_vs_cycles.py, whose settings and noise
measure this uses: variance between two renders over ref^2 + 0.01, ref a high-spp Prism render at full
depth; "full" and "bulk"). The mean of each image shows whether the two depth limits count the same paths
(they should agree to a percent or two); the noise added from one depth to the next is that of the paths
of that length. What this found first (2026-12-06, SSS Cornell box): Prism's walls are noisier than
Cycles' up to one indirect bounce and quieter from the second on.

usage: .venv-bpy/bin/python bench/noise_by_depth.py SCENE [SCENE ...] [--depths 1,2,3,16] [--pairs 2]
       [--spp 64] [--size 256] [--ref-spp 512] [--work DIR]
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import noise_vs_cycles as nvc  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--depths", default="1,2,3,16")
    ap.add_argument("--pairs", type=int, default=2)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--ref-spp", type=int, default=512)
    ap.add_argument("--work", default=None)
    args = ap.parse_args()
    work = args.work or tempfile.mkdtemp(prefix="prism_depth_")
    os.makedirs(work, exist_ok=True)
    depths = [int(d) for d in args.depths.split(",")]
    # Cycles' bounce limits from the environment instead of noise_vs_cycles' fixed 15.
    script_text = nvc.CYCLES_SCRIPT.replace(
        "setattr(c, k, 15)", 'setattr(c, k, int(__import__("os").environ["BOUNCES"]))')
    script = os.path.join(work, "cycles_depth.py")
    with open(script, "w") as f:
        f.write(script_text)

    def prism(gltf, out, seed, spp, depth):
        w, h = nvc.image_size(gltf, args.size)
        subprocess.run([nvc.PRISM, "render", gltf, "-o", out, "--spp", str(spp), "--width", str(w),
                        "--height", str(h), "--threads", "2", "--seed", str(seed), "--progress", "none",
                        "--max-depth", str(depth), "--noise-threshold", "0"], check=True,
                       capture_output=True)

    def cycles(blend, out, seed, depth):
        w, h = nvc.image_size(blend, args.size)
        subprocess.run([sys.executable, script, blend, out, str(args.spp), str(seed), "%dx%d" % (w, h),
                        "0", "0"], check=True, capture_output=True,
                       env=dict(os.environ, BOUNCES=str(depth - 1)))

    for name in args.scenes:
        gltf = os.path.join(nvc.REPO, "scenes", name, name + ".gltf")
        blend = os.path.splitext(gltf)[0] + ".blend"
        ref = os.path.join(work, "%s_ref%d.exr" % (name, args.ref_spp))
        if not os.path.exists(ref):
            prism(gltf, ref, 1000, args.ref_spp, 16)
        den = nvc.read(ref) ** 2 + 1e-2
        print("%s (noise over ref^2 + 0.01, %d spp, %d pairs)" % (name, args.spp, args.pairs))
        print("| depth | Prism full / bulk / mean | Cycles full / bulk / mean | Prism / Cycles full, bulk |")
        print("| --- | --- | --- | --- |")
        for d in depths:
            row = []
            for who in ("prism", "cycles"):
                images = []
                for s in range(2 * args.pairs):
                    out = os.path.join(work, "%s_%s_d%d_%d.exr" % (name, who, d, s))
                    if who == "prism":
                        prism(gltf, out, s + 1, args.spp, d)
                    else:
                        cycles(blend, out, s + 1, d)
                    images.append(nvc.read(out))
                full, bulk = nvc.noise(images, den)
                row.append((full, bulk, float(np.mean(images[0]))))
            (pf, pb, pm), (cf, cb, cm) = row
            print("| %d | %.4g / %.4g / %.4f | %.4g / %.4g / %.4f | %.2f, %.2f |"
                  % (d, pf, pb, pm, cf, cb, cm, pf / cf, pb / cb), flush=True)


if __name__ == "__main__":
    main()
