"""Excited band, H1 frequency response and the measurement delay (behind :mod:`hammerstein.models.lti`).

The delay between the applied inputs and the measured outputs is the
linear phase of the H1 estimate over the excited band (Pintelon and
Schoukens 2012, Section 6.3; the references of :mod:`hammerstein.models.lti`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from hammerstein.models.dynamics import DynamicsError
from hammerstein.core.lazy import lazy_module

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use
scipy_linalg = lazy_module("scipy.linalg")  # lazy: ~0.1 s CPU of `from hammerstein import ...`

from hammerstein.models._lti_systems import _records

def excited_band(inputs, sampling_period, threshold=0.01):
    """Frequency band excited by the input records (Welch power spectral density).

    The band spans the frequencies whose summed input power spectral density
    is at least ``threshold`` times its largest value (the excited lines of
    a flat multisine, the passband of a filtered noise), over each whole
    record (one Welch segment: the resolution of the record). A slow
    transient can hold most of a record's power, e.g. a lead-in ramp from
    rest to an amplifier's offset before a multisine around it: then the
    band is also taken from four Welch segments per record, each less its
    least-squares cubic (the ramp's power mostly goes: measured with ramps
    of up to 15 times the multisine's amplitude), and where that band
    reaches more than twice as high it is the one returned.

    Parameters
    ----------
    inputs : list of array_like, each shape (m, n_samples)
        Input records [any unit].
    sampling_period : float
        T [s].
    threshold : float
        Relative density that counts as excited.

    Returns
    -------
    (f_lo, f_hi) : tuple of float
        Lowest and highest excited frequency [Hz] (above 0).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(20000) * 1e-4
    >>> u = np.sin(2 * np.pi * 50 * t) + np.sin(2 * np.pi * 700 * t)
    >>> lo, hi = excited_band([u[None, :]], 1e-4)
    >>> bool(40 < lo < 55 and 690 < hi < 710)
    True
    """
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    T = float(sampling_period)
    f = np.linspace(0, 0.5 / T, 2 ** 16 + 1)
    total = np.zeros(f.size)
    parts = np.zeros(f.size)
    for u in inputs:
        u = np.atleast_2d(np.asarray(u, dtype=float))
        nper = int(min(u.shape[1], 2 ** 18))     # resolution of the whole record
        fw, pxx = scipy.signal.welch(u - u.mean(axis=1, keepdims=True), fs=1.0 / T,
                                     nperseg=nper, axis=1)
        total += np.interp(f, fw, pxx.sum(axis=0))
        fw, pxx = scipy.signal.welch(u, fs=1.0 / T, nperseg=max(min(u.shape[1], 256), nper // 4),
                                     detrend=_cubic_detrend, axis=1)
        parts += np.interp(f, fw[1:], pxx[:, 1:].sum(axis=0), left=0.0)   # no DC bin
    band = _band(f, total, threshold)
    detrended = _band(f, parts, threshold)
    return detrended if detrended[1] > 2.0 * band[1] else band


def _cubic_detrend(x):
    """``x`` (..., n) less its least-squares cubic over the last axis (a Welch segment)."""
    V = np.vander(np.linspace(-1.0, 1.0, x.shape[-1]), 4)
    flat = x.reshape(-1, x.shape[-1]).T
    return x - (V @ np.linalg.lstsq(V, flat, rcond=None)[0]).T.reshape(x.shape)


def _band(f, density, threshold):
    """(lowest, highest) frequency above 0 whose density reaches ``threshold`` of its largest."""
    dens = density[1:]
    excited = np.flatnonzero(dens >= threshold * dens.max())
    if excited.size == 0:
        return float(f[1]), float(f[-1])
    return float(f[1:][excited[0]]), float(f[1:][excited[-1]])


#: Longest default Welch segment of :func:`frf_h1` [samples] (1.2 Hz lines at 20 kHz).
MAX_NPERSEG = 2 ** 14
#: Bytes the delay search's phase table may take at once (:func:`_delay_over`, in blocks).
DELAY_BLOCK_BYTES = 2 ** 25


def frf_h1(inputs, outputs, sampling_period, nperseg=None):
    """H1 estimate of a p x m frequency response from several records.

    ``H(f) = S_yu(f) S_uu(f)^-1`` with the cross- and auto-spectral density
    matrices summed over the records (Welch averages,
    :func:`scipy.signal.csd`, Hann window), so that records exciting one
    input each combine into the full matrix (Bendat & Piersol, *Random
    Data*, 4th ed., Wiley 2010, Section 9.3; Pintelon & Schoukens [4]).

    Parameters
    ----------
    inputs : list of array_like, each shape (m, n_samples)
        Inputs of G [µm] per record.
    outputs : list of array_like, each shape (p, n_samples)
        Measured outputs [µm] per record.
    sampling_period : float
        T [s].
    nperseg : int, optional
        Welch segment length; default the largest power of two up to a
        quarter of the shortest record (at least 256 samples), at most
        :data:`MAX_NPERSEG` (longer records average more segments: a 6 M
        sample multisine's 2^20-sample segments made the delay search
        allocate 4 TiB).

    Returns
    -------
    frequency_hz : numpy.ndarray, shape (n_freq,)
        [Hz], without 0.
    H : numpy.ndarray, shape (p, m, n_freq)
        Complex frequency response [µm/µm]; NaN where ``S_uu`` is singular.

    Examples
    --------
    >>> import numpy as np, scipy.signal
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((1, 20000))
    >>> y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.5], u)
    >>> f, H = frf_h1([u], [y], 1e-3)
    >>> bool(abs(abs(H[0, 0, 0]) - 1.0) < 0.02)
    True
    """
    import scipy.signal  # lazy: ~0.5 s to import; only sensors and identification need it

    ins, outs = _records(inputs, outputs)
    T = float(sampling_period)
    if nperseg is None:
        shortest = min(u.shape[1] for u in ins)
        nperseg = max(256, 2 ** int(np.floor(np.log2(max(shortest // 4, 2)))))
        nperseg = min(nperseg, shortest, MAX_NPERSEG)
    m, p = ins[0].shape[0], outs[0].shape[0]
    Suu = Syu = f = None
    for u, y in zip(ins, outs):
        # every pair in one csd call, broadcast over (output or input a, input b): each
        # channel's Welch segments are transformed once, not once per pair;
        # S[a, b] = csd(u[b], [u; y][a]), the cross spectra of u[b] with u[a] and y[a]
        f, S = scipy.signal.csd(u[None, :, :], np.concatenate([u, y])[:, None, :], fs=1 / T,
                                nperseg=nperseg)
        Suu = S[:m] if Suu is None else Suu + S[:m]
        Syu = S[m:] if Syu is None else Syu + S[m:]
    H = np.full((p, m, f.size), np.nan, complex)
    S = np.moveaxis(Suu, -1, 0)[1:]                      # (n_freq - 1, m, m)
    ok = np.flatnonzero(np.linalg.cond(S) < 1e8)         # S_uu not singular
    H[:, :, 1 + ok] = np.moveaxis(np.moveaxis(Syu, -1, 0)[1 + ok] @ np.linalg.inv(S[ok]), 0, -1)
    return f[1:], H[:, :, 1:]


@dataclass(frozen=True)
class MeasurementDelay:
    """Acquisition delay estimated from broadband records (:func:`estimate_measurement_delay`).

    Parameters
    ----------
    delay : int
        Estimated delay [samples] (the nearest integer to ``samples``);
        meaningful only when ``problem`` is None.
    samples : float
        Group delay of the measured frequency response over the fit band
        minus the half sample of the zero-order hold [samples].
    band_hz : tuple of float
        Fit band ``(f_lo, f_hi)`` [Hz]: the upper half of the excited band.
    std : float
        Standard deviation of ``samples`` [samples] (least squares on the
        phase, inflated for the correlation of neighbouring Welch lines).
    halves : tuple of float
        ``samples`` fitted on the lower and on the upper half of the fit
        band separately [samples] (a pure delay gives the same on both).
    residual_deg : float
        Weighted RMS of the phase left once the delay and one constant phase
        per transfer are removed [deg].
    n_lines : int
        Frequency lines used.
    problem : str or None
        Why the estimate is not trusted (phase not a straight line, output
        ahead of the input, band too narrow), else None.
    checked : str or None
        What :func:`hammerstein.models.lti.check_delay_by_fit` found (the
        held-out fits of G with the delay and with one sample less), or None.
    """

    delay: int
    samples: float
    band_hz: tuple
    std: float
    halves: tuple
    residual_deg: float
    n_lines: int
    problem: str | None = None
    checked: str | None = None

    @property
    def method(self):
        """One line: how the delay was found [text]."""
        return (f"phase slope of the measured H1 frequency response over "
                f"{self.band_hz[0]:.4g}-{self.band_hz[1]:.4g} Hz ({self.n_lines} lines): group "
                f"delay {self.samples + 0.5:.2f} samples less the zero-order hold's 0.5 = "
                f"{self.samples:.2f} +- {self.std:.2f} (halves of the band {self.halves[0]:.2f} / "
                f"{self.halves[1]:.2f}), phase residual {self.residual_deg:.2g} deg"
                + (f"; {self.checked}" if self.checked else ""))


#: Largest spread [samples] between the two half-band estimates of a pure delay, beyond twice
#: the standard deviation of their difference.
DELAY_HALVES_TOLERANCE = 0.25
#: Inflation of a least-squares standard deviation over Hann-windowed, half-overlapping Welch
#: lines (neighbouring lines share about half their data).
WELCH_LINE_CORRELATION = 2.0
#: Fewest frequency lines in the fit band.
DELAY_MIN_LINES = 8


def _phase_slope(H, f, T, tau, weights):
    """``tau`` [samples] refined by weighted least squares on the wrapped residual phase.

    Model per transfer ``ab``: ``angle(H_ab(f) exp(j 2 pi f tau T)) = c_ab - 2 pi f T s``;
    returns ``(tau + s, weighted RMS residual [rad], standard deviation of tau [samples])``,
    the last from the least-squares covariance inflated by
    :data:`WELCH_LINE_CORRELATION` (neighbouring Welch lines are not independent).
    """
    for _ in range(3):
        R = H * np.exp(2j * np.pi * f * tau * T)
        rows, rhs, wts, cols = [], [], [], []
        n_tr = R.shape[0]
        for k in range(n_tr):
            ref = np.sum(weights[k] * R[k])
            ph = np.angle(R[k] * np.conj(ref))
            a = np.zeros((f.size, n_tr + 1))
            a[:, k] = 1.0
            a[:, -1] = -2 * np.pi * f * T
            rows.append(a)
            rhs.append(ph)
            wts.append(weights[k])
        A, b, w = np.vstack(rows), np.concatenate(rhs), np.sqrt(np.concatenate(wts))
        Aw = A * w[:, None]
        sol = np.linalg.lstsq(Aw, b * w, rcond=None)[0]
        tau = tau + sol[-1]
        res = (b - A @ sol) * w
    dof = max(b.size - sol.size, 1)
    cov = np.linalg.pinv(Aw.T @ Aw) * (np.sum(res ** 2) / dof)
    std = float(np.sqrt(max(cov[-1, -1], 0.0)) * WELCH_LINE_CORRELATION)
    return tau, float(np.sqrt(np.sum(res ** 2) / np.sum(w ** 2))), std


def estimate_measurement_delay(inputs, outputs, sampling_period, band_hz=None):
    """Integer acquisition delay of records, from the phase of their frequency response.

    A measured output that lags its input by ``d`` samples multiplies the
    frequency response by ``exp(-j 2 pi f d T)``: a phase falling linearly
    with frequency, 360 d f T degrees (540 deg for d = 3 at 10 kHz and
    20 kHz), while the phase of an actuator's bending modes settles to a
    constant (a multiple of -90 deg per relative degree) above them [4]. The
    H1 estimate (:func:`frf_h1`) of every transfer is taken over the upper
    half of the excited band (:func:`excited_band`), where a piezo
    actuator's modes are behind (10 Hz - 5 kHz multisines at 20 kHz:
    2.5-5 kHz); the common group delay ``tau`` of all transfers is the
    maximum over ``tau`` of ``sum_ab |sum_f H_ab(f) exp(j 2 pi f tau T)|``
    (a coherent sum, robust to phase wrapping; ``tau`` searched up to a
    quarter of the Welch segment, both signs), refined by weighted least
    squares on the residual phase (weights ``|H_ab(f)|^2``; one constant
    phase per transfer). A sampled actuator with no acquisition delay lags
    by the half sample of the zero-order hold [5]: the delay is
    ``round(tau - 0.5)``. The estimate is independent of the hysteresis
    model and of the model order of G (the records' inputs are taken as
    they are: a rate-independent hysteresis adds no linear phase).

    The estimate is refused (``problem``) when the fit band holds fewer than
    8 lines; when the two halves of the band give delays further apart
    than 0.25 samples plus twice the standard deviation of their difference
    (the phase is not a delay's straight line: a mode in the band; with the
    default band, the bands of :data:`FALLBACK_BANDS` are then tried in
    turn, the upper half of that band, above such a mode, then the quarter
    of the excited band below it, and the first estimate that passes every
    test is returned); when
    the distance of the estimate to the nearest integer plus twice its
    standard deviation exceeds half a sample (noise, or a filter's fraction
    of a sample, leaves two integers possible); or when the outputs lead
    the inputs by a sample or more.

    Parameters
    ----------
    inputs : list of array_like, each shape (m, n_samples)
        Inputs of each record [V, or any unit].
    outputs : list of array_like, each shape (p, n_samples)
        Measured outputs of each record [µm, or any unit].
    sampling_period : float
        T [s].
    band_hz : tuple of float, optional
        Fit band ``(f_lo, f_hi)`` [Hz]; default the upper half of the
        excited band.

    Returns
    -------
    MeasurementDelay
        ``delay`` [samples], the fractional estimate, the band, the
        residual and ``problem`` (None when the estimate is trusted).

    Raises
    ------
    DynamicsError
        On malformed records (shapes, non-finite values) or a non-positive
        sampling period.

    Examples
    --------
    >>> import numpy as np, scipy.signal
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((1, 16000))
    >>> y = scipy.signal.lfilter([0.0, 0.1], [1.0, -0.9], u)    # a lag sampled by a ZOH
    >>> estimate_measurement_delay([u], [y], 5e-5).delay, estimate_measurement_delay(
    ...     [u], [np.roll(y, 3)], 5e-5).delay
    (0, 3)
    """
    T = float(sampling_period)
    if not (np.isfinite(T) and T > 0):
        raise DynamicsError(f"sampling_period: expected a positive time [s], found "
                            f"{sampling_period!r}")
    ins, outs = _records(inputs, outputs)
    ins = [u - u.mean(axis=1, keepdims=True) for u in ins]
    outs = [y - y.mean(axis=1, keepdims=True) for y in outs]
    f, H = frf_h1(ins, outs, T)
    if band_hz is not None:
        return _delay_over(f, H, T, band_hz)[0]
    top = excited_band(ins, T)[1]
    found, curved = _delay_over(f, H, T, (0.5 * top, top))
    if curved:          # a mode in the upper half: the band above it, else the band below it
        tried = []
        for lo, hi in FALLBACK_BANDS:
            other, bent = _delay_over(f, H, T, (lo * top, hi * top))
            if other.problem is None:
                return other
            tried.append(f"{lo * top:.4g}-{hi * top:.4g} Hz ("
                         + ("not a straight line either" if bent else other.problem) + ")")
        found = dataclasses.replace(found, problem=f"{found.problem}; also tried "
                                                   f"{', '.join(tried)}")
    return found


#: Bands tried in turn, as fractions of the excited band's top, when the upper half's phase
#: is not a straight line (a mode in it): its upper half, above a mode there, then the
#: quarter below the upper half, below it (where a mode's group delay is 2 zeta / omega_n
#: and little more: 0.04-0.2 samples for a 1.8 kHz mode of damping 0.02 at 10 kHz).
FALLBACK_BANDS = ((0.75, 1.0), (0.25, 0.5))


def _delay_over(f, H, T, band_hz):
    """``(MeasurementDelay, curved)`` of the H1 estimate ``H`` (p, m, n_freq) over ``band_hz``;
    ``curved``: refused because the phase is not a delay's straight line (a mode in the band)."""
    lo, hi = (float(v) for v in band_hz)
    seg = int(round(1.0 / (T * (f[1] - f[0])))) if f.size > 1 else 0
    sel = (f >= lo) & (f <= hi) & np.all(np.isfinite(H), axis=(0, 1))
    f, H = f[sel], H[:, :, sel].reshape(H.shape[0] * H.shape[1], int(sel.sum()))
    if f.size < DELAY_MIN_LINES:
        return MeasurementDelay(0, float("nan"), (lo, hi), float("nan"), (float("nan"),) * 2,
                                float("nan"), int(f.size), f"only {f.size} frequency lines in "
                                             f"{lo:.4g}-{hi:.4g} Hz (at least "
                                             f"{DELAY_MIN_LINES}: a longer or broader "
                                             f"record)"), False
    weights = np.abs(H) ** 2
    reach = max(seg // 4, 4)
    grid = np.arange(-reach, reach + 0.125, 0.25)
    # coherent sum per transfer for every tau of the grid: (n_grid, n_transfers), the phase
    # table built in blocks of DELAY_BLOCK_BYTES (a long record's grid times its lines)
    J = np.empty(grid.size)
    step = max(1, DELAY_BLOCK_BYTES // (16 * f.size))
    for i in range(0, grid.size, step):
        g = grid[i:i + step]
        J[i:i + step] = np.abs(np.exp(2j * np.pi * T * g[:, None] * f[None, :]) @ H.T).sum(axis=1)
    tau, res, std = _phase_slope(H, f, T, float(grid[np.argmax(J)]), weights)
    mid = 0.5 * (lo + hi)
    halves, hstd = [], []
    for part in (f < mid, f >= mid):
        t_h, _, s_h = _phase_slope(H[:, part], f[part], T, tau, weights[:, part])
        halves.append(t_h - 0.5)
        hstd.append(s_h)

    samples = tau - 0.5
    delay = int(np.round(samples))
    problem = None
    res_deg = float(np.degrees(res))
    curved = not abs(halves[0] - halves[1]) <= DELAY_HALVES_TOLERANCE + 2 * np.hypot(*hstd)
    if curved:
        problem = (f"the phase over {lo:.4g}-{hi:.4g} Hz is not a delay's straight line (the "
                   f"band's halves give {halves[0]:.2f} and {halves[1]:.2f} samples, "
                   f"+-{hstd[0]:.2f} and +-{hstd[1]:.2f}): a mode in the band?")
    elif not abs(samples - delay) + 2 * std <= 0.5:
        problem = (f"{samples:.2f} +- {std:.2f} samples does not single out one integer (noise "
                   f"over {lo:.4g}-{hi:.4g} Hz, phase residual {res_deg:.2g} deg, or a "
                   f"fraction of a sample from a filter)")
    elif delay < 0:
        problem = (f"the outputs lead the inputs by {-samples:.2f} samples (columns swapped, or "
                   f"clocks not shared?)")
    return MeasurementDelay(delay, float(samples), (lo, hi), float(std),
                            tuple(float(h) for h in halves), res_deg, int(f.size), problem), curved
