"""Figure jobs of the reports and the renderer that runs them (inline or in a process pool).

The report code does not draw: it adds one :class:`FigureJob` per PNG
(a module-level figure function, its picklable arguments, the file) to a
:class:`FigureJobs` list, which hands it at once to a
:class:`FigureRenderer`. Without a
renderer (``FigureJobs()``) every job is drawn at once in the calling
process, as a plain function call would. The runner of ``hammerstein
run``/``check``/``replicate`` uses a renderer with a pool of worker
processes (:data:`WORKERS`: 1 on a 2-core machine, 2 on more cores;
``multiprocessing`` fork context: the workers inherit the imported
matplotlib and draw while the next scenario simulates); it waits
for a report's figures (:meth:`FigureJobs.wait`) before the report
directory is renamed into place, and an error raised in a worker is raised
again there, so it becomes the scenario's one-line error. Where fork is not
available, figures are drawn inline.

A renderer draws a figure once per run: a job whose function and arguments
equal (by the hash of their pickle) those of a job it has already drawn gets
a copy of that PNG instead of a second drawing (the paper run's five
scenarios with the same identified dynamics share one Bode plot).

A figure function may name the modules it imports on first use in an
``imports`` attribute (the Bode plots: ``("control",)``, python-control and
scipy.signal, about 1 s of CPU to import). The workers are forked with the
first job, usually before the run has loaded them; when the main process has
loaded them since, such a job goes to one more worker forked then, which
inherits them, instead of importing them a second time in a worker.
"""

from __future__ import annotations

import fnmatch
import gc
import hashlib
import io
import multiprocessing
import os
import pickle
import re
import signal
import sys
import types
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures import wait as wait_futures
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from hammerstein.core.files import safe_write
from hammerstein.report.figures import save

__all__ = ["FigureJob", "FigureJobs", "FigureRenderer", "render_job", "job_key", "WORKERS",
           "LATE_WORKERS", "REMEMBERED", "figure_selection", "loaded_modules"]

def _usable_cores():
    """The CPU cores this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


#: Worker processes of the pool of :class:`FigureRenderer`: one core is left to
#: the main process, which simulates meanwhile (at most 2 workers, at least 1).
#: On a 2-core machine that is 1 worker: with 2 workers the three processes
#: shared the two cores and each ran slower per unit of work (the paper run's
#: 26 figures took 4.7 s of CPU in one process alone, 6.6-6.8 s each in two
#: processes run side by side); the paper run with 1 worker measured 9.6-9.75 s
#: of CPU (medians of 3) against 10.3-12.2 s with 2, alternated at load 2.4-3.7
#: (``benchmarks/cli.py --only paper``).
WORKERS = min(2, max(1, _usable_cores() - 1))


@dataclass(frozen=True)
class FigureJob:
    """One PNG of a report: ``save(function(*args, **kwargs), path)``.

    Parameters
    ----------
    path : pathlib.Path
        The PNG file to write.
    function : callable
        A module-level function returning a ``matplotlib.figure.Figure``
        (pickled by reference for the pool).
    args : tuple
        Positional arguments (arrays, strings, frames: picklable).
    kwargs : dict
        Keyword arguments.
    """

    path: Path
    function: Callable
    args: tuple = ()
    kwargs: dict = field(default_factory=dict)


def render_job(job):
    """Draw and write one figure job (the function the pool workers run).

    Parameters
    ----------
    job : FigureJob

    Returns
    -------
    bytes
        The PNG written to ``job.path`` (the renderer copies it for an
        identical job).
    """
    buffer = io.BytesIO()
    save(job.function(*job.args, **job.kwargs), buffer)
    png = buffer.getvalue()
    safe_write(job.path, png, "figure")
    return png


#: Workers forked later for jobs whose ``imports`` the first workers lack (see the module doc).
LATE_WORKERS = 1

#: Drawn figures a :class:`FigureRenderer` remembers for copies (oldest dropped first).
REMEMBERED = 64


def _array_values(dtype, shape, data):
    """Stands for an array in :func:`job_key`'s pickle (never called: the pickle is only hashed)."""
    raise NotImplementedError


class _KeyPickler(pickle.Pickler):
    """Pickles every numeric array by its dtype, shape and values in C order.

    numpy pickles a Fortran-ordered array differently from a C-ordered one
    holding the same values; an identification computed in the run gives
    Fortran-ordered matrices and the same one read from the on-disk cache
    C-ordered ones, so their Bode plots were not recognised as equal.
    """

    def reducer_override(self, obj):
        if isinstance(obj, np.ndarray) and not obj.dtype.hasobject:
            return _array_values, (obj.dtype.str, obj.shape, np.ascontiguousarray(obj).tobytes())
        return NotImplemented


def job_key(job):
    """Hash of a job's function and arguments: equal keys draw equal PNGs.

    Parameters
    ----------
    job : FigureJob

    Returns
    -------
    bytes or None
        16-byte BLAKE2 digest of the pickled ``(module, name, args,
        kwargs)``, numeric arrays pickled by dtype, shape and values (not
        their memory layout); None when they do not pickle.
    """
    buffer = io.BytesIO()
    try:
        _KeyPickler(buffer, protocol=pickle.HIGHEST_PROTOCOL).dump(
            (job.function.__module__, job.function.__qualname__, job.args,
             sorted(job.kwargs.items())))
    except Exception:  # an argument that does not pickle: no copy, draw it
        return None
    return hashlib.blake2b(buffer.getvalue(), digest_size=16).digest()


def _settle(future, done, path=None):
    """Give ``future`` the outcome of ``done`` (writing its PNG to ``path`` first, if given)."""
    try:
        png = done.result()
        if path is not None:
            safe_write(path, png, "figure")
    except BaseException as exc:     # the drawing's error, or this write's
        future.set_exception(exc)
    else:
        future.set_result(png)


def _done(value=None, error=None):
    f = Future()
    if error is None:
        f.set_result(value)
    else:
        f.set_exception(error)
    return f



def loaded_modules():
    """Names of the modules whose code has run in this process.

    A module registered by :func:`hammerstein.core.lazy.lazy_module` and
    not used yet is left out (its type is not yet ``ModuleType``; testing
    the type does not load it).

    Returns
    -------
    frozenset of str
    """
    return frozenset(name for name, module in list(sys.modules.items())
                     if type(module) is types.ModuleType)


def _job_imports(job):
    """The modules ``job``'s function imports on first use (its ``imports`` attribute)."""
    return frozenset(getattr(job.function, "imports", ()) or ())


def _every(path):
    """The selection of a renderer without ``selects``: every figure."""
    return True

class FigureJobs:
    """The figure jobs of one report directory.

    Parameters
    ----------
    renderer : FigureRenderer, optional
        Runs the jobs; without one each job is drawn when added.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from hammerstein.report.trajectories import divergence_figure
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> jobs = FigureJobs()
    >>> jobs.add(d / "div.png", divergence_figure, np.zeros((2, 10)), ["u1", "u2"], 5, "test", "t")
    >>> jobs.wait(); (d / "div.png").exists()
    True
    """

    def __init__(self, renderer=None):
        self.renderer = renderer
        self._futures = []
        self.skipped = []                   # PNGs the renderer's selection leaves out
        self._jobs = []

    def add(self, path, function, *args, **kwargs):
        """Add the job ``save(function(*args, **kwargs), path)``.

        Drawn at once without a renderer (errors raised here); otherwise
        handed to the renderer at once, so that it draws while the caller
        writes the rest of the report.

        Parameters
        ----------
        path : str or pathlib.Path
            The PNG file.
        function : callable
            Module-level function returning a ``matplotlib.figure.Figure``.
        *args, **kwargs
            Its arguments (picklable: arrays, strings, frames, dicts).

        Raises
        ------
        Exception
            Whatever ``function`` or the PNG writer raises, when drawn at once.
        """
        job = FigureJob(Path(path), function, args, kwargs)
        if self.renderer is None:
            render_job(job)
        elif not getattr(self.renderer, "selects", _every)(job.path):   # optional in a renderer
            self.skipped.append(job.path)
        else:
            self._futures += self.renderer.submit([job])
            self._jobs.append(job)

    def done(self):
        """Whether every job has finished (successfully or not).

        Returns
        -------
        bool
        """
        return all(f.done() for f in self._futures)

    def wait(self):
        """Run or wait for every job; then raise the first job's error, if any.

        Raises
        ------
        Exception
            The first error of a job (after all of them have finished, so
            no worker still writes into the directory).
        """
        wait_futures(self._futures)
        for i, (f, job) in enumerate(zip(self._futures, self._jobs)):
            if not f.cancelled() and isinstance(f.exception(), BrokenProcessPool):
                # a worker was killed (the OOM killer...): draw this figure here instead
                self._futures[i] = _done(render_job(job))
        for f in self._futures:
            if f.exception() is not None:
                raise f.exception()
        _note_skipped(self.skipped)

    def cancel(self, wait=True):
        """Cancel the jobs not started; wait for the running ones (before removing the directory).

        Parameters
        ----------
        wait : bool
            False once the renderer's pool is shut down (its workers have
            exited, so nothing writes any more; the futures of jobs it had
            started may never finish then).
        """
        for f in self._futures:
            f.cancel()
        if wait:
            wait_futures(self._futures)


_PARENT = {"pid": None}


def _die_with_parent(parent):
    """Ask Linux to kill this worker when its parent dies (``prctl(PR_SET_PDEATHSIG, SIGKILL)``).

    Without it a worker of a run killed by SIGKILL lives on under pid 1,
    holding the run's stdout and stderr (``| tee`` never ends). Elsewhere
    (no ``prctl``) the pool's own watchdog ends idle workers.
    """
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)     # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError, TypeError):
        return
    if parent is not None and os.getppid() != parent:   # the parent died before the prctl
        os._exit(1)


def _worker_init():
    _die_with_parent(_PARENT["pid"])
    # the parent handles Ctrl-C/SIGTERM/SIGHUP (and cancels); a worker finishes its figure
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "SIGHUP"):
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # the objects inherited from the parent live as long as the worker: the collector
    # need not walk them again every time a figure's many small objects trigger it
    gc.freeze()


class FigureRenderer:
    """Runs figure jobs in a pool of forked worker processes (or inline).

    A context manager; the pool starts with the first job and stops on
    exit (pending jobs are cancelled when leaving on an
    error). Inline where the fork start method is unavailable, with
    ``workers=0``, or after the pool broke (a worker killed).

    Parameters
    ----------
    workers : int
        Worker processes (default :data:`WORKERS`); 0 draws inline.
    select : callable, optional
        ``select(path) -> bool``: draw only the PNGs it accepts (e.g.
        :func:`figure_selection`); every figure by default. A
        ``report.md`` link to a PNG left out becomes a line saying so.
    """

    def __init__(self, workers=WORKERS, select=None):
        self.workers = int(workers) if "fork" in multiprocessing.get_all_start_methods() else 0
        self._pool = None
        self._late = None                       # (pool, modules it inherited) for late imports
        self._forked_with = frozenset()         # modules loaded when self._pool was forked
        self._drawn = {}                        # job_key -> future of its PNG bytes
        self._select = select

    def selects(self, path):
        """Whether the figure ``path`` is to be drawn.

        Parameters
        ----------
        path : pathlib.Path
            The PNG file.

        Returns
        -------
        bool
        """
        return self._select is None or bool(self._select(Path(path)))

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close(cancel=exc_type is not None)
        return False

    def close(self, cancel=False):
        """Stop the pool; wait for the running jobs.

        Parameters
        ----------
        cancel : bool
            Drop the jobs not started yet.
        """
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=cancel)
            self._pool = None
        if self._late is not None:
            self._late[0].shutdown(wait=True, cancel_futures=cancel)
            self._late = None

    def submit(self, jobs):
        """Start the jobs; return one ``concurrent.futures.Future`` per job.

        Parameters
        ----------
        jobs : list of FigureJob

        Returns
        -------
        list of concurrent.futures.Future
            Each resolves to the job's PNG bytes. Already finished for jobs
            drawn inline (their error is set on the future, not raised); a
            job equal to one drawn before (:func:`job_key`) gets a copy of
            its PNG when that one is done.
        """
        keys = [job_key(j) for j in jobs]
        for key in [k for k, f in self._drawn.items()     # a failed drawing is not reused
                    if f.done() and (f.cancelled() or f.exception() is not None)]:
            del self._drawn[key]
        first = {}                          # index of each new key's first job in this batch
        for i, key in enumerate(keys):
            if key is None or (key not in self._drawn and key not in first):
                first[key if key is not None else ("undrawn", i)] = i
        new = sorted(first.values())
        started = dict(zip(new, self._start([jobs[i] for i in new])))
        for i in new:
            if keys[i] is not None:
                self._drawn[keys[i]] = started[i]
        out = [started[i] if i in started else self._copy_when_drawn(self._drawn[keys[i]], j)
               for i, j in enumerate(jobs)]
        while len(self._drawn) > REMEMBERED:
            del self._drawn[next(iter(self._drawn))]
        return out

    def _copy_when_drawn(self, first, job):
        """A future for ``job`` that gets the PNG of ``first`` once ``first`` is drawn.

        If ``first`` was cancelled (the report that drew it was abandoned),
        ``job`` is drawn after all.
        """
        copy = Future()

        def chain(done):
            if not copy.set_running_or_notify_cancel():     # this report was abandoned
                return
            if not done.cancelled():
                _settle(copy, done, job.path)
                return
            try:
                again = self._start([job])[0]
            except BaseException as exc:                    # the pool is shut down
                copy.set_exception(exc)
            else:
                again.add_done_callback(lambda d: _settle(copy, d))

        first.add_done_callback(chain)
        return copy

    def _fork(self, workers):
        _PARENT["pid"] = os.getpid()
        return ProcessPoolExecutor(workers, multiprocessing.get_context("fork"),
                                   initializer=_worker_init)

    def _broken(self):
        """Whether a worker of a pool died (the renderer then draws inline)."""
        pools = [self._pool] + ([self._late[0]] if self._late is not None else [])
        return any(p is not None and getattr(p, "_broken", False) for p in pools)

    def _pool_for(self, job):
        """The pool that draws ``job``: a late worker if it needs modules loaded since the fork."""
        needs = _job_imports(job)
        if not needs or needs <= self._forked_with:
            return self._pool
        if self._late is not None and needs <= self._late[1]:
            return self._late[0]
        loaded = loaded_modules()
        if self._late is None and needs <= loaded:
            self._late = (self._fork(LATE_WORKERS), loaded)
            return self._late[0]
        return self._pool

    def _start(self, jobs):
        if self._broken():                                   # a worker died: inline now
            for pool in [self._pool] + ([self._late[0]] if self._late is not None else []):
                if pool is not None:
                    pool.shutdown(wait=False, cancel_futures=True)
            self._pool, self._late, self.workers = None, None, 0
        if self._pool is None and self.workers >= 1 and jobs:
            self._forked_with = loaded_modules()
            self._pool = self._fork(self.workers)
        if self._pool is not None:
            try:
                return [self._pool_for(j).submit(render_job, j) for j in jobs]
            except BrokenProcessPool:  # a worker died: draw the rest here
                self._pool, self._late, self.workers = None, None, 0
        out = []
        for j in jobs:
            try:
                out.append(_done(render_job(j)))
            except Exception as exc:
                out.append(_done(error=exc))
        return out


def figure_selection(spec):
    """The ``select`` of a :class:`FigureRenderer` from the ``run --figures`` value.

    Parameters
    ----------
    spec : str
        ``"all"`` (every figure), ``"none"``, or comma-separated shell
        patterns matched against the PNG file names (``fnmatch``, e.g.
        ``"loops*,sweep-*"``).

    Returns
    -------
    callable or None
        ``select(path) -> bool``; None for ``"all"``.

    Raises
    ------
    ValueError
        If ``spec`` is empty or holds an empty pattern.

    Examples
    --------
    >>> from pathlib import Path
    >>> select = figure_selection("loops*,sweep-*")
    >>> select(Path("r/loops-compensated.png")), select(Path("r/trajectory-x.png"))
    (True, False)
    >>> figure_selection("all") is None
    True
    """
    spec = str(spec).strip()
    if spec == "all":
        return None
    if spec == "none":
        return lambda path: False
    patterns = [p.strip() for p in spec.split(",")]
    if not spec or any(not p for p in patterns):
        raise ValueError(f"--figures: expected 'all', 'none' or comma-separated file name "
                         f"patterns (e.g. 'maps-*,trajectory-*'), found {spec!r}")
    return lambda path: any(fnmatch.fnmatchcase(Path(path).name, p) for p in patterns)


def _note_skipped(paths):
    """Replace the ``report.md`` image links to the PNGs ``paths`` (not drawn) by a note."""
    by_dir = {}
    for path in paths:
        by_dir.setdefault(Path(path).parent, []).append(Path(path).name)
    for directory, names in by_dir.items():
        md = directory / "report.md"
        if not md.is_file():
            continue
        text = md.read_text(encoding="utf-8")
        for name in names:
            text = re.sub(r"!\[([^\]]*)\]\(" + re.escape(name) + r"\)",
                          lambda m, n=name: f"*{m.group(1) or n}: figure `{n}` not drawn "
                                            f"(`run --figures`)*", text)
        safe_write(md, text, "report")
