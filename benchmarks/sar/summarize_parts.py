#!/usr/bin/env python3
"""Speedups of Tests 1-2 (bench_sar_parts CSVs in FOLDER): per backend and size, cpu-seq's
prediction, correction, step and belief fusion time over the backend's. Writes FOLDER/speedup.md,
FOLDER/speedup-test1.svg, FOLDER/speedup-test2.svg (step speedup) and FOLDER/fusion-test2.svg
(belief fusion speedup against the grid). Standard library only.

    python3 benchmarks/sar/summarize_parts.py results/sar/test12-cpu"""
import csv
import glob
import os
import sys


def load(folder):
    rows = []
    for path in sorted(glob.glob(os.path.join(folder, "test*.csv"))):
        with open(path) as f:
            rows += list(csv.DictReader(f))
    return rows


def svg(path, title, xlabel, curves):
    w, h, left, bottom, top, right = 720, 400, 70, 50, 40, 170
    xs = [x for _, pts in curves for x, _ in pts] or [1]
    ys = [y for _, pts in curves for _, y in pts] or [1]
    x1, y1 = max(xs), max(ys) * 1.1
    sx = lambda x: left + x / x1 * (w - left - right)
    sy = lambda y: h - bottom - y / y1 * (h - bottom - top)
    colours = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>', f'<text x="{left}" y="22" font-size="14">{title}</text>',
           f'<line x1="{left}" y1="{h - bottom}" x2="{w - right}" y2="{h - bottom}" stroke="black"/>',
           f'<line x1="{left}" y1="{top}" x2="{left}" y2="{h - bottom}" stroke="black"/>',
           f'<text x="{(w - right) / 2}" y="{h - 12}">{xlabel}</text>']
    for i in range(6):
        out.append(f'<text x="{sx(x1 * i / 5) - 10:.1f}" y="{h - bottom + 16}">{x1 * i / 5:.0f}</text>')
        out.append(f'<text x="{left - 50}" y="{sy(y1 * i / 5) + 4:.1f}">{y1 * i / 5:.1f}x</text>')
    for k, (name, pts) in enumerate(curves):
        c = colours[k % len(colours)]
        out.append('<polyline points="' + " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in pts) +
                   f'" fill="none" stroke="{c}" stroke-width="1.6"/>')
        out.append(f'<text x="{w - right + 10}" y="{top + 18 * k}" fill="{c}">{name}</text>')
    out.append("</svg>")
    open(path, "w").write("\n".join(out) + "\n")


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else "results/sar/test12-cpu"
    rows = load(folder)
    if not rows:
        sys.exit(f"summarize_parts: no test*.csv in {folder}")
    base = {(r["test"], r["nx"], r["Ix"]): r for r in rows if r["backend"] == "cpu-seq"}
    md = ["| test | backend | grid | kernel | predict | correct | step | speedup predict | speedup correct | "
          "speedup step | fusion (3, product) | log-linear | wire | speedup fusion | speedup log-linear |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    curves, fusion_curves = {}, {}
    for r in rows:
        b = base.get((r["test"], r["nx"], r["Ix"]))
        if not b:
            continue
        # A part the backend does not time apart (cuda-resident's prediction and correction run in
        # one fused kernel: bench_sar_parts leaves them empty) or did not run (a CSV made before
        # fusion ran on every backend: 0) has no time and no speedup: "fused" / "-", never nan.
        def timed(row, key):
            v = row.get(key)
            return float(v) if v not in (None, "") and float(v) > 0 else None
        def ratio(key):
            v, w = timed(r, key), timed(b, key)
            return w / v if v and w else float("nan")
        fused = timed(r, "predict_s") is None and timed(r, "correct_s") is None and timed(r, "step_s")
        def blank(key):
            return "fused" if key in ("predict_s", "correct_s") and fused else "-"
        def ms(key):
            v = timed(r, key)
            return f"{v * 1e3:.3f} ms" if v else blank(key)
        def x(key):
            v = ratio(key)
            return f"{v:.1f}x" if v == v else blank(key)
        md.append(f"| {r['test']} | {r['backend']} | {r['nx']}x{r['ny']} | {r['Ix']} | {ms('predict_s')} | "
                  f"{ms('correct_s')} | {ms('step_s')} | {x('predict_s')} | "
                  f"{x('correct_s')} | {x('step_s')} | {ms('fusion_s')} | {ms('loglinear_s')} | "
                  f"{ms('wire_s')} | {x('fusion_s')} | {x('loglinear_s')} |")
        if r["backend"] != "cpu-seq":
            x = float(r["Ix"]) if r["test"] == "1" else float(r["nx"])
            curves.setdefault((r["test"], r["backend"]), []).append((x, ratio("step_s")))
            if r["test"] == "2" and ratio("fusion_s") == ratio("fusion_s"):
                fusion_curves.setdefault(r["backend"] + " product", []).append((x, ratio("fusion_s")))
                fusion_curves.setdefault(r["backend"] + " log-linear", []).append((x, ratio("loglinear_s")))
    open(os.path.join(folder, "speedup.md"), "w").write("\n".join(md) + "\n")
    for test, xlabel in (("1", "kernel size I"), ("2", "grid n (n x n)")):
        c = [(b, sorted(pts)) for (t, b), pts in curves.items() if t == test]
        if c:
            svg(os.path.join(folder, f"speedup-test{test}.svg"), f"Test {test}: speedup of a step over cpu-seq",
                xlabel, c)
    if fusion_curves:
        svg(os.path.join(folder, "fusion-test2.svg"), "Test 2: speedup of belief fusion (3 platforms) over cpu-seq",
            "grid n (n x n)", [(b, sorted(pts)) for b, pts in fusion_curves.items()])
    print("\n".join(md))


if __name__ == "__main__":
    main()
