"""Compile the chain kernel into numba's on-disk cache, in a helper process.

``python -m hammerstein.simulation._prefetch`` compiles
:func:`~hammerstein.simulation._kernels.chain_kernel` for the one signature
every chain run uses (float64 C-contiguous arrays in the named tuples of
:mod:`._packing`, an ``int`` sample count, ``bool`` flags) and exits; numba
writes it to its cache (a temporary renamed into place, so a reader never
sees half a file). :func:`hammerstein.simulation._compile.prefetch` starts
it at the beginning of a command-line run, so that on a machine whose cache
is empty the kernel compiles on the second core while the run validates,
resolves and compiles the plant kernel on the first, and the run then loads
it from the cache instead of compiling it itself.

Nothing is simulated: the call has zero samples. The helper dies with the
process that started it (its pid is the argument): a run killed by SIGKILL
leaves no compiler behind (numba renames a finished cache file into place,
so a killed helper leaves no partial entry either).
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

import numpy as np

from hammerstein.simulation import _kernels as kernels
from hammerstein.simulation._packing import ChainState, LawArrays, LinearArrays, PIArrays

__all__ = ["chain_kernel_arguments", "main"]


#: the variants the helper can compile: the default run's kernel (no reference pre-filter,
#: no closed-form law) and the Hammerstein kind's (ZPETC pre-filter, 2 x 2 closed form)
VARIANTS = ("default", "hammerstein")


def chain_kernel_arguments(variant="default"):
    """Arguments of a zero-sample :func:`chain_kernel` call, typed as every chain run's.

    Parameters
    ----------
    variant : {'default', 'hammerstein'}
        ``'hammerstein'``: typed as a ``kind = "hammerstein"`` (ZPETC) run,
        with a pre-filter plan and a closed-form table.

    Returns
    -------
    tuple
        ``(yr, n_samples, law, comp, plan, slopes, plant, linear, run_plant,
        state, u_out, y_out)`` (``plan`` and ``slopes`` None: the kernel
        without a reference pre-filter and without the closed-form 2 x 2
        law, as the default run uses it) for one input and one output, no
        plays, zero samples.
    """
    one = np.zeros((1, 1))
    pi = PIArrays(np.zeros(2, dtype=np.int64), np.zeros(0), np.zeros((1, 0)), np.zeros((1, 1)))
    linear = LinearArrays(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.eye(1))
    law = LawArrays(one.copy(), 1, 1.0, False, 0.0, False)
    state = ChainState(*(np.zeros(k) for k in (1, 1, 0, 0, 0, 0)))
    if variant == "hammerstein":    # the types of a ZPETC plan and a closed-form table
        plan, slopes = kernels.prefilter_plan(linear), np.zeros((2, 4))
    else:
        plan, slopes = None, None
    return (np.zeros((1, 0)), 0, law, pi, plan, slopes, pi, linear, True,
            state, np.zeros((1, 0)), np.zeros((1, 0)))


def _die_with(parent):
    """Linux: SIGKILL this process when ``parent`` dies (``prctl(PR_SET_PDEATHSIG)``)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError, TypeError):
        return True                 # elsewhere: the parent stops it at its exit
    return os.getppid() == parent   # False: the parent died before the prctl


def main(argv=None):
    """Compile (or load) the chain kernel; exit status 0 (1: the parent has gone).

    Parameters
    ----------
    argv : list of str, optional
        ``[parent_pid, variant]`` (default ``sys.argv[1:]``); without a pid
        the helper is not tied to a parent; ``variant`` one of
        :data:`VARIANTS` (default ``'default'``).

    Returns
    -------
    int
        The exit status.
    """
    argv = sys.argv[1:] if argv is None else argv
    if argv and not _die_with(int(argv[0])):
        return 1
    variant = argv[1] if len(argv) > 1 and argv[1] in VARIANTS else "default"
    kernels.chain_kernel(*chain_kernel_arguments(variant))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
