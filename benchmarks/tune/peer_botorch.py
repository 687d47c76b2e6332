#!/usr/bin/env python3
"""Bayesian optimization (BoTorch) as the tuner's peer, on the same measured space.

Reads the space `dtflop tune --replay ... --space-csv space.csv` wrote: every valid configuration
with its measured time per step. The measure step is the same as dtflop's strategies replay: the
time the store holds for the configuration BO asks for. BO's surrogate is a Gaussian process
(SingleTaskGP) on the configuration's parameters (numbers scaled to [0, 1], WxH sizes as two
numbers, text values one-hot), fitted to log(time); the next configuration is the unmeasured one
with the largest expected improvement (LogExpectedImprovement) over the whole discrete space. It
starts from 3 configurations drawn from the seed.

    python3 benchmarks/tune/peer_botorch.py space.csv --budgets 5,10,20,50 --seeds 10

prints JSON: for each budget, the fraction of the optimum (optimum / best measured) after that
many measurements, per seed and its median, as `dtflop tune --replay` reports model and random.
"""
import argparse
import concurrent.futures
import csv
import json
import math
import os
import re
import statistics
import sys
import time


def encode(rows, params):
    """Features in [0, 1]: numbers scaled, WxH as two numbers, a block layout such as 32x8x2:split as
    its numbers (missing ones 0) and its suffix one-hot, anything else one-hot."""
    columns = []
    for p in params:
        values = [r[p] for r in rows]
        if all(v == "" for v in values) or len(set(values)) == 1:
            continue
        if all(re.fullmatch(r"-?[0-9.eE+-]+", v or "0") for v in values):
            columns.append([float(v or 0) for v in values])
        elif all(re.fullmatch(r"[0-9]+x[0-9]+", v) for v in values if v):
            for k in (0, 1):
                columns.append([float(v.split("x")[k]) if v else 0.0 for v in values])
        elif all(re.fullmatch(r"[0-9]+(x[0-9]+)*(:[a-z]+)?", v) for v in values if v):
            numbers = [[float(n) for n in v.split(":")[0].split("x")] if v else [] for v in values]
            width = max(len(n) for n in numbers)
            for k in range(width):
                columns.append([n[k] if k < len(n) else 0.0 for n in numbers])
            suffixes = [v.split(":")[1] if ":" in v else "" for v in values]
            for level in sorted(set(suffixes)):
                columns.append([1.0 if x == level else 0.0 for x in suffixes])
        else:
            for level in sorted(set(values)):
                columns.append([1.0 if v == level else 0.0 for v in values])
    features = []
    for col in columns:
        lo, hi = min(col), max(col)
        features.append([(x - lo) / (hi - lo) if hi > lo else 0.0 for x in col])
    return [list(t) for t in zip(*features)]


def run_bo(args):
    """One seed's search (a process of its own: small GPs run fastest on one thread each)."""
    x, y, budget, seed = args
    import torch
    from botorch.fit import fit_gpytorch_mll
    from botorch.models import SingleTaskGP
    from botorch.acquisition.analytic import LogExpectedImprovement
    from gpytorch.mlls import ExactMarginalLogLikelihood
    torch.set_num_threads(1)
    x = torch.tensor(x, dtype=torch.float64)
    y = torch.tensor(y, dtype=torch.float64)
    gen = torch.Generator().manual_seed(seed)
    n = x.shape[0]
    order = torch.randperm(n, generator=gen).tolist()
    measured = order[:3]
    while len(measured) < min(budget, n):
        xs, ys = x[measured], -y[measured].unsqueeze(-1)  # maximize -log(time)
        model = SingleTaskGP(xs, ys)
        try:
            fit_gpytorch_mll(ExactMarginalLogLikelihood(model.likelihood, model))
        except Exception:  # a failed hyperparameter fit keeps the defaults
            pass
        acq = LogExpectedImprovement(model, best_f=ys.max())
        rest = [i for i in range(n) if i not in set(measured)]
        with torch.no_grad():
            scores = acq(x[rest].unsqueeze(1))
        measured.append(rest[int(torch.argmax(scores))])
    return measured


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("space", help="CSV written by dtflop tune --space-csv after --replay")
    ap.add_argument("--budgets", default="5,10,20,50")
    ap.add_argument("--seeds", type=int, default=10)
    a = ap.parse_args()
    budgets = [int(b) for b in a.budgets.split(",")]
    try:
        import botorch  # noqa: F401
    except ImportError as e:
        sys.exit(f"peer_botorch: BoTorch is not installed here ({e}); run it where it is (the lent GPU machine)")
    with open(a.space, newline="") as f:
        rows = [r for r in csv.DictReader(f)]
    rows = [r for r in rows if r["measured_s"]]
    if len(rows) < 5:
        sys.exit(f"peer_botorch: {a.space} holds {len(rows)} measured configurations; run dtflop tune --replay first")
    fixed = {"key", "predicted_s", "interval_lo_s", "interval_hi_s", "accuracy_error", "measured_s"}
    params = [p for p in rows[0].keys() if p not in fixed]
    x = encode(rows, params)
    t = [float(r["measured_s"]) for r in rows]
    y = [math.log(v) for v in t]
    optimum = min(t)
    out = {"peer": "botorch SingleTaskGP + LogExpectedImprovement", "configurations": len(rows),
           "features": len(x[0]), "seeds": a.seeds, "rows": []}
    started = time.time()
    workers = min(a.seeds, os.cpu_count() or 1)
    with concurrent.futures.ProcessPoolExecutor(max_workers=workers) as pool:
        traces = list(pool.map(run_bo, [(x, y, max(budgets), seed) for seed in range(1, a.seeds + 1)]))
    for b in budgets:
        fractions = [optimum / min(t[i] for i in tr[:b]) for tr in traces]
        out["rows"].append({"strategy": "botorch", "budget": b, "fractions": fractions,
                            "median_fraction_of_optimum": statistics.median(fractions)})
    out["seconds"] = time.time() - started
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
