#!/usr/bin/env python3
"""Tables and figures of Test 4 (benchmarks/sar/test4.sh): per configuration, over the seeds,
time to first detection, belief entropy and information, estimate error and distance to the
raft, with 95% confidence intervals (mean +- t * sd / sqrt(n)); SVG figures of the mean over
seeds against time. Standard library only.

    python3 benchmarks/sar/summarize.py results/sar/test4

Writes OUT/summary.md, OUT/summary.csv, OUT/distance.svg, OUT/entropy.svg, OUT/error.svg. Each
configuration's series are its seed-*-series.csv files or, archived, series.tar.xz."""
import csv
import glob
import io
import json
import math
import os
import statistics
import sys
import tarfile

ORDER = ["observation", "belief-k1", "belief-k5", "belief-k50", "belief-k500", "loglinear-k5", "none"]
COLOURS = ["#000000", "#d62728", "#ff7f0e", "#2ca02c", "#17becf", "#9467bd", "#7f7f7f"]


def t95(n):
    # two-sided 95% Student t quantile, n - 1 degrees of freedom (large n: 1.96)
    table = {1: 12.71, 2: 4.30, 3: 3.18, 4: 2.78, 5: 2.57, 6: 2.45, 7: 2.36, 8: 2.31, 9: 2.26, 10: 2.23,
             15: 2.13, 20: 2.09, 30: 2.04, 50: 2.01, 100: 1.98}
    d = n - 1
    if d <= 0:
        return float("nan")
    for k in sorted(table):
        if d <= k:
            return table[k]
    return 1.96


def mean_ci(values):
    n = len(values)
    if n == 0:
        return float("nan"), float("nan")
    m = statistics.fmean(values)
    if n < 2:
        return m, float("nan")
    return m, t95(n) * statistics.stdev(values) / math.sqrt(n)


def load(folder):
    """The runs' summaries and series: seed-*-series.csv, or the same inside series.tar.xz."""
    runs = [json.loads(line) for line in open(os.path.join(folder, "summary.jsonl"))]
    series = {}
    for path in glob.glob(os.path.join(folder, "seed-*-series.csv")):
        with open(path) as f:
            series[path] = list(csv.DictReader(f))
    archive = os.path.join(folder, "series.tar.xz")
    if not series and os.path.exists(archive):
        with tarfile.open(archive) as tar:
            for m in tar.getmembers():
                if m.isfile() and m.name.endswith("-series.csv"):
                    text = tar.extractfile(m).read().decode()
                    series[m.name] = list(csv.DictReader(io.StringIO(text)))
    return runs, series


def per_time(series, column_prefix, reduce):
    """Mean over seeds, at each step, of reduce(values of the helicopters)."""
    steps = None
    sums, counts, times = [], [], []
    for rows in series.values():
        if steps is None:
            steps = len(rows)
            sums = [0.0] * steps
            counts = [0] * steps
            times = [0.0] * steps
        for i, r in enumerate(rows[:steps]):
            vals = [float(v) for k, v in r.items() if k.startswith(column_prefix)]
            sums[i] += reduce(vals)
            counts[i] += 1
            times[i] += float(r["time"])
    return [t / c for t, c in zip(times, counts)], [s / c for s, c in zip(sums, counts)]


def svg(path, title, ylabel, curves, ymax=None):
    w, h, left, bottom, top, right = 760, 420, 70, 50, 40, 190
    xs = [x for _, _, pts in curves for x, _ in pts]
    ys = [y for _, _, pts in curves for _, y in pts]
    x0, x1 = 0, max(xs)
    y0, y1 = 0, ymax if ymax else max(ys) * 1.05
    sx = lambda x: left + (x - x0) / (x1 - x0) * (w - left - right)
    sy = lambda y: h - bottom - (min(y, y1) - y0) / (y1 - y0) * (h - bottom - top)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<text x="{w / 2 - 80}" y="22" font-size="14">{title}</text>',
           f'<line x1="{left}" y1="{h - bottom}" x2="{w - right}" y2="{h - bottom}" stroke="black"/>',
           f'<line x1="{left}" y1="{top}" x2="{left}" y2="{h - bottom}" stroke="black"/>',
           f'<text x="{(w - right) / 2}" y="{h - 12}">time (s)</text>',
           f'<text x="14" y="{top - 10}">{ylabel}</text>']
    for i in range(6):
        xv = x0 + (x1 - x0) * i / 5
        yv = y0 + (y1 - y0) * i / 5
        out.append(f'<text x="{sx(xv) - 10:.1f}" y="{h - bottom + 16}">{xv:.0f}</text>')
        out.append(f'<text x="{left - 45}" y="{sy(yv) + 4:.1f}">{yv:.2f}</text>')
        out.append(f'<line x1="{left}" y1="{sy(yv):.1f}" x2="{w - right}" y2="{sy(yv):.1f}" stroke="#ddd"/>')
    for k, (name, colour, pts) in enumerate(curves):
        poly = " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in pts)
        out.append(f'<polyline points="{poly}" fill="none" stroke="{colour}" stroke-width="1.6"/>')
        out.append(f'<line x1="{w - right + 10}" y1="{top + 18 * k}" x2="{w - right + 30}" y2="{top + 18 * k}" '
                   f'stroke="{colour}" stroke-width="2"/>')
        out.append(f'<text x="{w - right + 35}" y="{top + 18 * k + 4}">{name}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else "results/sar/test4"
    rows, curves = [], {"distance": [], "entropy": [], "error": []}
    info_of = {}
    for i, name in enumerate(ORDER):
        sub = os.path.join(folder, name)
        if not os.path.exists(os.path.join(sub, "summary.jsonl")):
            continue
        runs, series = load(sub)
        cells = runs[0]["grid"][0] * runs[0]["grid"][1]
        horizon = runs[0]["physical_time"]
        detected = [r["first_detection_time"] for r in runs if r["first_detection_step"] >= 0]
        # Runs that never detect count at the end of the run (censored): the mean is a lower bound then.
        censored = [r["first_detection_time"] if r["first_detection_step"] >= 0 else horizon for r in runs]
        entropy = [r["mean_entropy"] for r in runs]
        info = [math.log(cells) - e for e in entropy]
        info_of[name] = info
        err_runs = []
        for rws in series.values():
            vals = [statistics.fmean(float(v) for k, v in r.items() if k.startswith("error_")) for r in rws]
            err_runs.append(statistics.fmean(vals))
        det_m, det_ci = mean_ci(censored)
        ent_m, ent_ci = mean_ci(entropy)
        inf_m, inf_ci = mean_ci(info)
        err_m, err_ci = mean_ci(err_runs)
        rows.append({"configuration": name, "runs": len(runs), "detected": len(detected),
                     "first_detection_s": det_m, "first_detection_ci95": det_ci,
                     "first_detection_median_s": statistics.median(censored),
                     "mean_entropy_nats": ent_m, "entropy_ci95": ent_ci,
                     "information_nats": inf_m, "information_ci95": inf_ci,
                     "estimate_error_km": err_m, "error_ci95": err_ci,
                     "messages_per_step": runs[0]["messages_per_step"], "bytes_per_step": runs[0]["bytes_per_step"]})
        t, d = per_time(series, "distance_", min)
        curves["distance"].append((name, COLOURS[i], list(zip(t, d))))
        t, e = per_time(series, "entropy_", statistics.fmean)
        curves["entropy"].append((name, COLOURS[i], list(zip(t, e))))
        t, x = per_time(series, "error_", statistics.fmean)
        curves["error"].append((name, COLOURS[i], list(zip(t, x))))
    if not rows:
        sys.exit(f"summarize: no results in {folder}; run benchmarks/sar/test4.sh first")
    with open(os.path.join(folder, "summary.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    md = ["| configuration | runs | detected | first detection (s), mean ± 95% CI | median (s) | "
          "mean entropy (nats) | information ln(n_g) - H (nats) | estimate error (km) | bytes/step |",
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        md.append(f"| {r['configuration']} | {r['runs']} | {r['detected']} | {r['first_detection_s']:.1f} ± "
                  f"{r['first_detection_ci95']:.1f} | {r['first_detection_median_s']:.1f} | "
                  f"{r['mean_entropy_nats']:.3f} ± {r['entropy_ci95']:.3f} | {r['information_nats']:.3f} ± "
                  f"{r['information_ci95']:.3f} | {r['estimate_error_km']:.3f} ± {r['error_ci95']:.3f} | "
                  f"{r['bytes_per_step']:.0f} |")
    if "observation" in info_of:
        md.append("")
        md.append("Information relative to observation fusion (ratio of the means; 95% CI from the seeds' "
                  "paired ratios):")
        md.append("")
        base = info_of["observation"]
        for name, info in info_of.items():
            if name == "observation" or len(info) != len(base):
                continue
            ratios = [a / b for a, b in zip(info, base) if b > 0]
            m, ci = mean_ci(ratios)
            md.append(f"- {name}: {statistics.fmean(info) / statistics.fmean(base):.2f}x (paired {m:.2f} ± {ci:.2f})")
    with open(os.path.join(folder, "summary.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    svg(os.path.join(folder, "distance.svg"), "Closest helicopter to the raft (mean over seeds)", "km", curves["distance"])
    svg(os.path.join(folder, "entropy.svg"), "Belief entropy (mean over helicopters and seeds)", "nats", curves["entropy"])
    svg(os.path.join(folder, "error.svg"), "Estimate error |mean - raft| (mean over helicopters and seeds)", "km",
        curves["error"], ymax=3.0)
    print("\n".join(md))


if __name__ == "__main__":
    main()
