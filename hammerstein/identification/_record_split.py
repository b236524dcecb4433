"""Records split for identification: periods, held-out levels, windows and their errors.

The private half of :mod:`hammerstein.identification.record_identification`
(which re-exports the public names): a record cut at its input's reversal
points into branches and amplitude levels (:func:`split_record`), the
training / held-out / burn-in samples of each (:class:`Split`), the records
checked, the model simulated on a split record and its errors per window and
per amplitude level, the noise level of a smooth record and the point-symmetry
defect of a measured loop.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.ndimage import uniform_filter1d

from hammerstein.core.numbers import check_array, is_number
from hammerstein.io.datafiles import MIN_SAMPLES, MultiRecord, Record
from hammerstein.identification.identification import IdentificationError
from hammerstein.identification._split_kernels import reversal_kernel

#: a single closed loop fitted by least squares: blocks per branch, every third held out
HOLD_OUT_BLOCKS = 30


#: A reversal is recognised once the input has come back by this fraction of its span.
REVERSAL_BAND = 0.05
#: A complete branch travels at least this fraction of the input span.
COMPLETE_TRAVEL = 0.9


# -- splitting -----------------------------------------------------------------------
def reversal_points(u, band=REVERSAL_BAND):
    """Sample indices where the input reverses (local extrema beyond a dead band).

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        Input record.
    band : float
        The input must come back from an extremum by ``band`` times its span
        (peak to peak) for the extremum to count (rejects noise wiggles).

    Returns
    -------
    list of int
        Indices of the extrema, increasing; the first and last samples are
        not included.

    Notes
    -----
    One pass of a compiled loop (:mod:`hammerstein.identification._split_kernels`).
    """
    u = np.ascontiguousarray(u, dtype=float)
    span = float(np.ptp(u)) if u.size else 0.0
    if not span > 0:
        return []
    return [int(i) for i in reversal_kernel(u, band * span)]


@dataclass
class Split:
    """How one record is used: training, held-out and burn-in samples.

    Parameters
    ----------
    train : numpy.ndarray of bool, shape (n_samples,)
        Samples fitted (after the burn-in, outside the held-out part).
    held_out : numpy.ndarray of bool, shape (n_samples,)
        Samples held out for validation (all False without validation).
    burn_in : int
        Samples before this index only warm up the play states.
    periodic : bool
        The play states start on the steady loop (a closed loop record) rather
        than at zero.
    roll : int
        The record was rotated to start at its original sample ``roll`` (a
        closed loop starting elsewhere than at a reversal); 0 otherwise.
    branches : list of (int, int, bool)
        ``(start, stop, complete)`` of every branch between reversals.
    excitation : int
        Index of the input the record is split on.
    description : str
        One sentence saying what was held out.
    levels : list of dict
        Amplitude levels of a multi-amplitude record (:func:`amplitude_levels`):
        ``start``, ``stop`` (samples), ``amplitude`` (input unit),
        ``percent`` (of the largest) and ``held_out``; empty otherwise.
    """

    train: np.ndarray
    held_out: np.ndarray
    burn_in: int
    periodic: bool
    roll: int
    branches: list
    excitation: int
    description: str
    levels: list = field(default_factory=list)

    def ascending(self, u):
        """Complete ascending branches of the training samples, (start, stop).

        The reversal sample ``stop`` may be the first held-out sample (two
        branches share their reversal).

        Parameters
        ----------
        u : array_like, shape (n_samples,)
            The excitation input of the record (row ``excitation`` of its
            inputs, input unit, e.g. [V]).

        Returns
        -------
        list of (int, int)
            ``(start, stop)`` sample indices of every complete branch along
            which ``u`` rises and whose samples ``start:stop`` are all
            training samples.
        """
        return [(a, b) for a, b, ok in self.branches
                if ok and u[b] > u[a] and self.train[a:b].all()]


def _branches(u):
    span = float(np.ptp(u))
    bounds = [0] + reversal_points(u) + [u.size - 1]
    return [(a, b, bool(abs(u[b] - u[a]) >= COMPLETE_TRAVEL * span))
            for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


#: Branches whose end amplitudes differ by at most this fraction of the larger one form one
#: level (10 %: levels 20 % of the amplitude apart stay apart, down to the smallest)...
LEVEL_TOLERANCE = 0.1
#: ... or by at most this fraction of the input span (the turning points' jitter of a measured
#: input).
LEVEL_FLOOR = 0.01


def amplitude_levels(u, branches=None):
    """Amplitude levels of a record: runs of branches turning at the same amplitude.

    A decreasing-amplitude sine (:func:`hammerstein.signals.excitation.decreasing_sine`)
    has one level per amplitude: the branches that end at the same distance
    from the centre of the input span, within :data:`LEVEL_TOLERANCE` of the
    larger of the two amplitudes or :data:`LEVEL_FLOOR` of the span, whichever
    is larger: a 1.2 V and a 0.6 V level of a 20 V span are two levels. Runs of
    fewer than three branches (less than a loop) are not levels.

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        The excitation input [input unit].
    branches : list of (int, int, bool), optional
        Branches between reversal points (computed when None).

    Returns
    -------
    list of dict
        ``start``, ``stop`` (sample indices, the level is ``start:stop + 1``),
        ``amplitude`` (input unit, from the centre of the span) and
        ``percent`` of the largest level, in record order.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(4000) / 1000
    >>> u = np.sin(2 * np.pi * t) * np.where(t < 2, 10.0, 4.0)
    >>> [round(lv["percent"]) for lv in amplitude_levels(u)]
    [100, 40]
    """
    u = np.asarray(u, dtype=float)
    if branches is None:
        branches = _branches(u)
    span = float(np.ptp(u))
    if not span > 0:
        return []
    centre = 0.5 * (u.max() + u.min())
    runs = []
    for a, b, _ in branches:
        amp = abs(u[b] - centre)
        if runs and abs(runs[-1]["amplitude"] - amp) <= max(
                LEVEL_TOLERANCE * max(runs[-1]["amplitude"], amp), LEVEL_FLOOR * span):
            runs[-1]["stop"] = b
            runs[-1]["n"] += 1
            runs[-1]["amplitude"] = max(runs[-1]["amplitude"], amp)
        else:
            runs.append({"start": a, "stop": b, "amplitude": amp, "n": 1})
    levels = [r for r in runs if r["n"] >= 3]
    top = max((r["amplitude"] for r in levels), default=0.0)
    return [{"start": int(r["start"]), "stop": int(r["stop"]), "amplitude": float(r["amplitude"]),
             "percent": 100.0 * r["amplitude"] / top} for r in levels]


def _closed_loop(u, y):
    """True when the record is one closed loop (ends where it started)."""
    su, sy = np.ptp(u), np.ptp(y, axis=-1)
    return bool(abs(u[-1] - u[0]) <= 0.05 * su
                and np.all(np.abs(y[..., -1] - y[..., 0]) <= 0.1 * np.where(sy > 0, sy, 1.0)))


def _excitation(record):
    spans = np.ptp(record.u, axis=1)
    return int(np.argmax(spans))


def split_record(record, method="least-squares", hold_out="auto", train_fraction=None,
                 burn_in_seconds=None):
    """Split a record into burn-in, training and held-out samples by periods.

    Parameters
    ----------
    record : MultiRecord
    method : {"least-squares", "closed-form"}
        The closed form needs a complete ascending branch in the training part.
    hold_out : {"auto", "none"}
        ``"auto"``: hold out trailing complete branches (see the module
        notes); ``"none"``: train on the whole record, no validation.
    train_fraction : float, optional
        Split instead at the reversal point nearest to this fraction of the
        samples (the held-out part still starts at a reversal).
    burn_in_seconds : float, optional
        Burn-in [s] instead of "up to the first complete branch".

    Returns
    -------
    (MultiRecord, Split)
        The record (rotated when it is a closed loop that did not start at a
        reversal) and its split.

    Raises
    ------
    IdentificationError
        If the excitation is constant, the record holds no complete branch,
        or too few branches to hold one out; the message names the option
        that helps (``--hold-out none``, ``--train-fraction``, a longer
        record).
    """
    k = _excitation(record)
    u = record.u[k]
    name = f"{record.source}: " if record.source else ""
    if not np.ptp(u) > 0:
        what = "the input is" if record.u.shape[0] == 1 else "all inputs are"
        raise IdentificationError(f"{name}{what} constant; expected an excitation")
    branches = _branches(u)
    complete = [i for i, br in enumerate(branches) if br[2]]
    roll, periodic = 0, False
    if len(complete) <= 2 and _closed_loop(u, record.y):
        roll = int(np.argmin(u))
        if roll:
            record = replace(record, u=np.roll(record.u, -roll, axis=1),
                             y=np.roll(record.y, -roll, axis=1))
            u = record.u[k]
            branches = _branches(u)
            complete = [i for i, br in enumerate(branches) if br[2]]
        periodic = True
    n = u.size
    if not complete:
        raise IdentificationError(
            f"{name}no complete branch (the input never travels from one extremum to the "
            f"other); record at least one full period of the excitation")
    held = np.zeros(n, dtype=bool)
    if train_fraction is not None:
        if not 0 < train_fraction <= 1:
            raise IdentificationError(f"train_fraction: expected in (0, 1], found {train_fraction}")
        cuts = [a for a, _, _ in branches[1:]]
        if train_fraction < 1:
            if not cuts:
                raise IdentificationError(f"{name}no reversal point to split at; use --hold-out "
                                          f"none (hold_out = \"none\" in a scenario)")
            s = min(cuts, key=lambda c: abs(c - train_fraction * n))
            held[s:] = True
    elif hold_out == "auto" and len(levels := amplitude_levels(u, branches)) >= 3:
        # a multi-amplitude record: hold out every second level (whole minor loops not
        # trained on), the largest level always trains
        for i, lv in enumerate(levels):
            lv["held_out"] = i % 2 == 1
            if lv["held_out"]:
                held[lv["start"]:lv["stop"] + 1] = True
    elif hold_out == "auto":
        c = len(complete)
        if c >= 3:
            h = 2 * max(1, int(round(c / 6)))
            while c - h < 2 and h > 1:
                h -= 1
            held[branches[complete[-h]][0]:] = True
        elif c == 2 and periodic and method != "closed-form":
            # one closed loop, least squares: both branches train (their turning points
            # set the play memory, and a loop that is not point-symmetric cannot be told
            # from one branch); every third of HOLD_OUT_BLOCKS blocks of each branch is
            # held out and predicted, so every threshold's breakpoint has training
            # samples next to it
            for i in complete:
                a, b, _ = branches[i]
                edges = np.linspace(a, b + 1, HOLD_OUT_BLOCKS + 1).astype(int)
                for j in range(1, HOLD_OUT_BLOCKS, 3):
                    held[edges[j]:edges[j + 1]] = True
        elif c == 2:
            held[branches[complete[-1]][0]:] = True
        elif len(branches) >= 6:           # broadband: no full-span branch, split at a reversal
            cuts = [a for a, _, _ in branches[1:]]
            held[min(cuts, key=lambda c: abs(c - 0.7 * n)):] = True
        else:
            raise IdentificationError(
                f"{name}only one complete branch, nothing to hold out for validation; record "
                f"at least one full period (or a closed loop), or train on all of it with "
                f"--hold-out none (hold_out = \"none\" in a scenario)")
    elif hold_out != "none":
        raise IdentificationError(f"hold_out: expected 'auto' or 'none', found {hold_out!r}")
    if method == "closed-form" and hold_out == "auto" and train_fraction is None:
        split = _train_mask(record, k, branches, complete, held, periodic, burn_in_seconds)
        if not split.ascending(u):        # hold out the first complete branch instead
            a, b, _ = branches[complete[0]]
            held[:] = False
            held[a:b + 1] = True
            if not held.any() or len(complete) < 2:
                raise IdentificationError(
                    f"{name}no complete ascending branch left for the closed form; use "
                    f"--method least-squares")
    split = _train_mask(record, k, branches, complete, held, periodic, burn_in_seconds)
    if hold_out == "auto" and train_fraction is None and len(levels := amplitude_levels(u, branches)) >= 3:
        for i, lv in enumerate(levels):
            lv["held_out"] = bool(held[lv["start"]:lv["stop"] + 1].all())
        split.levels = levels
        held_txt = ", ".join(f"{lv['percent']:.0f} %" for lv in levels if lv["held_out"])
        train_txt = ", ".join(f"{lv['percent']:.0f} %" for lv in levels if not lv["held_out"])
        rest = split.description.partition(";")[2]
        split.description = (f"held out whole amplitude levels {held_txt} of the largest (minor "
                             f"loops not trained on; trained on {train_txt})"
                             + (";" + rest if rest else ""))
    if not split.train.any():
        raise IdentificationError(
            f"{name}no training samples left after the burn-in; shorten the held-out part "
            f"(--train-fraction) or the burn-in (--skip)")
    if method == "closed-form" and not split.ascending(u):
        raise IdentificationError(
            f"{name}no complete ascending branch (minimum followed by the maximum) in the "
            f"training part; record at least one full period, or use --method least-squares")
    return record, split


def _one_branch_held_mask(held):
    """True when a held-out mask is one contiguous block (a whole branch of a closed loop)."""
    return np.count_nonzero(np.diff(held.astype(np.int8))) <= 2


def _one_branch_held(split):
    """True when a closed loop's held-out part is one contiguous block (a whole branch)."""
    return _one_branch_held_mask(split.held_out)


def _train_mask(record, k, branches, complete, held, periodic, burn_in_seconds):
    u = record.u[k]
    n = u.size
    if burn_in_seconds is not None:
        ratio = burn_in_seconds / record.sampling_period  # inf for a huge --skip
        burn = int(round(ratio)) if np.isfinite(ratio) and abs(ratio) < n else n
        if not 0 <= burn < n - 1:
            source = getattr(record, "source", "")
            where = f"{source}: " if source else ""      # the record, as every other error names it
            raise IdentificationError(
                f"{where}skip (identify --skip): expected a burn-in shorter than the record "
                f"({n * record.sampling_period:g} s), found {burn_in_seconds:g} s")
    else:
        burn = 0 if periodic else branches[complete[0]][0]
    train = ~held
    train[:burn] = False
    T = record.sampling_period
    if held.any() and periodic and not _one_branch_held_mask(held):
        idx = np.flatnonzero(held)
        parts = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
        desc = (f"held out {idx.size} samples in {len(parts)} blocks, every third block of "
                f"each branch of the closed loop ({parts[0][0]}..{parts[0][-1]}, ...); both "
                f"branches and their turning points train")
    elif held.any():
        idx = np.flatnonzero(held)
        n_br = sum(1 for a, b, ok in branches if ok and held[a:b + 1].all())
        what = (f"{n_br} complete branch{'es' if n_br != 1 else ''}"
                + (f" ({n_br // 2} period{'s' if n_br // 2 != 1 else ''})" if n_br >= 2 else ""))
        desc = (f"held out samples {idx[0]}..{idx[-1]} (t = {idx[0] * T:.4g} to {idx[-1] * T:.4g} s,"
                f" {what})")
    else:
        desc = "nothing held out (trained on the whole record)"
    if burn:
        desc += f"; samples 0..{burn - 1} only warm up the play states"
    if periodic:
        desc += "; one closed loop: play states start on the steady loop"
    return Split(train, held, burn, periodic, 0, branches, k, desc)


def _checked_record(rec, i):
    """``rec`` with finite real float arrays of matching lengths and a valid sampling period."""
    where = f"records[{i}]" + (f" ({rec.source})" if getattr(rec, "source", "") else "")
    u = check_array(rec.u, f"{where}.u", IdentificationError, ndim=2)
    y = check_array(rec.y, f"{where}.y", IdentificationError, ndim=2, length=u.shape[1])
    t = check_array(rec.timepts, f"{where}.timepts", IdentificationError, ndim=1,
                    length=u.shape[1])
    if u.shape[1] < MIN_SAMPLES:
        raise IdentificationError(f"{where}: {u.shape[1]} samples; expected a record of at least "
                                  f"{MIN_SAMPLES} samples")
    T = rec.sampling_period
    if not (is_number(T) and T > 0):
        raise IdentificationError(f"{where}.sampling_period: expected a positive finite time [s], "
                                  f"found {T!r}")
    return replace(rec, u=u, y=y, timepts=t, sampling_period=float(T))


def _as_records(records):
    out = []
    for rec in ([records] if isinstance(records, (Record, MultiRecord)) else list(records)):
        out.append(MultiRecord.from_record(rec) if isinstance(rec, Record) else rec)
    if not out:
        raise IdentificationError("records: expected at least one record, found none")
    out = [_checked_record(rec, i) for i, rec in enumerate(out)]
    m, p = out[0].u.shape[0], out[0].y.shape[0]
    for rec in out[1:]:
        if rec.u.shape[0] != m or rec.y.shape[0] != p:
            raise IdentificationError(
                f"{rec.source}: expected {m} inputs and {p} outputs as in {out[0].source}, "
                f"found {rec.u.shape[0]} and {rec.y.shape[0]}")
    return out


def simulate_on_record(model, record, split):
    """Model outputs over a record, play states as the split assumes.

    Parameters
    ----------
    model : MultivariablePI
        The identified p x m model.
    record : MultiRecord
        Record whose inputs ``u`` (shape (m, n_samples)) drive the model.
    split : Split
        When ``split.periodic``, the play states start on the steady loop
        (the state after one pass over the record); otherwise at zero.

    Returns
    -------
    numpy.ndarray, shape (p, n_samples)
        Offset included.
    """
    state = model.simulate(record.u)[1] if split.periodic else None
    return model.simulate(record.u, state)[0]


def _window_metrics(records, splits, predictions, which):
    p = records[0].y.shape[0]
    out = []
    for l in range(p):
        err, meas = [], []
        for rec, s, pred in zip(records, splits, predictions):
            mask = getattr(s, which)
            err.append(rec.y[l][mask] - pred[l][mask])
            meas.append(rec.y[l][mask])
        err, meas = np.concatenate(err), np.concatenate(meas)
        if not err.size:
            return None
        rng = float(np.ptp(meas))
        rms = float(np.sqrt(np.mean(err ** 2)))
        out.append({"rms": rms, "rms_percent": 100 * rms / rng if rng > 0 else float("inf"),
                    "max_abs": float(np.max(np.abs(err))), "range": rng,
                    "n_samples": int(err.size)})
    return out


#: A component whose contribution (or hysteresis) RMS exceeds this multiple of the noise stays.
NOISE_FACTOR = 2.0


def noise_level(y):
    """Standard deviation of white measurement noise on a smooth record.

    From the second difference, robustly: ``1.4826 MAD(d2 y) / sqrt(6)``
    (for white noise of variance s^2 the second difference has variance
    6 s^2; the median absolute deviation ignores turning points and record
    boundaries).

    Parameters
    ----------
    y : array_like, shape (n_samples,)
        Output samples [output unit].

    Returns
    -------
    float
        Noise standard deviation [output unit].

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 1, 20000)
    >>> y = 50 * np.sin(2 * np.pi * t) + 0.04 * np.random.default_rng(0).standard_normal(t.size)
    >>> round(noise_level(y), 2)
    0.04
    """
    d2 = np.diff(np.asarray(y, dtype=float), 2)
    if d2.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def split_level_records(records, hold_out="auto", train_fraction=None, skip_seconds=None,
                        splits=None, model_class="this model class"):
    """Records and their splits for a model judged on minor loops (Preisach, generalised PI).

    Parameters
    ----------
    records : MultiRecord, Record or sequence of them
        Inputs shape (m, n_samples) [V], outputs shape (p, n_samples) [µm].
    hold_out, train_fraction, skip_seconds
        See :func:`split_record`.
    splits : list of Split, optional
        Given splits (then ``records`` are used as they are).
    model_class : str
        Named in the error, e.g. ``"a Preisach model"``.

    Returns
    -------
    records : list of Record
    splits : list of Split

    Raises
    ------
    IdentificationError
        On a single closed loop (its minor loops are not in it) or records
        that cannot be split.
    """
    records = _as_records(records)
    if splits is None:
        pairs = [split_record(r, "least-squares", hold_out, train_fraction, skip_seconds)
                 for r in records]
        records, splits = [r for r, _ in pairs], [s for _, s in pairs]
    if any(s.periodic for s in splits):
        raise IdentificationError(
            f"records: a single closed loop cannot identify {model_class} (its minor loops "
            "are not in it); record the decreasing-amplitude sine of `hammerstein excitation`")
    return records, splits


def levels_end(record, split):
    """Where a record leaves its last amplitude level (the cut of :func:`levels_part`).

    Parameters
    ----------
    record : MultiRecord
    split : Split
        Its split (:func:`split_record`).

    Returns
    -------
    int
        The first sample after the last level farther from the centre of the
        excited input's span than ``1.05`` times that level's amplitude; the
        record's length when it has no levels or never leaves the last one.
    """
    u = record.u[split.excitation]
    if not split.levels:
        return u.size
    last = split.levels[-1]
    centre = 0.5 * (u.max() + u.min())
    after = np.flatnonzero(np.abs(u[last["stop"] + 1:] - centre) > 1.05 * last["amplitude"])
    return u.size if after.size == 0 else last["stop"] + 1 + int(after[0])


def level_weights(split, n_samples):
    """Row weights that make a fit's residual relative to each amplitude level.

    ``w_t = 100 / percent`` of the level (:func:`amplitude_levels`) whose
    samples ``start <= t < stop`` hold ``t`` (``A_max / A_level``: the
    full-amplitude level 1, a 20 % level 5), and 1 outside every level (the
    burn-in before the first, the reversal curves after the last, a record
    without levels); a level below 1 % counts as 1 %. A least-squares fit
    whose rows are scaled by ``w`` minimises each level's residual in units
    of its amplitude, the measure by which ``identify --model auto`` judges
    the held-out levels (% of each level's range). Unweighted, the
    full-amplitude levels, whose residuals are the largest in µm, decide the
    fit, and the small loops are what it extrapolates.

    Parameters
    ----------
    split : Split
        The record's split (:func:`split_record`), its ``levels``.
    n_samples : int
        The record's length.

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        Dimensionless, >= 1.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(4000) / 1000
    >>> u = np.sin(2 * np.pi * t) * np.where(t < 2, 10.0, 4.0)
    >>> lv = amplitude_levels(u)
    >>> w = level_weights(Split(u > 9, u > 9, 0, False, 0, [], 0, "", lv), u.size)
    >>> float(w[lv[0]["start"]]), float(w[lv[1]["start"] + 10])
    (1.0, 2.5)
    """
    w = np.ones(int(n_samples))
    for lv in split.levels:
        w[lv["start"]:lv["stop"]] = 100.0 / max(lv["percent"], 1.0)
    return w


def levels_part(records, splits):
    """The records and splits cut where a multi-level record leaves its last level.

    A hysteresis record of ``hammerstein excitation --reversals`` holds the
    decreasing sine's amplitude levels, then first-order reversal curves
    (:func:`hammerstein.signals.excitation.reversal_curves`), which leave the last
    (smallest) level at once for the full amplitude. A record is cut where it
    leaves its last level (:func:`levels_end`); a record without levels, or that
    never leaves its last one, is kept whole.

    Parameters
    ----------
    records : list of MultiRecord
    splits : list of Split
        As :func:`split_record` gives them.

    Returns
    -------
    records : list of MultiRecord
    splits : list of Split
        Cut (samples, masks and branches up to the cut); the others as given.
    cut : int
        How many records were cut.
    """
    out_r, out_s, cut = [], [], 0
    for rec, sp in zip(records, splits):
        n = levels_end(rec, sp)
        if n == rec.u.shape[1]:
            out_r.append(rec), out_s.append(sp)
            continue
        cut += 1
        out_r.append(replace(rec, timepts=rec.timepts[:n], u=rec.u[:, :n], y=rec.y[:, :n]))
        out_s.append(replace(sp, train=sp.train[:n], held_out=sp.held_out[:n],
                             branches=[(a, min(b, n - 1), ok) for a, b, ok in sp.branches if a < n]))
    return out_r, out_s, cut


def level_errors(fit):
    """Errors of a fitted model per amplitude level (minor loop) of its records.

    For every level of every multi-amplitude record (``Split.levels``) and
    every output: the RMS error over the level in % of the measured output
    range there, and the error of the loop amplitude (peak to peak over the
    last half of the level, its steady loop) in % of the measured one. Both
    peak-to-peak values are taken after the same moving average over 1/200
    of that half (5 ms for a 1 Hz level of two periods): the sensor's noise
    would otherwise add its own extremes to the measured one, -20 % on a
    1.3 µm cross-coupling loop with 40 nm of noise.

    Parameters
    ----------
    fit : RecordFit
        A fit whose splits may hold amplitude levels.

    Returns
    -------
    list of dict
        ``source``, ``level`` (its place among the record's levels, from 1:
        a record may repeat an amplitude), ``percent`` (level amplitude, % of
        the largest), ``held_out`` (bool), ``output``, ``rms_percent``,
        ``amplitude_error_percent``, ``measured_peak_to_peak``, ``rms`` and
        ``range`` (the RMS error and the measured range over the level)
        [output unit].
    """
    rows = []
    for rec, s, pred in zip(fit.records, fit.splits, fit.predictions):
        for index, lv in enumerate(s.levels, start=1):
            a, b = lv["start"], lv["stop"] + 1
            h = a + (b - a) // 2
            w = max(1, (b - h) // 200)
            for l, name in enumerate(fit.model.output_names):
                y, yh = rec.y[l, a:b], pred[l, a:b]
                rng = float(np.ptp(y))
                rms = float(np.sqrt(np.mean((y - yh) ** 2)))
                pp, pp_hat = (float(np.ptp(uniform_filter1d(np.asarray(v[l, h:b], dtype=float), w,
                                                            mode="nearest")))
                              for v in (rec.y, pred))
                rows.append({"source": rec.source, "level": index, "percent": lv["percent"],
                             "held_out": bool(lv["held_out"]), "output": name,
                             "rms_percent": 100 * rms / max(rng, 1e-300),
                             "amplitude_error_percent": 100 * (pp_hat - pp) / max(pp, 1e-300),
                             "measured_peak_to_peak": pp,
                             "rms": rms, "range": rng})
    return rows


def held_out_level_error(rows):
    """Mean RMS Euclidean error of the held-out amplitude levels [% of each level's range].

    Per held-out level (one record's minor loop): the RMS over its samples of
    the Euclidean norm of the output error (every output together, the error
    a trajectory in the plane sees), in % of the largest output range over
    the level (the direct transfer's). A cross-coupling output counts with
    its error in the output unit, not in % of its own small range, where the
    sensor's noise alone is several % and would decide between model
    classes.

    Parameters
    ----------
    rows : list of dict
        :func:`level_errors`.

    Returns
    -------
    float or None
        The mean over the held-out levels [%]; None without one.
    """
    levels = {}
    for r in rows:
        if r["held_out"]:
            levels.setdefault((r["source"], r.get("level", r["percent"])), []).append(r)
    if not levels:
        return None
    return float(np.mean([100 * np.sqrt(sum(r["rms"] ** 2 for r in lv))
                          / max(max(r["range"] for r in lv), 1e-300) for lv in levels.values()]))


#: A measured loop whose point-symmetry defect exceeds this % of its output range gets a note.
ASYMMETRY_NOTE_PERCENT = 2.0


def loop_asymmetry(u, y, branches):
    """How far a measured loop is from point symmetry, in % of its output range.

    A classical PI's steady loops are point-symmetric about their centre
    (the descending branch is the ascending one rotated by 180 degrees,
    Brokate & Sprekels [3], Section 2.3), whatever its weights: an
    asymmetric loop (saturation on one side, a Preisach or Bouc-Wen loop
    with asymmetric parameters) is beyond the model. The last complete
    descending branch ``y_d`` is compared with the last complete ascending
    one ``y_a`` rotated about ``(u_c, y_c)``: ``u_c`` the mid-range of the
    input over both branches, ``y_c`` fitted by least squares; the RMS of
    ``y_d(u) + y_a(2 u_c - u) - 2 y_c`` is returned.

    Parameters
    ----------
    u : array_like, shape (n_samples,)
        The excitation (input unit, e.g. [V]).
    y : array_like, shape (n_samples,)
        One output (output unit, e.g. [µm]).
    branches : list of (int, int, bool)
        ``(start, stop, complete)`` as in :attr:`Split.branches`.

    Returns
    -------
    float or None
        RMS defect [%] of the output range over the two branches, or None
        without a complete ascending and a complete descending branch.

    References
    ----------
    .. [3] M. Brokate, J. Sprekels, "Hysteresis and phase transitions",
       Springer (1996).
    """
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    up = [(a, b) for a, b, ok in branches if ok and u[b] > u[a]]
    down = [(a, b) for a, b, ok in branches if ok and u[b] < u[a]]
    if not up or not down:
        return None
    (a1, b1), (a2, b2) = up[-1], down[-1]
    ua, ya, ud, yd = u[a1:b1 + 1], y[a1:b1 + 1], u[a2:b2 + 1], y[a2:b2 + 1]
    order = np.argsort(ua, kind="stable")
    uc = 0.5 * (min(ua.min(), ud.min()) + max(ua.max(), ud.max()))
    mirrored = 2 * uc - ud
    inside = (mirrored >= ua.min()) & (mirrored <= ua.max())
    span = np.ptp(np.concatenate([ya, yd]))
    if inside.sum() < 3 or not span > 0:
        return None
    total = yd[inside] + np.interp(mirrored[inside], ua[order], ya[order])
    defect = total - total.mean()                  # the mean is 2 y_c
    return float(100 * np.sqrt(np.mean(defect ** 2)) / span)


def _asymmetry_notes(records, splits, out_names):
    notes = []
    for l, name in enumerate(out_names):
        for rec, s in zip(records, splits):
            others = np.delete(np.ptp(rec.u, axis=1), s.excitation)
            if np.any(others > 0.02 * np.ptp(rec.u[s.excitation])):
                continue                           # several inputs driven: no single loop
            d = loop_asymmetry(rec.u[s.excitation], rec.y[l], s.branches)
            if d is not None and d > ASYMMETRY_NOTE_PERCENT:
                notes.append(
                    f"{name}: the measured loop of {rec.source or 'the record'} is not "
                    f"point-symmetric ({d:.3g} % of the range between its descending branch "
                    f"and its ascending branch rotated by 180 degrees); a classical PI's loops "
                    f"are, so expect an error of that order on the held-out branch (training "
                    f"on both branches with --hold-out none, hold_out = \"none\" in a scenario, "
                    f"reduces but cannot remove it)")
                break
    return notes
