#!/usr/bin/env python3
"""The PyTorch peer of one grid-RBE step, and the comparison table.

A step as a PyTorch user writes it: conv2d along x, conv2d along y (the separable prediction),
multiply by the likelihood, sum, divide by A_c x sum; float32 on the GPU. Timed with CUDA events
around each step after a warm-up, median of many steps; eagerly (what a user runs) and replayed
from a CUDA graph (PyTorch's best case).

  peer_torch.py --out torch.json                        # measure the peer
  peer_torch.py --table bench.json torch.json           # print dtflop vs PyTorch vs floor
"""
import argparse
import json
import statistics
import sys

CONFIGS = [(1000, 1000, 33), (1000, 1000, 201), (4000, 4000, 33)]
TARGETS_US = {(1000, 1000, 33): 15, (1000, 1000, 201): 40, (4000, 4000, 33): 150}
BANDWIDTH, RATE = 4.2e12, 55e12  # measured H200 ceilings (docs/design.md)


def floor_us(nx, ny, k):
    ng = nx * ny
    return max(3 * ng * 4 / BANDWIDTH, (2 * ng * (k + k) + 3 * ng) / RATE) * 1e6


def measure(reps):
    import torch
    import torch.nn.functional as F

    torch.backends.cudnn.benchmark = True
    dev = torch.device("cuda")
    out = {"device": torch.cuda.get_device_name(0), "torch": torch.__version__, "results": []}
    for nx, ny, k in CONFIGS:
        g = torch.Generator(device=dev).manual_seed(1)
        p = torch.rand(1, 1, ny, nx, device=dev, generator=g) + 0.1
        lik = torch.rand(1, 1, ny, nx, device=dev, generator=g) * 0.5 + 0.5
        x = torch.arange(k, device=dev, dtype=torch.float32) - (k - 1) / 2
        w = torch.exp(-0.5 * (x / (k / 6)) ** 2)
        w = w / w.sum()
        kx = w.view(1, 1, 1, k).contiguous()
        ky = w.view(1, 1, k, 1).contiguous()
        area = 1.0
        state = {"p": p}

        def step():
            u = F.conv2d(state["p"], kx, padding=(0, k // 2))
            pred = F.conv2d(u, ky, padding=(k // 2, 0))
            q = pred * lik
            s = q.sum()
            state["p"] = q / (area * s)

        def timed(fn, n):
            times = []
            for _ in range(n):
                a, b = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
                a.record()
                fn()
                b.record()
                b.synchronize()
                times.append(a.elapsed_time(b) * 1e3)
            return statistics.median(times)

        for _ in range(20):
            step()
        torch.cuda.synchronize()
        eager = timed(step, reps)
        # CUDA graph of one step, replayed.
        static = {"p": state["p"].clone()}
        stream = torch.cuda.Stream()
        stream.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(stream):
            for _ in range(3):
                step()
        torch.cuda.current_stream().wait_stream(stream)
        graph = torch.cuda.CUDAGraph()
        state["p"] = static["p"]
        with torch.cuda.graph(graph):
            step()
        for _ in range(10):
            graph.replay()
        torch.cuda.synchronize()
        graphed = timed(graph.replay, reps)
        out["results"].append({"nx": nx, "ny": ny, "k": k, "eager_us": eager, "graph_us": graphed})
        print(f"torch {nx}x{ny} k{k}: eager {eager:.1f} us, graph {graphed:.1f} us", file=sys.stderr, flush=True)
    return out


def table(bench_path, torch_path):
    with open(bench_path) as f:
        bench = json.load(f)
    with open(torch_path) as f:
        torch_res = json.load(f)
    default_layout = "32x8x16"  # rbe::Layout's default
    ours, best = {}, {}
    for b in bench["benchmarks"]:
        parts = b["name"].split("/")
        if len(parts) < 5 or parts[1] != "cuda-resident" or b.get("error_occurred"):
            continue
        nx, ny = map(int, parts[2].split("x"))
        key = (nx, ny, int(parts[3][1:]))
        us = b["real_time"] if b.get("time_unit") == "us" else b["real_time"] / 1e3
        layout = parts[4]
        if layout == default_layout:
            ours[key] = us
        if layout.startswith("layout-") and (key not in best or us < best[key][0]):
            best[key] = (us, layout[len("layout-"):])
    rows = [f"{'config':<16}{'default us':>11}{'best us':>9}{'best layout':>16}{'floor us':>10}{'x floor':>9}"
            f"{'torch us':>10}{'speedup':>9}{'torch graph':>12}{'target':>8}{'met':>5}"]
    for r in torch_res["results"]:
        key = (r["nx"], r["ny"], r["k"])
        if key not in ours:
            continue
        us = ours[key]
        bus, blay = best.get(key, (float("nan"), "-"))
        fl = floor_us(*key)
        tgt = TARGETS_US.get(key)
        rows.append(f"{r['nx']}x{r['ny']} k{r['k']:<6}{us:>11.1f}{bus:>9.1f}{blay:>16}{fl:>10.2f}{us / fl:>9.1f}"
                    f"{r['eager_us']:>10.1f}{r['eager_us'] / us:>9.1f}{r['graph_us']:>12.1f}"
                    f"{tgt if tgt else '-':>8}{('yes' if tgt and us <= tgt else 'no'):>5}")
    print(f"one RBE step, float32, {torch_res['device']} (torch {torch_res['torch']}); default layout "
          f"{default_layout}; x floor and speedup for the default; floor = "
          f"max(3 n_g x 4 B / 4.2 TB/s, (2 n_g (Ix+Iy) + 3 n_g) / 55 TFLOP/s)")
    print("\n".join(rows))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="write the peer's measurements (JSON) here")
    ap.add_argument("--reps", type=int, default=200)
    ap.add_argument("--table", nargs=2, metavar=("BENCH_JSON", "TORCH_JSON"),
                    help="print dtflop (Google Benchmark JSON of bench_rbe) against the peer")
    a = ap.parse_args()
    if a.table:
        table(*a.table)
        return
    res = measure(a.reps)
    text = json.dumps(res, indent=1)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    else:
        print(text)


if __name__ == "__main__":
    main()
