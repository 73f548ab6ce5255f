#!/usr/bin/env python3
"""Run a command and record its wall time and peak memory (Python standard library only).

    scripts/timed.py REPORT.json -- COMMAND [ARGS...]

Writes {"seconds": wall time, "peak_rss_mib": the largest resident set of the command or any process
it waited for (getrusage RUSAGE_CHILDREN ru_maxrss, KiB on Linux), "command": [...]} to REPORT.json
once the command succeeds, and exits with the command's status (REPORT.json is left alone on failure).
The report is written to a temporary file and renamed, so an interrupted run leaves no half report.
"""
import json
import os
import resource
import subprocess
import sys
import time


def main() -> int:
    if len(sys.argv) < 4 or sys.argv[2] != "--":
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    report, cmd = sys.argv[1], sys.argv[3:]
    t0 = time.monotonic()
    status = subprocess.call(cmd)
    seconds = time.monotonic() - t0
    if status != 0:
        print(f"timed.py: {' '.join(cmd)} exited with {status}", file=sys.stderr)
        return status if status > 0 else 1
    peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    tmp = report + ".tmp"
    with open(tmp, "w") as f:
        json.dump({"seconds": round(seconds, 3), "peak_rss_mib": round(peak_kib / 1024, 1),
                   "command": cmd}, f)
    os.replace(tmp, report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
