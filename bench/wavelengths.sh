#!/usr/bin/env bash
# Equal-time error of the wavelength strategies (issue 5): for each scene, a high-spp hero
# reference, then hero / single / stratified (visible-range wavelength pdf) and hero with the
# uniform pdf at the same spp, all with the same thread count in the same run. Reports seconds,
# microseconds per sample, relative MSE against the reference (per pixel, `prism compare`), and
# the equal-time relative MSE = relMSE x seconds / hero's seconds (relMSE of an unbiased
# estimator falls as 1/time), plus single/hero ratios. Also relMSE with both images clamped to
# [0, 1] (`prism compare --clamp 1`): one firefly can dominate a single run's per-pixel relMSE.
#   (a) scenes/diamond            smooth dispersive glass (secondaries end at the first refraction)
#   (b) scenes/rough_dispersive   rough SF11-like glass, roughness 0.2 (all 4 wavelengths live on)
#   (c) scenes/cornell            coloured walls, no dispersion
# Usage: bench/wavelengths.sh [--append]   (env: RES=128 SPP=64 REF_SPP=2048 THREADS=2 SEED=7 REPEAT=3
#        PRISM=path/to/prism; --append adds the table, date and commands to bench/README.md)
set -euo pipefail
cd "$(dirname "$0")/.."
RES=${RES:-128}; SPP=${SPP:-64}; REF_SPP=${REF_SPP:-2048}; THREADS=${THREADS:-2}; SEED=${SEED:-7}
REPEAT=${REPEAT:-3}
OUT=${OUT:-/tmp/prism_wavelengths}
append=0
for a in "$@"; do
  case "$a" in
    --append) append=1 ;;
    *) echo "unknown option $a" >&2; exit 2 ;;
  esac
done
mkdir -p "$OUT"
if [ -z "${PRISM:-}" ]; then
  cargo build --release -q
  PRISM=./target/release/prism
fi

# render SCENE OUT SPP SEED [extra flags...] -> prints the render's wall-clock seconds; the rays
# traced (a load-independent measure of the work; both from the final `--progress json` event)
# go to $OUT/last_rays, the process's user + system CPU seconds (less sensitive than wall time
# to other processes on a shared machine) to $OUT/last_cpu.
r() {
  local scene=$1 out=$2 spp=$3 seed=$4
  shift 4
  local done_line
  done_line=$(/usr/bin/time -o "$OUT/last_cpu" -f "%U %S" "$PRISM" render "$scene" -o "$out" \
    --spp "$spp" --seed "$seed" --width "$RES" --height "$RES" --threads "$THREADS" \
    --progress json "$@" 2>&1 | grep '"event":"done"')
  python3 -c 'import json,sys; d=json.loads(sys.argv[1]); print(d["rays"], file=open(sys.argv[2], "w")); print(d["seconds"])' \
    "$done_line" "$OUT/last_rays"
}
relmse() { "$PRISM" compare "$@" | sed -n 's/.*"rel_mse":\([0-9.eE+-]*\).*/\1/p'; }

CFGS=(hero single stratified hero-uniform)
flags_for() {
  case $1 in
    hero-uniform) echo "--wavelengths hero --wavelength-pdf uniform" ;;
    *) echo "--wavelengths $1 --wavelength-pdf visible" ;;
  esac
}
mean() { python3 -c 'import sys; v=[float(x) for x in sys.argv[1:]]; print(sum(v)/len(v))' "$@"; }

rows="$OUT/rows.tsv"
: > "$rows"
for name in diamond rough_dispersive cornell; do
  scene="scenes/$name/$name.gltf"
  echo "== $name: reference hero, $REF_SPP spp" >&2
  t_ref=$(r "$scene" "$OUT/${name}_ref.exr" "$REF_SPP" 1000)
  echo "   reference: $t_ref s" >&2
  # REPEAT rounds with seeds SEED, SEED+1, ...; the strategies alternate within a round so
  # that changes of the machine's load hit them alike. Mean seconds, rays and relMSE.
  declare -A ts=() es=() ecs=() rs=() cs=()
  for k in $(seq 0 $((REPEAT - 1))); do
    for cfg in "${CFGS[@]}"; do
      img="$OUT/${name}_${cfg}_$k.exr"
      # shellcheck disable=SC2046
      ts[$cfg]+=" $(r "$scene" "$img" "$SPP" $((SEED + k)) $(flags_for "$cfg"))"
      rs[$cfg]+=" $(cat "$OUT/last_rays")"
      cs[$cfg]+=" $(python3 -c 'import sys; print(sum(map(float, sys.argv[1:])))' $(cat "$OUT/last_cpu"))"
      es[$cfg]+=" $(relmse "$img" "$OUT/${name}_ref.exr")"
      ecs[$cfg]+=" $(relmse "$img" "$OUT/${name}_ref.exr" --clamp 1)"
    done
  done
  for cfg in "${CFGS[@]}"; do
    # shellcheck disable=SC2086
    t=$(mean ${ts[$cfg]}); e=$(mean ${es[$cfg]}); ec=$(mean ${ecs[$cfg]}); rays=$(mean ${rs[$cfg]})
    cpu=$(mean ${cs[$cfg]})
    echo "   $cfg:${ts[$cfg]} s (CPU${cs[$cfg]} s), relMSE${es[$cfg]} (clamped to 1:${ecs[$cfg]})" >&2
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$cfg" "$t" "$e" "$t_ref" "$ec" "$rays" "$cpu" >> "$rows"
  done
  unset ts es ecs rs cs
done

table=$(python3 - "$rows" "$RES" "$SPP" <<'PY'
import sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1]) if l.strip()]
res, spp = int(sys.argv[2]), int(sys.argv[3])
samples = res * res * spp
by = {}
clamped, rays, cpu = {}, {}, {}
for scene, cfg, t, e, tref, ec, nr, c in rows:
    by.setdefault(scene, {})[cfg] = (float(t), float(e), float(tref))
    clamped[scene, cfg] = float(ec)
    rays[scene, cfg] = float(nr) / samples
    cpu[scene, cfg] = float(c)
print("| scene | strategy | seconds | CPU s | µs/sample | rays/sample | relMSE | equal-time relMSE "
      "| vs hero (equal time) | equal-time relMSE, clamped to 1 | vs hero |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
summary = []
for scene, cfgs in by.items():
    th, eh, _ = cfgs["hero"]
    th, eh = max(th, 1e-6), max(eh, 1e-12)  # tiny trial runs report 0.00 s
    ech = max(clamped[scene, "hero"], 1e-12)
    for cfg, (t, e, _) in cfgs.items():
        eq = e * t / th
        eqc = clamped[scene, cfg] * t / th
        print(f"| {scene} | {cfg} | {t:.2f} | {cpu[scene, cfg]:.2f} | {t / samples * 1e6:.2f} | "
              f"{rays[scene, cfg]:.2f} | "
              f"{e:.4g} | {eq:.4g} | {eq / eh:.2f}x | {eqc:.4g} | {eqc / ech:.2f}x |")
    ts, es, _ = cfgs["single"]
    ts = max(ts, 1e-6)
    summary.append(f"{scene}: single/hero relMSE {es / eh:.2f}x at equal spp, "
                   f"{es * ts / th / eh:.2f}x at equal time; "
                   f"hero/single time per sample {th / ts:.2f}x (CPU time "
                   f"{cpu[scene, 'hero'] / max(cpu[scene, 'single'], 1e-9):.2f}x, rays per sample "
                   f"{rays[scene, 'hero'] / max(rays[scene, 'single'], 1e-9):.2f}x); uniform/visible pdf (hero) "
                   f"{cfgs['hero-uniform'][1] * cfgs['hero-uniform'][0] / th / eh:.2f}x")
print()
for s in summary:
    print("- " + s)
PY
)
echo "$table"

if [ $append = 1 ]; then
  rev=$(git rev-parse --short HEAD)
  dirty=$(git diff --quiet -- src && echo "" || echo " (+ uncommitted src changes of the shared tree)")
  {
    echo
    echo "### Wavelength strategies, equal time ($(date -u '+%Y-%m-%d %H:%M UTC'), commit $rev$dirty)"
    echo
    echo "\`RES=$RES SPP=$SPP REF_SPP=$REF_SPP THREADS=$THREADS SEED=$SEED REPEAT=$REPEAT bench/wavelengths.sh --append\`:"
    echo "each scene rendered at ${RES}x${RES} with \`prism render SCENE --spp $SPP --seed S --threads $THREADS"
    echo "--wavelengths S --wavelength-pdf P\`, against a hero reference at $REF_SPP spp (seed 1000, same threads);"
    echo "for S = $SEED..$((SEED + REPEAT - 1)) (seconds and relMSE are means over the $REPEAT runs);"
    echo "relMSE per pixel (\`prism compare\`), equal-time relMSE = relMSE x seconds / hero's seconds."
    echo "Load average during the run: $(cut -d' ' -f1-3 /proc/loadavg) (2-core VM shared with other sessions)."
    echo
    echo "$table"
  } >> bench/README.md
  echo "appended to bench/README.md" >&2
fi
