"""Drive files: the CSV files of the hardware commands, read and written.

``hammerstein compensate`` and ``learn`` write a drive (``t`` and one
column per input [V], optionally predicted or shaped outputs [µm]) under
a comment header that starts with :data:`DRIVE_MARK` (the mark by which a
command knows a file it may replace) and states the fade-in
(:func:`drive_fade_samples`); :func:`read_signals` reads named columns of
any such CSV (drive, measured record or reference file) on a uniform time
grid. Split from :mod:`hammerstein.compensation.drive`, which re-exports
these names.
"""

from __future__ import annotations

import io
import re
import warnings

import numpy as np

from hammerstein.io.datafiles import numeric_column, signal_table, uniform_period
from hammerstein.io.time_grid import gap_text, step_gaps
from hammerstein.core.files import FileLimitError, bounded_read_bytes, escape
from hammerstein.core.numbers import check_samples
from hammerstein.exceptions import DataFileError

__all__ = ["DRIVE_MARK", "read_signals", "signals_csv", "drive_fade_samples", "drive_rest_lead",
           "drive_rest_output",
           "rest_lead_text", "fade_weight",
           "drive_kind", "optional_columns", "learnt_names", "followed_reference", "shaped_target"]


#: First characters of every CSV file written by ``hammerstein compensate`` / ``learn`` (ownership).
DRIVE_MARK = "# hammerstein"

#: Suffix of a ``learn`` drive's columns of the reference its drive was computed for.
LEARNT_SUFFIX = "_learnt"


def read_signals(path, names, time="t", mapping=None, sampling_period=None, what="file",
                 upsample=True):
    """Columns of a drive, measured or reference CSV file, on a uniform time grid.

    File conventions: a header row (lines starting with ``#`` are comments);
    time in column ``time`` [s], strictly increasing; one column per signal
    named as the model's inputs [V] or outputs [µm] (``mapping`` maps other
    names); other columns are ignored. With ``sampling_period`` the columns
    are interpolated linearly onto ``t_k = k T`` from 0 to the file's last
    time (a file starting after 0 is refused); without it the file's times
    must be uniform (relative spread below 1e-6) and are kept.

    Parameters
    ----------
    path : str or pathlib.Path
        The file (read through the 256 MiB data-file limit,
        ``HAMMERSTEIN_MAX_DATA_BYTES``).
    names : list of str
        The signals wanted, in order.
    time : str
        Time column [s].
    mapping : dict of str to str, optional
        ``{name: column}`` for columns named otherwise.
    sampling_period : float, optional
        Resample onto this period [s].
    what : str
        What the file is, for messages (e.g. ``"--measured"``).
    upsample : bool
        Whether a file sampled more coarsely than ``sampling_period`` (its
        median step above 1.5 T) is interpolated onto it (a reference drawn
        coarsely), or refused (a measured response, recorded at the drive's
        sampling period: a coarser one is a time column in other units than
        seconds, or another rate).

    Returns
    -------
    t : numpy.ndarray, shape (n_samples,)
        [s].
    values : numpy.ndarray, shape (len(names), n_samples)
    sampling_period : float
        [s].

    Raises
    ------
    DataFileError
        Unreadable file, missing column (the message lists the columns
        found), non-numeric values, times not increasing or not uniform.
    """
    try:
        raw = bounded_read_bytes(path, "data", "data file")
    except FileLimitError as exc:        # its message names the file
        raise DataFileError(f"{what}: {exc}") from None
    except OSError as exc:
        raise DataFileError(f"{what}: {escape(path)}: {exc.strerror or exc}") from None
    table = signal_table(raw, path, what)
    del raw
    mapping = dict(mapping or {})

    def column(col, label, unit=("V", "µm")):
        return numeric_column(table, col, label, unit)

    t = column(time, "the time [s]", "s")
    if t.size < 2:
        raise DataFileError(f"{what}: {escape(path)}: {t.size} data row; expected at least two "
                            f"samples")
    if np.any(np.diff(t) <= 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise DataFileError(f"{what}: {escape(path)}: the time column {escape(repr(time), 60)} "
                            f"is not strictly increasing at data row {i + 2} ({t[i]:g} s then "
                            f"{t[i + 1]:g} s)")
    vals = np.array([column(mapping.get(n, n), n) for n in names]).reshape(len(names), t.size)
    Tf, off, tol = uniform_period(t)
    gaps = step_gaps(t)
    uniform = bool(np.max(np.abs(off)) <= tol) and not gaps.size
    if sampling_period is None:
        if gaps.size:
            raise DataFileError(f"{what}: {escape(path)}: the time column "
                                f"{escape(repr(time), 60)} has {gap_text(t, gaps)}; expected "
                                f"one sampling period (fill or resample the gaps, or give "
                                f"--sampling-period to interpolate across them)")
        if not uniform:
            d = np.diff(t)
            raise DataFileError(f"{what}: {path}: the times are not uniform (steps from "
                                f"{d.min():g} to {d.max():g} s, a time {np.max(np.abs(off)):.3g} s "
                                f"off the grid of {Tf:g} s, more than its stamps' rounding "
                                f"{tol:.2g} s); expected one sampling period (give "
                                f"--sampling-period to resample it)")
        return t[0] + np.arange(t.size) * Tf, vals, Tf
    T = float(sampling_period)
    if uniform and abs(Tf - T) <= 1e-6 * T and abs(t[0]) <= tol:
        # sampled at T, its stamps rounded (a float32 logger's): the samples as they are,
        # not interpolated between stamps that are off their sampling times
        return np.arange(t.size) * T, vals, T
    if t[0] > 1e-9 * max(1.0, abs(t[-1])):
        raise DataFileError(f"{what}: {path}: starts at {t[0]:g} s; expected t = 0 first")
    if t[-1] < T:
        raise DataFileError(f"{what}: {escape(path)}: spans {t[-1]:g} s, less than one sampling "
                            f"period {T:g} s; is its time column {escape(repr(time), 60)} in "
                            f"seconds?")
    n = check_samples(np.floor(t[-1] / T + 1e-9) + 1,
                      f"{what}: {escape(path)}: {t[-1]:g} s sampled at {T:g} s",
                      DataFileError, T, len(names) + 1)
    step = float(np.median(np.diff(t)))
    if not upsample and step > 1.5 * T:
        raise DataFileError(f"{what}: {escape(path)}: sampled every {step:g} s, {step / T:.4g} "
                            f"sampling periods of {T:g} s; expected one sample per period (is its "
                            f"time column {escape(repr(time), 60)} in seconds?)")
    if step < 0.5 * T and t.size > 2 * n:
        warnings.warn(f"{what}: {escape(path)}: sampled every {step:g} s, resampled onto "
                      f"{T:g} s: {t.size} rows become {n} samples (the reference between "
                      f"the samples is dropped)", UserWarning, stacklevel=2)
    grid = np.arange(n) * T
    return grid, np.array([np.interp(grid, t, v) for v in vals]).reshape(len(names), n), T


def signals_csv(t, columns, comment):
    """CSV text of signals at full precision, headed by a ``# hammerstein`` comment.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time [s] (column ``t``).
    columns : dict of str to array_like, each shape (n_samples,)
        Name -> values, in column order.
    comment : str
        The comment lines' text (units, what wrote the file); each line is
        prefixed with ``# hammerstein`` / ``#``.

    Returns
    -------
    str

    Examples
    --------
    >>> print(signals_csv([0.0, 0.5], {"ux": [0.1, 1 / 3]}, "drive: t [s], ux [V]"), end="")
    # hammerstein drive: t [s], ux [V]
    t,ux
    0,0.10000000000000001
    0.5,0.33333333333333331
    """
    lines = comment.splitlines() or [""]
    head = [f"{DRIVE_MARK} {lines[0]}".rstrip()] + [f"# {ln}".rstrip() for ln in lines[1:]]
    data = np.column_stack([np.asarray(t, dtype=float)]
                           + [np.asarray(v, dtype=float) for v in columns.values()])
    buf = io.StringIO()
    np.savetxt(buf, data, delimiter=",", fmt="%.17g")
    return "\n".join(head + [",".join(["t", *columns])]) + "\n" + buf.getvalue()



def fade_weight(s):
    """The weight of a drive's fade-in at ``s`` in [0, 1]: ``s^4 (35 - 84 s + 70 s^2 - 20 s^3)``.

    From 0 to 1 with value, slope, acceleration and jerk continuous at both
    ends: a raised cosine's jump in acceleration made the inverse of two
    bending modes ring at the fade's start and end (steps 9 times the
    settled drive's largest, on an outside actuator), which this one does
    not. :func:`hammerstein.compensation.drive.hardware_fade` fades a
    reference with it; a C caller computes the same weights.

    Parameters
    ----------
    s : array_like
        Position in the fade [1].

    Returns
    -------
    numpy.ndarray
        The weights [1], shape of ``s``.

    Examples
    --------
    >>> fade_weight([0.0, 0.25, 0.5, 1.0, 2.0]).tolist()
    [0.0, 0.070556640625, 0.5, 1.0, 1.0]
    """
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    return s ** 4 * (35.0 - 84.0 * s + 70.0 * s ** 2 - 20.0 * s ** 3)


def drive_fade_samples(path):
    """The ``fade-in N samples`` a drive file's header records, or None.

    Parameters
    ----------
    path : str or pathlib.Path
        A drive file of ``hammerstein compensate`` or ``learn``.

    Returns
    -------
    int or None
        N [samples]; None when the first 20 comment lines do not state it.

    Raises
    ------
    OSError
        The file cannot be read.
    """
    return _header_int(path, r"fade-in (\d+) samples")


def rest_lead_text(rest_lead):
    """The words of a drive file's fade-in phrase that give its rest lead.

    Parameters
    ----------
    rest_lead : int or None
        The fade-in's samples at rest; None for the default tenth.

    Returns
    -------
    str
        ``"its first L at rest, "`` (:func:`drive_rest_lead` reads it back), or ``""``.
    """
    return "" if rest_lead is None else f"its first {int(rest_lead)} at rest, "


def drive_rest_lead(path):
    """The fade-in's samples at rest a drive file's header records (``its first L at rest``),
    or None (then a tenth of the fade-in, :func:`hammerstein.compensation.drive.hardware_fade`).

    Parameters
    ----------
    path : str or pathlib.Path
        A drive file of ``hammerstein compensate`` or ``learn``.

    Returns
    -------
    int or None
        L [samples].

    Raises
    ------
    OSError
        The file cannot be read.
    """
    return _header_int(path, r"fade-in \d+ samples \([^)]*its first (\d+) at rest")


def drive_rest_output(path, outputs):
    r"""The rest output a drive file's header records its fade-in started from, or None.

    ``compensate`` writes ``from the rest output x = 0.0 µm, y = 0.0 µm``
    (the model's output at 0 V, where it faded the reference in from).

    Parameters
    ----------
    path : str or pathlib.Path
        A drive file of ``hammerstein compensate`` or ``learn``.
    outputs : list of str
        Output names.

    Returns
    -------
    numpy.ndarray, shape (len(outputs),), or None
        [µm]; None when the header does not give every output's.

    Raises
    ------
    OSError
        The file cannot be read.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as fh:
    ...     _ = fh.write("# a drive, fade-in 4 samples from the rest output x = 0.5 µm, "
    ...                  "y = -1.0 µm (the model's output at 0 V)\nt,ux\n0,0\n")
    >>> drive_rest_output(fh.name, ["x", "y"]).tolist()
    [0.5, -1.0]
    >>> os.remove(fh.name)
    """
    for line in _header(path):
        m = re.search(r"from the rest output (.*?)(?: \(|$)", line)
        if m:
            values = dict(re.findall(r"(\S+) = ([-+0-9.eE]+|nan|inf) µm", m.group(1)))
            try:
                return np.array([float(values[o]) for o in outputs])
            except (KeyError, ValueError):
                return None
    return None


def _header_int(path, pattern):
    """The integer ``pattern``'s group captures in the first header line it matches, or None."""
    for line in _header(path):
        m = re.search(pattern, line)
        if m:
            return int(m.group(1))
    return None


#: Bytes of a file's opening read for its header lines (never the whole of a device or FIFO).
HEAD_BYTES = 1 << 16


def head_lines(path, lines=20, what="data file"):
    """The first ``lines`` lines of a regular file, read through a bounded read.

    Parameters
    ----------
    path : str or pathlib.Path
    lines : int
        Lines wanted at most.
    what : str
        What the file should be, for messages.

    Returns
    -------
    list of str
        Each with its end of line; from the first :data:`HEAD_BYTES` bytes only.

    Raises
    ------
    FileLimitError
        A directory, device, FIFO or socket (never read: it may never end).
    OSError
        The file cannot be read.
    """
    raw = bounded_read_bytes(path, "data", what, head=HEAD_BYTES)
    return raw.decode("utf-8", errors="replace").splitlines(keepends=True)[:lines]


def _header(path, lines=20):
    """The comment lines that open a file (at most ``lines``)."""
    out = []
    for line in head_lines(path, lines):
        if not line.startswith("#"):
            break
        out.append(line)
    return out


def drive_kind(path):
    """The command and the compensator kind a drive file's header records.

    Parameters
    ----------
    path : str or pathlib.Path
        A drive file of ``hammerstein compensate`` or ``learn``.

    Returns
    -------
    command : str or None
        ``'compensate'`` or ``'learn'`` (the header's first line), else None.
    kind : str or None
        The ``kind K`` the header states, else None.

    Raises
    ------
    OSError
        The file cannot be read.
    """
    command = kind = None
    for i, line in enumerate(_header(path)):
        if i == 0:
            m = re.match(re.escape(DRIVE_MARK) + r" (compensate|learn) ", line)
            command = m.group(1) if m else None
        m = re.search(r"\bkind ([a-z-]+)", line)
        if m and kind is None:
            kind = m.group(1)
    return command, kind


def _header_columns(path):
    """The column names of a CSV file: its first line that is not a ``#`` comment (200 at most)."""
    header = next((line for line in head_lines(path, 200)
                   if line and not line.startswith("#")), "")
    return [c.strip() for c in header.split(",")]


def optional_columns(path, names, sampling_period=None, what="file"):
    """Named columns of a CSV file, or None when one of them is not there.

    Parameters
    ----------
    path : str or pathlib.Path
    names : list of str
        Column names.
    sampling_period : float, optional
        Expected T [s] (:func:`read_signals`).
    what : str
        Name of the file in messages.

    Returns
    -------
    numpy.ndarray, shape (len(names), n_samples), or None

    Raises
    ------
    DataFileError
        The columns are there but not readable (:func:`read_signals`).
    OSError
        The file cannot be read.
    """
    columns = _header_columns(path)
    if not all(n in columns for n in names):
        return None
    _, values, _ = read_signals(path, list(names), "t", None, sampling_period, what)
    return values


def drive_input_names(path, outputs):
    """The input columns of a drive file: every column but ``t`` and the outputs' own.

    A drive ``compensate`` or ``learn`` wrote holds ``t``, one column per input
    [V], and columns of the outputs it aims at (``<output>_shaped``,
    ``<output>_learnt``, ``<output>_pred``).

    Parameters
    ----------
    path : str or pathlib.Path
        The drive file.
    outputs : list of str
        Output names.

    Returns
    -------
    list of str
        In the file's order; empty when the file names none.

    Raises
    ------
    OSError
        The file cannot be read.
    """
    columns = [c for c in _header_columns(path) if c]
    return [c for c in columns if c != "t" and c not in outputs
            and not any(c.startswith(f"{o}_") for o in outputs)]


def shaped_target(path, outputs, target, sampling_period=None):
    """The shaped reference a drive file records as its target, or None.

    ``compensate`` writes the reference it shaped to what the amplifier and
    the identified dynamics allow (``<output>_shaped`` columns, fade-in
    included) and ``learn`` carries it over to its drives: the position the
    drive aims at, where the reference as asked cannot be followed.

    Parameters
    ----------
    path : str or pathlib.Path
        The drive file.
    outputs : list of str
        Output names.
    target : numpy.ndarray, shape (p, n_samples)
        The faded reference as asked [µm] (gives the expected shape).
    sampling_period : float, optional
        Expected T [s].

    Returns
    -------
    numpy.ndarray, shape (p, n_samples), or None
        [µm]; None without ``<output>_shaped`` columns.

    Raises
    ------
    DataFileError
        Columns that are not readable, or of another length than ``target``.
    OSError
        The file cannot be read.
    """
    f = optional_columns(path, [f"{o}_shaped" for o in outputs], sampling_period, "--drive")
    if f is not None and f.shape != np.shape(target):
        raise DataFileError(f"--drive: its shaped reference has {f.shape[1]} samples; expected "
                            f"the reference's {np.shape(target)[1]}")
    return f


def learnt_names(outputs):
    """The columns of a drive file that hold the reference its drive was computed for.

    Parameters
    ----------
    outputs : list of str
        Output names.

    Returns
    -------
    list of str
        ``<output>_learnt``.

    Examples
    --------
    >>> learnt_names(["x", "y"])
    ['x_learnt', 'y_learnt']
    """
    return [f"{o}{LEARNT_SUFFIX}" for o in outputs]


def followed_reference(path, outputs, target, sampling_period=None):
    """The reference the drive in a drive file was computed for, and the compensator kind.

    A ``learn`` drive of a repeating reference records it in its
    ``<output>_learnt`` columns; a ``compensate`` drive followed the faded
    reference ``target``, or the shaped one it records in its
    ``<output>_shaped`` columns. Another drive (no such header or columns)
    has none: its start-up is not a compensator's.

    Parameters
    ----------
    path : str or pathlib.Path
        The drive file.
    outputs : list of str
        Output names.
    target : numpy.ndarray, shape (p, n_samples)
        The faded reference [µm].
    sampling_period : float, optional
        Expected T [s].

    Returns
    -------
    followed : numpy.ndarray, shape (p, n_samples), or None
        [µm].
    kind : str or None
        The kind the header states (:func:`drive_kind`).

    Raises
    ------
    DataFileError
        Columns that are not readable, or of another length than ``target``.
    OSError
        The file cannot be read.
    """
    command, kind = drive_kind(path)
    f = optional_columns(path, learnt_names(outputs), sampling_period, "--drive")
    if f is None and command == "compensate":
        f = optional_columns(path, [f"{o}_shaped" for o in outputs], sampling_period, "--drive")
        if f is None:
            f = np.asarray(target, dtype=float)
    if f is not None and f.shape != np.shape(target):
        raise DataFileError(f"--drive: its learnt reference has {f.shape[1]} samples; expected "
                            f"the reference's {np.shape(target)[1]}")
    return f, kind
