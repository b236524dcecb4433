"""Split the regression gate's scenarios into groups of about equal CPU time, one per line.

Usage: python .ci/gate_groups.py N SCENARIO...

`hammerstein check` runs its scenarios one after another on one core; .ci/run starts
one `hammerstein check` per group at once, so that the gate uses both cores of the CI
machine. Every scenario given is in exactly one group (longest first, each to the group
with the least time so far); a scenario not in COST counts as DEFAULT_COST. Exits 2 when
two scenario files have the same name: the gate refuses that for one `check`, and two
groups would not see it.
"""

import sys
import tomllib
from pathlib import Path

#: CPU seconds of `hammerstein check` on each scenario alone with an empty identification
#: cache (user + system, start-up included; 2026-11, the identifications of the realistic
#: scenarios are most of it). Only the order of magnitude matters.
COST = {
    "realistic-feedback": 50.6,
    "realistic-2dof": 43.1,
    "realistic-pi-minor": 25.9,
    "realistic-b-nocreep": 23.7,
    "realistic-b": 23.0,
    "ilc-realistic-2dof": 18.4,
    "hammerstein-robustness": 6.1,
    "hammerstein-trajectories-coupled": 3.1,
}
DEFAULT_COST = 2.0


def main(argv):
    n, paths = int(argv[0]), argv[1:]
    names = {}
    for path in paths:
        with open(path, "rb") as fh:
            name = tomllib.load(fh).get("name", Path(path).stem)
        if name in names:
            print(f"gate_groups: {path} and {names[name]} are both named {name!r}",
                  file=sys.stderr)
            return 2
        names[name] = path
    groups = [[0.0, []] for _ in range(n)]
    for path in sorted(paths, key=lambda p: -COST.get(Path(p).stem, DEFAULT_COST)):
        group = min(groups, key=lambda g: g[0])
        group[0] += COST.get(Path(path).stem, DEFAULT_COST)
        group[1].append(path)
    for _, members in groups:
        if members:
            print(" ".join(sorted(members)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
