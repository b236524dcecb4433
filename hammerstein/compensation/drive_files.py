"""Drive files: the CSV files of the hardware commands, read and written.

``hammerstein compensate`` and ``learn`` write a drive (``t`` and one
column per input [V], optionally predicted or shaped outputs [µm]) under
a comment header that starts with :data:`DRIVE_MARK` (the mark by which a
command knows a file it may replace) and states the fade-in
(:func:`drive_fade_samples`); :func:`read_signals` reads named columns of
any such CSV (drive, measured record or reference file) on a uniform time
grid. Split from :mod:`hammerstein.compensation.drive`, which re-exports
these names.

Length: the readers and the writer of one file format, the drive file: its
table, and each field of its header the hardware commands read back (fade-in,
rest lead, rest output, units, kind, input columns, shaped and learnt references).
"""

from __future__ import annotations

import io
import re
import warnings

import numpy as np

from hammerstein.io.datafiles import (_first_line, _sniff_separator, numeric_column, signal_table,
                                      uniform_period)
from hammerstein.io.time_grid import gap_text, step_gaps
from hammerstein.compensation.drive_size import DRIVE_MARK, file_limit, write_drive_rows
from hammerstein.core.files import FileLimitError, bounded_read_bytes, escape
from hammerstein.core.numbers import check_samples
from hammerstein.exceptions import DataFileError

__all__ = ["DRIVE_MARK", "AIMED_SUFFIXES", "RATE_TOL", "read_signals", "read_table", "block_mean",
           "signals_csv", "signals_writer", "drive_fade_samples", "drive_rest_lead",
           "drive_rest_output", "drive_units",
           "rest_lead_text", "fade_weight",
           "drive_kind", "optional_columns", "learnt_names", "followed_reference", "shaped_target"]


#: Suffix of a ``learn`` drive's columns of the reference its drive was computed for.
LEARNT_SUFFIX = "_learnt"

#: Suffixes of a drive file's columns of an output it aims at or predicts (never an input):
#: ``<output>_shaped``, ``<output>_learnt``, ``<output>_predicted`` (``_pred`` in older files).
AIMED_SUFFIXES = ("_shaped", LEARNT_SUFFIX, "_pred", "_predicted")

#: Relative difference of a file's nominal period from the sampling period within which it is
#: taken as sampled at that period (a jittered logger's), not at another rate.
RATE_TOL = 1e-3


#: Files larger than this [bytes] have their time column parsed alone, as numbers, and
#: checked before the whole table is parsed as text (a 640 MB file took 75 s and 8 GB).
TIME_PRECHECK_BYTES = 16 * 2**20


def _check_increasing(t, path, time, what):
    """Refuse times ``t`` that do not strictly increase, naming the data row and both stamps."""
    if np.any(np.diff(t) <= 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise DataFileError(f"{what}: {escape(path)}: the time column {escape(repr(time), 60)} "
                            f"is not strictly increasing at data row {i + 2} ({float(t[i])!r} s "
                            f"then {float(t[i + 1])!r} s)")


def _time_precheck(raw, path, time, what):
    """:func:`_check_increasing` on the time column parsed alone from ``raw``, if it can be.

    Any file the quick parse does not take as it is (a units row, another encoding, a
    non-numeric cell) is left to the full reader, which names its problem.
    """
    import pandas as pd  # lazy: ~0.3 s to import; read_signals' table parse needs it anyway
    try:
        sep = _sniff_separator(_first_line(raw))
        t = pd.read_csv(io.BytesIO(raw), sep=sep, usecols=[time], comment="#", dtype=float,
                        engine="c", skipinitialspace=True)[time].to_numpy()
    except Exception:         # noqa: BLE001 -- the full parse names whatever this did not take
        return
    if t.size >= 2 and np.all(np.isfinite(t)):
        _check_increasing(t, path, time, what)


def read_table(path, what="file", time="t"):
    """The parsed table of a drive, measured or reference CSV file, read once.

    The file is read through a bounded read: within the data files' limit
    (``HAMMERSTEIN_MAX_DATA_BYTES``, 256 MiB), or, for a drive file a command
    wrote (it opens with :data:`DRIVE_MARK`), within the size of the largest
    drive of the largest accepted record
    (:func:`hammerstein.compensation.drive_size.drive_file_limit`). A file
    larger than :data:`TIME_PRECHECK_BYTES` has its time column checked first.
    The table is what :func:`read_signals` and :func:`optional_columns` take
    (``table=``), so that a command reading several columns of one file at
    several steps parses it once.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    what : str
        What the file is, for messages (e.g. ``"--drive"``).
    time : str
        Time column [s] (checked first in a large file).

    Returns
    -------
    hammerstein.io.datafiles._Table
        :func:`hammerstein.io.datafiles.signal_table` of the file (``.frame``:
        its columns).

    Raises
    ------
    DataFileError
        No such file, not a regular file, larger than its limit (the message
        names the file, its size, the limit and the variable that raises it),
        unreadable, not a table, or a time column that does not increase.
    """
    try:
        cap, kind = file_limit(bounded_read_bytes(path, "data", "data file", head=HEAD_BYTES))
        raw = bounded_read_bytes(path, "data", kind, cap=cap)
    except FileLimitError as exc:        # its message names the file
        raise DataFileError(f"{what}: {exc}") from None
    except FileNotFoundError:           # as every other missing file is named
        raise DataFileError(f"{what}: {escape(path)}: no such file") from None
    except OSError as exc:
        raise DataFileError(f"{what}: {escape(path)}: {exc.strerror or exc}") from None
    if len(raw) > TIME_PRECHECK_BYTES:
        _time_precheck(raw, path, time, what)
    return signal_table(raw, path, what)


def read_signals(path, names, time="t", mapping=None, sampling_period=None, what="file",
                 upsample=True, notes=None, period=None, table=None, units=None):
    """Columns of a drive, measured or reference CSV file, on a uniform time grid.

    File conventions: a header row (lines starting with ``#`` are comments);
    time in column ``time`` [s], strictly increasing; one column per signal
    named as the model's inputs [V] or outputs [µm] (``mapping`` maps other
    names); other columns are ignored; a file starting after 0 is refused.
    With ``sampling_period`` the columns are resampled onto ``t_k = k T``
    over the file's whole duration (its last sample plus one of its own
    periods): a file at another rate than ``T`` (its nominal period more
    than :data:`RATE_TOL` off) is interpolated linearly, said in one line
    (``notes``); a measured response (``upsample`` False) faster by an
    integer factor ``m`` is averaged over each period instead (the ``m``
    samples within half a period of ``t_k``: a block mean, which lowers the
    noise), and one slower than ``T`` is refused. Without it the file's
    times must be uniform (relative spread below 1e-6) and are kept.

    Parameters
    ----------
    path : str or pathlib.Path
        The file (read as :func:`read_table` reads it: within the 256 MiB
        data-file limit, ``HAMMERSTEIN_MAX_DATA_BYTES``, or a drive file's).
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
        Whether a file sampled more coarsely than ``sampling_period`` is
        interpolated onto it (a reference drawn coarsely), or refused (a
        measured response, recorded at the drive's sampling period or faster:
        a coarser one is a time column in other units than seconds, or another
        rate); False also averages a file faster by an integer factor.
    notes : list of str, optional
        Receives the line saying how a file at another rate was resampled;
        without it the line is a ``UserWarning``.
    period : float, optional
        Period of a periodic file [s]: the samples past its last one continue
        from one period earlier (else they continue its last step).
    table : hammerstein.io.datafiles._Table, optional
        The file already parsed (:func:`read_table`): not read again.
    units : tuple of str, optional
        The model's ``(input unit, output unit)`` (``HammersteinPlant.units``):
        a units row or a column name (``x_nm``) that gives one of them is read
        as well as V and µm (a model identified in nm).

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
    if table is None:
        table = read_table(path, what, time)
    mapping = dict(mapping or {})

    allowed = tuple(dict.fromkeys(("V", "µm", *(units or ()))))

    def column(col, label, unit=allowed):
        return numeric_column(table, col, label, unit)

    t = column(time, "the time [s]", "s")
    if t.size < 2:
        raise DataFileError(f"{what}: {escape(path)}: {t.size} data row; expected at least two "
                            f"samples")
    _check_increasing(t, path, time, what)
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
    if t[0] > 1e-9 * max(1.0, abs(t[-1])) and t[0] > tol:   # after a gap's message: its cause
        raise DataFileError(f"{what}: {path}: starts at {t[0]:g} s; expected t = 0 first "
                            f"(subtract {t[0]:g} s from its time column: a record's time "
                            f"counts from its first sample)")
    if sampling_period is None:
        return t[0] + np.arange(t.size) * Tf, vals, Tf
    T = float(sampling_period)
    if uniform and abs(Tf - T) <= 1e-6 * T and abs(t[0]) <= tol:
        # sampled at T, its stamps rounded (a float32 logger's): the samples as they are,
        # not interpolated between stamps that are off their sampling times
        return np.arange(t.size) * T, vals, T
    if t[-1] < T:
        raise DataFileError(f"{what}: {escape(path)}: spans {t[-1]:g} s, less than one sampling "
                            f"period {T:g} s; is its time column {escape(repr(time), 60)} in "
                            f"seconds?")
    # the file's nominal period: the line through its first and last stamps (a jittered
    # record's median step is off it); its duration includes its last sample's period
    Tf = (t[-1] - t[0]) / (t.size - 1)
    n = check_samples(np.ceil((t[-1] + Tf) / T - 1e-6),
                      f"{what}: {escape(path)}: {t[-1]:g} s sampled at {T:g} s",
                      DataFileError, T, len(names) + 1)
    ratio = Tf / T
    where = f"{what}: {escape(path)}: sampled every {Tf:.6g} s"
    if not upsample and ratio > 1 + RATE_TOL:
        raise DataFileError(f"{where}, {ratio:.4g} sampling periods of {T:g} s: slower than "
                            f"the drive; expected a measurement at its period or faster by an "
                            f"integer factor (is its time column {escape(repr(time), 60)} in "
                            f"seconds? else record at the drive's rate)")
    m = int(round(1 / ratio))
    if not upsample and m >= 2 and abs(m * ratio - 1) <= RATE_TOL:
        _say(notes, f"{where}, {m} samples per sampling period of {T:g} s: averaged over each "
                    f"period (a block mean centred on the drive's samples, which lowers the "
                    f"noise)")
        return np.arange(n) * T, block_mean(t, vals, T, m, n), T
    if abs(ratio - 1) > RATE_TOL:
        if ratio > 1:
            more = (f" ({ratio:.3g} times coarser: corners at every sample of the file; write it "
                    f"at the sampling period {T:g} s to follow it smoothly)")
        else:
            more = (f"; --sampling-period {Tf:.6g} computes the drive at the file's rate"
                    if upsample else "")
        _say(notes, f"{where}, resampled (interpolated linearly) onto the sampling period "
                    f"{T:g} s{more}")
    grid = np.arange(n) * T
    past = grid > t[-1]
    if period is not None and 0 < period <= t[-1] + Tf * (1 + 1e-9):
        after = grid[past] - period     # periodic: past the last sample, one period earlier
    else:   # the last step continued for one of the file's periods (a stop would be a corner)
        after = None
    out = np.empty((len(names), n))
    for i, v in enumerate(vals):
        out[i, ~past] = np.interp(grid[~past], t, v)
        if after is not None:
            out[i, past] = np.interp(after, t, v)
        else:
            out[i, past] = v[-1] + (grid[past] - t[-1]) * (v[-1] - v[-2]) / (t[-1] - t[-2])
    return grid, out, T


def _say(notes, text):
    """``text`` appended to ``notes``, or a ``UserWarning`` without them."""
    if notes is None:
        warnings.warn(text, UserWarning, stacklevel=3)
    else:
        notes.append(text)


def block_mean(t, values, period, m, n):
    """Signals sampled ``m`` times per ``period``, averaged onto ``t_k = k period``.

    The columns are first put onto the exact fine grid ``period / m`` (linear
    interpolation: a jittered logger's stamps), then averaged over the
    samples within half a period of each ``t_k`` (``m`` of them for odd
    ``m``; ``m + 1`` with the two ends weighted one half for even ``m``), so
    the averaged signal is not delayed. The first samples average the half
    window after ``t = 0`` only.

    Parameters
    ----------
    t : numpy.ndarray, shape (n_rows,)
        Time stamps [s], from 0, increasing.
    values : numpy.ndarray, shape (n_signals, n_rows)
        The signals.
    period : float
        The coarse sampling period [s].
    m : int
        Samples per period, at least 2.
    n : int
        Coarse samples wanted.

    Returns
    -------
    numpy.ndarray, shape (n_signals, n)
        The block means.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(9) * 0.1
    >>> block_mean(t, np.arange(9.0)[None, :], 0.3, 3, 3)
    array([[0.5, 3. , 6. ]])
    """
    fine = np.arange(n * m) * (period / m)
    h = m // 2
    w = np.ones(2 * h + 1)
    if m % 2 == 0:
        w[0] = w[-1] = 0.5
    count = np.convolve(np.ones(fine.size), w, "same")
    out = np.empty((values.shape[0], n))
    for i, v in enumerate(values):
        mean = np.convolve(np.interp(fine, t, v), w, "same") / count
        out[i] = mean[::m][:n]
    return out


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
        prefixed with ``# hammerstein`` / ``#``; the last is the file's digest
        (:func:`hammerstein.compensation.drive_size.write_drive_rows`).

    Returns
    -------
    str

    Examples
    --------
    >>> print(signals_csv([0.0, 0.5], {"ux": [0.1, 1 / 3]}, "drive: t [s], ux [V]"), end="")
    # hammerstein drive: t [s], ux [V]
    # sha256 of this file without this line: 12cabb7a697338681a1430a5af08a64b320f0d74e736b317be321463cccf9018 (hammerstein replaces the file only while it matches)
    t,ux
    0,0.10000000000000001
    0.5,0.33333333333333331
    """
    buf = io.BytesIO()
    signals_writer(t, columns, comment)(buf)
    return buf.getvalue().decode("utf-8")


def signals_writer(t, columns, comment, cap=None):
    """The writer of :func:`signals_csv`'s text, for :func:`hammerstein.core.files.safe_write`.

    The same bytes as ``signals_csv(t, columns, comment).encode()``, written
    by blocks of rows (:func:`hammerstein.compensation.drive_size.write_drive_rows`):
    never the whole text at once; signed (``fh`` must be seekable).

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time [s] (column ``t``).
    columns : dict of str to array_like, each shape (n_samples,)
        Name -> values (V, µm), in column order.
    comment : str
        The comment lines' text, as :func:`signals_csv`.
    cap : int, optional
        Most bytes the file may take (e.g.
        :func:`hammerstein.compensation.drive_size.drive_file_limit`).

    Returns
    -------
    callable
        ``writer(fh)`` writing to a binary file object; it raises
        :class:`~hammerstein.exceptions.FileLimitError` when the text would
        take more than ``cap`` bytes.
    """
    lines = comment.splitlines() or [""]
    head = [f"{DRIVE_MARK} {lines[0]}".rstrip()] + [f"# {ln}".rstrip() for ln in lines[1:]]
    text = "\n".join(head + [",".join(["t", *columns])]) + "\n"
    data = np.column_stack([np.asarray(t, dtype=float)]
                           + [np.asarray(v, dtype=float) for v in columns.values()])
    return lambda fh: write_drive_rows(fh, text, data, cap, signed=True)


def fade_weight(s):
    """The weight of a drive's fade-in at ``s`` in [0, 1]: ``s^4 (35 - 84 s + 70 s^2 - 20 s^3)``.

    From 0 to 1 with value, slope, acceleration and jerk continuous at both
    ends: a raised cosine's jump in acceleration made the inverse of two
    bending modes ring at the fade's start and end (steps 9 times the
    settled drive's largest, on an outside actuator), which this one does
    not. :func:`hammerstein.compensation.drive.hardware_fade` fades a
    reference with it; a C caller computes the same weights with the same products,
    ``s2 = s * s``, ``(s2 * s2) * (35 - 84 * s + 70 * s2 - 20 * (s2 * s))``, in that
    order (as every C compiler does without contraction, ``-ffp-contract=off``).

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
    s2 = s * s      # products, in this order: a C caller repeats them bit for bit (not powers)
    return (s2 * s2) * (35.0 - 84.0 * s + 70.0 * s2 - 20.0 * (s2 * s))


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
    (the model's output at 0 V, where it faded the reference in from), in the
    model's output unit (``x = 12.5 nm`` for a model in nm): the values are read in it.

    Parameters
    ----------
    path : str or pathlib.Path
        A drive file of ``hammerstein compensate`` or ``learn``.
    outputs : list of str
        Output names.

    Returns
    -------
    numpy.ndarray, shape (len(outputs),), or None
        In the unit the header names (the model's output unit); None when the header does
        not give every output's.

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
    >>> with open(fh.name, "w") as out:
    ...     _ = out.write("# fade-in 4 samples from the rest output x = 12.5 nm (the model's "
    ...                   "output at 0 mV)\nt,ux\n0,0\n")
    >>> drive_rest_output(fh.name, ["x"]).tolist()
    [12.5]
    >>> os.remove(fh.name)
    """
    for line in _header(path):
        m = re.search(r"from the rest output (.*?)(?: \(|$)", line)
        if m:
            # in the model's output unit: µm, nm, ... (OUTPUT_UNIT_SCALES), or any the preset names
            values = dict(re.findall(r"(\S+) = ([-+0-9.eE]+|nan|inf) [^\s,;()]+", m.group(1)))
            try:
                return np.array([float(values[o]) for o in outputs])
            except (KeyError, ValueError):
                return None
    return None


#: A unit in a drive file's header: ``mV``, ``nm``, ``µm`` (no space, comma or bracket).
_UNIT = r"([^\s\[\](),;]{1,24})"

#: Where a drive file's header names its input unit: its first line (``compensate drive: t
#: [s]; ux, uy [mV]``, ``learn drive: ...``) or a best trial's (``... the drive [mV], ...``).
_INPUT_UNIT = (re.compile(r"\bdrive: t \[s\]; [^\[\];]*\[" + _UNIT + r"\]"),
               re.compile(r"\bthe drive \[" + _UNIT + r"\]"))

#: Where it names its output unit: the rest output's values (``from the rest output x = 1.2
#: nm, ...``), else the columns of an output it aims at or predicts (``x_learnt, y_learnt
#: [nm]``, ``x_shaped y_shaped [nm]``, ``x_predicted [nm]``), else a best trial's response.
_OUTPUT_UNIT = (re.compile(r"from the rest output \S+ = \S+ " + _UNIT),
                re.compile(r"\w_(?:shaped|learnt|predicted) \[" + _UNIT + r"\]"),
                re.compile(r"\bmeasured response \[" + _UNIT + r"\]"))


def drive_units(path):
    r"""The input and output units a drive file's header states, ``("V", "µm")`` where it does not.

    ``compensate`` and ``learn`` write the model's units (``identify --input-unit`` and
    ``--output-unit``) in the header: the inputs' after their names on the first line
    (``# hammerstein compensate drive: t [s]; ux, uy [mV]``), the outputs' after the rest
    output's values (``from the rest output x = 1.2 nm, ...``) or after the names of the
    output columns the drive holds (``x_learnt, y_learnt [nm]``). A file that is no drive,
    or a drive of an older header, is in the default units. Only the first 20 comment
    lines are read.

    Parameters
    ----------
    path : str or pathlib.Path
        A drive file of ``hammerstein compensate`` or ``learn``.

    Returns
    -------
    input_unit : str
        The inputs' (the drive's columns) unit, ``"V"`` when not stated.
    output_unit : str
        The outputs' unit, ``"µm"`` when not stated.

    Raises
    ------
    OSError
        The file cannot be read.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False,
    ...                                  encoding="utf-8") as fh:
    ...     _ = fh.write("# hammerstein compensate drive: t [s]; ux, uy [mV]\n# actuator m.toml, "
    ...                  "fade-in 4 samples (0.004 s) from the rest output x = 1.2 nm, "
    ...                  "y = 1.4 nm (the model's output at 0 mV)\nt,ux,uy\n0,0,0\n")
    >>> drive_units(fh.name)
    ('mV', 'nm')
    >>> with open(fh.name, "w", encoding="utf-8") as out:
    ...     _ = out.write("t,ux\n0,0\n")
    >>> drive_units(fh.name)
    ('V', 'µm')
    >>> os.remove(fh.name)
    """
    lines = _header(path)
    found = []
    for patterns, default in ((_INPUT_UNIT, "V"), (_OUTPUT_UNIT, "µm")):
        found.append(next((m.group(1) for pattern in patterns for line in lines
                           for m in [pattern.search(line)] if m), default))
    return found[0], found[1]


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


def optional_columns(path, names, sampling_period=None, what="file", table=None):
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
    table : hammerstein.io.datafiles._Table, optional
        The file already parsed (:func:`read_table`): its columns are looked
        up there and the file is not read again.

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
    columns = _header_columns(path) if table is None else list(table.frame.columns)
    if not all(n in columns for n in names):
        return None
    _, values, _ = read_signals(path, list(names), "t", None, sampling_period, what, table=table)
    return values


def drive_input_names(path, outputs):
    """The input columns of a drive file: every column but ``t`` and the outputs' own.

    A drive ``compensate`` or ``learn`` wrote holds ``t``, one column per input
    [V], and columns of the outputs it aims at or predicts (``<output>_shaped``,
    ``<output>_learnt``, ``<output>_predicted``; :data:`AIMED_SUFFIXES`), left
    out for every output, named in ``outputs`` or not.

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
    # an output's aimed or predicted column is none of the inputs, whether or not that output
    # is among ``outputs`` (a circle judged on x, y of a drive that also predicts a held z)
    return [c for c in columns if c != "t" and c not in outputs
            and not any(c.startswith(f"{o}_") for o in outputs)
            and not c.endswith(AIMED_SUFFIXES)]


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
