#!/usr/bin/env python3
"""How a configuration's rounds spread, per held-out store and setup, from the stored samples alone:
    python3 results/rounds/spread.py RESULTS_DIR EXPERIMENT...
    e.g. python3 results/rounds/spread.py benchmarks/calibrate/results cpu-2026-11-21f h200-2026-11-21i
Per configuration, the rounds' medians of the total are compared with the fastest of them:
  median above fastest   how far the median round is above the fastest (median over configurations)
  slowest above median   how far the slowest is above the median round
  slow rounds            share of rounds more than 10% above the configuration's fastest (mean), and
                         how many configurations have more than half of their rounds that slow
  within a round         interquartile range of a round's repetitions / their median (median)
  halves differ          each rule applied to the odd and to the even rounds apart, |a - b| / mean
                         (mean over configurations): how repeatable the rule is (4+ rounds only)"""
import collections, gzip, json, os, re, statistics as st, sys


def q(v, p):  # type 7, as calibrate's Stats
    v = sorted(v)
    i = p * (len(v) - 1)
    lo = int(i)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (i - lo)


RULES = {"fastest": min, "p25": lambda v: q(v, 0.25), "median": lambda v: q(v, 0.5)}


def setup_of(key):
    parts = key.split("/")
    return parts[1] + (" pinned" if "/pinned/" in key else " pageable" if parts[1] == "cuda-seed" else "")


def main():
    root, exps = sys.argv[1], sys.argv[2:]
    print("| experiment | setup | rounds | median above fastest | slowest above median | slow rounds (>10%) "
          "| within a round | halves differ: fastest / p25 / median |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for exp in exps:
        path = os.path.join(root, exp, "held.jsonl.gz")
        cfg = collections.defaultdict(dict)
        with gzip.open(path, "rt") as f:
            for line in f:
                s = json.loads(line)
                base = re.sub(r"/round=[1-9][0-9]*$", "", s["key"])
                cfg[base].setdefault(s.get("round", 1), s["components"]["total"])
        groups = collections.defaultdict(list)
        for key, rounds in cfg.items():
            if len(rounds) >= 2:
                groups[setup_of(key)].append([rounds[r] for r in sorted(rounds)])
        for setup, configs in sorted(groups.items()):
            below, above, slow, within, halves = [], [], [], [], collections.defaultdict(list)
            for rounds in configs:
                v = [t["median"] for t in rounds]
                lo, m = min(v), q(v, 0.5)
                below.append(m / lo - 1)
                above.append(max(v) / m - 1)
                slow.append(sum(x > 1.10 * lo for x in v) / len(v))
                within.append(st.median((t["p75"] - t["p25"]) / t["median"] for t in rounds))
                if len(v) >= 4:
                    a, b = v[0::2], v[1::2]
                    for name, f in RULES.items():
                        halves[name].append(abs(f(a) - f(b)) / ((f(a) + f(b)) / 2))
            n = {len(r) for r in configs}
            rr = str(min(n)) if len(n) == 1 else f"{min(n)}-{max(n)}"
            hv = " / ".join(f"{100 * st.mean(halves[k]):.1f}%" for k in RULES) if halves else "-"
            print(f"| {exp} | {setup} | {rr} | {100 * st.median(below):.1f}% | {100 * st.median(above):.1f}% "
                  f"| {100 * st.mean(slow):.0f}%, {sum(s > 0.5 for s in slow)}/{len(slow)} configurations over half "
                  f"| {100 * st.median(within):.1f}% | {hv} |")


main()
