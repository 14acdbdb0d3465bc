#!/usr/bin/env bash
# Blender add-on tests in real Blender (no mocks). Installs what they need, idempotently:
#   - a venv .venv-bpy/ with the bpy wheel (Blender 5.0.1 as a Python module) and numpy,
#   - Debian's blender (3.4, for `blender -b`) and python3-numpy via apt-get (as root, if missing),
#   - the release binary (cargo build --release).
#   - Xvfb (Debian's xvfb) for the interactive test: Blender with a window, F12 render.
# Usage: tests/addon/run_addon_tests.sh [bpy|background|interactive|package|all|install]
#   install: only install the above (scripts/test.sh runs it first: the Rust denoising tests
#   use the bpy wheel's Open Image Denoise library).
set -euo pipefail
cd "$(dirname "$0")/../.."
REPO=$(pwd)
WHICH=${1:-all}

if [ ! -x .venv-bpy/bin/python ] || ! .venv-bpy/bin/python -c "import bpy, numpy" 2>/dev/null; then
    echo "== installing bpy==5.0.1 into .venv-bpy (about 375 MB)"
    PY=$(command -v python3.11 || command -v python3)  # the bpy 5.0.1 wheel is for CPython 3.11
    rm -rf .venv-bpy
    if ! "$PY" -m venv .venv-bpy; then  # Debian: venv needs python3-venv
        rm -rf .venv-bpy
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
        "$PY" -m venv .venv-bpy
    fi
    .venv-bpy/bin/pip install -q bpy==5.0.1 numpy
fi
blender_ok() {
    command -v blender >/dev/null &&
        blender -b --factory-startup --python-exit-code 1 --python-expr "import numpy" >/dev/null 2>&1
}
if ! blender_ok; then
    echo "== installing Debian's blender and python3-numpy (apt-get)"
    if [ "$(id -u)" != 0 ]; then echo "need root for apt-get install blender python3-numpy" >&2; exit 1; fi
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq blender python3-numpy >/dev/null
fi

if { [ "$WHICH" = all ] || [ "$WHICH" = interactive ] || [ "$WHICH" = install ]; } && ! command -v xvfb-run >/dev/null; then
    echo "== installing Debian's xvfb (apt-get) for the interactive test"
    if [ "$(id -u)" != 0 ]; then echo "need root for apt-get install xvfb xauth" >&2; exit 1; fi
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq xvfb xauth >/dev/null
fi

if [ "$WHICH" = install ]; then exit 0; fi

cargo build --release -q

WORK=$(mktemp -d /tmp/prism_addon_tests.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
mkdir -p "$WORK/scripts/addons" "$WORK/config" "$WORK/tmp"
ln -s "$REPO/blender_addon/prism" "$WORK/scripts/addons/prism"
export BLENDER_USER_SCRIPTS="$WORK/scripts" BLENDER_USER_CONFIG="$WORK/config" TMPDIR="$WORK/tmp"

# Blender prints a status line per progress update; keep the test lines.
filter() { grep -v -E '^(Fra:|$|Prism: started|[0-9:.]+ +(blend|render))' || true; }
# Blender's bundled glTF exporter logs a line per step.
quiet_info() { "$@" 2>&1 | grep -v ' INFO: '; return "${PIPESTATUS[0]}"; }
# step "what" command...: runs one test file, keeps its test lines, prints its wall time (so the
# suite's budget can be watched per file), and fails the run if the file fails.
step() {
    local what=$1 start=$SECONDS
    shift
    echo "== $what"
    local rc=0
    { "$@" 2>&1 | filter; } || rc=$?  # pipefail: the test's status (filter never fails)
    echo "   ($((SECONDS - start)) s)"
    [ "$rc" = 0 ]
}

if [ "$WHICH" = all ] || [ "$WHICH" = bpy ]; then
    step "add-on tests in the bpy wheel (Blender 5.0.1)" .venv-bpy/bin/python tests/addon/test_bpy.py
    step "Properties editor panels with Prism (light, world, material, camera) in the bpy wheel" .venv-bpy/bin/python tests/addon/test_panels.py
    step "Sampling and Light Paths presets in the bpy wheel" .venv-bpy/bin/python tests/addon/test_presets.py
    step "soft lights (radius, sun angle), Temperature, Blackbody, Exposure vs Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_lights.py
    step "render border, Film Transparent, holdouts vs Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_pipeline.py
    step "camera and world parity with Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_camera_world.py
    step "worlds baked by Cycles (every Sky Texture model, a procedural world) vs Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_world_bake.py
    step "shader node graphs: export and parity with Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_node_graphs.py
    step "volume shaders (fog, tinted glass, smoke, glow, a camera inside fog) vs Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_volumes.py
    step "denoising (the wheel's OIDN) and clamps in the bpy wheel" .venv-bpy/bin/python tests/addon/test_denoise.py
    step "normal maps: export and parity with Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_normal_map.py
    step "Principled subsurface parity with Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_sss_parity.py
    step "energy-conserving rough glass, metal and Principled parity with Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_energy_parity.py
    step "particle hair and Curves objects vs Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_hair.py
    step "object and camera motion blur vs Cycles in the bpy wheel" .venv-bpy/bin/python tests/addon/test_motion_blur.py
    step "the rendered viewport's renderer (prism serve): each kind of edit vs F12 renders in the bpy wheel" .venv-bpy/bin/python tests/addon/test_serve.py
    step "the standalone binary on glTF from Blender's bundled exporter, vs Cycles" quiet_info .venv-bpy/bin/python tests/addon/test_bundled_gltf.py
fi
if [ "$WHICH" = all ] || [ "$WHICH" = background ]; then
    step "add-on tests through blender -b ($(blender --version 2>/dev/null | head -1))" .venv-bpy/bin/python tests/addon/test_background.py
    step "Properties editor panels with Prism in blender -b ($(blender --version 2>/dev/null | head -1))" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_panels.py
    step "Sampling and Light Paths presets in blender -b" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_presets.py
    step "soft lights vs Cycles in blender -b ($(blender --version 2>/dev/null | head -1))" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_lights.py
    step "object and camera motion blur vs Cycles in blender -b ($(blender --version 2>/dev/null | head -1))" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_motion_blur.py
    step "render border, Film Transparent, holdouts vs Cycles in blender -b ($(blender --version 2>/dev/null | head -1))" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_pipeline.py
    step "camera shift and panoramic cameras vs Cycles in blender -b ($(blender --version 2>/dev/null | head -1))" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_camera_world.py -- \
        test_camera_shift_parity test_panoramic_camera_parity
    step "shader node setups and Cycles bakes of unsupported nodes vs Cycles in blender -b ($(blender --version 2>/dev/null | head -1))" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_node_graphs.py -- \
        test_node_setups_match_cycles test_refraction_bsdf_matches_cycles test_unsupported_nodes_are_baked
    step "Blender 3.x's Principled and Clearcoat vs Cycles 3.x in blender -b" blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_energy_parity.py -- \
        test_principled_3x_matches_cycles test_clearcoat_3x_matches_cycles
    step "worlds baked by Cycles vs Cycles in blender -b ($(blender --version 2>/dev/null | head -1))" env PRISM_SKY_MODELS=NISHITA blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_world_bake.py
fi
if [ "$WHICH" = all ] || [ "$WHICH" = interactive ]; then
    step "interactive Blender ($(blender --version 2>/dev/null | head -1)) under Xvfb: Rendered viewport vs F12, engine list, panels, F12, the Properties editor's tabs" .venv-bpy/bin/python tests/addon/test_interactive.py
fi
if [ "$WHICH" = all ] || [ "$WHICH" = package ]; then
    step "packaged zips: extension in bpy 5.0.1, legacy add-on in blender -b 3.4" .venv-bpy/bin/python tests/addon/test_package.py
fi
leftover=$(find "$TMPDIR" -maxdepth 1 -name 'prism_*' -type d | grep -v -E 'prism_(addon|bg|pkg)_test_|prism_interactive_' || true)
if command -v pgrep >/dev/null && pgrep -f 'prism serve' >/dev/null; then echo "prism serve processes left running: $(pgrep -af 'prism serve')" >&2; exit 1; fi
if [ -n "$leftover" ]; then echo "temporary render folders left behind: $leftover" >&2; exit 1; fi
echo "== add-on tests passed"
