"""Simulated characterisation experiments: displacement sensor and sine tests.

:class:`Sensor` models the inductive sensors of the paper (IBS ECL202: 40 nm
resolution, 2 kHz bandwidth; docs/identification.md). :func:`characterize` drives each input
of a simulated actuator in turn with a sine and records all outputs (Steps 1-4
of Section 3.3); :func:`identify_plant` identifies a multivariable PI model
from those records and can save it as a model file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.identification.identification import IdentificationError, MultivariableIdentifier
from hammerstein.io.presets import save_model

__all__ = ["Sensor", "characterize", "identify_plant", "identification_metadata"]


@dataclass
class Sensor:
    """Displacement sensor: first-order low-pass, white noise, quantisation.

    ``measure`` applies, in this order, the first-order low-pass of cut-off
    ``bandwidth_hz`` discretised by the bilinear (Tustin) transform with
    :func:`scipy.signal.cont2discrete` and run by :func:`scipy.signal.lfilter`
    (started in steady state on the first sample, so that an offset causes no
    transient), additive Gaussian white noise of RMS ``noise_rms``, and
    rounding to the resolution.

    Parameters
    ----------
    resolution : float
        Quantisation step [µm]; 0 disables it. Default 0.04 µm (40 nm,
        IBS ECL202, docs/identification.md).
    bandwidth_hz : float or None
        -3 dB bandwidth [Hz]; ``None`` disables the filter. Default 2000 Hz.
    noise_rms : float
        RMS of the white measurement noise [µm]. Default 0.
    seed : int or None
        Seed of :func:`numpy.random.default_rng` for the noise.

    Raises
    ------
    ValueError
        On a negative resolution or noise, or a non-positive bandwidth.
    """

    resolution: float = 0.04
    bandwidth_hz: float | None = 2000.0
    noise_rms: float = 0.0
    seed: int | None = None

    def __post_init__(self):
        if not (np.isfinite(self.resolution) and self.resolution >= 0):
            raise ValueError(f"resolution: expected >= 0 µm, found {self.resolution!r}")
        if not (np.isfinite(self.noise_rms) and self.noise_rms >= 0):
            raise ValueError(f"noise_rms: expected >= 0 µm, found {self.noise_rms!r}")
        if self.bandwidth_hz is not None and not (np.isfinite(self.bandwidth_hz)
                                                  and self.bandwidth_hz > 0):
            raise ValueError(f"bandwidth_hz: expected > 0 Hz or None, found {self.bandwidth_hz!r}")

    def measure(self, outputs, sampling_period):
        """Measured displacements.

        Parameters
        ----------
        outputs : array_like, shape (p, n_samples)
            True displacements [µm].
        sampling_period : float
            Sampling period T [s].

        Returns
        -------
        numpy.ndarray, shape (p, n_samples)
            Measured displacements [µm].

        Raises
        ------
        ValueError
            On a non-positive sampling period or non-finite outputs.
        """
        y = np.atleast_2d(np.asarray(outputs, dtype=float))
        if y.ndim != 2 or not np.all(np.isfinite(y)):
            raise ValueError(f"outputs: expected finite (p, n_samples), found shape {y.shape}")
        if not (np.isfinite(sampling_period) and sampling_period > 0):
            raise ValueError(f"sampling_period: expected > 0 s, found {sampling_period!r}")
        if self.bandwidth_hz is not None:
            import scipy.signal  # lazy: ~0.5 s to import; only a sensor with a low-pass needs it

            wc = 2 * np.pi * self.bandwidth_hz
            b, a, _ = scipy.signal.cont2discrete(([wc], [1.0, wc]), sampling_period,
                                                 method="bilinear")
            b, a = np.ravel(b), np.ravel(a)
            zi = scipy.signal.lfilter_zi(b, a)
            y = np.vstack([scipy.signal.lfilter(b, a, row, zi=zi * row[0])[0] for row in y])
        if self.noise_rms > 0:
            y = y + np.random.default_rng(self.seed).normal(0.0, self.noise_rms, y.shape)
        if self.resolution > 0:
            y = np.round(y / self.resolution) * self.resolution
        return y


def _amplitudes(amplitude, m):
    a = np.broadcast_to(np.asarray(amplitude, dtype=float), (m,)).copy() \
        if np.ndim(amplitude) == 0 else np.asarray(amplitude, dtype=float)
    if a.shape != (m,) or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise IdentificationError(f"amplitude: expected {m} positive voltages, found {amplitude!r}")
    return a


def characterize(plant, amplitude=10.0, frequency=50.0, periods=3, sensor=None):
    """Sine characterisation of each input of a simulated actuator in turn.

    Input k is ``A_k sin(2 pi f t)`` from t = 0 (0 V, zero plant state, so the
    record starts with the virgin curve) for ``periods`` periods, the other
    inputs at 0 V; all p outputs are recorded through ``sensor`` if given.

    Parameters
    ----------
    plant : HammersteinPlant
        Simulated actuator, simulated with its ``simulate``
        (:mod:`hammerstein.simulation`).
    amplitude : float or array_like, shape (m,)
        Sine amplitude per input [V].
    frequency : float
        Sine frequency [Hz].
    periods : int or float
        Record length in periods (>= 2 for a complete ascending branch after
        the virgin curve).
    sensor : Sensor, optional
        Measurement model; ideal outputs when ``None``.

    Returns
    -------
    list of (timepts, inputs, outputs)
        One record per input: ``timepts`` (N,) [s], ``inputs`` (m, N) [V],
        ``outputs`` (p, N) [µm]; the input of :class:`MultivariableIdentifier`.

    Raises
    ------
    IdentificationError
        On non-positive amplitude, frequency or too few periods.
    """
    m = plant.hysteresis.n_inputs
    amp = _amplitudes(amplitude, m)
    if not (np.isfinite(frequency) and frequency > 0):
        raise IdentificationError(f"frequency: expected > 0 Hz, found {frequency!r}")
    if not periods >= 1.5:
        raise IdentificationError(f"periods: expected >= 1.5, found {periods!r}")
    T = plant.sampling_period
    n = int(round(periods / (frequency * T))) + 1
    timepts = np.arange(n) * T
    records = []
    for k in range(m):
        inputs = np.zeros((m, n))
        inputs[k] = amp[k] * np.sin(2 * np.pi * frequency * timepts)
        outputs, _ = plant.simulate(inputs)
        if sensor is not None:
            outputs = sensor.measure(outputs, T)
        records.append((timepts, inputs, outputs))
    return records


def identification_metadata(identifier, **extra):
    """``[identification]`` table for :func:`hammerstein.io.presets.save_model`.

    Parameters
    ----------
    identifier : MultivariableIdentifier
        Fitted identifier.
    **extra
        Further TOML-ready entries (frequency_hz, amplitude_V, partition...).

    Returns
    -------
    dict
        ``method``, ``n_hysterons``, ``fit_rms_um`` (p x m nested list [µm],
        one per component), ``offsets_um`` (p x m) and the extra entries.
    """
    meta = {"method": identifier.method,
            "n_hysterons": np.asarray(identifier.n_hysterons).tolist(),
            "fit_rms_um": identifier.fit_rms_.tolist(),
            "offsets_um": identifier.offsets_.tolist()}
    for key, value in extra.items():
        if value is not None:
            meta[key] = value.tolist() if isinstance(value, np.ndarray) else value
    return meta


def identify_plant(plant, frequency, amplitude=10.0, n_hysterons=15, method="closed-form",
                   sensor=None, partition="time", periods=3, out=None, **options) -> MultivariablePI:
    """Identify a multivariable PI model of a simulated actuator at one frequency.

    Runs :func:`characterize` then :class:`MultivariableIdentifier`; the model
    keeps the plant's input and output names and the excitation amplitudes.

    Parameters
    ----------
    plant : HammersteinPlant
    frequency : float
        Identification frequency [Hz].
    amplitude : float or array_like, shape (m,)
        Excitation amplitude [V].
    n_hysterons : int or array_like, shape (p, m)
    method : {"closed-form", "least-squares"}
    sensor : Sensor, optional
    partition : {"time", "input"} or array_like
        Threshold partition (:func:`~hammerstein.identification.identification.partition_thresholds`).
    periods : int
        Periods per record.
    out : str or pathlib.Path, optional
        If given, the model is saved there with an ``[identification]`` table
        (method, frequency_hz, amplitude_V, n_hysterons, partition, fit_rms_um).
    **options
        Other options of the monovariable method (``bounds``, ``offset``).

    Returns
    -------
    MultivariablePI

    Raises
    ------
    IdentificationError
    """
    records = characterize(plant, amplitude, frequency, periods, sensor)
    ident = MultivariableIdentifier(method, n_hysterons, partition=partition, **options)
    ident.fit(records, plant.hysteresis.input_names, plant.hysteresis.output_names)
    if out is not None:
        amp = _amplitudes(amplitude, plant.hysteresis.n_inputs)
        meta = identification_metadata(
            ident, frequency_hz=float(frequency), amplitude_V=amp.tolist(),
            partition=partition if isinstance(partition, str) else "explicit",
            periods=periods, sampling_period_s=float(plant.sampling_period),
            sensor=None if sensor is None else {
                "resolution_um": sensor.resolution,
                "bandwidth_hz": sensor.bandwidth_hz if sensor.bandwidth_hz else 0.0,
                "noise_rms_um": sensor.noise_rms})
        save_model(ident.model_, out, meta)
    return ident.model_
