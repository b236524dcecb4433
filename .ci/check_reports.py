"""Compare the committed replication report's metrics with a fresh `hammerstein replicate`.

Usage: python .ci/check_reports.py FRESH_DIR [COMMITTED_DIR]

Every reports/paper/<scenario>/metrics.csv must hold the same rows as the fresh
run's, with values equal to 1e-6 relative (1e-9 absolute); otherwise it prints
what differs and exits 1: run `hammerstein replicate` and commit reports/paper/.
"""

import math
import sys
from pathlib import Path

import pandas as pd


def rows(path):
    frame = pd.read_csv(path, comment="#")
    return {(r.case, r.channel, r.metric): r.value for r in frame.itertuples()}


def main(fresh, committed="reports/paper"):
    fresh, committed = Path(fresh), Path(committed)
    problems = []
    for new in sorted(fresh.glob("*/metrics.csv")):
        old = committed / new.parent.name / "metrics.csv"
        if not old.exists():
            problems.append(f"{old}: missing")
            continue
        a, b = rows(old), rows(new)
        for key in sorted(set(a) ^ set(b)):
            problems.append(f"{old}: row {key} {'only committed' if key in a else 'missing'}")
        for key in sorted(set(a) & set(b)):
            x, y = a[key], b[key]
            if not (math.isclose(x, y, rel_tol=1e-6, abs_tol=1e-9)
                    or (math.isnan(x) and math.isnan(y))):
                problems.append(f"{old}: {key}: committed {x!r}, now {y!r}")
    for line in problems[:40]:
        print(line)
    if problems:
        print(f"{len(problems)} differences: run `hammerstein replicate` and commit reports/paper/")
        return 1
    print(f"reports/paper: the metrics of {len(list(fresh.glob('*/metrics.csv')))} scenarios match")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
