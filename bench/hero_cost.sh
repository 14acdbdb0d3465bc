#!/usr/bin/env bash
# Per-sample cost of `--wavelengths hero` vs `single` on one scene, for one or more prism
# binaries (e.g. before / after a change): single-threaded renders, the configurations
# alternating within each round so that load changes of a shared machine hit them alike;
# prints the median and the minimum user CPU seconds of each (binary, strategy) and
# hero/single per binary (the minimum is the run least disturbed by other processes: on a
# loaded machine CPU time also grows, through shared caches and cores).
# Usage: bench/hero_cost.sh SCENE BINARY... (env: RES=128 SPP=64 ROUNDS=5)
set -euo pipefail
RES=${RES:-128}; SPP=${SPP:-64}; ROUNDS=${ROUNDS:-5}
scene=$1
shift
out=$(mktemp -d)
for k in $(seq 1 "$ROUNDS"); do
  for bin in "$@"; do
    for w in hero single; do
      /usr/bin/time -o "$out/t" -f "%U" "$bin" render "$scene" -o "$out/img.exr" --spp "$SPP" \
        --width "$RES" --height "$RES" --threads 1 --seed "$k" --wavelengths "$w" --progress none \
        2>/dev/null
      echo "$bin $w $(cat "$out/t")" >> "$out/times"
    done
  done
done
python3 - "$out/times" <<'PY'
import statistics, sys
t = {}
for line in open(sys.argv[1]):
    b, w, s = line.split()
    t.setdefault((b, w), []).append(float(s))
for b in dict.fromkeys(k[0] for k in t):
    h, s = statistics.median(t[b, "hero"]), statistics.median(t[b, "single"])
    hm, sm = min(t[b, "hero"]), min(t[b, "single"])
    print(f"{b}: hero {h:.3f} s, single {s:.3f} s (medians of {len(t[b, 'hero'])}; user CPU), "
          f"hero/single {h / s:.3f}; minima {hm:.3f} / {sm:.3f} s = {hm / sm:.3f}")
PY
rm -r "$out"
