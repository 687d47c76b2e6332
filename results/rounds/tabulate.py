#!/usr/bin/env python3
"""Tabulates what results/rounds/rerun.sh wrote: held-out mean / max relative error of the total
and of each measured component, per experiment, setup and rule of combining the rounds.
    python3 results/rounds/tabulate.py OUT_DIR                  every run, with its components
    python3 results/rounds/tabulate.py --matrix OUT_DIR...      one row per experiment and setup, a column per rule
Also says where calibrate or validate warned (e.g. rounds whose counts differ) or failed."""
import json, os, re, sys

RULES = ["median", "fastest", "p25"]
SETUPS = ["cpu-seq", "cpu-par", "pinned", "pageable", "resident"]
NAMES = {"pinned": "cuda-seed pinned", "pageable": "cuda-seed pageable", "resident": "cuda-resident"}
COMPONENTS = ["CG", "GC", "G", "C"]


def cell(v):
    return "-" if v is None else f"{100 * v:.2f}"


def load(out, exp, setup, rule):
    base = os.path.join(out, exp, f"{setup}-{rule}")
    if not os.path.exists(base + ".calibrate.txt"):
        return None
    r = {"warn": [], "variant": None}
    cal = open(base + ".calibrate.txt").read()
    m = re.search(r"to the (\w+) variant", cal)
    r["variant"] = m.group(1) if m else None
    r["warn"] += [l.strip() for l in cal.splitlines() if "warning:" in l or " error:" in l.lower() and l.lower().startswith("dtflop")]
    try:
        v = json.load(open(base + ".validate.json"))
    except (OSError, ValueError):
        r["failed"] = open(base + ".validate.txt").read().strip().splitlines()[-1:] if os.path.exists(base + ".validate.txt") else ["no output"]
        return r
    g = v["groups"]["all"]
    r["mean"], r["max"] = g["total"]["mean_rel"], g["total"]["max_rel"]
    r["comp"] = {c: (g[c]["mean_rel"], g[c]["max_rel"]) for c in COMPONENTS if c in g}
    r["rounds"] = v.get("rounds", {})
    val = open(base + ".validate.txt").read() if os.path.exists(base + ".validate.txt") else ""
    r["warn"] += [l.strip() for l in val.splitlines() if "warning:" in l or " error:" in l.lower() and l.lower().startswith("dtflop")]
    return r


def matrix(outs):
    """One row per experiment and setup, one column per rule: held-out total mean / max. With several
    output folders the first that has a result wins (e.g. the cross-validated runs before the fixed-variant ones)."""
    rows = {}
    for out in outs:
        for exp in sorted(os.listdir(out)):
            if not os.path.isdir(os.path.join(out, exp)) or exp == "stores":
                continue
            for setup in SETUPS:
                for rule in RULES:
                    r = load(out, exp, setup, rule)
                    if r is None or "mean" not in r or (exp, setup, rule) in rows:
                        continue
                    rows[(exp, setup, rule)] = (r, os.path.basename(os.path.normpath(out)))
    pairs = sorted({(e, s) for e, s, _ in rows}, key=lambda p: (p[0], SETUPS.index(p[1])))
    print("| experiment | setup | rounds | " + " | ".join(f"{rule}: mean / max" for rule in RULES) + " | fit |")
    print("| --- | --- | --- | " + " | ".join("---" for _ in RULES) + " | --- |")
    met = {rule: [0, 0] for rule in RULES}
    for e, s in pairs:
        cells, rounds, how = [], "", set()
        for rule in RULES:
            got = rows.get((e, s, rule))
            if not got:
                cells.append("-")
                continue
            r, src = got
            how.add(src)
            ro = r["rounds"]
            rounds = f"{ro.get('min')}" if ro.get("min") == ro.get("max") else f"{ro.get('min')}-{ro.get('max')}"
            ok = r["mean"] <= 0.03 and r["max"] <= 0.08
            met[rule][0] += ok
            met[rule][1] += 1
            text = f"{cell(r['mean'])} / {cell(r['max'])}%"
            cells.append(f"**{text}**" if ok else text)
        print(f"| {e} | {NAMES.get(s, s)} | {rounds} | " + " | ".join(cells) + f" | {', '.join(sorted(how))} |")
    print()
    for rule in RULES:
        print(f"- {rule}: both targets met (bold) on {met[rule][0]} of {met[rule][1]}")


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if "--matrix" in sys.argv:
        return matrix(args)
    out = args[0]
    exps = sorted(d for d in os.listdir(out) if os.path.isdir(os.path.join(out, d)) and d != "stores")
    met = {rule: [0, 0] for rule in RULES}
    print("| experiment | setup | rounds | rule | variant | held-out total: mean / max | meets 3% / 8% | components (mean / max) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    warnings = []
    for exp in exps:
        for setup in SETUPS:
            for rule in RULES:
                r = load(out, exp, setup, rule)
                if r is None:
                    continue
                if "mean" not in r:
                    print(f"| {exp} | {NAMES.get(setup, setup)} | | {rule} | {r['variant']} | failed: {' '.join(r.get('failed', []))} | | |")
                    continue
                ok = r["mean"] <= 0.03 and r["max"] <= 0.08
                met[rule][0] += ok
                met[rule][1] += 1
                rounds = r["rounds"]
                rr = f"{rounds.get('min')}" if rounds.get("min") == rounds.get("max") else f"{rounds.get('min')}-{rounds.get('max')}"
                comps = ", ".join(f"{c} {cell(a)} / {cell(b)}" for c, (a, b) in r["comp"].items())
                print(f"| {exp} | {NAMES.get(setup, setup)} | {rr} | {rule} | {r['variant']} | {cell(r['mean'])} / {cell(r['max'])}% "
                      f"| {'met' if ok else 'missed'} | {comps} |")
                for w in r["warn"]:
                    warnings.append(f"{exp} {setup} {rule}: {w}")
    print()
    for rule in RULES:
        print(f"{rule}: meets both targets on {met[rule][0]} of {met[rule][1]} experiment x setup pairs")
    if warnings:
        print("\nWarnings:")
        seen = set()
        for w in warnings:
            key = re.sub(r"^\S+ \S+ \S+: ", "", w)
            if key in seen:
                continue
            seen.add(key)
            print("- " + w)


main()
