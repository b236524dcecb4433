"""Is a measured response the drive's? The plausibility check of ``hammerstein learn``.

``learn`` learns the next drive from the error of the measured response; a
measurement that is not the drive's response (channels swapped, another
drive's record, a saturated sensor) is learnt from as readily as a genuine
one, and the next drive is wrong by as much as the record is. Before
learning, the measurement is compared with the model's prediction of the
drive it was given with (the prediction ``learn`` estimates the lag on,
:func:`hammerstein.cli._learn_rules.trial_lag`), aligned on its own lag:

* the **misfit**: the RMS Euclidean error of the measurement against the
  prediction, each output's mean removed (a sensor's zero or a creep offset
  is no sign of another record), over the samples after the fade-in, both
  low-passed at :data:`BAND_HARMONICS` times the reference's fundamental, or
  its spectral centroid where its motion lies far above the fundamental of
  its whole pattern (a Lissajous figure, a spiral: :func:`band_share`; a
  mode the model lacks, rung by a learnt drive, answers above it), as a
  share of the prediction's own RMS motion about its mean
  (:func:`prediction_misfit`). Beyond :data:`MISFIT_LIMIT` it is not a
  model error; the line then says whether the outputs permuted fit (the
  channels swapped, and in which order);
* a **flat run**: an output exactly constant for :data:`FLAT_SAMPLES`
  samples or more while the prediction moves by :data:`FLAT_MOTION` of its
  range or more there (:func:`flat_runs`): a saturated or clipped sensor,
  or a dropped-out acquisition holding its last value.

:func:`measurement_problem` gives the one line of the refusal, its causes
in the order to check them (channels swapped, another drive's measurement,
the sensor saturated), or None.
"""

from __future__ import annotations

import itertools

import numpy as np

from hammerstein.compensation.shaping import first_mode_hz

__all__ = ["MISFIT_LIMIT", "BAND_HARMONICS", "band_share", "CENTROID_MARGIN", "spectral_centroid",
           "FLAT_SAMPLES", "FLAT_MOTION", "prediction_misfit", "flat_runs", "measurement_problem", "MODEL_GAIN_TOLERANCE", "model_gains",
           "model_gain_note", "GAIN_MODE_SHARE", "gain_band", "plant_first_mode", "START_LAG_SHARE",
           "start_lag", "start_lag_text", "stepping_outputs", "STEPPING_SHARE"]

#: above this misfit (RMS error against the model's prediction of the drive, means removed,
#: below BAND_HARMONICS times the fundamental, over the prediction's RMS motion) a measurement
#: is not the drive's. Measured, genuine trials: the shortcut user's stage (a model without
#: dynamics, modes at 380/450 Hz): 0.012 for 10 and 50 Hz circles, 0.063 for an 80 um one,
#: 0.151 at 150 Hz (its first trial 21 % of the radius off), 0.075 for a learnt trial that
#: diverged to 71 % of the radius ringing the modes (0.46 over the whole band: hence the
#: band); every learn call of the tests <= 0.117, the largest 0.235 (an amplifier 20 % weaker,
#: test_evaluate_learn), 0.296 for rakotondrabe-2dof 25 % stronger with a 3 um 700 Hz mode.
#: Not the drive's: the user's 20 um circle's record given for a 10 um drive 1.01, its channels
#: swapped 1.42 (0.012 read in the right order), x held at 70 um for 30 samples 0.34 (found
#: as a flat run)
MISFIT_LIMIT = 0.5
#: an output exactly constant for at least this many samples ...
FLAT_SAMPLES = 10
#: ... while the prediction moves by at least this share of its range there is a flat run
FLAT_MOTION = 0.05
#: the misfit is taken below this many times the reference's fundamental (when known; its
#: spectral centroid instead where that is beyond CENTROID_MARGIN times the fundamental)
BAND_HARMONICS = 4
#: a reference's spectral centroid beyond this many times its fundamental sets the band instead
#: (:func:`band_share`). Measured: a circle 1.000 (one whose period was rounded to whole samples,
#: 37 Hz given as 541 samples, 1.0009), a triangle 1.037, rasters 0.68-0.81 (the slow axis'
#: power lies lower); a 37/41 Hz Lissajous figure repeating every second 39, a constant-velocity
#: spiral of 20 turns out and in every second 27
CENTROID_MARGIN = 1.05
#: outputs permuted for the swapped-channels test up to this many outputs (24 orders)
MAX_PERMUTED = 4
#: a lag beyond the delay search is named (:func:`start_lag`) when the measurement fits the
#: prediction there within MISFIT_LIMIT and within this share of its best misfit near lag 0.
#: Measured: a DAQ record started 0.2 s before a 20 Hz circle's drive (1 s at 10 kHz): 0.033
#: at 1999 samples, 0.71 at lag 0, 0.26 at the next best lag (2498: the fade-in tells the
#: periods apart); the same record started with the drive: 0.033 at lag 0
START_LAG_SHARE = 0.5


def _aligned(predicted, measured, lag, start):
    """(prediction, measurement, the measurement's first sample) from ``start``, lag removed."""
    N = min(predicted.shape[1], measured.shape[1])
    lag = int(lag)
    if lag >= 0:
        p, m = predicted[:, :N - lag], measured[:, lag:N]
    else:
        p, m = predicted[:, -lag:N], measured[:, :N + lag]
    start = min(max(int(start), 0), max(p.shape[1] - 2, 0))
    return p[:, start:], m[:, start:], start + max(lag, 0)


def band_share(fundamental_samples, reference=None):
    """The share of the sampling rate below which a measurement is compared with its
    prediction: :data:`BAND_HARMONICS` times the reference's frequency, or None (the whole
    band) when it is unknown or too fast for it.

    The reference's frequency is its fundamental, or its spectral centroid
    (:func:`spectral_centroid`) where that is above :data:`CENTROID_MARGIN` times the
    fundamental: a reference whose motion lies far above the fundamental of its whole
    pattern (a 37/41 Hz Lissajous figure repeating every second: 39 times; a spiral) is
    compared up to four times where its motion is, not low-passed away. A circle's,
    a triangle's and a raster's band is their fundamental's, as their centroid is at most
    1.04 times it (the harmonics it passes are their content).

    Parameters
    ----------
    fundamental_samples : float
        The reference's fundamental period [samples]; 0 or None: unknown.
    reference : array_like, shape (p, n_samples), optional
        The reference [µm]; None: the fundamental alone.

    Returns
    -------
    float or None
        In (0, 0.5) [-].
    """
    P = float(fundamental_samples or 0)
    if P > 0 and reference is not None:
        centroid = spectral_centroid(reference)
        if centroid * P > CENTROID_MARGIN:
            P = 1.0 / centroid
    return BAND_HARMONICS / P if P > 2 * BAND_HARMONICS + 1 else None


def spectral_centroid(reference):
    """The power-weighted mean frequency of a reference, each row's mean removed.

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].

    Returns
    -------
    float
        ``sum_k f_k |X_k|^2 / sum_k |X_k|^2`` over the rows' one-sided DFTs
        (no window) [share of the sampling rate, in [0, 0.5]]; 0 for a
        reference that does not move. A sine over whole periods: its
        frequency exactly.

    Examples
    --------
    >>> n = np.arange(2000)
    >>> r = np.vstack([np.sin(2 * np.pi * 37 * n / 2000), np.sin(2 * np.pi * 41 * n / 2000)])
    >>> round(spectral_centroid(r) * 2000, 9)
    39.0
    """
    r = np.atleast_2d(np.asarray(reference, dtype=float))
    if r.shape[1] < 2:
        return 0.0
    power = (np.abs(np.fft.rfft(r - r.mean(axis=1, keepdims=True), axis=1)) ** 2).sum(axis=0)
    total = float(power.sum())
    if not total > 0:
        return 0.0
    return float(power @ np.fft.rfftfreq(r.shape[1]) / total)


def _compared(predicted, measured, lag, start, band):
    """Both low-passed below ``band`` (zero-phase second-order Butterworth), then aligned."""
    predicted, measured = np.atleast_2d(predicted), np.atleast_2d(measured)
    if band is not None and 0 < band < 0.5 and predicted.shape[1] > 12:
        from scipy import signal      # ~1 s to import: not before a band is asked for
        b, a = signal.butter(2, 2.0 * band)
        predicted, measured = signal.filtfilt(b, a, predicted), signal.filtfilt(b, a, measured)
    p, m, _ = _aligned(predicted, measured, lag, start)
    return p, m


def prediction_misfit(predicted, measured, lag=0, start=0, band=None):
    """RMS error of a measurement against the model's prediction, per RMS motion of the prediction.

    Parameters
    ----------
    predicted, measured : numpy.ndarray, shape (p, N)
        The model's response to the drive and the measured response [µm].
    lag : int
        Samples the measurement lags the prediction (negative: leads).
    start : int
        First sample compared (after the fade-in) [samples, of the prediction].
    band : float, optional
        Both low-passed below this share of the sampling rate first
        (zero-phase second-order Butterworth; in (0, 0.5)); None: as they are.

    Returns
    -------
    float
        ``||e - mean e|| / ||y_hat - mean y_hat||`` over the samples compared
        (Frobenius norms over outputs and samples), ``e`` the measurement less
        the prediction; ``inf`` when the prediction does not move and the
        measurement does, 0 when neither moves.
    """
    p, m = _compared(predicted, measured, lag, start, band)
    e = m - p
    err = float(np.linalg.norm(e - e.mean(axis=1, keepdims=True)))
    motion = float(np.linalg.norm(p - p.mean(axis=1, keepdims=True)))
    if motion > 0:
        return err / motion
    return 0.0 if err == 0 else float("inf")


def flat_runs(predicted, measured, lag=0, start=0):
    """Runs where a measured output is exactly constant while its prediction moves.

    Parameters
    ----------
    predicted, measured : numpy.ndarray, shape (p, N)
        As for :func:`prediction_misfit` [µm].
    lag, start : int
        As for :func:`prediction_misfit` [samples].

    Returns
    -------
    list of (int, float, int, int)
        Per run (longest first): the output's index, its constant value [µm],
        and the first and last sample of the run in the measured record
        [samples]. A run holds at least ``FLAT_SAMPLES`` samples and the
        prediction moves over it by at least ``FLAT_MOTION`` of the
        prediction's range of that output.
    """
    predicted, measured = np.atleast_2d(predicted), np.atleast_2d(measured)
    p, m, offset = _aligned(predicted, measured, lag, start)
    runs = []
    for i in range(m.shape[0]):
        span = float(np.ptp(p[i])) if p.shape[1] else 0.0
        if not span > 0:
            continue
        same = np.diff(m[i]) == 0
        edges = np.flatnonzero(np.diff(np.concatenate([[0], same.astype(np.int8), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):       # same[a:b]: samples a .. b equal
            if b - a + 1 < FLAT_SAMPLES:
                continue
            if float(np.ptp(p[i, a:b + 1])) >= FLAT_MOTION * span:
                runs.append((i, float(m[i, a]), int(a + offset), int(b + offset)))
    runs.sort(key=lambda r: r[2] - r[3])
    return runs


def measurement_problem(predicted, measured, names, lag_of, start=0, fundamental_samples=0,
                        reference=None, within=None, sampling_period=None, unit="µm"):
    """The line refusing a measurement that is not the drive's response, or None.

    Parameters
    ----------
    predicted, measured : numpy.ndarray, shape (p, N)
        The model's response to the drive and the measured response [µm].
    names : sequence of str
        The outputs' names (the measured file's columns, in the model's order).
    lag_of : callable
        ``lag_of(measured)``: samples a record, shape (p, N), lags the
        prediction (:func:`hammerstein.cli._learn_rules.trial_lag`); called
        again for each order of the outputs tried.
    start : int
        First sample compared (after the fade-in) [samples].
    fundamental_samples : float
        The period of the reference's fundamental [samples]; 0: unknown
        (the misfit is then taken over the whole band). Else the misfit is
        taken below ``BAND_HARMONICS`` times the fundamental, where a
        measurement that is the drive's follows the model (a mode the model
        lacks, rung by a learnt drive, answers above it).
    reference : array_like, shape (p, N), optional
        The reference [µm]: the band is taken at the higher of its
        fundamental and its spectral centroid (:func:`band_share`).
    within : int, optional
        The delay search span [samples]; with ``sampling_period``, a misfit
        whose measurement fits the prediction at a lag beyond it names that
        lag first (:func:`start_lag`: a pre-trigger).
    sampling_period : float, optional
        T [s], for the lag in seconds.
    unit : str
        The outputs' unit, the model's (``HammersteinPlant.units[1]``), in which a flat
        run's value is given.

    Returns
    -------
    str or None
        None when the misfit is within ``MISFIT_LIMIT`` and no output has a
        flat run; else the causes in the order to check them: a start
        offset (the lag named), the channels
        swapped (when the outputs permuted fit within ``MISFIT_LIMIT``: the
        order named), another drive's measurement, the sensor saturated or
        clipped (the output, its value and the samples of its flat run), and
        for a misfit an actuator far from its model last.
    """
    names = list(names)
    measured = np.atleast_2d(measured)
    band = band_share(fundamental_samples, reference)
    lag = int(lag_of(measured))
    misfit = prediction_misfit(predicted, measured, lag, start, band)
    runs = flat_runs(predicted, measured, lag, start)
    offset = (start_lag(predicted, measured, within)
              if within is not None and sampling_period else None)
    if misfit <= MISFIT_LIMIT and not runs:
        if offset is None:
            return None
        # a pre-trigger of whole periods: the periodic part fits at the delay, the fade-in
        # does not (a tube's 30 Hz circle recorded 0.1 s early, 3 periods: learnt from, its
        # next drive 20 % off where a trial from the right record was 5.7 %)
        return (f"--measured: not the response of --drive, nothing learnt or written; likely "
                f"cause: {start_lag_text(offset, sampling_period)}")
    causes = []
    if offset is not None:     # its rest reads as a flat run, its shift as a misfit
        causes.append(start_lag_text(offset, sampling_period))
    if misfit > MISFIT_LIMIT:
        best = None
        if 1 < len(names) <= MAX_PERMUTED:
            for order in itertools.permutations(range(len(names))):
                if list(order) == list(range(len(names))):
                    continue
                permuted = measured[list(order)]
                f = prediction_misfit(predicted, permuted, lag_of(permuted), start, band)
                if best is None or f < best[0]:
                    best = (f, order)
        head = (f"--measured: not the response of --drive, nothing learnt or written: its error "
                f"against the model's prediction of the drive is {100 * misfit:.3g} % of the "
                f"prediction's motion (RMS, means removed; a model's error stays below "
                f"{100 * MISFIT_LIMIT:.3g} %)")
        if best is not None and best[0] <= MISFIT_LIMIT:
            held = ", ".join(f"the column read as {names[j]} holds {names[i]}"
                             for i, j in enumerate(best[1]) if i != j)
            read = ",".join(f"{names[i]}={names[j]}" for i, j in enumerate(best[1]))
            causes.append(f"the channels swapped: {held} (so read, the record fits the "
                          f"prediction within {100 * best[0]:.3g} %): put the header in the "
                          f"acquisition's order, or read it so (--output-columns {read} for "
                          f"columns named as the outputs)")
        else:
            causes.append("the channels swapped (no other order of the columns fits)")
        causes.append("a measurement of another drive (record --measured while --drive plays, "
                      "for this reference)")
        last = ("an actuator or amplifier far from its model (a gain changed: identify it "
                "again)")
    else:
        head = "--measured: not the response of --drive, nothing learnt or written"
        last = None
    if runs:
        i, value, a, b = runs[0]
        causes.append(f"the sensor saturated or clipped: {names[i]} stays at {value:.6g} {unit} over "
                      f"samples {a}..{b} ({b - a + 1} samples) where the prediction moves"
                      + (f" ({len(runs) - 1} more such runs)" if len(runs) > 1 else ""))
    else:
        causes.append("the sensor saturated or clipped (no output stays flat where the "
                      "prediction moves)")
    if last:
        causes.append(last)
    if len(causes) == 1:
        return f"{head}; likely cause: {causes[0]}"
    return head + "; likely causes, in order: " + "; ".join(
        f"({n}) {c}" for n, c in enumerate(causes, 1))


#: a measured output whose gain against the model's prediction of the drive departs from 1 by
#: more than this [-] is named (:func:`model_gain_note`). Measured: the outside family's
#: twenty actuators, each with its own fresh model, first drives: 0.994-1.023 (the largest
#: where identify's unconstrained G(0) was 1.02); a stage 4 % stronger on x and 2 % weaker on
#: y the next day (warmer, creep 30 % stronger): 1.040-1.047 on x, 0.983-0.984 on y, the
#: day before 0.997-1.004
MODEL_GAIN_TOLERANCE = 0.03

#: An output whose prediction moves less than this share of the most-moving output's (RMS about
#: its mean) has no gain to read: an output held while the others move (a tube's z held at 0
#: under a circle on x, y; predicted to 1e-9 µm, it read -1.348e9 and "the actuator has
#: changed")
MOTION_SHARE = 0.01


#: the gain against the model is taken below this share of the first bending mode, where
#: the mode's gain hardly depends on its identified frequency and damping (a 10 um circle at
#: 300 Hz on a 299 Hz mode, 22.7 times its static gain there, read 1.218 against a model
#: fresh from identify: "the actuator has changed" on an unchanged stage; 1.003 at 150 Hz)
GAIN_MODE_SHARE = 0.6


def gain_band(fundamental_samples, reference=None, first_mode=None):
    """The band of :func:`model_gains`: :func:`band_share`'s, below :data:`GAIN_MODE_SHARE` of the first mode.

    Parameters
    ----------
    fundamental_samples : float
        The reference's fundamental period [samples]; 0 or None: unknown.
    reference : array_like, shape (p, n_samples), optional
        The reference [µm] (its spectral centroid, :func:`band_share`).
    first_mode : float, optional
        The identified first bending mode [share of the sampling rate, f1 T];
        None: no dynamics, the band is :func:`band_share`'s.

    Returns
    -------
    float or None
        In (0, 0.5) [-], None for the whole band, or 0.0 when the reference's
        own frequency (its fundamental, or its centroid) is at or above
        :data:`GAIN_MODE_SHARE` of the mode: no gain is judged there.
    """
    band = band_share(fundamental_samples, reference)
    if first_mode is None or not first_mode > 0:
        return band
    cap = GAIN_MODE_SHARE * float(first_mode)
    if band is not None and band / BAND_HARMONICS >= cap:
        return 0.0
    return cap if band is None else min(band, cap)


def plant_first_mode(plant):
    """The first bending mode of a plant's identified dynamics, or None.

    Parameters
    ----------
    plant : HammersteinPlant

    Returns
    -------
    float or None
        ``f1 T`` [share of the sampling rate] (:func:`~hammerstein.compensation.shaping.first_mode_hz`);
        None without dynamics or without an oscillatory mode.
    """
    matrices = getattr(plant, "matrices", None) if getattr(plant, "dynamics", None) is not None \
        else None
    f1 = first_mode_hz(matrices[0], plant.sampling_period) if matrices else None
    return None if f1 is None else float(f1) * float(plant.sampling_period)


def model_gains(predicted, measured, lag=0, start=0, band=None):
    """Each measured output's gain against the model's prediction of the drive.

    The least-squares slope of the measurement on the prediction, each about
    its mean, over the samples compared (both low-passed first, as for
    :func:`prediction_misfit`): 1 where the actuator is its model.

    Parameters
    ----------
    predicted, measured : numpy.ndarray, shape (p, N)
        The model's response to the drive and the measured response [µm].
    lag, start : int
        As for :func:`prediction_misfit` [samples].
    band : float, optional
        As for :func:`prediction_misfit` [share of the sampling rate].

    Returns
    -------
    numpy.ndarray, shape (p,)
        [-]; NaN for an output whose prediction does not move, or moves less
        than :data:`MOTION_SHARE` of the most-moving output's (held).

    Examples
    --------
    >>> t = np.arange(2000) / 2000
    >>> p = np.vstack([np.sin(2 * np.pi * 5 * t), np.cos(2 * np.pi * 5 * t)])
    >>> np.round(model_gains(p, np.array([[1.04], [0.98]]) * p + 0.3), 6).tolist()
    [1.04, 0.98]
    >>> held = np.vstack([p[0], 1e-9 * p[1]])         # y held at 0, measured moving
    >>> np.round(model_gains(held, p), 6).tolist()
    [1.0, nan]
    """
    p, m = _compared(predicted, measured, lag, start, band)
    p = p - p.mean(axis=1, keepdims=True)
    m = m - m.mean(axis=1, keepdims=True)
    power = np.sum(p * p, axis=1)
    moving = (power > 0) & (power >= MOTION_SHARE ** 2 * np.max(power, initial=0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(moving, np.sum(p * m, axis=1) / np.where(moving, power, 1.0), np.nan)


#: An output of the reference held still on more than this share of its samples moves in steps
#: (a raster's slow axis): its gain against the model is not the actuator's alone.
STEPPING_SHARE = 0.5


def stepping_outputs(reference):
    """Per output, whether the reference holds it still on most samples (moves in steps).

    Parameters
    ----------
    reference : array_like, shape (p, n_samples)
        [µm].

    Returns
    -------
    numpy.ndarray of bool, shape (p,)
        True where more than :data:`STEPPING_SHARE` of the sample-to-sample steps
        are zero (to rounding) while the output moves.

    Examples
    --------
    >>> r = np.vstack([np.sin(np.linspace(0, 6, 100)), np.repeat(np.arange(4.0), 25)])
    >>> stepping_outputs(r).tolist()
    [False, True]
    """
    r = np.array(reference, dtype=float, ndmin=2)
    if r.shape[1] < 3:
        return np.zeros(r.shape[0], dtype=bool)
    d = np.abs(np.diff(r, axis=1))
    scale = np.maximum(np.max(np.abs(r), axis=1, keepdims=True), 1e-12)
    still = np.mean(d <= 1e-9 * scale, axis=1)
    return (still > STEPPING_SHARE) & (np.ptp(r, axis=1) > 0)


def model_gain_note(gains, names, stepping=None, misfit=None):
    """The note when a measured output's gain departs from its model's, or None.

    Parameters
    ----------
    gains : numpy.ndarray, shape (p,)
        :func:`model_gains` [-].
    names : sequence of str
        The outputs' names.
    stepping : array_like of bool, shape (p,), optional
        :func:`stepping_outputs` of the reference: where an output whose gain is
        off moves in steps, the hysteresis model's error on small steps is named
        beside a changed actuator (a raster's slow axis read 1.09 on a stage that
        had not changed, 1.047 on one whose gain had fallen to 0.96).
    misfit : str, optional
        What the model missed in its own records when identified
        (:func:`hammerstein.cli._hardware.identify_misfit`): the gain is then that
        model's error as much as a changed actuator's, and the note says so instead of
        concluding that the actuator changed.

    Returns
    -------
    str or None
        One line without the ``note:`` prefix when some gain departs from 1
        by more than :data:`MODEL_GAIN_TOLERANCE`.
    """
    gains = np.asarray(gains, dtype=float)
    off = np.isfinite(gains) & (np.abs(gains - 1.0) > MODEL_GAIN_TOLERANCE)
    if not np.any(off):
        return None
    text = ", ".join(f"{n} {g:.4g}" for n, g in zip(names, gains) if np.isfinite(g))
    head = (f"the measured response's gain against the model's prediction of the drive is "
            f"{text} (on the actuators it was measured on, a model fresh from identify "
            f"reads within {100 * MODEL_GAIN_TOLERANCE:g} %): ")
    rate = ("; a gain that falls as the frequency rises, on one size of circle at several "
            "frequencies, is instead a hysteresis that depends on the rate (loops wider than "
            "in the slow records), which no model class here holds: learn corrects it")
    steps = [n for n, o, st in zip(names, off, stepping if stepping is not None else
                                   [False] * len(names)) if o and st]
    if steps:
        return (head + f"on {', '.join(steps)}, which the reference moves in steps, this is "
                f"the hysteresis model's error on small steps as much as the actuator's "
                f"(a model fresh from identify reads up to 1.09 there): judge a changed actuator "
                f"on a circle or a sine; learn corrects either trial by trial")
    if misfit:
        return (head + f"the model already missed its own records when identified ({misfit}): "
                f"this is its error at this reference's frequencies as much as a changed "
                f"actuator; learn corrects either trial by trial, and identify again only if "
                f"the actuator changed (temperature, load, another amplifier gain)" + rate)
    return (head + "the actuator has changed since it was identified (temperature, load, another "
            "amplifier gain), or at this reference it moves otherwise than in the records the "
            "model was identified on (a hysteresis no model class here holds: minor loops "
            "that re-centre cycle after cycle, as a Bouc-Wen stage's); learn corrects either "
            "trial by trial, and identify on records made now (all of them, together) tells "
            "which: its model is the actuator as it is, and a gain still off against it is the "
            "class's" + rate)


def start_lag(predicted, measured, within):
    """The lag of a measurement started before its drive (a pre-trigger), or None.

    The misfit of the measurement shifted by each lag L >= 0 (``measured[:, L:]``
    against ``predicted[:, :N - L]``, each output's mean over the overlap removed, RMS
    error over the prediction's RMS motion there; by FFT, every lag up to half the
    record at once) is smallest at L beyond ``within`` (the delay search), within
    :data:`MISFIT_LIMIT`, and below :data:`START_LAG_SHARE` times the best misfit up to
    ``within``: the record started L samples before the drive.

    Parameters
    ----------
    predicted, measured : numpy.ndarray, shape (p, N)
        The model's response to the drive and the measured response [µm].
    within : int
        The delay search span [samples]: lags up to it are a delay, not a start offset.

    Returns
    -------
    int or None
        L [samples].

    Examples
    --------
    >>> t = np.arange(4000)
    >>> p = np.sin(2 * np.pi * t / 400) * np.minimum(t / 1000, 1)[None, :]
    >>> m = np.concatenate([np.zeros((1, 700)), p[:, :-700]], axis=1)
    >>> start_lag(p, m, 50)
    700
    >>> start_lag(p, p, 50) is None
    True
    """
    P = np.atleast_2d(np.asarray(predicted, dtype=float))
    M = np.atleast_2d(np.asarray(measured, dtype=float))
    N = min(P.shape[1], M.shape[1])
    if N < 16 or P.shape[0] != M.shape[0] or not (np.all(np.isfinite(P[:, :N]))
                                                    and np.all(np.isfinite(M[:, :N]))):
        return None
    P, M = P[:, :N] - P[:, :N].mean(axis=1, keepdims=True), M[:, :N] - M[:, :N].mean(
        axis=1, keepdims=True)           # conditioning only: the overlap's means are removed
    n = 1 << int(np.ceil(np.log2(2 * N)))
    lags = np.arange(N // 2 + 1)
    k = N - lags                                                   # overlap [samples]
    cross = np.fft.irfft(np.fft.rfft(M, n) * np.conj(np.fft.rfft(P, n)), n)[:, :lags.size]
    zero = np.zeros((P.shape[0], 1))
    sp = np.concatenate([zero, np.cumsum(P, axis=1)], axis=1)[:, k]      # over P[:, :k]
    sp2 = np.concatenate([zero, np.cumsum(P ** 2, axis=1)], axis=1)[:, k]
    sm = np.concatenate([zero, np.cumsum(M[:, ::-1], axis=1)], axis=1)[:, k]   # M[:, L:]
    sm2 = np.concatenate([zero, np.cumsum(M[:, ::-1] ** 2, axis=1)], axis=1)[:, k]
    var_p = (sp2 - sp ** 2 / k).sum(axis=0)
    sse = ((sm2 - sm ** 2 / k) + (sp2 - sp ** 2 / k) - 2 * (cross - sm * sp / k)).sum(axis=0)
    if not np.all(var_p > 0):
        return None
    misfit = np.sqrt(np.maximum(sse, 0.0) / var_p)
    within = max(int(within), 0)
    if within + 1 >= misfit.size:
        return None
    best = int(np.argmin(misfit[within + 1:])) + within + 1
    near = float(np.min(misfit[:within + 1]))
    if misfit[best] <= MISFIT_LIMIT and misfit[best] < START_LAG_SHARE * near:
        return best
    return None


def start_lag_text(lag, sampling_period):
    """The words for a measurement that lags its drive by ``lag`` samples (:func:`start_lag`).

    Parameters
    ----------
    lag : int
        [samples].
    sampling_period : float
        T [s].

    Returns
    -------
    str

    Examples
    --------
    >>> start_lag_text(2000, 1e-4)[:57]
    'the measured response lags the drive by 2000 samples (0.2'
    """
    return (f"the measured response lags the drive by {lag} samples ({lag * sampling_period:.4g} "
            f"s), far beyond a delay: a pre-trigger? record from the drive's first sample, or "
            f"cut the record's first {lag} samples (t from 0 at the drive's start)")
