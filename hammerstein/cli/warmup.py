"""``hammerstein warmup``: compile every simulation kernel once into numba's on-disk cache.

Numba compiles a kernel on its first call and caches it on disk, so the
first run on a machine (or after an upgrade of the kernels) waits for the
compiler: about 80 % of a cold first ``run``. This command does that wait
once, e.g. right after ``pip install``, by running tiny workloads that
reach every kernel with the argument types the commands use:

* the chain kernel (compensator then plant) of a default run and of a
  ``kind = "hammerstein"`` run (reference pre-filter, closed-form 2 x 2
  law), and the batched chain of the sweeps;
* the Hammerstein plant and the multivariable PI of the bundled presets
  (with creep), and the play operators of the PI identification;
* the Preisach and generalised-PI models, the generalised plays of their
  identification and the Preisach inverse compensator;
* a generalised-PI identification (its sensitivity kernel) and creep
  identifications with and without dynamics (the lag, creep and inverse
  creep kernels).

It prints each workload with the kernels numba compiled for it and the
time taken; a kernel already in the cache loads silently (a second
``warmup`` compiles nothing). ``NUMBA_CACHE_DIR`` chooses the cache as for
every other command.
"""

from __future__ import annotations

import time

import control
import numpy as np
from numba.core import event

from hammerstein.cli._common import print_err
from hammerstein.compensation.compensators import (InverseMultiplicativeCompensator,
                                                   PerAxisInverseCompensator)
from hammerstein.identification.creep_identification import remove_creep, step_level_errors
from hammerstein.identification.gpi_identification import identify_gpi_records
from hammerstein.identification.record_identification import identify_record_creep
from hammerstein.io.datafiles import MultiRecord
from hammerstein.signals.excitation import decreasing_sine
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.models.hysteresis import play
from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.io.presets import load_plant
from hammerstein.simulation import (generalized_play_states, preisach_states, simulate_chain,
                                    simulate_chain_batch)
from hammerstein.simulation import _kernels
from hammerstein.simulation._prefetch import chain_kernel_arguments

__all__ = ["add_parser", "handler", "WORKLOADS", "warm_up"]

HELP = "compile every simulation kernel once into numba's cache"


class _Compiled(event.Listener):
    """Names of the functions numba compiles (top level only) while installed."""

    def __init__(self):
        self.names, self.depth = [], 0

    def on_start(self, ev):
        self.depth += 1
        if self.depth == 1:
            d = ev.data["dispatcher"]
            self.names.append(getattr(d, "__name__", None) or getattr(d.py_func, "__name__", "?"))

    def on_end(self, ev):
        self.depth -= 1


def _sine(m, n=400, amplitude=5.0):
    t = np.arange(n) / n
    return amplitude * np.vstack([np.sin(2 * np.pi * (k + 1) * t) for k in range(m)])


def _chain(variant):
    _kernels.chain_kernel(*chain_kernel_arguments(variant))


def _presets():
    for name in ("rakotondrabe-2dof", "realistic-2dof"):
        plant = load_plant(name)
        u = _sine(plant.hysteresis.n_inputs)
        plant.simulate(u)
        plant.hysteresis.simulate(u)
        play(u[0], np.array([0.0, 1.0, 2.0]))


def _compensated():
    plant = load_plant("rakotondrabe-2dof")
    comp = InverseMultiplicativeCompensator(plant.hysteresis)
    ref = _sine(plant.hysteresis.n_outputs, amplitude=10.0)
    simulate_chain(comp, plant, ref)
    simulate_chain_batch([comp, comp], [plant, plant], [ref, ref[:, :300].copy()])
    PerAxisInverseCompensator(plant.hysteresis).simulate(ref)      # the inverse play


def _preisach_classes():
    edges = np.linspace(-10.0, 10.0, 5)
    w = np.tril(np.full((4, 4), 0.1))
    direct = PreisachModel(edges, w, [1.0])
    gpi = GeneralizedPI([0.0, 1.0, 2.0], [1.0, 0.5, 0.2], [10.0, 0.1, 0.0, 0.0],
                        [10.0, 0.1, 0.0, 0.0])
    model = MultivariableHysteresis([[direct, gpi], [None, direct]], ["u1", "u2"], ["y1", "y2"],
                                    [10.0, 10.0])
    u = _sine(2)
    model.simulate(u)
    preisach_states(u[0], edges, np.array([1, 1]), np.array([0, 1]), np.zeros(2))
    generalized_play_states(u[0], np.array([0.0, 1.0]), np.array([10.0, 0.1, 0.0, 0.0]),
                            np.array([10.0, 0.1, 0.0, 0.0]), np.zeros(2))
    inverse_model = MultivariableHysteresis([[direct, None], [None, direct]], ["u1", "u2"],
                                            ["y1", "y2"], [10.0, 10.0])
    PreisachInverseCompensator(inverse_model).simulate(0.5 * model.simulate(u)[0])


def _identification():
    """The identification kernels: generalised-PI sensitivities, the creep's lags and inverse."""
    T = 1e-3
    t, u, _ = decreasing_sine(T, 8.0)
    y = GeneralizedPI([0.0, 2.0, 4.0], [1.0, 0.4, 0.2], [10.0, 0.1, 0.0, 0.0],
                      [10.0, 0.1, 0.0, 0.0]).simulate(u)[0]
    rec = MultiRecord(t, u[None], y[None], ("u",), ("y",), T, "warmup")
    fit = identify_gpi_records(rec, n_plays=4)
    steps = np.repeat([0.0, 4.0, -3.0, 1.0, 0.0, 2.0], 400)
    stairs = [MultiRecord(np.arange(steps.size) * T, steps[None], 1.02 * steps[None], ("u",),
                          ("y",), T, "warmup-stairs")]
    G = control.ss([[0.5]], [[0.5]], [[1.0]], [[0.0]], dt=T)
    for dynamics in (None, G):
        creep = identify_record_creep(fit, stairs, dynamics)
        step_level_errors(fit.model, stairs, creep.creeps_)
        remove_creep([rec], creep.creeps_)


#: (label, function) of every workload, in order.
WORKLOADS = (
    ("chain kernel, default run", lambda: _chain("default")),
    ("chain kernel, hammerstein kind (pre-filter, closed-form law)", lambda: _chain("hammerstein")),
    ("plants and PI models of the bundled presets", _presets),
    ("compensated chain, single and batched; the per-axis inverse", _compensated),
    ("Preisach and generalised-PI models, their inverse", _preisach_classes),
    ("identification: generalised-PI sensitivities, creep", _identification),
)


def warm_up(report=None):
    """Run every workload of :data:`WORKLOADS`; what numba compiled for each and the time.

    Parameters
    ----------
    report : callable, optional
        Called after each workload with ``(label, compiled names, seconds, error or None)``.

    Returns
    -------
    list of tuple
        ``(label, list of str, float, Exception or None)`` per workload: the
        functions numba compiled (the cached ones load without compiling),
        the wall time [s] and the error, if the workload failed.
    """
    out = []
    for label, work in WORKLOADS:
        listener = _Compiled()
        t0 = time.perf_counter()
        error = None
        with event.install_listener("numba:compile", listener):
            try:
                work()
            except Exception as exc:     # noqa: BLE001 - reported; the other workloads still run
                error = exc
        row = (label, listener.names, time.perf_counter() - t0, error)
        out.append(row)
        if report is not None:
            report(*row)
    return out


def add_parser(subparsers):
    """Register `hammerstein warmup`: compile the simulation kernels into numba's cache.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``hammerstein`` sub-command registry.
    """
    p = subparsers.add_parser(
        "warmup", help=HELP,
        description="Compile every simulation kernel once into numba's on-disk cache "
                    "(~/.cache/hammerstein/numba, under $XDG_CACHE_HOME when that is set; "
                    "NUMBA_CACHE_DIR when you set it), so that the first run on this machine "
                    "does not wait for the compiler. A second warmup compiles nothing.")
    p.add_argument("-q", "--quiet", action="store_true", help="print only the total")
    p.set_defaults(handler=handler)


def handler(args):
    """Compile the kernels; exit status 0, or 1 when a workload failed.

    Parameters
    ----------
    args : argparse.Namespace
        ``quiet``.

    Returns
    -------
    int
    """
    t0, c0 = time.perf_counter(), time.process_time()

    def report(label, names, seconds, error):
        if error is not None:
            print_err(f"error: warmup: {label}: {error}")
        elif not args.quiet:
            what = ", ".join(dict.fromkeys(names)) if names else "nothing (cached)"
            print(f"{label}: {seconds:.1f} s, compiled {what}")

    rows = warm_up(report)
    compiled = sorted({n for _, names, _, _ in rows for n in names})
    print(f"warmup: {len(compiled)} kernel(s) compiled in {time.perf_counter() - t0:.1f} s "
          f"({time.process_time() - c0:.1f} s CPU); later runs load them from numba's cache")
    return 1 if any(err is not None for *_, err in rows) else 0
