"""Notice of the kernels' one-time compilation (numba), for the CLI and other front ends.

Numba compiles a kernel on its first call and keeps it in its on-disk cache
(``cache=True``), so only the first run on a machine (or after an upgrade
of the kernels) waits. :func:`compile_notices` tells a front end *before*
such a wait, with an estimate: it listens to numba's ``numba:compile``
event, which numba raises only when the on-disk cache does not hold the
kernel (a cache hit loads it without the event). Nothing is printed by the
library itself: without :func:`compile_notices` the notice goes to the
``hammerstein.simulation`` logger at INFO level (silent by default).

:func:`guard_cache_writes` keeps a cache that cannot be written (full disk,
quota, read-only file system) from failing a run: the kernel compiled in
memory is used, the cache is not written again in this process, and one
notice says so.

:func:`prefetch` starts the compilation of the chain kernel (the longest,
about two thirds of a cold run's compile time) in a helper process
(:mod:`._prefetch`) that writes it to numba's on-disk cache, so that a
command-line run on a machine whose cache is empty compiles it on a second
core while it validates, resolves and compiles its other kernels; the chain
runs (:mod:`._stepping`) call :func:`await_prefetch` first and then load it
from the cache.
"""

from __future__ import annotations

import atexit
import errno
import logging
import os
import subprocess
import sys
import threading
import time
from contextlib import contextmanager

import numba
from numba.core import caching, event

from hammerstein.simulation import _kernels, _prefetch

__all__ = ["COMPILE_SECONDS", "MIN_NOTICE_SECONDS", "PREFETCH_WAIT_SECONDS", "compile_notices",
           "announce_compiles", "compile_estimate", "guard_cache_writes", "prefetch",
           "await_prefetch"]

_LOG = logging.getLogger("hammerstein.simulation")

#: Typical compile time of each kernel [s], cold cache, on the 2-core
#: development machine (``python benchmarks/benchmark.py``, section 3).
#: ``chain_batch`` links ``chain_kernel``, compiled first when it is not
#: cached either.
COMPILE_SECONDS = {"play_kernel": 0.4, "pi_kernel": 0.5, "plant_kernel": 1.0,
                   "chain_kernel": 4.5, "chain_batch": 3.0}

#: Extra compile time [s] of the chain kernel's specialisations (cold, measured like
#: :data:`COMPILE_SECONDS`): with a reference pre-filter (its plan; the batch kernel also
#: compiles the planner) and with the closed-form 2 x 2 law's table. Measured alone:
#: 3.8 s neither, 5.1 s pre-filter, 5.7 s table, 7.1 s both.
COMPILE_EXTRA_SECONDS = {"prefilter": 1.3, "planner": 1.8, "closed_form": 1.9}

#: Compilations estimated below this [s] pass without a notice.
MIN_NOTICE_SECONDS = 1.5


def _dispatchers():
    return {name: getattr(_kernels, name) for name in COMPILE_SECONDS}


def _on_disk(dispatcher, match=None):
    """True when numba's on-disk cache holds a compiled version of ``dispatcher``.

    Reads the cache index (stamped with the source file, so an edited kernel
    reads as absent); any failure reads as absent. With ``match`` (a
    predicate on a signature, a tuple of numba types), only a version whose
    signature it accepts counts.
    """
    try:
        index = dispatcher._cache._cache_file._load_index()
        return bool(index) if match is None else any(match(key[0]) for key in index)
    except Exception:      # noqa: BLE001 - a private numba API; absent means "estimate it"
        return False


def _chain_variant_ready(prefiltered, closed):
    """True when a chain kernel with (or without) a pre-filter plan and a closed-form table is
    compiled in this process or held by the on-disk cache (e.g. written by the helper)."""
    chain = _kernels.chain_kernel

    def matches(sig):
        return (len(sig) > 5 and (not isinstance(sig[4], numba.types.NoneType)) == prefiltered
                and (not isinstance(sig[5], numba.types.NoneType)) == closed)

    return any(matches(sig) for sig in chain.signatures) or _on_disk(chain, matches)


def compile_estimate(name, args=None):
    """Seconds the compilation of kernel ``name`` will take here, from :data:`COMPILE_SECONDS`.

    Includes the kernels it links that are neither loaded nor cached, and,
    given the argument types, what the chain kernel's specialisation adds
    (:data:`COMPILE_EXTRA_SECONDS`: a reference pre-filter, the closed-form
    2 x 2 law).

    Parameters
    ----------
    name : str
        A key of :data:`COMPILE_SECONDS`.
    args : sequence of numba types, optional
        The argument types being compiled (numba's ``numba:compile`` event).

    Returns
    -------
    float
        Estimated compile time [s] at the development machine's speed.
    """
    seconds = COMPILE_SECONDS[name]
    where = {"chain_kernel": (4, 5), "chain_batch": (5, 6)}.get(name)
    given = [] if where is None or args is None or len(args) <= where[1] else \
        [not isinstance(args[i], numba.types.NoneType) for i in where]
    prefiltered, closed = given if given else (False, False)
    extra = (prefiltered * COMPILE_EXTRA_SECONDS["prefilter"]
             + closed * COMPILE_EXTRA_SECONDS["closed_form"])
    if name == "chain_kernel":
        seconds += extra
    elif name == "chain_batch":
        if not _chain_variant_ready(prefiltered, closed):     # it compiles within the batch
            seconds += COMPILE_SECONDS["chain_kernel"] + extra
        if prefiltered:
            seconds += COMPILE_EXTRA_SECONDS["planner"]
    return seconds


class _Notices(event.Listener):
    """Calls ``notify(message)`` before each top-level compilation of a kernel."""

    def __init__(self, notify):
        self.tell = notify
        self.names = {id(d): name for name, d in _dispatchers().items()}
        self.depth = 0
        self.started = None
        self.told = False
        self.scale = 1.0                 # measured / estimated (>= 1), from earlier compilations
        self.lock = threading.Lock()

    def on_start(self, ev):
        with self.lock:
            self.depth += 1
            name = self.names.get(id(ev.data["dispatcher"]))
            if self.depth > 1 or name is None:
                return
            self.estimate = compile_estimate(name, ev.data.get("args"))
            self.started = time.perf_counter()
            seconds = self.estimate * self.scale
            if seconds < MIN_NOTICE_SECONDS:
                return
            about = f"about {seconds:.0f} s" if seconds >= 2 else "about 1 s"
            if self.told:
                self.tell(f"compiling one more simulation kernel once, {about}")
            else:
                self.tell(f"compiling the simulation kernels once, {about} "
                            f"(numba caches them for later runs)")
                self.told = True

    def on_end(self, ev):
        with self.lock:
            self.depth -= 1
            if self.depth == 0 and self.started is not None:
                # a slower machine (or a busy one) scales the later estimates up; the
                # short compilations are too noisy (fixed costs) to scale anything
                if self.estimate >= 1.0:
                    taken = time.perf_counter() - self.started
                    self.scale = min(3.0, max(1.0, taken / self.estimate))
                self.started = None


@contextmanager
def compile_notices(notify=None):
    """Within the block, announce each kernel compilation before it starts.

    A compilation is announced when numba is about to compile one of the
    simulation kernels because its on-disk cache does not hold it, and the
    compilation is estimated at :data:`MIN_NOTICE_SECONDS` or more; loads
    from the cache are silent. The estimate is :func:`compile_estimate`,
    scaled up (at most 3x) when this process's earlier compilations took
    longer than theirs (a slower or busy machine).

    Parameters
    ----------
    notify : callable, optional
        Called with a one-line message, e.g. ``"compiling the simulation
        kernels once, about 3 s (numba caches them for later runs)"``;
        by default the ``hammerstein.simulation`` logger at INFO level.

    Yields
    ------
    None

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.simulation import compile_notices, simulate_plays
    >>> messages = []
    >>> with compile_notices(messages.append):
    ...     y, _ = simulate_plays(np.zeros(3), np.zeros(1), np.zeros(1))
    >>> all(m.startswith("compiling the simulation kernels") for m in messages)
    True
    """
    listener = _Notices(notify if notify is not None else _LOG.info)
    with event.install_listener("numba:compile", listener):
        yield


_PROCESS = {"listener": None}


def announce_compiles(notify):
    """Announce kernel compilations from now on, process-wide (a command-line front end).

    The same notices as :func:`compile_notices`, without a block: calling it
    again replaces ``notify`` (one listener per process, so repeated calls
    never repeat a message); ``None`` stops the notices.

    Parameters
    ----------
    notify : callable or None
        Called with each one-line message (e.g. a print to stderr).
    """
    listener = _PROCESS["listener"]
    if listener is not None:
        event.unregister("numba:compile", listener)
        _PROCESS["listener"] = None
    if notify is not None:
        listener = _Notices(notify)
        event.register("numba:compile", listener)
        _PROCESS["listener"] = listener


#: Longest wait [s] of a chain run for the helper process of :func:`prefetch`;
#: beyond it the run compiles the kernel itself.
PREFETCH_WAIT_SECONDS = 120.0

_PREFETCH = {"process": None}


def _stop_prefetch():
    """At exit: a helper still compiling is stopped (nothing of it is half written)."""
    process = _PREFETCH["process"]
    _PREFETCH["process"] = None
    if process is not None and process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            process.kill()


def prefetch(variant="default"):
    """Compile the chain kernel into numba's on-disk cache in a helper process, if needed.

    Nothing happens when the kernel is already compiled in this process or
    held by the cache. Else ``python -m hammerstein.simulation._prefetch``
    starts (same interpreter and environment, so the same cache directory;
    output discarded) and this returns at once; :func:`await_prefetch`,
    called by every chain run, waits for it before the kernel's first call,
    which then loads it from the cache. A helper that fails (a cache that
    cannot be written, a signature it did not foresee) costs nothing but its
    CPU time: the run compiles the kernel itself, as without it. A helper
    still running when this process exits is stopped (killed with it on
    Linux, even by SIGKILL). Compiling is the
    same work either way; on two cores it overlaps the rest of a cold run
    (measured on the default scenario: 6.8-7.0 s wall without, 5.5 s with).

    Parameters
    ----------
    variant : {'default', 'hammerstein'}
        Which specialisation (:data:`hammerstein.simulation._prefetch.VARIANTS`):
        the default run's (no pre-filter, no closed-form law) or a
        ``kind = "hammerstein"`` run's (ZPETC pre-filter, closed-form 2 x 2
        law; a cold 200-frequency Hammerstein sweep: 21 -> 15 s).

    Returns
    -------
    bool
        True when a helper process was started.
    """
    if variant not in _prefetch.VARIANTS:
        raise ValueError(f"variant: expected one of {_prefetch.VARIANTS}, found {variant!r}")
    chain = _kernels.chain_kernel
    signature = tuple(numba.typeof(a) for a in _prefetch.chain_kernel_arguments(variant))
    if (_PREFETCH["process"] is not None or signature in chain.signatures
            or _on_disk(chain, lambda sig: sig == signature)):
        return False
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    path = os.environ.get("PYTHONPATH")
    env = dict(os.environ, PYTHONPATH=root if not path else root + os.pathsep + path)
    try:
        _PREFETCH["process"] = subprocess.Popen(
            [sys.executable, "-m", "hammerstein.simulation._prefetch", str(os.getpid()), variant],
            env=env,
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except OSError:
        return False
    _PREFETCH["estimate"] = compile_estimate("chain_kernel", signature)
    atexit.register(_stop_prefetch)
    return True


def await_prefetch():
    """Wait for the helper process of :func:`prefetch`, if one runs (at most :data:`PREFETCH_WAIT_SECONDS`).

    Called before the first call of a chain kernel; returns at once when no
    helper was started or it has finished. A helper still compiling is
    announced to the listener of :func:`announce_compiles` as the wait
    starts.
    """
    process = _PREFETCH["process"]
    if process is None:
        return
    listener = _PROCESS["listener"]
    if listener is not None and not listener.told and process.poll() is None:
        # the run waits for the helper: said now, once (not when the helper started: a run
        # that stopped on its file's first problem was told of a compilation it never waited for)
        seconds = _PREFETCH.get("estimate") or COMPILE_SECONDS["chain_kernel"]
        listener.tell(f"compiling the simulation kernels once, about {seconds:.0f} s "
                      f"(numba caches them for later runs)")
        listener.told = True
    try:
        process.wait(timeout=PREFETCH_WAIT_SECONDS)
    except subprocess.TimeoutExpired:
        return                  # compiled here instead; the helper is stopped at exit
    _PREFETCH["process"] = None


#: errno values of a cache directory that cannot take the file: full disk, quota,
#: file size limit, read-only file system, permission.
CACHE_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS,
                                errno.EACCES, errno.EPERM})

_GUARD = {"notify": None, "failed": None, "original": None}


def guard_cache_writes(notify=None):
    """Survive a numba cache that cannot be written; the kernels run from memory.

    numba writes a compiled kernel to its on-disk cache and, on Linux, lets
    an ``OSError`` of that write (``ENOSPC``, ``EDQUOT``, ``EFBIG``,
    ``EROFS``, ``EACCES``, ``EPERM``) escape from the kernel's first call,
    where it read as a failure of whatever the caller was writing. After
    this call such an error is caught: the kernel compiled in memory is
    used, no further cache write is tried in this process, and ``notify``
    gets one line naming the cache file and the reason. numba writes to a
    temporary and renames it, so a failed write leaves no partial cache
    entry. Other errors still propagate.

    Parameters
    ----------
    notify : callable, optional
        Called once with the one-line message; default the
        ``hammerstein.simulation`` logger at WARNING level. Calling again
        replaces it.

    Returns
    -------
    OSError or None
        The cache write error caught so far in this process, if any.
    """
    _GUARD["notify"] = notify
    if _GUARD["original"] is None:
        original = caching.Cache.save_overload
        _GUARD["original"] = original

        def save_overload(self, sig, data):
            if _GUARD["failed"] is not None:
                return None
            try:
                return original(self, sig, data)
            except OSError as exc:
                if exc.errno not in CACHE_WRITE_ERRNOS:
                    raise
                _GUARD["failed"] = exc
                where = getattr(exc, "filename", None) or getattr(self, "_cache_path", None)
                where = f" {where}" if where else ""
                message = (f"note: cannot write the compiled-kernel cache{where} "
                           f"({exc.strerror or exc}); the kernels are compiled for this run "
                           f"only (set NUMBA_CACHE_DIR to a writable directory)")
                (_GUARD["notify"] or _LOG.warning)(message)
                return None

        caching.Cache.save_overload = save_overload
    return _GUARD["failed"]
