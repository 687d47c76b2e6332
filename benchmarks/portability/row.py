"""One row of the portability tables: runs `dtflop validate --json` and prints its result as a
markdown row (a failed validation is a row that says so); `--header` prints the table's head.

    python3 benchmarks/portability/row.py --header
    python3 benchmarks/portability/row.py DTFLOP LABEL VALIDATE-ARGUMENTS...
"""
import json
import subprocess
import sys

if sys.argv[1:] == ['--header']:
    print('| machine, backend, basis | n | held-out total: mean / max | bias | rms log | 90% interval holds |')
    print('| --- | --- | --- | --- | --- | --- |')
    sys.exit()
dtflop, label, args = sys.argv[1], sys.argv[2], sys.argv[3:]
run = subprocess.run([dtflop, 'validate', *args, '--json'], capture_output=True, text=True)
try:
    d = json.loads(run.stdout)
except ValueError:
    print(f'| {label} | - | validation failed | | | |')
    sys.exit()
a, i, e = d['groups']['all']['total'], d['interval90'], d['error']
print(f"| {label} | {a['n']} | {100*a['mean_rel']:.2f}% / {100*a['max_rel']:.2f}% | {100*a['bias']:+.1f}% "
      f"| {e['rms_log']:.3f} | {i['inside']}/{i['scored']} ({100*i['coverage']:.0f}%) |")
