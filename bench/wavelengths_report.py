#!/usr/bin/env python3
"""Tables for bench/wavelengths.sh from its rows.tsv (see the script's header for the method).

Usage: wavelengths_report.py ROWS.tsv RES SPP
Rows: group, configuration, seed, wall s, CPU s, rays, relMSE JSON, clamped relMSE JSON (the
JSON lines of examples/bench_relmse.rs: total / glass / rest, each raw / reference / corrected).
"""
import json
import statistics
import sys

rows_path, res, spp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
samples = res * res * spp
runs = {}  # (group, cfg) -> list of dicts
for line in open(rows_path):
    if not line.strip():
        continue
    group, cfg, seed, wall, cpu, rays, e, ec = line.rstrip("\n").split("\t")
    runs.setdefault((group, cfg), []).append(
        dict(seed=int(seed), wall=float(wall), cpu=float(cpu), rays=float(rays),
             e=json.loads(e), ec=json.loads(ec)))
groups = list(dict.fromkeys(g for g, _ in runs))


def med(group, cfg, key):
    return statistics.median(r[key] for r in runs[group, cfg])


def err(group, cfg, kind="corrected", region="total", clamped=False):
    """Mean over seeds of a relMSE value."""
    key = "ec" if clamped else "e"
    return statistics.fmean(r[key][region][kind] for r in runs[group, cfg])


def tiny(x):
    return max(x, 1e-12)


def per_seed_ratios(group, kind="corrected"):
    """single/hero relMSE for each seed (equal spp): the seed-to-seed spread of the ratio."""
    hero = {r["seed"]: r["e"]["total"][kind] for r in runs[group, "hero"]}
    return [r["e"]["total"][kind] / tiny(hero[r["seed"]]) for r in runs[group, "single"]
            if r["seed"] in hero]


def rel_time(group, cfg, key="wall"):
    """cfg / hero seconds per sample: the median over rounds of the ratio of the two runs of a
    round, which ran close together, so that a change of the shared machine's load between
    rounds cancels (a ratio of medians would mix rounds)."""
    hero = {r["seed"]: r[key] for r in runs[group, "hero"]}
    return statistics.median(r[key] / max(hero[r["seed"]], 1e-6)
                             for r in runs[group, cfg] if r["seed"] in hero)


def cost(group):
    """hero / single seconds per sample (wall, CPU)."""
    return 1 / rel_time(group, "single"), 1 / rel_time(group, "single", "cpu")


out = []
main = [g for g in groups if not g.startswith("sweep_")]
out.append("| scene | strategy | seconds | CPU s | µs/sample | rays/sample | relMSE raw | relMSE "
           "corrected | equal-time relMSE, corrected | vs hero (equal time, corrected) "
           "| same, clamped to 1 |")
out.append("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for g in main:
    eh, ech = tiny(err(g, "hero")), tiny(err(g, "hero", clamped=True))
    for cfg in [c for (gg, c) in runs if gg == g and c != "ref"]:
        t = med(g, cfg, "wall")
        eq = err(g, cfg) * rel_time(g, cfg)
        eqc = err(g, cfg, clamped=True) * rel_time(g, cfg)
        out.append(
            f"| {g} | {cfg} | {t:.2f} | {med(g, cfg, 'cpu'):.2f} | {t / samples * 1e6:.2f} | "
            f"{med(g, cfg, 'rays') / samples:.2f} | {err(g, cfg, 'raw'):.4g} | {err(g, cfg):.4g} | "
            f"{eq:.4g} | {eq / eh:.2f}x | {eqc / ech:.2f}x |")
out.append("")
has_lum = all("lum_corrected" in r["e"]["total"] for g in main for r in runs[g, "hero"])
out.append("| scene | reference relMSE (estimated) | single/hero, equal spp: raw; corrected (per-seed "
           "range) | hero/single time per sample: wall; CPU | single/hero, equal wall time: raw; "
           "**corrected** | equal CPU time, corrected |" + (" single/hero, luminance only, equal spp |" if has_lum else ""))
out.append("| --- | --- | --- | --- | --- | --- |" + (" --- |" if has_lum else ""))
for g in main:
    ref = err(g, "hero", "reference")
    raw = err(g, "single", "raw") / tiny(err(g, "hero", "raw"))
    cor = err(g, "single") / tiny(err(g, "hero"))
    seeds = per_seed_ratios(g)
    cw, cc = cost(g)
    lum = (f" {err(g, 'single', 'lum_corrected') / tiny(err(g, 'hero', 'lum_corrected')):.2f} |"
           if has_lum else "")
    out.append(f"| {g} | {ref:.3g} | {raw:.2f}; {cor:.2f} ({min(seeds):.2f}–{max(seeds):.2f}) | "
               f"{cw:.2f}; {cc:.2f} | {raw / cw:.2f}; **{cor / cw:.2f}** | {cor / cc:.2f} |" + lum)
out.append("")
out.append("Error by region (corrected relMSE, contributions to the image mean; `glass`: pixels whose "
           "camera ray hits clear glass):")
out.append("")
out.append("| scene | region | pixels | hero | single | single/hero, equal spp | share of hero's error |")
out.append("| --- | --- | --- | --- | --- | --- | --- |")
for g in main:
    for region in ("glass", "rest"):
        frac = runs[g, "hero"][0]["e"][region]["fraction"]
        if frac == 0:
            continue
        h, s = err(g, "hero", region=region), err(g, "single", region=region)
        out.append(f"| {g} | {region} | {frac:.0%} | {h:.4g} | {s:.4g} | {s / tiny(h):.2f}x | "
                   f"{h / tiny(err(g, 'hero')):.0%} |")
sweep = [g for g in groups if g.startswith("sweep_")]
if sweep:
    out.append("")
    out.append("Glass sweep on rough_dispersive (roughness 0.2; generated materials JSON), hero vs single:")
    out.append("")
    out.append("| glass | hero relMSE (corrected) | single/hero, equal spp: raw; corrected | on glass "
               "pixels | elsewhere | hero/single time per sample (wall; CPU) | single/hero, equal "
               "time, corrected (wall; CPU) |")
    out.append("| --- | --- | --- | --- | --- | --- | --- |")
    for g in sweep + ["rough_dispersive"]:
        if (g, "hero") not in runs:
            continue
        name = "SF11 (committed scene)" if g == "rough_dispersive" else g[len("sweep_"):]
        raw = err(g, "single", "raw") / tiny(err(g, "hero", "raw"))
        cor = err(g, "single") / tiny(err(g, "hero"))
        rg = [err(g, "single", region=x) / tiny(err(g, "hero", region=x)) for x in ("glass", "rest")]
        cw, cc = cost(g)
        out.append(f"| {name} | {err(g, 'hero'):.4g} | {raw:.2f}; {cor:.2f} | {rg[0]:.2f} | "
                   f"{rg[1]:.2f} | {cw:.2f}; {cc:.2f} | {cor / cw:.2f}; {cor / cc:.2f} |")
print("\n".join(out))
