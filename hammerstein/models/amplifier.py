"""The voltage amplifier between a drive and the actuator: range, slew rate, bandwidth.

A piezo amplifier delivers at most its output range, changes its output at
most at its slew rate and follows a command with a finite bandwidth. A
preset describes it in an ``[amplifier]`` table, for every input or per
input::

    [amplifier]                 # every input
    range = [-10.0, 10.0]       # V, [min, max]
    slew_rate = 2.0e5           # V/s
    bandwidth_hz = 5000.0       # optional: first-order low-pass, -3 dB frequency [Hz]

    [amplifier.uy]              # optional: this input's own values (same keys)
    range = [0.0, 150.0]

``source = "records"`` (written by ``hammerstein identify``, see
:func:`records_amplifier_table`) marks limits taken from the identification
records: the range the inputs spanned and their largest slew. They are not
the amplifier's own limits but the region the model was identified on; the
hardware commands keep their drives inside them (shaping a drive that would
leave them) unless the table is widened by hand.

The simulated amplifier applies, per input and in this order (each step
keeps the signal within the range, so the order is also what reaches the
actuator):

1. the range clip ``c[k] = min(max(u[k], u_min), u_max)``;
2. the slew limit ``s[k] = s[k-1] + clip(c[k] - s[k-1], -S T, S T)``
   (S the slew rate [V/s], T the sampling period);
3. the optional first-order bandwidth ``a[k] = a[k-1] + beta (s[k] - a[k-1])``,
   ``beta = 1 - exp(-2 pi f_c T)`` (the pole of ``1 / (1 + s / (2 pi f_c))``
   mapped by ``z = exp(s T)``, unit DC gain).

Its state (``s[k-1]`` and ``a[k-1]`` per input) starts at rest (0 V, or the
range's nearest value to 0), so a record processed in chunks gives the
same voltages as one run. A drive *file* gets steps 1-2 only (the
amplifier's own bandwidth acts on it in the hardware).

Every drive is also measured: ``peak_input`` (largest ``|u|`` [V]) and
``peak_slew`` (largest ``|u[k] - u[k-1]| / T`` [V/s], the first sample
counted from rest) per input (:func:`drive_metrics`); :meth:`Amplifier.check`
compares them with the limits and reacts as ``limits`` says: ``"error"``
raises :class:`~hammerstein.exceptions.AmplifierError`, ``"warn"`` warns
(:class:`~hammerstein.exceptions.AmplifierWarning`), ``"clip"`` says
nothing; the message names the input, the peak and the limit.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from hammerstein.exceptions import AmplifierError, AmplifierWarning


__all__ = ["Amplifier", "AmplifierChannel", "LIMITS", "amplifier_from_table", "drive_metrics",
           "AMPLIFIER_KEYS", "records_amplifier_table", "records_hold_steps", "records_input_range",
           "RECORDS_SOURCE",
           "slew_limit"]

#: Reactions to a drive beyond the amplifier: name -> description.
LIMITS = {
    "clip": "saturate silently (the amplifier's own range clip and slew limit)",
    "warn": "saturate and warn once per input",
    "error": "refuse the drive",
}
#: Keys of an ``[amplifier]`` table (and of each ``[amplifier.<input>]`` table).
AMPLIFIER_KEYS = ("range", "slew_rate", "bandwidth_hz")
#: ``source`` of an ``[amplifier]`` table whose limits were measured on the identification records
RECORDS_SOURCE = "records"
#: relative tolerance of the limit checks (a drive exactly at the limit passes)
_TOL = 1e-9


@dataclass(frozen=True)
class AmplifierChannel:
    """The limits of one input's amplifier channel.

    Parameters
    ----------
    low, high : float
        Output range [V], ``low < high``; ``-inf``/``inf`` for none.
    slew_rate : float
        Largest ``|du/dt|`` [V/s]; ``inf`` for none.
    bandwidth_hz : float or None
        -3 dB frequency of the first-order low-pass [Hz]; None for none.
    """

    low: float = -math.inf
    high: float = math.inf
    slew_rate: float = math.inf
    bandwidth_hz: float | None = None

    @property
    def rest(self) -> float:
        """Output at rest [V]: 0, or the range's value nearest to 0."""
        return float(min(max(0.0, self.low), self.high))


def _number(value, where, unit, positive=True):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or (positive and value <= 0):
        kind = "a positive number" if positive else "a finite number"
        raise AmplifierError(f"{where}: expected {kind} [{unit}], found {value!r}")
    return float(value)


def _channel(table, where, base=None):
    unknown = sorted(set(table) - set(AMPLIFIER_KEYS))
    if unknown:
        raise AmplifierError(f"{where}.{unknown[0]}: unknown key (expected "
                             f"{', '.join(AMPLIFIER_KEYS)})")
    low, high, slew, bw = ((base.low, base.high, base.slew_rate, base.bandwidth_hz)
                           if base is not None else (-math.inf, math.inf, math.inf, None))
    if "range" in table:
        r = table["range"]
        if not isinstance(r, list) or len(r) != 2:
            raise AmplifierError(f"{where}.range: expected [min, max] in V, found {r!r}")
        low = _number(r[0], f"{where}.range", "V", positive=False)
        high = _number(r[1], f"{where}.range", "V", positive=False)
        if not low < high:
            raise AmplifierError(f"{where}.range: expected min < max [V], found {r!r}")
    if "slew_rate" in table:
        slew = _number(table["slew_rate"], f"{where}.slew_rate", "V/s")
    if "bandwidth_hz" in table:
        bw = _number(table["bandwidth_hz"], f"{where}.bandwidth_hz", "Hz")
    return AmplifierChannel(low, high, slew, bw)


def amplifier_from_table(table, inputs, source="preset"):
    """The :class:`Amplifier` of a preset's ``[amplifier]`` table.

    Parameters
    ----------
    table : dict or None
        The table: ``range``, ``slew_rate``, ``bandwidth_hz`` for every input,
        and optional per-input sub-tables ``<input> = {same keys}`` that
        override them. None: no amplifier (returns None).
    inputs : list of str
        The model's input names (m).
    source : str
        File name for messages.

    Returns
    -------
    Amplifier or None

    Raises
    ------
    AmplifierError
        Unknown keys or inputs, a range that is not ``[min, max]`` with
        ``min < max``, a non-positive slew rate or bandwidth; the message
        names the key, e.g. ``amplifier.uy.range``.

    Examples
    --------
    >>> amp = amplifier_from_table({"range": [-10, 10], "slew_rate": 1e5,
    ...                             "uy": {"range": [0, 150]}}, ["ux", "uy"])
    >>> amp.channels[1].low, amp.channels[1].high, amp.channels[1].slew_rate
    (0.0, 150.0, 100000.0)
    """
    if table is None:
        return None
    if not isinstance(table, dict):
        raise AmplifierError(f"{source}: amplifier: expected a table, found {table!r}")
    source_key = table.get("source")
    if source_key is not None and not isinstance(source_key, str):
        raise AmplifierError(f"{source}: amplifier.source: expected a string (e.g. "
                             f"{RECORDS_SOURCE!r}), found {source_key!r}")
    common = {k: v for k, v in table.items() if not isinstance(v, dict) and k != "source"}
    per = {k: v for k, v in table.items() if isinstance(v, dict)}
    bad = sorted(set(per) - set(inputs))
    if bad:
        raise AmplifierError(f"{source}: amplifier.{bad[0]}: not an input of the model "
                             f"(expected one of {', '.join(inputs)})")
    try:
        base = _channel(common, "amplifier")
        chans = [_channel(per[name], f"amplifier.{name}", base) if name in per else base
                 for name in inputs]
    except AmplifierError as exc:
        raise AmplifierError(f"{source}: {exc}") from None
    return Amplifier(chans, list(inputs), source_key)


def records_input_range(table, input_names):
    """The input range of the records a model was identified on, from its ``[amplifier]`` table.

    ``hammerstein identify`` writes the records' range per input in
    ``[amplifier]`` marked ``source = "records"``
    (:func:`hammerstein.models.amplifier.records_amplifier_table`). The
    exact inverse keeps its inputs there
    (:class:`hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`):
    outside it the model is extrapolated (a unipolar 0..100 V record's
    reversible terms below 0 V) and the amplifier clips the drive anyway.

    Parameters
    ----------
    table : dict or None
        The file's ``[amplifier]`` table.
    input_names : list of str
        The model's inputs (m).

    Returns
    -------
    numpy.ndarray, shape (m, 2), or None
        ``[low, high]`` per input [V]; None without a table from the records,
        with a malformed one (:func:`hammerstein.io.presets.load_plant` reports it) or with an
        input whose range is not finite.
    """
    if not isinstance(table, dict) or table.get("source") != RECORDS_SOURCE:
        return None
    try:
        amp = amplifier_from_table(table, list(input_names), "amplifier")
    except AmplifierError:
        return None
    rng = np.array([[c.low, c.high] for c in amp.channels], dtype=float)
    return rng if np.all(np.isfinite(rng)) else None


def records_amplifier_table(records, input_names):
    """The ``[amplifier]`` table of the identification records: their input range and largest slew.

    Per input, the range ``[min u, max u]`` over every record and the largest
    slew ``max |u[k] - u[k-1]| / T`` [V/s] within a record (no step across
    records; the first sample is not counted from rest, the records may
    start anywhere). A record's step out of its initial hold, or into its
    final hold, is not counted when the record moves otherwise
    (:func:`records_hold_steps`): the amplifier switched on or off abruptly
    (a real record that is 0 V for 3 s and then starts a 150 V sine at
    -87 V in one sample), not a slew the records followed. The table is
    marked ``source = "records"``: these are the limits of what the model
    was identified on, not the amplifier's.

    Parameters
    ----------
    records : sequence
        The records, each with ``u`` (m, n_samples) [V] and
        ``sampling_period`` [s] (e.g.
        :class:`hammerstein.io.datafiles.MultiRecord`).
    input_names : list of str
        The model's input names (m).

    Returns
    -------
    dict
        ``{"source": "records", "<input>": {"range": [lo, hi], "slew_rate": S}}``
        (a constant input gets a range of +-1e-6 V about its value; an input
        that never moves no ``slew_rate``).

    Raises
    ------
    AmplifierError
        No record, or records whose number of inputs is not ``len(input_names)``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> rec = SimpleNamespace(u=np.array([[0.0, 1.0, -2.0]]), sampling_period=1e-3)
    >>> records_amplifier_table([rec], ["u"])
    {'source': 'records', 'u': {'range': [-2.0, 1.0], 'slew_rate': 3000.0}}
    """
    m = len(input_names)
    if not records:
        raise AmplifierError("records_amplifier_table: no record")
    lo, hi, slew = np.full(m, np.inf), np.full(m, -np.inf), np.zeros(m)
    for rec in records:
        u = np.atleast_2d(np.asarray(rec.u, dtype=float))
        if u.shape[0] != m:
            raise AmplifierError(f"records_amplifier_table: a record has {u.shape[0]} inputs; "
                                 f"expected {m} ({', '.join(input_names)})")
        if u.shape[1] == 0:
            continue
        lo, hi = np.minimum(lo, u.min(axis=1)), np.maximum(hi, u.max(axis=1))
        if u.shape[1] > 1:
            steps = np.abs(np.diff(u, axis=1))
            for i, row in enumerate(u):
                for k in _hold_steps(row):
                    steps[i, k - 1] = 0.0
            slew = np.maximum(slew, steps.max(axis=1) / float(rec.sampling_period))
    table = {"source": RECORDS_SOURCE}
    for i, name in enumerate(input_names):
        a, b = float(lo[i]), float(hi[i])
        if not b > a:
            a, b = a - 1e-6, b + 1e-6
        chan = {"range": [a, b]}
        if slew[i] > 0:
            chan["slew_rate"] = float(slew[i])
        table[name] = chan
    return table


def _hold_steps(row):
    """Indices k of the steps ``row[k] - row[k-1]`` out of the initial hold and into the final one.

    Only when the row moves otherwise: a step that is all the row does (a
    step-response record) is its slew.
    """
    moves = np.flatnonzero(np.diff(row) != 0.0) + 1
    if moves.size < 3:
        return []
    ends = []
    if moves[0] > 1:                  # held at least two samples before its first move
        ends.append(int(moves[0]))
    if moves[-1] <= row.size - 2:     # held at least two samples after its last move
        ends.append(int(moves[-1]))
    return ends


def records_hold_steps(records, input_names):
    """The records' steps out of an initial hold or into a final hold, largest per input.

    These are the steps :func:`records_amplifier_table` does not count in
    the records' slew; ``hammerstein identify`` names those that would have
    set it.

    Parameters
    ----------
    records : sequence
        As for :func:`records_amplifier_table`.
    input_names : list of str
        The model's input names (m).

    Returns
    -------
    dict
        ``{input: (step, time, rate)}``: the fastest such step [V] (signed),
        the time of its sample from its record's start [s] and its rate
        ``|step| / T`` [V/s], for the inputs that have one.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> u = np.r_[np.zeros(4), -87.0, -86.9, -86.7, -86.4]
    >>> records_hold_steps([SimpleNamespace(u=u[None], sampling_period=0.5)], ["u"])
    {'u': (-87.0, 2.0, 174.0)}
    """
    found = {}
    for rec in records:
        u = np.atleast_2d(np.asarray(rec.u, dtype=float))
        for name, row in zip(input_names, u):
            for k in _hold_steps(row):
                step, period = float(row[k] - row[k - 1]), float(rec.sampling_period)
                if name not in found or abs(step) / period > found[name][2]:
                    found[name] = (step, k * period, abs(step) / period)
    return found


def drive_metrics(inputs, sampling_period, rest=None):
    """Peak voltage and peak slew rate of a drive, per input.

    Parameters
    ----------
    inputs : array_like, shape (m, n_samples)
        Voltages [V] at the sampling period.
    sampling_period : float
        T [s].
    rest : array_like, shape (m,), optional
        Voltage before the first sample [V] (default 0): the first step is
        counted from it.

    Returns
    -------
    peak_input : numpy.ndarray, shape (m,)
        ``max |u|`` [V].
    peak_slew : numpy.ndarray, shape (m,)
        ``max |u[k] - u[k-1]| / T`` [V/s], ``u[-1]`` = rest.

    Examples
    --------
    >>> drive_metrics([[0.5, 1.0, -2.0]], 1e-3)
    (array([2.]), array([3000.]))
    """
    u = np.atleast_2d(np.asarray(inputs, dtype=float))
    r = np.zeros(u.shape[0]) if rest is None else np.asarray(rest, dtype=float)
    if u.shape[1] == 0:
        return np.zeros(u.shape[0]), np.zeros(u.shape[0])
    steps = np.diff(np.concatenate([r[:, None], u], axis=1), axis=1)
    return np.max(np.abs(u), axis=1), np.max(np.abs(steps), axis=1) / float(sampling_period)


class Amplifier:
    """A multi-channel piezo amplifier: range clip, slew limit, optional bandwidth.

    Parameters
    ----------
    channels : list of AmplifierChannel
        One per input (m).
    inputs : list of str
        Input names, for messages.
    source : str, optional
        Where the limits come from: :data:`RECORDS_SOURCE` for limits
        measured on the identification records (a soft bound: the hardware
        commands shape a drive into it), None for the amplifier's own.

    Notes
    -----
    The state is a flat vector of length ``2 m``: the slew limiter's last
    output then the low-pass's last output per input [V]; :meth:`rest_state`
    is the amplifier at rest. See the module docstring for the equations.

    Examples
    --------
    >>> import numpy as np
    >>> amp = Amplifier([AmplifierChannel(-10.0, 10.0, slew_rate=1000.0)], ["u"])
    >>> out, state = amp.apply(np.array([[12.0, 12.0, 12.0]]), 1e-3)
    >>> out                                   # 1 V per 1 ms sample, then the range
    array([[1., 2., 3.]])
    """

    def __init__(self, channels, inputs, source=None):
        self.channels = list(channels)
        self.inputs = list(inputs)
        self.source = source
        if len(self.channels) != len(self.inputs):
            raise AmplifierError(f"amplifier: expected one channel per input ({len(self.inputs)}), "
                                 f"found {len(self.channels)}")

    def __repr__(self):
        return f"Amplifier({self.channels!r}, {self.inputs!r}, {self.source!r})"

    @property
    def from_records(self) -> bool:
        """True when the limits were measured on the identification records."""
        return self.source == RECORDS_SOURCE

    @property
    def n_inputs(self) -> int:
        """m."""
        return len(self.channels)

    @property
    def has_bandwidth(self) -> bool:
        """True when some channel has a finite bandwidth."""
        return any(c.bandwidth_hz is not None for c in self.channels)

    def rest_voltages(self):
        """Each input's rest voltage: 0, or its range's value nearest 0.

        Returns
        -------
        numpy.ndarray, shape (m,)
            [V].
        """
        return np.array([c.rest for c in self.channels], dtype=float)

    def rest_state(self):
        """The state at rest: every channel at its rest voltage.

        Returns
        -------
        numpy.ndarray, shape (2 m,)
            [V].
        """
        r = self.rest_voltages()
        return np.concatenate([r, r])

    def range_widths(self):
        """Each input's range width ``high - low`` [V], or None when one has no finite range.

        Returns
        -------
        numpy.ndarray, shape (m,), or None
        """
        widths = np.array([c.high - c.low for c in self.channels], dtype=float)
        return widths if np.all(np.isfinite(widths)) else None

    def limit(self, inputs, sampling_period, state=None):
        """Range clip and slew limit (steps 1-2): what a drive file may command.

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            Commanded voltages [V].
        sampling_period : float
            T [s].
        state : array_like, shape (2 m,), optional
            As returned by a previous call (only its first m values are
            used here); rest by default.

        Returns
        -------
        limited : numpy.ndarray, shape (m, n_samples)
            [V].
        state : numpy.ndarray, shape (2 m,)
            The slew limiter's last outputs, then the low-pass state unchanged.

        Raises
        ------
        AmplifierError
            When ``inputs`` does not have one row per channel.
        """
        u = np.array(inputs, dtype=float, ndmin=2)
        st = self.rest_state() if state is None else np.array(state, dtype=float)
        m = self.n_inputs
        if u.shape[0] != m:
            raise AmplifierError(f"inputs: expected {m} rows, one per amplifier channel "
                                 f"({', '.join(self.inputs)}), found {u.shape[0]}")
        for i, c in enumerate(self.channels):
            x = np.clip(u[i], c.low, c.high)
            step = c.slew_rate * float(sampling_period)
            prev = st[i]
            if math.isfinite(step) and x.size:
                d = np.diff(np.concatenate([[prev], x]))
                if np.any(np.abs(d) > step * (1 + _TOL)):
                    x = _slew_limit(x, prev, step)
            u[i] = x
            if x.size:
                st[i] = x[-1]
        return u, st

    def apply(self, inputs, sampling_period, state=None):
        """What reaches the actuator: range clip, slew limit, then the bandwidth (steps 1-3).

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            Commanded voltages [V].
        sampling_period : float
            T [s].
        state : array_like, shape (2 m,), optional
            Rest by default; chunked calls passing the returned state equal
            one call.

        Returns
        -------
        outputs : numpy.ndarray, shape (m, n_samples)
            [V].
        state : numpy.ndarray, shape (2 m,)
        """
        u, st = self.limit(inputs, sampling_period, state)
        m = self.n_inputs
        for i, c in enumerate(self.channels):
            if c.bandwidth_hz is None or u.shape[1] == 0:
                st[m + i] = u[i, -1] if u.shape[1] else st[m + i]
                continue
            beta = 1.0 - math.exp(-2.0 * math.pi * c.bandwidth_hz * float(sampling_period))
            u[i], st[m + i] = _first_order(u[i], st[m + i], beta)
        return u, st

    def violations(self, inputs, sampling_period, rest=None, unit="V"):
        """The limits a commanded drive exceeds, one message per input and limit.

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            [V].
        sampling_period : float
            T [s].
        rest : array_like, shape (m,), optional
            Voltage before the first sample; the channels' rest by default.
        unit : str
            The inputs' unit, the model's (``HammersteinPlant.units[0]``): the messages'.

        Returns
        -------
        list of str
            e.g. ``"input ux needs 19.4 V at t = 0.0125 s, beyond the amplifier's range
            [-10, 10] V"`` (the first sample of the peak).
        """
        u = np.atleast_2d(np.asarray(inputs, dtype=float))
        r = self.rest_state()[:self.n_inputs] if rest is None else rest
        _, slew = drive_metrics(u, sampling_period, r)
        out = []
        for i, c in enumerate(self.channels):
            if u.shape[1] == 0:
                continue
            lo, hi = float(np.min(u[i])), float(np.max(u[i]))
            tol = _TOL * max(abs(c.low) if math.isfinite(c.low) else 0.0,
                             abs(c.high) if math.isfinite(c.high) else 0.0, 1.0)
            if hi > c.high + tol or lo < c.low - tol:
                peak = hi if hi > c.high + tol else lo
                k = int(np.argmax(u[i]) if peak == hi else np.argmin(u[i]))
                out.append(f"input {self.inputs[i]} needs {peak:.4g} {unit} at t = "
                           f"{k * sampling_period:.4g} s, beyond the amplifier's "
                           f"range [{c.low:g}, {c.high:g}] {unit}")
            if slew[i] > c.slew_rate * (1 + _TOL):
                out.append(f"input {self.inputs[i]} needs a slew rate of {slew[i]:.4g} {unit}/s, "
                           f"beyond the amplifier's {c.slew_rate:.4g} {unit}/s")
        return out

    def check(self, inputs, sampling_period, limits="error", where="", unit="V"):
        """React to a drive beyond the limits as ``limits`` says.

        Parameters
        ----------
        inputs : array_like, shape (m, n_samples)
            Commanded voltages [V].
        sampling_period : float
            T [s].
        limits : {'error', 'warn', 'clip'}
            Raise, warn once per problem, or say nothing.
        where : str
            Prefix of the messages (e.g. the case name).
        unit : str
            The inputs' unit, the model's (``HammersteinPlant.units[0]``): the messages'.

        Returns
        -------
        list of str
            The problems found (also when only warned or clipped).

        Raises
        ------
        AmplifierError
            ``limits = "error"`` and a limit is exceeded; an unknown ``limits``.

        Warns
        -----
        AmplifierWarning
            ``limits = "warn"``: one per problem.
        """
        if limits not in LIMITS:
            raise AmplifierError(f"limits: expected one of {', '.join(map(repr, LIMITS))}, "
                                 f"found {limits!r}")
        problems = self.violations(inputs, sampling_period, unit=unit)
        pre = f"{where}: " if where else ""
        if problems and limits == "error":
            raise AmplifierError(pre + "; ".join(problems) + " (limits = 'error'; lower the "
                                 "reference, or use limits = 'clip' or 'warn' to saturate)")
        if limits == "warn":
            for p in problems:
                warnings.warn(pre + p + " (saturated)", AmplifierWarning, stacklevel=2)
        return problems


def slew_limit(x, start, step):
    """A signal slew-limited from ``start``: ``s[k] = s[k-1] + clip(x[k] - s[k-1], -step, step)``.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        [V].
    start : float
        ``s[-1]`` [V].
    step : float
        Largest step per sample [V], > 0.

    Returns
    -------
    numpy.ndarray, shape (n_samples,)

    Examples
    --------
    >>> slew_limit([3.0, 3.0, 0.0], 0.0, 1.0).tolist()
    [1.0, 2.0, 1.0]
    """
    return _slew_limit(np.asarray(x, dtype=float), start, step)


def _slew_limit(x, prev, step):
    """``s[k] = s[k-1] + clip(x[k] - s[k-1], -step, step)`` (a plain loop: only when it acts)."""
    out = np.empty_like(x)
    s = float(prev)
    for k in range(x.size):
        d = x[k] - s
        if d > step:
            d = step
        elif d < -step:
            d = -step
        s += d
        out[k] = s
    return out


def _first_order(x, prev, beta):
    """``a[k] = a[k-1] + beta (x[k] - a[k-1])`` from ``a[-1] = prev``: (outputs, last)."""
    a = 1.0 - beta
    y, _ = _scipy_signal().lfilter([beta], [1.0, -a], x, zi=[a * float(prev)])
    return y, float(y[-1])


def _scipy_signal():
    """scipy.signal, imported on first use (about 0.3 s; a plain preset simulation never needs it)."""
    import scipy.signal
    return scipy.signal
