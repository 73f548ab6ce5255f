#!/usr/bin/env python3
"""Table of `chamfer --protocol dtu` results: one row per scanNNN.json given, then the mean.

Usage: scripts/dtu_summary.py OUT/scan24.json OUT/scan37.json ...
"""
import json
import re
import sys

KEYS = ("mean_d2s", "mean_s2d", "overall")
rows = []
for path in sys.argv[1:]:
    with open(path) as f:
        result = json.load(f)
    scan = re.search(r"scan(\d+)\.json$", path)
    rows.append((scan.group(1) if scan else path, result))
print("scan\t" + "\t".join(KEYS))
for scan, r in rows:
    print(scan + "\t" + "\t".join(f"{r[k]:.4f}" for k in KEYS))
if rows:
    print("mean\t" + "\t".join(f"{sum(r[k] for _, r in rows) / len(rows):.4f}" for k in KEYS))
