#!/usr/bin/env bash
# Prism benchmarks in one run, so the numbers share the machine's state:
#   1. criterion micro-benches (BVH traversal, BSDF sampling), short measurement windows;
#   2. `prism bench` on the Cornell box: samples/s and rays/s per thread, median of N runs;
#   3. Blender Cycles (bpy wheel) on the same glTF, same resolution, spp, bounces and threads,
#      then the Prism/Cycles time ratio.
# Usage: bench/run.sh [--no-criterion] [--no-cycles]   (env: SIZE=256 SPP=64 THREADS=2 REPEAT=3)
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${SIZE:-256}; SPP=${SPP:-64}; THREADS=${THREADS:-2}; REPEAT=${REPEAT:-3}
SCENE=${SCENE:-scenes/cornell/cornell.gltf}
VENV=${PRISM_BPY_VENV:-.venv-bpy}
run_criterion=1; run_cycles=1
for a in "$@"; do
  case "$a" in
    --no-criterion) run_criterion=0 ;;
    --no-cycles) run_cycles=0 ;;
    *) echo "unknown option $a" >&2; exit 2 ;;
  esac
done

cargo build --release --quiet
if [ $run_criterion = 1 ]; then
  echo "== criterion"
  cargo bench --quiet --bench bvh --bench bsdf -- --warm-up-time 1 --measurement-time 3 2>/dev/null \
    | grep -E '^[a-z_/0-9]+( |$)|time:|thrpt:' | grep -v '%' || true
fi

echo "== prism bench: $SCENE ${SIZE}x${SIZE}, $SPP spp, threads 1,$THREADS, median of $REPEAT"
prism_json=$(./target/release/prism bench "$SCENE" --width "$SIZE" --height "$SIZE" --spp "$SPP" \
  --threads "1,$THREADS" --repeat "$REPEAT")
echo "$prism_json"

if [ $run_cycles = 1 ]; then
  if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c 'import bpy' 2>/dev/null; then
    echo "== installing the bpy wheel into $VENV (about 375 MB)"
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install --quiet bpy==5.0.1 numpy
  fi
  echo "== Cycles: same scene and settings, $THREADS threads, median of $REPEAT"
  times=()
  for _ in $(seq "$REPEAT"); do
    line=$("$VENV/bin/python" bench/cycles_reference.py "$SCENE" --out /tmp/prism_bench_cycles.exr \
      --width "$SIZE" --height "$SIZE" --spp "$SPP" --threads "$THREADS" --max-bounces 16 \
      --one-sided-emission --quiet | tail -1)
    echo "$line"
    times+=("$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["seconds"])' "$line")")
  done
  cycles_median=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
  prism_median=$(printf '%s\n' "$prism_json" | python3 -c "
import json,sys
for l in sys.stdin:
    d=json.loads(l)
    if d['threads']==$THREADS: print(d['seconds_median'])")
  python3 - "$prism_median" "$cycles_median" <<'PY'
import sys
p, c = float(sys.argv[1]), float(sys.argv[2])
print(f"== ratio: prism {p:.3f} s vs cycles {c:.3f} s  ->  prism/cycles time = {p / c:.2f}x")
PY
fi
