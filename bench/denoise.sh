#!/usr/bin/env bash
# Denoising cost: OIDN (the bpy wheel's, run by the prism binary) at 1920x1080 and 3840x2160 on
# 2 threads, median of N runs, with the process's peak memory. The image is a 1-spp Cornell box
# (the content does not change OIDN's cost; only its size does).
# Two settings: Cycles' final-render defaults (quality high, prefilter accurate) and the fast
# pair (balanced, fast). Cycles' own cost on the same machine: bench/denoise_cycles.py.
#   bench/denoise.sh [RUNS=3] [SIZES="1920x1080 3840x2160"] [SETTINGS="high/accurate balanced/fast"]
#   (needs .venv-bpy: tests/addon/run_addon_tests.sh install)
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-3}
SIZES=${2:-1920x1080 3840x2160}
SETTINGS=${3:-high/accurate balanced/fast}
OIDN=${PRISM_OIDN:-$(ls -d .venv-bpy/lib/python3*/site-packages/bpy/lib | head -1)}
cargo build --release -q
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
for size in $SIZES; do
  for opts in $SETTINGS; do
    w=${size%x*}; h=${size#*x}; set -- ${opts%/*} ${opts#*/}
    times=(); mems=()
    for _ in $(seq "$RUNS"); do
        /usr/bin/time -f "%M" -o "$OUT/mem" ./target/release/prism render scenes/cornell/cornell.gltf \
            --width "$w" --height "$h" --spp 1 --threads 2 --denoise --oidn "$OIDN" \
            --denoise-quality "$1" --denoise-prefilter "$2" \
            --progress json --exr-compression none -o "$OUT/d.exr" 2> "$OUT/log"
        times+=("$(grep '"done"' "$OUT/log" | sed -E 's/.*"denoise_s":([0-9.]+).*/\1/')")
        mems+=("$(cat "$OUT/mem")")
    done
    med=$(printf '%s\n' "${times[@]}" | sort -g | sed -n "$(( (RUNS + 1) / 2 ))p")
    mem=$(printf '%s\n' "${mems[@]}" | sort -g | tail -1)
    echo "{\"size\":\"$size\",\"quality\":\"$1\",\"prefilter\":\"$2\",\"threads\":2,\"denoise_s_median\":$med,\"denoise_s_all\":[$(IFS=,; echo "${times[*]}")],\"peak_rss_mb\":$(( mem / 1024 ))}"
  done
done
