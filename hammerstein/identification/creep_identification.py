"""Creep identified from voltage staircases, after an identified hysteresis model.

After a voltage step a piezoelectric actuator jumps (the hysteresis) and then
drifts slowly (creep, Jung and Gweon [1]_). The creep is modelled per output
as the linear operator of :mod:`hammerstein.models.creep`,

``y = G (d h + sum_k w_k x_k)``, ``tau_k dx_k/dt = h - x_k``,

with h the output of the hysteresis model [µm], lags of fixed log-spaced
time constants ``tau_k`` [s] and non-negative weights ``w_k`` [-] (a
positive sum of decaying exponentials, the creep model of Jung and Gweon and
of Croft, Shed and Devasia [2]_; a logarithmic law is such a sum with equal
weights per decade, :meth:`hammerstein.models.creep.Creep.log_law`).

What is fitted (:class:`CreepIdentifier`). The identified hysteresis model
predicts h on each staircase record; within one step h is constant, and the
model's error on the level of each step is constant too, so each step of each
output gets a free offset (a nuisance parameter that absorbs the hysteresis
model's error on the step's level). The weights are then fitted on the shape
of the drift inside the steps, including the drift left by earlier steps, by
non-negative least squares (Lawson-Hanson, :func:`scipy.optimize.nnls`) on
the regressors ``x_k`` of every lag (passed through the identified dynamics
G when given, so the ringing after each step is modelled instead of
skipped), with a small second-difference smoothing of the weights over
``log tau``. Lags much slower than the records (``tau`` above a few times
the step duration) change the output inside a step by less than the noise:
their weights are extrapolated by the smoothing and are reported as such.

Instantaneous part. The hysteresis model is identified on slow sines (1 Hz by
default): the lags much faster than that sine are complete in its loops, so
the model already holds them. The identified creep is therefore normalised to
unit gain (real part) at the frequency ``f_h`` of the hysteresis records,
``d = 1 - sum_k w_k / (1 + (2 pi f_h tau_k)^2)``, so that the hysteresis
model followed by the creep reproduces the loops it was identified on and
adds the drift at lower frequencies. ``d > sum_k w_k (1 - a_k) / (1 + a_k)``
(``a_k = exp(-T / tau_k)``) makes the discrete creep minimum phase (see
:func:`hammerstein.models.creep.creep_dynamics`).

References
----------
.. [1] H. Jung and D.-G. Gweon, "Creep characteristics of piezoelectric
   actuators", Rev. Sci. Instrum. 71(4), 1896-1900, 2000.
.. [2] D. Croft, G. Shed and S. Devasia, "Creep, hysteresis, and vibration
   compensation for piezoactuators: atomic force microscopy application",
   J. Dyn. Sys., Meas., Control 123(1), 35-43, 2001.
.. [3] C. L. Lawson and R. J. Hanson, *Solving Least Squares Problems*,
   Prentice-Hall, 1974, Chapter 23 (non-negative least squares).
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import scipy.linalg

from hammerstein.models.creep import Creep, minimum_phase_margin
from hammerstein.exceptions import IdentificationError
from hammerstein.simulation import linear_steps
from hammerstein.identification.defaults import CREEP_T_MIN
from hammerstein.identification._creep_kernels import creep_output, lag_kernel, lag_states

__all__ = ["CreepIdentifier", "CREEP_DEFAULTS", "staircase_steps", "hysteresis_frequency",
           "remove_creep", "step_level_errors", "ramps_joined"]

#: Defaults of :class:`CreepIdentifier`.
CREEP_DEFAULTS = {"t_min": CREEP_T_MIN, "t_max": 100.0, "per_decade": 2, "smoothing": 1e-3,
                  "max_rows": 200_000}

#: Minimum samples of a step (shorter steps are not used for the drift).
_MIN_STEP_SAMPLES = 10

#: The creep fit with G has one offset column per step of a record: its regressor buffer is
#: bounded by this (a record whose voltage changes at every sample is refused).
_MAX_BUFFER_BYTES = 2 ** 30


def staircase_steps(u, tolerance=None):
    """Index of the voltage step of every sample of a staircase record.

    A new step starts where any input changes by more than ``tolerance``.

    Parameters
    ----------
    u : array_like, shape (m, n_samples)
        Input voltages [V].
    tolerance : float, optional
        [V]; default 1e-6 of the largest |u| (exact staircases).

    Returns
    -------
    numpy.ndarray of int, shape (n_samples,)
        0 for the first step, increasing by one at each change.

    Examples
    --------
    >>> import numpy as np
    >>> staircase_steps(np.array([[0.0, 0.0, 5.0, 5.0, 5.0, 0.0]])).tolist()
    [0, 0, 1, 1, 1, 2]
    """
    u = np.atleast_2d(np.asarray(u, dtype=float))
    tol = tolerance if tolerance is not None else 1e-6 * max(float(np.max(np.abs(u))), 1e-300)
    change = np.any(np.abs(np.diff(u, axis=1)) > tol, axis=0)
    return np.concatenate([[0], np.cumsum(change)])


def hysteresis_frequency(records):
    """Fundamental frequency [Hz] of slow hysteresis records (largest input DFT bin).

    Parameters
    ----------
    records : sequence of MultiRecord
        Records with ``u`` (m, n_samples) and ``sampling_period`` [s].

    Returns
    -------
    float
        Frequency of the largest spectral line of the excited inputs [Hz],
        averaged over the records.
    """
    freqs = []
    for rec in records:
        u = np.asarray(rec.u, dtype=float)
        k = int(np.argmax(np.ptp(u, axis=1)))
        spec = np.abs(np.fft.rfft(u[k] - u[k].mean()))
        f = np.fft.rfftfreq(u.shape[1], rec.sampling_period)
        freqs.append(float(f[1 + int(np.argmax(spec[1:]))]) if spec.size > 1 else 1.0)
    return float(np.mean(freqs))


def remove_creep(records, creeps, output_offset=None):
    """Records with the creep removed from the outputs: ``v = (I + C)^-1 y``.

    The creep is a linear operator after the hysteresis, ``y - o = c(v - o)``
    per output (o the output offset), and the discrete creep
    ``c(z) = d + sum_k w_k (1 - a_k) / (z - a_k)`` is minimum phase when
    ``d > sum_k w_k (1 - a_k) / (1 + a_k)``
    (:func:`hammerstein.models.creep.minimum_phase_margin`), so its inverse is
    stable and v follows exactly, sample by sample, from the measured y: with
    the ZOH matrices ``(A, B, c, d)`` of the lags,
    ``v_n = (y_n - c x_n) / d``, ``x_{n+1} = A x_n + B v_n``
    (the state-space inverse of a system with an invertible direct term,
    ``x_{n+1} = (A - B c / d) x_n + B y_n / d``, e.g. Zhou, Doyle and
    Glover [4]_, Section 3.5; the lags are diagonal, so a compiled kernel
    steps them one by one). Both start from rest, as
    the records do. The hysteresis model refitted on ``(u, v)`` no longer
    takes the creep inside its loops for hysteresis.

    Parameters
    ----------
    records : sequence of MultiRecord
        Records with ``y`` (p, n_samples) [µm] and ``sampling_period`` [s]
        (other fields are kept).
    creeps : sequence of (Creep or None), length p
        Identified creep per output (None: the output is kept).
    output_offset : array_like, shape (p,), optional
        Output offset o [µm] of the hysteresis model; zero by default.

    Returns
    -------
    list of MultiRecord
        Copies of the records with ``y`` replaced by v (p, n_samples) [µm].

    Raises
    ------
    IdentificationError
        On a creep count other than p or a creep that is not minimum phase.

    References
    ----------
    .. [4] K. Zhou, J. C. Doyle and K. Glover, *Robust and Optimal Control*,
       Prentice-Hall, 1996.

    Examples
    --------
    A known creep applied to a ramp and removed again:

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> from hammerstein.models.creep import Creep
    >>> c = Creep([0.1, 1.0], [0.02, 0.03], instantaneous=0.97)
    >>> v = np.linspace(0.0, 5.0, 2000)[None, :]
    >>> y, _ = c.simulate(v, 1e-3)
    >>> rec = SimpleNamespace(y=y, sampling_period=1e-3)
    >>> back = remove_creep([rec], [c])[0].y
    >>> bool(np.allclose(back, v, atol=1e-9))
    True
    """
    out = []
    for rec in records:
        y = np.asarray(rec.y, dtype=float)
        p = y.shape[0]
        creeps = list(creeps)
        if len(creeps) != p:
            raise IdentificationError(f"creep: expected {p} entries (one per output), found "
                                      f"{len(creeps)}")
        T = float(rec.sampling_period)
        off = np.zeros(p) if output_offset is None else np.asarray(output_offset, dtype=float)
        v = y.copy()
        for l, c in enumerate(creeps):
            if c is None:
                continue
            if minimum_phase_margin(c, T) <= 0:
                raise IdentificationError(f"creep: output {l} is not minimum phase at T = {T:g} s;"
                                          f" it cannot be removed from the records")
            v[l] = creep_output(c, y[l] - off[l], T, inverse=True) + off[l]
        if dataclasses.is_dataclass(rec):
            out.append(dataclasses.replace(rec, y=v))
        else:
            new = copy.copy(rec)
            new.y = v
            out.append(new)
    return out


def step_level_errors(model, records, creeps=None, settle=0.1, outputs=None):
    """Measured minus predicted level of every step of staircase records.

    The prediction is the hysteresis model followed by the creep (when
    given), from rest, as :class:`CreepIdentifier` models it
    (``o + c(h - o)``, o the model's output offset); the linear dynamics
    have G(0) = I and have rung out ``settle`` seconds after a step, so they
    are left out. The level of a step is the mean over the samples from
    ``settle`` after its start to its end. Staircases are not used to fit
    the hysteresis, so these are held-out errors of the static model on
    levels reached from rest (the slow tracking a scan or a positioning
    task needs).

    Parameters
    ----------
    model : object
        ``simulate(u)`` returning ``(h, state)``, h shape (p, n_samples)
        [µm]; ``output_offset`` (p,) or None.
    records : sequence of MultiRecord
        Staircases (``u`` (m, n_samples) [V], ``y`` (p, n_samples) [µm],
        ``sampling_period`` [s]), from rest.
    creeps : sequence of (Creep or None), length p, optional
        Creep per output; None: the hysteresis model alone.
    settle : float
        Samples of each step within this time [s] of its start are skipped.
    outputs : sequence of array_like, optional
        The model's outputs on the records, ``model.simulate(rec.u)[0]``
        (p, n_samples) each, when already simulated (e.g. by
        :meth:`CreepIdentifier.fit`); simulated here by default.

    Returns
    -------
    list of numpy.ndarray
        Per record, shape (p, n_steps): level errors [µm]; NaN for a step
        shorter than ``settle``.

    Raises
    ------
    IdentificationError
        On a record that is not a staircase or outputs that do not match.

    Examples
    --------
    A linear model h = 2 u off by 10 % on a staircase: each level's error is
    10 % of the measured level:

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> u = np.repeat([0.0, 1.0, 3.0], 400)[None, :]
    >>> rec = SimpleNamespace(u=u, y=2.2 * u, sampling_period=1e-3)
    >>> model = SimpleNamespace(output_offset=None, simulate=lambda v: (2.0 * v, None))
    >>> np.round(step_level_errors(model, [rec])[0], 6).tolist()
    [[0.0, 0.2, 0.6]]
    """
    out = []
    records = list(records)
    if outputs is not None and len(outputs) != len(records):
        raise IdentificationError(f"creep records: expected {len(records)} model outputs (one "
                                  f"per record), found {len(outputs)}")
    for r_i, rec in enumerate(records):
        u = np.asarray(rec.u, dtype=float)
        y = np.asarray(rec.y, dtype=float)
        T = float(rec.sampling_period)
        h = np.array(model.simulate(u)[0] if outputs is None else outputs[r_i], dtype=float)
        if h.shape != y.shape:
            raise IdentificationError(f"creep records: {getattr(rec, 'source', 'record')}: "
                                      f"expected {h.shape[0]} output columns, found {y.shape[0]}")
        p = h.shape[0]
        off = np.zeros(p) if getattr(model, "output_offset", None) is None \
            else np.asarray(model.output_offset, dtype=float)
        if creeps is not None:
            for l, c in enumerate(creeps):
                if c is not None:
                    h[l] = creep_output(c, h[l] - off[l], T) + off[l]
        steps = staircase_steps(u)
        n_steps = int(steps[-1]) + 1
        start = np.searchsorted(steps, np.arange(n_steps))
        skip = int(round(settle / T))
        err = np.full((p, n_steps), np.nan)
        for j in range(n_steps):
            a, b = start[j] + skip, (start[j + 1] if j + 1 < n_steps else steps.size)
            if b > a:
                err[:, j] = np.mean(y[:, a:b] - h[:, a:b], axis=1)
        out.append(err)
    return out


def _step_responses(mats, p, N):
    """G's unit-step responses from rest, (p inputs, p outputs, N); identity if no G."""
    if mats is None:
        return np.eye(p)[:, :, None] * np.ones(N)
    return _responses(mats, np.ones((p, N)))


def ramps_joined(steps, u, min_samples):
    """Staircase step labels with each ramp between two holds joined to the hold it leads to.

    A ramp is a run of consecutive steps shorter than ``min_samples`` along which every
    input moves monotonically from the hold before it to the hold after it (a
    slew-limited staircase: one step per sample). An oscillation, whose short steps
    reverse, is left as it is (no staircase: refused by the caller).

    Parameters
    ----------
    steps : numpy.ndarray of int, shape (n_samples,)
        Each sample's step, 0, 1, ... in order (:func:`staircase_steps`).
    u : numpy.ndarray, shape (m, n_samples)
        The record's voltages [V].
    min_samples : int
        A step this long or longer is a hold.

    Returns
    -------
    steps : numpy.ndarray of int, shape (n_samples,)
    n_steps : int

    Examples
    --------
    >>> u = np.r_[np.zeros(12), 1.0, 2.0, np.full(12, 3.0), 2.5][None, :]
    >>> s, n = ramps_joined(staircase_steps(u), u, 10)
    >>> n, s[[0, 11, 12, 13, 14, 25, 26]].tolist()
    (2, [0, 0, 1, 1, 1, 1, 1])
    >>> w = np.r_[np.zeros(12), 1.0, -1.0, np.full(12, 3.0)][None, :]   # reverses: kept
    >>> ramps_joined(staircase_steps(w), w, 10)[1]
    4
    """
    steps = np.asarray(steps)
    lengths = np.bincount(steps)
    n = lengths.size
    firsts = np.r_[0, np.flatnonzero(np.diff(steps)) + 1]
    level = np.asarray(u, dtype=float)[:, firsts]                  # (m, n): each step's voltages
    short = lengths < min_samples
    target = np.arange(n)
    j = 0
    while j < n:
        if not short[j]:
            j += 1
            continue
        k = j
        while k < n and short[k]:
            k += 1                                                  # short steps j .. k - 1
        run = level[:, max(j - 1, 0):min(k + 1, n)]
        d = np.diff(run, axis=1)
        monotone = bool(np.all((d >= 0).all(axis=1) | (d <= 0).all(axis=1)))
        if monotone and (k < n or j > 0):
            target[j:k] = k if k < n else j - 1                   # the next hold (or the last)
        j = k
    kept, label = np.unique(target, return_inverse=True)
    return label[steps], int(kept.size)


def _regressors(mats, h, steps, n_steps, tau, T, stride, S=None, g=None, out=None, gap=0):
    """Regression columns of one staircase record, every ``stride``-th row of each output stacked.

    Columns: lag ``k`` of hysteresis output ``l`` through G (``l``-major),
    then the indicator of step ``j`` on output ``l`` through G. G and the
    lags are linear and time-invariant from rest, so they commute: the lags
    of G's response to ``h_l e_l`` are G's response to the lags of ``h_l e_l``
    (all p x p responses lagged in one kernel pass, :func:`_lag_states`;
    without G the lags of ``h_l`` alone, the other outputs' rows being zero);
    a step's indicator is the difference of two delayed unit steps, so its
    response is the difference of G's delayed step responses (one
    simulation per output instead of one per column, the same numbers to
    rounding), each read off the step response by a strided slice.
    ``S``: :func:`_step_responses` (at least N samples), ``g``: G's responses
    to each ``h_l e_l``, (p, p, N), when already simulated. The matrix is in
    Fortran (column) order: every column is written, and later multiplied, in
    one contiguous run; ``out``: such a matrix to fill, every entry written
    except ``gap`` columns left between the lag and the step columns.
    """
    p, N = h.shape
    K = tau.size
    nr = -(-N // stride)
    cols = np.empty((p * nr, p * (K + n_steps) + gap), order="F") if out is None else out
    c0 = p * K + gap                             # the first step column
    starts = np.r_[0, np.flatnonzero(np.diff(steps)) + 1]       # step j starts at sample a_j
    if mats is None:
        cols[:, :p * K] = 0.0
        X = lag_states(h, tau, T, stride)
        for l in range(p):
            cols[l * nr:(l + 1) * nr, l * K:(l + 1) * K] = X[l].T
    else:
        if g is None:
            g = _responses(mats, h)
        X = lag_states(g.reshape(p * p, N), tau, T, stride)     # its lags, per output of G
        for l in range(p):
            for i in range(p):
                cols[i * nr:(i + 1) * nr, l * K:(l + 1) * K] = X[l * p + i].T
    if S is None:
        S = _step_responses(mats, p, N)
    first = np.r_[-(-starts // stride), nr]      # first kept row at or after each step's start
    for l in range(p):
        for i in range(p):
            for j in range(n_steps):             # S delayed to a_j, less S delayed to a_{j + 1}
                c = cols[i * nr:(i + 1) * nr, c0 + l * n_steps + j]
                c[:first[j]] = 0.0
                c[first[j]:] = S[l, i, first[j] * stride - starts[j]::stride][:nr - first[j]]
                if j + 1 < n_steps:
                    c[first[j + 1]:] -= S[l, i, first[j + 1] * stride - starts[j + 1]::stride][
                        :nr - first[j + 1]]
    return cols


def _responses(mats, h):
    """G's responses from rest to each output of ``h`` alone, ``g[l] = G (h_l e_l)``: (p, p, N).

    Each simulated with G's column ``l`` only (B and D restricted to input
    ``l``): the other inputs are zero, so the same numbers with p times
    fewer input products per sample.
    """
    A, B, C, D = mats
    p, N = h.shape
    g = np.empty((p, p, N))
    for l in range(p):
        g[l] = linear_steps(h[l:l + 1], (A, B[:, l:l + 1], C, D[:, l:l + 1]),
                            np.zeros(A.shape[0]))[0]
    return g


def _segment_means(v, bounds):
    """Means of ``v`` (..., n) over the samples ``bounds[j]:bounds[j + 1]``: (..., n_seg).

    0 for an empty segment (the minimum-norm offset of a column of zeros).
    """
    out = np.zeros(v.shape[:-1] + (bounds.size - 1,))
    for j in range(bounds.size - 1):
        if bounds[j + 1] > bounds[j]:
            out[..., j] = np.mean(v[..., bounds[j]:bounds[j + 1]], axis=-1)
    return out


class CreepIdentifier:
    """Creep per output from staircase records and an identified hysteresis model.

    Parameters
    ----------
    time_constants : array_like, shape (K,), optional
        Lag time constants [s]; default log-spaced from ``t_min`` to ``t_max``
        with ``per_decade`` per decade (0.01-100 s, 2 per decade: 9 lags).
    t_min, t_max : float
        Range of the default time constants [s].
    per_decade : int
        Default time constants per decade.
    smoothing : float
        Weight of the second-difference penalty on the weights over log tau,
        relative to the mean squared regressor (0: plain NNLS).
    hysteresis_frequency_hz : float
        Frequency of the records the hysteresis model was identified on [Hz]
        (the creep is normalised to unit gain there); default 1 Hz, the
        ``hammerstein excitation`` sine; ``numpy.inf`` when the model is the
        instantaneous response itself (d = 1, e.g. a known hysteresis).
    max_rows : int
        Samples used per output (the records are sub-sampled evenly above it;
        creep is slow).

    Attributes
    ----------
    time_constants_ : numpy.ndarray, shape (K,)
        [s].
    weights_ : numpy.ndarray, shape (p, K)
        Fitted lag weights [-] (>= 0).
    instantaneous_ : numpy.ndarray, shape (p,)
        d per output [-] (unit gain at the hysteresis frequency).
    creeps_ : list of Creep
        One per output.
    offsets_ : list of numpy.ndarray
        Per record, shape (p, n_steps): fitted level offsets [µm] (the
        hysteresis model's error on each step).
    residual_rms_ : numpy.ndarray, shape (p,)
        RMS of the fit residual [µm] on the samples used.
    residual_rms_no_creep_ : numpy.ndarray, shape (p,)
        The same with the offsets alone (no creep) [µm]: what creep explains.
    drift_ : numpy.ndarray, shape (p,)
        Identified relative drift from 0.1 s to 10 s after a step [-]
        (``(s(10) - s(0.1)) / s(0.1)``, s the step response).
    rate_per_decade_ : numpy.ndarray, shape (p,)
        ``drift_ / 2``: the equivalent logarithmic rate [-/decade].
    identifiable_up_to_ : float
        Longest step of the records [s]; weights of lags much slower are
        extrapolated.

    Examples
    --------
    A known creep on a staircase through a static linear hysteresis (h = u),
    no noise, identified on its own lags:

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> from hammerstein.models.creep import Creep, minimum_phase_margin
    >>> from hammerstein.signals.excitation import staircase
    >>> T = 1e-3
    >>> t, u, _ = staircase(T, 10.0, hold=2.0)
    >>> true = Creep([0.1, 1.0], [0.02, 0.03])
    >>> y, _ = true.simulate(u[None, :], T)
    >>> rec = SimpleNamespace(u=u[None, :], y=y, sampling_period=T, source="stairs")
    >>> model = SimpleNamespace(n_outputs=1, output_names=["x"], output_offset=None,
    ...                         simulate=lambda v: (np.asarray(v, dtype=float), None))
    >>> ident = CreepIdentifier([0.1, 1.0], smoothing=0.0).fit(model, [rec])
    >>> np.round(ident.weights_, 4).tolist()
    [[0.02, 0.03]]
    """

    def __init__(self, time_constants=None, t_min=CREEP_DEFAULTS["t_min"],
                 t_max=CREEP_DEFAULTS["t_max"], per_decade=CREEP_DEFAULTS["per_decade"],
                 smoothing=CREEP_DEFAULTS["smoothing"], hysteresis_frequency_hz=1.0,
                 max_rows=CREEP_DEFAULTS["max_rows"]):
        if time_constants is None:
            if not (0 < t_min < t_max and np.isfinite(t_max)):
                raise IdentificationError(f"creep: t_min, t_max: expected 0 < t_min < t_max [s], "
                                          f"found {t_min!r}, {t_max!r}")
            n = max(1, int(round(np.log10(t_max / t_min) * per_decade)) + 1)
            time_constants = np.logspace(np.log10(t_min), np.log10(t_max), n)
        tau = np.atleast_1d(np.asarray(time_constants, dtype=float))
        if tau.ndim != 1 or tau.size == 0 or not np.all(np.isfinite(tau)) or np.any(tau <= 0):
            raise IdentificationError(f"creep: time_constants: expected positive times [s], found "
                                      f"{tau.tolist()}")
        if not (np.isfinite(smoothing) and smoothing >= 0):
            raise IdentificationError(f"creep: smoothing: expected >= 0, found {smoothing!r}")
        if not (hysteresis_frequency_hz > 0):       # inf: the model is the instantaneous part
            raise IdentificationError(f"creep: hysteresis_frequency_hz: expected a positive "
                                      f"frequency [Hz], found {hysteresis_frequency_hz!r}")
        self.time_constants = np.sort(tau)
        self.smoothing = float(smoothing)
        self.hysteresis_frequency_hz = float(hysteresis_frequency_hz)
        self.max_rows = int(max_rows)

    def fit(self, model, records, dynamics=None, outputs=None):
        """Fit the creep of every output.

        Parameters
        ----------
        model : object
            The identified hysteresis model: ``simulate(u)`` returns
            ``(h, state)`` with h (p, n_samples) [µm] including
            ``output_offset`` (p,) or None; ``n_outputs``, ``output_names``.
        records : sequence of MultiRecord
            Staircase records (``u`` (m, n_samples) [V], ``y`` (p, n_samples)
            [µm], ``sampling_period`` [s], ``source``), from rest.
        dynamics : control.StateSpace, optional
            Identified discrete p x p dynamics G after the creep (same
            sampling period); None: G = I (the ringing is then part of the
            residual).
        outputs : sequence of array_like, optional
            The model's outputs on the records, ``model.simulate(rec.u)[0]``
            (p, n_samples) each, when already simulated (e.g. for
            :func:`step_level_errors` on the same records); simulated here
            by default.

        Returns
        -------
        CreepIdentifier
            ``self``, fitted.

        Raises
        ------
        IdentificationError
            On no records, differing sampling periods, records with fewer than
            two steps, or outputs that do not match the model.
        """
        records = list(records)
        if not records:
            raise IdentificationError("creep records: expected at least one staircase record")
        T = float(records[0].sampling_period)
        p = int(model.n_outputs)
        for rec in records:
            if not np.isclose(rec.sampling_period, T, rtol=0.01):
                raise IdentificationError("creep records: expected one sampling period for all")
            if np.shape(rec.y)[0] != p:
                raise IdentificationError(f"creep records: {rec.source}: expected {p} output "
                                          f"columns, found {np.shape(rec.y)[0]}")
        if outputs is not None and len(outputs) != len(records):
            raise IdentificationError(f"creep records: expected {len(records)} model outputs (one "
                                      f"per record), found {len(outputs)}")
        mats = None
        if dynamics is not None:
            if not np.isclose(float(dynamics.dt), T, rtol=0.01):
                raise IdentificationError(f"creep records: sampled at {T:g} s, the dynamics at "
                                          f"{dynamics.dt!r} s")
            mats = tuple(np.asarray(M, dtype=float) for M in
                         (dynamics.A, dynamics.B, dynamics.C, dynamics.D))
        tau = self.time_constants
        K = tau.size
        n_lag = p * K
        off = np.zeros(p) if model.output_offset is None else np.asarray(model.output_offset, float)
        total = sum(np.shape(r.y)[1] for r in records)
        stride = max(1, int(np.ceil(total / self.max_rows)))
        # lag columns shared by the records, offset columns per record; the
        # offsets are free: projected out, NNLS on the lag weights alone. Each
        # record's offsets touch its own rows only (the offset block is block
        # diagonal), so the projection is made record by record. Without G an
        # offset column is a step's indicator on one output's rows: projecting
        # it out subtracts the step's mean (only output l's lags are nonzero on
        # its rows, so each output is a block of its own); with G the offsets
        # are projected by the (small) normal equations of their columns.
        # ``fits``: per record, the row blocks (output, lag columns, projected
        # lags, projected target) and what the offsets are solved from.
        H, b_vec, sum_sq, n_rows, fits, seg_counts = (np.zeros((n_lag, n_lag)), np.zeros(n_lag),
                                                       0.0, 0, [], [])
        self.identifiable_up_to_ = 0.0
        S = None                         # G's step responses, once for all records
        for r_i, rec in enumerate(records):
            u = np.asarray(rec.u, dtype=float)
            steps = staircase_steps(u)
            n_steps = int(steps[-1]) + 1
            lengths = np.bincount(steps)
            if n_steps < 2 or np.max(lengths) < _MIN_STEP_SAMPLES:
                raise IdentificationError(f"creep records: {rec.source}: expected a voltage "
                                          f"staircase (steps held >= {_MIN_STEP_SAMPLES} samples), "
                                          f"found {n_steps} step(s)")
            self.identifiable_up_to_ = max(self.identifiable_up_to_, float(lengths.max() * T))
            h = np.asarray(model.simulate(u)[0] if outputs is None else outputs[r_i], dtype=float)
            h = h - off[:, None]
            N = u.shape[1]
            rows = np.arange(0, N, stride)
            nr = rows.size
            if mats is None:         # (p, K + 1, nr): each output's lags, then its target
                y_r = (np.asarray(rec.y, dtype=float) - off[:, None] - h)[:, rows]
                Xy = np.empty((p, K + 1, nr))
                lag_kernel(np.ascontiguousarray(h), np.exp(-T / tau), stride, Xy[:, :K])
                Xy[:, K] = y_r
                bounds = np.searchsorted(steps[rows], np.arange(n_steps + 1))
                means = _segment_means(Xy, bounds)                       # (p, K + 1, n_steps)
                for j in range(n_steps):                                 # centred in place
                    Xy[:, :, bounds[j]:bounds[j + 1]] -= means[:, :, j:j + 1]
                blocks = [(l, slice(l * K, (l + 1) * K), Xy[l, :K].T, Xy[l, K])
                          for l in range(p)]
                fits.append((blocks, ("means", means)))
            else:                    # columns: lags, target, offsets (Fortran order)
                # a slew-limited staircase (excitation --slew-rate) ramps between its holds:
                # each ramp sample would be a step of its own, one offset column each (401
                # columns, 1.1 GiB, for a 2000 V/s amplifier at 20 kHz); a ramp joins the hold
                # it leads to, whose offset then starts with the ramp
                steps, n_steps = ramps_joined(steps, u, _MIN_STEP_SAMPLES)
                lengths = np.bincount(steps)
                g = _responses(mats, h)  # G h is the sum of G's responses to each output alone
                y_r = (np.asarray(rec.y, dtype=float) - off[:, None] - g.sum(axis=0))[:, rows]
                size = 8.0 * p * nr * (1 + p * (K + n_steps))
                if size > _MAX_BUFFER_BYTES:
                    # one offset column per step: a ramp or an oscillation, whose voltage changes
                    # at every sample, would ask for one column per sample (413 GiB for an 18 s
                    # record at 20 kHz behind an oscillation); a slew-limited staircase's ramps
                    # are a few columns each
                    short = int(np.count_nonzero(lengths < _MIN_STEP_SAMPLES))
                    raise IdentificationError(
                        f"creep records: {rec.source}: expected a voltage staircase (steps held "
                        f">= {_MIN_STEP_SAMPLES} samples), found {n_steps} steps, {short} of them "
                        f"shorter (a ramp or an oscillation, not a staircase): the fit would "
                        f"need {size / 2 ** 30:.3g} GiB (at most {_MAX_BUFFER_BYTES / 2 ** 30:g})")
                if S is None or S.shape[2] < N:
                    S = _step_responses(mats, p, max(np.shape(r.u)[1] for r in records))
                buf = np.empty((p * nr, 1 + p * (K + n_steps)), order="F")
                _regressors(mats, h, steps, n_steps, tau, T, stride, S, g, out=buf, gap=1)
                buf[:, n_lag] = y_r.ravel()
                Ly, O = buf[:, :n_lag + 1], buf[:, n_lag + 1:]
                G_oo = O.T @ O
                OtLy = O.T @ Ly
                # the offsets projected out in place: Ly <- Ly - O G_oo^+ O^T Ly
                P = scipy.linalg.blas.dgemm(-1.0, O, np.linalg.lstsq(G_oo, OtLy, rcond=None)[0],
                                            1.0, Ly, overwrite_c=True)
                blocks = [(l, slice(0, n_lag), P[l * nr:(l + 1) * nr, :n_lag],
                           P[l * nr:(l + 1) * nr, n_lag]) for l in range(p)]
                fits.append((blocks, ("normal", G_oo, OtLy)))
            for _, c, Lp, yp in blocks:
                H[c, c] += Lp.T @ Lp
                b_vec[c] += Lp.T @ yp
                sum_sq += float(np.sum(Lp ** 2))
                n_rows += yp.size
            seg_counts.append(n_steps)
        if self.smoothing > 0 and K >= 3:
            lam2 = self.smoothing * n_rows * (sum_sq / (n_rows * n_lag))
            D2 = np.kron(np.eye(p), np.diff(np.eye(K), 2, axis=0))
            H = H + lam2 * D2.T @ D2
        # NNLS on the Cholesky factor: min |R w - R^-T b| = min |A w - y| + const
        H = H + 1e-12 * np.trace(H) / H.shape[0] * np.eye(H.shape[0])
        R = scipy.linalg.cholesky(H, lower=False)
        try:
            from scipy.optimize import nnls  # lazy: ~0.3 s to import; creep fits only
            wflat, _ = nnls(R, scipy.linalg.solve_triangular(R, b_vec, trans="T"),
                            maxiter=50 * n_lag)
        except RuntimeError as exc:
            raise IdentificationError(f"creep: non-negative least squares failed: {exc}") from None
        w = wflat.reshape(p, K)
        offs, res_out, res0_out = [], [[] for _ in range(p)], [[] for _ in range(p)]
        for blocks, (kind, *data) in fits:
            # the offsets solve the normal equations of their columns on the target
            # less the lags, O^T (y - L w) = O^T y - (O^T L) w: without G each
            # output's step means of its target less those of its lags times w
            if kind == "means":
                means, = data
                offs.append((means[:, K] - np.einsum("lkj,lk->lj", means[:, :K], w)).ravel())
            else:
                G_oo, OtLy = data
                offs.append(np.linalg.lstsq(G_oo, OtLy[:, n_lag] - OtLy[:, :n_lag] @ wflat,
                                            rcond=None)[0])
            for l, c, Lp, yp in blocks:
                res_out[l].append(yp - Lp @ wflat[c])
                res0_out[l].append(yp)
        offs = np.concatenate(offs)
        self.time_constants_ = tau.copy()
        self.weights_ = w
        wf = 2 * np.pi * self.hysteresis_frequency_hz
        absorbed = w @ (1.0 / (1.0 + (wf * tau) ** 2))
        a = np.exp(-T / tau)
        floor = w @ ((1 - a) / (1 + a))
        self.instantaneous_ = np.maximum(1.0 - absorbed, 2.0 * floor + 1e-9)
        self.creeps_ = [Creep(tau, w[l], float(self.instantaneous_[l])) for l in range(p)]
        self.offsets_, c0 = [], 0
        for n in seg_counts:
            self.offsets_.append(np.vstack([offs[c0 + l * n:c0 + (l + 1) * n] for l in range(p)]))
            c0 += p * n
        self.residual_rms_ = np.array([np.sqrt(np.mean(np.concatenate(r) ** 2)) for r in res_out])
        self.residual_rms_no_creep_ = np.array([np.sqrt(np.mean(np.concatenate(r) ** 2))
                                                for r in res0_out])
        s = np.array([c.step_response([0.1, 10.0]) for c in self.creeps_])
        self.drift_ = (s[:, 1] - s[:, 0]) / s[:, 0]
        self.rate_per_decade_ = self.drift_ / 2.0
        self.sampling_period_ = T
        self.output_names_ = list(model.output_names)
        self.sources_ = [str(r.source) for r in records]
        return self

    def summary(self):
        """Plain data for the ``[identification.creep]`` table of a preset.

        Returns
        -------
        dict
            ``time_constants_s``, per output ``weights``, ``instantaneous``,
            ``drift_0p1_to_10s_percent``, ``rate_per_decade``,
            ``residual_rms``, ``residual_rms_without_creep`` [µm]; the
            ``hysteresis_frequency_hz``, ``identifiable_up_to_s``, ``sources``.
        """
        out = {"time_constants_s": [float(v) for v in self.time_constants_],
               "hysteresis_frequency_hz": self.hysteresis_frequency_hz,
               "identifiable_up_to_s": float(self.identifiable_up_to_),
               "smoothing": self.smoothing, "sources": list(self.sources_),
               "outputs": {}}
        for l, name in enumerate(self.output_names_):
            out["outputs"][name] = {
                "weights": [float(v) for v in self.weights_[l]],
                "instantaneous": float(self.instantaneous_[l]),
                "total": float(self.instantaneous_[l] + self.weights_[l].sum()),
                "drift_0p1_to_10s_percent": float(100 * self.drift_[l]),
                "rate_per_decade": float(self.rate_per_decade_[l]),
                "residual_rms": float(self.residual_rms_[l]),
                "residual_rms_without_creep": float(self.residual_rms_no_creep_[l])}
        return out

    def report_lines(self, output_unit="µm"):
        """Printed report: per output, drift, weights, residual with and without creep.

        Parameters
        ----------
        output_unit : str
            Unit of the outputs.

        Returns
        -------
        list of str
        """
        tau = self.time_constants_
        lines = [f"creep: {tau.size} lags, time constants {tau[0]:.3g}-{tau[-1]:.3g} s, fitted on "
                 f"{len(self.sources_)} staircase record(s) (steps up to "
                 f"{self.identifiable_up_to_:.3g} s; slower lags extrapolated); normalised to unit "
                 f"gain at {self.hysteresis_frequency_hz:.3g} Hz, the hysteresis records"]
        for l, name in enumerate(self.output_names_):
            lines.append(
                f"  {name}: drift {100 * self.drift_[l]:+.3g} % from 0.1 s to 10 s after a step "
                f"({100 * self.rate_per_decade_[l]:.3g} %/decade), instantaneous "
                f"{self.instantaneous_[l]:.4g}, weights "
                + ", ".join(f"{v:.3g}" for v in self.weights_[l])
                + f"; residual RMS {self.residual_rms_[l]:.3g} {output_unit} "
                  f"({self.residual_rms_no_creep_[l]:.3g} without creep)")
        return lines
