"""Identification of p x m PI models from measured records, split by periods.

:func:`identify_records` identifies a multivariable classical PI model
(:class:`~hammerstein.models.hysteresis.MultivariablePI`) from one or more
measured records (:class:`~hammerstein.io.datafiles.MultiRecord`), each
holding every input and every output column. Typically there is one record per
excited input (Steps 1-4 of Section 3.3 of the paper), but least squares
accepts any excitation: all components of an output are fitted together.

What it does, in order:

1. **Split by periods.** The excitation of each record (its input of largest
   relative span) is cut at its reversal points into branches; a branch is
   *complete* when it travels at least 90 % of the input span. The held-out
   part is a run of trailing complete branches (about a third of the
   periods, at least one branch); the rest trains. A record holding a single
   closed loop (one ascending and one descending branch, ending where it
   started) is rotated to start at its minimum and its play states start on
   the steady loop; least squares trains on both branches and holds out
   every third of 30 blocks of each (a loop that is not point-symmetric
   cannot be told from one branch), the closed form trains on the ascending branch and holds
   out the descending one. Before the first complete branch the play states depend on
   an unknown history: those samples only warm up the play states (burn-in).
2. **Thresholds** per input: ``time`` (Remark 5.1 of the paper, the instants
   that split the first complete branch into n + 1 equal parts), ``input``
   (uniform in input, ``r_1 = 0`` a linear term) or ``auto``: both are
   fitted and the one with the smaller held-out error is kept.
3. **Fit**: least squares of every output on the play outputs of every input
   plus one output offset, on the triangular factor of the regression
   (:func:`hammerstein.identification.lsq.r_factor`; :func:`scipy.linalg.lstsq`, or
   :func:`hammerstein.identification.lsq.bounded_lstsq` with bounds on the direct
   transfers),
   or the closed form of the paper's Appendix per component.
4. **Structure**: each component is a PI, a pure gain or absent. With
   ``components="auto"`` a component is simplified (PI -> absent, else PI ->
   gain) when the simplified fit's training RMS error of its output grows by
   at most 5 %, i.e. when its contribution is below the noise and mismatch
   of that output.
5. **Fit report** on the training and held-out samples per output (RMS,
   RMS in % of the measured output range, largest absolute error), the model
   simulated with its output offset.

References
----------
.. [1] M. Rakotondrabe, "Multivariable classical Prandtl-Ishlinskii hysteresis
   modeling and compensation and sensorless control of a nonlinear 2-dof
   piezoactuator", Section 3.3, Remark 5.1 and Appendix.
.. [2] K. Kuhnen, "Modeling, identification and compensation of complex
   hysteretic nonlinearities", Eur. J. Control 9 (2003) (least squares on
   play outputs, monotone PI via cumulative weights).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg

from hammerstein.core.numbers import MAX_HYSTERONS, check_array, check_integer, is_number
from hammerstein.io.datafiles import MIN_SAMPLES, MultiRecord, Record
from hammerstein.models.hysteresis import (HysteresisError, MultivariablePI, OutputMap,
                                         PrandtlIshlinskii, play)
from hammerstein.models import lti
from hammerstein.identification.lsq import bounded_lstsq, lstsq_bounded_below, r_factor
from hammerstein.models.creep import creep_matrices
from hammerstein.identification.creep_identification import CreepIdentifier, hysteresis_frequency
from hammerstein.simulation import linear_steps
from hammerstein.identification.identification import (ClosedFormPI, IdentificationError,
                                             partition_thresholds)

#: a single closed loop fitted by least squares: blocks per branch, every third held out
HOLD_OUT_BLOCKS = 30

__all__ = [
    "HOLD_OUT_BLOCKS",
    "REVERSAL_BAND",
    "COMPLETE_TRAVEL",
    "PRUNE_TOLERANCE",
    "Split",
    "RecordFit",
    "reversal_points",
    "split_record",
    "parse_components",
    "identify_records",
    "identify_record",
    "identify_record_creep",
    "dynamics_tables",
    "noise_level",
    "split_level_records",
    "weak_couplings",
    "amplitude_levels",
    "level_errors",
    "NOISE_FACTOR",
    "identify_record_dynamics",
    "RecordDynamics",
    "DYNAMICS_DEFAULTS",
    "loop_asymmetry",
    "ASYMMETRY_NOTE_PERCENT",
    "OUTPUT_MAPS",
    "MAP_KNOTS",
]

#: Output-map options of :func:`identify_records`.
OUTPUT_MAPS = ("auto", "none", "deadzone")
#: Knots of a fitted output map (at quantiles of the PI output).
MAP_KNOTS = 16
#: Alternations of the output-map fit (PI weights, then map slopes).
MAP_ITERATIONS = 8
#: Weight of the slope-change penalty of the output map (relative to the data rows).
MAP_SMOOTHING = 0.05
#: Relative drop of the score that makes ``output_map="auto"`` keep the map on a symmetric loop.
MAP_GAIN = 0.1

#: A reversal is recognised once the input has come back by this fraction of its span.
REVERSAL_BAND = 0.05
#: A complete branch travels at least this fraction of the input span.
COMPLETE_TRAVEL = 0.9
#: Relative growth of an output's training RMS error accepted when a component is simplified.
PRUNE_TOLERANCE = 0.05
#: Component kinds.
KINDS = ("pi", "gain", "none")


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
    """
    u = np.asarray(u, dtype=float)
    span = float(np.ptp(u)) if u.size else 0.0
    if not span > 0:
        return []
    tol = band * span
    rev = []
    hi = lo = 0
    direction = 0
    ext = 0
    for i in range(1, u.size):
        v = u[i]
        if direction == 0:
            if v > u[hi]:
                hi = i
            if v < u[lo]:
                lo = i
            if v - u[lo] > tol:
                direction, ext = 1, i
                if lo > 0 and u[0] - u[lo] > tol:
                    rev.append(lo)
            elif u[hi] - v > tol:
                direction, ext = -1, i
                if hi > 0 and u[hi] - u[0] > tol:
                    rev.append(hi)
        elif direction > 0:
            if v >= u[ext]:
                ext = i
            elif u[ext] - v > tol:
                rev.append(ext)
                direction, ext = -1, i
        else:
            if v <= u[ext]:
                ext = i
            elif v - u[ext] > tol:
                rev.append(ext)
                direction, ext = 1, i
    return rev


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


#: Branches whose end amplitudes differ by at most this fraction of the span form one level.
LEVEL_TOLERANCE = 0.05


def amplitude_levels(u, branches=None):
    """Amplitude levels of a record: runs of branches turning at the same amplitude.

    A decreasing-amplitude sine (:func:`hammerstein.signals.excitation.decreasing_sine`)
    has one level per amplitude: the branches that end at the same distance
    from the centre of the input span (within :data:`LEVEL_TOLERANCE` of the
    span). Runs of fewer than three branches (less than a loop) are not levels.

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
        if runs and abs(runs[-1]["amplitude"] - amp) <= LEVEL_TOLERANCE * span:
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
                raise IdentificationError(f"{name}no reversal point to split at; use --hold-out none")
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
                f"--hold-out none")
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
            raise IdentificationError(
                f"skip: expected a burn-in shorter than the record ({n * record.sampling_period:g} s), "
                f"found {burn_in_seconds:g} s")
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


# -- structure -------------------------------------------------------------------------
def parse_components(spec, input_names, output_names):
    """Component kinds from ``"auto"``, ``"all"`` or ``"OUT:IN=pi|gain|none,..."``.

    Parameters
    ----------
    spec : None, str or dict
        ``None`` or ``"auto"`` (every component a PI, all prunable),
        ``"all"`` (every component a PI, none prunable), a comma-separated
        string ``"OUT:IN=kind,..."`` or a dict ``{"OUT:IN" or (OUT, IN):
        kind}``; the components not named stay automatic.
    input_names : sequence of str
        The m input names of the model.
    output_names : sequence of str
        The p output names of the model.

    Returns
    -------
    (kinds, auto) : (list of list of str, numpy.ndarray of bool)
        Kinds per (output, input) and which ones the automatic pruning may
        simplify (those not given explicitly, unless ``"all"``).

    Raises
    ------
    IdentificationError
        On an unknown output, input or kind (the known ones are listed).
    """
    p, m = len(output_names), len(input_names)
    kinds = [["pi"] * m for _ in range(p)]
    auto = np.ones((p, m), dtype=bool)
    if spec is None or spec == "auto":
        return kinds, auto
    if spec == "all":
        return kinds, np.zeros((p, m), dtype=bool)
    items = spec.items() if isinstance(spec, dict) else [
        tuple(part.split("=", 1)) if "=" in part else (part, None)
        for part in str(spec).split(",") if part.strip()]
    for key, kind in items:
        key = key if isinstance(key, tuple) else tuple(str(key).strip().split(":", 1))
        if len(key) != 2 or kind is None:
            raise IdentificationError(
                f"components: expected OUTPUT:INPUT=pi|gain|none entries, found {key!r}")
        out, inp = (str(v).strip() for v in key)
        kind = str(kind).strip()
        if out not in output_names:
            raise IdentificationError(f"components: unknown output {out!r} (outputs: "
                                      f"{', '.join(output_names)})")
        if inp not in input_names:
            raise IdentificationError(f"components: unknown input {inp!r} (inputs: "
                                      f"{', '.join(input_names)})")
        if kind not in KINDS:
            raise IdentificationError(f"components: {out}:{inp}: expected pi, gain or none, "
                                      f"found {kind!r}")
        l, k = output_names.index(out), input_names.index(inp)
        kinds[l][k] = kind
        auto[l, k] = False
    return kinds, auto


# -- least squares engine ----------------------------------------------------------------
def _thresholds(records, splits, k, n, partition, explicit):
    """Thresholds of input k from the record where it travels most."""
    if explicit is not None:
        return np.asarray(explicit, dtype=float), "explicit"
    spans = [np.ptp(r.u[k][s.train]) if s.train.any() else 0.0 for r, s in zip(records, splits)]
    j = int(np.argmax(spans))
    if not spans[j] > 0:
        raise IdentificationError(f"input {records[0].input_names[k]!r}: never excited in the "
                                  f"training samples; cannot identify its components")
    uk = records[j].u[k][splits[j].train]
    if partition == "time":
        for a, b, ok in _branches(uk):
            if ok:
                sign = 1.0 if uk[b] > uk[a] else -1.0
                try:
                    return partition_thresholds(sign * uk, n, "time", (a, b)), "time"
                except IdentificationError:
                    break
        # no complete branch of this input (broadband): uniform in input
    amplitude = np.ptp(uk) / 2.0
    return amplitude * np.arange(n) / n, "input"


def _plays(u, r, periodic):
    phi, final = play(u, r)
    if periodic:
        phi, _ = play(u, r, final)
    return phi


class _LeastSquares:
    """Joint least squares of every output on the play outputs of every input."""

    def __init__(self, records, splits, thresholds, bounds, offset=True):
        self.records, self.splits, self.r = records, splits, thresholds
        self.bounds = bounds
        self.offset = offset
        m = records[0].u.shape[0]
        self.m = m
        # regressors over the training samples, concatenated over the records
        self.phi = [np.concatenate([_plays(rec.u[k], thresholds[k], s.periodic)[:, s.train]
                                    for rec, s in zip(records, splits)], axis=1).T
                    for k in range(m)]
        self.lin = [np.concatenate([rec.u[k][s.train] for rec, s in zip(records, splits)])
                    for k in range(m)]
        self.y = np.concatenate([rec.y[:, s.train] for rec, s in zip(records, splits)], axis=1)

    def fit_output(self, l, kinds):
        """Components and offset of output l for kinds[k]; returns (comps, offset, rms)."""
        cols, layout = [], []
        lower, upper = [], []
        for k, kind in enumerate(kinds):
            if kind == "pi":
                X = self.phi[k]
                n = X.shape[1]
                lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
                transform = None
                if l == k and self.bounds == "nonnegative":
                    lo[:] = 0.0
                elif l == k and self.bounds == "monotone":
                    sec = np.polyfit(self.lin[k], self.y[l], 1)[0] if np.ptp(self.lin[k]) > 0 else 1.0
                    sign = 1.0 if sec >= 0 else -1.0
                    M = np.eye(n) - np.eye(n, k=-1)
                    transform = sign * M
                    X = X @ transform
                    lo[:] = 0.1 * abs(sec)
                cols.append(X)
                layout.append((k, "pi", n, transform))
                lower.append(lo)
                upper.append(hi)
            elif kind == "gain":
                cols.append(self.lin[k][:, None])
                layout.append((k, "gain", 1, None))
                lower.append([-np.inf])
                upper.append([np.inf])
        target = self.y[l]
        if self.offset:
            cols.append(np.ones((target.size, 1)))
            lower.append([-np.inf])
            upper.append([np.inf])
        if not cols:
            return [None] * self.m, float(np.mean(target)), float(np.std(target))
        lo, hi = np.concatenate(lower), np.concatenate(upper)
        # hi is +inf throughout; the tall problem reduced to its n x n factor first (from the
        # column blocks: the tall matrix is never stacked), ||X c - t||^2 = ||R c - q||^2 + rho^2
        R, c, rho = r_factor(cols, target)
        if np.all(np.isinf(lo)):
            coef, *_ = scipy.linalg.lstsq(R, c)
        else:
            coef = bounded_lstsq(R, c, lo)
        rms = float(np.sqrt(max(np.sum((R @ coef - c) ** 2) + rho ** 2, 0.0) / target.size))
        comps = [None] * self.m
        i = 0
        for k, kind, n, transform in layout:
            c = coef[i:i + n]
            i += n
            if kind == "pi":
                w = transform @ c if transform is not None else c
                comps[k] = PrandtlIshlinskii(self.r[k], w)
            else:
                comps[k] = float(c[0])
        offset = float(coef[-1]) if self.offset else 0.0
        return comps, offset, rms


class _ClosedForm:
    """Closed form of the Appendix per component (records exciting one input each)."""

    def __init__(self, records, splits, n_hysterons, partition):
        self.records, self.splits = records, splits
        self.m = records[0].u.shape[0]
        self.by_input = {}
        for j, rec in enumerate(records):
            spans = np.ptp(rec.u, axis=1)
            excited = np.flatnonzero(spans > 1e-9 * max(spans.max(), 1e-300))
            if excited.size != 1:
                raise IdentificationError(
                    f"{rec.source}: the closed form needs records that excite one input each, "
                    f"found {excited.size} excited inputs; use --method least-squares")
            self.by_input.setdefault(int(excited[0]), []).append(j)
        missing = [rec_name for k, rec_name in enumerate(records[0].input_names)
                   if k not in self.by_input]
        if missing:
            raise IdentificationError(f"inputs {missing}: no record excites them; the closed form "
                                      f"needs one record per input (Steps 1-4)")
        self.fits = {}
        p = records[0].y.shape[0]
        for k, js in self.by_input.items():
            j = js[0]
            rec, s = records[j], splits[j]
            for l in range(p):
                ident = ClosedFormPI(n_hysterons, partition)
                try:
                    ident.fit(rec.u[k], rec.y[l], branches=s.ascending(rec.u[k]))
                except IdentificationError as exc:
                    raise IdentificationError(f"{rec.source}: component ({records[0].output_names[l]}, "
                                              f"{rec.input_names[k]}): {exc}") from None
                self.fits[l, k] = ident
        self.thresholds = {k: self.fits[0, k].thresholds_ for k in self.by_input}

    def fit_output(self, l, kinds):
        comps = [None] * self.m
        offsets = []
        parts = []
        for k, kind in enumerate(kinds):
            for j in self.by_input[k]:
                rec, s = self.records[j], self.splits[j]
                if kind == "pi":
                    comps[k] = self.fits[l, k].model_
                elif kind == "gain":
                    uk, yk = rec.u[k][s.train], rec.y[l][s.train]
                    comps[k] = float(np.polyfit(uk, yk, 1)[0])
                break
        for j, (rec, s) in enumerate(zip(self.records, self.splits)):
            pred = np.zeros(rec.n_samples)
            for k, c in enumerate(comps):
                if isinstance(c, PrandtlIshlinskii):
                    pred += c.simulate(rec.u[k], _steady(c, rec.u[k]) if s.periodic else None)[0]
                elif c is not None:
                    pred += c * rec.u[k]
            parts.append(rec.y[l][s.train] - pred[s.train])
            offsets.append(parts[-1])
        res = np.concatenate(parts)
        offset = float(np.mean(res))
        return comps, offset, float(np.sqrt(np.mean((res - offset) ** 2)))


def _steady(pi, u):
    return pi.simulate(u)[1]


# -- driver ------------------------------------------------------------------------------
@dataclass
class RecordFit:
    """Result of :func:`identify_records`.

    Parameters
    ----------
    model : MultivariablePI
        Identified model, ``output_offset`` included, ``input_amplitude`` the
        half span of each input over the training samples.
    method : str
    partition : str
        Threshold partition used (``"time"``, ``"input"`` or ``"explicit"``).
    partition_scores : dict of str to float
        Mean held-out (or training, without held-out samples) RMS error in %
        of the output range for each partition tried.
    structure : list of list of str
        ``"pi"``, ``"gain"`` or ``"none"`` per (output, input).
    notes : list of str
        What was decided automatically (partition, pruned components).
    records : list of MultiRecord
        The records as used (closed loops rotated to start at their minimum).
    splits : list of Split
    train, validation : list of dict
        Per output: ``rms``, ``rms_percent`` (of the measured range of the
        window), ``max_abs``, ``range``, ``n_samples``; ``validation`` is
        ``None`` when nothing is held out.
    predictions : list of numpy.ndarray, shape (p, n_samples)
        Model outputs over each record (offset included).
    output_map : {"none", "deadzone"}
        Whether the model has a static output map (modified PI).
    levels : list of dict
        Per amplitude level of multi-amplitude records (:func:`level_errors`).
    """

    model: MultivariablePI
    method: str
    partition: str
    partition_scores: dict
    structure: list
    notes: list
    records: list
    splits: list
    train: list
    validation: list | None
    predictions: list = field(repr=False)
    output_map: str = "none"
    levels: list = field(default_factory=list)

    @property
    def minor_loop_error(self):
        """Mean RMS error of the held-out amplitude levels [% of each level's output range].

        The minor loops the fit never saw (:func:`level_errors`); what
        ``identify --model auto`` and the generalised PI's
        ``threshold_spacing="auto"`` compare. None without held-out levels.
        """
        rows = [r["rms_percent"] for r in self.levels if r["held_out"]]
        return float(np.mean(rows)) if rows else None


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


def _fit_structure(engine, kinds, auto, names_out, names_in, prune):
    """Fit every output; simplify components where allowed. Returns (grid, offsets, notes)."""
    p = len(kinds)
    grid, offsets, notes = [], [], []
    for l in range(p):
        row = list(kinds[l])
        comps, off, rms = engine.fit_output(l, row)
        if prune:
            base = rms
            order = sorted((k for k in range(len(row)) if auto[l, k] and row[k] != "none"),
                           key=lambda k: _contribution(comps[k], engine, k))
            for k in order:
                for simpler in ("none", "gain"):
                    if KINDS.index(simpler) <= KINDS.index(row[k]):
                        continue
                    trial = list(row)
                    trial[k] = simpler
                    if not any(t == "pi" for r_ in ([trial] + [g for g in kinds[l + 1:]]) for t in r_) \
                            and not any(isinstance(c, PrandtlIshlinskii) for g in grid for c in g):
                        continue          # keep at least one hysteresis component in the model
                    c2, o2, rms2 = engine.fit_output(l, trial)
                    if rms2 <= (1 + PRUNE_TOLERANCE) * base + 1e-12 * max(abs(o2), 1.0):
                        above = _above_noise(engine, l, k, comps[k], simpler)
                        if above is not None:
                            notes.append(
                                f"{names_out[l]} <- {names_in[k]}: kept, not "
                                f"{'absent' if simpler == 'none' else 'a pure gain'} (its "
                                f"{'contribution' if simpler == 'none' else 'hysteresis'} "
                                f"{above[0]:.3g} RMS is above the noise {above[1]:.3g}, though "
                                f"the training RMS grows only from {base:.3g} to {rms2:.3g})")
                            continue
                        notes.append(f"{names_out[l]} <- {names_in[k]}: "
                                     f"{'absent' if simpler == 'none' else 'a pure gain'} "
                                     f"(training RMS {rms2:.3g} vs {base:.3g} as a PI)")
                        row, comps, off, rms = trial, c2, o2, rms2
                        break
        kinds[l] = row
        grid.append(comps)
        offsets.append(off)
    return grid, offsets, notes


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


def weak_couplings(records, auto, components, contribution, input_names, output_names):
    """Cross-couplings below the noise, dropped by ``components = "auto"`` (never one above it).

    A cross-coupling (l, k) chosen automatically is absent when the RMS of its
    contribution over the records is at most :data:`NOISE_FACTOR` times the
    output's measurement noise (:func:`noise_level`, median over the records).

    Parameters
    ----------
    records : list of Record
        Inputs shape (m, n_samples) [V], outputs shape (p, n_samples) [µm].
    auto : numpy.ndarray of bool, shape (p, m)
        Components whose presence is decided here (:func:`parse_components`).
    components : list of list
        The fitted components, ``components[l][k]`` (None when absent).
    contribution : callable
        ``contribution(component, u)`` -> output [µm] of a component for the
        input samples ``u`` (shape (n_samples,)).
    input_names, output_names : sequence of str

    Returns
    -------
    absent : list of (int, int)
        The (output, input) pairs to drop.
    notes : list of str
        One line per judged cross-coupling.
    """
    absent, notes = [], []
    for l in range(len(output_names)):
        noise = float(np.median([noise_level(r.y[l]) for r in records]))
        for k in range(len(input_names)):
            c = components[l][k]
            if k == l or not auto[l, k] or c is None:
                continue
            rms = float(np.std(np.concatenate([contribution(c, r.u[k]) for r in records])))
            if rms <= NOISE_FACTOR * noise:
                absent.append((l, k))
                notes.append(f"{output_names[l]} <- {input_names[k]}: absent (its contribution "
                             f"{rms:.3g} RMS is below twice the noise {noise:.3g})")
            else:
                notes.append(f"{output_names[l]} <- {input_names[k]}: kept (contribution "
                             f"{rms:.3g} RMS, noise {noise:.3g})")
    return absent, notes


def _above_noise(engine, l, k, comp, simpler):
    """(RMS, noise) when simplifying component (l, k) would drop more than the noise, else None."""
    if not hasattr(engine, "phi") or comp is None:
        return None
    if isinstance(comp, PrandtlIshlinskii):
        c = engine.phi[k] @ comp.weights
    else:
        c = comp * engine.lin[k]
    if simpler == "gain":
        if not isinstance(comp, PrandtlIshlinskii):
            return None
        X = np.column_stack([engine.lin[k], np.ones_like(engine.lin[k])])
        c = c - X @ np.linalg.lstsq(X, c, rcond=None)[0]
    rms = float(np.std(c))
    noise = noise_level(engine.y[l])
    return (rms, noise) if rms > NOISE_FACTOR * noise else None


def _contribution(comp, engine, k):
    if comp is None:
        return 0.0
    if isinstance(comp, PrandtlIshlinskii):
        c = engine.phi[k] @ comp.weights if hasattr(engine, "phi") else comp.weights
        return float(np.std(c))
    return float(np.std(comp * engine.lin[k])) if hasattr(engine, "lin") else abs(comp)


def identify_records(records, method="least-squares", n_hysterons=15, thresholds=None,
                     partition="auto", bounds=None, components="auto", hold_out="auto",
                     train_fraction=None, skip_seconds=None, input_names=None, output_names=None,
                     output_map="auto"):
    """Identify a p x m PI model from records, validated on held-out periods.

    Parameters
    ----------
    records : MultiRecord, Record or sequence of them
        Each with all m inputs (shape (m, n_samples), input unit) and all p
        outputs (shape (p, n_samples), output unit).
    method : {"least-squares", "closed-form"}
    n_hysterons : int
        Hysterons per component, 1 to 100 (``MAX_HYSTERONS``, the bound of
        the command line and of the scenario files).
    thresholds : array_like, shape (n,), optional
        Explicit thresholds (input unit) for every component.
    partition : {"auto", "time", "input"}
        Threshold partition; ``"auto"`` keeps the one with the smaller
        held-out error.
    bounds : None, "nonnegative" or "monotone"
        Least-squares constraints on the direct transfers (output l from
        input l): ``w >= 0``, or cumulative weights ``|S_j| >= 10 %`` of the
        secant slope (a strictly monotone, invertible PI). Cross-couplings are
        unconstrained.
    components : "auto", "all", str or dict
        ``"auto"``: every component starts as a PI and is simplified to absent
        or a pure gain where that costs at most 5 % of the output's training
        RMS error; ``"all"``: every component a PI; or explicit kinds
        ``"OUT:IN=pi|gain|none,..."`` (the others automatic).
    hold_out, train_fraction, skip_seconds
        See :func:`split_record` (``skip_seconds`` is the burn-in [s]).
    input_names, output_names : sequence of str, optional
        Names in the model (default: the column names of the first record).
    output_map : {"auto", "none", "deadzone"}
        Static output map per output after the PI, the modified PI of
        Kuhnen (K. Kuhnen, Eur. J. Control 9(4), 2003): ``y = S(Gamma(u)) + c``
        with S a monotone superposition of one-sided dead zones (knots at
        quantiles of the PI output), fitted by alternating least squares on
        the structure of the classical fit. ``"deadzone"`` always fits it,
        ``"none"`` never; ``"auto"`` keeps it when it lowers the held-out
        (else training) error and the measured loop is not point-symmetric
        (:func:`loop_asymmetry` above ``ASYMMETRY_NOTE_PERCENT``), or when
        it lowers that error by more than 10 %. A note says which was chosen.
        Least squares only.

    Returns
    -------
    RecordFit

    Raises
    ------
    IdentificationError
        On records that cannot be split or identified (the message names
        the record and the option that helps).
    """
    records = _as_records(records)
    if thresholds is None:
        n_hysterons = check_integer(n_hysterons, "n_hysterons", 1, MAX_HYSTERONS,
                                    IdentificationError)
    if method not in ("least-squares", "closed-form"):
        raise IdentificationError(
            f"method: expected 'least-squares' or 'closed-form', found {method!r}")
    if partition not in ("auto", "time", "input"):
        raise IdentificationError(f"partition: expected 'auto', 'time' or 'input', found {partition!r}")
    if bounds not in (None, "none", "nonnegative", "monotone"):
        raise IdentificationError(
            f"bounds: expected 'none', 'nonnegative' or 'monotone', found {bounds!r}")
    if bounds is not None and bounds != "none" and method == "closed-form":
        raise IdentificationError("bounds: only used by the least-squares method")
    bounds = None if bounds == "none" else bounds
    if output_map not in OUTPUT_MAPS:
        raise IdentificationError(f"output_map: expected one of {', '.join(OUTPUT_MAPS)}, "
                                  f"found {output_map!r}")
    if method == "closed-form":
        if output_map == "deadzone":
            raise IdentificationError("output_map: deadzone needs --method least-squares")
        output_map = "none"
    in_names = list(input_names or records[0].input_names)
    out_names = list(output_names or records[0].output_names)
    kinds0, auto = parse_components(components, in_names, out_names)
    pairs = [split_record(rec, method, hold_out, train_fraction, skip_seconds) for rec in records]
    records = [r for r, _ in pairs]
    splits = [s for _, s in pairs]
    for l, name in enumerate(out_names):  # a fit to it is meaningless, its % error infinite
        if not any(np.ptp(r.y[l][s.train]) > 0 for r, s in zip(records, splits) if s.train.any()):
            raise IdentificationError(
                f"{records[0].source}: output column {name!r}: the output is constant over the "
                f"training samples; expected the response to the excitation: add a record that "
                f"excites an input it depends on, or leave it out of --outputs")
    m = records[0].u.shape[0]
    tried = ["time", "input"] if partition == "auto" and thresholds is None else [partition]
    results, errors = {}, {}
    for part in tried:
        try:
            results[part] = _one_partition(records, splits, method, n_hysterons, thresholds, part,
                                           bounds, [list(r) for r in kinds0], auto,
                                           in_names, out_names, m)
        except (IdentificationError, HysteresisError) as exc:
            errors[part] = str(exc)
    if not results:
        raise IdentificationError(next(iter(errors.values())))
    scores = {part: res[1] for part, res in results.items()}
    best = min(scores, key=scores.get)
    fit, _ = results[best]
    if len(tried) > 1:
        basis = "held-out" if fit.validation is not None else "training"
        fit.notes.insert(0, "partition auto: chose " + best + " (" + ", ".join(
            f"{p} {scores[p]:.3g} %" if p in scores else f"{p} failed: {errors[p]}"
            for p in tried) + f" mean {basis} RMS of the output range)")
    fit.partition_scores = scores
    asym = _asymmetry_notes(records, splits, out_names)
    fit.output_map = "none"
    if output_map != "none":
        fit = _with_output_map(fit, output_map, bounds, scores[best], bool(asym))
    if fit.output_map == "none":
        fit.notes += asym
    fit.levels = level_errors(fit)
    return fit


def level_errors(fit):
    """Errors of a fitted model per amplitude level (minor loop) of its records.

    For every level of every multi-amplitude record (``Split.levels``) and
    every output: the RMS error over the level in % of the measured output
    range there, and the error of the loop amplitude (peak to peak over the
    last half of the level, its steady loop) in % of the measured one.

    Parameters
    ----------
    fit : RecordFit
        A fit whose splits may hold amplitude levels.

    Returns
    -------
    list of dict
        ``source``, ``percent`` (level amplitude, % of the largest),
        ``held_out`` (bool), ``output``, ``rms_percent``,
        ``amplitude_error_percent``, ``measured_peak_to_peak`` [output unit].
    """
    rows = []
    for rec, s, pred in zip(fit.records, fit.splits, fit.predictions):
        for lv in s.levels:
            a, b = lv["start"], lv["stop"] + 1
            h = a + (b - a) // 2
            for l, name in enumerate(fit.model.output_names):
                y, yh = rec.y[l, a:b], pred[l, a:b]
                rng = float(np.ptp(y))
                pp, pp_hat = float(np.ptp(rec.y[l, h:b])), float(np.ptp(pred[l, h:b]))
                rows.append({"source": rec.source, "percent": lv["percent"],
                             "held_out": bool(lv["held_out"]), "output": name,
                             "rms_percent": 100 * float(np.sqrt(np.mean((y - yh) ** 2))) / max(rng, 1e-300),
                             "amplitude_error_percent": 100 * (pp_hat - pp) / max(pp, 1e-300),
                             "measured_peak_to_peak": pp})
    return rows


def _with_output_map(fit, output_map, bounds, classical, asymmetric):
    """Fit the modified PI on the structure of ``fit``; keep it as ``output_map`` says."""
    try:
        model, _ = _fit_output_maps(fit, bounds)
    except (IdentificationError, HysteresisError) as exc:
        if output_map == "deadzone":
            raise IdentificationError(f"output map: {exc}") from None
        fit.notes.append(f"output map auto: none (the fit failed: {exc})")
        return fit
    predictions = [simulate_on_record(model, rec, s) for rec, s in zip(fit.records, fit.splits)]
    train = _window_metrics(fit.records, fit.splits, predictions, "train")
    val = _window_metrics(fit.records, fit.splits, predictions, "held_out")
    score = float(np.mean([v["rms_percent"] for v in (val or train)]))
    basis = "held-out" if val is not None else "training"
    numbers = (f"mean {basis} RMS {score:.3g} % of the output range with the map, "
               f"{classical:.3g} % without")
    if output_map == "auto":
        keep = score < classical and (asymmetric or score < (1 - MAP_GAIN) * classical)
        if not keep:
            fit.notes.append(f"output map auto: none ({numbers})")
            return fit
        why = "the loop is not point-symmetric; " if asymmetric else ""
        fit.notes.append(f"output map auto: chose deadzone, a monotone map after the PI "
                         f"(modified PI; {why}{numbers})")
    else:
        fit.notes.append(f"output map: deadzone ({numbers})")
    if val is not None and any(s.periodic and _one_branch_held(s) for s in fit.splits):
        fit.notes.append("output map: one closed loop trains on its ascending branch only, on "
                         "which the PI and the map can be traded against each other; the "
                         "held-out branch is extrapolated: record two periods or more, or train "
                         "on both branches with --hold-out none")
    fit.model, fit.predictions, fit.train, fit.validation = model, predictions, train, val
    fit.output_map = "deadzone"
    return fit


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
                    f"on both branches with --hold-out none reduces but cannot remove it)")
                break
    return notes


def _one_partition(records, splits, method, n, thresholds, partition, bounds, kinds, auto,
                   in_names, out_names, m):
    if partition == "auto":
        partition = "time"
    notes = []
    if method == "least-squares":
        r, used = zip(*[_thresholds(records, splits, k, n, partition, thresholds) for k in range(m)])
        if thresholds is None and any(u != partition for u in used):
            notes.append("inputs " + ", ".join(in_names[k] for k in range(m) if used[k] != partition)
                         + ": no complete branch, thresholds uniform in input")
        engine = _LeastSquares(records, splits, list(r), bounds)
    else:
        engine = _ClosedForm(records, splits, n, thresholds if thresholds is not None else partition)
    grid, offsets, prune_notes = _fit_structure(engine, kinds, auto, out_names, in_names,
                                                prune=bool(auto.any()))
    notes += prune_notes
    amplitude = np.zeros(m)
    for rec, s in zip(records, splits):
        amplitude = np.maximum(amplitude, np.ptp(rec.u[:, s.train], axis=1) / 2.0)
    amplitude = np.where(amplitude > 0, amplitude, 1.0)
    model = MultivariablePI(grid, in_names, out_names, amplitude, output_offset=offsets)
    predictions = [simulate_on_record(model, rec, s) for rec, s in zip(records, splits)]
    train = _window_metrics(records, splits, predictions, "train")
    val = _window_metrics(records, splits, predictions, "held_out")
    score = float(np.mean([v["rms_percent"] for v in (val or train)]))
    structure = [["pi" if isinstance(c, PrandtlIshlinskii) else "none" if c is None else "gain"
                  for c in row] for row in grid]
    return RecordFit(model, method, "explicit" if thresholds is not None else partition, {},
                     structure, notes, records, splits, train, val, predictions), score


def identify_record(record, method="least-squares", n_hysterons=15, thresholds=None,
                    partition="auto", bounds=None, train_fraction=None, skip_seconds=None,
                    hold_out="auto", components="auto", output_map="auto"):
    """Single-record form of :func:`identify_records` (same options and result).

    Parameters
    ----------
    record : MultiRecord or Record
        The record, all m inputs and p outputs.
    method : {"least-squares", "closed-form"}
        Identification method.
    n_hysterons : int
        Hysterons per component.
    thresholds : array_like, shape (n,), optional
        Explicit thresholds (input unit, e.g. [V]) for every component.
    partition : {"auto", "time", "input"}
        Threshold partition.
    bounds : None, "nonnegative" or "monotone"
        Least-squares constraints on the direct transfers.
    train_fraction : float, optional
        Split at the reversal nearest to this fraction of the samples.
    skip_seconds : float, optional
        Burn-in [s].
    hold_out : {"auto", "none"}
        Whether trailing complete branches are held out for validation.
    components : "auto", "all", str or dict
        Component kinds, see :func:`parse_components`.
    output_map : {"auto", "none", "deadzone"}
        Static output map after the PI (modified PI), see :func:`identify_records`.

    Returns
    -------
    RecordFit
        As :func:`identify_records`.

    Raises
    ------
    IdentificationError
        As :func:`identify_records`.
    """
    return identify_records([record], method, n_hysterons, thresholds, partition, bounds,
                            components, hold_out, train_fraction, skip_seconds,
                            output_map=output_map)


#: Defaults of the dynamics identified from records (:func:`identify_record_dynamics`).
DYNAMICS_DEFAULTS = {"max_order": 10, "unit_dc_gain": True, "low_pole_fraction": 0.5,
                     "cancel_tolerance": 0.01}


@dataclass
class RecordDynamics:
    """Linear dynamics G identified from broadband records (:func:`identify_record_dynamics`).

    Parameters
    ----------
    identifier : hammerstein.models.lti.DynamicsIdentifier
        The fitted identifier (``system_`` is the discrete G, G(1) = I by default).
    continuous : control.StateSpace
        G in continuous time (inverse ZOH map), p x p.
    tables : dict
        ``preset`` and ``dynamics`` tables of a preset file.
    summary : dict
        Plain data for the ``[identification.dynamics]`` table: ``order``,
        ``chosen_on`` (the held-out data), ``band_hz``, ``candidates``
        (order, held-out fit [%], kept modes, what was dropped or why the
        order was rejected), ``modes`` (frequency [Hz], damping [-] and the
        share of each axis), ``dc_gain_unconstrained`` (p, p),
        ``dc_gain`` (p, p), ``held_out_fit_percent`` and ``fit_percent``
        per output.
    frf_frequency_hz : numpy.ndarray, shape (n_freq,)
        Frequencies of the measured H1 estimate [Hz].
    frf : numpy.ndarray, shape (p, p, n_freq)
        Measured H1 frequency-response estimate of G (complex) [µm/µm].
    """

    identifier: object
    continuous: object
    tables: dict
    summary: dict
    frf_frequency_hz: np.ndarray = field(repr=False)
    frf: np.ndarray = field(repr=False)


def _held_out_records(records):
    """Indices of the last record of each excited input when every input has two or more."""
    by_input = {}
    for i, rec in enumerate(records):
        by_input.setdefault(_excitation(rec), []).append(i)
    m = records[0].u.shape[0]
    if len(by_input) == m and all(len(v) >= 2 for v in by_input.values()):
        return tuple(sorted(v[-1] for v in by_input.values()))
    return ()


def identify_record_dynamics(fit, records, name="identified", creep=None, **options):
    """Identify the linear dynamics G behind a fitted PI from broadband records.

    The Hammerstein structure ``y = G(Gamma(u)) + c`` is identified in two
    steps: ``Gamma`` and ``c`` from the (slow) hysteresis records
    (:func:`identify_records`), then G from broadband records: the PI outputs
    ``H = Gamma(u)`` are the inputs of G and ``y - c`` its outputs
    (:class:`hammerstein.models.lti.DynamicsIdentifier`, subspace method).

    What makes G trustworthy (defaults :data:`DYNAMICS_DEFAULTS`):

    * **unit static gain**: the PI, identified quasi-statically, holds the
      static gain of the actuator, so G is fitted under the constraint
      ``G(0) = I``; the unconstrained G(0) is reported;
    * **order on held-out data**: when every input has two or more
      broadband records, the last record of each input is held out whole and
      the order is chosen on it (else the last 30 % of each record);
    * **no pole outside what the data show**: poles below half the lowest
      excited frequency (estimated from the input spectrum) and modes
      whose largest gain in the band is below 1 % of G's (near pole-zero
      cancellations) are removed and B refitted; unstable orders are rejected.

    Parameters
    ----------
    fit : RecordFit
        Square p x p model.
    records : sequence of MultiRecord
        Broadband records with the same columns, one sampling period.
    name : str
        Preset name.
    creep : sequence of (Creep or None), optional
        Identified creep per output (:func:`identify_record_creep`): G's
        inputs are then the PI outputs through the creep, ``(I + C) H``
        (each record from rest), so that G(0) = I holds for the cascade the
        compensator inverts. Without it, the part of the creep faster than
        the hysteresis records but slower than the broadband band (a few %)
        would be fitted into G.
    **options
        Options of :class:`~hammerstein.models.lti.DynamicsIdentifier`
        (``order``, ``max_order``...), overriding the defaults.

    Returns
    -------
    RecordDynamics

    Raises
    ------
    IdentificationError
        On a non-square model, no records, differing sampling periods, or a
        failed identification.
    """
    model = fit.model
    if model.n_inputs != model.n_outputs:
        raise IdentificationError(
            f"dynamics: expected a square model (one displacement per PI output), found "
            f"{model.n_outputs} outputs x {model.n_inputs} inputs")
    records = _as_records(records)
    T = records[0].sampling_period
    if any(not np.isclose(r.sampling_period, T, rtol=0.01) for r in records):
        raise IdentificationError("dynamics records: expected one sampling period for all")
    off = np.zeros((model.n_outputs, 1)) if model.output_offset is None \
        else model.output_offset[:, None]
    ins = [model.simulate(r.u)[0] - off for r in records]
    if creep is not None and any(c is not None for c in creep):
        mats = creep_matrices(list(creep), T)
        ins = [linear_steps(h, mats, np.zeros(mats[0].shape[0]))[0] for h in ins]
    outs = [r.y - off for r in records]
    opts = dict(DYNAMICS_DEFAULTS)
    opts["validation_records"] = _held_out_records(records)
    opts.update({k: v for k, v in options.items() if v is not None or k == "order"})
    try:
        ident = lti.DynamicsIdentifier(**opts).fit(ins, outs, T)
        cont = lti.continuous_system(ident.system_)
        frf_f, frf = lti.frf_h1(ins, outs, T)
        in_band = (frf_f >= 0.9 * ident.band_hz_[0]) & (frf_f <= 1.1 * ident.band_hz_[1])
        frf_f, frf = frf_f[in_band], frf[:, :, in_band]
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise IdentificationError(f"dynamics: {exc}") from None
    held = opts["validation_records"]
    chosen_on = (("held-out records " + ", ".join(records[i].source for i in held)) if held
                 else ident.validation_)
    summary = _dynamics_summary(ident, cont, chosen_on, model.output_names)
    mat = lambda M: [[float(v) for v in row] for row in np.atleast_2d(np.asarray(M))]
    tables = {"preset": {"name": name, "sampling_period": float(T),
                         "description": "PI identified from records + identified linear dynamics"},
              "dynamics": {"kind": "state_space", "A": mat(cont.A), "B": mat(cont.B),
                           "C": mat(cont.C), "D": mat(cont.D)}}
    return RecordDynamics(ident, cont, tables, summary, frf_f, frf)


def _dynamics_summary(ident, cont, chosen_on, names):
    """Plain data of an identified G for ``[identification.dynamics]``."""
    p = cont.noutputs
    lam, V = np.linalg.eig(np.asarray(cont.A))
    C = np.asarray(cont.C)
    modes = []
    f_all = np.abs(lam) / (2 * np.pi)
    for i in np.argsort(f_all):
        if lam[i].imag < -1e-9 * max(abs(lam[i]), 1.0):
            continue
        share = np.abs(C @ V[:, i])
        share = share / max(share.sum(), 1e-300)
        modes.append({"frequency_hz": float(f_all[i]),
                      "damping_ratio": float(-lam[i].real / max(abs(lam[i]), 1e-300)),
                      "axis_share": {n: float(v) for n, v in zip(names, share)}})
    cands = []
    for c in ident.candidates_:
        entry = {"order": int(c["order"])}
        if "validation_fit_percent" in c:
            entry["held_out_fit_percent"] = float(c["validation_fit_percent"])
            entry["modes_hz"] = [float(m[0]) for m in c["modes"]]
        if c.get("rejected"):
            entry["rejected"] = str(c["rejected"])
        if c.get("dropped"):
            entry["dropped"] = [str(d) for d in c["dropped"]]
        cands.append(entry)
    pick = np.flatnonzero(np.asarray(ident.orders_) == ident.candidate_order_)
    held_fit = float(ident.validation_fit_[pick[0]]) if pick.size else float("nan")
    return {"order": int(ident.order_), "candidate_order": int(ident.candidate_order_),
            "chosen_on": str(chosen_on),
            "band_hz": [float(v) for v in ident.band_hz_],
            "candidates": cands, "modes": modes,
            "dc_gain_unconstrained": [[float(v) for v in row] for row in ident.dc_gain_unconstrained_],
            "dc_gain": [[float(v) for v in row] for row in lti.dc_gain(cont)],
            "unit_dc_gain": bool(ident.unit_dc_gain),
            "held_out_fit_percent": float(held_fit),
            "fit_percent": [float(v) for v in ident.fit_percent_]}


def dynamics_tables(fit, records, name="identified", **options):
    """Identify the linear dynamics behind a fitted PI and return preset tables.

    :func:`identify_record_dynamics` without the report: its ``tables``.

    Parameters
    ----------
    fit : RecordFit
        Square p x p model.
    records : sequence of MultiRecord
        Broadband records with the same columns, one sampling period.
    name : str
        Preset name.
    **options
        Options of :class:`~hammerstein.models.lti.DynamicsIdentifier`.

    Returns
    -------
    dict
        ``{"preset": {...}, "dynamics": {"kind": "state_space", "A", "B",
        "C", "D"}}`` for :func:`hammerstein.io.presets.save_model`.

    Raises
    ------
    IdentificationError
        On a non-square model, no records, differing sampling periods, or a
        failed identification.
    """
    return identify_record_dynamics(fit, records, name, **options).tables


def identify_record_creep(fit, records, dynamics=None, **options):
    """Identify the creep after a fitted hysteresis model from staircase records.

    :class:`hammerstein.identification.creep_identification.CreepIdentifier` on the
    fitted model, normalised at the frequency of the hysteresis records of
    ``fit`` (:func:`hammerstein.identification.creep_identification.hysteresis_frequency`).

    Parameters
    ----------
    fit : RecordFit
        The fitted hysteresis model and its records.
    records : sequence of MultiRecord
        Staircase records with the same columns.
    dynamics : control.StateSpace, optional
        Identified discrete dynamics G (e.g. ``RecordDynamics.identifier.system_``).
    **options
        Options of :class:`~hammerstein.identification.creep_identification.CreepIdentifier`.

    Returns
    -------
    CreepIdentifier
        Fitted.

    Raises
    ------
    IdentificationError
        On records that are not staircases or do not match the model.
    """
    opts = {"hysteresis_frequency_hz": hysteresis_frequency(fit.records)}
    opts.update({k: v for k, v in options.items() if v is not None})
    return CreepIdentifier(**opts).fit(fit.model, _as_records(records), dynamics)


# -- modified PI: static output map ---------------------------------------------------
def _segment_basis(h, knots):
    """Columns whose coefficients are the segment slopes of a piecewise-linear map.

    ``sum_j a_j psi_j(h)`` is continuous, piecewise linear with knots ``z`` and
    slope ``a_j`` on segment j, equal to ``sum_j a_j psi_j(0)`` at 0.
    """
    z = np.asarray(knots, dtype=float)
    cols = [np.minimum(h, z[0])] if z.size else [h]
    for a, b in zip(z[:-1], z[1:]):
        cols.append(np.clip(h, a, b) - a)
    if z.size:
        cols.append(np.maximum(h - z[-1], 0.0))
    return np.column_stack(cols)


def _component_thresholds(model, k, default):
    for row in model.components:
        if isinstance(row[k], PrandtlIshlinskii):
            return row[k].thresholds
    return default


def _fit_output_maps(fit, bounds, n_knots=None, iterations=None):
    n_knots = MAP_KNOTS if n_knots is None else n_knots
    iterations = MAP_ITERATIONS if iterations is None else iterations
    """Modified PI: the structure of ``fit`` plus a monotone output map per output.

    Alternating linear least squares (Kuhnen's modified PI, the operators
    fitted in turn): (a) given the map ``R(h) = c + S(h)``, the PI weights
    and an inner offset ``d`` by least squares on ``R^-1(y)`` (the direct
    transfers with non-negative weights, so that the PI draws the convex
    part of a branch and the map its saturation); (b) given
    ``h = Gamma(u) + d``, the segment slopes of ``S`` (knots at quantiles of
    h, slopes >= 1e-3 of the secant) and ``c`` by bounded least squares
    (:func:`hammerstein.identification.lsq.lstsq_bounded_below`). Starts from ``S`` = identity; keeps
    the iterate with the smallest training RMS error of ``y``.

    Returns
    -------
    (MultivariablePI, list of float)
        The model (map shifted so that ``y = S_m(Gamma(u)) + c_m`` with
        ``S_m(0) = 0``) and the training RMS per output.
    """
    model, records, splits = fit.model, fit.records, fit.splits
    m, p = model.n_inputs, model.n_outputs
    r = [_component_thresholds(model, k, model.input_amplitude[k] * np.arange(3) / 3)
         for k in range(m)]
    engine = _LeastSquares(records, splits, r, bounds or "nonnegative")
    measured = engine.y.copy()
    grid, offsets, maps, rms_out = [], [], [], []
    for l in range(p):
        kinds = list(fit.structure[l])
        y = measured[l]
        target = y
        best = None
        for _ in range(iterations + 1):
            engine.y[l] = target
            comps, d, _ = engine.fit_output(l, kinds)
            h = np.full(y.size, d)
            for k, c in enumerate(comps):
                if isinstance(c, PrandtlIshlinskii):
                    h = h + engine.phi[k] @ c.weights
                elif c is not None:
                    h = h + c * engine.lin[k]
            if not np.ptp(h) > 0:
                break
            z = np.unique(np.quantile(h, np.arange(1, n_knots + 1) / (n_knots + 1)))
            X = np.column_stack([_segment_basis(h, z), np.ones(h.size)])
            sec = max(float(np.polyfit(h, y, 1)[0]), 1e-12)
            lo = np.r_[np.full(z.size + 1, 1e-3 * sec), -np.inf]
            # smoothness prior: slope changes cost, so that S bends only where the PI cannot
            D = np.diff(np.eye(z.size + 1), axis=0)
            mu = MAP_SMOOTHING * np.sqrt(h.size) * np.ptp(h) / (z.size + 1)
            Xa = np.vstack([X, np.column_stack([mu * D, np.zeros(z.size)])])
            ya = np.concatenate([y, np.zeros(z.size)])
            coef = lstsq_bounded_below(Xa, ya, lo)
            err = float(np.sqrt(np.mean((y - X @ coef) ** 2)))
            smap = OutputMap(z, coef[:-1])
            c0 = float(coef[-1] + _segment_basis(np.zeros(1), z)[0] @ coef[:-1])   # R(0)
            if best is None or err < best[0]:
                best = (err, comps, d, smap, c0)
            target = smap.inverse(y - c0)
        engine.y[l] = y
        if best is None:
            raise IdentificationError(f"output {model.output_names[l]}: constant PI output, "
                                      f"no output map to fit")
        err, comps, d, smap, c0 = best
        grid.append(comps)
        maps.append(OutputMap(smap.knots - d, smap.slopes))
        offsets.append(c0 + float(smap.apply(np.array(d))))
        rms_out.append(err)
    return MultivariablePI(grid, model.input_names, model.output_names, model.input_amplitude,
                           output_offset=offsets, output_map=maps), rms_out
