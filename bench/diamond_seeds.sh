#!/usr/bin/env bash
# Issue 5 target (a) with more seeds: hero vs single on scenes/diamond at equal CPU time. The
# diamond's per-pixel relMSE is dominated by rare caustic fireflies, so the per-seed
# single/hero ratio scatters widely (0.9-1.6) and bench/wavelengths.sh's 4 seeds cannot tell a
# few percent; this runs N seeds (default 16, alternating the order each round) against the
# reference halves bench/wavelengths.sh left in $OUT (run that first) and prints the equal-spp
# ratio, the per-round CPU-time ratio and a bootstrap 90% interval of the equal-time ratio.
# Usage: bench/diamond_seeds.sh   (env: N=16 SEED=100 OUT=/tmp/prism_wavelengths)
set -euo pipefail
cd "$(dirname "$0")/.."
N=${N:-16}; SEED=${SEED:-100}; OUT=${OUT:-/tmp/prism_wavelengths}
[ -f "$OUT/diamond_refA.exr" ] || { echo "run bench/wavelengths.sh first (needs $OUT/diamond_refA.exr)" >&2; exit 2; }
cargo build --release -q
cargo build --release -q --example bench_relmse
P=./target/release/prism; RELMSE=./target/release/examples/bench_relmse
rows="$OUT/diamond_seeds.txt"; : > "$rows"
for k in $(seq 0 $((N - 1))); do
  order="hero single"; [ $((k % 2)) = 1 ] && order="single hero"
  for w in $order; do
    img="$OUT/dseed_${w}_$k.exr"
    /usr/bin/time -o "$OUT/cpu" -f "%U %S" "$P" render scenes/diamond/diamond.gltf -o "$img" \
      --spp 64 --seed $((SEED + k)) --width 128 --height 128 --threads 2 --wavelengths "$w" --progress none 2>/dev/null
    e=$("$RELMSE" "$OUT/diamond_refA.exr" "$OUT/diamond_refB.exr" --mask "$OUT/diamond_refA.exr" "$img")
    echo "$k $w $(awk '{print $1 + $2}' "$OUT/cpu") $e" >> "$rows"
  done
done
python3 - "$rows" <<'PY'
import json, random, re, statistics as st, sys
H, S = {}, {}
for line in open(sys.argv[1]):
    k, w, cpu, rest = line.split(None, 3)
    e = float(re.search(r'"corrected":([0-9.eE+-]+)', rest).group(1))
    (H if w == "hero" else S)[int(k)] = (float(cpu), e)
ks = sorted(H)
def ratio(sel):
    spp = st.mean(S[k][1] for k in sel) / st.mean(H[k][1] for k in sel)
    cost = st.median(H[k][0] / S[k][0] for k in sel)
    return spp, cost, spp / cost
spp, cost, eq = ratio(ks)
random.seed(1)
boot = sorted(ratio([random.choice(ks) for _ in ks])[2] for _ in range(2000))
print("seeds %d: single/hero relMSE at equal spp %.3f (per seed %.2f-%.2f); hero/single CPU per sample %.3f;"
      " single/hero at equal CPU time %.3f, bootstrap 90%% interval %.3f-%.3f"
      % (len(ks), spp, min(S[k][1] / H[k][1] for k in ks), max(S[k][1] / H[k][1] for k in ks), cost, eq,
         boot[100], boot[1900]))
PY
