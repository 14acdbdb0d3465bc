#!/usr/bin/env bash
# Equal-time error of the wavelength strategies (issue 5). For each scene, a high-spp hero
# reference rendered as two independent halves (REF_SPP/2 spp each, seeds 1000 and 1001), then
# hero / single / stratified (visible-range wavelength pdf) and hero with the uniform pdf at the
# same spp, all with the same thread count in the same run.
#   (a) scenes/diamond            smooth dispersive glass (secondaries end at the first refraction)
#   (b) scenes/rough_dispersive   rough SF11 glass, roughness 0.2 (all 4 wavelengths live on)
#   (c) scenes/cornell            coloured walls, no dispersion
# then a glass sweep on (b): the same scene with the glass's IOR replaced (a generated copy of
# its materials JSON, passed with --materials; the committed scene is not changed) by a
# constant IOR (no dispersion), BK7, F2 (and SF11, the committed scene itself), hero vs single.
#
# Error: per-pixel relative MSE against the mean of the two reference halves, raw and with the
# reference's own error removed (examples/bench_relmse.rs: the halves' difference estimates the
# reference's variance, which otherwise adds to every strategy alike and pulls ratios towards
# 1), mean over REPEAT seeds (SEED, SEED+1, ...; relMSE is an expectation, so the mean, not
# the median). Also split by region: pixels whose camera ray hits clear glass (the albedo
# guide of the first reference half, rendered with --guides) and the rest. Times are medians
# over the seeds (wall seconds from the `done` event; CPU = user + system of the process).
# Equal-time relMSE = relMSE x (seconds / hero's seconds), the time ratio being the median
# over rounds of the ratio within a round (the relMSE of an unbiased estimator falls as
# 1/time); with wall seconds and, less disturbed by other processes, with CPU seconds.
# Runtime with the defaults on the 2-core VM: about 7 minutes (references ~60%).
# Usage: bench/wavelengths.sh [--append]   (env: RES=128 SPP=64 REF_SPP=2048 THREADS=2 SEED=7
#        REPEAT=4 SWEEP=1 PRISM=path/to/prism; --append adds the tables, date, commit, commands
#        and load to bench/README.md)
set -euo pipefail
cd "$(dirname "$0")/.."
RES=${RES:-128}; SPP=${SPP:-64}; REF_SPP=${REF_SPP:-2048}; THREADS=${THREADS:-2}; SEED=${SEED:-7}
REPEAT=${REPEAT:-4}; SWEEP=${SWEEP:-1}
OUT=${OUT:-/tmp/prism_wavelengths}
append=0
for a in "$@"; do
  case "$a" in
    --append) append=1 ;;
    *) echo "unknown option $a" >&2; exit 2 ;;
  esac
done
mkdir -p "$OUT"
cargo build --release -q --example bench_relmse
RELMSE=./target/release/examples/bench_relmse
if [ -z "${PRISM:-}" ]; then
  cargo build --release -q
  PRISM=./target/release/prism
fi
start=$(date +%s)
load_start=$(cut -d' ' -f1-3 /proc/loadavg)

# r SCENE OUT SPP SEED [extra flags...] -> prints "wall_seconds cpu_seconds rays": wall seconds
# and rays traced (a load-independent measure of the work) from the final `--progress json`
# event, CPU = user + system seconds of the process (less sensitive than wall time to other
# processes on a shared machine).
r() {
  local scene=$1 out=$2 spp=$3 seed=$4
  shift 4
  local done_line
  done_line=$(/usr/bin/time -o "$OUT/last_cpu" -f "%U %S" "$PRISM" render "$scene" -o "$out" \
    --spp "$spp" --seed "$seed" --width "$RES" --height "$RES" --threads "$THREADS" \
    --progress json "$@" 2>&1 | grep '"event":"done"')
  python3 -c 'import json,sys; d=json.loads(sys.argv[1]); c=open(sys.argv[2]).read().split(); print(d["seconds"], float(c[0]) + float(c[1]), d["rays"])' \
    "$done_line" "$OUT/last_cpu"
}

flags_for() {
  case $1 in
    hero-uniform) echo "--wavelengths hero --wavelength-pdf uniform" ;;
    *) echo "--wavelengths $1 --wavelength-pdf visible" ;;
  esac
}

rows="$OUT/rows.tsv"
: > "$rows"
# measure GROUP SCENE MATERIALS CFG... : reference halves, then REPEAT rounds over the
# configurations (all in each round, so that changes of the machine's load hit them alike);
# appends "GROUP CFG SEED WALL CPU RAYS RELMSE_JSON CLAMPED_JSON" rows.
measure() {
  local group=$1 scene=$2 materials=$3
  shift 3
  local mflag=()
  [ -n "$materials" ] && mflag=(--materials "$materials")
  local half=$((REF_SPP / 2))
  echo "== $group: reference, 2 x $half spp" >&2
  local ta tb
  ta=$(r "$scene" "$OUT/${group}_refA.exr" "$half" 1000 "${mflag[@]}" --guides)
  tb=$(r "$scene" "$OUT/${group}_refB.exr" "$half" 1001 "${mflag[@]}")
  echo "   reference halves: $ta / $tb (wall s, CPU s, rays)" >&2
  printf '%s\tref\t1000\t%s\t{}\t{}\n' "$group" "$(echo "$ta" | tr ' ' '\t')" >> "$rows"
  local fwd=("$@") rev=() i
  for ((i = $# - 1; i >= 0; i--)); do rev+=("${fwd[i]}"); done
  for k in $(seq 0 $((REPEAT - 1))); do
    local order=("${fwd[@]}")
    # Odd rounds in reverse order (A B, B A, ...): a steady drift of the machine's load then
    # cancels from the per-round time ratios instead of favouring whichever runs first.
    [ $((k % 2)) = 1 ] && order=("${rev[@]}")
    for cfg in "${order[@]}"; do
      local img="$OUT/${group}_${cfg}_$k.exr" t e ec
      # shellcheck disable=SC2046
      t=$(r "$scene" "$img" "$SPP" $((SEED + k)) "${mflag[@]}" $(flags_for "$cfg"))
      e=$("$RELMSE" "$OUT/${group}_refA.exr" "$OUT/${group}_refB.exr" --mask "$OUT/${group}_refA.exr" "$img")
      ec=$("$RELMSE" "$OUT/${group}_refA.exr" "$OUT/${group}_refB.exr" --mask "$OUT/${group}_refA.exr" --clamp 1 "$img")
      echo "   $cfg seed $((SEED + k)): $t; $(echo "$e" | sed 's/.*"total":{\([^}]*\)}.*/\1/')" >&2
      printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$group" "$cfg" $((SEED + k)) "$(echo "$t" | tr ' ' '\t')" "$e" "$ec" >> "$rows"
    done
  done
}

for name in diamond rough_dispersive cornell; do
  measure "$name" "scenes/$name/$name.gltf" "" hero single stratified hero-uniform
done
if [ "$SWEEP" = 1 ]; then
  # Variants of (b)'s glass at the committed roughness: constant IOR (SF11's n_d = 1.7847, no
  # dispersion), BK7 (Abbe number 64), F2 (36); SF11 (25.7) is the committed scene above.
  base=scenes/rough_dispersive/rough_dispersive.materials.json
  for glass in ior1.7847 BK7 F2; do
    python3 - "$base" "$glass" "$OUT/sweep_$glass.materials.json" <<'PY'
import json, sys
base, glass, out = sys.argv[1:]
d = json.load(open(base))
(name, mat), = d["materials"].items()  # the scene's single (glass) material
diel = mat["dielectric"]
for k in ("ior", "cauchy", "sellmeier", "abbe", "preset"):
    diel.pop(k, None)
if glass.startswith("ior"):
    diel["ior"] = float(glass[3:])
else:
    diel["preset"] = glass
json.dump(d, open(out, "w"), indent=1)
PY
    measure "sweep_$glass" scenes/rough_dispersive/rough_dispersive.gltf \
      "$OUT/sweep_$glass.materials.json" hero single
  done
fi
elapsed=$(( $(date +%s) - start ))

table=$(python3 bench/wavelengths_report.py "$rows" "$RES" "$SPP")
echo "$table"
echo "bench/wavelengths.sh took ${elapsed} s" >&2

if [ $append = 1 ]; then
  rev=$(git rev-parse --short HEAD)
  dirty=$(git diff --quiet -- src && echo "" || echo " (+ uncommitted src changes of the shared tree)")
  {
    echo
    echo "### Wavelength strategies, equal time, reference error removed ($(date -u '+%Y-%m-%d %H:%M UTC'), commit $rev$dirty)"
    echo
    echo "\`RES=$RES SPP=$SPP REF_SPP=$REF_SPP THREADS=$THREADS SEED=$SEED REPEAT=$REPEAT SWEEP=$SWEEP bench/wavelengths.sh --append\`"
    echo "(${elapsed} s): each scene rendered at ${RES}x${RES} with \`prism render SCENE --spp $SPP --seed S"
    echo "--threads $THREADS --wavelengths W --wavelength-pdf P\` for S = $SEED..$((SEED + REPEAT - 1)), against a"
    echo "hero reference of two halves at $((REF_SPP / 2)) spp (seeds 1000 and 1001, same threads). relMSE: mean"
    echo "over the seeds of the per-pixel relative MSE, raw and corrected (reference error removed,"
    echo "\`examples/bench_relmse.rs\`); seconds: medians; equal-time relMSE = relMSE x seconds / hero's seconds."
    echo "Load average at start: $load_start, at end: $(cut -d' ' -f1-3 /proc/loadavg) (2-core VM shared with other sessions)."
    echo
    echo "$table"
  } >> bench/README.md
  echo "appended to bench/README.md" >&2
fi
