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
   mean flip, median x hard;
3. the accuracy and speed targets of the accurate forms (ratios of mae_lit to pcss's and
   hard's, frame time to hard's), worst scene first, so that a missed target shows by how
   much.

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
        print(
            f"\nR = {float(rows[0]['light_radius']):.4f}. Pareto front: {' → '.join(pareto(rows))}. "
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


# (technique, its paper form or None, max mae_lit / pcss's, max mae_lit / hard's, max x hard)
TARGETS = [
    ("smoothies-centred", "smoothies", 1.5, 0.5, 1.3),
    ("penumbra-map-centred", "penumbra-map", 1.5, 0.5, None),
    ("plateaus-centred", "plateaus", 1.5, 0.5, None),
    ("ssm-bitmask", "ssm", 1.0, 0.5, None),
    ("ssm2-bitmask", "ssm2", 1.0, 0.5, None),
]


def targets(scenes):
    techs = by_technique(scenes)
    pcss = {s: float(r["mae_lit"]) for s, r, _ in techs.get("pcss", [])}
    if set(pcss) != set(scenes):
        print("(the run has no `pcss` row on every scene: no targets)\n")
        return
    print("| technique | target | worst scene | worst value | scenes meeting it |")
    print("|:---|:---|:---|---:|---:|")
    for name, _paper, vs_pcss, vs_hard, time in TARGETS:
        items = techs.get(name)
        if not items:
            continue
        checks = []
        if vs_pcss is not None:
            checks.append((f"mae_lit ≤ {vs_pcss}x pcss's", vs_pcss,
                           [(s, float(r["mae_lit"]) / max(pcss[s], 1e-9)) for s, r, _ in items]))
        if vs_hard is not None:
            checks.append((f"mae_lit ≤ {vs_hard}x hard's", vs_hard,
                           [(s, float(r["mae_lit"]) / max(float(h["mae_lit"]), 1e-9)) for s, r, h in items]))
        if time is not None:
            checks.append((f"frame ≤ {time}x hard's", time,
                           [(s, float(r["ratio_to_hard"])) for s, r, _ in items]))
        for label, limit, values in checks:
            worst = max(values, key=lambda v: v[1])
            met = sum(v <= limit for _, v in values)
            print(f"| {name} | {label} | {worst[0]} | {worst[1]:.2f}x | {met} of {len(values)} |")
    # Is any technique at least as accurate as pcss on every scene within 1.5x hard's frame?
    winners = [
        name for name, items in techs.items()
        if name != "pcss" and all(
            float(r["mae_lit"]) <= pcss[s] and float(r["ratio_to_hard"]) <= 1.5 for s, r, _ in items
        )
    ]
    print(
        "\nA technique with mae_lit ≤ pcss's on every scene at ≤ 1.5x hard's frame: "
        + (", ".join(winners) if winners else "none in this run") + ".\n"
    )


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: scripts/bench-tables.py DIR/results.csv")
    scenes = load(sys.argv[1])
    print("## Per scene\n")
    scene_tables(scenes)
    print("## Across scenes\n")
    summary(scenes)
    print("## Targets\n")
    targets(scenes)


if __name__ == "__main__":
    main()
