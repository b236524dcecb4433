"""What the broadband records can tell about G, measured on them: band, amplitude, noise.

``identify --dynamics`` fits G on the multisine records; when it fails, or its model fits
the held-out records poorly, the cause is most often in the records themselves, and it can
be measured there rather than guessed:

* the **band**: the highest frequency the inputs excite, against the Nyquist frequency (a
  slew rate narrows the default band of ``hammerstein excitation``: a band far below the
  first bending modes holds nothing for G to identify);
* the **amplitude**: the multisines' peak input against the hysteresis records' (``excitation``
  plays them at 80 %; a slew rate scales them further down, ``--f-max`` more so);
* the **noise**: a multisine of P identical periods repeats its response; what differs from
  period to period is the noise (Pintelon & Schoukens, *System Identification: A Frequency
  Domain Approach*, 2nd ed., 2012, Section 2.5). Against the response it bounds the held-out
  fit any model reaches: ``100 (1 - noise RMS / output RMS)``.

:func:`broadband_conditions` measures them; :func:`dynamics_advice` turns them, and the modes
identified, into the cause and the option that helps.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hammerstein.models import lti

#: A band ending below this fraction of the Nyquist frequency is "narrow": the default
#: multisine band of ``hammerstein excitation`` is half the Nyquist frequency at 20 kHz and
#: below (:func:`hammerstein.signals.excitation.default_f_max`).
NARROW_BAND = 0.25
#: A first mode above this fraction of the Nyquist frequency is sampled at fewer than five
#: samples per period; modes above Nyquist fold next to it when nothing filters them.
NEAR_NYQUIST = 0.4
#: Below this ceiling [%] on the held-out fit (:func:`broadband_conditions`) the noise
#: decides the fit: a perfect G fits no better.
NOISY_CEILING = 90.0
#: Records at or above this rate [Hz] whose multisines reach beyond :data:`SPREAD_BAND` times
#: the highest identified mode have spread their power away from the modes: measured on a
#: tester's 50 kHz records (band to 12.5 kHz, modes at 350 and 520 Hz), held-out fit 78.7 %
#: against 96.1 % from the same actuator's 10 kHz records (dynamics decimated alike)
FAST_RECORDS_HZ = 25e3
SPREAD_BAND = 10.0
#: The multisines are "scaled down" below this share of the hysteresis records' amplitude
#: (``excitation`` plays them at 80 %; below half, a slew rate or ``--f-max`` scaled them).
SCALED_SHARE = 0.5


def _periods(u, y, tolerance=1e-6):
    """``(P, N)``: the record holds P >= 2 identical input periods of N samples, else None."""
    n = u.shape[1]
    scale = max(float(np.max(np.abs(u))), 1e-300)
    for P in range(min(n // 8, 64), 1, -1):     # most periods first: the shortest period
        if n % P:
            continue
        N = n // P
        parts = u.reshape(u.shape[0], P, N)
        if np.max(np.abs(parts - parts[:, :1])) <= tolerance * scale + 1e-12:
            return P, N
    return None


def broadband_conditions(dynamics_records, hysteresis_records=()):
    """Band, amplitude and noise of broadband records (measured on them alone).

    Parameters
    ----------
    dynamics_records : sequence of MultiRecord
        The broadband records (inputs [V], outputs [µm]), one sampling period.
    hysteresis_records : sequence of MultiRecord, optional
        The hysteresis records, whose peak input the multisines' amplitude is compared with.

    Returns
    -------
    dict
        ``band_hz`` (lowest, highest excited frequency of the inputs [Hz]),
        ``nyquist_hz``, ``amplitude`` (the broadband inputs' largest peak from their
        mean [input unit]), ``amplitude_share`` (the smallest and largest record's
        peak over the hysteresis records' peak from their mean; None without them),
        ``noise_rms`` and ``response_rms`` (per output, [output unit]: the RMS of what
        differs between a record's periods, of the period average less its mean; None
        when no record repeats its input), ``fit_ceiling_percent`` (the held-out fit
        ``100 (1 - noise / output RMS)`` a noiseless-model reaches, averaged over the
        outputs as the fit is; None without the noise) and ``files`` (the sources).

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.io.datafiles import MultiRecord
    >>> t = np.arange(4000) * 1e-4
    >>> u = np.sin(2 * np.pi * 100 * t)[None, :]
    >>> y = 2 * u + 0.1 * np.random.default_rng(0).standard_normal(u.shape)
    >>> c = broadband_conditions([MultiRecord(t, u, y, ("u",), ("y",), 1e-4, "a.csv")])
    >>> round(c["noise_rms"][0], 2), round(c["response_rms"][0], 2), c["nyquist_hz"]
    (0.1, 1.41, 5000.0)
    """
    recs = list(dynamics_records)
    T = float(recs[0].sampling_period)
    centred = [r.u - r.u.mean(axis=1, keepdims=True) for r in recs]
    band = lti.excited_band(centred, T)
    peaks = [float(np.max(np.abs(u))) for u in centred]
    share = None
    hyst = [np.max(np.abs(r.u - r.u.mean(axis=1, keepdims=True))) for r in hysteresis_records]
    if hyst and max(hyst) > 0:
        share = (min(peaks) / float(max(hyst)), max(peaks) / float(max(hyst)))
    p = recs[0].y.shape[0]
    noise, power, response = np.zeros(p), np.zeros(p), np.zeros(p)
    count = 0
    for r in recs:
        found = _periods(r.u, r.y)
        if found is None:
            continue
        P, N = found
        parts = r.y.reshape(p, P, N)[:, 1:] if P >= 3 else r.y.reshape(p, P, N)  # transient out
        mean = parts.mean(axis=1)
        noise += ((parts - mean[:, None, :]) ** 2).sum(axis=(1, 2)) / (N * (parts.shape[1] - 1))
        response += np.var(mean, axis=1)
        power += np.var(r.y, axis=1)
        count += 1
    out = {"band_hz": (float(band[0]), float(band[1])), "nyquist_hz": 0.5 / T,
           "amplitude": max(peaks), "amplitude_share": share, "noise_rms": None,
           "response_rms": None, "fit_ceiling_percent": None,
           "files": [r.source for r in recs]}
    if count:
        noise, power, response = noise / count, power / count, response / count
        out["noise_rms"] = [float(v) for v in np.sqrt(noise)]
        out["response_rms"] = [float(v) for v in np.sqrt(response)]
        ceiling = 100 * (1 - np.sqrt(noise / np.maximum(power, 1e-300)))
        out["fit_ceiling_percent"] = float(np.mean(ceiling))
    return out


def _scaled(c):
    share = c.get("amplitude_share")
    return share is not None and share[1] < SCALED_SHARE


def _amplitude_clause(c):
    share = c["amplitude_share"]
    lo, hi = 100 * share[0], 100 * share[1]
    span = f"{lo:.2g} %" if np.isclose(lo, hi, rtol=0.05) else f"{lo:.2g}-{hi:.2g} %"
    return f"their multisines at {span} of the hysteresis records' amplitude"


def _noise_clause(c, unit):
    noise, resp = max(c["noise_rms"]), max(c["response_rms"])
    return (f"the noise that differs between their periods, {noise:.3g} {unit} RMS, against "
            f"their response, {resp:.3g} {unit} RMS, caps the held-out fit of any model at "
            f"{c['fit_ceiling_percent']:.0f} %")


def records_cause(c, unit="µm"):
    """Why broadband records cannot give G, when measurable: one clause, or None.

    Parameters
    ----------
    c : dict
        :func:`broadband_conditions`.
    unit : str
        Output unit.

    Returns
    -------
    str or None
        A narrow band first (modes above it cannot be identified), then a noise
        that caps the held-out fit below :data:`NOISY_CEILING`, each with the
        option of ``hammerstein excitation`` that helps; None when neither.
    """
    lo, hi = c["band_hz"]
    nyq = c["nyquist_hz"]
    scaled = f" ({_amplitude_clause(c)}, scaled down to a slew rate)" if _scaled(c) else ""
    if hi < NARROW_BAND * nyq:
        names = ", ".join(Path(f).name for f in c.get("files", ()) if f)
        files = f" ({names})" if names else ""
        return (f"the broadband records{files} excite up to {hi:.3g} Hz only, {hi / nyq:.2g} of the "
                f"Nyquist frequency {nyq:.4g} Hz{scaled}: G is flat there, and bending modes "
                f"above it cannot be identified; record multisines up to your first bending "
                f"modes (hammerstein excitation --f-max HZ; with --slew-rate their amplitude "
                f"then drops, docs/records.md), or identify without --dynamics")
    if c["fit_ceiling_percent"] is not None and c["fit_ceiling_percent"] < NOISY_CEILING:
        return (f"{_noise_clause(c, unit)}{scaled}; raise the multisines' signal-to-noise "
                f"ratio (hammerstein excitation --periods N to average more periods, a lower "
                f"--f-max for more amplitude within the slew rate, a quieter sensor)")
    return None


def dynamics_advice(summary, c, unit="µm"):
    """What the measurable causes of a poor held-out fit say, as clauses (may be empty).

    Parameters
    ----------
    summary : dict
        The identified dynamics' summary (``modes``: ``frequency_hz``, ``damping_ratio``).
    c : dict or None
        :func:`broadband_conditions` of the records.
    unit : str
        Output unit.

    Returns
    -------
    list of str
        The noise ceiling when below :data:`NOISY_CEILING`; the first resonant mode when
        above :data:`NEAR_NYQUIST` of the Nyquist frequency; records at
        :data:`FAST_RECORDS_HZ` or faster whose band reaches beyond :data:`SPREAD_BAND`
        times the highest mode; the amplifier's limits only when none of these shows and
        the multisines were not scaled down to a slew rate.
    """
    if c is None:
        return []
    out = []
    cause = records_cause(c, unit)
    if cause:
        out.append(cause)
    nyq = c["nyquist_hz"]
    modes = [m for m in (summary or {}).get("modes", []) if m["damping_ratio"] < 0.7]
    if modes and modes[0]["frequency_hz"] > NEAR_NYQUIST * nyq:
        f = modes[0]["frequency_hz"]
        out.append(f"the first identified mode, {f:.4g} Hz, sits at {f / nyq:.2g} of the Nyquist "
                   f"frequency {nyq:.4g} Hz ({2 * nyq / f:.2g} samples per period): a fraction "
                   f"of a sample of delay turns its phase by tens of degrees, and modes above "
                   f"Nyquist fold next to it unless the sensor filters them; sample faster (5 or "
                   f"more samples per period of the first mode) or low-pass the sensor")
    band = c.get("band_hz")
    if modes and band is not None and 2 * nyq >= FAST_RECORDS_HZ:
        top = max(m["frequency_hz"] for m in modes)
        if band[1] > SPREAD_BAND * top:
            out.append(f"the multisines spread their power up to {band[1]:.4g} Hz, "
                       f"{band[1] / top:.2g} times the highest mode ({top:.4g} Hz): at "
                       f"{2 * nyq / 1e3:.3g} kHz little of it excites the modes; record the "
                       f"multisines at --sampling-period 1e-4, or with --f-max a few times the "
                       f"highest mode (docs/records.md)")
    if not _scaled(c) and not out:
        out.append("the records may not hold what the actuator received (an amplifier slower "
                   "than the multisines, or one that clipped them); record again within the "
                   "amplifier's limits (hammerstein excitation --slew-rate, docs/records.md)")
    return out
