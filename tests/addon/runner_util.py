"""The add-on test scripts' runner (no bpy import: test_background.py runs without Blender state)."""

import sys
import traceback


def run_tests(label, namespace):
    """Runs the `test_*` functions of `namespace` (or those named on the command line), prints
    one closing line 'LABEL: N passed, M failed' and exits non-zero if any failed."""
    # Test names: after "--" under `blender -b ... --python FILE`, else the script's arguments.
    argv = sys.argv
    names = argv[argv.index("--") + 1:] if "--" in argv else ([] if "--python" in argv else argv[1:])
    names = names or [n for n in namespace if n.startswith("test_")]
    failed = []
    for n in names:
        print("== %s" % n, flush=True)
        try:
            namespace[n]()
        except Exception:
            traceback.print_exc()
            failed.append(n)
    print("%s: %d passed, %d failed %s" % (label, len(names) - len(failed), len(failed), failed or ""), flush=True)
    sys.exit(1 if failed else 0)
