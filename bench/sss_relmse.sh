#!/usr/bin/env bash
# Equal-time relative MSE of the SSS table method vs the random walk on the SSS Cornell box
# (scenes/sss/cornell_{sss,walk}.gltf), each against its own high-spp reference, plus the
# difference between the two converged references (the diffusion model's bias).
# Usage: bench/sss_relmse.sh [RES] [REF_SPP] [TABLE_SPP] [THREADS]
set -euo pipefail
cd "$(dirname "$0")/.."
RES=${1:-96}
REF_SPP=${2:-2048}
TABLE_SPP=${3:-32}
THREADS=${4:-2}
OUT=${OUT:-/tmp/prism_sss_relmse}
mkdir -p "$OUT"
P=./target/release/prism
cargo build --release -q
r() { # scene spp seed out
  "$P" render "scenes/sss/$1.gltf" -o "$2" --spp "$3" --seed "$4" --width "$RES" --height "$RES" \
    --threads "$THREADS" --progress none 2>&1 | sed -n 's/.* in \([0-9.]*\) s.*/\1/p'
}
echo "references ($REF_SPP spp)..."
t_ref_table=$(r cornell_sss "$OUT/ref_table.exr" "$REF_SPP" 1000)
t_ref_walk=$(r cornell_walk "$OUT/ref_walk.exr" "$REF_SPP" 1000)
echo "reference times: table $t_ref_table s, walk $t_ref_walk s"
t_table=$(r cornell_sss "$OUT/table.exr" "$TABLE_SPP" 7)
# Walk spp for the same time, from the reference timings.
WALK_SPP=$(python3 -c "print(max(1, round($TABLE_SPP * $t_ref_table / $t_ref_walk)))")
t_walk=$(r cornell_walk "$OUT/walk.exr" "$WALK_SPP" 7)
echo "table: $TABLE_SPP spp in $t_table s"
"$P" compare "$OUT/table.exr" "$OUT/ref_table.exr"
echo "walk: $WALK_SPP spp in $t_walk s"
"$P" compare "$OUT/walk.exr" "$OUT/ref_walk.exr"
echo "table reference vs walk reference (bias of the diffusion table, 8x8 blocks):"
"$P" compare "$OUT/ref_table.exr" "$OUT/ref_walk.exr" --block 8
