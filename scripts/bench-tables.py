#!/usr/bin/env python3
"""Markdown tables for BENCHMARKS.md from one `softshadow bench` run's results.csv.

    scripts/bench-tables.py DIR/results.csv > tables.md

Prints, from the rows at one buffer size and radius per scene (the run BENCHMARKS.md
records: `bench --full --width 512 --height 512 --resolutions 1024 --radii scene`):
1. per scene, one row per technique: frame ms, x hard, the passes' median ms, counted work
   per image pixel (the final pass's fragments; the texels the frame read, plain and per
   warp, light passes included; each with its ratio to hard's), mae_lit, p99_lit, flip,
   false edges per 1,000 penumbra pixels, mae_shadow; then the Pareto front on
   (x hard, mae_lit);
2. per technique over the scenes: mean mae_lit, on how many scenes it beats hard's mae_lit,
   mean flip, median x hard; then the two rankings (medians over the scenes of x hard, of
   the frame's warp lookups and its final pass's over hard's, of the plain lookups, and of
   the false edges per 1,000 penumbra pixels);
3. the fast-and-accurate goals of the accurate forms (frame time, warp lookups and false
   edges against hard's, mae_lit against pcss's), worst scene first, so that a missed goal
   shows by how much;
4. the sun scenes (`light_kind` sun) apart, after the spotlights' sections: their per-scene
   tables (at the scene's angular radius) and the per-technique summary over them (only the
   techniques that serve a sun have rows there).

Standard library only. Figures are printed as the bench wrote them, rounded for reading.
"""
import csv
import statistics
import sys
from collections import OrderedDict


def fmt_ms(x):
    return f"{x:.2f}" if x < 100 else f"{x:.1f}"


def fmt_pass(x):
    return f"{x:.3g}" if x < 100 else f"{x:.0f}"


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"error: bench-tables.py: {path} holds no rows")
    scenes = OrderedDict()
    for r in rows:
        if r["motion"] != "static" or r.get("spirv", "glslang") != "glslang":
            continue
        scenes.setdefault(r["scene"], []).append(r)
    return scenes


def is_sun(rows):
    """Whether a scene's rows are lit by a sun (older results.csv files have no light_kind)."""
    return rows[0].get("light_kind") == "sun"


def label(r):
    """The row's name as the bench's report prints it (`smoothies t=0.02` for a fixed t)."""
    return r["technique"] or r["technique_name"]


def passes(r):
    out = []
    for k, v in r.items():
        if k.startswith("pass:") and v not in ("", None):
            out.append(f"{k.split('/', 1)[1]} {fmt_pass(float(v))}")
    cpu = float(r["cpu_ms_median"] or 0)
    if cpu > 0:
        out.append(f"cpu {fmt_pass(cpu)}")
    return " · ".join(out)


def final_count(r, prefix):
    """Count `prefix` per image pixel, or None where the run has no such column (no pipeline
    statistics, an older schema): the final pass's fragments (frags), or the texels the whole
    frame read (texels, texels_warp: the light passes' and the final pass's, summed)."""
    pixels = float(r["width"]) * float(r["height"])
    found = [float(v) for k, v in r.items()
             if k.startswith(prefix + ":") and v not in ("", None)
             and (prefix != "frags" or k.endswith("/final"))]
    return sum(found) / pixels if found else None


def count_cell(r, hard, prefix):
    x, h = final_count(r, prefix), final_count(hard, prefix)
    if x is None:
        return "–"
    if not h:
        return f"{x:.2f}"
    return f"{x:.2f} ({x / h:.2f}×)"


def false_edges(r):
    """False edges per 1,000 penumbra pixels, or – for a run from before the column."""
    v = r.get("false_edges")
    return "–" if v in ("", None) else f"{float(v):.1f}"


def pareto(rows):
    front, best = [], float("inf")
    for r in sorted(rows, key=lambda r: (float(r["ratio_to_hard"]), float(r["mae_lit"]))):
        if float(r["mae_lit"]) < best:
            best = float(r["mae_lit"])
            front.append(label(r))
    return front


def scene_tables(scenes):
    for scene, rows in scenes.items():
        print(f"### {scene}")
        hard = next(r for r in rows if label(r) == "hard")
        print("| technique | frame ms | × hard | passes, median ms | frags/px | lookups/px | warp lookups/px | mae_lit | p99_lit | flip | false edges ‰ | mae_shadow |")
        print("|:---|---:|---:|:---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for r in rows:
            print(
                f"| {label(r)} | {fmt_ms(float(r['frame_ms_median']))} "
                f"| {float(r['ratio_to_hard']):.2f} | {passes(r)} "
                f"| {count_cell(r, hard, 'frags')} | {count_cell(r, hard, 'texels')} "
                f"| {count_cell(r, hard, 'texels_warp')} "
                f"| {float(r['mae_lit']):.3f} | {float(r['p99_lit']):.2f} "
                f"| {float(r['flip']):.4f} | {false_edges(r)} | {float(r['mae_shadow']):.3f} |"
            )
        by_err = sorted(rows, key=lambda r: float(r["mae_lit"]))
        by_flip = min(rows, key=lambda r: float(r["flip"]))
        lowest = " then ".join(
            f"{label(r)} ({float(r['mae_lit']):.3f})" for r in by_err[:2]
        )
        light = (
            f"Sun, angular radius {float(rows[0]['angular_radius_deg']):g}°"
            if is_sun(rows)
            else f"R = {float(rows[0]['light_radius']):.4f}"
        )
        print(
            f"\n{light}. Pareto front: {' → '.join(pareto(rows))}. "
            f"Lowest mae_lit: {lowest}; "
            f"lowest flip: {label(by_flip)} ({float(by_flip['flip']):.4f}).\n"
        )


def by_technique(scenes):
    out = OrderedDict()
    for scene, rows in scenes.items():
        hard = next(r for r in rows if label(r) == "hard")
        for r in rows:
            out.setdefault(label(r), []).append((scene, r, hard))
    return out


def summary(scenes):
    n = len(scenes)
    print("| technique | mae_lit, mean over scenes | beats hard's mae_lit on | flip, mean | × hard, median over scenes |")
    print("|:---|---:|---:|---:|---:|")
    for name, items in by_technique(scenes).items():
        mae = statistics.mean(float(r["mae_lit"]) for _, r, _ in items)
        flip = statistics.mean(float(r["flip"]) for _, r, _ in items)
        ratio = statistics.median(float(r["ratio_to_hard"]) for _, r, _ in items)
        beats = sum(float(r["mae_lit"]) < float(h["mae_lit"]) for _, r, h in items)
        beats = "–" if name == "hard" else f"{beats} of {n} scenes"
        print(f"| {name} | {mae:.3f} | {beats} | {flip:.4f} | {ratio:.2f} |")
    print()


def final_pass_warp(r):
    """The final pass's warp-summed texels per image pixel, or None without the column."""
    pixels = float(r["width"]) * float(r["height"])
    found = [float(v) for k, v in r.items()
             if k.startswith("texels_warp:") and k.endswith("/final") and v not in ("", None)]
    return sum(found) / pixels if found else None


def rankings(scenes):
    """Per technique, medians over the scenes of its ratios to hard's: frame time, the
    frame's warp lookups, the final pass's share of them (both over hard's whole frame),
    the frame's plain lookups; and the median false edges per 1,000 penumbra pixels."""
    print("| technique | time | warp lookups, frame | of which final pass | plain lookups, frame | false edges ‰ |")
    print("|:---|---:|---:|---:|---:|---:|")
    for name, items in by_technique(scenes).items():
        def median_of(f):
            xs = [f(r, h) for _, r, h in items]
            xs = [x for x in xs if x is not None]
            return statistics.median(xs) if xs else None

        def ratio(count):
            def f(r, h):
                x, y = count(r), count(h)
                return x / y if x is not None and y else None
            return f

        def final_over_frame(r, h):
            x, y = final_pass_warp(r), warp(h)
            return x / y if x is not None and y else None

        cells = [
            median_of(lambda r, h: float(r["ratio_to_hard"])),
            median_of(ratio(warp)),
            median_of(final_over_frame),
            median_of(ratio(lambda r: final_count(r, "texels"))),
        ]
        edges = median_of(lambda r, h: fe(r))
        text = ["–" if c is None else f"{c:.2f}" for c in cells]
        text.append("–" if edges is None else f"{edges:.0f}")
        print(f"| {name} | " + " | ".join(text) + " |")
    print()


CENTRED = ["smoothies-centred", "penumbra-map-centred", "plateaus-centred"]
BITMASK = ["ssm-bitmask"]
# Scenes whose frame goal for the centred forms is looser (many casters, many silhouettes).
DENSE = ("dense", "dense-1m")


def warp(r):
    return final_count(r, "texels_warp")


def fe(r):
    v = r.get("false_edges")
    return None if v in ("", None) else float(v)


def checks_for(name, pcss):
    """(label, per-scene value and limit) of the fast-and-accurate goals that apply to `name`."""
    out = []
    if name in CENTRED:
        out.append(("frame ≤ 1.3x hard's (dense: 1.6x)",
                    lambda s, r, h: (float(r["ratio_to_hard"]), 1.6 if s in DENSE else 1.3)))
        out.append(("warp lookups ≤ 1.5x hard's",
                    lambda s, r, h: (warp(r) / warp(h) if warp(r) and warp(h) else None, 1.5)))
        out.append(("false edges ≤ 0.15x hard's",
                    lambda s, r, h: (fe(r) / fe(h) if fe(r) is not None and fe(h) else None, 0.15)))
        out.append(("mae_lit ≤ 1.0x pcss's",
                    lambda s, r, h: (float(r["mae_lit"]) / max(pcss[s], 1e-9), 1.0)))
    if name in BITMASK:
        out.append(("frame ≤ 3x hard's", lambda s, r, h: (float(r["ratio_to_hard"]), 3.0)))
        out.append(("mae_lit ≤ 1.0x pcss's",
                    lambda s, r, h: (float(r["mae_lit"]) / max(pcss[s], 1e-9), 1.0)))
    return out


def targets(scenes):
    techs = by_technique(scenes)
    pcss = {s: float(r["mae_lit"]) for s, r, _ in techs.get("pcss", [])}
    if set(pcss) != set(scenes):
        print("(the run has no `pcss` row on every scene: no targets)\n")
        return
    print("| technique | target | worst scene | worst value / its limit | scenes meeting it |")
    print("|:---|:---|:---|---:|---:|")
    for name in CENTRED + BITMASK:
        items = techs.get(name)
        if not items:
            continue
        for label_, check in checks_for(name, pcss):
            values = [(s, *check(s, r, h)) for s, r, h in items]
            values = [(s, v, lim) for s, v, lim in values if v is not None]
            if not values:
                continue
            worst = max(values, key=lambda v: v[1] / v[2])
            met = sum(v <= lim for _, v, lim in values)
            print(f"| {name} | {label_} | {worst[0]} | {worst[1]:.2f}x / {worst[2]}x | {met} of {len(values)} |")
    # The new Pareto front the goals ask for: mae_lit ≤ pcss's on every scene at ≤ 1.3x hard.
    winners = [
        name for name, items in techs.items()
        if name != "pcss" and all(
            float(r["mae_lit"]) <= pcss[s] and float(r["ratio_to_hard"]) <= 1.3 for s, r, _ in items
        )
    ]
    print(
        "\nA technique with mae_lit ≤ pcss's on every scene at ≤ 1.3x hard's frame: "
        + (", ".join(winners) if winners else "none in this run") + ".\n"
    )


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: scripts/bench-tables.py DIR/results.csv")
    everything = load(sys.argv[1])
    scenes = OrderedDict((k, v) for k, v in everything.items() if not is_sun(v))
    suns = OrderedDict((k, v) for k, v in everything.items() if is_sun(v))
    if scenes:
        print("## Per scene\n")
        scene_tables(scenes)
        print("## Across scenes\n")
        summary(scenes)
        print("## Two rankings\n")
        rankings(scenes)
        print("## Targets\n")
        targets(scenes)
    if suns:
        print("## Sun\n")
        scene_tables(suns)
        print("### Across the sun scenes\n")
        summary(suns)


if __name__ == "__main__":
    main()
