"""The packaged zips install and render with the bundled binary, in a fresh Blender user folder.

    .venv-bpy/bin/python tests/addon/test_package.py
- extension zip, bpy wheel 5.0.1: extensions.package_install_files(repo='user_default')
- legacy zip, Debian blender -b 3.4: preferences.addon_install + addon_enable
Each runs in its own process with a fresh BLENDER_USER_RESOURCES/SCRIPTS/CONFIG, no binary path
set and no prism on PATH: only the bundled binary can be found. The bundled AVX2 build beside it
must be executable after the install.
"""

import os
import subprocess
import sys
import tempfile
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
OUT = tempfile.mkdtemp(prefix="prism_pkg_test_")


def check(cond, msg):
    if not cond:
        raise AssertionError(msg)
    print("  ok: " + msg, flush=True)


INNER = r'''
import os, sys
sys.path.insert(0, {here!r})
import bpy
import common as C
mode, zip_path, out = sys.argv[-3:]
if mode == "extension":
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    mod = "bl_ext.user_default.prism"
else:
    bpy.ops.preferences.addon_install(filepath=zip_path)
    bpy.ops.preferences.addon_enable(module="prism")
    mod = "prism"
import importlib
prism = importlib.import_module(mod)
sc = C.simple_scene()
C.use_prism(sc, spp=4)
px = C.render_pixels(sc, out)
last = prism.engine.LAST
assert last.get("error") is None, last
# The AVX2 build beside the bundled binary (the portable one hands over to it) is executable
# after the install, which drops executable bits.
sibling = os.path.join(os.path.dirname(prism.runner.find_binary()), "prism-x86-64-v3")
assert os.path.isfile(sibling) and os.access(sibling, os.X_OK), sibling
print("RESULT", px.shape, float(px[..., :3].mean()))
'''


def run(mode, cmd_prefix, zip_path):
    fresh = tempfile.mkdtemp(prefix=mode + "_", dir=OUT)
    script = os.path.join(fresh, "inner.py")
    with open(script, "w") as f:
        f.write(INNER.format(here=HERE))
    env = {k: v for k, v in os.environ.items() if not k.startswith("BLENDER_USER")}
    env.update(
        BLENDER_USER_RESOURCES=os.path.join(fresh, "res"),
        BLENDER_USER_SCRIPTS=os.path.join(fresh, "scripts"),
        BLENDER_USER_CONFIG=os.path.join(fresh, "config"),
        BLENDER_USER_EXTENSIONS=os.path.join(fresh, "extensions"),
        PATH="/usr/bin:/bin",
    )
    out = os.path.join(fresh, "out.exr")
    p = subprocess.run(cmd_prefix + [script, "--", mode, zip_path, out], env=env, capture_output=True, text=True, timeout=300)
    log = p.stdout + p.stderr
    line = next((x for x in log.splitlines() if x.startswith("RESULT")), None)
    if p.returncode != 0 or line is None:
        print(log[-3000:])
    check(p.returncode == 0 and line is not None, "%s zip installed and rendered: %s" % (mode, line))
    started = next((x for x in log.splitlines() if "Prism: started" in x), "")
    check(fresh in started or "bundled" in started, "the bundled binary ran (%s)" % started.strip())


def main():
    # The repository's build stands in for the AVX2 build too (only its file matters here).
    binary = os.path.join(REPO, "target", "release", "prism")
    p = subprocess.run([sys.executable, os.path.join(REPO, "blender_addon", "package.py"), "--no-build", "--out", OUT,
                        "--avx2-binary", binary],
                       check=True, capture_output=True, text=True)
    legacy, ext = p.stdout.split()
    failed = []
    tests = [
        ("test_extension_zip_bpy5", lambda: run("extension", [sys.executable], ext)),
        ("test_legacy_zip_blender34", lambda: run("legacy", [os.environ.get("BLENDER", "blender"), "-b", "--factory-startup", "-P"], legacy)),
    ]
    for name, fn in tests:
        print("== " + name, flush=True)
        try:
            fn()
        except Exception:
            traceback.print_exc()
            failed.append(name)
    print("package tests: %d passed, %d failed %s" % (len(tests) - len(failed), len(failed), failed or ""))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
