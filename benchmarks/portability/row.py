"""One row of the portability tables: `dtflop validate --json` output (a file) to a markdown row.

    python3 benchmarks/portability/row.py LABEL v.json
"""
import json
import sys

label, path = sys.argv[1], sys.argv[2]
try:
    d = json.load(open(path))
except Exception:
    print(f'| {label} | - | validation failed | | | |')
    sys.exit()
a, i, e = d['groups']['all']['total'], d['interval90'], d['error']
print(f"| {label} | {a['n']} | {100*a['mean_rel']:.2f}% / {100*a['max_rel']:.2f}% | {100*a['bias']:+.1f}% "
      f"| {e['rms_log']:.3f} | {i['inside']}/{i['scored']} ({100*i['coverage']:.0f}%) |")
