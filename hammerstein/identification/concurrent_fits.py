"""Independent identifications run side by side in worker processes.

``identify --model auto`` fits three model classes (classical PI, Preisach,
generalised PI) on the same records, one after the other; the fits share
nothing, and each is single-threaded Python and compiled kernels, so on a
machine with more than one core they can run at the same time.
:func:`fit_concurrently` runs such independent calls in a pool of forked
processes (each inherits the records and the loaded modules; only the
results travel back, pickled) and returns each call's result or the
exception it raised, so the caller applies its own rule (e.g. ``auto``
keeps the classes that succeeded). ``workers`` caps the processes; with one
worker, or where the fork start method is unavailable, the calls run in
this process, in order, with the same results.

:func:`worker_count` is the default cap: the cores this process may use
(``os.sched_getaffinity``), at most ``HAMMERSTEIN_WORKERS`` when that
environment variable is set.
"""

from __future__ import annotations

import multiprocessing
import signal
import os
from concurrent.futures import ProcessPoolExecutor

__all__ = ["fit_concurrently", "worker_count"]


def worker_count(tasks=None):
    """Worker processes to use: the usable cores, capped by ``HAMMERSTEIN_WORKERS`` and ``tasks``.

    Parameters
    ----------
    tasks : int, optional
        Number of independent calls (no more workers than calls).

    Returns
    -------
    int
        At least 1.

    Examples
    --------
    >>> worker_count(1)
    1
    """
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    cap = os.environ.get("HAMMERSTEIN_WORKERS", "").strip()
    if cap.isdigit() and int(cap) >= 1:
        n = min(n, int(cap))
    if tasks is not None:
        n = min(n, int(tasks))
    return max(1, n)


def _call(function, args, kwargs):
    return function(*args, **kwargs)


def fit_concurrently(tasks, workers=None):
    """Run independent calls, in worker processes when more than one worker is allowed.

    Parameters
    ----------
    tasks : dict of str to (callable, tuple, dict)
        ``name -> (function, args, kwargs)``; the function must be importable
        at module level (it is pickled by reference), its result picklable.
    workers : int, optional
        Largest number of processes (default :func:`worker_count`). With 1,
        the calls run here, in the order of ``tasks``.

    Returns
    -------
    dict of str to object
        ``name -> result``, or ``name -> exception`` when the call raised
        one (an :class:`Exception`; a worker process that died reads as a
        :class:`concurrent.futures.process.BrokenProcessPool`). Same keys and
        order as ``tasks``.

    Examples
    --------
    >>> out = fit_concurrently({"a": (divmod, (7, 2), {}), "b": (divmod, (1, 0), {})}, workers=1)
    >>> out["a"], type(out["b"]).__name__
    ((3, 1), 'ZeroDivisionError')
    """
    n = worker_count(len(tasks)) if workers is None else max(1, min(int(workers), len(tasks)))
    results = {}
    if n <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        for name, (function, args, kwargs) in tasks.items():
            try:
                results[name] = function(*args, **kwargs)
            except Exception as exc:      # noqa: BLE001 - handed back to the caller's rule
                results[name] = exc
        return results
    pool = ProcessPoolExecutor(n, multiprocessing.get_context("fork"), initializer=_quiet_worker)
    try:
        futures = {name: pool.submit(_call, function, args, kwargs)
                   for name, (function, args, kwargs) in tasks.items()}
        for name, future in futures.items():
            try:
                results[name] = future.result()
            except Exception as exc:      # noqa: BLE001 - handed back to the caller's rule
                results[name] = exc
    except BaseException:
        # Ctrl-C (or SIGTERM) in the parent: the workers, which ignore SIGINT, are stopped
        # now rather than after their fits (a traceback per worker was printed before)
        for proc in list((getattr(pool, "_processes", None) or {}).values()):
            proc.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return results


def _quiet_worker():
    """A worker ignores SIGINT: a terminal's Ctrl-C reaches the whole process group, and the
    parent alone handles it (each worker printed 'Process ForkProcess-2: Traceback ...')."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)    # the parent's terminate() ends it at once
