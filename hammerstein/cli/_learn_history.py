"""The files of a ``hammerstein learn --history DIR`` (behind :mod:`hammerstein.cli.learn`).

A history belongs to one learning: ``history.csv`` (each trial's max and
RMS error per output) and ``convergence.png``, ``settled.csv`` (each
trial's settled errors); the errors of both files are those of the
measurement advanced by the delay learn estimated (or was given), over the
window after the fade-in and the settling, and each row says so (columns
``delay_removed_samples`` and ``window_from_s``: ``hammerstein evaluate``
keeps the delay unless given ``--remove-delay``, so its figures are larger
for the same records), ``harmonics.csv`` (the per-harmonic gains),
``best-trial.csv`` (the best trial's drive, measured response and the
reference its drive was computed for) and ``learning.csv`` (the state: the
best trial, the gain halvings, the reference's fingerprint and samples of
the last drive written). Every file is written through
:func:`hammerstein.core.files.safe_write` under the directory's mark.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from hammerstein.compensation.drive import read_signals
from hammerstein.compensation.drive_files import learnt_names, optional_columns
from hammerstein.core.files import (TMP_SUFFIX, bounded_read_text, escape, file_digest,
                                    make_directory, safe_write)
from hammerstein.core._version import VERSION
from hammerstein.exceptions import DataFileError
from hammerstein.report.figures import save
from hammerstein.report.ilc_figure import convergence_figure


HISTORY_MARK = ".hammerstein-history"


def history_rows(history_dir):
    """The rows of ``DIR/history.csv``.

    Parameters
    ----------
    history_dir : str or pathlib.Path
        The ``--history`` directory.

    Returns
    -------
    list of tuple
        ``(iteration, output, max_error, rms_error)``, errors in the model's output unit; empty when
        there is no history yet.

    Raises
    ------
    DataFileError
        The file is not text or a line is not ``iteration,output,max,rms``
        (the message names the file and the line).
    FileLimitError
        Larger than the data file limit, or not a regular file.
    """
    path = Path(history_dir) / "history.csv"
    if not path.is_file():
        return []
    try:
        text = bounded_read_text(path, "data", "history file")
    except UnicodeDecodeError as exc:
        raise DataFileError(f"{escape(path)}: not UTF-8 text (byte {exc.start}); not a history "
                            f"written by hammerstein learn: choose a new --history directory") from None
    rows = []
    for n, line in enumerate(text.splitlines()[1:], start=2):
        if not line.strip():
            continue
        try:
            k, out, mx, rms = line.split(",")[:4]
            rows.append((int(k), out, float(mx), float(rms)))
        except ValueError:
            raise DataFileError(
                f"{escape(path)}: line {n}: '{escape(line, 60)}' is not 'iteration,output,"
                f"max_error,rms_error' (an integer, a name, two numbers); not a history written by "
                f"hammerstein learn: choose a new --history directory") from None
    return rows


def history_file_problem(out, history_dir):
    """Why the drive ``out`` may not be written with the history ``history_dir`` (one line), or None.

    The drive may not be one of the history's files (by resolved path, or
    the same file through a hard link): both are written together and one
    would silently replace the other.

    Parameters
    ----------
    out : str or pathlib.Path
        ``--out``.
    history_dir : str or pathlib.Path
        ``--history``.

    Returns
    -------
    str or None
        ``"--out: <out> is also an output of this command (...)"``.
    """
    real = os.path.realpath(out)
    for name in HISTORY_FILES:
        path = Path(history_dir) / name
        if os.path.realpath(path) == real or (os.path.exists(out) and os.path.exists(path)
                                               and os.path.samefile(out, path)):
            return (f"--out: {escape(out)} is also an output of this command (the history's "
                    f"{name} in --history {escape(history_dir)}); choose another name for the "
                    f"drive")
    return None


def foreign_history_problem(history, out=None):
    """Why ``--history DIR`` is not a history this command may write (one line), or None.

    A directory holding files (other than the drive ``out`` and its pending
    temporary) without the history's mark is someone else's. Checked before
    the learning runs, and again when the history is written.

    Parameters
    ----------
    history : str or pathlib.Path
        ``--history``.
    out : str or pathlib.Path, optional
        ``--out`` (the drive may be written into the history directory).

    Returns
    -------
    str or None
        ``"--history: DIR is a directory hammerstein did not make; ..."``.
    """
    d = Path(history)
    drive = os.path.realpath(out) if out is not None else None
    others = [p for p in d.iterdir() if not p.name.endswith(TMP_SUFFIX)   # the drive's, pending
              and os.path.realpath(p) != drive] if d.is_dir() else []    # the drive: ours
    if others and not (d / HISTORY_MARK).exists():
        return (f"--history: {escape(d)} is a directory hammerstein did not make; "
                f"choose an empty or new directory")
    changed = changed_history_files(d) if others else []
    if changed:
        more = f" and {len(changed) - 3} more" if len(changed) > 3 else ""
        return (f"--history: {', '.join(escape(d / n) for n in changed[:3])}{more}: changed or "
                f"deleted since hammerstein learn wrote {'it' if len(changed) == 1 else 'them'} (not "
                f"the SHA-256 its {HISTORY_MARK} keeps); nothing was written: move "
                f"{'it' if len(changed) == 1 else 'them'} away or restore "
                f"{'it' if len(changed) == 1 else 'them'}, or start a new history directory")
    return None


def history_unit_problem(history_dir, unit):
    """Why the errors of a model in ``unit`` may not be added to ``DIR/history.csv`` (one line), or None.

    A history's columns name the unit its errors are in (``max_error_um``); a model whose
    output unit is another (a preset relabelled from µm to nm) would add its errors to rows
    in another unit and relabel them.

    Parameters
    ----------
    history_dir : str or pathlib.Path
        ``--history``.
    unit : str
        The model's output unit.

    Returns
    -------
    str or None
        ``"--history: DIR/history.csv holds errors in um (max_error_um); ..."``.
    """
    path = Path(history_dir) / "history.csv"
    if not path.is_file():
        return None
    try:
        head = bounded_read_text(path, "data", "history file").split("\n", 1)[0].split(",")
    except (OSError, ValueError):
        return None                    # history_rows says what is wrong with the file
    if len(head) < 3 or not head[2].startswith("max_error_"):
        return None
    have = head[2].removeprefix("max_error_")
    if have == unit_suffix(unit):
        return None
    return (f"--history: {escape(path)} holds errors in {have} ({head[2]}), this model's "
            f"output unit is {unit}: a history belongs to one learning; choose a new --history "
            f"directory")


def _manifest(history_dir):
    """File name -> SHA-256 the history's mark lists, or None (an older mark: no digests)."""
    try:
        text = bounded_read_text(Path(history_dir) / HISTORY_MARK, "toml", "history mark")
    except (OSError, ValueError):
        return None
    listed = {}
    for line in text.splitlines():
        parts = line.split(" ", 2)
        if len(parts) == 3 and parts[0] == "sha256":
            listed[parts[2]] = parts[1]
    return listed or None


def changed_history_files(history_dir):
    """The history's files that are not what learn wrote (names, in :data:`HISTORY_FILES` order).

    The mark lists the SHA-256 of each file learn wrote (:func:`write_history_manifest`);
    a listed file whose bytes differ, or a history file the mark does not list, was changed
    or put there by someone else; a listed file deleted too. A mark without digests (an older
    version's, or one emptied by hand) lists nothing: no file is judged.

    Parameters
    ----------
    history_dir : str or pathlib.Path

    Returns
    -------
    list of str
    """
    d = Path(history_dir)
    listed = _manifest(d)
    if listed is None:
        return []
    changed = []
    for name in HISTORY_FILES[1:]:
        p = d / name
        if not os.path.lexists(p):
            if name in listed:          # deleted: the history would restart half
                changed.append(name)
            continue
        if p.is_symlink() or not p.is_file() or file_digest(p) != listed.get(name):
            changed.append(name)
    return changed


def write_history_manifest(history_dir):
    """Rewrite the history's mark with the SHA-256 of each of its files (after a trial's writes).

    Parameters
    ----------
    history_dir : str or pathlib.Path
    """
    d = Path(history_dir)
    lines = [f"hammerstein learn {VERSION}: the files of this history and their SHA-256 (a file "
             f"changed since is never replaced)"]
    for name in HISTORY_FILES[1:]:
        p = d / name
        if p.is_file() and not p.is_symlink():
            lines.append(f"sha256 {file_digest(p)} {name}")
    safe_write(d / HISTORY_MARK, "\n".join(lines) + "\n", "history mark", root=d)


def _settled_series(history_dir, trials, now=None):
    """Settled max Euclidean and judged errors per trial [µm] from ``settled.csv`` (NaN if none).

    ``now``: ``(trial, settled max, judged)`` of the trial being written (its
    row is written after the figure).
    """
    found = {}
    path = Path(history_dir) / SETTLED_FILE
    if path.is_file():
        try:
            text = bounded_read_text(path, "data", "settled errors file")
        except (OSError, ValueError):
            text = ""
        for line in text.splitlines()[1:]:
            cells = line.split(",")
            try:
                found[int(cells[0])] = (float(cells[1]), float(cells[3]))
            except (IndexError, ValueError):
                continue
    if now is not None:
        found[int(now[0])] = (float(now[1]), float(now[2]))
    euclid = np.array([found.get(t, (np.nan, np.nan))[0] for t in trials])
    judged = np.array([found.get(t, (np.nan, np.nan))[1] for t in trials])
    return euclid, judged


def unit_suffix(unit):
    """A column name's suffix for ``unit``: ``"µm"`` -> ``"um"``, ``"nm"`` -> ``"nm"``.

    Parameters
    ----------
    unit : str
        The model's output unit (``HammersteinPlant.units[1]``).

    Returns
    -------
    str
        ``unit`` with the micro sign written ``u`` and every character but an ASCII
        letter or digit written ``_`` (``"um"`` for an empty unit).
    """
    text = str(unit).replace("µ", "u").replace("μ", "u")
    text = "".join(c if c.isascii() and c.isalnum() else "_" for c in text)
    return text or "um"


def history_head(unit="µm"):
    """The header of ``history.csv``: the trial's errors per output in ``unit``, then how they
    were measured (the measurement advanced by ``delay_removed_samples``, the window from
    ``window_from_s``); ``max_error_um`` for µm, ``max_error_nm`` for nm (readers index the
    columns)."""
    u = unit_suffix(unit)
    return f"iteration,output,max_error_{u},rms_error_{u},delay_removed_samples,window_from_s\n"


def settled_head(unit="µm"):
    """The header of ``settled.csv`` (the first four as in the earliest files; readers index
    them), its errors in ``unit``."""
    u = unit_suffix(unit)
    return (f"trial,settled_max_euclidean_{u},settled_rms_euclidean_{u},judged_{u},"
            f"delay_removed_samples,window_from_s\n")


#: ``settled.csv``'s columns in its earliest files (no ``delay_removed_samples``, ``window_from_s``)
SETTLED_OLD_COLUMNS = 4


def _aligned_cells(aligned):
    """``delay_removed_samples,window_from_s`` cells of a row (empty when not known)."""
    if aligned is None:
        return ","
    delay, start = aligned
    return f"{int(delay)},{float(start)!r}"


def _history_extras(history_dir):
    """``iteration -> "delay,window"`` cells of the rows already in ``history.csv``."""
    path = Path(history_dir) / "history.csv"
    if not path.is_file():
        return {}
    extras = {}
    for line in bounded_read_text(path, "data", "history file").splitlines()[1:]:
        cells = line.split(",")
        if len(cells) >= 6:
            extras[(cells[0], cells[1])] = ",".join(cells[4:6])
    return extras


def _write_history(history, names, rec, scale, scale_name="radius / amplitude", out=None,
                   settled=None, aligned=None, unit="µm"):
    """Append a trial to ``history.csv`` and redraw ``convergence.png``; the trial number.

    ``aligned``: ``(delay [samples], window start [s])``: the trial's errors are those of
    the measurement advanced by that delay over the window from that time (written in
    each row and in the figure's title); ``unit``: the model's output unit, the figure's
    axis label's and the columns' (``max_error_um`` for µm, ``max_error_nm`` for nm).
    """
    d = Path(history)
    problem = foreign_history_problem(d, out)
    if problem:
        raise DataFileError(problem)
    make_directory(d, "--history")
    if not (d / HISTORY_MARK).exists():
        safe_write(d / HISTORY_MARK, "", "history mark", root=d)
    rows = history_rows(d)
    extras = _history_extras(d)
    k = 1 + max((r[0] for r in rows), default=-1)
    rows += [(k, n, float(rec.max_error[i]), float(rec.rms_error[i])) for i, n in enumerate(names)]
    extras.update({(str(k), n): _aligned_cells(aligned) for n in names})
    text = history_head(unit) + "".join(
        f"{a},{b},{c!r},{e!r},{extras.get((str(a), b), ',')}\n" for a, b, c, e in rows)
    safe_write(d / "history.csv", text, "history file", root=d)
    its = sorted({r[0] for r in rows})
    mx = np.array([[next(r[2] for r in rows if r[0] == i and r[1] == n) for i in its] for n in names])
    rms = np.array([[next(r[3] for r in rows if r[0] == i and r[1] == n) for i in its] for n in names])
    euclid, judged = _settled_series(d, its, None if settled is None else (k, *settled))
    title = "iterative learning control (hammerstein learn): tracking error per trial"
    if aligned is not None:
        title += (f" (measurement advanced by its delay of {int(aligned[0])} samples; "
                  f"window from t = {aligned[1]:.4g} s)")
    fig = convergence_figure(its, mx, rms, names, title, scale, scale_name, euclid, judged,
                             unit)
    safe_write(d / "convergence.png", lambda fh: save(fig, fh), "convergence figure", root=d)
    return k


GAINS_FILE = "harmonics.csv"


SETTLED_FILE = "settled.csv"


BEST_FILE = "best-trial.csv"


STATE_FILE = "learning.csv"


#: Every file a history directory holds (``--out`` may be none of them).
HISTORY_FILES = (HISTORY_MARK, "history.csv", "convergence.png", SETTLED_FILE, GAINS_FILE,
                 BEST_FILE, STATE_FILE)


#: samples of the last drive kept in the state file, per input (the --drive check)
DRIVE_SAMPLES = 256


#: a --drive matches a drive of the history within this fraction of that drive's span per
#: input (a drive re-written by the acquisition, or quantised by a 16-bit converter, passes)
DRIVE_TOLERANCE = 1e-3


def _settled_rows(history_dir, trial, settled_max, settled_rms, score, margin, aligned=None,
                  unit="µm"):
    """Append a trial's settled errors to ``DIR/settled.csv``; the previous trial's if it was lower.

    ``aligned``: ``(delay [samples], window start [s])`` of the errors (columns
    ``delay_removed_samples`` and ``window_from_s``; a file of the four first
    columns gets them, empty on its rows); ``unit``: the errors' (the columns' names).

    Returns
    -------
    tuple or None
        ``(trial, judged error [µm])`` of the previous trial when this
        trial's judged error exceeds it by more than ``margin`` (the noise),
        else None.
    """
    path = Path(history_dir) / SETTLED_FILE
    head = settled_head(unit)
    text = bounded_read_text(path, "data", "settled errors file") if path.is_file() else head
    lines = text.splitlines()
    old = bool(lines) and lines[0].count(",") + 1 == SETTLED_OLD_COLUMNS
    # the header written again in this unit (the rows' own); an earliest file's rows get
    # the two last cells, empty
    text = head + "".join(f"{line},,\n" if old else f"{line}\n" for line in lines[1:]
                          if line.strip())
    rows = [line.split(",") for line in text.splitlines()[1:] if line.strip()]
    prev = None
    if rows:
        try:
            prev = (int(rows[-1][0]), float(rows[-1][3]))
        except (IndexError, ValueError):
            prev = None
    text = text + (f"{trial},{settled_max!r},{settled_rms!r},{float(score)!r},"
                   f"{_aligned_cells(aligned)}\n")
    safe_write(path, text, "settled errors file")
    return prev if prev is not None and score > prev[1] + margin else None


def _read_state(history_dir, n_samples):
    """``{trial, score, halvings, rejections, lag_offset, ...}`` of ``DIR/learning.csv``, or None.

    ``rejections``: the trials not learnt from in a row (0 in an older file);
    ``lag_offset``: the lag of the last trial learnt from less its delay (None
    when not known).

    None when the directory is not one ``learn`` made, has no state yet, or
    holds the state of a record of another length (another reference).
    """
    d = Path(history_dir)
    path = d / STATE_FILE
    if not path.is_file() or not (d / HISTORY_MARK).exists() or not (d / BEST_FILE).is_file():
        return None
    values = {}
    try:
        text = bounded_read_text(path, "data", "learning state file")
    except UnicodeDecodeError as exc:
        raise DataFileError(f"--history: {escape(path)}: not UTF-8 text (byte {exc.start}); not a "
                            f"learning state file written by hammerstein learn: choose a new "
                            f"--history directory") from None
    for line in text.splitlines()[1:]:
        if "," in line:
            key, value = line.split(",", 1)
            values[key.strip()] = value.strip()
    try:
        score = next(v for k, v in values.items() if k.startswith("best_score_"))
        state = {"trial": int(values["best_trial"]), "score": float(score),
                 "halvings": int(values["halvings"]), "samples": int(values["samples"]),
                 "reference": values.get("reference_sha256"),
                 "written_by": values.get("written_by"),
                 "rejections": int(values.get("rejections", 0)),
                 "lag_offset": (None if values.get("lag_offset") is None else
                                int(values["lag_offset"])),
                 "drive": (None if values.get("last_drive") is None else
                           np.array(values["last_drive"].split(), float))}
    except (KeyError, ValueError, StopIteration):
        raise DataFileError(f"--history: {path} is not a learning state file written by "
                            f"hammerstein learn; choose a new --history directory") from None
    return state if state["samples"] == n_samples else None


def _fingerprint(target):
    """SHA-256 of the faded reference [µm] (float64, C order): which learning a history is."""
    return hashlib.sha256(np.ascontiguousarray(target, dtype=np.float64).tobytes()).hexdigest()


def _drive_samples(u):
    """The samples of a drive (m, N) the state keeps: ``DRIVE_SAMPLES`` per input, flat."""
    idx = np.linspace(0, u.shape[1] - 1, min(DRIVE_SAMPLES, u.shape[1])).round().astype(int)
    return np.asarray(u, float)[:, idx].ravel(), idx


def _same_drive(u, kept):
    """True when the samples ``kept`` (as :func:`_drive_samples`) are those of the drive u."""
    mine, _ = _drive_samples(u)
    if kept is None or kept.size != mine.size:
        return False
    m = u.shape[0]
    a, b = mine.reshape(m, -1), kept.reshape(m, -1)
    span = np.ptp(b, axis=1) + 1e-9
    return bool(np.all(np.max(np.abs(a - b), axis=1) <= DRIVE_TOLERANCE * span))


def _check_history(history_dir, state, fingerprint, u, best_u, y=None, no_fade=False):
    """Refuse a trial that does not belong to the history's learning (a DataFileError).

    ``fingerprint`` is the faded reference's (:func:`_fingerprint`); ``best_u`` is called
    for the best trial's drive (m, N) [V] and measured response (p, N) [µm] when the last
    drive differs.

    The reference (faded as the drive was) must have the history's fingerprint, and the
    applied drive must be the last one written or the best trial's re-measured: the best
    trial's own measurement ``y`` again (the same files given twice, e.g. after a run that
    said ``interrupted`` once everything was written) would be learnt twice. ``no_fade``: the
    drive file records no fade-in (the reason a fingerprint differs, named first).

    Returns True when ``u`` is the best trial's drive (a re-measurement of it), ``"replayed"``
    when it is that drive and not the one written last, else False.
    """
    if state is None:
        return False
    d = Path(history_dir)
    if state["reference"] is not None and state["reference"] != fingerprint and no_fade:
        raise DataFileError(f"--drive: records no fade-in (its header lacks 'fade-in N "
                            f"samples', as a {BEST_FILE} older than this version does): give the "
                            f"drive file compensate or learn wrote, or --fade-in S")
    if state["reference"] is not None and state["reference"] != fingerprint \
            and state.get("written_by") != VERSION:
        by = state.get("written_by")
        by = f"hammerstein {by}" if by else "an earlier version of hammerstein"
        raise DataFileError(f"--history: {d} was written by {by}, not {VERSION}: its "
                            f"reference, faded and shaped as that version did, is not this "
                            f"version's ({STATE_FILE}); choose a new --history directory (to go "
                            f"on from its best trial, give that trial's drive file as --drive and "
                            f"its measurement as --measured)")
    if state["reference"] is not None and state["reference"] != fingerprint:
        raise DataFileError(f"--history: {d} holds the trials of another reference or fade-in "
                            f"({STATE_FILE}); choose a new --history directory for this one")
    best_u, best_y = best_u()
    is_best = best_u is not None and _same_drive(u, _drive_samples(best_u)[0])
    if is_best and y is not None and best_y is not None and np.shape(y) == np.shape(best_y) \
            and np.allclose(y, best_y, rtol=1e-12, atol=1e-12):
        raise DataFileError(f"--measured: the best trial of {d} already holds this drive and "
                            f"this measurement: learnt once, its next drive is the last one {d} "
                            f"wrote; apply that one (or measure this drive again)")
    last = state["drive"] is None or _same_drive(u, state["drive"])
    if last or is_best:
        return "replayed" if is_best and not last else bool(is_best)
    raise DataFileError(f"--drive: not the drive the last trial of {d} wrote, nor its best "
                        f"trial's ({BEST_FILE}): this history belongs to another learning (another "
                        f"actuator, identification or first drive); choose a new --history "
                        f"directory, or apply the last drive written")


def _write_state(history_dir, state, unit="µm"):
    """Write ``DIR/learning.csv`` (the best trial's score in ``unit``: ``best_score_um``)."""
    text = "key,value\n" + "".join(f"{k},{state[v]!r}\n" for k, v in (
        ("best_trial", "trial"), (f"best_score_{unit_suffix(unit)}", "score"), ("halvings", "halvings"),
        ("samples", "samples"), ("rejections", "rejections")))
    if state.get("lag_offset") is not None:
        text += f"lag_offset,{int(state['lag_offset'])}\n"
    text += f"reference_sha256,{state['reference']}\n"
    text += f"written_by,{VERSION}\n"
    text += "last_drive," + " ".join(repr(float(v)) for v in state["drive"]) + "\n"
    safe_write(Path(history_dir) / STATE_FILE, text, "learning state file", root=history_dir)


def _read_best(history_dir, model, u_shape, y_shape, n_samples):
    """The best trial's drive, measured response and learnt reference (``DIR/best-trial.csv``).

    The learnt reference (``<output>_learnt`` columns, the reference the drive was computed
    for) is None in a file without them.
    """
    path = Path(history_dir) / BEST_FILE
    _, bu, _ = read_signals(path, list(model.input_names), "t", None, None, "--history best trial")
    _, by, _ = read_signals(path, list(model.output_names), "t", None, None, "--history best trial")
    if bu.shape != u_shape or by.shape != y_shape:
        raise DataFileError(f"--history: {BEST_FILE} does not match the drive's "
                            f"{n_samples} samples; choose a new --history directory")
    bf = optional_columns(path, learnt_names(model.output_names), None, "--history best trial")
    return bu, by, (bf if bf is not None and bf.shape == y_shape else None)


def _restore_gains(history_dir, gains):
    """The per-harmonic gains of the previous trials (``DIR/harmonics.csv``), when they match."""
    path = Path(history_dir) / GAINS_FILE
    if not path.is_file() or not (Path(history_dir) / HISTORY_MARK).exists():
        return
    problem = (f"--history: {escape(path)}: not the per-harmonic gains hammerstein learn writes "
               f"('harmonic,gain,previous_error,growths,converged'); choose a new --history "
               f"directory")
    try:
        text = bounded_read_text(path, "data", "harmonics file")
    except UnicodeDecodeError:
        raise DataFileError(problem) from None
    rows = [line.split(",") for line in text.splitlines()[1:] if line.strip()]
    if len(rows) != gains.base.size:
        return                          # another reference: start afresh
    try:
        table = np.array([[float(v) for v in r[1:4]] for r in rows])
    except ValueError:
        raise DataFileError(problem) from None
    if table.shape != (len(rows), 3):             # a row of fewer cells
        raise DataFileError(problem)
    gains.gains = table[:, 0].copy()
    gains.previous = table[:, 1].copy()
    gains.growths = table[:, 2].astype(int)
    gains.converged = any(len(r) > 4 and r[4].strip() == "1" for r in rows)   # older files: 4 columns


def _save_gains(history_dir, gains, unit="µm"):
    """Write ``DIR/harmonics.csv`` (the previous errors in ``unit``: ``previous_error_um``)."""
    prev = gains.previous if gains.previous is not None else np.zeros(gains.gains.shape)
    growths = getattr(gains, "growths", np.zeros(gains.gains.shape, dtype=int))
    done = int(bool(gains.converged))
    text = f"harmonic,gain,previous_error_{unit_suffix(unit)},growths,converged\n" + "".join(
        f"{h},{float(g)!r},{float(e)!r},{int(n)},{done}\n"
        for h, (g, e, n) in enumerate(zip(gains.gains, prev, growths)))
    safe_write(Path(history_dir) / GAINS_FILE, text, "harmonics file", root=history_dir)

