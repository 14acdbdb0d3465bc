#!/usr/bin/env python3
"""Runs the renderer over a directory of glTF files with the Khronos validator's verdicts
(`<file>.report.json` beside each file, as in glTF-Validator's test/ corpus) and tabulates
what happens (issue 16).

Each file that parses as JSON gets a camera (looking at the origin from +z, 5 units away) added
to its default scene and a lit world in a sidecar, so the file alone decides whether it renders;
a file that does not parse is run as it is. Every run is 8 x 6 pixels, 1 spp, with a timeout.

    python3 bench/gltf_corpus.py CORPUS_DIR [--prism target/release/prism] [--timeout 20]

Prints one line per file that is valid (numErrors 0) and refused, and per run that ended by a
signal, a panic (exit 101) or the timeout, then the totals. Exit status 1 if any run crashed
or hung. The corpus is not in the repository; the files are copied to a scratch directory.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile


def add_camera(doc):
    """Adds a perspective camera node to the default scene (creating a scene if there is
    none). Returns False when the document's shape does not allow it."""
    if not isinstance(doc, dict):
        return False
    cams = doc.setdefault("cameras", [])
    nodes = doc.setdefault("nodes", [])
    scenes = doc.setdefault("scenes", [])
    if not (isinstance(cams, list) and isinstance(nodes, list) and isinstance(scenes, list)):
        return False
    cams.append({"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}})
    nodes.append({"name": "CorpusCamera", "camera": len(cams) - 1, "translation": [0, 0, 5]})
    if not scenes:
        # Without a scene the renderer draws every root node; keep that meaning.
        return True
    s = doc.get("scene", 0)
    target = scenes[s] if isinstance(s, int) and 0 <= s < len(scenes) else scenes[0]
    if not isinstance(target, dict):
        return False
    target.setdefault("nodes", []).append(len(nodes) - 1)
    return True


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("corpus")
    ap.add_argument("--prism", default="target/release/prism")
    ap.add_argument("--timeout", type=float, default=20.0)
    args = ap.parse_args()
    prism = os.path.abspath(args.prism)

    files = []
    for d, _, names in os.walk(args.corpus):
        for n in sorted(names):
            if n.endswith((".gltf", ".glb")):
                files.append(os.path.join(d, n))
    files.sort()

    counts = {"valid": 0, "valid_ok": 0, "invalid": 0, "invalid_ok": 0, "noreport": 0,
              "crash": 0, "hang": 0}
    scratch = tempfile.mkdtemp(prefix="prism_gltf_corpus_")
    try:
        for path in files:
            report = path + ".report.json"
            errors = None
            if os.path.exists(report):
                with open(report) as f:
                    errors = json.load(f).get("issues", {}).get("numErrors")
            work = os.path.join(scratch, "case")
            shutil.rmtree(work, ignore_errors=True)
            shutil.copytree(os.path.dirname(path), work)
            case = os.path.join(work, os.path.basename(path))
            if path.endswith(".gltf"):
                try:
                    with open(path, encoding="utf-8") as f:
                        doc = json.load(f)
                    if add_camera(doc):
                        with open(case, "w") as f:
                            json.dump(doc, f)
                except (ValueError, UnicodeDecodeError):
                    pass
            stem = os.path.splitext(case)[0]
            with open(stem + ".materials.json", "w") as f:
                json.dump({"version": 1, "world": {"color": [0.5, 0.5, 0.5], "strength": 1}}, f)
            cmd = [prism, "render", case, "--width", "8", "--height", "6", "--spp", "1",
                   "--threads", "1", "--progress", "none", "-o", os.path.join(work, "out.exr")]
            rel = os.path.relpath(path, args.corpus)
            try:
                r = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
                code = r.returncode
                err = r.stderr.strip().splitlines()
                last = err[-1] if err else ""
            except subprocess.TimeoutExpired:
                code, last = None, "timeout"
            if code is None:
                counts["hang"] += 1
                print(f"HANG    {rel}")
            elif code < 0 or code == 101 or code not in (0, 2):
                counts["crash"] += 1
                print(f"CRASH   {rel}: exit {code}: {last}")
            if errors is None:
                counts["noreport"] += 1
            elif errors == 0:
                counts["valid"] += 1
                if code == 0:
                    counts["valid_ok"] += 1
                elif code is not None:
                    print(f"REFUSED {rel}: {last}")
            else:
                counts["invalid"] += 1
                if code == 0:
                    counts["invalid_ok"] += 1
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print(f"files {len(files)}: valid {counts['valid']} (rendered {counts['valid_ok']}, "
          f"refused {counts['valid'] - counts['valid_ok']}), invalid {counts['invalid']} "
          f"(rendered {counts['invalid_ok']}, refused with exit 2 {counts['invalid'] - counts['invalid_ok']}), "
          f"without report {counts['noreport']}; crashes {counts['crash']}, hangs {counts['hang']}")
    sys.exit(1 if counts["crash"] or counts["hang"] else 0)


if __name__ == "__main__":
    main()
