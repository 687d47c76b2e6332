#!/usr/bin/env python3
"""PyTorch peer of dtflop's transfer probes: the same copies through torch, timed the same way.

Measures host->device and device->host copies (pinned 4 KiB..1 GiB, pageable 16 MiB and
1 GiB) and a device->device copy (2 GiB, read + write counted) with torch.cuda.Event around
each copy, after warm-up, and reports medians. Every copy's data is checked once.

With --compare BENCH.json (the Google Benchmark JSON of bench_probes, run in the same call)
it prints dtflop / torch for each case, the ratio docs/PERFORMANCE.md records.

    python3 benchmarks/probes/peer_torch.py --json torch.json --compare bench.json
"""
import argparse
import json
import re
import statistics
import sys

import torch

KiB, MiB, GiB = 1 << 10, 1 << 20, 1 << 30
PINNED_SIZES = [4 * KiB, 64 * KiB, 1 * MiB, 16 * MiB, 64 * MiB, 256 * MiB, 1 * GiB]
PAGEABLE_SIZES = [16 * MiB, 1 * GiB]
D2D_BYTES = 2 * GiB


def size_label(n):
    for unit, div in (("GiB", GiB), ("MiB", MiB), ("KiB", KiB)):
        if n % div == 0:
            return f"{n // div} {unit}"
    return f"{n} B"


def time_copies(dst, src, reps, warmup=2):
    """Median seconds of dst.copy_(src), events around each copy; checks the data."""
    stream = torch.cuda.current_stream()
    for _ in range(warmup):
        dst.copy_(src, non_blocking=True)
    stream.synchronize()
    times = []
    start = torch.cuda.Event(enable_timing=True)
    stop = torch.cuda.Event(enable_timing=True)
    for _ in range(reps):
        start.record()
        dst.copy_(src, non_blocking=True)
        stop.record()
        stop.synchronize()
        times.append(start.elapsed_time(stop) * 1e-3)
    torch.cuda.synchronize()
    if not torch.equal(dst if dst.device == src.device else dst.to(src.device), src):
        raise SystemExit(f"peer_torch: copied data differ ({tuple(src.shape)} bytes)")
    return statistics.median(times), times


def reps_for(n):
    return 50 if n <= MiB else 15 if n <= 64 * MiB else 7 if n <= 256 * MiB else 5


def measure():
    torch.cuda.init()
    g = torch.Generator().manual_seed(1)
    results = []
    for pinned, sizes in ((True, PINNED_SIZES), (False, PAGEABLE_SIZES)):
        for n in sizes:
            host = torch.randint(0, 256, (n,), dtype=torch.uint8, generator=g)
            if pinned:
                host = host.pin_memory()
            dev = torch.empty(n, dtype=torch.uint8, device="cuda")
            back = torch.empty(n, dtype=torch.uint8, pin_memory=pinned)
            mem = "pinned" if pinned else "pageable"
            t, _ = time_copies(dev, host, reps_for(n))
            results.append({"case": "h2d", "memory": mem, "bytes": n, "median_s": t})
            t, _ = time_copies(back, dev, reps_for(n))
            results.append({"case": "d2h", "memory": mem, "bytes": n, "median_s": t})
            del host, dev, back
    src = torch.randint(0, 256, (D2D_BYTES,), dtype=torch.uint8, device="cuda")
    dst = torch.empty_like(src)
    t, _ = time_copies(dst, src, 30, warmup=3)
    results.append({"case": "d2d", "memory": "device", "bytes": D2D_BYTES, "median_s": t})
    for r in results:
        moved = 2 * r["bytes"] if r["case"] == "d2d" else r["bytes"]
        r["GBps"] = moved / r["median_s"] / 1e9
    return results


def dtflop_medians(bench_json):
    """{(case, memory, bytes): GB/s} from bench_probes' Google Benchmark JSON."""
    with open(bench_json) as f:
        data = json.load(f)
    out = {}
    for b in data.get("benchmarks", []):
        name = b["name"]
        m = re.match(r"BM_Transfer/bytes:(\d+)/d2h:(\d)/pageable:(\d)", name)
        if m and "median_GBps" in b:
            case = "d2h" if m.group(2) == "1" else "h2d"
            mem = "pageable" if m.group(3) == "1" else "pinned"
            out[(case, mem, int(m.group(1)))] = b["median_GBps"]
        m = re.match(r"BM_D2D/bytes:(\d+)", name)
        if m and "median_TBps" in b:
            out[("d2d", "device", int(m.group(1)))] = b["median_TBps"] * 1e3
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--compare", help="bench_probes JSON (Google Benchmark) to compare with")
    args = ap.parse_args()
    if not torch.cuda.is_available():
        print("peer_torch: no CUDA device", file=sys.stderr)
        return 1
    res = measure()
    ours = dtflop_medians(args.compare) if args.compare else {}
    print(f"PyTorch {torch.__version__}, {torch.cuda.get_device_name(0)}")
    print(f"{'copy':<28}{'torch':>12}{'dtflop':>12}{'dtflop/torch':>14}")
    for r in res:
        label = f"{r['case']} {r['memory']} {size_label(r['bytes'])}"
        d = ours.get((r["case"], r["memory"], r["bytes"]))
        ratio = f"{d / r['GBps']:.3f}" if d else "-"
        dtxt = f"{d:.2f} GB/s" if d else "-"
        print(f"{label:<28}{r['GBps']:>7.2f} GB/s{dtxt:>12}{ratio:>14}")
        if d:
            r["dtflop_GBps"] = d
            r["ratio_dtflop_over_torch"] = d / r["GBps"]
    small = next(r for r in res if r["case"] == "h2d" and r["bytes"] == 4 * KiB)
    print(f"torch 4 KiB pinned host->device copy: {small['median_s'] * 1e6:.2f} us (median)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"torch": torch.__version__, "device": torch.cuda.get_device_name(0),
                       "results": res}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
