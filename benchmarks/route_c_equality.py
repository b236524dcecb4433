"""The exported C against ``compensate``'s drives, sample by sample, as an outside checker does.

On the files a :mod:`route_defaults` run left in ``--work`` (per actuator its
``preset.toml``, written by ``identify`` with every default, the drives
``compensate`` wrote with every default, nine circles, a raster and the
first drive of the learning, and the ten drives ``learn`` wrote), per drive:

1. ``hammerstein export preset.toml --target c`` with the limits the drive's
   header names (``the exported C gives this drive, fed its reference, when
   exported with ... --slew-rate ...``, where ``compensate`` slew-limited its
   start-up after the compensator; else every default);
2. the C compiled with ``-std=c99 -Wall -Wextra -Werror -ffp-contract=off
   -O2`` against the header it documents (the harness of
   ``tests/export/conftest.py``: ``NAME_init``, ``NAME_step``);
3. fed the reference the drive follows (a learnt drive's ``<output>_learnt``
   columns, a shaped one's ``<output>_shaped`` columns, else
   the reference faded as the header says, docs/real-time.md), then the
   reference continued past the record for the preview;
4. its voltages against the drive's, all but the last ``NAME_PREVIEW``
   samples (where ``compensate`` looked into the reference's continuation),
   relative to the drive's peak; and the same C exported with every default
   (no start-up limit) for the drives whose header names one.

Printed per drive and summarised (median, worst, how many within 1e-12).
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from hammerstein.compensation.drive import hardware_fade
from hammerstein.compensation.drive_files import (drive_fade_samples, drive_rest_lead,
                                                  drive_rest_output, followed_reference)
from hammerstein.signals.references import raster

HERE = Path(__file__).resolve().parent
T = 5e-5
TARGET = 1e-12


def _harness_module():
    spec = importlib.util.spec_from_file_location(
        "export_conftest", HERE.parent / "tests" / "export" / "conftest.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def reference(name, count):
    """The reference a route_defaults drive was computed for, ``count`` samples (2, count)."""
    if name == "raster":
        one = raster(T, [40, 40], 8, 50.0)[1]
        return np.tile(one, int(np.ceil(count / one.shape[1])))[:, :count]
    radius, freq = ((30, 100) if re.fullmatch(r"u\d+", name) else
                    (int(v) for v in name.split("-")[1:3]))
    t = np.arange(count) * T
    return radius * np.vstack([np.cos(2 * np.pi * freq * t), np.sin(2 * np.pi * freq * t)])


def export_options(path):
    """The ``--amplifier-range``/``--slew-rate`` the drive's header names, or []."""
    text = "\n".join(ln for ln in Path(path).read_text().splitlines() if ln.startswith("#"))
    m = re.search(r"when exported with((?: --amplifier-range \S+ \S+)? --slew-rate [0-9.e+,-]+)",
                  text)
    return m.group(1).split() if m else []


def run_c(mod, preset, options, fed, work):
    """The C exported with ``options``, compiled, fed ``fed`` (2, N + P): (voltages, P)."""
    out = work / "c"
    subprocess.run([sys.executable, "-m", "hammerstein", "export", str(preset), "--target", "c",
                    "--name", "act", "--out", str(out), "--force", *options], check=True,
                   capture_output=True, text=True)
    header = (out / "act.h").read_text()
    P = int(re.search(r"#define act_PREVIEW (\d+)", header).group(1))
    (work / "harness.c").write_text(mod.HARNESS.replace("@NAME@", "act"))
    exe = work / "harness"
    subprocess.run([mod.COMPILERS[0], *mod.CFLAGS, f"-I{out}", "-o", str(exe),
                    str(work / "harness.c"), str(out / "act.c"), "-lm"], check=True)
    src, dst = work / "ref.bin", work / "out.bin"
    np.ascontiguousarray(fed[:, P:].T).tofile(src)
    subprocess.run([str(exe), str(src), str(dst)], check=True, capture_output=True)
    v = np.fromfile(dst).reshape(-1, 3).T
    return v[:2], P


def one_drive(mod, d, path, work):
    """(relative difference with the header's limits, without them or None, limited)."""
    lines = [ln for ln in Path(path).read_text().splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    vals = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    u = np.vstack([vals[:, head.index("ux")], vals[:, head.index("uy")]])
    n = u.shape[1]
    asked = reference(path.stem, n)
    target = hardware_fade(asked, drive_fade_samples(path), drive_rest_output(path, ["x", "y"]),
                           drive_rest_lead(path))
    followed, _ = followed_reference(path, ["x", "y"], target)
    followed = target if followed is None else followed
    options = export_options(path)
    out = []
    for opts in ([options, []] if options else [[]]):
        fed = np.hstack([followed, reference(path.stem, n + 64)[:, n:]])
        v, P = run_c(mod, d / "preset.toml", opts, fed, work)
        out.append(float(np.max(np.abs(v[:, :n - P] - u[:, :n - P])) / np.max(np.abs(u))))
    return out[0], (out[1] if options else None), bool(options)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", required=True, help="a route_defaults --work directory")
    ap.add_argument("--only", help="comma-separated actuator names")
    args = ap.parse_args(argv)
    mod = _harness_module()
    if not mod.COMPILERS:
        print("no C compiler on PATH")
        return 1
    only = set(args.only.split(",")) if args.only else None
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for d in sorted(p for p in Path(args.work).iterdir() if (p / "preset.toml").is_file()):
            if only is not None and d.name not in only:
                continue
            learnt = sorted(d.glob("u*.csv"), key=lambda p: int(p.stem[1:]))
            for path in sorted(d.glob("circle-*.csv")) + [d / "raster.csv"] + learnt:
                if not path.is_file():
                    continue
                rel, without, limited = one_drive(mod, d, path, Path(tmp))
                rows.append((d.name, path.stem, rel, without, limited))
                extra = f" (exported without the named limits {without:.2g})" if limited else ""
                print(f"{d.name} {path.stem}: |C - drive| / peak {rel:.2g}{extra}", flush=True)
    if not rows:
        return 1
    rel = np.array([r[2] for r in rows])
    lim = [r for r in rows if r[4]]
    print(f"\n{len(rows)} drives: |C - drive| / peak median {np.median(rel):.2g}, worst "
          f"{rel.max():.2g}; {int(np.sum(rel <= TARGET))} within {TARGET:g}")
    if lim:
        w = np.array([r[3] for r in lim])
        print(f"{len(lim)} with a start-up slew-limited after the compensator: exported with "
              f"the limits their header names, worst {max(r[2] for r in lim):.2g}; exported "
              f"with every default, median {np.median(w):.2g}, worst {w.max():.2g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
